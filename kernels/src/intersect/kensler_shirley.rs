//! The Kensler–Shirley ray × triangle test, the baseline: Andrew Kensler and Peter Shirley,
//! *Optimizing Ray-Triangle Intersection via Automated Search*, IEEE Symposium on Interactive
//! Ray Tracing (RT06), 2006.
//!
//! Per triangle ([`KsTriangle`]): `e0 = p1 − p0`, `e1 = p0 − p2`, `n = e0 × e1`. Per ray, with
//! `c = p0 − o`:
//!
//! ```text
//! r = 1 / (n · d)      t = (n · c) · r
//! w = c × d            u = (w · e1) · r      v = (w · e0) · r
//! ```
//!
//! **Which barycentric is which.** Write the hit as `o + t·d = p0 + u·(p1 − p0) + v·(p2 − p0)
//! = p0 + u·e0 − v·e1`, i.e. `t·d − c = u·e0 − v·e1`. Dotting with `n` kills both edges:
//! `t = (n·c)/(n·d)`. Dotting with `d × e1` kills `d` and `e1`: `−c·(d × e1) = u·e0·(d × e1)`;
//! with the triple products `c·(d × e1) = (c × d)·e1 = w·e1` and `e0·(d × e1) = −(n·d)` this is
//! `u = (w·e1)/(n·d)`. Dotting with `d × e0` likewise gives `v = (w·e0)/(n·d)`. So RT06's `u` is
//! the weight of `p1` and `v` the weight of `p2`, as [`TriangleHit`] wants: no sign to fix.
//!
//! **A ray in the triangle's plane misses it.** There `n · d` is zero but for rounding, and
//! `t`, `u` and `v` are quotients of rounding noise: a ray along an edge shared by two
//! triangles can "hit" one at its origin, a whole edge length away from it. Such a hit lies
//! nowhere near its triangle, which would break every culling stage's argument (the hit point
//! is in the triangle's box, cell and frustum). So a hit also needs `|n · d|` above the bound
//! on its rounding error, [`PLANE_EPS`]` · ‖e0‖₁‖e1‖₁‖d‖₁`: with `n` itself rounded from
//! `e0 × e1` and `e0`, `e1` from the vertices, the computed `n · d` is off by at most about
//! `7ε · ‖e0‖₁‖e1‖₁‖d‖∞` (`ε = 2⁻²⁴`), so below the bound not even its sign is known. For a
//! well-shaped triangle that refuses incidence angles below about 10⁻⁶ radians; the bound is
//! evaluated only when some lane hits.
//!
//! Edge cases: a degenerate triangle has `n = 0` (exactly, when two vertices are equal), so
//! `r = ±inf` and `t = 0·inf = NaN`; a ray parallel to the plane has `r = ±inf` and then `u` or
//! `v` is `±inf` or NaN. Every accepting comparison is written so that NaN fails it, and
//! `u, v >= 0, u + v <= 1` rejects infinities, so neither ever hits. No FMA: with [`Scalar`]
//! lanes, [`intersect_lanes`] equals [`intersect`] bit for bit, and so does every lane of every
//! ISA.
//!
//! [`Scalar`]: crate::lanes::Scalar

use super::{cross3, dot3, l1, splat3, sub3, LaneHits, LaneRays, TriangleHit};
use crate::beam::load_vertex;
use crate::lanes::{LaneF32, LaneMask, Lanes};
use crate::ray::Ray;
use crate::triangle::{KsTriangle, TriangleBlock, BLOCK};
use glam::Vec3;

/// `8ε` (`ε = 2⁻²⁴`, the unit roundoff of `f32`): `|n · d|` at or below `PLANE_EPS ·
/// ‖e0‖₁‖e1‖₁‖d‖₁` is rounding noise, and the ray is taken to lie in the triangle's plane.
pub const PLANE_EPS: f32 = 1.0 / 2_097_152.0;

/// The triangle's part of the bound on `n · d`'s rounding error: `‖e0‖₁‖e1‖₁ ·`
/// [`PLANE_EPS`].
#[inline(always)]
fn plane_scale<F: LaneF32>(e0: [F; 3], e1: [F; 3], eps: F) -> F {
    l1(e0) * l1(e1) * eps
}

/// Is `den = n · d` clear of its rounding error (`scale` from [`plane_scale`], `l1d = ‖d‖₁`),
/// i.e. is the ray off the triangle's plane? False for NaN or infinite operands.
#[inline(always)]
fn off_plane<F: LaneF32>(den: F, scale: F, l1d: F) -> F::Mask {
    den.abs().gt(scale * l1d)
}

/// Kensler–Shirley test of one ray against one triangle.
///
/// Returns the hit when `tmin <= t <= tmax`, `u >= 0`, `v >= 0` and `u + v <= 1` (all inclusive:
/// a ray through an edge or vertex hits, possibly both triangles sharing it, and may also miss
/// both after rounding; use the watertight test where that matters). `ray.tmin`/`ray.tmax` are
/// ignored in favour of the arguments. Degenerate triangles (`n = 0`) and NaN rays never hit.
#[inline(always)]
#[must_use]
pub fn intersect(ray: &Ray, tri: &KsTriangle, tmin: f32, tmax: f32) -> Option<TriangleHit> {
    let d = ray.direction.to_array();
    let n = tri.n.to_array();
    let c = sub3(tri.p0.to_array(), ray.origin.to_array());
    let den = dot3(n, d);
    let r = 1.0 / den;
    let t = dot3(n, c) * r;
    if !(t >= tmin && t <= tmax) {
        return None;
    }
    let (e0, e1) = (tri.e0.to_array(), tri.e1.to_array());
    let w = cross3(c, d);
    let u = dot3(w, e1) * r;
    let v = dot3(w, e0) * r;
    (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && off_plane(den, plane_scale(e0, e1, PLANE_EPS), l1(d)))
        .then_some(TriangleHit { t, u, v })
}

/// Kensler–Shirley test of `WIDTH` rays against one triangle, with per-lane `[tmin, tmax]`.
///
/// Lane `i` of the result is what [`intersect`] returns for ray `i`, bit for bit (the same
/// operations in the same order, no FMA).
#[inline(always)]
pub fn intersect_lanes<L: Lanes>(
    l: L,
    rays: &LaneRays<L>,
    tri: &KsTriangle,
    tmin: L::F32,
    tmax: L::F32,
) -> LaneHits<L> {
    let (n, e0, e1) = (splat3(l, tri.n), splat3(l, tri.e0), splat3(l, tri.e1));
    let c = sub3(splat3(l, tri.p0), rays.origin);
    let den = dot3(n, rays.direction);
    let r = l.splat(1.0) / den;
    let t = dot3(n, c) * r;
    let w = cross3(c, rays.direction);
    let u = dot3(w, e1) * r;
    let v = dot3(w, e0) * r;
    let zero = l.splat(0.0);
    let mut mask = t.ge(tmin) & t.le(tmax) & u.ge(zero) & v.ge(zero) & (u + v).le(l.splat(1.0));
    if mask.any() {
        let scale = plane_scale(tri.e0.to_array(), tri.e1.to_array(), PLANE_EPS);
        mask = mask & off_plane(den, l.splat(scale), rays.direction_l1);
    }
    LaneHits { mask, t, u, v }
}

/// Kensler–Shirley test of one ray against the `WIDTH` triangles `first..first + WIDTH` of
/// `block` (`first` a multiple of `WIDTH`), one triangle per lane, hits in `[tmin, tmax]`.
///
/// Lane `i` of the result is what [`intersect`] returns for triangle `first + i` in its
/// [`KsTriangle`] form (computed from the block's vertices as [`KsTriangle::from`] does), bit
/// for bit: the same operations, no FMA.
/// The block's point-triangle padding never hits (`n = 0`, NaN `t`). Panics if
/// `first + WIDTH > BLOCK`.
///
/// ```
/// use kdbeam_kernels::intersect::kensler_shirley::intersect_block;
/// use kdbeam_kernels::{LaneMask, Lanes, Ray, Triangle, TriangleBlock, Vec3};
/// use kdbeam_kernels::lanes::Scalar;
///
/// let tri = Triangle::new(Vec3::new(-1.0, -1.0, 2.0), Vec3::new(1.0, -1.0, 2.0), Vec3::new(0.0, 1.0, 2.0));
/// let mut block = TriangleBlock::padding(tri.v0);
/// block.set(0, &tri, 0);
/// let ray = Ray::new(Vec3::ZERO, Vec3::Z);
/// let l = Scalar;
/// assert!(intersect_block(l, &ray, &block, 0, 0.0, f32::INFINITY).mask.any());
/// assert!(intersect_block(l, &ray, &block, 1, 0.0, f32::INFINITY).mask.none());
/// ```
#[inline(always)]
pub fn intersect_block<L: Lanes>(
    l: L,
    ray: &Ray,
    block: &TriangleBlock,
    first: usize,
    tmin: f32,
    tmax: f32,
) -> LaneHits<L> {
    let p0 = load_vertex(l, &block.v[0], first);
    let [e0, e1, n] = ks_lanes(l, block, first);
    let d = splat3(l, ray.direction);
    let c = sub3(p0, splat3(l, ray.origin));
    let den = dot3(n, d);
    let r = l.splat(1.0) / den;
    let t = dot3(n, c) * r;
    let w = cross3(c, d);
    let u = dot3(w, e1) * r;
    let v = dot3(w, e0) * r;
    let zero = l.splat(0.0);
    let mut mask = t.ge(l.splat(tmin))
        & t.le(l.splat(tmax))
        & u.ge(zero)
        & v.ge(zero)
        & (u + v).le(l.splat(1.0));
    if mask.any() {
        let scale = plane_scale(e0, e1, l.splat(PLANE_EPS));
        mask = mask & off_plane(den, scale, l.splat(l1(ray.direction.to_array())));
    }
    LaneHits { mask, t, u, v }
}

/// `[e0, e1, n]` of lanes `first..first + WIDTH` of `block`: [`KsTriangle::from`]'s
/// operations, lane by lane, so each lane equals it bit for bit.
#[inline(always)]
fn ks_lanes<L: Lanes>(l: L, block: &TriangleBlock, first: usize) -> [[L::F32; 3]; 3] {
    let (p0, p1, p2) = (
        load_vertex(l, &block.v[0], first),
        load_vertex(l, &block.v[1], first),
        load_vertex(l, &block.v[2], first),
    );
    let (e0, e1) = (sub3(p1, p0), sub3(p0, p2));
    [e0, e1, cross3(e0, e1)]
}

/// A [`TriangleBlock`]'s triangles in Kensler–Shirley form: `[e0, e1, n][axis][lane]`.
///
/// Blocks store only vertices; a packet tests each triangle against several groups of rays,
/// so it computes this once per block in lanes, rather than per triangle and group.
///
/// ```
/// use kdbeam_kernels::intersect::kensler_shirley::KsBlock;
/// use kdbeam_kernels::lanes::Scalar;
/// use kdbeam_kernels::{KsTriangle, Triangle, TriangleBlock, Vec3};
///
/// let t = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
/// let mut block = TriangleBlock::padding(t.v0);
/// block.set(3, &t, 0);
/// let ks = KsBlock::new(Scalar, &block);
/// assert_eq!(ks.triangle(&block, 3), KsTriangle::from(&t));
/// assert_eq!(ks.triangle(&block, 0).n, Vec3::ZERO);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct KsBlock {
    e: [[[f32; BLOCK]; 3]; 3],
}

impl KsBlock {
    /// The Kensler–Shirley form of every lane of `block`.
    #[inline(always)]
    #[must_use]
    pub fn new<L: Lanes>(l: L, block: &TriangleBlock) -> Self {
        let mut e = [[[0.0; BLOCK]; 3]; 3];
        for first in (0..BLOCK).step_by(L::WIDTH) {
            for (k, vector) in ks_lanes(l, block, first).into_iter().enumerate() {
                for (a, lanes) in vector.into_iter().enumerate() {
                    l.store(lanes, &mut e[k][a][first..]);
                }
            }
        }
        KsBlock { e }
    }

    /// Triangle `i` of `block` (the block this was made from). Panics if `i >= BLOCK`.
    #[inline(always)]
    #[must_use]
    pub fn triangle(&self, block: &TriangleBlock, i: usize) -> KsTriangle {
        let vector = |k: &[[f32; BLOCK]; 3]| Vec3::new(k[0][i], k[1][i], k[2][i]);
        KsTriangle {
            p0: vector(&block.v[0]),
            e0: vector(&self.e[0]),
            e1: vector(&self.e[1]),
            n: vector(&self.e[2]),
        }
    }
}

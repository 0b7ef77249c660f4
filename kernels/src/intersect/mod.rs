//! Ray × triangle tests: Kensler–Shirley (the baseline), watertight (Woop, Benthin & Wald), and
//! the watertight test in `f64` as an oracle.
//!
//! Every test accepts a hit on the **closed** interval `tmin <= t <= tmax`; callers break ties
//! between triangles with [`Hit::is_beaten_by`](crate::Hit::is_beaten_by). Triangles with two
//! equal vertices or a non-finite vertex, rays with a NaN, infinite or zero direction and rays
//! with a non-finite origin never hit, and nothing panics.
//!
//! Three *distinct* collinear vertices are another matter: each test sees them through its own
//! roundings (Kensler–Shirley's edge differences, the watertight shear), which can leave a sliver
//! about one ulp wide that a ray aimed exactly at the segment may hit (with the watertight test,
//! some rays aimed at collinear triangles with small integer coordinates do; Kensler–Shirley
//! computes `n = 0` exactly there and never hits). Zero-area triangles belong in mesh validation.
//!
//! Each test has a single-ray form and a lane form generic over [`Lanes`]; the two share their
//! arithmetic (the helpers below), so that with the same inputs every lane of the lane form
//! computes bit for bit what the single-ray form does.

use glam::Vec3;

use crate::lanes::{LaneF32, Lanes};

pub mod kensler_shirley;
pub mod oracle;
pub mod watertight;

/// Where a ray meets a triangle: `t` along the ray, barycentrics `u` (weight of `v1`) and `v`
/// (weight of `v2`); the point is `(1 − u − v)·v0 + u·v1 + v·v2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter of the hit, in `[tmin, tmax]`.
    pub t: f32,
    /// Barycentric weight of `v1`, `>= 0`.
    pub u: f32,
    /// Barycentric weight of `v2`, `>= 0`; `u + v <= 1` up to one rounding.
    pub v: f32,
}

/// `WIDTH` rays in structure-of-arrays form: lane `i` of `origin[k]` is component `k` of ray `i`'s
/// origin.
#[derive(Clone, Copy, Debug)]
pub struct LaneRays<L: Lanes> {
    /// Origins, per axis.
    pub origin: [L::F32; 3],
    /// Directions (any length), per axis.
    pub direction: [L::F32; 3],
    /// `‖direction‖₁ = |d.x| + |d.y| + |d.z|`, summed left to right: the rays' part of
    /// Kensler–Shirley's bound on the rounding of `n · d`. [`LaneRays::new`] computes it; a
    /// value that is not `direction`'s would make the lane form disagree with the single-ray
    /// form on rays near a triangle's plane.
    pub direction_l1: L::F32,
}

impl<L: Lanes> LaneRays<L> {
    /// The rays with these origins and directions.
    #[inline(always)]
    pub fn new(origin: [L::F32; 3], direction: [L::F32; 3]) -> Self {
        LaneRays {
            origin,
            direction,
            direction_l1: l1(direction),
        }
    }

    /// The origin of lane `i`. Panics if `i >= L::WIDTH`.
    #[inline(always)]
    pub fn origin(&self, i: usize) -> Vec3 {
        Vec3::from_array(self.origin.map(|c| c.extract(i)))
    }

    /// The direction of lane `i`. Panics if `i >= L::WIDTH`.
    #[inline(always)]
    pub fn direction(&self, i: usize) -> Vec3 {
        Vec3::from_array(self.direction.map(|c| c.extract(i)))
    }
}

/// The hits of `WIDTH` rays against one triangle: lane `i` of `mask` says whether ray `i` hit.
///
/// `t`, `u` and `v` mean what [`TriangleHit`]'s fields mean in the lanes set in `mask`; in the
/// other lanes they are unspecified (often NaN).
#[derive(Clone, Copy, Debug)]
pub struct LaneHits<L: Lanes> {
    /// Which lanes hit.
    pub mask: L::Mask,
    /// Ray parameters.
    pub t: L::F32,
    /// Barycentric weights of `v1`.
    pub u: L::F32,
    /// Barycentric weights of `v2`.
    pub v: L::F32,
}

/// `‖a‖₁ = |a0| + |a1| + |a2|`, summed left to right.
#[inline(always)]
pub(crate) fn l1<F: LaneF32>(a: [F; 3]) -> F {
    a[0].abs() + a[1].abs() + a[2].abs()
}

/// `a · b`, summed as `(a0·b0 + a1·b1) + a2·b2`, never fused.
#[inline(always)]
pub(crate) fn dot3<F: LaneF32>(a: [F; 3], b: [F; 3]) -> F {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `a × b`, each component `a_i·b_j − a_j·b_i`, never fused.
#[inline(always)]
pub(crate) fn cross3<F: LaneF32>(a: [F; 3], b: [F; 3]) -> [F; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// `a − b` per component.
#[inline(always)]
pub(crate) fn sub3<F: LaneF32>(a: [F; 3], b: [F; 3]) -> [F; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `v` broadcast to every lane, per component.
#[inline(always)]
pub(crate) fn splat3<L: Lanes>(l: L, v: Vec3) -> [L::F32; 3] {
    [l.splat(v.x), l.splat(v.y), l.splat(v.z)]
}

//! The watertight ray × triangle test of Woop, Benthin & Wald ("Watertight Ray/Triangle
//! Intersection", JCGT 2(1), 2013).
//!
//! Per ray: `kz` is the axis of the largest `|d|`, `kx = kz + 1`, `ky = kz + 2` (mod 3), swapped
//! when `d[kz] < 0` so that the winding is kept; the shear `S = (d[kx]/d[kz], d[ky]/d[kz],
//! 1/d[kz])` maps the ray onto the `+z` axis from the origin. Per vertex `p` (paper §3, Fig. 2):
//! `A = p − o` permuted to `(kx, ky, kz)`, then `x = A[kx] − Sx·A[kz]`, `y = A[ky] − Sy·A[kz]`,
//! `z = Sz·A[kz]`. The 2D edge functions of the sheared vertices `A, B, C`
//!
//! ```text
//! U = Cx·By − Cy·Bx      V = Ax·Cy − Ay·Cx      W = Bx·Ay − By·Ax
//! ```
//!
//! are twice the signed areas of the triangles the origin forms with each edge. The ray hits when
//! `U, V, W` have one sign (zero counts as either: edges and vertices hit, both triangles of a
//! shared edge may report it) and `det = U + V + W ≠ 0`; then `T = U·Az + V·Bz + W·Cz` and
//! `t = T / det`, `u = V / det` (weight of `v1`), `v = W / det` (weight of `v2`).
//!
//! **Why no ray leaks.** A vertex's sheared coordinates depend only on the vertex and the ray, so
//! two triangles sharing an edge compute the same `(x, y)` for its end points, and its edge
//! function in one triangle is `fl(fl(px·qy) − fl(py·qx))`, in the other `fl(fl(qx·py) −
//! fl(qy·px))`: exact negatives (products commute, `fl(a − b) = −fl(b − a)`). The origin is
//! therefore never strictly outside both. This needs **plain** products: an FMA would round one
//! product but not the other, and break the symmetry, so none is used here. When an edge
//! function is exactly zero its sign is unreliable; the paper then recomputes `U, V, W` in `f64`
//! (§3: the products of two `f32` are exact in `f64`, so only the subtraction rounds, again
//! antisymmetrically).
//!
//! **Distance.** The paper compares `±T` with `tmax·|det|` before dividing, to skip the division
//! for hits beyond the current one. That compare rounds differently from the returned
//! `t = T·(1/det)`, so it can reject a hit whose returned `t` equals `tmax`, and then which of two
//! triangles at the same `t` wins would depend on the order they are tested in (callers break
//! ties by triangle id and need `t == tmax` accepted). Here the acceptance test is therefore
//! `tmin <= t <= tmax` on the returned `t` itself; the division is only reached by rays that
//! already passed the edge tests, so skipping it would save little.
//!
//! Edge cases: a triangle with two equal vertices has two equal sheared vertices, so its edge
//! functions cancel exactly, `det = 0`, and it never hits (three distinct collinear vertices are
//! not caught: the shear's rounding can make them a thin sliver). NaN in the ray or in a vertex makes an
//! edge function NaN; every accepting comparison is written so that NaN fails it. A zero
//! direction gives `Sx = 0/0 = NaN` and never hits. A direction with an infinite component names no
//! point at a finite `t > 0` (the shear would flatten it to `t = 0`): the prepared ray gets a NaN
//! origin and never hits.

use glam::Vec3;

use super::{dot3, splat3, LaneHits, LaneRays, TriangleHit};
use crate::lanes::{LaneF32, LaneMask, Lanes};
use crate::ray::Ray;
use crate::triangle::{Triangle, TriangleBlock, BLOCK};

/// A ray prepared for the watertight test: its axis permutation and shear.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WatertightRay {
    /// `(kx, ky, kz)`.
    axes: [usize; 3],
    /// The origin, permuted to `(kx, ky, kz)` (NaN for a direction with an infinite component).
    origin: [f32; 3],
    /// `(Sx, Sy, Sz)`.
    shear: [f32; 3],
}

/// The axis of the largest of `a` (component-wise absolute direction); ties go to the later axis.
/// Written as comparisons so that [`WatertightLanes::new`] makes the same choice per lane.
#[inline(always)]
fn dominant_axis(a: [f32; 3]) -> usize {
    if a[0] > a[1] {
        if a[0] > a[2] {
            0
        } else {
            2
        }
    } else if a[1] > a[2] {
        1
    } else {
        2
    }
}

/// `(d[kx]/d[kz], d[ky]/d[kz], 1/d[kz])` for a direction `d` permuted to `(kx, ky, kz)`.
#[inline(always)]
fn shear_of<F: LaneF32>(d: [F; 3], one: F) -> [F; 3] {
    [d[0] / d[2], d[1] / d[2], one / d[2]]
}

/// A vertex relative to the origin, permuted to `(kx, ky, kz)`, sheared: `(x, y, z)`.
#[inline(always)]
fn shear_vertex<F: LaneF32>(a: [F; 3], s: &[F; 3]) -> [F; 3] {
    [a[0] - s[0] * a[2], a[1] - s[1] * a[2], s[2] * a[2]]
}

/// `(U, V, W)` of sheared vertices `a, b, c`, in plain (unfused) `f32` products.
#[inline(always)]
fn edge_functions<F: LaneF32>(a: &[F; 3], b: &[F; 3], c: &[F; 3]) -> [F; 3] {
    [
        c[0] * b[1] - c[1] * b[0],
        a[0] * c[1] - a[1] * c[0],
        b[0] * a[1] - b[1] * a[0],
    ]
}

/// [`edge_functions`] in `f64` (exact products, one rounding), rounded back to `f32`.
#[inline(never)]
fn edge_functions_f64(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> [f32; 3] {
    let edge = |p: [f32; 2], q: [f32; 2]| {
        (f64::from(p[0]) * f64::from(q[1]) - f64::from(p[1]) * f64::from(q[0])) as f32
    };
    [edge(c, b), edge(a, c), edge(b, a)]
}

impl WatertightRay {
    /// Prepares `ray` (its `tmin`/`tmax` are not used: [`WatertightRay::intersect`] takes them).
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction.to_array();
        let kz = dominant_axis(d.map(LaneF32::abs));
        let (kx, ky) = if d[kz] < 0.0 {
            ((kz + 2) % 3, (kz + 1) % 3)
        } else {
            ((kz + 1) % 3, (kz + 2) % 3)
        };
        let axes = [kx, ky, kz];
        let finite = LaneF32::abs(d[kz]) < f32::INFINITY;
        WatertightRay {
            axes,
            origin: axes.map(|k| if finite { ray.origin[k] } else { f32::NAN }),
            shear: shear_of(axes.map(|k| d[k]), 1.0),
        }
    }

    /// `p − o` permuted to `(kx, ky, kz)`, sheared.
    #[inline(always)]
    fn project(&self, p: Vec3) -> [f32; 3] {
        // Written out, not `array::map`, whose closure stays out of line.
        let [kx, ky, kz] = self.axes;
        let a = [
            p[kx] - self.origin[0],
            p[ky] - self.origin[1],
            p[kz] - self.origin[2],
        ];
        shear_vertex(a, &self.shear)
    }

    /// Watertight test against `tri`: the hit if the ray meets it with `tmin <= t <= tmax`.
    ///
    /// Edges and vertices count as inside (a ray through a shared edge may hit both triangles;
    /// it never misses both). Both windings hit. Triangles with two equal vertices and rays with
    /// NaN never hit (collinear distinct vertices: see the [module](super) documentation).
    #[inline(always)]
    #[must_use]
    pub fn intersect(&self, tri: &Triangle, tmin: f32, tmax: f32) -> Option<TriangleHit> {
        let [a, b, c] = [
            self.project(tri.v0),
            self.project(tri.v1),
            self.project(tri.v2),
        ];
        let mut e = edge_functions(&a, &b, &c);
        if e.contains(&0.0) {
            e = edge_functions_f64([a[0], a[1]], [b[0], b[1]], [c[0], c[1]]);
        }
        let [eu, ev, ew] = e;
        let inside = (eu >= 0.0 && ev >= 0.0 && ew >= 0.0) || (eu <= 0.0 && ev <= 0.0 && ew <= 0.0);
        let det = eu + ev + ew;
        if !inside || det == 0.0 {
            return None;
        }
        let rcp = 1.0 / det;
        let t = dot3(e, [a[2], b[2], c[2]]) * rcp;
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        Some(TriangleHit {
            t,
            u: ev * rcp,
            v: ew * rcp,
        })
    }
}

impl WatertightRay {
    /// Watertight test of this ray against the `WIDTH` triangles `first..first + WIDTH` of
    /// `block` (`first` a multiple of `WIDTH`), one triangle per lane, hits in `[tmin, tmax]`;
    /// only the lanes of `valid` (bit `i`: triangle `first + i`) may hit.
    ///
    /// Lane `i` of the result is what [`WatertightRay::intersect`] returns for triangle
    /// `first + i`, bit for bit (the same projection, edge functions and `f64` fallback, no
    /// FMA). Lanes outside `valid` (a leaf's padding) are left out before the fallback, which
    /// they would otherwise always take (a point triangle's edge functions are 0).
    /// Panics if `first + WIDTH > BLOCK`.
    #[inline(always)]
    pub fn intersect_block<L: Lanes>(
        &self,
        l: L,
        block: &TriangleBlock,
        first: usize,
        valid: u32,
        (tmin, tmax): (f32, f32),
    ) -> LaneHits<L> {
        let origin = [
            l.splat(self.origin[0]),
            l.splat(self.origin[1]),
            l.splat(self.origin[2]),
        ];
        let shear = [
            l.splat(self.shear[0]),
            l.splat(self.shear[1]),
            l.splat(self.shear[2]),
        ];
        let axes = self.axes;
        let sheared = [
            project_lanes(l, &block.v[0], first, axes, &origin, &shear),
            project_lanes(l, &block.v[1], first, axes, &origin, &shear),
            project_lanes(l, &block.v[2], first, axes, &origin, &shear),
        ];
        let t_range = (l.splat(tmin), l.splat(tmax));
        sheared_hits(l, sheared, l.mask_from_bits(valid), t_range)
    }
}

/// Per lane, which axis an index (`kx`, `ky` or `kz`) names: `x`, `y`, or (neither) `z`.
#[derive(Clone, Copy, Debug)]
struct LaneAxis<L: Lanes> {
    is_x: L::Mask,
    is_y: L::Mask,
}

impl<L: Lanes> LaneAxis<L> {
    /// Per lane, the component of `v` this axis names.
    #[inline(always)]
    fn pick(&self, v: [L::F32; 3]) -> L::F32 {
        L::F32::select(self.is_x, v[0], L::F32::select(self.is_y, v[1], v[2]))
    }

    /// Per lane, `if m { a } else { b }`.
    #[inline(always)]
    fn choose(m: L::Mask, a: Self, b: Self) -> Self {
        LaneAxis {
            is_x: (m & a.is_x) | b.is_x.and_not(m),
            is_y: (m & a.is_y) | b.is_y.and_not(m),
        }
    }
}

/// `WIDTH` rays prepared for the watertight test; each lane has its own axis permutation.
#[derive(Clone, Copy, Debug)]
pub struct WatertightLanes<L: Lanes> {
    /// `(kx, ky, kz)` per lane.
    axes: [LaneAxis<L>; 3],
    /// The origins, permuted per lane (NaN in lanes whose direction has an infinite component).
    origin: [L::F32; 3],
    /// `(Sx, Sy, Sz)` per lane.
    shear: [L::F32; 3],
}

impl<L: Lanes> WatertightLanes<L> {
    /// Prepares `rays`; lane `i` makes the choices [`WatertightRay::new`] makes for ray `i`.
    #[inline(always)]
    pub fn new(l: L, rays: &LaneRays<L>) -> Self {
        let a = [
            rays.direction[0].abs(),
            rays.direction[1].abs(),
            rays.direction[2].abs(),
        ];
        // `dominant_axis` as masks: x when |dx| > |dy| and |dx| > |dz|, y when |dy| >= |dx| and
        // |dy| > |dz|, z otherwise.
        let x_over_y = a[0].gt(a[1]);
        let z_is_x = x_over_y & a[0].gt(a[2]);
        let z_is_y = a[1].gt(a[2]).and_not(x_over_y);
        let z_is_z = !(z_is_x | z_is_y);
        let kz = LaneAxis::<L> {
            is_x: z_is_x,
            is_y: z_is_y,
        };
        let next = LaneAxis::<L> {
            is_x: z_is_z,
            is_y: z_is_x,
        };
        let after_next = LaneAxis::<L> {
            is_x: z_is_y,
            is_y: z_is_z,
        };
        let flip = kz.pick(rays.direction).lt(l.splat(0.0));
        let axes = [
            LaneAxis::choose(flip, after_next, next),
            LaneAxis::choose(flip, next, after_next),
            kz,
        ];
        let finite = kz.pick(a).lt(l.splat(f32::INFINITY));
        let nan = l.splat(f32::NAN);
        let origin = |k: &LaneAxis<L>| L::F32::select(finite, k.pick(rays.origin), nan);
        let [kx, ky, kz] = &axes;
        WatertightLanes {
            axes,
            origin: [origin(kx), origin(ky), origin(kz)],
            shear: shear_of(
                [
                    kx.pick(rays.direction),
                    ky.pick(rays.direction),
                    kz.pick(rays.direction),
                ],
                l.splat(1.0),
            ),
        }
    }

    /// `p − o` permuted per lane, sheared.
    #[inline(always)]
    fn project(&self, l: L, p: Vec3) -> [L::F32; 3] {
        let p = splat3(l, p);
        let ([kx, ky, kz], [ox, oy, oz]) = (&self.axes, self.origin);
        let a = [kx.pick(p) - ox, ky.pick(p) - oy, kz.pick(p) - oz];
        shear_vertex(a, &self.shear)
    }

    /// Watertight test of every lane against `tri`, with per-lane `[tmin, tmax]`.
    ///
    /// Lane `i` of the result is what [`WatertightRay::intersect`] returns for ray `i`, bit for bit
    /// (same operations, no FMA). Lanes with an exactly zero edge function take the `f64` edge
    /// functions one by one (rare: the origin projects exactly onto an edge line).
    #[inline(always)]
    pub fn intersect(&self, l: L, tri: &Triangle, tmin: L::F32, tmax: L::F32) -> LaneHits<L> {
        let [a, b, c] = [
            self.project(l, tri.v0),
            self.project(l, tri.v1),
            self.project(l, tri.v2),
        ];
        sheared_hits(l, [a, b, c], !l.mask_from_bits(0), (tmin, tmax))
    }
}

/// Lanes `first..first + WIDTH` of a block's vertex `v` (`[axis][lane]`) minus `origin`,
/// permuted to `axes`, sheared: [`WatertightRay::project`] per lane.
#[inline(always)]
fn project_lanes<L: Lanes>(
    l: L,
    v: &[[f32; BLOCK]; 3],
    first: usize,
    [kx, ky, kz]: [usize; 3],
    origin: &[L::F32; 3],
    shear: &[L::F32; 3],
) -> [L::F32; 3] {
    let a = [
        l.load(&v[kx][first..]) - origin[0],
        l.load(&v[ky][first..]) - origin[1],
        l.load(&v[kz][first..]) - origin[2],
    ];
    shear_vertex(a, shear)
}

/// The watertight verdict, per lane, on the sheared vertices `a, b, c` (the tail of
/// [`WatertightRay::intersect`], lane for lane): edge functions, the `f64` ones in lanes of
/// `lanes` where one is exactly zero, one sign and `det != 0`, `tmin <= t <= tmax`; only lanes
/// of `lanes` may hit.
#[inline(always)]
fn sheared_hits<L: Lanes>(
    l: L,
    [a, b, c]: [[L::F32; 3]; 3],
    lanes: L::Mask,
    (tmin, tmax): (L::F32, L::F32),
) -> LaneHits<L> {
    let zero = l.splat(0.0);
    let mut e = edge_functions(&a, &b, &c);
    let on_edge = (e[0].eq(zero) | e[1].eq(zero) | e[2].eq(zero)) & lanes;
    if on_edge.any() {
        e = edge_functions_f64_lanes(l, on_edge, [&a, &b, &c], e);
    }
    let [eu, ev, ew] = e;
    let nonneg = eu.ge(zero) & ev.ge(zero) & ew.ge(zero);
    let nonpos = eu.le(zero) & ev.le(zero) & ew.le(zero);
    let det = eu + ev + ew;
    let rcp = l.splat(1.0) / det;
    let t = dot3(e, [a[2], b[2], c[2]]) * rcp;
    let mask = (nonneg | nonpos).and_not(det.eq(zero)) & t.ge(tmin) & t.le(tmax) & lanes;
    LaneHits {
        mask,
        t,
        u: ev * rcp,
        v: ew * rcp,
    }
}

/// `e` with the lanes in `lanes` replaced by [`edge_functions_f64`] of those lanes' vertices.
#[inline(always)]
fn edge_functions_f64_lanes<L: Lanes>(
    l: L,
    lanes: L::Mask,
    [a, b, c]: [&[L::F32; 3]; 3],
    e: [L::F32; 3],
) -> [L::F32; 3] {
    const MAX_WIDTH: usize = 16;
    const { assert!(L::WIDTH <= MAX_WIDTH) };
    let mut out = [[0.0f32; MAX_WIDTH]; 3];
    for (o, v) in out.iter_mut().zip(e) {
        l.store(v, o);
    }
    let mut bits = lanes.bits();
    while bits != 0 {
        let i = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        let xy = |p: &[L::F32; 3]| [p[0].extract(i), p[1].extract(i)];
        let lane = edge_functions_f64(xy(a), xy(b), xy(c));
        for (o, v) in out.iter_mut().zip(lane) {
            o[i] = v;
        }
    }
    let [u, v, w] = &out;
    [l.load(u), l.load(v), l.load(w)]
}

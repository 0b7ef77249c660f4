//! The transient frustum ("beam") of a packet in a leaf: Alexander Reshetov, *Faster Ray
//! Packets – Triangle Intersection through Vertex Culling*, IEEE Symposium on Interactive Ray
//! Tracing (RT07), 2007, section 2.
//!
//! Each time a packet enters a leaf, a frustum is built around the rays it uses ([`Beam::new`]),
//! and every triangle of the leaf is checked against it before any ray is tested
//! ([`Beam::cull`]). The checks are *obligations*: none ever rejects a triangle that the unculled
//! path finds as a ray's closest hit. Each stage states its argument below.
//!
//! # Coordinates
//!
//! Everything is computed in *leaf-local* coordinates `v' = (s·(v[k] − c[k]), v[k1] − c[k1],
//! v[k2] − c[k2])`: `k` is the prevalent axis, `s = ±1` its direction sign (so every ray used
//! moves towards `+x'`), and `c` the leaf box corner where the rays enter. The slab of the leaf
//! on `k` is then `x' ∈ [0, dx]`. Working near the leaf keeps Reshetov's `q0` free of the
//! catastrophic cancellation `x00·z10 − x10·z00` suffers at coordinates like 1e5.
//!
//! # Margins
//!
//! Every bound is moved outwards by `δ = 2⁻¹⁴·max(Λ, B)`, where `Λ` bounds the magnitude of
//! every local quantity the beam is built from (ray origins, crossings, the leaf's extent) and
//! `B` bounds every coordinate of the scene (the caller passes it). The side and distance planes
//! are then moved to world coordinates (the translation folded into their offsets), so a vertex
//! is tested as read, with three fused multiply-adds; every term of that sum is at most a few
//! `B` or `Λ`, so its rounding (a few ulps, ≈ 6·10⁻⁸ each) stays far below `δ`. The aperture
//! test works in local coordinates, adds a barycentric margin and refuses grazing corner rays
//! (see [`Beam::cull`]).

use glam::Vec3;

use crate::aabb::Aabb;
use crate::groups::{group_bits, group_count};
use crate::lanes::{LaneF32, LaneMask, Lanes, MAX_WIDTH};
use crate::packet::{RayPacket, MAX_PACKET_RAYS};
use crate::triangle::{TriangleBlock, BLOCK};

/// Which culling stages a beam runs, beyond the four side planes it always checks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Stages {
    /// The near and far planes (with the side planes: the 6-plane frustum).
    pub distance: bool,
    /// The corner-ray aperture test, and the far plane it finds when all four corner rays hit
    /// one triangle.
    pub aperture: bool,
    /// Run the aperture test before the near/far planes (suits real scenes) instead of after
    /// (suits the Kensler–Shirley synthetic data).
    pub aperture_first: bool,
}

/// Triangles culled by each stage.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CullCounts {
    /// By one of the four side planes (vertex culling).
    pub planes: u32,
    /// By the near or far plane.
    pub distance: u32,
    /// By the corner-ray aperture test.
    pub aperture: u32,
}

/// The outcome of culling a block of up to [`BLOCK`] triangles.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Survivors {
    /// Bit `i` set: triangle `i` must be tested.
    pub mask: u64,
    /// Bit `i` set: every ray the beam was built from crosses triangle `i` inside the leaf
    /// (all four corner rays hit it): its per-ray barycentric checks may be skipped.
    pub inside: u64,
    /// What each stage culled (counted only with the `stats` feature; zero otherwise).
    pub culled: CullCounts,
}

const PLANES: usize = 6;
/// `δ = MARGIN·Λ`.
const MARGIN: f32 = 1.0 / 16384.0;
/// Barycentric margin of the aperture test.
const BARY_EPS: f32 = 1.0 / 4096.0;
/// Corner crossings must lie this far (as a fraction of the slab) inside it.
const SLAB_EPS: f32 = 1.0 / 1024.0;
/// Corner rays must meet the plane at more than asin(1/32) ≈ 1.8°.
const MIN_SIN2: f32 = 1.0 / 1024.0;

/// A transient frustum around some rays of a packet, in one leaf.
#[derive(Clone, Copy, Debug)]
pub struct Beam<L: Lanes> {
    l: L,
    axes: [usize; 3],
    sign: f32,
    corner: Vec3,
    dx: f32,
    /// Plane `p` in world coordinates, `[wx, wy, wz, e]`: `d = x·wx + y·wy + z·wz + e`,
    /// negative outside. Planes 4 and 5 are near and far when they are folded in.
    planes: [[f32; 4]; PLANES],
    /// The x' coefficient of the far plane, to move it in world coordinates.
    far_offset: f32,
    plane_count: usize,
    distance_folded: bool,
    near: f32,
    far: f32,
    margin: f32,
    /// Corner rays `A_j + σ·D_j`, `σ ∈ [0, 1]`, from the corners of the entry rectangle at
    /// `x' = 0` to those of the exit rectangle at `x' = dx` (`A.x' = 0`, `D.x' = dx`).
    corner_a: [[f32; 4]; 2],
    corner_d: [[f32; 4]; 2],
    /// Largest `x'` where a ray used starts, smallest where one ends.
    start_max: f32,
    end_min: f32,
    stages: Stages,
}

impl<L: Lanes> Beam<L> {
    /// The frustum around the rays `used` of `p` in a leaf with (tight) box `leaf`.
    ///
    /// Returns `None` when no axis has a direction component of one non-zero sign for every ray
    /// used (no prevalent axis: the caller tests unculled), when `used` is empty, or when the
    /// box or a ray is not finite. `best_t`, when given, holds each ray's closest hit so far:
    /// if every ray used has one (bit set in `has_hit`), triangles entirely beyond all of them
    /// are culled by the far plane. `scene_bound` bounds the absolute value of every vertex
    /// coordinate of the scene (it sets the margin that covers the rounding of the vertex test).
    ///
    /// **Prevalent axis.** Among axes on which every ray used has a direction component of one
    /// non-zero sign, the one whose smallest `|d|` is largest (Reshetov: the largest prevalent
    /// axis is about 30% faster than the first suitable one); slopes `d_y/d_x` are then bounded.
    ///
    /// **Rectangles.** Where each ray crosses `x' = 0` and `x' = dx`, take `y'` and `z'`; the
    /// rectangles `[y00, y01] × [z00, z01]` and `[y10, y11] × [z10, z11]` bound them. They are
    /// not clamped to the leaf: that would not be conservative. Between the two planes a ray's
    /// `y'` is the linear interpolation of its crossings, so its whole segment in the slab lies
    /// in `F = {x' ∈ [0, dx], ymin(x') ≤ y' ≤ ymax(x'), zmin(x') ≤ z' ≤ zmax(x')}`, the convex
    /// hull of the two rectangles. A flat leaf (`dx = 0`) is widened first (Reshetov: the
    /// expansion costs nothing, since only the flat leaf's own triangles are tested).
    ///
    /// **A summary of the rays.** With `rays`, the [`BeamRays`] of the same rays `used` of `p`,
    /// the crossings come from it in constant time (but for the far plane, which reads each
    /// ray's best hit), for the same frustum up to a few ulps of its bounds. The rays share one
    /// origin `o`, so in leaf-local coordinates every ray crosses `x' = 0` at
    /// `y' = o'_y − o'_x·s_y` and `x' = dx` at `y' = o'_y + (dx − o'_x)·s_y`, its slope
    /// `s_y = d_y/d_x'` the only term that differs between rays. Both are linear in the slope,
    /// so over the rays they are extreme at the smallest and the largest slope. At `x' = 0` the
    /// rounded `o'_y − o'_x·s_y` is monotonic in `s_y`, so its extremes are those found ray by
    /// ray, bit for bit; at `x' = dx` the rounded sum of two terms is not, and can differ from
    /// the ray-by-ray extreme by a few ulps of its magnitude, far below the margin `δ` (2⁻¹⁴ of
    /// it) every bound is widened by. Likewise the starts and ends `o'_x + t·d_x'` are
    /// monotonic in `t·d_x'`, whose extremes the summary keeps.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        l: L,
        p: &RayPacket,
        used: u64,
        rays: Option<&BeamRays>,
        leaf: &Aabb,
        best_t: Option<(&[f32; MAX_PACKET_RAYS], u64)>,
        stages: Stages,
        scene_bound: f32,
    ) -> Option<Self> {
        if used == 0 || !leaf.min.is_finite() || !leaf.max.is_finite() {
            return None;
        }
        let (slab, crossings) = match rays {
            Some(rays) => {
                let slab = Slab::enter(leaf, rays.axes, rays.sign);
                let far = best_t.filter(|&(_, has_hit)| stages.distance && used & !has_hit == 0);
                (slab, Crossings::of_summary(l, rays, p, used, &slab, far))
            }
            None => {
                let (k, sign) = prevalent_axis(l, p, used)?;
                let slab = Slab::enter(leaf, [k, (k + 1) % 3, (k + 2) % 3], sign);
                (slab, Crossings::of_rays(l, p, used, &slab, best_t))
            }
        };
        let (axes, sign, corner, dx) = (slab.axes, slab.sign, slab.corner, slab.dx);
        let lambda = crossings.mag + dx + leaf.extent().max_element();
        let margin = lambda.max(scene_bound) * MARGIN;
        if !(margin.is_finite() && lambda.is_finite()) {
            return None;
        }
        let (y00, y01) = (crossings.y0.0 - margin, crossings.y0.1 + margin);
        let (y10, y11) = (crossings.y1.0 - margin, crossings.y1.1 + margin);
        let (z00, z01) = (crossings.z0.0 - margin, crossings.z0.1 + margin);
        let (z10, z11) = (crossings.z1.0 - margin, crossings.z1.1 + margin);
        let (start_max, end_min) = (crossings.start_max, crossings.end_min);

        // Near: every ray used starts at x' >= near. Far: every ray used already has a hit at
        // x' <= far (only when all of them have one).
        let near = if stages.distance {
            crossings.start_min - margin
        } else {
            f32::NEG_INFINITY
        };
        let far = match best_t {
            Some((_, has_hit)) if stages.distance && used & !has_hit == 0 => {
                crossings.hit_max + margin
            }
            _ => f32::INFINITY,
        };

        // Reshetov's eq. (5): q1 (the x' coefficients) and q0 (the offsets) of the four side
        // planes, in local coordinates where x00 = 0 and x10 = dx, so q0 = [−z00, y01, z01, −y00].
        let inv_dx = 1.0 / dx;
        let mut cx = [0.0f32; PLANES];
        let mut cy = [0.0f32; PLANES];
        let mut cz = [0.0f32; PLANES];
        let mut e = [1.0f32; PLANES];
        for (pl, (qx, qy, qz, q0)) in [
            ((z00 - z10) * inv_dx, 0.0, 1.0, -z00),
            ((y11 - y01) * inv_dx, -1.0, 0.0, y01),
            ((z11 - z01) * inv_dx, 0.0, -1.0, z01),
            ((y00 - y10) * inv_dx, 1.0, 0.0, -y00),
        ]
        .into_iter()
        .enumerate()
        {
            (cx[pl], cy[pl], cz[pl], e[pl]) = (qx, qy, qz, q0);
        }
        let distance_folded = stages.distance && !(stages.aperture && stages.aperture_first);
        if distance_folded {
            (cx[4], e[4]) = (1.0, -near);
            (cx[5], e[5]) = (-1.0, far);
        }
        let plane_count = if distance_folded { PLANES } else { 4 };
        // To world coordinates: x' = s·(v[k] − c.x), y' = v[k1] − c.y, z' = v[k2] − c.z.
        let mut wx = [0.0f32; PLANES];
        let mut wy = [0.0f32; PLANES];
        let mut wz = [0.0f32; PLANES];
        for pl in 0..PLANES {
            let coef = [cx[pl] * sign, cy[pl], cz[pl]];
            e[pl] -= coef[0] * corner.x + coef[1] * corner.y + coef[2] * corner.z;
            let mut world = [0.0f32; 3];
            for (a, c) in axes.iter().zip(coef) {
                world[*a] = c;
            }
            (wx[pl], wy[pl], wz[pl]) = (world[0], world[1], world[2]);
        }
        let mut planes = [[0.0f32; 4]; PLANES];
        for (pl, plane) in planes.iter_mut().enumerate() {
            *plane = [wx[pl], wy[pl], wz[pl], e[pl]];
        }
        let corner_a = [[y00, y01, y01, y00], [z00, z00, z01, z01]];
        let corner_d = [
            [y10 - y00, y11 - y01, y11 - y01, y10 - y00],
            [z10 - z00, z10 - z00, z11 - z01, z11 - z01],
        ];
        Some(Beam {
            l,
            axes,
            sign,
            corner,
            dx,
            planes,
            far_offset: sign * corner.x,
            plane_count,
            distance_folded,
            near,
            far,
            margin,
            corner_a,
            corner_d,
            start_max,
            end_min,
            stages,
        })
    }

    /// The prevalent axis (0, 1, 2 for x, y, z).
    pub fn axis(&self) -> usize {
        self.axes[0]
    }

    /// `v` in leaf-local coordinates.
    #[inline(always)]
    fn local(&self, v: Vec3) -> Vec3 {
        Vec3::new(
            self.sign * (v[self.axes[0]] - self.corner.x),
            v[self.axes[1]] - self.corner.y,
            v[self.axes[2]] - self.corner.z,
        )
    }

    /// Culls the first `count` triangles of `block` against the beam (bit `i` of the result:
    /// triangle `i`); the survivors must be tested. Lanes at or beyond `count` never survive.
    ///
    /// The side planes (and the near and far planes when folded in) are tested a vector of
    /// triangles at a time: one fused multiply-add chain per vertex, plane and `WIDTH`
    /// triangles (Reshetov's vertex culling, on Wald's structure-of-arrays triangle blocks
    /// instead of one triangle per instruction). The same chain, in the same order, as per
    /// triangle, so the verdicts are the same at every width. The survivors then meet the
    /// per-triangle stages in order.
    ///
    /// **Side planes (vertex culling, Reshetov eq. 5).** For a local vertex `v`,
    /// `d = [v_z, −v_y, −v_z, v_y] + v_x·q1 + q0 = [v_z − zmin(v_x), ymax(v_x) − v_y,
    /// zmax(v_x) − v_z, v_y − ymin(v_x)]`. A lane negative for all three vertices puts the whole
    /// triangle (the convex hull of its vertices) outside a half-space that contains `F`, and
    /// every ray used lies in `F` within the slab, where any hit it has in this leaf lies: cull.
    /// A hit the unculled path finds outside this leaf's slab is found again in the leaf that
    /// holds it, which the traversal still enters (it stops only once the closest hit lies
    /// before the next cell).
    ///
    /// **Near and far planes.** Every ray used starts at `x' >= near`, so a triangle entirely
    /// at `x' < near` is behind all of them. Every ray used already has a hit at `x' <= far`
    /// (from its best hit so far, or from an occluder the aperture test proved every ray hits),
    /// so a triangle entirely at `x' > far` can only be hit farther away: cull.
    ///
    /// **Aperture (corner rays).** Only when all four corner rays cross the triangle's plane
    /// strictly inside the slab with one sign of `n·D` (the guard): then the plane
    /// separates the entry rectangle from the exit rectangle, so `F ∩ plane` is exactly the
    /// convex hull of the four crossings (the four corner edges are the only edges of `F` that
    /// cross it), and barycentrics are affine on the plane. If `u < 0` at all four crossings, or
    /// `v < 0`, or `u + v > 1`, no point of `F ∩ plane` is on the triangle: cull. If all four are
    /// inside, every ray used crosses the triangle at `x' <= max crossing`; when, moreover,
    /// every ray used starts before the first crossing and ends after the last, all of them hit
    /// it, and it becomes the far plane for the triangles after it. Grazing corner rays
    /// (`sin < 1/32`) and crossings near the slab's faces fail the guard, and the barycentric
    /// bounds carry a margin of 2⁻¹², so that rounding never decides.
    #[inline(always)]
    pub fn cull(&mut self, block: &TriangleBlock, count: usize) -> Survivors {
        let l = self.l;
        let w = L::WIDTH;
        let zero = l.splat(0.0);
        let count = count.min(BLOCK);
        let valid = TriangleBlock::valid_bits(count);
        let mut culled = 0u32;
        let mut first = 0;
        while first < count {
            let vertices = [
                load_vertex(l, &block.v[0], first),
                load_vertex(l, &block.v[1], first),
                load_vertex(l, &block.v[2], first),
            ];
            let mut outside_any = l.mask_from_bits(0);
            for plane in &self.planes[..self.plane_count] {
                let [wx, wy, wz, e] = [
                    l.splat(plane[0]),
                    l.splat(plane[1]),
                    l.splat(plane[2]),
                    l.splat(plane[3]),
                ];
                let mut outside = !l.mask_from_bits(0);
                for [x, y, z] in vertices {
                    let d = x.mul_add(wx, y.mul_add(wy, z.mul_add(wz, e)));
                    outside = outside & d.lt(zero);
                }
                outside_any = outside_any | outside;
            }
            culled |= outside_any.bits() << first;
            first += w;
        }
        let culled = culled & valid;
        let mut out = Survivors::default();
        #[cfg(feature = "stats")]
        {
            out.culled.planes = culled.count_ones();
        }
        let left = valid & !culled;
        if !self.stages.aperture && (self.distance_folded || !self.stages.distance) {
            out.mask = u64::from(left);
            return out;
        }
        let mut rest = left;
        while rest != 0 {
            let i = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let tri = block.triangle(i);
            let v = [self.local(tri.v0), self.local(tri.v1), self.local(tri.v2)];
            if self.stages.aperture {
                match self.aperture(&v) {
                    Aperture::Outside => {
                        #[cfg(feature = "stats")]
                        {
                            out.culled.aperture += 1;
                        }
                        continue;
                    }
                    Aperture::Occluder(x_far) => {
                        out.inside |= 1 << i;
                        if x_far < self.far && self.stages.distance {
                            self.set_far(x_far);
                        }
                    }
                    Aperture::Unknown => {}
                }
            }
            if self.stages.distance && !self.distance_folded {
                let lo = v[0].x.min(v[1].x).min(v[2].x);
                let hi = v[0].x.max(v[1].x).max(v[2].x);
                if hi < self.near || lo > self.far {
                    #[cfg(feature = "stats")]
                    {
                        out.culled.distance += 1;
                    }
                    continue;
                }
            }
            out.mask |= 1 << i;
        }
        out
    }

    /// Moves the far plane to `x_far`.
    #[inline(always)]
    fn set_far(&mut self, x_far: f32) {
        self.far = x_far;
        if self.distance_folded {
            self.planes[5][3] = self.far_offset + x_far;
        }
    }

    /// The corner-ray test of one triangle, given its local vertices.
    #[inline(always)]
    fn aperture(&self, v: &[Vec3; 3]) -> Aperture {
        let l = self.l;
        let w = L::WIDTH;
        let e0 = v[1] - v[0];
        let e1 = v[0] - v[2];
        let n = e0.cross(e1);
        let n2 = n.length_squared();
        if n2.is_nan() || n2 <= 0.0 {
            return Aperture::Unknown;
        }
        let (nx, ny, nz) = (l.splat(n.x), l.splat(n.y), l.splat(n.z));
        let ldx = l.splat(self.dx);
        let zero = l.splat(0.0);
        let full = if w >= 4 { (1u32 << w) - 1 } else { 1 };
        let (mut pos, mut neg, mut guard) = (true, true, true);
        let (mut u_neg, mut v_neg, mut uv_big, mut inside) = (true, true, true, true);
        let (mut s_min, mut s_max) = (f32::INFINITY, f32::NEG_INFINITY);
        for c in 0..4usize.div_ceil(w) {
            // Corner lanes: corner j in lane j (padding lanes repeat corners, which leaves
            // every "all four" reduction unchanged).
            let pick = |a: &[f32; 4]| {
                if w == 1 {
                    l.splat(a[c])
                } else {
                    let mut buf = [0.0f32; MAX_WIDTH];
                    for (j, b) in buf.iter_mut().enumerate().take(w) {
                        *b = a[j % 4];
                    }
                    l.load(&buf)
                }
            };
            let (ay, az) = (pick(&self.corner_a[0]), pick(&self.corner_a[1]));
            let (dy, dz) = (pick(&self.corner_d[0]), pick(&self.corner_d[1]));
            let qx = l.splat(v[0].x);
            let qy = l.splat(v[0].y) - ay;
            let qz = l.splat(v[0].z) - az;
            let det = nx * ldx + ny * dy + nz * dz;
            let num = nx * qx + ny * qy + nz * qz;
            let d2 = ldx * ldx + dy * dy + dz * dz;
            pos &= det.gt(zero).bits() == full;
            neg &= det.lt(zero).bits() == full;
            guard &= (det * det).ge(l.splat(MIN_SIN2 * n2) * d2).bits() == full;
            let r = l.splat(1.0) / det;
            let s = num * r;
            guard &= s.ge(l.splat(SLAB_EPS)).bits() == full;
            guard &= s.le(l.splat(1.0 - SLAB_EPS)).bits() == full;
            let wx = qy * dz - qz * dy;
            let wy = qz * ldx - qx * dz;
            let wz = qx * dy - qy * ldx;
            let u = (wx * l.splat(e1.x) + wy * l.splat(e1.y) + wz * l.splat(e1.z)) * r;
            let vv = (wx * l.splat(e0.x) + wy * l.splat(e0.y) + wz * l.splat(e0.z)) * r;
            let (eps, one) = (l.splat(BARY_EPS), l.splat(1.0));
            u_neg &= u.lt(-eps).bits() == full;
            v_neg &= vv.lt(-eps).bits() == full;
            uv_big &= (u + vv).gt(one + eps).bits() == full;
            inside &= (u.ge(eps) & vv.ge(eps) & (u + vv).le(one - eps)).bits() == full;
            s_min = s_min.min(s.reduce_min());
            s_max = s_max.max(s.reduce_max());
        }
        if !(guard && (pos || neg)) {
            return Aperture::Unknown;
        }
        if u_neg || v_neg || uv_big {
            return Aperture::Outside;
        }
        let slack = self.margin + SLAB_EPS * self.dx;
        if inside
            && self.start_max <= s_min * self.dx - slack
            && self.end_min >= s_max * self.dx + slack
        {
            return Aperture::Occluder(s_max * self.dx + slack);
        }
        Aperture::Unknown
    }
}

/// Where the rays a beam is built from cross the slab of its leaf, in leaf-local coordinates:
/// the ranges of their `y'` and `z'` at `x' = 0` (`y0`, `z0`) and at `x' = dx` (`y1`, `z1`), the
/// extremes of their starts and ends along `x'`, the farthest best hit (`-inf` when not needed)
/// and the largest magnitude of any of these.
struct Crossings {
    y0: (f32, f32),
    y1: (f32, f32),
    z0: (f32, f32),
    z1: (f32, f32),
    start_min: f32,
    start_max: f32,
    end_min: f32,
    hit_max: f32,
    mag: f32,
}

impl Crossings {
    /// The crossings of the rays `used` of `p` with `slab`, ray by ray.
    #[inline(always)]
    fn of_rays<L: Lanes>(
        l: L,
        p: &RayPacket,
        used: u64,
        slab: &Slab,
        best_t: Option<(&[f32; MAX_PACKET_RAYS], u64)>,
    ) -> Self {
        let (axes, sign, corner, dx) = (slab.axes, slab.sign, slab.corner, slab.dx);
        let w = L::WIDTH;
        let inf = l.splat(f32::INFINITY);
        let splat_c = [l.splat(corner.x), l.splat(corner.y), l.splat(corner.z)];
        let (s, zero) = (l.splat(sign), l.splat(0.0));
        let ldx = l.splat(dx);
        let mut y0 = (inf, -inf);
        let mut y1 = (inf, -inf);
        let mut z0 = (inf, -inf);
        let mut z1 = (inf, -inf);
        let mut start_min = inf;
        let mut start_max = -inf;
        let mut end_min = inf;
        let mut hit_max = -inf;
        let mut mag = zero;
        for g in 0..group_count::<L>(p.len()) {
            let act = l.mask_from_bits(group_bits::<L>(used, g));
            if act.none() {
                continue;
            }
            let b = g * w;
            let ox = s * (l.load(&p.origin[axes[0]][b..]) - splat_c[0]);
            let oy = l.load(&p.origin[axes[1]][b..]) - splat_c[1];
            let oz = l.load(&p.origin[axes[2]][b..]) - splat_c[2];
            let dxr = s * l.load(&p.direction[axes[0]][b..]);
            let sy = l.load(&p.direction[axes[1]][b..]) / dxr;
            let sz = l.load(&p.direction[axes[2]][b..]) / dxr;
            let cy0 = oy - ox * sy;
            let cz0 = oz - ox * sz;
            let cy1 = cy0 + ldx * sy;
            let cz1 = cz0 + ldx * sz;
            y0 = widen::<L>(act, cy0, y0, inf);
            y1 = widen::<L>(act, cy1, y1, inf);
            z0 = widen::<L>(act, cz0, z0, inf);
            z1 = widen::<L>(act, cz1, z1, inf);
            let start = ox + l.load(&p.tmin[b..]) * dxr;
            let end = ox + l.load(&p.tmax[b..]) * dxr;
            start_min = L::F32::select(act, start, inf).min(start_min);
            start_max = L::F32::select(act, start, -inf).max(start_max);
            end_min = L::F32::select(act, end, inf).min(end_min);
            if let Some((t, _)) = best_t {
                let at = ox + l.load(&t[b..]) * dxr;
                hit_max = L::F32::select(act, at, -inf).max(hit_max);
            }
            let m = ox
                .abs()
                .max(oy.abs())
                .max(oz.abs())
                .max(cy0.abs().max(cz0.abs()));
            let m = m.max(cy1.abs().max(cz1.abs()));
            mag = L::F32::select(act, m, zero).max(mag);
        }
        Crossings {
            y0: (y0.0.reduce_min(), y0.1.reduce_max()),
            y1: (y1.0.reduce_min(), y1.1.reduce_max()),
            z0: (z0.0.reduce_min(), z0.1.reduce_max()),
            z1: (z1.0.reduce_min(), z1.1.reduce_max()),
            start_min: start_min.reduce_min(),
            start_max: start_max.reduce_max(),
            end_min: end_min.reduce_min(),
            hit_max: hit_max.reduce_max(),
            mag: mag.reduce_max(),
        }
    }

    /// The crossings of the rays `used` of `p` with `slab` from their summary `rays`, and
    /// their farthest best hit only when `far` gives the best hits (else `-inf`).
    #[inline(always)]
    fn of_summary<L: Lanes>(
        l: L,
        rays: &BeamRays,
        p: &RayPacket,
        used: u64,
        slab: &Slab,
        far: Option<(&[f32; MAX_PACKET_RAYS], u64)>,
    ) -> Self {
        let (axes, sign, corner, dx) = (slab.axes, slab.sign, slab.corner, slab.dx);
        let ox = sign * (rays.origin[axes[0]] - corner.x);
        let oy = rays.origin[axes[1]] - corner.y;
        let oz = rays.origin[axes[2]] - corner.z;
        // Both ends of the slab at the extreme slopes, rounded as `of_rays` rounds them.
        let (ya, yb) = (
            ends(oy, ox, dx, rays.slope_y.0),
            ends(oy, ox, dx, rays.slope_y.1),
        );
        let (za, zb) = (
            ends(oz, ox, dx, rays.slope_z.0),
            ends(oz, ox, dx, rays.slope_z.1),
        );
        let (y0, y1) = (
            (ya.0.min(yb.0), ya.0.max(yb.0)),
            (ya.1.min(yb.1), ya.1.max(yb.1)),
        );
        let (z0, z1) = (
            (za.0.min(zb.0), za.0.max(zb.0)),
            (za.1.min(zb.1), za.1.max(zb.1)),
        );
        let mut hit_max = f32::NEG_INFINITY;
        if let Some((t, _)) = far {
            let (s, ninf) = (l.splat(sign), l.splat(f32::NEG_INFINITY));
            let mut hi = ninf;
            for g in 0..group_count::<L>(p.len()) {
                let act = l.mask_from_bits(group_bits::<L>(used, g));
                if act.none() {
                    continue;
                }
                let b = g * L::WIDTH;
                let dxr = s * l.load(&p.direction[axes[0]][b..]);
                hi = L::F32::select(act, l.load(&t[b..]) * dxr, ninf).max(hi);
            }
            hit_max = ox + hi.reduce_max();
        }
        let mut mag = ox.abs().max(oy.abs()).max(oz.abs());
        for c in [y0.0, y0.1, y1.0, y1.1, z0.0, z0.1, z1.0, z1.1] {
            mag = mag.max(c.abs());
        }
        Crossings {
            y0,
            y1,
            z0,
            z1,
            start_min: ox + rays.start.0,
            start_max: ox + rays.start.1,
            end_min: ox + rays.end_min,
            hit_max,
            mag,
        }
    }
}

/// Where a ray from leaf-local `(ox, o)` with slope `slope` crosses `x' = 0` and `x' = dx`.
#[inline(always)]
fn ends(o: f32, ox: f32, dx: f32, slope: f32) -> (f32, f32) {
    let c0 = o - ox * slope;
    (c0, c0 + dx * slope)
}

/// What [`Beam::new`] needs of rays that start at one point, computed once for every
/// leaf they visit together: the prevalent axis, the origin, and the extremes of the slopes
/// and of the starts and ends along the axis.
#[derive(Clone, Copy, Debug)]
pub struct BeamRays {
    axes: [usize; 3],
    sign: f32,
    origin: Vec3,
    /// `(min, max)` of `d[axes[1]] / (sign·d[axes[0]])`.
    slope_y: (f32, f32),
    /// `(min, max)` of `d[axes[2]] / (sign·d[axes[0]])`.
    slope_z: (f32, f32),
    /// `(min, max)` of `tmin·sign·d[axes[0]]`.
    start: (f32, f32),
    /// The smallest `tmax·sign·d[axes[0]]`.
    end_min: f32,
}

impl BeamRays {
    /// The summary of the rays `used` of `p` for [`Beam::new`]; `None` when they do not
    /// all start at one point (equal coordinates; a NaN origin never is), when no axis is
    /// prevalent, or when `used` is empty (build their beams from the rays).
    ///
    /// Pinhole cameras' packets start at the eye; so do the tiles of any camera whose rays
    /// share an origin.
    #[inline(always)]
    pub fn new<L: Lanes>(l: L, p: &RayPacket, used: u64) -> Option<Self> {
        if used == 0 {
            return None;
        }
        let first = used.trailing_zeros() as usize;
        let origin = Vec3::new(p.origin[0][first], p.origin[1][first], p.origin[2][first]);
        // First the origins, which most packets that are not a camera's fail, and most of
        // those already at their last ray.
        let last = 63 - used.leading_zeros() as usize;
        if Vec3::new(p.origin[0][last], p.origin[1][last], p.origin[2][last]) != origin {
            return None;
        }
        let o = [l.splat(origin.x), l.splat(origin.y), l.splat(origin.z)];
        for g in 0..group_count::<L>(p.len()) {
            let act = l.mask_from_bits(group_bits::<L>(used, g));
            for (a, o) in o.iter().enumerate() {
                // `eq` takes -0 for +0: the crossings come out the same from either.
                if !(!l.load(&p.origin[a][g * L::WIDTH..]).eq(*o) & act).none() {
                    return None;
                }
            }
        }
        let (k, sign) = prevalent_axis(l, p, used)?;
        let axes = [k, (k + 1) % 3, (k + 2) % 3];
        let (inf, s) = (l.splat(f32::INFINITY), l.splat(sign));
        let (mut sy, mut sz, mut start) = ((inf, -inf), (inf, -inf), (inf, -inf));
        let mut end_min = inf;
        for g in 0..group_count::<L>(p.len()) {
            let act = l.mask_from_bits(group_bits::<L>(used, g));
            if act.none() {
                continue;
            }
            let b = g * L::WIDTH;
            let dxr = s * l.load(&p.direction[axes[0]][b..]);
            sy = widen::<L>(act, l.load(&p.direction[axes[1]][b..]) / dxr, sy, inf);
            sz = widen::<L>(act, l.load(&p.direction[axes[2]][b..]) / dxr, sz, inf);
            start = widen::<L>(act, l.load(&p.tmin[b..]) * dxr, start, inf);
            end_min = L::F32::select(act, l.load(&p.tmax[b..]) * dxr, inf).min(end_min);
        }
        Some(BeamRays {
            axes,
            sign,
            origin,
            slope_y: (sy.0.reduce_min(), sy.1.reduce_max()),
            slope_z: (sz.0.reduce_min(), sz.1.reduce_max()),
            start: (start.0.reduce_min(), start.1.reduce_max()),
            end_min: end_min.reduce_min(),
        })
    }
}

/// The prevalent axis of the rays `used` of `p`, and its direction sign: among axes on which
/// every ray used has a direction component of one non-zero sign, the one whose smallest `|d|`
/// is largest; `None` when there is none.
#[inline(always)]
fn prevalent_axis<L: Lanes>(l: L, p: &RayPacket, used: u64) -> Option<(usize, f32)> {
    let inf = l.splat(f32::INFINITY);
    let mut axis = None;
    let mut best = 0.0f32;
    for a in 0..3 {
        let (mut lo, mut hi) = (inf, -inf);
        for g in 0..group_count::<L>(p.len()) {
            let act = l.mask_from_bits(group_bits::<L>(used, g));
            if act.none() {
                continue;
            }
            let d = l.load(&p.direction[a][g * L::WIDTH..]);
            lo = L::F32::select(act, d, inf).min(lo);
            hi = L::F32::select(act, d, -inf).max(hi);
        }
        let (lo, hi) = (lo.reduce_min(), hi.reduce_max());
        let smallest = if lo > 0.0 {
            lo
        } else if hi < 0.0 {
            -hi
        } else {
            0.0
        };
        if smallest > best && smallest.is_finite() {
            best = smallest;
            axis = Some((a, if lo > 0.0 { 1.0 } else { -1.0 }));
        }
    }
    axis
}

/// The slab of a leaf along a beam's prevalent axis `axes[0]` (then `axes[1]`, `axes[2]` are
/// the leaf-local `y'` and `z'`), which rays moving with direction `sign` enter at `corner`
/// (the leaf's lower corner on the other axes) and cross over a depth `dx`.
#[derive(Clone, Copy)]
struct Slab {
    axes: [usize; 3],
    sign: f32,
    corner: Vec3,
    dx: f32,
}

impl Slab {
    /// The slab of a leaf with box `leaf`. A flat leaf is widened symmetrically (Reshetov: the
    /// expansion costs nothing, since only the flat leaf's own triangles are tested), so that
    /// `dx > 0`.
    #[inline(always)]
    fn enter(leaf: &Aabb, axes: [usize; 3], sign: f32) -> Self {
        let k = axes[0];
        let ext = leaf.extent();
        let mut corner = Vec3::new(leaf.min[k], leaf.min[axes[1]], leaf.min[axes[2]]);
        let mut dx = ext[k];
        if sign < 0.0 {
            corner.x = leaf.max[k];
        }
        if dx <= 0.0 {
            let e = (ext.max_element() + corner.abs().max_element()) * (1.0 / 1024.0) + 1e-30;
            corner.x -= sign * e;
            dx = 2.0 * e;
        }
        Slab {
            axes,
            sign,
            corner,
            dx,
        }
    }
}

/// What the corner rays say of one triangle.
enum Aperture {
    /// `F ∩ plane` misses the triangle.
    Outside,
    /// Every ray used hits the triangle at `x' <=` this.
    Occluder(f32),
    /// The guard failed, or the crossings straddle the triangle.
    Unknown,
}

/// `(min, max)` of `r` widened by the lanes `act` of `v` (`inf`: the identity of `min`).
///
/// A function, not a closure, which rustc may leave out of line without the ISA's features.
#[inline(always)]
fn widen<L: Lanes>(act: L::Mask, v: L::F32, r: (L::F32, L::F32), inf: L::F32) -> (L::F32, L::F32) {
    (
        L::F32::select(act, v, inf).min(r.0),
        L::F32::select(act, v, -inf).max(r.1),
    )
}

/// Lanes `first..first + WIDTH` of a block's vertex `v` (`[axis][lane]`), per axis.
#[inline(always)]
pub(crate) fn load_vertex<L: Lanes>(l: L, v: &[[f32; BLOCK]; 3], first: usize) -> [L::F32; 3] {
    [
        l.load(&v[0][first..]),
        l.load(&v[1][first..]),
        l.load(&v[2][first..]),
    ]
}

//! Synthetic Kensler–Shirley data: one leaf cell of random triangles and packets of parallel
//! rays through it, kdbeam's own definition of the data of Alexander Reshetov, *Faster Ray
//! Packets – Triangle Intersection through Vertex Culling*, IEEE Symposium on Interactive Ray
//! Tracing (RT07), 2007, section 3.1 and Figs. 3–5, after Andrew Kensler and Peter Shirley,
//! *Optimizing Ray-Triangle Intersection via Automated Search*, RT06. The benchmark that traces
//! it is `kdbeam::trace::synthetic`.
//!
//! The RT06 generator is not public, so kdbeam defines its own, seeded by [`Rng`]:
//!
//! - **The cell** is the unit cube `[0, 1]³`, the leaf box of the frustum.
//! - **Triangles**: equilateral (up to rounding) with edge `1 / ratio`, centres uniform in the
//!   cell, a uniform in-plane rotation, and normals uniform on the cone of half-angle
//!   [`SyntheticParams::normal_cone`] about the packets' mean direction `+z` (90° orients them
//!   uniformly). Vertices may stick out of the cell, as triangles straddling a kd-tree split do.
//! - **Calibration**: RT06 aims at 25% of ray–triangle pairs intersecting (Reshetov, RT07,
//!   section 3: "aiming at 25% probability of intersection for any given triangle"), and
//!   kdbeam sets `tmax` to reach it at ratio 1. Uniformly oriented triangles of edge 1 cannot:
//!   one covers on average (√3/4)·½ ≈ 22% of the cell's face in projection, less the part that
//!   falls outside it, and all pairs together plateau at 15% for any `tmax`. Triangles that
//!   face the packets, as the surfaces a primary-ray packet meets mostly do, cover more, so the
//!   default cone of [`DEFAULT_NORMAL_CONE`] raises the plateau above 25% and [`calibrate_tmax`]
//!   can meet the target by `tmax`; [`CALIBRATED_TMAX`] is the result.
//! - **Packets**: `n × n` parallel rays. The common direction is `+z` tilted by up to
//!   [`MAX_TILT`] on x and y; the rays cross the cell's entry face `z = 0` on an `n × n` grid of
//!   side `jitter` (times the cell edge) centred at a uniform point of that face, and start on
//!   the plane `z = −1` in front of the cell. `tmin = 0`, `tmax` = [`SyntheticParams::tmax`].
//!
//! Packets of 16 × 16 rays exceed [`MAX_PACKET_RAYS`]: each is stored as four 8 × 8
//! [`RayPacket`]s (its quadrants), traced one after the other.

use glam::Vec3;
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Aabb, KsTriangle, Ray, RayPacket, Triangle, TriangleBlock, MAX_PACKET_RAYS};

use super::rng::Rng;
use crate::{Error, Result};

/// Largest tilt of a packet's direction from `+z`: `|d.x / d.z|, |d.y / d.z| ≤ MAX_TILT`.
pub const MAX_TILT: f32 = 0.1;

/// The default [`SyntheticParams::normal_cone`], in degrees.
pub const DEFAULT_NORMAL_CONE: f32 = 30.0;

/// The default `tmax`: what [`calibrate_tmax`] returns for 25% at the default parameters
/// (the test `calibration_meets_a_quarter` checks it).
pub const CALIBRATED_TMAX: f32 = 1.875;

/// What to generate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SyntheticParams {
    /// Cell edge over triangle edge: 1 (RT06's setup) to 10 (Reshetov's Fig. 3 abscissa).
    pub ratio: f32,
    /// Rays per packet side: 2, 4, 8 or 16 (Fig. 4).
    pub packet_n: usize,
    /// Packet cross-section over cell edge, in (0, 1] (Fig. 5; 0.04 in Figs. 3 and 4).
    pub jitter: f32,
    /// Triangles in the cell.
    pub triangles: usize,
    /// Packets of `packet_n × packet_n` rays.
    pub packets: usize,
    /// Seed of every random draw.
    pub seed: u64,
    /// Largest accepted `t` of every ray (rays start at distance 1 from the cell along z).
    pub tmax: f32,
    /// Largest angle between a triangle's normal and `+z`, in degrees, in [0, 90]: 0 faces
    /// every triangle to the packets, 90 orients them uniformly.
    pub normal_cone: f32,
}

impl Default for SyntheticParams {
    /// Reshetov's Fig. 3 setting at ratio 4: 8 × 8 packets, jitter 4%, 64 triangles.
    fn default() -> Self {
        SyntheticParams {
            ratio: 4.0,
            packet_n: 8,
            jitter: 0.04,
            triangles: 64,
            packets: 1024,
            seed: 1,
            tmax: CALIBRATED_TMAX,
            normal_cone: DEFAULT_NORMAL_CONE,
        }
    }
}

/// A generated cell: its triangles and the packets that cross it.
#[derive(Clone, Debug)]
pub struct SyntheticCell {
    /// The cell, `[0, 1]³`.
    pub bounds: Aabb,
    /// The triangles, by vertex.
    pub triangles: Vec<Triangle>,
    /// The same triangles in leaf blocks, ids `0..triangles.len()`.
    pub blocks: Vec<TriangleBlock>,
    /// The packets; a 16 × 16 packet is four consecutive 8 × 8 ones.
    pub packets: Vec<RayPacket>,
    /// The largest absolute coordinate of any vertex or ray origin (the beam's `scene_bound`).
    pub scene_bound: f32,
}

impl SyntheticCell {
    /// Rays in all packets.
    pub fn rays(&self) -> usize {
        self.packets.iter().map(RayPacket::len).sum()
    }
}

fn invalid(name: &'static str, message: String) -> Error {
    Error::InvalidParameter { name, message }
}

impl SyntheticParams {
    /// Checks every parameter; the error names the first bad one.
    pub fn validate(&self) -> Result<()> {
        if !(self.ratio.is_finite() && (1.0..=1000.0).contains(&self.ratio)) {
            return Err(invalid(
                "ratio",
                format!("must be from 1 to 1000, got {}", self.ratio),
            ));
        }
        if ![2, 4, 8, 16].contains(&self.packet_n) {
            return Err(invalid(
                "packet",
                format!("must be 2, 4, 8 or 16, got {}", self.packet_n),
            ));
        }
        if !(self.jitter > 0.0 && self.jitter <= 1.0) {
            return Err(invalid(
                "jitter",
                format!("must be in (0, 1], got {}", self.jitter),
            ));
        }
        if !(1..=1 << 16).contains(&self.triangles) {
            return Err(invalid(
                "triangles",
                format!("must be from 1 to 65536, got {}", self.triangles),
            ));
        }
        if !(1..=1 << 20).contains(&self.packets) {
            return Err(invalid(
                "packets",
                format!("must be from 1 to 1048576, got {}", self.packets),
            ));
        }
        if self.tmax.is_nan() || self.tmax <= 0.0 {
            return Err(invalid(
                "tmax",
                format!("must be positive, got {}", self.tmax),
            ));
        }
        if !(0.0..=90.0).contains(&self.normal_cone) {
            return Err(invalid(
                "normal_cone",
                format!("must be from 0 to 90 degrees, got {}", self.normal_cone),
            ));
        }
        Ok(())
    }
}

/// An equilateral triangle of edge `edge` centred at a uniform point of `[0, 1]³`, its normal
/// uniform on the cap `z ≥ normal_min_z` and its rotation about the normal uniform.
fn random_triangle(rng: &mut Rng, edge: f32, normal_min_z: f32) -> Triangle {
    let centre = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let n = rng.unit_vector_in_cap(normal_min_z);
    // A uniform direction in the plane: a uniform unit vector projected onto it (its
    // projection's direction is uniform on the circle by symmetry about `n`).
    let a = loop {
        let w = rng.unit_vector();
        let p = w - w.dot(n) * n;
        if p.length_squared() > 1e-4 {
            break p.normalize();
        }
    };
    let b = n.cross(a);
    // Circumradius edge/√3; vertices at 0°, 120° and 240° (cos = −½, sin = ±√3/2).
    let r = edge / 3f32.sqrt();
    let h = 0.75f32.sqrt();
    Triangle::new(
        centre + r * a,
        centre + r * (-0.5 * a + h * b),
        centre + r * (-0.5 * a - h * b),
    )
}

/// The rays of one `n × n` packet, row by row, crossing `z = 0` on the grid of side `side`
/// centred at `(cx, cy)`.
fn packet_rays(direction: Vec3, cx: f32, cy: f32, side: f32, n: usize, tmax: f32) -> Vec<Ray> {
    let step = side / n as f32;
    let back = direction / direction.z;
    (0..n * n)
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let on_face = Vec3::new(
                cx + (i as f32 + 0.5) * step - 0.5 * side,
                cy + (j as f32 + 0.5) * step - 0.5 * side,
                0.0,
            );
            Ray {
                origin: on_face - back,
                direction,
                tmin: 0.0,
                tmax,
            }
        })
        .collect()
}

/// Generates the cell and packets of `params` (see the module documentation).
///
/// Errors with [`Error::InvalidParameter`] when a parameter is out of range (see
/// [`SyntheticParams::validate`]). The same parameters give the same bits on every platform.
pub fn generate(params: &SyntheticParams) -> Result<SyntheticCell> {
    params.validate()?;
    let mut rng = Rng::new(params.seed);
    let edge = 1.0 / params.ratio;
    let normal_min_z = params.normal_cone.to_radians().cos();
    let triangles: Vec<Triangle> = (0..params.triangles)
        .map(|_| random_triangle(&mut rng, edge, normal_min_z))
        .collect();
    let n = params.packet_n;
    let mut packets = Vec::with_capacity(params.packets * (n * n).div_ceil(MAX_PACKET_RAYS));
    for _ in 0..params.packets {
        let tilt_x = rng.range(-MAX_TILT, MAX_TILT);
        let tilt_y = rng.range(-MAX_TILT, MAX_TILT);
        let direction = Vec3::new(tilt_x, tilt_y, 1.0).normalize();
        let (cx, cy) = (rng.next_f32(), rng.next_f32());
        let rays = packet_rays(direction, cx, cy, params.jitter, n, params.tmax);
        if n * n <= MAX_PACKET_RAYS {
            packets.push(RayPacket::from_rays(&rays));
        } else {
            // Quadrants of 8 × 8: rows 0–7 or 8–15, columns 0–7 or 8–15.
            for q in 0..4 {
                let quadrant: Vec<Ray> = rays
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| (k % n >= 8) == (q & 1 == 1) && (k / n >= 8) == (q >= 2))
                    .map(|(_, r)| *r)
                    .collect();
                packets.push(RayPacket::from_rays(&quadrant));
            }
        }
    }
    let vertex_bound = triangles
        .iter()
        .flat_map(|t| [t.v0, t.v1, t.v2])
        .fold(0.0f32, |m, v| m.max(v.abs().max_element()));
    let origin_bound = packets
        .iter()
        .flat_map(|p| (0..p.len()).map(move |i| p.ray(i).origin))
        .fold(0.0f32, |m, o| m.max(o.abs().max_element()));
    Ok(SyntheticCell {
        bounds: Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        },
        blocks: triangles
            .chunks(BLOCK)
            .zip((0..).step_by(BLOCK))
            .map(|(chunk, first)| {
                TriangleBlock::new(triangles[0].v0, chunk.iter().copied().zip(first..))
            })
            .collect(),
        triangles,
        packets,
        scene_bound: vertex_bound.max(origin_bound),
    })
}

/// The share of ray–triangle pairs of `cell` that intersect in `[tmin, tmax]`, by the scalar
/// f32 Kensler–Shirley test: every ray against every triangle, not only closest hits.
///
/// 0 for a cell without rays or triangles.
#[must_use]
pub fn hit_rate(cell: &SyntheticCell) -> f64 {
    use kdbeam_kernels::intersect::kensler_shirley::intersect;
    let mut hits = 0u64;
    for p in &cell.packets {
        for i in 0..p.len() {
            let ray = p.ray(i);
            hits += cell
                .triangles
                .iter()
                .filter(|t| intersect(&ray, &KsTriangle::from(*t), ray.tmin, ray.tmax).is_some())
                .count() as u64;
        }
    }
    let pairs = (cell.rays() * cell.triangles.len()) as f64;
    if pairs == 0.0 {
        0.0
    } else {
        hits as f64 / pairs
    }
}

/// The smallest `tmax` (to 1/256) at which [`hit_rate`] at ratio 1 reaches `target`, with the
/// rate measured there, on the cell and packets of `params` with ratio 1; when even
/// `tmax = 3` (beyond every triangle at ratio 1) falls short, `3` and the rate there.
///
/// Bisection on `tmax`: the rate never decreases as `tmax` grows.
pub fn calibrate_tmax(params: &SyntheticParams, target: f64) -> Result<(f32, f64)> {
    let rate_at = |tmax: f32| -> Result<f64> {
        let p = SyntheticParams {
            ratio: 1.0,
            tmax,
            ..*params
        };
        Ok(hit_rate(&generate(&p)?))
    };
    let (mut lo, mut hi) = (0.0f32, 3.0f32);
    let at_hi = rate_at(hi)?;
    if at_hi < target {
        return Ok((hi, at_hi));
    }
    while hi - lo > 1.0 / 256.0 {
        let mid = 0.5 * (lo + hi);
        if rate_at(mid)? >= target {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Ok((hi, rate_at(hi)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn generation_is_seeded_and_shaped_as_asked() {
        let p = SyntheticParams {
            packets: 8,
            ..Default::default()
        };
        let a = generate(&p).unwrap();
        let b = generate(&p).unwrap();
        assert_eq!(a.triangles, b.triangles);
        assert_eq!(a.packets, b.packets);
        let c = generate(&SyntheticParams { seed: 2, ..p }).unwrap();
        assert_ne!(a.triangles, c.triangles);
        assert_eq!(a.triangles.len(), 64);
        assert_eq!(a.packets.len(), 8);
        assert!(a.packets.iter().all(|p| p.len() == 64));
        // Edge 1/4: every edge within 1e-5 of it (rounding of a few f32 operations on
        // coordinates below 2).
        for t in &a.triangles {
            for e in [t.v1 - t.v0, t.v2 - t.v1, t.v0 - t.v2] {
                assert!((e.length() - 0.25).abs() < 1e-5, "{e}");
            }
            let centre = (t.v0 + t.v1 + t.v2) / 3.0;
            assert!(
                centre.cmpge(Vec3::splat(-1e-6)).all()
                    && centre.cmple(Vec3::splat(1.0 + 1e-6)).all()
            );
        }
        // Parallel rays starting at z = −1, crossing z = 0 inside a square of side 4% (+1e-6
        // for rounding).
        for p in &a.packets {
            let r0 = p.ray(0);
            let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for i in 0..p.len() {
                let r = p.ray(i);
                assert_eq!(r.direction, r0.direction);
                assert!((r.origin.z + 1.0).abs() < 1e-6);
                let on_face = r.origin + r.direction / r.direction.z;
                lo = lo.min(on_face);
                hi = hi.max(on_face);
            }
            let side = hi - lo;
            assert!(side.x < 0.04 + 1e-6 && side.y < 0.04 + 1e-6, "{side}");
            assert!(side.x > 0.03, "{side}");
        }
    }

    #[test]
    fn packets_of_16_by_16_are_four_quadrants() {
        let p = SyntheticParams {
            packet_n: 16,
            packets: 2,
            ..Default::default()
        };
        let c = generate(&p).unwrap();
        assert_eq!(c.packets.len(), 8);
        assert_eq!(c.rays(), 2 * 256);
        // Quadrant 0 lies left of quadrant 1 and below quadrant 2 (on the face z = 0).
        let first_x = |q: usize| c.packets[q].ray(0).origin.x;
        let first_y = |q: usize| c.packets[q].ray(0).origin.y;
        assert!(first_x(0) < first_x(1) && first_y(0) < first_y(2));
    }

    #[test]
    fn bad_parameters_are_errors() {
        let ok = SyntheticParams::default();
        for bad in [
            SyntheticParams { ratio: 0.5, ..ok },
            SyntheticParams {
                ratio: f32::NAN,
                ..ok
            },
            SyntheticParams { packet_n: 3, ..ok },
            SyntheticParams { jitter: 0.0, ..ok },
            SyntheticParams { jitter: 1.5, ..ok },
            SyntheticParams { triangles: 0, ..ok },
            SyntheticParams { packets: 0, ..ok },
            SyntheticParams {
                tmax: f32::NAN,
                ..ok
            },
            SyntheticParams {
                normal_cone: 91.0,
                ..ok
            },
            SyntheticParams {
                normal_cone: f32::NAN,
                ..ok
            },
        ] {
            assert!(generate(&bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn calibration_meets_a_quarter() {
        // The default parameters are calibrated: 25% of pairs at ratio 1, from above.
        let p = SyntheticParams::default();
        let (tmax, rate) = calibrate_tmax(&p, 0.25).unwrap();
        assert_eq!(tmax, CALIBRATED_TMAX);
        assert!((0.25..0.26).contains(&rate), "{rate}");
        let below = generate(&SyntheticParams {
            ratio: 1.0,
            tmax: tmax - 1.0 / 128.0,
            ..p
        })
        .unwrap();
        assert!(hit_rate(&below) < 0.25);
        // Uniformly oriented triangles plateau below 25% (see the module documentation), so
        // calibration stops at tmax = 3, beyond every triangle.
        let uniform = SyntheticParams {
            normal_cone: 90.0,
            packets: 256,
            ..p
        };
        let (tmax, rate) = calibrate_tmax(&uniform, 0.25).unwrap();
        assert_eq!(tmax, 3.0);
        assert!((0.10..0.25).contains(&rate), "{rate}");
    }
}

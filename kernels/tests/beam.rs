//! Beams built from a summary of rays that share an origin ([`BeamRays`]) against beams built
//! ray by ray ([`Beam::new`] without one), on every ISA: neither culls a triangle that one of its rays
//! hits inside the leaf before its best hit, both cull triangles clear of every ray, and the
//! summary exists only for rays that start at one point.
#![cfg(feature = "std")] // `Dispatch::available` detects the CPU.

mod common;

use common::Rng;
use kdbeam_kernels::beam::{Beam, BeamRays, Stages};
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{
    Aabb, LaneTask, Lanes, Ray, RayPacket, Triangle, TriangleBlock, Vec3, MAX_PACKET_RAYS,
};

/// One leaf visit: the packet, the rays used, the leaf's box and the rays' best hits so far.
struct Visit {
    packet: RayPacket,
    used: u64,
    leaf: Aabb,
    best: [f32; MAX_PACKET_RAYS],
    has_hit: u64,
    stages: Stages,
    scene_bound: f32,
}

/// The survivors of `block` under the ray-by-ray beam and under the summarised one (`None`
/// when either builds no beam or the rays have no summary).
struct CullBoth<'a> {
    visit: &'a Visit,
    block: &'a TriangleBlock,
}

impl LaneTask for CullBoth<'_> {
    type Output = Option<(u64, u64)>;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Option<(u64, u64)> {
        let v = self.visit;
        let best = Some((&v.best, v.has_hit));
        let rays = BeamRays::new(l, &v.packet, v.used)?;
        let beam = |rays| {
            Beam::new(
                l,
                &v.packet,
                v.used,
                rays,
                &v.leaf,
                best,
                v.stages,
                v.scene_bound,
            )
        };
        let (mut by_ray, mut summarised) = (beam(None)?, beam(Some(&rays))?);
        Some((
            by_ray.cull(self.block, BLOCK).mask,
            summarised.cull(self.block, BLOCK).mask,
        ))
    }
}

/// Whether the rays `used` of `packet` have a [`BeamRays`] summary on `d`'s ISA.
struct Summarised<'a> {
    packet: &'a RayPacket,
    used: u64,
}

impl LaneTask for Summarised<'_> {
    type Output = bool;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> bool {
        BeamRays::new(l, self.packet, self.used).is_some()
    }
}

/// A small triangle around `q` in a random plane through it.
fn triangle_around(rng: &mut Rng, q: Vec3, size: f32) -> Triangle {
    let (a, b) = (rng.on_sphere(), rng.on_sphere());
    let n = a.cross(b).normalize_or(Vec3::X);
    let u = n.any_orthonormal_vector();
    let w = n.cross(u);
    // `q` is the centroid: inside, whatever the rounding of the corners.
    Triangle::new(
        q + size * u,
        q + size * (-0.5 * u + 0.866 * w),
        q + size * (-0.5 * u - 0.866 * w),
    )
}

/// A leaf visit of up to 64 rays from one origin (at magnitude `scale`) through a random leaf
/// box, with some rays' best hits inside the box.
fn random_visit(rng: &mut Rng, scale: f32, stages: Stages) -> Visit {
    let center = rng.in_cube(scale);
    let half = Vec3::new(
        rng.range(0.01, 1.0),
        rng.range(0.01, 1.0),
        rng.range(0.01, 1.0),
    );
    let half = if rng.chance(0.1) {
        half * Vec3::new(1.0, 1.0, 0.0)
    } else {
        half
    };
    let leaf = Aabb::new(center - half, center + half);
    let origin = center + rng.on_sphere() * rng.range(2.0, 50.0);
    let n = 1 + rng.below(MAX_PACKET_RAYS);
    let rays: Vec<Ray> = (0..n)
        .map(|_| {
            let target = center
                + half
                    * Vec3::new(
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                        rng.range(-1.0, 1.0),
                    );
            let mut ray = Ray::new(origin, target - origin);
            if rng.chance(0.3) {
                // Some start inside the leaf (the targets lie at t = 1).
                ray.tmin = rng.range(0.0, 1.0);
            }
            if rng.chance(0.2) {
                ray.tmax = rng.range(0.9, 2.0);
            }
            ray
        })
        .collect();
    let packet = RayPacket::from_rays(&rays);
    let used = if rng.chance(0.3) {
        packet.full_mask() & rng.next_u64() | 1
    } else {
        packet.full_mask()
    };
    let mut best = [f32::INFINITY; MAX_PACKET_RAYS];
    let mut has_hit = 0;
    let all_hit = rng.chance(0.5);
    for (i, b) in best.iter_mut().enumerate().take(n) {
        *b = rays[i].tmax;
        if all_hit || rng.chance(0.5) {
            // A hit somewhere about the leaf (the targets lie at t = 1).
            *b = rng.range(0.95, 1.05).min(rays[i].tmax).max(rays[i].tmin);
            has_hit |= 1 << i;
        }
    }
    Visit {
        packet,
        used,
        leaf,
        best,
        has_hit,
        stages,
        scene_bound: center.abs().max_element() + 2.0 * half.max_element() + 60.0,
    }
}

/// A point of ray `i`'s segment `[tmin, best]` inside the leaf box, if it has one.
fn point_inside(rng: &mut Rng, v: &Visit, i: usize) -> Option<Vec3> {
    let ray = v.packet.ray(i);
    let inv = ray.direction.recip();
    let t0 = (v.leaf.min - ray.origin) * inv;
    let t1 = (v.leaf.max - ray.origin) * inv;
    let enter = t0.min(t1).max_element().max(ray.tmin);
    let exit = t0.max(t1).min_element().min(v.best[i]);
    // Away from the ends: the point must lie inside the box once rounded.
    let (lo, hi) = (enter + 0.01 * (exit - enter), exit - 0.01 * (exit - enter));
    (lo < hi).then(|| ray.at(rng.range(lo, hi)))
}

const STAGES: [Stages; 3] = [
    Stages {
        distance: false,
        aperture: false,
        aperture_first: false,
    },
    Stages {
        distance: true,
        aperture: false,
        aperture_first: false,
    },
    Stages {
        distance: true,
        aperture: true,
        aperture_first: true,
    },
];

#[test]
fn neither_beam_culls_a_hit_of_its_rays_inside_the_leaf() {
    let mut rng = Rng::new(7);
    let mut checked = 0;
    for trial in 0..1500 {
        let scale = [1.0, 100.0, 1e4][trial % 3];
        let stages = STAGES[trial % STAGES.len()];
        let v = random_visit(&mut rng, scale, stages);
        let mut tris = Vec::new();
        for _ in 0..200 {
            if tris.len() == BLOCK {
                break;
            }
            let i = rng.below(v.packet.len());
            if v.used >> i & 1 == 0 {
                continue;
            }
            if let Some(q) = point_inside(&mut rng, &v, i) {
                let size = rng.range(0.001, 0.5);
                tris.push((triangle_around(&mut rng, q, size), tris.len() as u32));
            }
        }
        let count = tris.len();
        if count == 0 {
            continue;
        }
        let block = TriangleBlock::new(tris[0].0.v0, tris);
        let want = (1u64 << count) - 1;
        for d in Dispatch::available() {
            let Some((by_ray, summarised)) = d.run(CullBoth {
                visit: &v,
                block: &block,
            }) else {
                continue;
            };
            checked += 1;
            assert_eq!(by_ray & want, want, "{:?}, trial {trial}", d.isa());
            assert_eq!(summarised & want, want, "{:?}, trial {trial}", d.isa());
        }
    }
    assert!(checked > 1000, "only {checked} beams were built");
}

#[test]
fn both_beams_cull_triangles_clear_of_every_ray() {
    let mut rng = Rng::new(8);
    for trial in 0..500 {
        let v = random_visit(&mut rng, 10.0, STAGES[trial % STAGES.len()]);
        // Beside the leaf, off every ray's way to it.
        let (center, half) = (v.leaf.center(), 0.5 * v.leaf.extent());
        let origin = v.packet.ray(0).origin;
        let side = (center - origin).normalize().any_orthonormal_vector();
        let tris: Vec<(Triangle, u32)> = (0..BLOCK as u32)
            .map(|id| {
                let q =
                    center + side * (4.0 * half.length() + 1.0) + rng.in_cube(half.min_element());
                (triangle_around(&mut rng, q, 0.01), id)
            })
            .collect();
        let block = TriangleBlock::new(tris[0].0.v0, tris);
        for d in Dispatch::available() {
            if let Some((by_ray, summarised)) = d.run(CullBoth {
                visit: &v,
                block: &block,
            }) {
                assert_eq!(by_ray, 0, "{:?}, trial {trial}", d.isa());
                assert_eq!(summarised, 0, "{:?}, trial {trial}", d.isa());
            }
        }
    }
}

#[test]
fn only_rays_from_one_origin_are_summarised() {
    let rays: Vec<Ray> = (0..64)
        .map(|i| {
            Ray::new(
                Vec3::new(1.0, 2.0, 3.0),
                Vec3::new(0.01 * i as f32, 0.2, 1.0),
            )
        })
        .collect();
    let mut packet = RayPacket::from_rays(&rays);
    for d in Dispatch::available() {
        assert!(d.run(Summarised {
            packet: &packet,
            used: u64::MAX
        }));
    }
    let mut moved = rays[37];
    moved.origin.y = 2.000_001;
    packet.set(37, &moved);
    for d in Dispatch::available() {
        assert!(!d.run(Summarised {
            packet: &packet,
            used: u64::MAX
        }));
        // Only the rays used count.
        assert!(d.run(Summarised {
            packet: &packet,
            used: !(1 << 37),
        }));
        assert!(!d.run(Summarised {
            packet: &packet,
            used: 0
        }));
    }
}

//! Differential tests: every packet path and the single-ray path (each ISA this CPU runs ×
//! packet size × intersector × closest and any hit) against the scalar single-ray path, on procedural and shared scenes,
//! with primary, random and adversarial rays and random inactive lanes.
//!
//! The packets trace with the default culling on the per-ray traversal (`auto/adaptive`): the
//! whole-packet traversal that the default gives coherent packets tests more than the scalar
//! path, and `tests/culling_vs_none.rs` checks it with the tolerance it needs.
//!
//! Tolerance: none. The lane kernels perform the same IEEE-754 operations in the same order as
//! the scalar ones (no FMA in either intersector), and a ray is active in exactly the cells the
//! scalar traversal enters, so hits must agree to the bit, ids included.

mod common;

use kdbeam::rays::random_rays;
use kdbeam::scene::rng::Rng;
use kdbeam::trace::{Culling, Frustum};
use kdbeam::{
    BuildParams, Hit, HitPacket, Intersector, Isa, KdTree, PacketShape, Ray, RayPacket, Tracer,
};

fn check(name: &str, tree: &KdTree, rays: &[Ray], seed: u64) -> usize {
    let mut compared = 0;
    for intersector in Intersector::ALL {
        let scalar = Tracer::new(tree)
            .with_isa(Isa::Scalar)
            .unwrap()
            .with_intersector(intersector)
            .with_culling(Culling::AUTO.with_frustum(Frustum::Adaptive));
        let expected: Vec<Hit> = rays.iter().map(|r| scalar.intersect(r)).collect();
        let expected_occ: Vec<bool> = rays.iter().map(|r| scalar.occluded(r)).collect();
        for (i, r) in rays.iter().enumerate() {
            assert_eq!(
                expected[i].is_hit(),
                expected_occ[i],
                "{name}: any hit disagrees with closest hit on {r:?}"
            );
        }
        for isa in Isa::available() {
            // Single rays: one ray against a vector of a leaf block's triangles per test.
            let single = scalar.with_isa(isa).unwrap();
            for (k, ray) in rays.iter().enumerate() {
                let (got, want) = (single.intersect(ray), expected[k]);
                assert!(
                    got.triangle == want.triangle
                        && got.t.to_bits() == want.t.to_bits()
                        && (got.u.to_bits(), got.v.to_bits()) == (want.u.to_bits(), want.v.to_bits()),
                    "{name} {isa} {intersector:?}: ray {k} {ray:?}: single {got:?}, scalar {want:?}"
                );
                assert_eq!(
                    single.occluded(ray),
                    expected_occ[k],
                    "{name} {isa} {intersector:?}: single occluded, ray {k}"
                );
                compared += 1;
            }
            for shape in PacketShape::ALL {
                let tracer = scalar.with_isa(isa).unwrap().with_packet(shape);
                let mut rng = Rng::new(seed);
                let mut hp = HitPacket::default();
                for (c, chunk) in rays.chunks(shape.ray_count()).enumerate() {
                    let p = RayPacket::from_rays(chunk);
                    // Every third packet has random inactive lanes.
                    let active = if c % 3 == 2 {
                        (u64::from(rng.next_u32()) << 32 | u64::from(rng.next_u32()))
                            & p.full_mask()
                    } else {
                        p.full_mask()
                    };
                    tracer.intersect_packet(&p, active, &mut hp);
                    let occ = tracer.occluded_packet(&p, active);
                    for (j, ray) in chunk.iter().enumerate() {
                        let k = c * shape.ray_count() + j;
                        let on = active >> j & 1 != 0;
                        let want = if on { expected[k] } else { Hit::NONE };
                        let got = hp.hit(j);
                        assert!(
                            got.triangle == want.triangle && got.t.to_bits() == want.t.to_bits()
                                && (!want.is_hit() || (got.u.to_bits(), got.v.to_bits()) == (want.u.to_bits(), want.v.to_bits())),
                            "{name} {isa} {shape:?} {intersector:?}: ray {k} {ray:?}: packet {got:?}, scalar {want:?}"
                        );
                        assert_eq!(
                            occ >> j & 1 != 0,
                            on && expected_occ[k],
                            "{name} {isa} {shape:?} {intersector:?}: occluded, ray {k}"
                        );
                        compared += 1;
                    }
                }
            }
        }
    }
    compared
}

#[test]
fn packets_equal_scalar_on_procedural_scenes() {
    let mut total = 0;
    for (name, mesh) in common::scenes(false) {
        let mut rays = common::primary_rays(&mesh, 96, 96);
        rays.extend(random_rays(&mesh.bounds(), 4096, 7));
        rays.extend(common::adversarial_rays(&mesh, 4096, 11));
        // The default tree, and one of large leaves (several blocks of triangles each).
        for ci in [1.5, 0.03] {
            let tree = KdTree::build(&mesh, &BuildParams::default().with_ci_over_ct(ci)).unwrap();
            total += check(&name, &tree, &rays, 3);
        }
    }
    eprintln!("compared {total} ray results");
}

#[test]
fn packets_equal_scalar_on_shared_scenes() {
    let scenes = common::real_scenes();
    if scenes.is_empty() {
        eprintln!("skipped: no shared scenes");
        return;
    }
    let mut total = 0;
    for (name, mesh) in scenes {
        for ci in [1.0, 10.0] {
            let tree = KdTree::build(&mesh, &BuildParams::default().with_ci_over_ct(ci)).unwrap();
            let mut rays = common::primary_rays(&mesh, 64, 64);
            rays.extend(random_rays(&mesh.bounds(), 2048, 5));
            rays.extend(common::adversarial_rays(&mesh, 2048, 13));
            total += check(&name, &tree, &rays, 17);
        }
    }
    eprintln!("compared {total} ray results");
}

//! Ray-box culling (Nah et al.) is conservative: with it, every single ray gets the same closest
//! hit as without — triangle id, `t`, `u`, `v`, bit for bit — and the same any-hit verdict, on
//! every ISA this CPU runs (each ISA tested is printed; one it lacks is reported skipped), with
//! both intersectors, on trees of small and large leaves, on, where it pays (the default
//! `auto`'s setting) and with the beam. Packets with it (leaf visits of few rays and no beam
//! culled by the box of their segments) are checked against the unculled scalar path at every
//! packet size.
//!
//! Tolerance: none. A culled triangle is never a hit the unculled query keeps, and the
//! survivors are tested by the same kernels on the same rays.
//!
//! Rays: adversarial (mixed signs, zero and signed-zero components, axis-parallel rays through
//! vertices, origins on triangles and vertices, NaN, infinite and zero directions, `tmin >
//! tmax`), grazing rays in the plane of flat geometry, ambient-occlusion and diffuse rays from
//! the primary hits, random rays; NaN lanes in packets.

mod common;

use kdbeam::rays::secondary::{SecondaryRays, Workload};
use kdbeam::scene::procedural;
use kdbeam::trace::{Culling, PacketCounters, RayBoxes, RayCounters};
use kdbeam::{
    BuildParams, Camera, Hit, HitPacket, Intersector, Isa, KdTree, Mesh, PacketShape, Ray,
    RayPacket, Tracer, Vec3,
};

/// The ISAs this CPU runs, printing once the ones it does not.
fn isas() -> Vec<Isa> {
    static SKIPS: std::sync::Once = std::sync::Once::new();
    SKIPS.call_once(|| {
        for isa in [Isa::Sse, Isa::Avx2, Isa::Avx512] {
            if !Isa::available().any(|a| a == isa) {
                eprintln!("skipped: {isa} (this CPU does not run it)");
            }
        }
    });
    Isa::available().collect()
}

/// The rays of a scene: adversarial, grazing, AO, diffuse.
fn rays_for(mesh: &Mesh, tree: &KdTree, count: usize, seed: u64) -> Vec<Ray> {
    let mut rays = common::adversarial_rays(mesh, count, seed);
    // Grazing: in the plane of a triangle, from one vertex through another and on.
    for i in 0..count / 8 {
        let t = mesh.triangle(i * 7919 % mesh.triangle_count());
        rays.push(Ray::new(t.v0, t.v1 - t.v0));
        rays.push(Ray::new(t.v1 * 2.0 - t.v2, t.v2 - t.v1));
    }
    let camera = Camera::standard(&mesh.bounds(), 32, 32);
    let tracer = Tracer::new(tree);
    for workload in [Workload::AmbientOcclusion { rays: 2 }, Workload::Diffuse] {
        let s = SecondaryRays::from_camera(workload, &tracer, mesh, &camera, seed).unwrap();
        rays.extend(s.rays);
    }
    rays
}

fn same(a: &Hit, b: &Hit) -> bool {
    a.triangle == b.triangle
        && a.t.to_bits() == b.t.to_bits()
        && (!a.is_hit() || (a.u.to_bits(), a.v.to_bits()) == (b.u.to_bits(), b.v.to_bits()))
}

/// The unculled scalar tracer and its closest hit and occlusion for every ray.
fn reference<'t>(
    tree: &'t KdTree,
    intersector: Intersector,
    rays: &[Ray],
) -> (Tracer<'t>, Vec<(Hit, bool)>) {
    let scalar = Tracer::new(tree)
        .with_isa(Isa::Scalar)
        .unwrap()
        .with_intersector(intersector)
        .with_culling(Culling::NONE);
    let want = rays
        .iter()
        .map(|r| (scalar.intersect(r), scalar.occluded(r)))
        .collect();
    (scalar, want)
}

/// Compares `+raybox` with no culling on every ISA and intersector; returns the counters summed
/// over the culled closest-hit queries.
fn check(name: &str, mesh: &Mesh, params: &BuildParams, seed: u64) -> RayCounters {
    let tree = KdTree::build(mesh, params).unwrap();
    let rays = rays_for(mesh, &tree, 3000, seed);
    let mut sum = RayCounters::default();
    for intersector in Intersector::ALL {
        let (scalar, want) = reference(&tree, intersector, &rays);
        for isa in isas() {
            for culling in [
                Culling::NONE.with_raybox(RayBoxes::On),
                Culling::NONE.with_raybox(RayBoxes::Auto),
                Culling::AUTO,
                Culling::AUTO.with_raybox(RayBoxes::On),
            ] {
                let tracer = scalar.with_isa(isa).unwrap().with_culling(culling);
                for (ray, (w, wo)) in rays.iter().zip(&want) {
                    let (g, c) = tracer.intersect_counted(ray);
                    assert!(
                        same(&g, w),
                        "{name} {isa} {intersector:?} {culling}: {ray:?}: culled {g:?}, unculled {w:?}"
                    );
                    let (o, _) = tracer.occluded_counted(ray);
                    assert_eq!(o, *wo, "{name} {isa} {intersector:?} {culling}: {ray:?}");
                    sum.tests += c.tests;
                    sum.culled += c.culled;
                    sum.leaves += c.leaves;
                }
            }
        }
    }
    sum
}

fn scenes() -> Vec<(&'static str, Mesh)> {
    let offset = Vec3::new(148376.0, 1234.0, -223423.0);
    vec![
        ("icosphere", procedural::builtin("icosphere").unwrap()),
        ("icosphere@1e5", procedural::icosphere(offset, 2.0, 3)),
        ("soup", procedural::builtin("soup:2000").unwrap()),
        ("grid", procedural::builtin("grid").unwrap()),
        (
            "flat grid",
            procedural::quad_grid(16, 16, Vec3::ZERO, Vec3::X, Vec3::Z),
        ),
    ]
}

#[test]
fn raybox_never_changes_a_single_ray_hit() {
    for (name, mesh) in scenes() {
        for params in [
            BuildParams::default(),
            BuildParams::default().with_leaf_size(16),
            BuildParams::default().with_ci_over_ct(0.02),
        ] {
            let c = check(name, &mesh, &params, 11);
            // The stage must have had something to do, or this test proves nothing.
            assert!(
                c.culled > 0 && c.tests > 0,
                "{name} {params:?}: nothing culled ({c:?})"
            );
            eprintln!(
                "{name} leaf size {} ci {}: {:.1}% of tests culled",
                params.leaf_size,
                params.ci_over_ct,
                100.0 * c.culled as f64 / (c.culled + c.tests) as f64
            );
        }
    }
}

#[test]
fn raybox_never_changes_a_hit_on_a_shared_scene() {
    let Some(mesh) = common::scenes::load_shared("bunny") else {
        return;
    };
    let params = BuildParams::default().with_leaf_size(16);
    let c = check("bunny", &mesh, &params, 5);
    assert!(c.culled > 0, "{c:?}");
}

/// Packets with `+raybox` (which culls leaf visits of few rays and no beam) against the
/// unculled scalar path; returns the tests the packets made with and without the stage.
fn check_packets(name: &str, mesh: &Mesh, params: &BuildParams, seed: u64) -> (u64, u64) {
    let tree = KdTree::build(mesh, params).unwrap();
    let mut rays = rays_for(mesh, &tree, 1024, seed);
    for r in rays.iter_mut().step_by(37) {
        r.origin.y = f32::NAN;
    }
    let (mut culled_tests, mut unculled_tests) = (0, 0);
    for intersector in Intersector::ALL {
        let (scalar, want) = reference(&tree, intersector, &rays);
        for isa in isas() {
            for shape in PacketShape::ALL {
                for culling in [
                    Culling::NONE,
                    Culling::NONE.with_raybox(RayBoxes::On),
                    Culling::AUTO,
                    Culling::AUTO.with_raybox(RayBoxes::On),
                ] {
                    let tracer = scalar
                        .with_isa(isa)
                        .unwrap()
                        .with_culling(culling)
                        .with_packet(shape);
                    let mut hits = HitPacket::default();
                    let mut counters = PacketCounters::default();
                    let n = shape.ray_count();
                    for (chunk, want) in rays.chunks(n).zip(want.chunks(n)) {
                        let p = RayPacket::from_rays(chunk);
                        tracer.intersect_packet_counted(
                            &p,
                            p.full_mask(),
                            &mut hits,
                            &mut counters,
                        );
                        let occluded =
                            tracer.occluded_packet_counted(&p, p.full_mask(), &mut counters);
                        for (j, (ray, (w, wo))) in chunk.iter().zip(want).enumerate() {
                            assert!(
                                same(&hits.hit(j), w),
                                "{name} {isa} {shape:?} {intersector:?} {culling}: {ray:?}: {:?} vs {w:?}",
                                hits.hit(j)
                            );
                            assert_eq!(
                                occluded >> j & 1 != 0,
                                *wo,
                                "{name} {isa} {shape:?} {culling}: {ray:?}"
                            );
                        }
                    }
                    if culling == Culling::NONE {
                        unculled_tests += counters.tests;
                    } else if culling == Culling::NONE.with_raybox(RayBoxes::On) {
                        culled_tests += counters.tests;
                    }
                }
            }
        }
    }
    (culled_tests, unculled_tests)
}

#[test]
fn raybox_packets_equal_the_unculled_scalar_path_with_nan_lanes() {
    for (name, mesh) in scenes() {
        let params = BuildParams::default().with_leaf_size(8);
        let (culled, unculled) = check_packets(name, &mesh, &params, 3);
        // The stage must have culled something, or this test proves nothing.
        assert!(
            culled < unculled,
            "{name}: {culled} tests with raybox, {unculled} without"
        );
        eprintln!(
            "{name} packets, leaf size 8: {:.1}% of tests culled",
            100.0 * (1.0 - culled as f64 / unculled as f64)
        );
    }
}

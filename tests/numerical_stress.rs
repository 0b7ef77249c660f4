//! Numerical stress through the whole tracer: scales from 1e-6 to 1e6 and offsets up to 1e5,
//! axis-parallel and grazing rays, rays starting on a surface, degenerate triangles, a flat mesh
//! (flat leaves), NaN and infinite lanes in packets, all-inactive packets, and the empty scene.
//!
//! Every scene also goes through `fuzz_checks::packets_equal_scalar`: every ISA, packet shape
//! and intersector, packets and streams, equal to the scalar path bit for bit (but for a hit
//! that the default's whole-packet traversal of a coherent packet proves to win by an extra
//! test; these rays are random, so their packets take the per-ray traversal). Comparisons with
//! the f64 oracle state their tolerance where they make them.

mod fuzz_checks;

use fuzz_checks::packets_equal_scalar;
use kdbeam::rays::random_rays;
use kdbeam::scene::procedural::{closed_grid_box, icosphere, quad_grid};
use kdbeam::scene::rng::Rng;
use kdbeam::trace::reference::brute_force;
use kdbeam::trace::Culling;
use kdbeam::{
    BuildParams, Hit, HitPacket, Intersector, Isa, KdTree, Mesh, PacketShape, Ray, RayPacket,
    Tracer, Vec3,
};

fn build(mesh: &Mesh) -> KdTree {
    KdTree::build(mesh, &BuildParams::default()).expect("valid mesh")
}

fn watertight(tree: &KdTree) -> Tracer<'_> {
    Tracer::new(tree)
        .with_isa(Isa::Scalar)
        .expect("scalar runs everywhere")
        .with_intersector(Intersector::Watertight)
}

/// The value at quantile `q` of `xs` (sorted in place); 0 for no values.
fn quantile(xs: &mut [f64], q: f64) -> f64 {
    xs.sort_by(f64::total_cmp);
    xs.get(((xs.len() as f64 - 1.0) * q).round() as usize)
        .copied()
        .unwrap_or(0.0)
}

/// The watertight scalar path against the f64 oracle over every triangle, on random rays
/// through a sphere and a slanted grid at every scale and offset.
///
/// Tolerances: hit/miss (or closest-triangle) disagreements at most 0.2% of the rays, for rays
/// that pass within rounding of a silhouette or a shared edge (the f32 and f64 tests see
/// different sides of it) — a disagreement with a `t` within the `t` tolerance on another
/// triangle is an edge tie, not counted; relative `t` error at the 99th percentile at most 2e-6
/// (≈ 17 ε: a handful of roundings of differences of `f32` inputs, which f64 computes exactly;
/// measured ≈ 3e-7), and never more than 1e-4 (grazing hits amplify the rounding of `det`;
/// measured max ≈ 8e-6). At scale 1e-6 and offsets ≥ 1e3 the mesh collapses to a few `f32`
/// points: no hits, which both sides must agree on.
#[test]
fn every_scale_and_offset_agrees_with_the_f64_oracle() {
    for scale in [1e-6f32, 1e-3, 1.0, 1e3, 1e6] {
        for offset in [0.0f32, 1e3, 1e5] {
            let center = Vec3::new(offset, -0.5 * offset, 0.25 * offset);
            let mut mesh = icosphere(center, scale, 3);
            mesh.append(&quad_grid(
                12,
                9,
                center - Vec3::new(1.5, 1.2, 0.3) * scale,
                Vec3::new(3.0, 0.4, 0.2) * scale,
                Vec3::new(-0.3, 2.5, 0.9) * scale,
            ))
            .expect("small meshes");
            let tree = build(&mesh);
            let rays = random_rays(&mesh.bounds(), 2000, 9);
            packets_equal_scalar(&mesh, &tree, &rays[..256], u64::MAX, Culling::AUTO);
            let tracer = watertight(&tree);
            let (mut disagreements, mut errors) = (0, Vec::new());
            for r in &rays {
                let hit = tracer.intersect(r);
                let reference = brute_force(&mesh, r);
                match reference {
                    Some(want) if hit.is_hit() => {
                        let error =
                            (f64::from(hit.t) - want.t).abs() / want.t.max(f64::MIN_POSITIVE);
                        if hit.triangle != want.triangle && error > 1e-2 {
                            disagreements += 1;
                        } else {
                            errors.push(error);
                        }
                    }
                    None if !hit.is_hit() => {}
                    _ => disagreements += 1,
                }
            }
            let (median, p99) = (quantile(&mut errors, 0.5), quantile(&mut errors, 0.99));
            let max = quantile(&mut errors, 1.0);
            eprintln!(
                "scale {scale:e} offset {offset:e}: {disagreements} disagreements in {} rays, \
                 relative t error median {median:.1e} p99 {p99:.1e} max {max:.1e}",
                rays.len()
            );
            let name = format!("scale {scale:e} offset {offset:e}");
            assert!(
                disagreements * 500 <= rays.len(),
                "{name}: {disagreements} disagreements"
            );
            assert!(
                p99 <= 2e-6 && max <= 1e-4,
                "{name}: t errors p99 {p99:e}, max {max:e}"
            );
        }
    }
}

/// Axis-parallel rays through the vertices and edge midpoints of a closed box, from outside
/// along each axis in both directions, hit its face at exactly the distance to it (the face's
/// coordinate and the origin's are small dyadic numbers, so `t` is exact); grazing rays in the
/// planes of the faces, and rays in the plane of a flat grid, give the scalar result on every
/// path, and a ray in the plane of every triangle it meets misses (det = 0 for both tests).
#[test]
fn axis_parallel_and_grazing_rays() {
    let n = 4;
    let mesh = closed_grid_box(n, Vec3::new(8.0, -4.0, 2.0), Vec3::splat(2.0));
    let tree = build(&mesh);
    let lo = mesh.bounds().min;
    let mut rays = Vec::new();
    for axis in 0..3 {
        for i in 0..=2 * n {
            for j in 0..=2 * n {
                // Lattice points at half the grid step: vertices and edge midpoints.
                let mut origin = lo;
                origin[(axis + 1) % 3] += i as f32 * 0.5;
                origin[(axis + 2) % 3] += j as f32 * 0.5;
                for sign in [1.0f32, -1.0] {
                    let mut o = origin;
                    o[axis] = if sign > 0.0 {
                        lo[axis] - 3.0
                    } else {
                        lo[axis] + 7.0
                    };
                    let mut direction = Vec3::ZERO;
                    direction[axis] = sign;
                    rays.push(Ray::new(o, direction));
                }
            }
        }
    }
    for intersector in Intersector::ALL {
        let tracer = watertight(&tree).with_intersector(intersector);
        for r in &rays {
            let hit = tracer.intersect(r);
            assert_eq!(hit.t, 3.0, "{intersector:?}: {r:?} → {hit:?}");
        }
    }
    // Grazing: in the plane of a face, from outside the box, across the face's grid lines.
    let mut grazing = Vec::new();
    let mut rng = Rng::new(4);
    for _ in 0..512 {
        let mut o = lo + Vec3::new(rng.range(-1.0, 5.0), rng.range(-1.0, 5.0), -1.0);
        o.z = lo.z;
        let d = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), 0.0);
        grazing.push(Ray::new(o, d));
    }
    rays.extend(&grazing);
    packets_equal_scalar(&mesh, &tree, &rays, u64::MAX, Culling::AUTO);
    // In the plane of a flat grid: every triangle it meets is edge-on.
    let flat = quad_grid(8, 8, Vec3::ZERO, Vec3::X, Vec3::Y);
    let flat_tree = build(&flat);
    let in_plane: Vec<Ray> = grazing
        .iter()
        .map(|r| {
            Ray::new(
                Vec3::new(r.origin.x - lo.x, r.origin.y - lo.y, 0.0) * 0.25,
                r.direction,
            )
        })
        .collect();
    packets_equal_scalar(&flat, &flat_tree, &in_plane, u64::MAX, Culling::AUTO);
    for intersector in Intersector::ALL {
        let tracer = watertight(&flat_tree).with_intersector(intersector);
        for r in &in_plane {
            assert!(!tracer.occluded(r), "{intersector:?}: {r:?} hits edge-on");
        }
    }
}

/// Rays starting on a surface: inward from a point of a closed box's face they always hit
/// something at `t ≥ 0` (the start triangle near 0, or the far side); outward, the only thing
/// to hit is the start surface itself, at `t` within 1e-5 of 0 (rounding of the start point,
/// relative to the box's size 4). Both on every path.
#[test]
fn rays_starting_on_a_surface() {
    let mesh = closed_grid_box(6, Vec3::new(-3.0, 1e3, 7.0), Vec3::splat(2.0));
    let tree = build(&mesh);
    let center = Vec3::new(-3.0, 1e3, 7.0);
    let mut rng = Rng::new(8);
    let mut inward = Vec::new();
    let mut outward = Vec::new();
    for _ in 0..4096 {
        let tri = mesh.triangle(rng.below(mesh.triangle_count() as u32) as usize);
        let (a, b) = (rng.next_f32(), rng.next_f32());
        let (a, b) = if a + b > 1.0 {
            (1.0 - a, 1.0 - b)
        } else {
            (a, b)
        };
        let start = tri.v0 + (tri.v1 - tri.v0) * a + (tri.v2 - tri.v0) * b;
        let to_inside = center + rng.unit_vector() - start;
        inward.push(Ray::new(start, to_inside));
        outward.push(Ray::new(start, -to_inside));
    }
    for intersector in Intersector::ALL {
        let tracer = watertight(&tree).with_intersector(intersector);
        for r in &inward {
            let hit = tracer.intersect(r);
            assert!(
                hit.is_hit() && hit.t >= 0.0,
                "{intersector:?}: {r:?} → {hit:?}"
            );
        }
        for r in &outward {
            let hit = tracer.intersect(r);
            assert!(
                !hit.is_hit() || hit.t * r.direction.length() <= 1e-5 * 4.0,
                "{intersector:?}: {r:?} → {hit:?}"
            );
        }
    }
    inward.extend(outward);
    packets_equal_scalar(&mesh, &tree, &inward, u64::MAX, Culling::AUTO);
}

/// Degenerate triangles (a repeated index, or two indices of one position) are never hit, not
/// even by rays aimed at their vertices, edges and centroids, on any path, while a proper
/// triangle beside them is.
#[test]
fn degenerate_triangles_are_never_hit() {
    let positions = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0], // = vertex 1
        [0.5, 0.5, 1.0],
        [5.0, 5.0, 0.0],
        [6.0, 5.0, 0.0],
        [5.0, 6.0, 0.0],
    ];
    let degenerate = [0u32, 0, 1, 1, 2, 2, 0, 1, 3, 4, 4, 4, 2, 4, 2, 1, 3, 4];
    let mut indices = degenerate.to_vec();
    indices.extend([5, 6, 7]);
    let mesh = Mesh::from_indexed(&positions, &indices).expect("valid mesh");
    let tree = build(&mesh);
    let mut rays = Vec::new();
    let mut rng = Rng::new(2);
    for face in degenerate.chunks(3) {
        let [a, b, c] = [0, 1, 2].map(|k| Vec3::from(positions[face[k] as usize]));
        for target in [a, b, c, (a + b) * 0.5, (b + c) * 0.5, (a + b + c) / 3.0] {
            for _ in 0..8 {
                let origin = target + rng.unit_vector() * 3.0;
                rays.push(Ray::new(origin, target - origin));
            }
        }
    }
    let proper = Ray::new(Vec3::new(5.25, 5.25, 2.0), -Vec3::Z);
    for intersector in Intersector::ALL {
        let tracer = watertight(&tree).with_intersector(intersector);
        for r in &rays {
            assert!(
                !tracer.occluded(r),
                "{intersector:?}: {r:?} hits a degenerate triangle"
            );
        }
        assert_eq!(tracer.intersect(&proper).triangle, 6, "{intersector:?}");
    }
    rays.push(proper);
    packets_equal_scalar(&mesh, &tree, &rays, u64::MAX, Culling::AUTO);
}

/// A flat mesh (every leaf box flat): rays from above and below at random points of the grid
/// all hit it, with `t` within 1e-6 relative of the oracle's (the plane z = 0.5 is exact in
/// `f32`, and so are the grid's vertices), on every path.
#[test]
fn flat_mesh_is_hit_everywhere() {
    let mesh = quad_grid(
        32,
        32,
        Vec3::new(-1.0, -1.0, 0.5),
        Vec3::X * 2.0,
        Vec3::Y * 2.0,
    );
    let tree = build(&mesh);
    assert!(tree
        .leaves()
        .iter()
        .all(|l| l.count == 0 || l.bounds.extent().z == 0.0));
    let mut rng = Rng::new(3);
    let rays: Vec<Ray> = (0..4096)
        .map(|k| {
            let target = Vec3::new(rng.range(-0.99, 0.99), rng.range(-0.99, 0.99), 0.5);
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let origin = target + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), side);
            Ray::new(origin, target - origin)
        })
        .collect();
    let tracer = watertight(&tree);
    for r in &rays {
        let hit = tracer.intersect(r);
        let want = brute_force(&mesh, r).expect("the oracle hits the grid");
        assert!(
            hit.is_hit() && (f64::from(hit.t) - want.t).abs() <= 1e-6 * want.t,
            "{r:?}: {hit:?}, oracle {want:?}"
        );
    }
    packets_equal_scalar(&mesh, &tree, &rays, 0x5555_aaaa_ffff_0f0f, Culling::AUTO);
}

/// Rays that cannot be traced, placed among good ones in every packet shape.
fn untraceable() -> Vec<Ray> {
    let good = Ray::new(Vec3::new(0.1, 0.2, -5.0), Vec3::Z);
    let with = |f: fn(&mut Ray)| {
        let mut r = good;
        f(&mut r);
        r
    };
    vec![
        with(|r| r.origin.x = f32::NAN),
        with(|r| r.direction.y = f32::NAN),
        with(|r| r.direction.z = f32::INFINITY),
        with(|r| r.direction.x = f32::NEG_INFINITY),
        with(|r| r.origin.z = f32::NEG_INFINITY),
        with(|r| r.direction = Vec3::ZERO),
        with(|r| r.tmax = f32::NAN),
        with(|r| (r.tmin, r.tmax) = (2.0, 1.0)),
        with(|r| r.tmin = f32::NAN),
    ]
}

/// NaN and infinite lanes report a miss (and no occlusion) on every path, and the other lanes of
/// their packets equal the scalar results of their rays.
#[test]
fn nan_and_infinite_lanes_miss_and_leave_the_others_alone() {
    let mesh = icosphere(Vec3::ZERO, 1.0, 3);
    let tree = build(&mesh);
    let bad = untraceable();
    let scalar = watertight(&tree);
    for intersector in Intersector::ALL {
        for r in &bad {
            let t = scalar.with_intersector(intersector);
            assert_eq!(t.intersect(r), Hit::NONE, "{intersector:?}: {r:?}");
            assert!(!t.occluded(r), "{intersector:?}: {r:?}");
        }
    }
    // Interleave: every packet of every shape gets bad lanes at varying positions.
    let good = kdbeam::Camera::standard(&mesh.bounds(), 16, 16).rays();
    let mut rays = Vec::new();
    for (k, r) in good.iter().enumerate() {
        rays.push(*r);
        if k % 3 == 1 {
            rays.push(bad[k / 3 % bad.len()]);
        }
    }
    packets_equal_scalar(&mesh, &tree, &rays, u64::MAX, Culling::AUTO);
    packets_equal_scalar(&mesh, &tree, &rays, 0xdead_beef_f00d_cafe, Culling::AUTO);
}

/// All-inactive packets (and active bits past the packet's rays, and packets of no rays) report
/// nothing: every hit is [`Hit::NONE`], whatever the hit record held before, and no ray is
/// occluded.
#[test]
fn inactive_packets_report_nothing() {
    let mesh = icosphere(Vec3::ZERO, 1.0, 2);
    let tree = build(&mesh);
    let rays: Vec<Ray> = (0..64)
        .map(|k| Ray::new(Vec3::new(k as f32 * 0.01, 0.0, -5.0), Vec3::Z))
        .collect();
    let stale = Hit {
        t: 1.0,
        u: 0.5,
        v: 0.25,
        triangle: 7,
    };
    for isa in Isa::available() {
        for intersector in Intersector::ALL {
            let tracer = Tracer::new(&tree)
                .with_isa(isa)
                .expect("available")
                .with_intersector(intersector);
            for shape in PacketShape::ALL {
                let n = shape.ray_count();
                let p = RayPacket::from_rays(&rays[..n]);
                // No active ray, and only bits past the rays.
                let past = if n == 64 { 0 } else { !p.full_mask() };
                for active in [0, past] {
                    let mut hits = HitPacket::default();
                    for j in 0..64 {
                        (hits.t[j], hits.u[j], hits.v[j], hits.triangle[j]) =
                            (stale.t, stale.u, stale.v, stale.triangle);
                    }
                    tracer.intersect_packet(&p, active, &mut hits);
                    for j in 0..n {
                        assert_eq!(hits.hit(j), Hit::NONE, "{isa} {intersector:?} {shape:?}");
                    }
                    assert_eq!(tracer.occluded_packet(&p, active), 0);
                }
            }
            let empty = RayPacket::from_rays(&[]);
            let mut hits = HitPacket::default();
            tracer.intersect_packet(&empty, u64::MAX, &mut hits);
            assert_eq!(tracer.occluded_packet(&empty, u64::MAX), 0);
        }
    }
}

/// The empty scene builds, and every ray misses it: single rays, packets and streams, including
/// the empty stream.
#[test]
fn the_empty_scene_is_missed_by_every_ray() {
    let mesh = Mesh::default();
    let tree = build(&mesh);
    let mut rays = random_rays(&icosphere(Vec3::ZERO, 1.0, 1).bounds(), 300, 1);
    rays.extend(untraceable());
    rays.push(Ray::new(Vec3::ZERO, Vec3::X));
    for r in &rays {
        assert_eq!(watertight(&tree).intersect(r), Hit::NONE);
    }
    packets_equal_scalar(&mesh, &tree, &rays, u64::MAX, Culling::AUTO);
    let tracer = Tracer::new(&tree);
    let mut hits = vec![
        Hit {
            t: 0.0,
            u: 0.0,
            v: 0.0,
            triangle: 0
        };
        rays.len()
    ];
    tracer
        .intersect_stream(&rays, &mut hits)
        .expect("lengths match");
    assert!(hits.iter().all(|h| *h == Hit::NONE));
    let mut occluded = vec![true; rays.len()];
    tracer
        .occluded_stream(&rays, &mut occluded)
        .expect("lengths match");
    assert!(occluded.iter().all(|o| !o));
    tracer.intersect_stream(&[], &mut []).expect("empty stream");
    tracer.occluded_stream(&[], &mut []).expect("empty stream");
}

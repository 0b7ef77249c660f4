//! `Scene` against brute force over its world-space triangles, with instances under rotations,
//! non-uniform scales and mirrors, masks and a rejecting filter; ids, stale ids, updates and
//! tracing from many threads.

use glam::{Affine3A, DVec3, EulerRot, Quat};
use kdbeam::kernels::intersect::oracle::OracleRay;
use kdbeam::rays::random_rays;
use kdbeam::scene::procedural::{icosphere, quad_grid, triangle_soup};
use kdbeam::scene::rng::Rng;
use kdbeam::scene::world::{Query, SceneHit};
use kdbeam::Isa;
use kdbeam::{
    Aabb, BuildParams, Error, GeometryId, InstanceId, Intersector, KdTree, Mesh, Ray, RayPacket,
    Scene, Triangle, Vec3,
};

/// One world-space triangle and where it comes from.
struct WorldTriangle {
    tri: Triangle,
    geometry: GeometryId,
    instance: InstanceId,
    triangle: u32,
    mask: u32,
}

/// The scene's triangles in world space, for the brute force.
fn world_triangles(
    scene: &Scene,
    as_is: &[GeometryId],
    instances: &[(InstanceId, u32)],
) -> Vec<WorldTriangle> {
    let mut out = Vec::new();
    for &g in as_is {
        for (i, tri) in scene.mesh(g).unwrap().triangles().enumerate() {
            out.push(WorldTriangle {
                tri,
                geometry: g,
                instance: InstanceId::NONE,
                triangle: i as u32,
                mask: u32::MAX,
            });
        }
    }
    for &(inst, mask) in instances {
        let g = scene.instance_geometry(inst).unwrap();
        let m = scene.transform(inst).unwrap();
        for (i, t) in scene.mesh(g).unwrap().triangles().enumerate() {
            let tri = Triangle::new(
                m.transform_point3(t.v0),
                m.transform_point3(t.v1),
                m.transform_point3(t.v2),
            );
            out.push(WorldTriangle {
                tri,
                geometry: g,
                instance: inst,
                triangle: i as u32,
                mask,
            });
        }
    }
    out
}

/// The closest hit by the f64 oracle over every triangle the query sees: (t, index into
/// `tris`, smallest barycentric), and the second-closest `t`.
fn brute(
    tris: &[WorldTriangle],
    ray: &Ray,
    mask: u32,
    accept: &dyn Fn(&WorldTriangle) -> bool,
) -> Option<(f64, usize, f64, f64)> {
    let o = OracleRay::new(ray);
    let mut hits: Vec<(f64, usize, f64)> = tris
        .iter()
        .enumerate()
        .filter(|(_, w)| w.mask & mask != 0 && accept(w))
        .filter_map(|(i, w)| {
            let h = o.intersect(&w.tri, f64::from(ray.tmin), f64::from(ray.tmax))?;
            Some((h.t, i, h.u.min(h.v).min(1.0 - h.u - h.v)))
        })
        .collect();
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    let second = hits.get(1).map_or(f64::INFINITY, |h| h.0);
    hits.first().map(|&(t, i, b)| (t, i, b, second))
}

/// Distance from `p` to the triangle (C. Ericson, *Real-Time Collision Detection*, 5.1.5), in f64.
fn distance(p: DVec3, tri: &Triangle) -> f64 {
    let (a, b, c) = (tri.v0.as_dvec3(), tri.v1.as_dvec3(), tri.v2.as_dvec3());
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return p.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = 1.0 / (va + vb + vc);
    p.distance(a + ab * (vb * denom) + ac * (vc * denom))
}

/// A scene of a ground mesh traced as it is and 60 instances of two prototypes under random
/// rotations, non-uniform scales (some mirrored) and translations, masks `1 << (i % 4)`.
fn build_scene(seed: u64) -> (Scene, Vec<GeometryId>, Vec<(InstanceId, u32)>) {
    let mut rng = Rng::new(seed);
    let mut scene = Scene::new();
    let ground = scene
        .add_mesh(quad_grid(
            8,
            8,
            Vec3::new(-12.0, -3.0, -12.0),
            Vec3::new(24.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 24.0),
        ))
        .unwrap();
    let sphere = scene.add_prototype(icosphere(Vec3::ZERO, 1.0, 2)).unwrap();
    let soup = scene.add_prototype(triangle_soup(200, seed)).unwrap();
    let mut instances = Vec::new();
    for i in 0..60u32 {
        let mut scale = Vec3::new(
            rng.range(0.5, 2.0),
            rng.range(0.5, 2.0),
            rng.range(0.5, 2.0),
        );
        if i % 5 == 0 {
            scale.x = -scale.x;
        }
        let m = Affine3A::from_scale_rotation_translation(
            scale,
            Quat::from_euler(
                EulerRot::XYZ,
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
                rng.range(-3.0, 3.0),
            ),
            Vec3::new(
                rng.range(-10.0, 10.0),
                rng.range(-2.0, 8.0),
                rng.range(-10.0, 10.0),
            ),
        );
        let mask = 1 << (i % 4);
        let g = if i % 2 == 0 { sphere } else { soup };
        instances.push((scene.add_instance_masked(g, m, mask).unwrap(), mask));
    }
    scene.commit().unwrap();
    (scene, vec![ground], instances)
}

/// Rays from around the scene to interior points of random triangles, and random rays.
fn rays(tris: &[WorldTriangle], count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let bounds = tris.iter().fold(Aabb::EMPTY, |b, w| {
        b.grow(w.tri.v0).grow(w.tri.v1).grow(w.tri.v2)
    });
    let mut out = random_rays(&bounds, count / 4, seed);
    while out.len() < count {
        let w = &tris[rng.below(tris.len() as u32) as usize];
        let (a, b) = (rng.range(0.05, 0.9), rng.range(0.05, 0.9));
        let (a, b) = if a + b > 0.95 {
            (1.0 - a, 1.0 - b)
        } else {
            (a, b)
        };
        let target = w.tri.v0 + (w.tri.v1 - w.tri.v0) * a + (w.tri.v2 - w.tri.v0) * b;
        let origin = Vec3::new(
            rng.range(bounds.min.x, bounds.max.x),
            rng.range(bounds.min.y, bounds.max.y),
            rng.range(bounds.min.z, bounds.max.z),
        );
        out.push(Ray::new(origin, target - origin));
    }
    out
}

/// Position tolerance: the rays are carried to object space and back through f32 transforms
/// whose entries are at most ~2 in magnitude, over coordinates up to ~30, a few roundings of
/// `2^-24` each: 1e-4 relative to the size of the scene is well above that and far below the
/// distances between different surfaces of the test scene.
fn tolerance(ray: &Ray, t: f64) -> f64 {
    1e-4 * (1.0 + ray.origin.as_dvec3().length() + t * ray.direction.as_dvec3().length())
}

/// Checks `hit` of `ray` against the brute force over the triangles the query sees.
/// Returns whether the hit was unambiguous (and so compared id for id).
fn check(
    tris: &[WorldTriangle],
    ray: &Ray,
    hit: &SceneHit,
    mask: u32,
    accept: &dyn Fn(&WorldTriangle) -> bool,
) -> bool {
    let truth = brute(tris, ray, mask, accept);
    if hit.is_hit() {
        // The point the scene reports lies on the triangle it names, which the query sees.
        let w = tris
            .iter()
            .find(|w| {
                w.geometry == hit.geometry
                    && w.instance == hit.instance
                    && w.triangle == hit.triangle
            })
            .expect("the hit names a triangle of the scene");
        assert!(
            w.mask & mask != 0 && accept(w),
            "{ray:?}: hit on a triangle the query does not see: {hit:?}"
        );
        let p = ray.origin.as_dvec3() + ray.direction.as_dvec3() * f64::from(hit.t);
        let tol = tolerance(ray, f64::from(hit.t));
        assert!(
            distance(p, &w.tri) <= tol,
            "{ray:?}: {hit:?} is {} off its triangle",
            distance(p, &w.tri)
        );
        if let Some((t, ..)) = truth {
            assert!(
                f64::from(hit.t) >= t - tol,
                "{ray:?}: {hit:?} before the closest hit at {t}"
            );
        }
    }
    // A hit well inside a triangle is found, at its t; a unique one with its ids.
    let Some((t, i, margin, second)) = truth else {
        return false;
    };
    if margin < 1e-3 {
        return false;
    }
    let tol = tolerance(ray, t);
    assert!(
        hit.is_hit() && f64::from(hit.t) <= t + tol,
        "{ray:?}: missed the hit at {t}: {hit:?}"
    );
    if second - t > 2.0 * tol {
        let w = &tris[i];
        assert_eq!(
            (hit.geometry, hit.instance, hit.triangle),
            (w.geometry, w.instance, w.triangle),
            "{ray:?}"
        );
        return true;
    }
    false
}

fn rejected(geometry: GeometryId, instance: InstanceId, triangle: u32) -> bool {
    (triangle.wrapping_mul(7) ^ instance.0.wrapping_mul(13) ^ geometry.0).is_multiple_of(3)
}

#[test]
fn closest_and_any_hits_match_brute_force_with_masks_and_filters() {
    let (mut scene, as_is, instances) = build_scene(3);
    let tris = world_triangles(&scene, &as_is, &instances);
    let rays = rays(&tris, 3000, 11);
    let filter = |h: &SceneHit| !rejected(h.geometry, h.instance, h.triangle);
    let accept_all = |_: &WorldTriangle| true;
    let accept_filtered = |w: &WorldTriangle| !rejected(w.geometry, w.instance, w.triangle);
    for intersector in Intersector::ALL {
        scene.set_intersector(intersector);
        let mut unambiguous = 0;
        for (mask, filtered) in [
            (u32::MAX, false),
            (0b0101, false),
            (u32::MAX, true),
            (0b0110, true),
        ] {
            let query = Query {
                mask,
                filter: filtered.then_some(&filter as _),
            };
            let accept: &dyn Fn(&WorldTriangle) -> bool = if filtered {
                &accept_filtered
            } else {
                &accept_all
            };
            for ray in &rays {
                let hit = scene.intersect_with(ray, &query);
                unambiguous += usize::from(check(&tris, ray, &hit, mask, accept));
                // Any hit: the closest accepted hit exists iff the ray is occluded, except
                // where the brute force's and the scene's hits are both near edges.
                let occluded = scene.occluded_with(ray, &query);
                if hit.is_hit() {
                    assert!(occluded, "{ray:?}: a closest hit but not occluded");
                } else if let Some((_, _, margin, _)) = brute(&tris, ray, mask, accept) {
                    assert!(
                        margin < 1e-3 || occluded,
                        "{ray:?}: occluded by brute force"
                    );
                }
            }
        }
        // Most rays aim inside triangles: most comparisons are id for id.
        assert!(
            unambiguous > rays.len(),
            "{intersector:?}: only {unambiguous} unambiguous hits"
        );
    }
}

#[test]
fn filtered_closest_hit_is_the_closest_accepted_hit_in_one_tree() {
    // Parallel triangles stacked along z, rejecting every second: the closest accepted hit is
    // behind rejected ones, which must not shorten the ray.
    let mut positions = Vec::new();
    for k in 0..40 {
        let z = 1.0 + k as f32 * 0.25;
        positions.extend([[0.0, 0.0, z], [4.0, 0.0, z], [0.0, 4.0, z]]);
    }
    let mesh = Mesh::from_soup(&positions).unwrap();
    let tree = kdbeam::KdTree::build(&mesh, &kdbeam::BuildParams::default()).unwrap();
    let mut rng = Rng::new(2);
    for _ in 0..500 {
        let ray = Ray::new(
            Vec3::new(rng.range(0.6, 1.5), rng.range(0.6, 1.5), 0.0),
            Vec3::new(rng.range(-0.05, 0.05), rng.range(-0.05, 0.05), 1.0),
        );
        let keep = |t: u32| t % 2 == 1 && t > 10;
        for intersector in Intersector::ALL {
            let h = kdbeam::trace::filtered::closest_hit(&tree, intersector, &ray, |h| {
                keep(h.triangle)
            });
            let truth = (0..40).filter(|&t| keep(t)).find(|&t| {
                OracleRay::new(&ray)
                    .intersect(&mesh.triangle(t as usize), 0.0, f64::INFINITY)
                    .is_some()
            });
            assert_eq!(h.is_hit().then_some(h.triangle), truth, "{ray:?}");
            assert_eq!(
                kdbeam::trace::filtered::any_hit(&tree, intersector, &ray, |h| keep(h.triangle)),
                truth.is_some()
            );
            assert!(!kdbeam::trace::filtered::any_hit(
                &tree,
                intersector,
                &ray,
                |_| false
            ));
            // Accepting everything is the tracer's closest hit, bit for bit.
            let all = kdbeam::trace::filtered::closest_hit(&tree, intersector, &ray, |_| true);
            let tracer = kdbeam::Tracer::new(&tree).with_intersector(intersector);
            assert_eq!(all, tracer.intersect(&ray));
        }
    }
}

#[test]
fn every_isa_gives_the_scalar_hits_bit_for_bit_with_and_without_a_filter() {
    // The scalar ISA is the reference the brute-force tests above check (on the preferred ISA
    // they check too); every other ISA must then give its hits exactly, filter or not.
    let (mut scene, as_is, instances) = build_scene(5);
    let tris = world_triangles(&scene, &as_is, &instances);
    let mut rays = rays(&tris, 1500, 9);
    rays[7].direction = Vec3::new(f32::NAN, 0.0, 1.0);
    let filter = |h: &SceneHit| !rejected(h.geometry, h.instance, h.triangle);
    let queries = [
        Query::default(),
        Query {
            mask: u32::MAX,
            filter: Some(&filter),
        },
    ];
    for intersector in Intersector::ALL {
        scene.set_intersector(intersector);
        scene.set_isa(Isa::Scalar).unwrap();
        let reference: Vec<Vec<(SceneHit, bool)>> = queries
            .iter()
            .map(|q| {
                rays.iter()
                    .map(|r| (scene.intersect_with(r, q), scene.occluded_with(r, q)))
                    .collect()
            })
            .collect();
        for isa in Isa::available() {
            scene.set_isa(isa).unwrap();
            assert_eq!(scene.isa(), isa);
            for (q, expected) in queries.iter().zip(&reference) {
                for (r, &(hit, occluded)) in rays.iter().zip(expected) {
                    assert_eq!(
                        scene.intersect_with(r, q),
                        hit,
                        "{isa:?} {intersector:?} {r:?}"
                    );
                    assert_eq!(scene.occluded_with(r, q), occluded, "{isa:?} {r:?}");
                }
            }
        }
    }
}

#[test]
fn streams_match_single_rays_and_threads_share_a_scene() {
    let (scene, as_is, instances) = build_scene(8);
    let tris = world_triangles(&scene, &as_is, &instances);
    let rays = rays(&tris, 2000, 4);
    let query = Query {
        mask: 0b1011,
        filter: None,
    };
    let single: Vec<SceneHit> = rays
        .iter()
        .map(|r| scene.intersect_with(r, &query))
        .collect();
    let mut stream = vec![SceneHit::NONE; rays.len()];
    scene.intersect_stream(&rays, &mut stream, &query).unwrap();
    assert_eq!(single, stream);
    let mut occluded = vec![false; rays.len()];
    scene.occluded_stream(&rays, &mut occluded, &query).unwrap();
    for (r, o) in rays.iter().zip(&occluded) {
        assert_eq!(*o, scene.occluded_with(r, &query));
    }
    assert!(matches!(
        scene.intersect_stream(&rays, &mut stream[1..], &query),
        Err(Error::InvalidParameter { .. })
    ));
    // Two threads trace the same committed scene through `&Scene`.
    std::thread::scope(|s| {
        let halves = rays.split_at(rays.len() / 2);
        let a = s.spawn(|| {
            halves
                .0
                .iter()
                .map(|r| scene.intersect_with(r, &query))
                .collect::<Vec<_>>()
        });
        let b = s.spawn(|| {
            halves
                .1
                .iter()
                .map(|r| scene.intersect_with(r, &query))
                .collect::<Vec<_>>()
        });
        let mut both = a.join().unwrap();
        both.extend(b.join().unwrap());
        assert_eq!(both, single);
    });
}

#[test]
fn normals_are_the_world_triangles_normals() {
    let (scene, as_is, instances) = build_scene(5);
    let tris = world_triangles(&scene, &as_is, &instances);
    let mut checked = 0;
    for ray in rays(&tris, 500, 9) {
        let hit = scene.intersect(&ray);
        let Some(n) = scene.normal(&hit) else {
            assert!(!hit.is_hit());
            continue;
        };
        let w = tris
            .iter()
            .find(|w| {
                (w.geometry, w.instance, w.triangle) == (hit.geometry, hit.instance, hit.triangle)
            })
            .unwrap();
        // The world triangle's own normal, flipped by a mirroring transform (the surface's
        // side is kept): equal to f32 rounding of the transform, 1e-4 on unit vectors.
        let flip = if hit.instance == InstanceId::NONE {
            1.0
        } else {
            scene
                .transform(hit.instance)
                .unwrap()
                .matrix3
                .determinant()
                .signum()
        };
        let expected = (w.tri.v1 - w.tri.v0).cross(w.tri.v2 - w.tri.v0).normalize() * flip;
        assert!(n.abs_diff_eq(expected, 1e-4), "{n} vs {expected}");
        checked += 1;
    }
    assert!(checked > 100);
    assert_eq!(scene.normal(&SceneHit::NONE), None);
}

#[test]
fn stale_ids_errors_and_commits() {
    let mut scene = Scene::new();
    let ray = Ray::new(Vec3::new(0.2, 0.2, -5.0), Vec3::Z);
    // Never committed: a miss, and the streams say why.
    assert!(!scene.intersect(&ray).is_hit() && !scene.occluded(&ray));
    let packet = RayPacket::from_rays(&[ray; 4]);
    assert_eq!(scene.occluded_packet(&packet, 0b1111, &Query::default()), 0);
    let mut out = [SceneHit::NONE];
    assert!(matches!(
        scene.intersect_stream(&[ray], &mut out, &Query::default()),
        Err(Error::NotCommitted)
    ));
    let tri = Mesh::from_indexed(
        &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
        &[0, 1, 2],
    )
    .unwrap();
    let a = scene.add_prototype(tri.clone()).unwrap();
    let b = scene.add_mesh(tri.clone()).unwrap();
    assert_eq!((a, b), (GeometryId(0), GeometryId(1)));
    let i0 = scene
        .add_instance(a, Affine3A::from_translation(Vec3::Z))
        .unwrap();
    scene.commit().unwrap();
    assert!(!scene.has_changes());
    let hit = scene.intersect(&ray);
    assert_eq!(
        (hit.t, hit.geometry, hit.instance),
        (5.0, b, InstanceId::NONE)
    );

    // Bad transforms leave the instance as it was.
    let bad = Affine3A::from_translation(Vec3::new(0.0, f32::INFINITY, 0.0));
    assert!(matches!(
        scene.set_transform(i0, bad),
        Err(Error::InvalidTransform(_))
    ));
    assert!(matches!(
        scene.add_instance(a, Affine3A::from_scale(Vec3::ZERO)),
        Err(Error::InvalidTransform(_))
    ));
    assert_eq!(
        scene.transform(i0).unwrap(),
        Affine3A::from_translation(Vec3::Z)
    );

    // Removal: in use, then stale; changes are seen only after commit.
    assert!(matches!(
        scene.remove_geometry(a),
        Err(Error::GeometryInUse {
            geometry: 0,
            instances: 1
        })
    ));
    scene.remove_geometry(b).unwrap();
    assert_eq!(
        scene.intersect(&ray).geometry,
        b,
        "the last commit is still traced"
    );
    scene.commit().unwrap();
    let hit = scene.intersect(&ray);
    assert_eq!((hit.t, hit.geometry, hit.instance), (6.0, a, i0));
    scene.remove_instance(i0).unwrap();
    assert!(matches!(
        scene.remove_instance(i0),
        Err(Error::UnknownInstance(0))
    ));
    assert!(matches!(
        scene.set_transform(i0, Affine3A::IDENTITY),
        Err(Error::UnknownInstance(0))
    ));
    assert!(matches!(
        scene.set_instance_mask(InstanceId(7), 1),
        Err(Error::UnknownInstance(7))
    ));
    assert!(matches!(scene.mesh(b), Err(Error::UnknownGeometry(1))));
    assert!(matches!(
        scene.add_instance(b, Affine3A::IDENTITY),
        Err(Error::UnknownGeometry(1))
    ));
    assert!(matches!(
        scene.update_positions(b, &[[0.0; 3]; 3]),
        Err(Error::UnknownGeometry(1))
    ));
    scene.commit().unwrap();
    assert!(!scene.intersect(&ray).is_hit());

    // Re-adding issues new ids, never the removed ones.
    let c = scene.add_mesh(tri).unwrap();
    let i1 = scene
        .add_instance(c, Affine3A::from_translation(Vec3::NEG_Z))
        .unwrap();
    assert_eq!((c, i1), (GeometryId(2), InstanceId(1)));
    scene.commit().unwrap();
    let hit = scene.intersect(&ray);
    assert_eq!((hit.t, hit.geometry, hit.instance), (4.0, c, i1));

    // Updates keep the topology and are validated.
    assert!(matches!(
        scene.update_positions(c, &[[0.0; 3]; 2]),
        Err(Error::VertexCountChanged {
            expected: 3,
            given: 2,
            ..
        })
    ));
    assert!(matches!(
        scene.update_positions(c, &[[0.0, f32::NAN, 0.0]; 3]),
        Err(Error::NonFinite { .. })
    ));
    scene
        .update_positions(c, &[[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0]])
        .unwrap();
    scene.commit().unwrap();
    let hit = scene.intersect(&ray);
    assert_eq!((hit.t, hit.geometry, hit.instance), (6.0, c, i1));
    assert_eq!(scene.normal(&hit), Some(Vec3::Z));
}

#[test]
fn moving_instances_match_brute_force_after_each_commit() {
    let (mut scene, as_is, mut instances) = build_scene(21);
    let mut rng = Rng::new(77);
    for round in 0..3 {
        for &(i, _) in instances.iter().step_by(2) {
            let m = scene.transform(i).unwrap();
            let moved = Affine3A::from_translation(Vec3::new(
                rng.range(-3.0, 3.0),
                rng.range(-1.0, 1.0),
                rng.range(-3.0, 3.0),
            )) * m;
            scene.set_transform(i, moved).unwrap();
        }
        if round == 1 {
            let (gone, _) = instances.remove(3);
            scene.remove_instance(gone).unwrap();
        }
        scene.commit().unwrap();
        let tris = world_triangles(&scene, &as_is, &instances);
        for ray in rays(&tris, 800, round) {
            check(&tris, &ray, &scene.intersect(&ray), u32::MAX, &|_| true);
        }
    }
}

#[test]
fn packets_match_single_rays_bit_for_bit() {
    let (mut scene, as_is, instances) = build_scene(13);
    let tris = world_triangles(&scene, &as_is, &instances);
    // Coherent packets (8×8 tiles of a pinhole camera) and incoherent ones (random rays).
    let eye = Vec3::new(0.0, 4.0, -25.0);
    let mut coherent = Vec::new();
    for tile in 0..16 {
        for k in 0..64 {
            let (x, y) = ((tile % 4) * 8 + k % 8, (tile / 4) * 8 + k / 8);
            let d = Vec3::new(x as f32 / 32.0 - 0.5, 0.5 - y as f32 / 32.0, 1.0);
            coherent.push(Ray::new(eye, d));
        }
    }
    let mut all = coherent;
    all.extend(rays(&tris, 1024, 6));
    all[70].direction = Vec3::new(f32::NAN, 0.0, 1.0);
    let filter = |h: &SceneHit| !rejected(h.geometry, h.instance, h.triangle);
    for intersector in Intersector::ALL {
        scene.set_intersector(intersector);
        for query in [
            Query::default(),
            Query {
                mask: 0b1001,
                filter: None,
            },
            Query {
                mask: u32::MAX,
                filter: Some(&filter),
            },
        ] {
            for chunk in all.chunks(64) {
                let packet = RayPacket::from_rays(chunk);
                let active = packet.full_mask() & !0b100;
                let mut hits = vec![SceneHit::NONE; 64];
                hits[2].t = 1.0;
                scene
                    .intersect_packet(&packet, active, &query, &mut hits)
                    .unwrap();
                assert_eq!(hits[2].t, 1.0, "an inactive ray's hit is untouched");
                for (i, r) in chunk.iter().enumerate().filter(|&(i, _)| i != 2) {
                    assert_eq!(
                        hits[i],
                        scene.intersect_with(r, &query),
                        "{intersector:?} {r:?}"
                    );
                }
                // Any hit, with segments ending before, at and beyond the closest hits, in
                // packets of every size.
                let shadow: Vec<Ray> = chunk
                    .iter()
                    .enumerate()
                    .map(|(i, r)| Ray {
                        tmax: [4.0, 12.0, 20.0, 30.0, f32::INFINITY][i % 5],
                        ..*r
                    })
                    .collect();
                for n in [4, 16, 64].into_iter().filter(|&n| n <= shadow.len()) {
                    for part in shadow.chunks(n) {
                        let packet = RayPacket::from_rays(part);
                        let active = packet.full_mask() & !0b100;
                        let occluded = scene.occluded_packet(&packet, active, &query);
                        for (i, r) in part.iter().enumerate() {
                            let expected = i != 2 && scene.occluded_with(r, &query);
                            assert_eq!(occluded >> i & 1 == 1, expected, "{intersector:?} {r:?}");
                        }
                    }
                }
            }
        }
    }
    let packet = RayPacket::from_rays(&all[..8]);
    let mut short = [SceneHit::NONE; 4];
    assert!(matches!(
        scene.intersect_packet(&packet, packet.full_mask(), &Query::default(), &mut short),
        Err(Error::InvalidParameter { .. })
    ));
}

/// A sphere of small triangles on a floor of two large ones: most of its surface in large
/// triangles, so its own tree is bigger than the default.
fn sphere_on_floor() -> Mesh {
    let mut mesh = icosphere(Vec3::new(0.0, 1.0, 0.0), 1.0, 3);
    let floor = quad_grid(
        1,
        1,
        Vec3::new(-50.0, 0.0, -50.0),
        Vec3::new(100.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 100.0),
    );
    mesh.append(&floor).unwrap();
    mesh
}

#[test]
fn each_mesh_gets_its_own_tree_until_parameters_are_set() {
    let (uneven, even) = (sphere_on_floor(), icosphere(Vec3::ZERO, 1.0, 3));
    let own = BuildParams::for_mesh(&uneven);
    assert!(
        own.ci_over_ct > 2.0 * BuildParams::default().ci_over_ct,
        "{own:?}"
    );
    assert_eq!(BuildParams::for_mesh(&even), BuildParams::default());
    let built_nodes = |params: &BuildParams| KdTree::build(&uneven, params).unwrap().stats().nodes;
    assert_ne!(built_nodes(&own), built_nodes(&BuildParams::default()));

    let mut scene = Scene::new();
    let (u, e) = (
        scene.add_mesh(uneven.clone()).unwrap(),
        scene.add_mesh(even).unwrap(),
    );
    assert_eq!(scene.build_params(), None);
    assert!(scene.tree(u).unwrap().is_none(), "before the commit");
    scene.commit().unwrap();
    let nodes = |scene: &Scene, g| scene.tree(g).unwrap().unwrap().stats().nodes;
    assert_eq!(scene.geometry_build_params(u).unwrap(), own);
    assert_eq!(
        scene.geometry_build_params(e).unwrap(),
        BuildParams::default()
    );
    assert_eq!(nodes(&scene, u), built_nodes(&own));

    // Set for every mesh: the trees built with others are rebuilt; the same again rebuilds
    // nothing.
    let set = BuildParams::default().with_ci_over_ct(1.0);
    scene.set_build_params(set).unwrap();
    assert_eq!(scene.build_params(), Some(&set));
    assert!(scene.tree(e).unwrap().is_none());
    scene.commit().unwrap();
    assert_eq!(scene.geometry_build_params(e).unwrap(), set);
    assert_eq!(nodes(&scene, u), built_nodes(&set));
    scene.set_build_params(set).unwrap();
    assert!(!scene.has_changes());

    // Reset: each mesh's own again.
    scene.reset_build_params();
    assert!(scene.has_changes());
    scene.commit().unwrap();
    assert_eq!(nodes(&scene, u), built_nodes(&own));

    // The default set on a scene of even triangles: the trees already have it.
    let mut even_only = Scene::new();
    even_only.add_mesh(icosphere(Vec3::ZERO, 1.0, 2)).unwrap();
    even_only.commit().unwrap();
    even_only.set_build_params(BuildParams::default()).unwrap();
    assert!(!even_only.has_changes());
    even_only.reset_build_params();
    assert!(!even_only.has_changes());

    assert!(matches!(
        scene.geometry_build_params(GeometryId(7)),
        Err(Error::UnknownGeometry(7))
    ));
    assert!(matches!(
        scene.tree(GeometryId(7)),
        Err(Error::UnknownGeometry(7))
    ));
}

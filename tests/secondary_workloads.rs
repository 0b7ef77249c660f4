//! The secondary-ray workloads (`kdbeam::rays::secondary`): deterministic from the seed, free
//! of self-hits on closed meshes, and traced as any-hit queries with the answers closest-hit
//! queries imply, on every ISA, packet size and packet layout (pixel tiles, sorted streams).

mod common;

use kdbeam::rays::secondary::{light, primary_hits, SecondaryRays, Workload, AO_RADIUS};
use kdbeam::rays::stream::{intersect_sorted, occluded_sorted};
use kdbeam::scene::procedural;
use kdbeam::trace::Frustum;
use kdbeam::{BuildParams, Camera, Culling, Hit, Isa, KdTree, Mesh, PacketShape, Tracer, Vec3};

const WORKLOADS: [Workload; 3] = [
    Workload::Shadow,
    Workload::AmbientOcclusion { rays: 4 },
    Workload::Diffuse,
];

fn tree(mesh: &Mesh) -> KdTree {
    KdTree::build(mesh, &BuildParams::default()).expect("tree builds")
}

#[test]
fn the_same_seed_gives_the_same_rays_and_another_seed_other_rays() {
    let mesh = procedural::builtin("default").expect("built-in scene");
    let tree = tree(&mesh);
    let tracer = Tracer::new(&tree);
    let camera = Camera::standard(&mesh.bounds(), 48, 40);
    for workload in WORKLOADS {
        let a = SecondaryRays::from_camera(workload, &tracer, &mesh, &camera, 7).expect("rays");
        let b = SecondaryRays::from_camera(workload, &tracer, &mesh, &camera, 7).expect("rays");
        assert_eq!(a, b, "{}", workload.name());
        assert!(
            !a.is_empty(),
            "{}: the camera sees the scene",
            workload.name()
        );
        let hits = primary_hits(&tracer, &camera)
            .iter()
            .filter(|h| h.is_hit())
            .count();
        assert_eq!(a.len(), hits * workload.rays_per_hit() as usize);
        let c = SecondaryRays::from_camera(workload, &tracer, &mesh, &camera, 8).expect("rays");
        assert_eq!(a.pixels, c.pixels, "the seed never moves the origins");
        let differ = a.rays.iter().zip(&c.rays).filter(|(x, y)| x != y).count();
        if workload == Workload::Shadow {
            assert_eq!(differ, 0, "shadow rays draw nothing");
        } else {
            assert!(
                differ > a.len() * 9 / 10,
                "{}: {differ} of {} differ",
                workload.name(),
                a.len()
            );
        }
    }
}

#[test]
fn the_rays_follow_the_definitions() {
    let mesh = procedural::builtin("default").expect("built-in scene");
    let tree = tree(&mesh);
    let tracer = Tracer::new(&tree);
    let camera = Camera::standard(&mesh.bounds(), 32, 32);
    let bounds = mesh.bounds();
    let diagonal = bounds.extent().length();
    let (c, e) = (bounds.center(), bounds.extent());
    assert_eq!(light(&bounds), c + Vec3::new(0.5 * e.x, 1.5 * e.y, -e.z));
    let primary = primary_hits(&tracer, &camera);
    for workload in WORKLOADS {
        let rays = SecondaryRays::new(workload, &mesh, &camera, &primary, 3).expect("rays");
        for (ray, &pixel) in rays.rays.iter().zip(&rays.pixels) {
            let hit = primary[pixel as usize];
            let tri = mesh.triangle(hit.triangle as usize);
            let mut n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).normalize();
            let incoming = camera.ray(pixel % 32, pixel / 32);
            if n.dot(incoming.direction) > 0.0 {
                n = -n;
            }
            // The origin is 1e-4·D above the triangle's plane, on the camera's side: the
            // distance is exact up to the rounding of the hit point and the offset (a few ulps
            // of the coordinates, far below 1e-6·D in this unit-sized scene).
            let height = (ray.origin - tri.v0).dot(n);
            assert!(
                (height - 1e-4 * diagonal).abs() < 1e-6 * diagonal,
                "height {height}"
            );
            assert!((ray.direction.length() - 1.0).abs() < 1e-5);
            match workload {
                Workload::Shadow => {
                    let to_light = light(&bounds) - ray.origin;
                    assert!(ray.direction.abs_diff_eq(to_light.normalize(), 1e-5));
                    assert!((ray.tmax - to_light.length()).abs() <= 1e-5 * to_light.length());
                }
                Workload::AmbientOcclusion { .. } => {
                    assert!(ray.direction.dot(n) > -1e-6, "in the hemisphere");
                    assert_eq!(ray.tmax, AO_RADIUS * diagonal);
                }
                Workload::Diffuse => {
                    assert!(ray.direction.dot(n) > -1e-6, "in the hemisphere");
                    assert_eq!(ray.tmax, f32::INFINITY);
                }
            }
        }
    }
}

/// Two closed spheres side by side: secondary rays leaving one sphere's outside can hit the
/// other sphere, but never the sphere they leave (it is convex: its whole surface lies below
/// the tangent plane). A self-hit, from too small an offset or a normal turned the wrong way,
/// is a hit on the sphere of the ray's own triangle.
#[test]
fn offsets_give_no_self_hits_on_closed_meshes() {
    let mut mesh = procedural::icosphere(Vec3::ZERO, 1.0, 4);
    let first = mesh.triangle_count() as u32;
    mesh.append(&procedural::icosphere(Vec3::new(2.6, 0.3, 0.4), 1.2, 4))
        .expect("two spheres");
    let sphere = |t: u32| t >= first;
    let tree = tree(&mesh);
    let tracer = Tracer::new(&tree);
    let camera = Camera::standard(&mesh.bounds(), 96, 96);
    let primary = primary_hits(&tracer, &camera);
    for workload in [
        Workload::AmbientOcclusion { rays: 8 },
        Workload::Diffuse,
        Workload::Shadow,
    ] {
        let rays = SecondaryRays::new(workload, &mesh, &camera, &primary, 1).expect("rays");
        let (mut other, mut lit) = (0, 0);
        for (ray, &pixel) in rays.rays.iter().zip(&rays.pixels) {
            let from = primary[pixel as usize].triangle;
            let tri = mesh.triangle(from as usize);
            let n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0);
            let facing = ray.direction.dot(n) * (ray.origin - tri.v0).dot(n) > 0.0;
            if workload == Workload::Shadow && !facing {
                continue; // A surface turned away from the light is shadowed by itself.
            }
            lit += 1;
            let hit = tracer.intersect(ray);
            if hit.is_hit() {
                assert_ne!(
                    sphere(hit.triangle),
                    sphere(from),
                    "{}: a ray from triangle {from} hits its own sphere (triangle {}, t {})",
                    workload.name(),
                    hit.triangle,
                    hit.t
                );
                other += 1;
            }
        }
        assert!(lit > 1000, "{}: {lit} rays checked", workload.name());
        if workload != Workload::Shadow {
            assert!(
                other > 0,
                "{}: some rays reach the other sphere",
                workload.name()
            );
        }
    }
}

/// Every tracing of the any-hit workloads answers "occluded" exactly when the scalar closest
/// hit exists: single rays, pixel-tile packets of every shape on every ISA (unculled and
/// with the default culling), and sorted streams. The diffuse bounce's closest hits are the
/// scalar ones, bit for bit, in tiles and in streams.
#[test]
fn any_hit_agrees_with_closest_hit_on_every_isa_and_packet_size() {
    let scenes = [
        (
            "default",
            procedural::builtin("default").expect("built-in scene"),
        ),
        (
            "terrain",
            procedural::builtin("terrain:40").expect("built-in scene"),
        ),
    ];
    for (name, mesh) in scenes {
        let tree = tree(&mesh);
        let scalar = Tracer::new(&tree);
        let camera = Camera::standard(&mesh.bounds(), 40, 40);
        let primary = primary_hits(&scalar, &camera);
        for workload in WORKLOADS {
            let rays = SecondaryRays::new(workload, &mesh, &camera, &primary, 5).expect("rays");
            let closest: Vec<Hit> = rays.rays.iter().map(|r| scalar.intersect(r)).collect();
            let occluded = closest.iter().filter(|h| h.is_hit()).count();
            if name == "default" {
                let what = workload.name();
                assert!(
                    occluded > 0 && occluded < rays.len(),
                    "{name} {what}: a mix"
                );
            }
            if workload.any_hit() {
                for (r, h) in rays.rays.iter().zip(&closest) {
                    assert_eq!(scalar.occluded(r), h.is_hit(), "{name} single {r:?}");
                }
            }
            for isa in Isa::available() {
                for culling in [
                    Culling::NONE,
                    Culling::AUTO,
                    Culling::FULL.with_frustum(Frustum::Masked),
                ] {
                    for shape in PacketShape::ALL {
                        let tracer = Tracer::new(&tree)
                            .with_isa(isa)
                            .expect("available")
                            .with_culling(culling)
                            .with_packet(shape);
                        let what = format!("{name} {} {isa} {culling} {shape:?}", workload.name());
                        check_tiles(&tracer, &rays, &camera, &closest, workload, shape, &what);
                        check_stream(&tracer, &rays, &mesh, &closest, workload, &what);
                    }
                }
            }
        }
    }
}

fn check_tiles(
    tracer: &Tracer<'_>,
    rays: &SecondaryRays,
    camera: &Camera,
    closest: &[Hit],
    workload: Workload,
    shape: PacketShape,
    what: &str,
) {
    let tiles = rays.tile_packets(camera, shape);
    let mut seen = vec![0u32; rays.len()];
    let mut lanes = tiles.rays.iter();
    for p in &tiles.packets {
        assert!(!p.is_empty() && p.len() <= shape.ray_count());
        let mut hits = kdbeam::HitPacket::default();
        let bits = workload
            .any_hit()
            .then(|| tracer.occluded_packet(p, p.full_mask()));
        if !workload.any_hit() {
            tracer.intersect_packet(p, p.full_mask(), &mut hits);
        }
        for j in 0..p.len() {
            let i = *lanes.next().expect("a ray per lane") as usize;
            seen[i] += 1;
            assert_eq!(p.ray(j), rays.rays[i], "{what}: lane {j}");
            match bits {
                Some(bits) => {
                    assert_eq!(bits >> j & 1 != 0, closest[i].is_hit(), "{what}: ray {i}")
                }
                None => assert_eq!(hits.hit(j), closest[i], "{what}: ray {i}"),
            }
        }
    }
    assert!(
        seen.iter().all(|&s| s == 1),
        "{what}: every ray in exactly one packet"
    );
}

fn check_stream(
    tracer: &Tracer<'_>,
    rays: &SecondaryRays,
    mesh: &Mesh,
    closest: &[Hit],
    workload: Workload,
    what: &str,
) {
    if workload.any_hit() {
        let mut occluded = vec![false; rays.len()];
        occluded_sorted(tracer, &rays.rays, &mesh.bounds(), &mut occluded).expect("lengths");
        for (i, (o, h)) in occluded.iter().zip(closest).enumerate() {
            assert_eq!(*o, h.is_hit(), "{what} stream: ray {i}");
        }
    } else {
        let mut hits = vec![Hit::NONE; rays.len()];
        intersect_sorted(tracer, &rays.rays, &mesh.bounds(), &mut hits).expect("lengths");
        assert_eq!(hits, closest, "{what} stream");
    }
}

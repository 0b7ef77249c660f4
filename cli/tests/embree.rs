//! Embree against kdbeam's watertight scalar path, on the same rays (`--features embree`).
#![cfg(feature = "embree")]

#[path = "../../tests/common/mod.rs"]
mod common;

use kdbeam::kernels::intersect::watertight::WatertightRay;
use kdbeam::rays::{random_rays, Camera};
use kdbeam::{BuildParams, Hit, Intersector, KdTree, Mesh, Ray, Tracer, Triangle, Vec3};
use kdbeam_cli::embree::{
    primary_rays, Context, EmbreeOptions, EmbreeRays, EmbreeScene, QUERY_WIDTHS,
};

/// Relative tolerance on `t` when both report the same triangle. Both compute `t` in `f32`
/// from the same vertices (Embree's robust mode by a Plücker-style test, kdbeam by the sheared
/// watertight test), which differ by a few ulps (~1e-7); 1e-4 leaves room for grazing hits,
/// whose `t` is ill-conditioned, while still catching a wrong ray parameterisation. Hits closer
/// than 1% of the scene's diagonal are measured against that distance instead: a random origin
/// next to a surface makes `t` tiny, and an ulp of the hit point huge relative to it.
const T_TOLERANCE: f32 = 1e-4;

/// How far the tie test moves each vertex away from the centroid, in ulps of the largest
/// coordinate of the triangle and the ray origin: far more than either test's rounding of the
/// hit point, far less than any gap between triangles of the test scenes.
const TIE_ULPS: f32 = 64.0;

/// The share of rays on which both must agree (hit/miss, triangle, `t`; ties count as agreeing).
const MIN_AGREEMENT: f64 = 0.999;

/// How two hit lists compare.
///
/// A *tie* is a ray whose two reported triangles differ but both lie at the same `t`, the ray
/// passing through (or within rounding of) an edge they share: kdbeam reports the smaller id,
/// Embree either, and the two tests may put a ray within an ulp of the edge on different
/// sides. It is detected by kdbeam's watertight test on Embree's triangle grown by
/// [`TIE_ULPS`] about its centroid: a hit within [`T_TOLERANCE`] of kdbeam's `t`.
/// Ties are reported, not counted as errors: either triangle is a correct answer.
struct Agreement {
    /// 1% of the scene's diagonal (see [`T_TOLERANCE`]).
    near: f32,
    rays: usize,
    agree: usize,
    ties: usize,
    hit_vs_miss: usize,
    other_triangle: usize,
    t_outside_tolerance: usize,
    max_t_error: f32,
}

impl Agreement {
    fn new(mesh: &Mesh) -> Self {
        Agreement {
            near: 0.01 * mesh.bounds().extent().length(),
            rays: 0,
            agree: 0,
            ties: 0,
            hit_vs_miss: 0,
            other_triangle: 0,
            t_outside_tolerance: 0,
            max_t_error: 0.0,
        }
    }

    fn add(&mut self, mesh: &Mesh, ray: &Ray, embree: &Hit, kdbeam: &Hit) {
        self.rays += 1;
        let near = self.near / ray.direction.length();
        let relative = |t: f32| (t - kdbeam.t).abs() / kdbeam.t.abs().max(near);
        if embree.is_hit() != kdbeam.is_hit() {
            self.hit_vs_miss += 1;
        } else if embree.triangle != kdbeam.triangle {
            let tri = grown(mesh.triangle(embree.triangle as usize), ray.origin);
            match WatertightRay::new(ray).intersect(&tri, ray.tmin, ray.tmax) {
                Some(h) if relative(h.t) <= T_TOLERANCE => self.ties += 1,
                _ => self.other_triangle += 1,
            }
        } else if embree.is_hit() {
            let err = relative(embree.t);
            self.max_t_error = self.max_t_error.max(err);
            if err <= T_TOLERANCE {
                self.agree += 1;
            } else {
                self.t_outside_tolerance += 1;
            }
        } else {
            self.agree += 1;
        }
    }

    fn share(&self) -> f64 {
        (self.agree + self.ties) as f64 / self.rays.max(1) as f64
    }

    fn check(&self, what: &str) {
        println!(
            "{what}: {}/{} agree ({:.4}%, {} of them ties), {} hit vs miss, {} other triangle, {} t outside {T_TOLERANCE:e}, max relative t error {:.2e}",
            self.agree + self.ties,
            self.rays,
            100.0 * self.share(),
            self.ties,
            self.hit_vs_miss,
            self.other_triangle,
            self.t_outside_tolerance,
            self.max_t_error,
        );
        assert!(
            self.share() >= MIN_AGREEMENT,
            "{what}: only {:.4}% of rays agree",
            100.0 * self.share()
        );
    }
}

/// `tri` with each vertex moved [`TIE_ULPS`] ulps (of the largest coordinate of the vertices
/// and `origin`) away from the centroid.
fn grown(tri: Triangle, origin: Vec3) -> Triangle {
    let c = (tri.v0 + tri.v1 + tri.v2) / 3.0;
    let scale = [tri.v0, tri.v1, tri.v2, origin]
        .iter()
        .map(|v| v.abs().max_element())
        .fold(0.0, f32::max);
    let step = TIE_ULPS * f32::EPSILON * scale;
    let grow = |v: Vec3| v + (v - c).normalize_or_zero() * step;
    Triangle {
        v0: grow(tri.v0),
        v1: grow(tri.v1),
        v2: grow(tri.v2),
    }
}

/// The built-in scenes and the bunny (when the shared scenes are present).
fn scenes() -> Vec<(String, Mesh)> {
    let mut scenes = common::scenes(false);
    scenes.extend(common::scenes::load_shared("bunny").map(|mesh| ("bunny".to_string(), mesh)));
    scenes
}

fn watertight(tree: &KdTree) -> Tracer<'_> {
    Tracer::new(tree).with_intersector(Intersector::Watertight)
}

fn embree_hits(scene: &EmbreeScene, rays: &[Ray], width: usize, context: Context) -> Vec<Hit> {
    let mut hits = vec![Hit::NONE; rays.len()];
    scene
        .intersect_stream(rays, width, context, &mut hits)
        .expect("a valid width and matching lengths");
    hits
}

#[test]
fn primary_rays_agree_with_the_watertight_scalar_path() {
    for (name, mesh) in scenes() {
        let tree = KdTree::build(&mesh, &BuildParams::default()).expect("tree builds");
        let tracer = watertight(&tree);
        let scene = EmbreeScene::new(&mesh).expect("embree builds");
        let camera = Camera::standard(&tree.bounds(), 512, 512);
        let reference: Vec<Hit> = camera.rays().iter().map(|r| tracer.intersect(r)).collect();
        for width in QUERY_WIDTHS {
            let (rays, pixels) = primary_rays(&camera, width).expect("a valid width");
            for context in Context::ALL {
                let hits = embree_hits(&scene, &rays, width, context);
                let mut agreement = Agreement::new(&mesh);
                for ((hit, ray), &pixel) in hits.iter().zip(&rays).zip(&pixels) {
                    agreement.add(&mesh, ray, hit, &reference[pixel as usize]);
                }
                let context = context.name();
                agreement.check(&format!(
                    "{name} primary 512x512 rtcIntersect{width} {context}"
                ));
            }
        }
    }
}

#[test]
fn random_rays_agree_with_the_watertight_scalar_path() {
    // 4099 rays: the last packet of every width is partly filled. Flat scenes (the grid) are
    // left out: every random origin lies on their surface, where a hit at t = 0 is kdbeam's
    // (tmin inclusive) but not reliably Embree's.
    for (name, mesh) in common::scenes(false) {
        if mesh.bounds().extent().min_element() == 0.0 {
            continue;
        }
        let tree = KdTree::build(&mesh, &BuildParams::default()).expect("tree builds");
        let tracer = watertight(&tree);
        let scene = EmbreeScene::new(&mesh).expect("embree builds");
        let rays = random_rays(&tree.bounds(), 4099, 7);
        let reference: Vec<Hit> = rays.iter().map(|r| tracer.intersect(r)).collect();
        for width in QUERY_WIDTHS {
            for context in Context::ALL {
                let hits = embree_hits(&scene, &rays, width, context);
                let mut agreement = Agreement::new(&mesh);
                for ((hit, ray), kdbeam) in hits.iter().zip(&rays).zip(&reference) {
                    agreement.add(&mesh, ray, hit, kdbeam);
                }
                let context = context.name();
                agreement.check(&format!("{name} random rtcIntersect{width} {context}"));
            }
        }
    }
}

#[test]
fn untraceable_rays_are_inactive_lanes_and_disturb_no_other_lane() {
    let mesh = Mesh::from_indexed(
        &[[-1.0, -1.0, 1.0], [1.0, -1.0, 1.0], [0.0, 1.0, 1.0]],
        &[0, 1, 2],
    )
    .expect("one triangle");
    let scene = EmbreeScene::new(&mesh).expect("embree builds");
    let good = Ray::new(Vec3::ZERO, Vec3::Z);
    let with = |f: fn(&mut Ray)| {
        let mut r = good;
        f(&mut r);
        r
    };
    let bad = [
        with(|r| r.origin.x = f32::NAN),
        with(|r| r.direction = Vec3::ZERO),
        with(|r| r.direction.y = f32::INFINITY),
        with(|r| r.tmin = 2.0 * r.tmax.min(1.0)),
        with(|r| r.tmax = f32::NAN),
        with(|r| r.tmin = -1.0),
    ];
    // Bad rays fill every lane but one, at each position of a 16-ray packet.
    for good_lane in 0..16 {
        let rays: Vec<Ray> = (0..16)
            .map(|i| {
                if i == good_lane {
                    good
                } else {
                    bad[i % bad.len()]
                }
            })
            .collect();
        for width in QUERY_WIDTHS {
            let hits = embree_hits(&scene, &rays, width, Context::Coherent);
            for (i, hit) in hits.iter().enumerate() {
                if i == good_lane {
                    assert_eq!(hit.triangle, 0, "width {width}: the good ray hits");
                    // Not exactly 1: Embree's AVX2 kernels divide by a refined reciprocal
                    // estimate, which lands an ulp short of z = 1 (0.99999994).
                    assert!(
                        (hit.t - 1.0).abs() <= T_TOLERANCE,
                        "width {width}: at z = 1, within rounding: {}",
                        hit.t
                    );
                } else {
                    assert_eq!(*hit, Hit::NONE, "width {width}: lane {i} ({:?})", rays[i]);
                }
            }
        }
    }
}

#[test]
fn bad_widths_and_lengths_are_errors() {
    let mesh = kdbeam::scene::procedural::builtin("icosphere:1").expect("built-in scene");
    let scene = EmbreeScene::new(&mesh).expect("embree builds");
    let rays = [Ray::new(Vec3::new(0.0, 0.0, -5.0), Vec3::Z); 3];
    let mut hits = [Hit::NONE; 3];
    let context = Context::Incoherent;
    for width in [0, 2, 3, 32, 64] {
        assert!(scene
            .intersect_stream(&rays, width, context, &mut hits)
            .is_err());
        assert!(EmbreeRays::new(&rays, width).is_err());
    }
    assert!(scene
        .intersect_stream(&rays, 4, context, &mut hits[..2])
        .is_err());
    let layout = EmbreeRays::new(&rays, 4).expect("a valid width");
    assert!(layout.hits(&mut hits[..2]).is_err());
    scene
        .intersect_stream(&rays, 4, context, &mut hits)
        .expect("valid input");
    assert!(hits.iter().all(Hit::is_hit));
}

/// The benchmark's way of tracing, a fresh copy of rays converted once, gives the hits of a
/// single call; before tracing, every ray reads as a miss.
#[test]
fn copies_of_converted_rays_trace_as_one_call_does() {
    let mesh = kdbeam::scene::procedural::builtin("icosphere").expect("built-in scene");
    let scene = EmbreeScene::new(&mesh).expect("embree builds");
    let rays = random_rays(&mesh.bounds(), 1000, 3);
    for width in QUERY_WIDTHS {
        let want = embree_hits(&scene, &rays, width, Context::Incoherent);
        assert!(want.iter().any(Hit::is_hit), "width {width}: some ray hits");
        let untraced = EmbreeRays::new(&rays, width).expect("a valid width");
        let mut hits = vec![Hit::NONE; rays.len()];
        untraced.hits(&mut hits).expect("matching lengths");
        assert!(hits.iter().all(|h| !h.is_hit()), "width {width}: untraced");
        let mut work = untraced.clone();
        for _ in 0..2 {
            work.clone_from(&untraced);
            scene.trace(&mut work, Context::Incoherent);
            work.hits(&mut hits).expect("matching lengths");
            assert_eq!(hits, want, "width {width}");
        }
    }
}

/// The share of shadow and AO rays on which Embree's occlusion answer must agree with
/// kdbeam's, as for closest hits ([`MIN_AGREEMENT`]).
const MIN_OCCLUSION_AGREEMENT: f64 = MIN_AGREEMENT;

/// A disagreement on occlusion is a near-grazing or end-of-segment case, not an error, when the
/// f64 oracle's closest hit lies within this relative distance of `tmax` (the occluder touches
/// the end of the segment, where rounding decides), or when the ray meets the hit triangle's
/// plane at a grazing angle, |cos| below this value (both tests' rounding decides whether the
/// ray clips an edge). Such rays are reported, and must stay rare (below 1 − [`MIN_AGREEMENT`]).
const GRAZING: f64 = 1e-3;

/// Shadow and AO rays from the primary hits (the library's workloads, seed 1): Embree's
/// rtcOccluded1/4/8/16 and rtcOccluded1M, in both contexts, answer as kdbeam's watertight
/// scalar `occluded`; the diffuse bounce's closest hits agree as primary rays do.
#[test]
fn secondary_rays_agree_with_the_watertight_scalar_path() {
    use kdbeam::rays::secondary::{SecondaryRays, Workload};
    use kdbeam::trace::reference::kd_oracle;
    for (name, mesh) in scenes() {
        let tree = KdTree::build(&mesh, &BuildParams::default()).expect("tree builds");
        let tracer = watertight(&tree);
        // Robust mode, as watertight as kdbeam's test: no ray leaks through a shared edge.
        let options = EmbreeOptions {
            robust: true,
            ..EmbreeOptions::default()
        };
        let scene = EmbreeScene::with_options(&mesh, &options).expect("embree builds");
        let camera = Camera::standard(&tree.bounds(), 128, 128);
        for workload in [
            Workload::Shadow,
            Workload::AmbientOcclusion { rays: 4 },
            Workload::Diffuse,
        ] {
            let rays = SecondaryRays::from_camera(workload, &tracer, &mesh, &camera, 1)
                .expect("rays")
                .rays;
            if rays.is_empty() {
                continue;
            }
            let kd_occluded: Vec<bool> = rays.iter().map(|r| tracer.occluded(r)).collect();
            let reference: Vec<Hit> = rays.iter().map(|r| tracer.intersect(r)).collect();
            let mut layouts: Vec<(String, EmbreeRays)> = QUERY_WIDTHS
                .iter()
                .map(|&w| {
                    (
                        format!("{w}"),
                        EmbreeRays::new(&rays, w).expect("a valid width"),
                    )
                })
                .collect();
            layouts.push(("1M".into(), EmbreeRays::stream(&rays)));
            for (call, layout) in &layouts {
                for context in Context::ALL {
                    let what = format!("{name} {} {call} {}", workload.name(), context.name());
                    let mut work = layout.clone();
                    if workload.any_hit() {
                        scene.occlude(&mut work, context);
                        let mut occluded = vec![false; rays.len()];
                        work.occluded(&mut occluded).expect("lengths");
                        let (mut agree, mut grazing) = (0, 0);
                        for (i, ray) in rays.iter().enumerate() {
                            if occluded[i] == kd_occluded[i] {
                                agree += 1;
                            } else if is_grazing(&mesh, &tree, ray) {
                                grazing += 1;
                            }
                        }
                        let share = agree as f64 / rays.len() as f64;
                        println!(
                            "{what} rtcOccluded: {agree}/{} agree, {grazing} near-grazing, {} other",
                            rays.len(),
                            rays.len() - agree - grazing
                        );
                        assert!(share >= MIN_OCCLUSION_AGREEMENT, "{what}: {share}");
                        assert_eq!(agree + grazing, rays.len(), "{what}: a clear disagreement");
                    } else {
                        scene.trace(&mut work, context);
                        let mut hits = vec![Hit::NONE; rays.len()];
                        work.hits(&mut hits).expect("lengths");
                        let mut agreement = Agreement::new(&mesh);
                        for ((hit, ray), kd) in hits.iter().zip(&rays).zip(&reference) {
                            agreement.add(&mesh, ray, hit, kd);
                        }
                        agreement.check(&format!("{what} rtcIntersect"));
                    }
                }
            }
        }
    }

    /// Is `ray` a case where rounding decides occlusion (see [`GRAZING`])?
    fn is_grazing(mesh: &Mesh, tree: &KdTree, ray: &Ray) -> bool {
        let mut unbounded = *ray;
        unbounded.tmax = f32::INFINITY;
        let Some(hit) = kd_oracle(tree, &unbounded) else {
            return false;
        };
        let tri = mesh.triangle(hit.triangle as usize);
        let n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).normalize();
        let cos = f64::from(n.dot(ray.direction.normalize())).abs();
        (hit.t - f64::from(ray.tmax)).abs() <= GRAZING * f64::from(ray.tmax) || cos < GRAZING
    }
}

/// Packets made of given groups (kdbeam's tile packets, partly filled) read back in the order
/// of the groups, with the hits of consecutive packets; a group wider than the call is an error.
#[test]
fn grouped_packets_trace_as_consecutive_ones() {
    let mesh = kdbeam::scene::procedural::builtin("icosphere").expect("built-in scene");
    let scene = EmbreeScene::new(&mesh).expect("embree builds");
    let rays = random_rays(&mesh.bounds(), 100, 9);
    let groups: Vec<&[Ray]> = [3, 16, 1, 9, 16, 5]
        .iter()
        .scan(0, |start, &n| {
            let g = &rays[*start..*start + n];
            *start += n;
            Some(g)
        })
        .collect();
    let flat: Vec<Ray> = groups.concat();
    let want = embree_hits(&scene, &flat, 1, Context::Incoherent);
    assert!(want.iter().any(Hit::is_hit));
    let mut work = EmbreeRays::from_groups(&groups, 16).expect("groups fit");
    assert_eq!(work.len(), flat.len());
    scene.trace(&mut work, Context::Incoherent);
    let mut hits = vec![Hit::NONE; flat.len()];
    work.hits(&mut hits).expect("lengths");
    assert_eq!(hits, want);
    assert!(EmbreeRays::from_groups(&groups, 8).is_err());
}

/// Embree's two-level scene of moving instances (`EmbreeInstances`) against `kdbeam::Scene` on
/// the same camera rays, before and after every instance moves: hit or miss, the instance (the
/// ground is Embree's last instance and kdbeam's mesh traced as it is) and `t` within 1e-4
/// relative (both carry the ray into the instance's space in `f32` and test the same triangle:
/// a few ulps apart). Rays through silhouettes and shared edges may differ: at most 0.5%.
#[test]
fn moving_instances_agree_with_kdbeam_scenes() {
    use glam::{Affine3A, Quat};
    use kdbeam::scene::procedural::{icosphere, terrain};
    use kdbeam::scene::world::SceneHit;
    use kdbeam::{InstanceId, Scene};
    use kdbeam_cli::embree::EmbreeInstances;

    let mesh = icosphere(Vec3::ZERO, 0.08, 2);
    let ground = terrain(48, 3);
    let placements = |frame: f32| -> Vec<Affine3A> {
        (0..24)
            .map(|i| {
                let (x, z) = ((i % 6) as f32 * 0.3 - 0.75, (i / 6) as f32 * 0.4 + 0.2);
                let turn = Quat::from_rotation_y(0.3 * frame + i as f32);
                let at = Vec3::new(x + 0.05 * frame, 0.2 + 0.1 * (i % 3) as f32, z);
                Affine3A::from_scale_rotation_translation(Vec3::new(1.0, 1.5, 0.7), turn, at)
            })
            .collect()
    };
    let mut scene = Scene::new();
    let prototype = scene.add_prototype(mesh.clone()).expect("a valid mesh");
    scene.add_mesh(ground.clone()).expect("a valid mesh");
    let ids: Vec<InstanceId> = placements(0.0)
        .into_iter()
        .map(|m| {
            scene
                .add_instance(prototype, m)
                .expect("a finite transform")
        })
        .collect();
    scene.commit().expect("builds");
    let mut embree = EmbreeInstances::new(&mesh, &ground, &placements(0.0)).expect("embree");
    assert_eq!(embree.len(), ids.len());
    let camera = Camera::look_at(
        Vec3::new(0.0, 1.2, -0.8),
        Vec3::new(0.0, 0.0, 0.9),
        60.0,
        64,
        64,
    )
    .expect("a valid camera");
    let (rays, _) = primary_rays(&camera, 16).expect("width 16");
    for frame in 0..3 {
        if frame > 0 {
            for (i, (&id, m)) in ids.iter().zip(placements(frame as f32)).enumerate() {
                scene.set_transform(id, m).expect("a finite transform");
                embree.set_transform(i, &m).expect("a finite transform");
            }
            scene.commit().expect("builds");
            embree.commit().expect("builds");
        }
        let mut work = EmbreeRays::new(&rays, 16).expect("width 16");
        embree.trace(&mut work, Context::Coherent);
        let mut hits = vec![Hit::NONE; rays.len()];
        let mut instances = vec![0; rays.len()];
        work.hits(&mut hits).expect("lengths");
        work.instances(&mut instances).expect("lengths");
        let (mut differ, mut on_instances) = (0, 0);
        for ((ray, h), &inst) in rays.iter().zip(&hits).zip(&instances) {
            let k: SceneHit = scene.intersect(ray);
            let inst = if inst as usize == ids.len() {
                InstanceId::NONE
            } else {
                InstanceId(inst)
            };
            let same = match (k.is_hit(), h.is_hit()) {
                (false, false) => true,
                (true, true) => k.instance == inst && (k.t - h.t).abs() <= 1e-4 * k.t,
                _ => false,
            };
            differ += usize::from(!same);
            on_instances += usize::from(k.instance != InstanceId::NONE && k.is_hit());
        }
        assert!(
            on_instances > 100,
            "frame {frame}: few rays see an instance"
        );
        assert!(
            differ * 200 <= rays.len(),
            "frame {frame}: {differ} of {} rays differ",
            rays.len()
        );
    }
    assert!(embree
        .set_transform(ids.len(), &Affine3A::IDENTITY)
        .is_err());
    let nan = Affine3A::from_translation(Vec3::splat(f32::NAN));
    assert!(embree.set_transform(0, &nan).is_err());
}

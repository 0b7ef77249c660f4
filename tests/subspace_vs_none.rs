//! Subspace culling (Yoshimura & Harada, *Subspace Culling for Ray-Box Intersection*, Proc.
//! ACM CGIT 2023) is conservative: every variant (R = 4 and 6, look-up table and exact ray
//! masks) gives every single ray the same closest hit as no culling — triangle id, `t`, `u`,
//! `v`, bit for bit — and the same any-hit verdict, with and without a hit filter that rejects
//! hits, on every ISA this CPU runs (each skipped ISA is named).
//!
//! Tolerance: none. A culled leaf or triangle holds no hit of the ray that another leaf does
//! not find the same way, and the survivors are tested by the same kernels on the same rays.
//!
//! Rays: random rays starting inside leaves, the adversarial set of `tests/common` (zero
//! direction components, axis-parallel rays through vertices, origins on surfaces, NaN,
//! infinite and zero directions, `tmin > tmax`), rays grazing triangles (in their plane,
//! along an edge), and `tmax` cut inside the scene (inside a leaf). Trees: the default and
//! one of large leaves (small `ci_over_ct`), where the per-triangle masks do the most.

mod common;

use kdbeam::scene::procedural;
use kdbeam::scene::rng::Rng;
use kdbeam::trace::{filtered, Culling, RayBoxes, Subspace};
use kdbeam::{BuildParams, Hit, Isa, KdTree, Mesh, Ray, Tracer, Vec3};

/// The ray sets of the module docs.
fn rays(mesh: &Mesh, count: usize, seed: u64) -> Vec<Ray> {
    let mut rays = common::adversarial_rays(mesh, count, seed);
    let mut rng = Rng::new(seed ^ 0x5eed);
    let n = mesh.triangle_count().max(1) as u32;
    let b = mesh.bounds();
    for i in 0..count / 2 {
        let tri = mesh.triangle(rng.below(n) as usize);
        let (e0, e1) = (tri.v1 - tri.v0, tri.v2 - tri.v0);
        let normal = e0.cross(e1).normalize_or_zero();
        let r = match i % 4 {
            // In the triangle's plane, through its interior: grazing.
            0 => {
                let inside = tri.v0 + e0 * 0.3 + e1 * 0.3;
                let along =
                    (e0 * rng.range(-1.0, 1.0) + e1 * rng.range(-1.0, 1.0)).normalize_or_zero();
                Ray::new(inside - along * b.extent().length(), along)
            }
            // Along an edge.
            1 => Ray::new(tri.v0 - e0, e0),
            // Barely off the plane, nearly parallel to it.
            2 => {
                let d = (e0.normalize_or_zero() + normal * 1e-4).normalize_or_zero();
                Ray::new(tri.v0 + e1 * 0.5 - d * b.extent().length() * 0.5, d)
            }
            // From a surface point, tmax cut short.
            _ => {
                let mut r = Ray::new(tri.v0 + e0 * 0.25 + e1 * 0.25, rng.unit_vector());
                r.tmax = b.extent().length() * rng.range(0.0, 0.3);
                r
            }
        };
        rays.push(r);
    }
    // Random rays with tmax inside the scene.
    for mut r in kdbeam::rays::random_rays(&b, count / 4, seed ^ 7) {
        r.tmax = b.extent().length() * rng.range(0.01, 0.5);
        rays.push(r);
    }
    rays
}

/// The same hit, bit for bit.
fn same(a: &Hit, b: &Hit) -> bool {
    a.triangle == b.triangle
        && a.t.to_bits() == b.t.to_bits()
        && a.u.to_bits() == b.u.to_bits()
        && a.v.to_bits() == b.v.to_bits()
}

/// Rejects every third triangle's hits.
fn accept(h: &Hit) -> bool {
    !h.triangle.is_multiple_of(3)
}

/// Every variant against none, on every ISA, on `rays`; returns the tests culled by the R = 4
/// table on the widest ISA, to check the stage does something.
fn check(name: &str, tree: &KdTree, rays: &[Ray], variants: &[Subspace]) -> u64 {
    let reference = Tracer::new(tree)
        .with_isa(Isa::Scalar)
        .expect("scalar")
        .with_culling(Culling::NONE);
    let expected: Vec<(Hit, bool, Hit, bool)> = rays
        .iter()
        .map(|r| {
            (
                reference.intersect(r),
                reference.occluded(r),
                filtered::closest_hit_on(&reference, r, accept),
                filtered::any_hit_on(&reference, r, accept),
            )
        })
        .collect();
    for isa in Isa::ALL {
        if !isa.is_available() {
            eprintln!("{name}: skipped ISA {isa:?}: this CPU does not run it");
        }
    }
    let mut culled = 0;
    for isa in Isa::available() {
        // Each subspace stage alone and followed by ray-box culling, and ray-box culling
        // alone: the filtered queries check that only accepted hits shrink the ray's box.
        let stages = variants.iter().map(|&s| Some(s)).chain([None]);
        for (s, raybox) in stages.flat_map(|s| [(s, false), (s, true)]) {
            if s.is_none() && !raybox {
                continue;
            }
            let boxes = if raybox { RayBoxes::On } else { RayBoxes::Off };
            let culling = Culling::NONE.with_subspace(s).with_raybox(boxes);
            let tracer = Tracer::new(tree)
                .with_isa(isa)
                .unwrap()
                .with_culling(culling);
            for (i, (r, e)) in rays.iter().zip(&expected).enumerate() {
                let (hit, counters) = tracer.intersect_counted(r);
                let why = || format!("{name} {isa:?} {culling}: ray {i} {r:?}");
                assert!(same(&hit, &e.0), "{}: {hit:?} vs {:?}", why(), e.0);
                assert_eq!(tracer.occluded(r), e.1, "{} (any hit)", why());
                let f = filtered::closest_hit_on(&tracer, r, accept);
                assert!(same(&f, &e.2), "{} (filtered): {f:?} vs {:?}", why(), e.2);
                assert_eq!(filtered::any_hit_on(&tracer, r, accept), e.3, "{}", why());
                if s == Some(Subspace::Table4) && !raybox && Some(isa) == Isa::available().last() {
                    culled += counters.culled;
                }
            }
        }
    }
    culled
}

fn trees(mesh: &Mesh) -> [KdTree; 2] {
    [
        KdTree::build(mesh, &BuildParams::default()).unwrap(),
        KdTree::build(mesh, &BuildParams::default().with_ci_over_ct(0.02)).unwrap(),
    ]
}

#[test]
fn subspace_never_changes_a_hit_on_procedural_scenes() {
    for name in ["hair:300", "icosphere:2", "soup:400"] {
        let mesh = procedural::builtin(name).unwrap();
        let rays = rays(&mesh, 400, 11);
        for (k, tree) in trees(&mesh).iter().enumerate() {
            let culled = check(&format!("{name}/{k}"), tree, &rays, &Subspace::ALL);
            if name.starts_with("hair") {
                assert!(culled > 0, "{name}: subspace culled nothing");
            }
        }
    }
}

#[test]
fn subspace_never_changes_a_hit_on_a_shared_scene_sample() {
    let Some(mesh) = common::scenes::load_shared("bunny") else {
        eprintln!("skipped: subspace on shared scenes (no bunny; set KDBEAM_SCENES)");
        return;
    };
    let tree = KdTree::build(&mesh, &BuildParams::default()).unwrap();
    let rays = rays(&mesh, 300, 5);
    check("bunny", &tree, &rays, &[Subspace::Table4, Subspace::Table6]);
}

#[test]
fn the_grammar_names_every_variant() {
    for s in Subspace::ALL {
        let c: Culling = s.name().parse().unwrap();
        assert_eq!(c.subspace, Some(s));
        assert_eq!(c.to_string(), s.name());
    }
    let v = Vec3::ZERO;
    // A ray that cannot be traced reports a miss with every variant.
    let mesh = procedural::builtin("icosphere:1").unwrap();
    let tree = KdTree::build(&mesh, &BuildParams::default()).unwrap();
    let t = Tracer::new(&tree).with_culling("subspace6".parse().unwrap());
    assert!(!t.intersect(&Ray::new(v, v)).is_hit());
}

//! The accuracy comparison (`kdbeam_cli::report::accuracy`) finds what it should.
//!
//! 1. Culling is exact: against the unculled hits as reference, every culling mode of
//!    `kdbeam accuracy` has 0 disagreements, 0 wrong ids, 0 ties and a `t` error of exactly 0
//!    (tolerance: none, culling never changes a hit), and so the same statistics against the
//!    f64 oracle.
//! 2. The statistics see errors: hits whose `t` is scaled by 1 + 1e-3 give a median and p99
//!    relative error of 1e-3; a dropped hit is a disagreement, a far triangle a wrong id, the
//!    neighbour across a shared edge a tie.

use kdbeam::scene::procedural;
use kdbeam::trace::reference::ReferenceHit;
use kdbeam::trace::Culling;
use kdbeam::{BuildParams, Hit, Intersector, Isa, KdTree, Mesh, Ray, Tracer, Vec3};
use kdbeam_cli::render::RaySet;
use kdbeam_cli::report::accuracy::{compare, reference_hits, Accuracy, Workload, CULLINGS};

fn as_reference(hits: &[Hit]) -> Vec<Option<ReferenceHit>> {
    hits.iter()
        .map(|h| {
            h.is_hit().then_some(ReferenceHit {
                t: f64::from(h.t),
                triangle: h.triangle,
            })
        })
        .collect()
}

#[test]
fn culling_modes_agree_with_no_culling_and_score_the_same_against_the_oracle() {
    let mesh = procedural::builtin("soup:2000").unwrap();
    let tree = KdTree::build(
        &mesh,
        // Large leaves: culling does the most.
        &BuildParams::default().with_ci_over_ct(0.3),
    )
    .unwrap();
    let sets = [
        RaySet::Primary,
        RaySet::Random,
        RaySet::Shadow,
        RaySet::Ao,
        RaySet::Diffuse,
    ];
    for set in sets {
        let work = Workload::new(set, &mesh, &tree, 48, 48, 4).unwrap();
        let oracle = reference_hits(&tree, &work.rays);
        for intersector in Intersector::ALL {
            for isa in Isa::available() {
                let tracer = Tracer::new(&tree)
                    .with_intersector(intersector)
                    .with_isa(isa)
                    .unwrap();
                let (unculled, _) = work.trace(&tracer.with_culling(Culling::NONE)).unwrap();
                let base = compare(&mesh, &work.rays, &oracle, &unculled).unwrap();
                assert!(
                    base.both_hit > 100,
                    "{set:?}: {} hits are too few to prove anything",
                    base.both_hit
                );
                let unculled = as_reference(&unculled);
                for culling in CULLINGS {
                    let (hits, _) = work.trace(&tracer.with_culling(culling)).unwrap();
                    let vs_none = compare(&mesh, &work.rays, &unculled, &hits).unwrap();
                    let what = format!("{set:?} {intersector:?} {isa} {culling}");
                    assert_eq!(
                        (vs_none.disagreements, vs_none.wrong_ids, vs_none.ties),
                        (0, 0, 0),
                        "{what}"
                    );
                    assert_eq!(vs_none.t_rel_err_max, 0.0, "{what}");
                    let vs_oracle = compare(&mesh, &work.rays, &oracle, &hits).unwrap();
                    assert_eq!(vs_oracle, base, "{what}");
                }
            }
        }
    }
}

#[test]
fn scaled_t_is_measured_as_its_relative_error() {
    let mesh = procedural::builtin("icosphere:3").unwrap();
    let tree = KdTree::build(&mesh, &BuildParams::default()).unwrap();
    let work = Workload::new(RaySet::Primary, &mesh, &tree, 64, 64, 4).unwrap();
    let oracle = reference_hits(&tree, &work.rays);
    let tracer = Tracer::new(&tree).with_intersector(Intersector::Watertight);
    let (mut hits, _) = work.trace(&tracer).unwrap();
    let exact = compare(&mesh, &work.rays, &oracle, &hits).unwrap();
    assert!(exact.both_hit > 1000, "{exact:?}");
    // f32 t is within a few ulps (~1e-7) of the oracle's on a sphere seen head-on.
    assert!(exact.t_rel_err_max < 1e-5, "{exact:?}");
    for h in hits.iter_mut().filter(|h| h.is_hit()) {
        h.t *= 1.0 + 1e-3;
    }
    let scaled = compare(&mesh, &work.rays, &oracle, &hits).unwrap();
    // 1e-3 plus the unscaled error (< 1e-5) and the f32 rounding of the product (6e-8).
    for (name, e) in [
        ("median", scaled.t_rel_err_median),
        ("p99", scaled.t_rel_err_p99),
        ("max", scaled.t_rel_err_max),
    ] {
        assert!((e - 1e-3).abs() < 2e-5, "{name} {e} should be 1e-3");
    }
    assert_eq!(
        (scaled.disagreements, scaled.wrong_ids, scaled.both_hit),
        (exact.disagreements, exact.wrong_ids, exact.both_hit)
    );
}

/// A unit square at z = 1 split along its diagonal (0,0)–(1,1), and a far triangle at z = 5.
fn quad_and_far_triangle() -> Mesh {
    Mesh::from_indexed(
        &[
            [0.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 1.0, 1.0],
            [0.0, 1.0, 1.0],
            [0.0, 0.0, 5.0],
            [1.0, 0.0, 5.0],
            [0.0, 1.0, 5.0],
        ],
        &[0, 1, 2, 0, 2, 3, 4, 5, 6],
    )
    .unwrap()
}

#[test]
fn misses_wrong_ids_and_edge_ties_are_told_apart() {
    let mesh = quad_and_far_triangle();
    let tree = KdTree::build(&mesh, &BuildParams::default()).unwrap();
    let ray = |x: f32, y: f32| Ray::new(Vec3::new(x, y, 0.0), Vec3::Z);
    // On the diagonal (both triangles at t = 1), inside triangle 0, inside triangle 1.
    let rays = [ray(0.5, 0.5), ray(0.7, 0.2), ray(0.2, 0.7)];
    let oracle = reference_hits(&tree, &rays);
    assert_eq!(
        oracle
            .iter()
            .map(|h| h.map(|h| h.triangle))
            .collect::<Vec<_>>(),
        [Some(0), Some(0), Some(1)],
        "equal t goes to the smaller id"
    );
    let hit = |t: f32, triangle: u32| Hit {
        t,
        u: 0.0,
        v: 0.0,
        triangle,
    };
    let check = |hits: [Hit; 3]| compare(&mesh, &rays, &oracle, &hits).unwrap();
    let summary = |a: Accuracy| (a.both_hit, a.disagreements, a.wrong_ids, a.ties);

    assert_eq!(
        summary(check([hit(1.0, 0), hit(1.0, 0), hit(1.0, 1)])),
        (3, 0, 0, 0)
    );
    // The neighbour across the shared edge, at the same t: a tie, not an error.
    assert_eq!(
        summary(check([hit(1.0, 1), hit(1.0, 0), hit(1.0, 1)])),
        (3, 0, 0, 1)
    );
    // The far triangle, and an id outside the mesh: wrong ids (no panic).
    let wrong = check([hit(1.0, 0), hit(5.0, 2), hit(1.0, 77)]);
    assert_eq!(summary(wrong), (3, 0, 2, 0));
    assert_eq!(wrong.t_rel_err_max, 4.0, "t = 5 against 1");
    // A dropped hit.
    assert_eq!(
        summary(check([Hit::NONE, hit(1.0, 0), hit(1.0, 1)])),
        (2, 1, 0, 0)
    );
    assert!(compare(&mesh, &rays, &oracle, &[Hit::NONE]).is_err());
}

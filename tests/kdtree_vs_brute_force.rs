//! The kd-tree finds what an exhaustive search finds.
//!
//! For every procedural scene and every shared scene, at `ci_over_ct` ∈ {0.1, 1, 10}, with
//! ≥ 100k rays per scene (primary and random, and short segments such as ambient-occlusion
//! rays, whose traversal starts below the root):
//! 1. *Structure*: traversal with the f64 oracle in the leaves returns exactly the brute-force
//!    oracle hit over all triangles: the same triangle id and the same f64 `t`, bit for bit
//!    (the same oracle on the same ray and triangle). Equal `t` goes to the smaller id on both
//!    sides (the rule of `Hit::is_beaten_by`), so there is no tolerance at all.
//! 2. *Precision*: the f32 tracers (Kensler–Shirley and watertight) agree with the brute-force
//!    oracle: the same id, or a different triangle whose oracle `t` is the same within the
//!    tolerance below (the ray crosses a shared edge, where f32 and f64 may pick different
//!    neighbours: an *edge tie*, counted and bounded, not an error); `t` within
//!    `(1e-4·t + 1e-6·diag) / cos θ` — f32 carries 24 bits (6e-8 relative), the test's few
//!    products lose up to ~3 orders of magnitude, `diag` (the scene diagonal) covers hits near
//!    the origin, and `cos θ` (ray against the triangle's normal, at least 1e-3) the loss of
//!    `t = n·(p0 − o) / n·d` on grazing rays (measured: thin hair triangles).
//!
//! Any hit agrees with closest hit on hit/miss for every ray.
//!
//! The brute force skips the triangles whose padded box a ray's line misses
//! ([`BruteForce`]), with the same hits as testing them all (checked in the library's own
//! tests), so that the oracle's exhaustive search does not dominate the test's time.

mod common;

use kdbeam::kernels::intersect::oracle::OracleRay;
use kdbeam::rays::random_rays;
use kdbeam::trace::reference::{kd_oracle, BruteForce, ReferenceHit};
use kdbeam::{BuildParams, Intersector, Isa, KdTree, Mesh, Ray, Tracer, Vec3};
use rayon::prelude::*;

/// 232 × 232 = 53,824 primary rays and as many random ones: 107,648 rays per scene, and
/// [`SHORT_RAYS`] short segments.
const RAYS_PER_SET: u32 = 232;

/// Segments of 0.2%, 2% and 20% of the scene's diagonal: half from random points, half leaving
/// a triangle as ambient-occlusion rays do (from just above its centroid, on its normal's side).
const SHORT_RAYS: usize = 8192;

fn ray_sets(mesh: &Mesh) -> Vec<Ray> {
    let mut rays = common::primary_rays(mesh, RAYS_PER_SET, RAYS_PER_SET);
    rays.extend(random_rays(
        &mesh.bounds(),
        (RAYS_PER_SET * RAYS_PER_SET) as usize,
        42,
    ));
    let diag = mesh.bounds().extent().length();
    let short = random_rays(&mesh.bounds(), SHORT_RAYS, 43);
    rays.extend(short.into_iter().enumerate().map(|(i, r)| {
        let tmax = [0.002, 0.02, 0.2][i % 3] * diag / r.direction.length();
        let t = mesh.triangle(i * 7919 % mesh.triangle_count().max(1));
        let n = (t.v1 - t.v0).cross(t.v2 - t.v0).normalize_or_zero();
        if i % 2 == 0 || mesh.is_empty() || n == Vec3::ZERO {
            return Ray { tmax, ..r };
        }
        let d = if r.direction.dot(n) < 0.0 {
            -r.direction
        } else {
            r.direction
        };
        Ray {
            origin: (t.v0 + t.v1 + t.v2) / 3.0 + n * (1e-3 * diag),
            direction: d,
            tmax,
            ..r
        }
    }));
    rays
}

fn check_scene(name: &str, mesh: &Mesh) {
    let rays = ray_sets(mesh);
    let oracle = BruteForce::new(mesh);
    let truth: Vec<Option<ReferenceHit>> = rays.par_iter().map(|r| oracle.closest(r)).collect();
    let diag = mesh.bounds().extent().length() as f64;
    let hits = truth.iter().filter(|h| h.is_some()).count();
    assert!(
        hits > 0 || mesh.is_empty(),
        "{name}: no ray hits anything: the test would prove nothing"
    );
    for ci in [0.1, 1.0, 10.0] {
        let tree = KdTree::build(mesh, &BuildParams::default().with_ci_over_ct(ci)).unwrap();
        let structural: Vec<usize> = rays
            .par_iter()
            .zip(&truth)
            .enumerate()
            .filter(|(_, (r, t))| kd_oracle(&tree, r) != **t)
            .map(|(i, _)| i)
            .collect();
        assert!(
            structural.is_empty(),
            "{name} ci={ci}: {} of {} rays differ from brute force, first ray {:?}: kd {:?}, brute force {:?}",
            structural.len(),
            rays.len(),
            rays[structural[0]],
            kd_oracle(&tree, &rays[structural[0]]),
            truth[structural[0]]
        );
        for intersector in Intersector::ALL {
            let tracer = Tracer::new(&tree)
                .with_isa(Isa::Scalar)
                .unwrap()
                .with_intersector(intersector);
            let (mut edge_ties, mut grazing, mut bad) = (0usize, 0usize, Vec::new());
            let mut starts_on_surface = 0usize;
            for (i, (r, want)) in rays.iter().zip(&truth).enumerate() {
                let got = tracer.intersect(r);
                assert_eq!(
                    got.is_hit(),
                    tracer.occluded(r),
                    "{name}: any hit disagrees with closest hit on ray {i}"
                );
                let on_surface = |t: f64| t <= 1e-5 * diag;
                match (got.is_hit(), want) {
                    (false, None) => {}
                    // A ray starting on a surface (the flat grid's random origins): whether it
                    // hits at t ≈ 0 is decided by rounding, in f32 and in f64 alike.
                    (true, None) if on_surface(f64::from(got.t)) => starts_on_surface += 1,
                    (false, Some(w)) if on_surface(w.t) => starts_on_surface += 1,
                    (true, Some(w)) => {
                        // t = (n·(p0 − o)) / (n·d) loses accuracy as the ray grazes the plane:
                        // the tolerance grows as 1 / cos θ (θ between ray and normal).
                        let tri = mesh.triangle(w.triangle as usize);
                        let n = (tri.v1 - tri.v0)
                            .as_dvec3()
                            .cross((tri.v2 - tri.v0).as_dvec3());
                        let d = r.direction.as_dvec3();
                        let cos = (n.dot(d).abs() / (n.length() * d.length())).max(1e-3);
                        let tol = (1e-4 * w.t + 1e-6 * diag) / cos;
                        if got.triangle == w.triangle {
                            if (f64::from(got.t) - w.t).abs() > tol {
                                bad.push(format!("ray {i}: t {} vs oracle {}", got.t, w.t));
                            }
                        } else {
                            // Is the f32 pick also hit by the oracle at the same t? Then it is an edge tie.
                            let tri = mesh.triangle(got.triangle as usize);
                            match OracleRay::new(r).intersect(
                                &tri,
                                f64::from(r.tmin),
                                f64::INFINITY,
                            ) {
                                Some(h) if (h.t - w.t).abs() <= tol => edge_ties += 1,
                                _ => grazing += 1,
                            }
                        }
                    }
                    _ => grazing += 1,
                }
            }
            eprintln!(
                "{name} ci={ci} {intersector:?}: {} rays, {hits} hits, {edge_ties} edge ties, {grazing} edge misses/extra hits, {starts_on_surface} starting on a surface, {} t errors",
                rays.len(),
                bad.len()
            );
            assert!(
                bad.is_empty(),
                "{name} ci={ci} {intersector:?}: t out of tolerance: {:?}",
                &bad[..bad.len().min(5)]
            );
            // Kensler–Shirley is not watertight: rays through shared edges (the grid's primary
            // rays land on its diagonals) may miss both triangles; its rate is printed above.
            // The watertight test differs from the oracle only on rays grazing a silhouette
            // edge, which are rare (measured: under 1 in 10^4); a tree bug shows far more.
            // A flat mesh (the grid) is grazed or started on by every ray of both sets, where
            // hit/miss is decided by rounding alone: only its structural check counts.
            let flat = mesh.bounds().extent().min_element() == 0.0;
            assert!(
                intersector == Intersector::KenslerShirley
                    || flat
                    || (edge_ties + grazing) as f64 <= 1e-3 * rays.len() as f64,
                "{name} ci={ci} {intersector:?}: {edge_ties} edge ties and {grazing} hit/miss flips in {} rays",
                rays.len()
            );
        }
    }
}

#[test]
fn kdtree_equals_brute_force_on_procedural_scenes() {
    for (name, mesh) in common::scenes(false) {
        check_scene(&name, &mesh);
    }
}

#[test]
fn kdtree_equals_brute_force_on_shared_scenes() {
    let scenes = common::real_scenes();
    if scenes.is_empty() {
        eprintln!("skipped: no shared scenes");
    }
    for (name, mesh) in scenes {
        check_scene(&name, &mesh);
    }
}

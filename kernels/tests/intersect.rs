//! Kensler–Shirley and watertight ray × triangle tests: against the `f64` oracle, barycentric
//! reconstruction, degenerate triangles, non-finite rays, and the lane forms against the
//! single-ray forms on every ISA.
#![cfg(feature = "std")] // `Dispatch::new` detects the CPU.

mod common;

use common::{barycentric_point, gather, lanes_of, ray_through, same, well_shaped_triangle, Rng};
use kdbeam_kernels::intersect::kensler_shirley::{self, KsBlock};
use kdbeam_kernels::intersect::oracle::OracleRay;
use kdbeam_kernels::intersect::watertight::{WatertightLanes, WatertightRay};
use kdbeam_kernels::intersect::{LaneHits, TriangleHit};
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{
    Isa, KsTriangle, LaneMask, LaneTask, Lanes, Ray, Triangle, TriangleBlock, Vec3,
};

/// A single-ray intersector under test.
type Intersector = fn(&Ray, &Triangle, f32, f32) -> Option<TriangleHit>;

fn kensler_shirley(ray: &Ray, tri: &Triangle, tmin: f32, tmax: f32) -> Option<TriangleHit> {
    kensler_shirley::intersect(ray, &KsTriangle::from(tri), tmin, tmax)
}

fn watertight(ray: &Ray, tri: &Triangle, tmin: f32, tmax: f32) -> Option<TriangleHit> {
    WatertightRay::new(ray).intersect(tri, tmin, tmax)
}

const INTERSECTORS: [(&str, Intersector); 2] = [
    ("kensler_shirley", kensler_shirley),
    ("watertight", watertight),
];

/// Accuracy against the oracle on well-shaped triangles (no angle below ~10°), rays at least
/// 0.1 from grazing, `t = 1` at the target.
///
/// Tolerances: inputs are `O(1)`, so each `f32` step rounds at `2^-24 ≈ 6e-8` of the inputs'
/// scale; the tests chain ~20 steps and divide by `n·d` and by the triangle's area, each at most
/// ~10× below that scale here, so errors stay around 1e-6 (measured worst: 3.4e-6 for
/// Kensler–Shirley barycentrics). We allow 3e-5 on `t` (relative), on `u`, `v` (absolute), and on
/// the distance between `ray.at(t)` and the barycentric point: ten times the measured worst,
/// far below what a wrong formula gives (swapping `u` and `v` errs by O(0.1)).
const TOLERANCE: f64 = 3e-5;

/// Barycentric margin that rounding can never cross under `TOLERANCE`.
const MARGIN: f64 = 0.01;

#[test]
fn hits_inside_the_margin_agree_with_the_oracle_and_reconstruct_the_point() {
    for (name, intersect) in INTERSECTORS {
        let mut rng = Rng::new(1);
        let (mut worst_t, mut worst_uv, mut worst_point) = (0.0f64, 0.0f64, 0.0f64);
        for _ in 0..50_000 {
            let tri = well_shaped_triangle(&mut rng);
            let (u, v) = loop {
                let (u, v) = (rng.unit(), rng.unit());
                if u >= MARGIN && v >= MARGIN && 1.0 - u - v >= MARGIN {
                    break (u, v);
                }
            };
            let ray = ray_through(&mut rng, &tri, barycentric_point(&tri, u, v));
            let truth = OracleRay::new(&ray)
                .intersect(&tri, 0.0, f64::INFINITY)
                .expect("the oracle hits a ray aimed inside the margin");
            let hit = intersect(&ray, &tri, 0.0, f32::INFINITY)
                .unwrap_or_else(|| panic!("{name} missed {ray:?} {tri:?}"));
            worst_t = worst_t.max(((hit.t as f64 - truth.t) / truth.t).abs());
            worst_uv = worst_uv
                .max((hit.u as f64 - truth.u).abs())
                .max((hit.v as f64 - truth.v).abs());
            let on_ray = ray.origin.as_dvec3() + ray.direction.as_dvec3() * hit.t as f64;
            let (hu, hv) = (hit.u as f64, hit.v as f64);
            let on_triangle = tri.v0.as_dvec3() * (1.0 - hu - hv)
                + tri.v1.as_dvec3() * hu
                + tri.v2.as_dvec3() * hv;
            worst_point = worst_point.max(on_ray.distance(on_triangle));
        }
        println!("{name}: max rel t error {worst_t:.2e}, max |du|,|dv| {worst_uv:.2e}, max point gap {worst_point:.2e}");
        assert!(worst_t <= TOLERANCE, "{name}: t error {worst_t}");
        assert!(
            worst_uv <= TOLERANCE,
            "{name}: barycentric error {worst_uv}"
        );
        assert!(worst_point <= TOLERANCE, "{name}: point gap {worst_point}");
    }
}

#[test]
fn rays_outside_the_margin_or_the_interval_miss_like_the_oracle() {
    for (name, intersect) in INTERSECTORS {
        let mut rng = Rng::new(2);
        for _ in 0..50_000 {
            let tri = well_shaped_triangle(&mut rng);
            // Outside one edge by at least the margin (any of the three).
            let (mut u, mut v) = (rng.unit() * 1.5 - 0.25, rng.unit() * 1.5 - 0.25);
            match rng.below(3) {
                0 => u = -MARGIN - rng.unit(),
                1 => v = -MARGIN - rng.unit(),
                _ => u = 1.0 - v + MARGIN + rng.unit(),
            }
            let ray = ray_through(&mut rng, &tri, barycentric_point(&tri, u, v));
            assert_eq!(
                OracleRay::new(&ray).intersect(&tri, 0.0, f64::INFINITY),
                None,
                "oracle"
            );
            assert_eq!(intersect(&ray, &tri, 0.0, f32::INFINITY), None, "{name}");

            // Inside, but the interval stops 0.1% short of the hit or starts 0.1% past it.
            let ray = ray_through(&mut rng, &tri, barycentric_point(&tri, 0.3, 0.3));
            assert_eq!(intersect(&ray, &tri, 0.0, 0.999), None, "{name}");
            assert_eq!(intersect(&ray, &tri, 1.001, f32::INFINITY), None, "{name}");
            let hit = intersect(&ray, &tri, 0.999, 1.001).expect("hit inside a narrow interval");
            assert!((0.999..=1.001).contains(&hit.t), "{name}: {hit:?}");
        }
    }
}

#[test]
fn the_interval_is_closed_at_both_ends() {
    for (name, intersect) in INTERSECTORS {
        let mut rng = Rng::new(3);
        for _ in 0..10_000 {
            let tri = well_shaped_triangle(&mut rng);
            let ray = ray_through(&mut rng, &tri, barycentric_point(&tri, 0.2, 0.3));
            let t = intersect(&ray, &tri, 0.0, f32::INFINITY).expect("hit").t;
            assert_eq!(intersect(&ray, &tri, t, t).map(|h| h.t), Some(t), "{name}");
            assert_eq!(
                intersect(&ray, &tri, t, f32::INFINITY).map(|h| h.t),
                Some(t)
            );
            assert_eq!(intersect(&ray, &tri, 0.0, t).map(|h| h.t), Some(t));
        }
    }
}

/// Degenerate forms of a triangle with vertices `a`, `b`: repeated vertices, a point, and
/// non-finite vertices.
fn degenerate_triangles(a: Vec3, b: Vec3) -> [Triangle; 7] {
    [
        Triangle::new(a, a, b),
        Triangle::new(a, b, a),
        Triangle::new(b, a, a),
        Triangle::new(a, a, a),
        Triangle::new(a, b, Vec3::new(f32::NAN, 0.0, 0.0)),
        Triangle::new(a, Vec3::new(0.0, f32::INFINITY, 0.0), b),
        Triangle::new(Vec3::NEG_INFINITY, a, b),
    ]
}

#[test]
fn degenerate_triangles_never_hit() {
    let mut rng = Rng::new(4);
    for _ in 0..20_000 {
        let (a, b) = (rng.in_cube(1.0), rng.in_cube(1.0));
        // Aim at the vertices, the segment between them, and anywhere.
        let targets = [a, b, (a + b) * 0.5, a + (b - a) * rng.range(0.0, 1.0)];
        for tri in degenerate_triangles(a, b) {
            for target in targets {
                let origin = target + rng.on_sphere() * rng.range(0.5, 3.0);
                let ray = Ray::new(origin, target - origin);
                for (name, intersect) in INTERSECTORS {
                    assert_eq!(
                        intersect(&ray, &tri, f32::NEG_INFINITY, f32::INFINITY),
                        None,
                        "{name} {tri:?} {ray:?}"
                    );
                }
                assert_eq!(
                    OracleRay::new(&ray).intersect(&tri, f64::NEG_INFINITY, f64::INFINITY),
                    None
                );
            }
        }
    }
}

#[test]
fn kensler_shirley_never_hits_exactly_collinear_triangles() {
    // Small integer coordinates: every difference and product is exact, so `n = 0` exactly.
    let mut rng = Rng::new(5);
    let int = |rng: &mut Rng| {
        Vec3::new(
            rng.below(9) as f32,
            rng.below(9) as f32,
            rng.below(9) as f32,
        ) - 4.0
    };
    for _ in 0..20_000 {
        let (p, step) = (int(&mut rng), int(&mut rng));
        let (k1, k2) = (rng.below(5) as f32 - 2.0, rng.below(5) as f32 - 2.0);
        let tri = Triangle::new(p, p + step * k1, p + step * k2);
        let target = p + step * rng.range(-2.0, 2.0);
        let origin = target + rng.on_sphere() * rng.range(0.5, 3.0);
        let ray = Ray::new(origin, target - origin);
        assert_eq!(
            kensler_shirley(&ray, &tri, f32::NEG_INFINITY, f32::INFINITY),
            None,
            "{tri:?} {ray:?}"
        );
    }
}

/// A ray in the plane of `tri`, along the edge from `a` to `b`: it starts one edge length
/// before `a`, as the grazing rays of the tracer's differential tests do.
fn along_edge(a: Vec3, b: Vec3) -> Ray {
    Ray::new(a * 2.0 - b, b - a)
}

#[test]
fn kensler_shirley_misses_rays_in_the_triangles_plane() {
    // Two triangles of an icosphere sharing an edge, and the ray along it on which the
    // unguarded test "hit" one at the ray's origin (t = 0), an edge length away from it.
    let shared = (
        Vec3::new(0.42453447, 0.17975883, -0.8873879),
        Vec3::new(0.45793355, 0.15911707, -0.8746306),
    );
    let pair = [
        Triangle::new(
            Vec3::new(0.45426187, 0.19822723, -0.8685345),
            shared.1,
            shared.0,
        ),
        Triangle::new(
            Vec3::new(0.4278731, 0.14050053, -0.8928517),
            shared.0,
            shared.1,
        ),
    ];
    let ray = along_edge(shared.0, shared.1);
    for tri in &pair {
        assert_eq!(
            kensler_shirley(&ray, tri, 0.0, f32::INFINITY),
            None,
            "{tri:?}"
        );
    }
    // Every edge of random well-shaped triangles, both ways.
    let mut rng = Rng::new(12);
    let mut in_plane = 0;
    for _ in 0..5_000 {
        let tri = well_shaped_triangle(&mut rng);
        for (a, b) in [(tri.v0, tri.v1), (tri.v1, tri.v2), (tri.v2, tri.v0)] {
            for ray in [along_edge(a, b), along_edge(b, a)] {
                in_plane += 1;
                let hit = kensler_shirley(&ray, &tri, f32::NEG_INFINITY, f32::INFINITY);
                assert_eq!(hit, None, "{tri:?} {ray:?}");
            }
        }
    }
    assert_eq!(in_plane, 30_000);
}

#[test]
fn kensler_shirley_still_hits_at_grazing_incidence() {
    // Incidence down to 1e-4 radians: far from the plane guard (about 1e-6 radians on these
    // triangles), and `t` still comes out near 1. Tolerance: `t`'s error grows as
    // 1/sin(incidence), 2^-24 times a few dozen roundings of `O(1)` inputs (measured worst:
    // 1.1e-3 at 1e-4 radians); we allow 1e-6/incidence, ten times that.
    let mut rng = Rng::new(13);
    for _ in 0..5_000 {
        let tri = well_shaped_triangle(&mut rng);
        let (e0, e1) = (tri.v1 - tri.v0, tri.v2 - tri.v0);
        let n = e0.cross(e1).normalize();
        let target = barycentric_point(&tri, 0.3, 0.3);
        let along = (e0 * rng.range(-1.0, 1.0) + e1 * rng.range(-1.0, 1.0)).normalize();
        let angle: f32 = [1e-4, 1e-3, 1e-2][rng.below(3)];
        let d = (along * angle.cos() + n * angle.sin()).normalize();
        let ray = Ray::new(target - d, d);
        let hit = kensler_shirley(&ray, &tri, f32::NEG_INFINITY, f32::INFINITY)
            .unwrap_or_else(|| panic!("incidence {angle}: {tri:?} {ray:?}"));
        assert!(
            (hit.t - 1.0).abs() < 1e-6 / angle,
            "incidence {angle}: t = {}",
            hit.t
        );
    }
}

/// Rays with a NaN, an infinite or an all-zero component, aimed near the triangle.
fn non_finite_rays(rng: &mut Rng, target: Vec3) -> Vec<Ray> {
    let origin = target + rng.on_sphere() * 2.0;
    let direction = target - origin;
    let mut rays = vec![Ray::new(origin, Vec3::ZERO), Ray::new(origin, -Vec3::ZERO)];
    for k in 0..3 {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let (mut o, mut d) = (origin, direction);
            o[k] = bad;
            rays.push(Ray::new(o, direction));
            d[k] = bad;
            rays.push(Ray::new(origin, d));
        }
    }
    rays
}

#[test]
fn non_finite_rays_and_intervals_never_hit() {
    for (name, intersect) in INTERSECTORS {
        let mut rng = Rng::new(6);
        for _ in 0..20_000 {
            let tri = well_shaped_triangle(&mut rng);
            let target = barycentric_point(&tri, 0.3, 0.3);
            for ray in non_finite_rays(&mut rng, target) {
                assert_eq!(
                    intersect(&ray, &tri, f32::NEG_INFINITY, f32::INFINITY),
                    None,
                    "{name} {ray:?}"
                );
            }
            let ray = ray_through(&mut rng, &tri, target);
            assert_eq!(
                intersect(&ray, &tri, f32::NAN, f32::INFINITY),
                None,
                "{name}"
            );
            assert_eq!(intersect(&ray, &tri, 0.0, f32::NAN), None, "{name}");
        }
    }
}

/// Rays and triangles on which every lane form must match the single-ray form: random, aimed at
/// the inside, the edges and the vertices (exactly zero edge functions: the `f64` path),
/// axis-aligned (signed zeros, per-lane permutations), degenerate and non-finite.
fn lane_cases(rng: &mut Rng) -> (Vec<Triangle>, Vec<Ray>) {
    let unit = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    let mut tris = vec![unit, Triangle::new(Vec3::ZERO, Vec3::Y, Vec3::X)];
    tris.extend(degenerate_triangles(Vec3::ZERO, Vec3::ONE));
    tris.extend((0..40).map(|_| well_shaped_triangle(rng)));
    let mut rays = Vec::new();
    for tri in &tris[..] {
        for _ in 0..24 {
            let (u, v) = match rng.below(4) {
                0 => (0.0, rng.unit()),
                1 => (rng.unit(), 0.0),
                2 => (0.0, 0.0),
                _ => (rng.unit() * 1.4 - 0.2, rng.unit() * 1.4 - 0.2),
            };
            let target = barycentric_point(tri, u, v);
            if target.is_finite() {
                let origin = target + rng.on_sphere() * 2.0;
                rays.push(Ray::new(origin, target - origin));
                // Axis-aligned through the same point, both ways along each axis.
                let axis = [Vec3::X, Vec3::Y, Vec3::Z][rng.below(3)]
                    * if rng.chance(0.5) { 1.0 } else { -1.0 };
                rays.push(Ray::new(target - axis, axis));
            }
        }
        rays.push(along_edge(tri.v0, tri.v1));
        rays.push(along_edge(tri.v2, tri.v1));
    }
    rays.extend(non_finite_rays(rng, Vec3::new(0.25, 0.25, 0.0)));
    for ray in rays.iter_mut() {
        (ray.tmin, ray.tmax) = match rng.below(4) {
            0 => (0.0, f32::INFINITY),
            1 => (rng.range(0.0, 1.5), rng.range(0.5, 3.0)),
            2 => (f32::NEG_INFINITY, rng.range(0.0, 2.0)),
            _ => (1.0, 1.0),
        };
    }
    let mut shuffled = Vec::with_capacity(rays.len());
    while !rays.is_empty() {
        shuffled.push(rays.swap_remove(rng.below(rays.len())));
    }
    (tris, shuffled)
}

/// Lane forms of both tests against their single-ray forms, bit for bit; returns the failures
/// and how many lanes were compared.
struct LanesVsSingle {
    tris: Vec<Triangle>,
    rays: Vec<Ray>,
}

impl LaneTask for LanesVsSingle {
    type Output = (Vec<String>, usize);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> (Vec<String>, usize) {
        let mut failures = Vec::new();
        let mut compared = 0;
        for group in self.rays.chunks_exact(L::WIDTH) {
            let lanes = gather(l, group);
            let tmin = l.load(&group.iter().map(|r| r.tmin).collect::<Vec<_>>());
            let tmax = l.load(&group.iter().map(|r| r.tmax).collect::<Vec<_>>());
            let prepared = WatertightLanes::new(l, &lanes);
            for tri in &self.tris {
                let results: [(&str, LaneHits<L>, Intersector); 2] = [
                    (
                        "kensler_shirley",
                        kensler_shirley::intersect_lanes(
                            l,
                            &lanes,
                            &KsTriangle::from(tri),
                            tmin,
                            tmax,
                        ),
                        kensler_shirley,
                    ),
                    (
                        "watertight",
                        prepared.intersect(l, tri, tmin, tmax),
                        watertight,
                    ),
                ];
                for (name, got, single) in results {
                    let (t, u, v) = (lanes_of(l, got.t), lanes_of(l, got.u), lanes_of(l, got.v));
                    for (i, ray) in group.iter().enumerate() {
                        compared += 1;
                        let want = single(ray, tri, ray.tmin, ray.tmax);
                        let hit = got.mask.bits() >> i & 1 != 0;
                        let agrees = match want {
                            None => !hit,
                            Some(w) => hit && same(t[i], w.t) && same(u[i], w.u) && same(v[i], w.v),
                        };
                        if !agrees {
                            failures.push(format!(
                                "{} {name} lane {i}: got {hit} ({}, {}, {}), want {want:?}; {ray:?} {tri:?}",
                                L::ISA,
                                t[i],
                                u[i],
                                v[i]
                            ));
                        }
                    }
                }
            }
        }
        (failures, compared)
    }
}

#[test]
fn lane_forms_equal_single_ray_forms_bit_for_bit_on_every_isa() {
    let mut rng = Rng::new(8);
    let (tris, rays) = lane_cases(&mut rng);
    for isa in Isa::available() {
        let task = LanesVsSingle {
            tris: tris.clone(),
            rays: rays.clone(),
        };
        let (failures, compared) = Dispatch::new(isa).expect("available ISA runs").run(task);
        assert!(compared > 100_000, "{isa}: only {compared} lanes compared");
        assert!(
            failures.is_empty(),
            "{isa}: {} failures, first {:#?}",
            failures.len(),
            &failures[..failures.len().min(5)]
        );
    }
}

#[test]
fn rays_through_an_edge_line_take_the_f64_path_and_still_hit() {
    // The ray runs down the z axis through (0.5, 0, 0), on the edge v0–v1 of the unit triangle:
    // in the sheared frame that edge's function is exactly 0.
    let tri = Triangle::new(Vec3::ZERO, Vec3::X, Vec3::Y);
    let neighbour = Triangle::new(Vec3::X, Vec3::ZERO, -Vec3::Y);
    let ray = Ray::new(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z);
    let hit = watertight(&ray, &tri, 0.0, f32::INFINITY).expect("edge hit");
    assert_eq!((hit.t, hit.u, hit.v), (1.0, 0.5, 0.0));
    assert!(watertight(&ray, &neighbour, 0.0, f32::INFINITY).is_some());
    // Shifted by the smallest step off the edge line, exactly one of the two is hit.
    for y in [f32::from_bits(1), -f32::from_bits(1), 1e-30, -1e-30] {
        let ray = Ray::new(Vec3::new(0.5, y, 1.0), -Vec3::Z);
        let hits = [tri, neighbour].map(|t| watertight(&ray, &t, 0.0, f32::INFINITY).is_some());
        assert_eq!(
            hits.iter().filter(|&&h| h).count(),
            1,
            "y = {y:e}: {hits:?}"
        );
    }
}

/// The block forms (one ray against `WIDTH` triangles of a [`TriangleBlock`]) against the
/// single-ray forms, bit for bit; padding lanes must never hit, even unmasked. Returns the
/// failures and how many lanes were compared.
struct BlockVsSingle {
    tris: Vec<Triangle>,
    rays: Vec<Ray>,
}

impl LaneTask for BlockVsSingle {
    type Output = (Vec<String>, usize);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> (Vec<String>, usize) {
        let mut failures = Vec::new();
        let mut compared = 0;
        // Blocks of every fill, 1 to BLOCK real triangles, so that every lane is padding in some.
        let mut blocks = Vec::new();
        let mut start = 0;
        for count in (1..=BLOCK).cycle() {
            if start >= self.tris.len() {
                break;
            }
            let chunk = &self.tris[start..(start + count).min(self.tris.len())];
            let lanes = chunk.iter().zip(start as u32..).map(|(t, id)| (*t, id));
            blocks.push((TriangleBlock::new(chunk[0].v0, lanes), chunk.len(), start));
            start += count;
        }
        // The packets' per-block Kensler–Shirley form equals the single triangle's, lane by lane.
        for (block, count, start) in &blocks {
            let form = KsBlock::new(l, block);
            for lane in 0..BLOCK {
                let (got, want) = (form.triangle(block, lane), block.ks_triangle(lane));
                let pairs = [
                    (got.p0, want.p0),
                    (got.e0, want.e0),
                    (got.e1, want.e1),
                    (got.n, want.n),
                ];
                if !pairs.iter().all(|(a, b)| (0..3).all(|k| same(a[k], b[k]))) {
                    failures.push(format!(
                        "{} KsBlock lane {lane} of {count} (block at {start})",
                        L::ISA
                    ));
                }
            }
        }
        let all = (1u32 << L::WIDTH) - 1;
        for ray in &self.rays {
            let w = WatertightRay::new(ray);
            for (block, count, start) in &blocks {
                for first in (0..BLOCK).step_by(L::WIDTH) {
                    let (tmin, tmax) = (ray.tmin, ray.tmax);
                    let results: [(&str, LaneHits<L>, Intersector); 2] = [
                        (
                            "kensler_shirley",
                            kensler_shirley::intersect_block(l, ray, block, first, tmin, tmax),
                            kensler_shirley,
                        ),
                        (
                            "watertight",
                            w.intersect_block(l, block, first, all, (tmin, tmax)),
                            watertight,
                        ),
                    ];
                    for (name, got, single) in results {
                        let (t, u, v) =
                            (lanes_of(l, got.t), lanes_of(l, got.u), lanes_of(l, got.v));
                        for i in 0..L::WIDTH {
                            compared += 1;
                            let lane = first + i;
                            let hit = got.mask.bits() >> i & 1 != 0;
                            let want = if lane < *count {
                                single(ray, &self.tris[start + lane], tmin, tmax)
                            } else {
                                None
                            };
                            let agrees = match want {
                                None => !hit,
                                Some(w) => {
                                    hit && same(t[i], w.t) && same(u[i], w.u) && same(v[i], w.v)
                                }
                            };
                            if !agrees {
                                failures.push(format!(
                                    "{} {name} lane {lane} of {count}: got {hit} ({}, {}, {}), \
                                     want {want:?}; {ray:?} {:?}",
                                    L::ISA,
                                    t[i],
                                    u[i],
                                    v[i],
                                    block.triangle(lane)
                                ));
                            }
                        }
                    }
                    // Lanes left out of `valid` never hit.
                    let masked = w.intersect_block(l, block, first, 0, (tmin, tmax));
                    if masked.mask.any() {
                        failures.push(format!("{} watertight hit with no valid lane", L::ISA));
                    }
                }
            }
        }
        (failures, compared)
    }
}

#[test]
fn block_forms_equal_single_ray_forms_bit_for_bit_and_padding_never_hits_on_every_isa() {
    let mut rng = Rng::new(9);
    let (tris, rays) = lane_cases(&mut rng);
    for isa in Isa::available() {
        let task = BlockVsSingle {
            tris: tris.clone(),
            rays: rays.clone(),
        };
        let (failures, compared) = Dispatch::new(isa).expect("available ISA runs").run(task);
        assert!(compared > 100_000, "{isa}: only {compared} lanes compared");
        assert!(
            failures.is_empty(),
            "{isa}: {} failures, first {:#?}",
            failures.len(),
            &failures[..failures.len().min(5)]
        );
    }
}

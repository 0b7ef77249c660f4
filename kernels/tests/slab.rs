//! Ray × box clipping: zero direction components with the origin inside, outside and exactly on
//! a face plane; a brute-force point-sampling reference; lanes against the single-ray form.
#![cfg(feature = "std")] // `Dispatch::new` detects the CPU.

mod common;

use common::{gather, lanes_of, same, Rng};
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::slab::{
    clip_planes, clip_planes_fused, exact_interval, fused_offsets, ray_box, slab_lanes,
};
use kdbeam_kernels::{Aabb, Isa, LaneF32, LaneMask, LaneTask, Lanes, Ray, Vec3};

fn unit_box() -> Aabb {
    Aabb::new(Vec3::ZERO, Vec3::ONE)
}

#[test]
fn zero_components_clip_by_the_origin_alone() {
    let b = unit_box();
    for zero in [0.0f32, -0.0] {
        let direction = Vec3::new(1.0, zero, zero);
        let inv = direction.recip();
        // Inside the y and z slabs, in them on a face plane, on an edge line: [0, 1] in x.
        for (y, z) in [
            (0.5, 0.5),
            (0.0, 0.5),
            (1.0, 0.5),
            (0.5, 0.0),
            (0.0, 1.0),
            (1.0, 1.0),
        ] {
            let origin = Vec3::new(-1.0, y, z);
            assert_eq!(
                ray_box(origin, inv, 0.0, f32::INFINITY, &b),
                Some((1.0, 2.0)),
                "{origin} {direction}"
            );
        }
        // Outside a y or z slab by any amount: miss.
        for (y, z) in [
            (-1e-7, 0.5),
            (1.0 + 1e-7, 0.5),
            (0.5, -f32::MIN_POSITIVE),
            (2.0, 2.0),
        ] {
            let origin = Vec3::new(-1.0, y, z);
            assert_eq!(
                ray_box(origin, inv, 0.0, f32::INFINITY, &b),
                None,
                "{origin} {direction}"
            );
        }
    }
    // All components zero: the interval is [tmin, tmax] inside (boundary included), empty outside.
    for zero in [Vec3::ZERO, -Vec3::ZERO] {
        let inv = zero.recip();
        assert_eq!(
            ray_box(Vec3::splat(0.5), inv, 0.0, 3.0, &b),
            Some((0.0, 3.0))
        );
        assert_eq!(ray_box(Vec3::ONE, inv, 0.0, 3.0, &b), Some((0.0, 3.0)));
        assert_eq!(ray_box(Vec3::ZERO, inv, 0.0, 3.0, &b), Some((0.0, 3.0)));
        assert_eq!(ray_box(Vec3::new(0.5, 0.5, 1.5), inv, 0.0, 3.0, &b), None);
    }
    // A flat box with the ray in its plane.
    let flat = Aabb::new(Vec3::new(0.0, 0.0, 2.0), Vec3::new(1.0, 1.0, 2.0));
    let origin = Vec3::new(-1.0, 0.5, 2.0);
    assert_eq!(
        ray_box(origin, Vec3::new(1.0, 0.0, 0.0).recip(), 0.0, 9.0, &flat),
        Some((1.0, 2.0))
    );
}

#[test]
fn nan_interval_and_empty_box_give_nothing() {
    let (origin, inv) = (Vec3::splat(-1.0), Vec3::ONE.recip());
    assert_eq!(ray_box(origin, inv, f32::NAN, 9.0, &unit_box()), None);
    assert_eq!(ray_box(origin, inv, 0.0, f32::NAN, &unit_box()), None);
    assert_eq!(ray_box(origin, inv, 0.0, 9.0, &Aabb::EMPTY), None);
    assert_eq!(
        ray_box(
            origin,
            Vec3::new(1.0, 0.0, 0.0).recip(),
            0.0,
            9.0,
            &Aabb::EMPTY
        ),
        None
    );
    // The interval is clipped to [tmin, tmax].
    assert_eq!(
        ray_box(origin, inv, 1.5, 1.75, &unit_box()),
        Some((1.5, 1.75))
    );
    assert_eq!(ray_box(origin, inv, 2.5, 9.0, &unit_box()), None);
}

/// A ray with random zero components (of either sign), its origin sometimes snapped onto the
/// box's face planes, and a finite interval.
fn random_ray(rng: &mut Rng, b: &Aabb) -> Ray {
    let mut origin = rng.in_cube(2.0);
    let mut direction = rng.on_sphere();
    for k in 0..3 {
        if rng.chance(0.3) {
            direction[k] = if rng.chance(0.5) { 0.0 } else { -0.0 };
        }
        if rng.chance(0.3) {
            origin[k] = if rng.chance(0.5) { b.min[k] } else { b.max[k] };
        }
    }
    let tmin = if rng.chance(0.5) {
        0.0
    } else {
        rng.range(-1.0, 2.0)
    };
    Ray {
        origin,
        direction,
        tmin,
        tmax: tmin + rng.range(0.0, 5.0),
    }
}

fn random_box(rng: &mut Rng) -> Aabb {
    let (a, b) = (rng.in_cube(1.5), rng.in_cube(1.5));
    let mut bx = Aabb::new(a.min(b), a.max(b));
    if rng.chance(0.1) {
        bx.max.x = bx.min.x; // flat boxes are boxes too
    }
    bx
}

#[test]
fn intervals_match_point_sampling() {
    // Reference: 4001 points `o + t·d` in `f64` at evenly spaced `t` in [tmin, tmax], each tested
    // against the closed box. Every sample inside the box must lie in the returned interval, up
    // to 1e-5 in `t` (the slab's `t` rounds 3 times at 6e-8 relative, on |t| <= 7, so its error
    // is below 2e-6); and if the interval is not empty, its midpoint must be inside the box, up
    // to 1e-5 in space (same argument). Zero components and origins on face planes are exact in
    // both.
    const SAMPLES: usize = 4000;
    const EPS: f64 = 1e-5;
    let mut rng = Rng::new(21);
    let (mut hits, mut misses) = (0, 0);
    for _ in 0..20_000 {
        let b = random_box(&mut rng);
        let ray = random_ray(&mut rng, &b);
        let got = ray_box(ray.origin, ray.direction.recip(), ray.tmin, ray.tmax, &b);
        let (o, d) = (ray.origin.as_dvec3(), ray.direction.as_dvec3());
        let (lo, hi) = (b.min.as_dvec3(), b.max.as_dvec3());
        let inside = |t: f64, eps: f64| {
            let p = o + d * t;
            (p.cmpge(lo - eps) & p.cmple(hi + eps)).all()
        };
        let (t0, t1) = (ray.tmin as f64, ray.tmax as f64);
        for s in 0..=SAMPLES {
            let t = t0 + (t1 - t0) * s as f64 / SAMPLES as f64;
            if inside(t, 0.0) {
                let (near, far) = got.unwrap_or_else(|| panic!("missed t = {t}: {ray:?} {b:?}"));
                assert!(
                    near as f64 - EPS <= t && t <= far as f64 + EPS,
                    "t = {t} outside ({near}, {far}): {ray:?} {b:?}"
                );
            }
        }
        match got {
            Some((near, far)) => {
                hits += 1;
                assert!(ray.tmin <= near && near <= far && far <= ray.tmax);
                assert!(
                    inside((near as f64 + far as f64) / 2.0, EPS),
                    "({near}, {far}) {ray:?} {b:?}"
                );
            }
            None => misses += 1,
        }
    }
    // Both outcomes are well represented, so neither half of the check is vacuous.
    assert!(
        hits > 2_000 && misses > 2_000,
        "hits {hits}, misses {misses}"
    );
}

/// Where lane `i` (`hit`, `(near, far)`) disagrees with `ray_box` for `ray` and `b`, bit for bit.
fn disagreement(
    isa: Isa,
    i: usize,
    ray: &Ray,
    b: &Aabb,
    hit: bool,
    (near, far): (f32, f32),
) -> Option<String> {
    let want = ray_box(ray.origin, ray.direction.recip(), ray.tmin, ray.tmax, b);
    let agrees = match want {
        None => !hit,
        Some((n, f)) => hit && same(near, n) && same(far, f),
    };
    (!agrees).then(|| format!("{isa} lane {i}: {hit} ({near}, {far}) want {want:?}: {ray:?} {b:?}"))
}

/// `slab_lanes` against `ray_box`, bit for bit, on the random rays and boxes above plus NaN.
struct LanesVsSingle {
    rays: Vec<Ray>,
    boxes: Vec<Aabb>,
}

impl LaneTask for LanesVsSingle {
    type Output = Vec<String>;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<String> {
        let mut failures = Vec::new();
        for (group, b) in self.rays.chunks_exact(L::WIDTH).zip(&self.boxes) {
            let lanes = gather(l, group);
            let inv = lanes.direction.map(|d| l.splat(1.0) / d);
            let tmin = l.load(&group.iter().map(|r| r.tmin).collect::<Vec<_>>());
            let tmax = l.load(&group.iter().map(|r| r.tmax).collect::<Vec<_>>());
            let (mask, near, far) = slab_lanes(l, &lanes.origin, &inv, tmin, tmax, b);
            let (near, far) = (lanes_of(l, near), lanes_of(l, far));
            for (i, ray) in group.iter().enumerate() {
                let hit = mask.bits() >> i & 1 != 0;
                failures.extend(disagreement(L::ISA, i, ray, b, hit, (near[i], far[i])));
            }
        }
        failures
    }
}

#[test]
fn lanes_equal_the_single_ray_form_bit_for_bit_on_every_isa() {
    let mut rng = Rng::new(22);
    let boxes: Vec<Aabb> = (0..20_000).map(|_| random_box(&mut rng)).collect();
    let mut rays: Vec<Ray> = Vec::new();
    for b in &boxes {
        for _ in 0..8 {
            let mut ray = random_ray(&mut rng, b);
            if rng.chance(0.02) {
                ray.origin[rng.below(3)] = f32::NAN;
            }
            if rng.chance(0.02) {
                ray.tmin = f32::NAN;
            }
            rays.push(ray);
        }
    }
    for isa in Isa::available() {
        let task = LanesVsSingle {
            rays: rays.clone(),
            boxes: boxes.clone(),
        };
        let failures = Dispatch::new(isa).expect("available ISA runs").run(task);
        assert!(
            failures.is_empty(),
            "{} failures, first {:#?}",
            failures.len(),
            &failures[..failures.len().min(5)]
        );
    }
}

/// `clip_planes`, one ray against a vector of boxes (the wide nodes' test), against `ray_box`
/// box by box, bit for bit; a lane holding the empty box of a missing child (`min = +inf`,
/// `max = −inf`) is never entered.
struct BoxesVsSingle {
    rays: Vec<Ray>,
    boxes: Vec<Aabb>,
}

impl LaneTask for BoxesVsSingle {
    type Output = (Vec<String>, usize);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> (Vec<String>, usize) {
        let (mut failures, mut entered) = (Vec::new(), 0);
        for (ray, boxes) in self.rays.iter().zip(self.boxes.chunks_exact(L::WIDTH)) {
            let inv = ray.direction.recip();
            let (o, iv) = (ray.origin.to_array(), inv.to_array());
            let (enter, exit) = planes_by_sign(l, boxes, iv);
            let (near, far) = clip_planes(
                &o.map(|x| l.splat(x)),
                &iv.map(|x| l.splat(x)),
                enter,
                exit,
                l.splat(ray.tmin),
                l.splat(ray.tmax),
            );
            let inside = near.le(far).bits();
            let (near, far) = (lanes_of(l, near), lanes_of(l, far));
            for (i, b) in boxes.iter().enumerate() {
                let hit = inside >> i & 1 != 0;
                entered += usize::from(hit);
                failures.extend(disagreement(L::ISA, i, ray, b, hit, (near[i], far[i])));
            }
        }
        (failures, entered)
    }
}

/// The planes of `boxes` (one a lane) a ray with reciprocal direction `iv` enters and leaves
/// them by: `min` where `iv >= 0` (`+0` included), `max` where it is negative.
fn planes_by_sign<L: Lanes>(l: L, boxes: &[Aabb], iv: [f32; 3]) -> ([L::F32; 3], [L::F32; 3]) {
    let row = |f: &dyn Fn(&Aabb) -> f32| l.load(&boxes.iter().map(f).collect::<Vec<_>>());
    let (mut enter, mut exit) = ([l.splat(0.0); 3], [l.splat(0.0); 3]);
    for k in 0..3 {
        let (lo, hi) = (row(&|b| b.min[k]), row(&|b| b.max[k]));
        (enter[k], exit[k]) = if iv[k] < 0.0 { (hi, lo) } else { (lo, hi) };
    }
    (enter, exit)
}

#[test]
fn one_ray_against_a_vector_of_boxes_equals_the_single_box_form_on_every_isa() {
    let mut rng = Rng::new(23);
    let missing = Aabb::new(Vec3::INFINITY, Vec3::NEG_INFINITY);
    let mut boxes: Vec<Aabb> = Vec::new();
    let mut rays: Vec<Ray> = Vec::new();
    for _ in 0..4_000 {
        let shared = random_box(&mut rng);
        rays.push(random_ray(&mut rng, &shared));
        for _ in 0..16 {
            boxes.push(match rng.below(4) {
                0 => missing,
                1 => shared,
                _ => random_box(&mut rng),
            });
        }
    }
    for isa in Isa::available() {
        let task = BoxesVsSingle {
            rays: rays.clone(),
            boxes: boxes.clone(),
        };
        let (failures, entered) = Dispatch::new(isa).expect("available ISA runs").run(task);
        assert!(
            failures.is_empty(),
            "{} failures, first {:#?}",
            failures.len(),
            &failures[..failures.len().min(5)]
        );
        // Both outcomes occur on every ISA (scalar lanes take one box a ray), so the comparison
        // is not vacuous.
        let tested = rays.len() * isa.width();
        assert!(
            entered * 50 > tested && entered < tested,
            "{isa}: {entered} of {tested} boxes entered"
        );
    }
}

/// `clip_planes_fused`, widened by `(|t| + err)·2⁻²¹` (`err` the largest finite `|o·inv|`, half
/// the widening of the wide nodes' walk), holds the exact interval (`f64`, the true `1/d`) of
/// every box the ray meets, on every ISA (with FMA and without); rays include zero components,
/// origins on face planes, and far origins with tiny components, whose `o·inv` is large or
/// overflows.
struct FusedHoldsExact {
    rays: Vec<Ray>,
    boxes: Vec<Aabb>,
}

impl LaneTask for FusedHoldsExact {
    type Output = (Vec<String>, usize);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> (Vec<String>, usize) {
        let (mut failures, mut entered) = (Vec::new(), 0);
        for (ray, boxes) in self.rays.iter().zip(self.boxes.chunks_exact(L::WIDTH)) {
            let inv = ray.direction.recip();
            let iv = inv.to_array();
            let (enter, exit) = planes_by_sign(l, boxes, iv);
            let (near, far) = clip_planes_fused(
                &fused_offsets(ray.origin, inv).map(|x| l.splat(x)),
                &iv.map(|x| l.splat(x)),
                enter,
                exit,
                l.splat(ray.tmin),
                l.splat(ray.tmax),
            );
            let err = (0..3)
                .map(|k| (ray.origin[k] * iv[k]).abs())
                .filter(|e| e.is_finite())
                .fold(0f32, f32::max);
            let (near, far) = (lanes_of(l, near), lanes_of(l, far));
            for (i, b) in boxes.iter().enumerate() {
                let Some((n, f)) = exact_interval(ray, b) else {
                    continue;
                };
                entered += 1;
                let slack = |t: f32| f64::from((t.abs() + err) * (1.0 / 2_097_152.0));
                let (lo, hi) = (
                    f64::from(near[i]) - slack(near[i]),
                    f64::from(far[i]) + slack(far[i]),
                );
                if !(lo <= n && hi >= f) {
                    failures.push(format!(
                        "{} lane {i}: ({lo}, {hi}) misses exact ({n}, {f}): {ray:?} {b:?}",
                        L::ISA
                    ));
                }
            }
        }
        (failures, entered)
    }
}

#[test]
fn fused_planes_widened_hold_the_exact_interval_on_every_isa() {
    let mut rng = Rng::new(29);
    let (mut boxes, mut rays) = (Vec::new(), Vec::new());
    for _ in 0..4_000 {
        let shared = random_box(&mut rng);
        let mut ray = random_ray(&mut rng, &shared);
        if rng.chance(0.2) {
            // Far out along one axis, moving on it by a tiny amount: a large or overflowing o·inv.
            let k = rng.below(3);
            ray.origin[k] = if rng.chance(0.5) { 1e3 } else { -1e30 };
            ray.direction[k] = if rng.chance(0.5) { 1e-20 } else { -1e-12 };
        }
        rays.push(ray);
        for _ in 0..16 {
            boxes.push(if rng.chance(0.3) {
                shared
            } else {
                random_box(&mut rng)
            });
        }
    }
    for isa in Isa::available() {
        let task = FusedHoldsExact {
            rays: rays.clone(),
            boxes: boxes.clone(),
        };
        let (failures, entered) = Dispatch::new(isa).expect("available ISA runs").run(task);
        assert!(
            failures.is_empty(),
            "{} failures, first {:#?}",
            failures.len(),
            &failures[..failures.len().min(5)]
        );
        // Scalar lanes take one box a ray: at least 2% of the boxes are met on every ISA.
        let tested = rays.len() * isa.width();
        assert!(
            entered * 50 > tested,
            "{isa}: {entered} of {tested} boxes met"
        );
    }
}

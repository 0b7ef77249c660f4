//! Every `Lanes` implementation available on this machine against `Scalar`, lane by lane, bit for
//! bit (NaN payloads excepted), on random values and special values (NaN, ±inf, ±0, denormals).
#![cfg(feature = "std")] // `Dispatch::new` detects the CPU.

mod common;

use common::{lanes_of, same, Rng};
use kdbeam_kernels::lanes::{Dispatch, IsaError};
use kdbeam_kernels::{Isa, LaneCount, LaneF32, LaneMask, LaneTask, Lanes};

/// Rounds of random inputs per ISA.
const ROUNDS: usize = 20_000;

/// Compares every `LaneF32` operation with the scalar one; returns the failures.
struct OpsVsScalar {
    seed: u64,
}

/// A scalar reference of a lane operation on lane values `(a, b, c)`.
type Reference = fn(f32, f32, f32) -> f32;

/// A scalar reference of a lane comparison.
type Predicate = fn(f32, f32) -> bool;

impl LaneTask for OpsVsScalar {
    type Output = Vec<String>;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<String> {
        let mut rng = Rng::new(self.seed);
        let mut failures = Vec::new();
        let w = L::WIDTH;
        for _ in 0..ROUNDS {
            let mut a: Vec<f32> = (0..w).map(|_| rng.any_f32()).collect();
            let b: Vec<f32> = (0..w)
                .map(|i| match rng.below(4) {
                    0 => a[i],
                    1 => -a[i],
                    _ => rng.any_f32(),
                })
                .collect();
            let c: Vec<f32> = (0..w).map(|_| rng.any_f32()).collect();
            if rng.chance(0.1) {
                a.iter_mut().for_each(|x| *x = f32::NAN);
            }
            let (va, vb, vc) = (l.load(&a), l.load(&b), l.load(&c));

            // FMA only on AVX2 + FMA and AVX-512: one rounding there (`f32::mul_add` is the fused
            // reference), two elsewhere. A non-fused `mul_add` there fails this on most random
            // inputs.
            let mul_add: Reference = if matches!(L::ISA, Isa::Avx2 | Isa::Avx512) {
                |x, y, z| x.mul_add(y, z)
            } else {
                |x, y, z| x * y + z
            };
            let values: [(&str, L::F32, Reference); 12] = [
                ("add", va + vb, |x, y, _| x + y),
                ("sub", va - vb, |x, y, _| x - y),
                ("mul", va * vb, |x, y, _| x * y),
                ("div", va / vb, |x, y, _| x / y),
                ("neg", -va, |x, _, _| -x),
                ("abs", va.abs(), |x, _, _| LaneF32::abs(x)),
                ("min", va.min(vb), |x, y, _| LaneF32::min(x, y)),
                ("max", va.max(vb), |x, y, _| LaneF32::max(x, y)),
                ("mul_add", va.mul_add(vb, vc), mul_add),
                ("select", L::F32::select(va.lt(vb), vc, vb), |x, y, z| {
                    if x < y {
                        z
                    } else {
                        y
                    }
                }),
                (
                    "masked",
                    vc.masked(va.lt(vb)),
                    |x, y, z| if x < y { z } else { 0.0 },
                ),
                ("splat", l.splat(c[0]), |_, _, _| f32::NAN),
            ];
            for (name, v, reference) in values {
                let got = lanes_of(l, v);
                for i in 0..w {
                    let want = if name == "splat" {
                        c[0]
                    } else {
                        reference(a[i], b[i], c[i])
                    };
                    if !same(got[i], want) || !same(v.extract(i), want) {
                        failures.push(format!(
                            "{}: {name}({}, {}, {}) lane {i} = {} want {want}",
                            L::ISA,
                            a[i],
                            b[i],
                            c[i],
                            got[i]
                        ));
                    }
                }
            }

            let masks: [(&str, L::Mask, Predicate); 6] = [
                ("lt", va.lt(vb), |x, y| x < y),
                ("le", va.le(vb), |x, y| x <= y),
                ("gt", va.gt(vb), |x, y| x > y),
                ("ge", va.ge(vb), |x, y| x >= y),
                ("eq", va.eq(vb), |x, y| x == y),
                ("is_nan", va.is_nan(), |x, _| x.is_nan()),
            ];
            for (name, m, reference) in masks {
                let want = (0..w).fold(0, |bits, i| bits | (reference(a[i], b[i]) as u32) << i);
                if m.bits() != want {
                    failures.push(format!(
                        "{}: {name}({a:?}, {b:?}) = {:b} want {want:b}",
                        L::ISA,
                        m.bits()
                    ));
                }
            }

            // Sign bits as the floats carry them: −0.0, −inf and negative NaNs included.
            let b_signs: Vec<f32> = b.iter().map(|&x| if x.is_nan() { -x } else { x }).collect();
            for values in [&a, &c, &b_signs] {
                let want = (0..w).fold(0, |bits, i| {
                    bits | (values[i].is_sign_negative() as u32) << i
                });
                let got = l.load(values).sign_bits();
                if got != want {
                    failures.push(format!(
                        "{}: sign_bits({values:?}) = {got:b} want {want:b}",
                        L::ISA
                    ));
                }
            }

            // Reductions ignore NaN lanes; which zero comes out of a ±0 tie is unspecified, so
            // they are compared with `==` (and +-inf for all-NaN vectors).
            let non_nan = a.iter().copied().filter(|x| !x.is_nan());
            let want_min = non_nan.clone().fold(f32::INFINITY, f32::min);
            let want_max = non_nan.fold(f32::NEG_INFINITY, f32::max);
            if va.reduce_min() != want_min || va.reduce_max() != want_max {
                failures.push(format!(
                    "{}: reduce of {a:?} = ({}, {}) want ({want_min}, {want_max})",
                    L::ISA,
                    va.reduce_min(),
                    va.reduce_max()
                ));
            }
        }
        failures
    }
}

#[test]
fn every_f32_op_matches_scalar_lane_by_lane() {
    passes_on_every_isa(|| OpsVsScalar { seed: 7 });
}

/// Runs the task `make` returns on every ISA this CPU has; fails with the first failures it
/// reports, or when a vector ISA this CPU has was skipped.
fn passes_on_every_isa<T: LaneTask<Output = Vec<String>>>(make: impl Fn() -> T) {
    let mut ran = Vec::new();
    for isa in Isa::available() {
        let failures = Dispatch::new(isa).expect("available ISA runs").run(make());
        assert!(
            failures.is_empty(),
            "{} failures, first: {:#?}",
            failures.len(),
            &failures[..failures.len().min(10)]
        );
        ran.push(isa);
    }
    assert_every_vector_isa_ran(&ran);
}

/// Fails when this CPU has AVX2 + FMA (or AVX-512F/BW/DQ/VL) but `ran` lacks that ISA: the
/// vector paths must not be skipped silently. Says which ISAs ran, and which were skipped.
fn assert_every_vector_isa_ran(ran: &[Isa]) {
    let has = |f: &[&str]| f.iter().all(|f| std_detect_has(f));
    let mut want = vec![Isa::Scalar, Isa::Portable];
    if has(&["sse4.1"]) {
        want.push(Isa::Sse);
    }
    if has(&["avx2", "fma"]) {
        want.push(Isa::Avx2);
    }
    if has(&["avx2", "fma", "avx512f", "avx512bw", "avx512dq", "avx512vl"]) {
        want.push(Isa::Avx512);
    }
    let skipped: Vec<Isa> = Isa::ALL.into_iter().filter(|i| !ran.contains(i)).collect();
    eprintln!("ran on {ran:?}; skipped (not on this CPU) {skipped:?}");
    assert_eq!(ran, want.as_slice());
}

/// `is_x86_feature_detected!` by name, for the features the x86 ISAs need.
fn std_detect_has(feature: &str) -> bool {
    match feature {
        "sse4.1" => std::is_x86_feature_detected!("sse4.1"),
        "avx2" => std::is_x86_feature_detected!("avx2"),
        "fma" => std::is_x86_feature_detected!("fma"),
        "avx512f" => std::is_x86_feature_detected!("avx512f"),
        "avx512bw" => std::is_x86_feature_detected!("avx512bw"),
        "avx512dq" => std::is_x86_feature_detected!("avx512dq"),
        "avx512vl" => std::is_x86_feature_detected!("avx512vl"),
        _ => unreachable!("no ISA needs {feature}"),
    }
}

/// The special values, each placed in every lane in turn (the others holding `1.0`), against
/// the scalar semantics: `min`/`max` return the second operand when either is NaN (x86
/// `minps`), `-0.0` and `+0.0` compare equal but keep their sign bits, infinities order, and
/// the reductions skip NaN lanes. The upper lanes of a 16-lane vector are where a half-wide
/// implementation would go wrong.
struct SpecialsInEveryLane;

impl LaneTask for SpecialsInEveryLane {
    type Output = Vec<String>;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<String> {
        let specials = [
            f32::NAN,
            -f32::NAN,
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MIN_POSITIVE / 2.0,
            -1.5,
        ];
        let mut failures = Vec::new();
        for &x in &specials {
            for &y in &specials {
                for lane in 0..L::WIDTH {
                    let mut a = vec![1.0f32; L::WIDTH];
                    let mut b = vec![1.0f32; L::WIDTH];
                    a[lane] = x;
                    b[lane] = y;
                    let (va, vb) = (l.load(&a), l.load(&b));
                    let bit = 1u32 << lane;
                    let lanes = [
                        ("min", va.min(vb).extract(lane), if x < y { x } else { y }),
                        ("max", va.max(vb).extract(lane), if x > y { x } else { y }),
                        ("neg", (-va).extract(lane), -x),
                        ("abs", va.abs().extract(lane), x.abs()),
                        (
                            "masked",
                            va.masked(va.lt(vb)).extract(lane),
                            if x < y { x } else { 0.0 },
                        ),
                        (
                            "select",
                            L::F32::select(va.ge(vb), va, vb).extract(lane),
                            if x >= y { x } else { y },
                        ),
                    ];
                    for (name, got, want) in lanes {
                        if !same(got, want) {
                            failures.push(format!(
                                "{}: {name}({x}, {y}) lane {lane} = {got} want {want}",
                                L::ISA
                            ));
                        }
                    }
                    let masks = [
                        ("lt", va.lt(vb).bits(), x < y),
                        ("le", va.le(vb).bits(), x <= y),
                        ("gt", va.gt(vb).bits(), x > y),
                        ("ge", va.ge(vb).bits(), x >= y),
                        ("eq", va.eq(vb).bits(), x == y),
                        ("is_nan", va.is_nan().bits(), x.is_nan()),
                        ("sign_bits", va.sign_bits(), x.is_sign_negative()),
                    ];
                    for (name, got, want) in masks {
                        if (got & bit != 0) != want {
                            failures
                                .push(format!("{}: {name}({x}, {y}) lane {lane}: {got:b}", L::ISA));
                        }
                    }
                    let (lo, hi) = (va.reduce_min(), va.reduce_max());
                    let non_nan = a.iter().copied().filter(|v| !v.is_nan());
                    let want_lo = non_nan.clone().fold(f32::INFINITY, f32::min);
                    let want_hi = non_nan.fold(f32::NEG_INFINITY, f32::max);
                    if lo != want_lo || hi != want_hi {
                        failures.push(format!(
                            "{}: reduce with {x} in lane {lane} = ({lo}, {hi})",
                            L::ISA
                        ));
                    }
                }
            }
        }
        failures
    }
}

#[test]
fn special_values_behave_as_scalar_in_every_lane() {
    passes_on_every_isa(|| SpecialsInEveryLane);
}

/// Sixteen lanes of `__m512` with `__mmask16` masks, where the CPU has AVX-512: a token is made
/// by detection, and bits of a mask are its lanes, all sixteen.
#[test]
fn the_avx512_token_has_sixteen_lanes_where_detected() {
    use kdbeam_kernels::lanes::Avx512;
    let Some(l) = Avx512::try_new() else {
        eprintln!("skipped: this CPU lacks AVX-512F/BW/DQ/VL");
        assert!(!Isa::Avx512.is_available());
        return;
    };
    assert_eq!(Avx512::WIDTH, 16);
    assert_eq!(Isa::detect(), Isa::Avx512, "the widest ISA is preferred");
    assert_eq!("AVX512".parse::<Isa>(), Ok(Isa::Avx512));
    let v: Vec<f32> = (0..16).map(|i| i as f32 - 7.5).collect();
    let lanes = lanes_of(l, l.load(&v));
    assert_eq!(lanes, v);
    assert_eq!(l.load(&v).sign_bits(), 0xff);
    assert_eq!(l.load(&v).gt(l.splat(0.0)).bits(), 0xff00);
    assert_eq!((!l.mask_from_bits(0x1_0001)).bits(), 0xfffe);
    assert_eq!(l.load(&v).reduce_min(), -7.5);
    assert_eq!(l.load(&v).reduce_max(), 7.5);
}

/// Checks masks: construction from bits, `bits`, `!` (only `WIDTH` lanes), `&`, `|`, `^`,
/// `and_not`, `any`, `none`.
struct MaskAlgebra;

impl LaneTask for MaskAlgebra {
    type Output = Vec<String>;

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<String> {
        let full = (1u32 << L::WIDTH) - 1;
        let mut failures = Vec::new();
        for x in 0..=full {
            for y in [0, full, 0b1010_0110 & full, x.rotate_left(1) & full] {
                // Bits above WIDTH must be ignored.
                let (mx, my) = (l.mask_from_bits(x | !full), l.mask_from_bits(y));
                let checks = [
                    ("from_bits", mx.bits(), x),
                    ("not", (!mx).bits(), !x & full),
                    ("and", (mx & my).bits(), x & y),
                    ("or", (mx | my).bits(), x | y),
                    ("xor", (mx ^ my).bits(), x ^ y),
                    ("and_not", mx.and_not(my).bits(), x & !y),
                    ("any", mx.any() as u32, (x != 0) as u32),
                    ("none", mx.none() as u32, (x == 0) as u32),
                ];
                for (name, got, want) in checks {
                    if got != want {
                        failures.push(format!("{}: {name}({x:b}, {y:b}) = {got:b}", L::ISA));
                    }
                }
            }
        }
        failures
    }
}

#[test]
fn mask_ops_match_their_bits() {
    for isa in Isa::available() {
        let failures = Dispatch::new(isa)
            .expect("available ISA runs")
            .run(MaskAlgebra);
        assert!(failures.is_empty(), "{failures:#?}");
    }
}

/// Reports which ISA and width it ran on, and a sum computed there.
struct WhereAmI;

impl LaneTask for WhereAmI {
    type Output = (Isa, usize, f32);

    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> (Isa, usize, f32) {
        let ones = lanes_of(l, l.splat(1.0) + l.splat(0.5));
        (L::ISA, L::WIDTH, ones.iter().sum())
    }
}

#[test]
fn a_dispatch_runs_the_task_on_its_isa() {
    for isa in Isa::ALL {
        match Dispatch::new(isa) {
            Ok(dispatch) => {
                let (ran_on, width, sum) = dispatch.run(WhereAmI);
                assert!(isa.is_available());
                assert_eq!(dispatch.isa(), isa);
                assert_eq!(ran_on, isa);
                assert_eq!(width, isa.width());
                assert_eq!(sum, 1.5 * width as f32);
            }
            Err(e) => {
                assert!(!isa.is_available(), "{isa} is available but was refused");
                assert_eq!(e, IsaError::Unavailable(isa));
            }
        }
    }
    let available: Vec<Isa> = Dispatch::available().map(Dispatch::isa).collect();
    assert_eq!(available, Isa::available().collect::<Vec<_>>());
    assert_eq!(Dispatch::detect().isa(), Isa::detect());
    assert_eq!(Dispatch::SCALAR.run(WhereAmI).0, Isa::Scalar);
    assert_eq!(Dispatch::PORTABLE.run(WhereAmI).0, Isa::Portable);
}

#[test]
#[should_panic]
fn load_from_a_short_slice_panics_instead_of_reading_past_it() {
    struct ShortLoad;
    impl LaneTask for ShortLoad {
        type Output = ();
        #[inline(always)]
        fn run<L: Lanes>(self, l: L) {
            let short = vec![1.0; L::WIDTH - 1];
            l.load(&short);
        }
    }
    Dispatch::detect().run(ShortLoad);
}

#[test]
fn truncation_of_three_lanes_is_as_i32_in_range() {
    use kdbeam_kernels::lanes::truncate_to_i32;
    let mut rng = Rng::new(5);
    for _ in 0..10_000 {
        let v = glam::Vec3A::new(
            rng.range(-40.0, 40.0),
            rng.range(0.0, 1.0),
            rng.range(-2e9, 2e9),
        );
        assert_eq!(truncate_to_i32(v), v.to_array().map(|x| x as i32), "{v}");
    }
    let edges = glam::Vec3A::new(-0.0, 0.999_999_94, 31.999_998);
    assert_eq!(truncate_to_i32(edges), [0, 0, 31]);
}

/// Counts the set lanes of `masks` (bits of mask `k`, lane `i` at bit `i`) with `LaneCount`.
struct CountSetLanes<'a>(&'a [u32]);

impl LaneTask for CountSetLanes<'_> {
    type Output = Vec<f32>;
    #[inline(always)]
    fn run<L: Lanes>(self, l: L) -> Vec<f32> {
        let counts = self.0.iter().fold(l.zero_counts(), |c, &bits| {
            c.add_set(l.mask_from_bits(bits))
        });
        lanes_of(l, counts.to_f32())
    }
}

#[test]
fn counters_count_the_set_lanes_of_every_mask() {
    let mut rng = Rng::new(9);
    let masks: Vec<u32> = (0..1000).map(|_| rng.next_u64() as u32).collect();
    for isa in Isa::available() {
        let got = Dispatch::new(isa).unwrap().run(CountSetLanes(&masks));
        let want: Vec<f32> = (0..isa.width())
            .map(|i| masks.iter().filter(|&&m| m >> i & 1 != 0).count() as f32)
            .collect();
        assert_eq!(got, want, "{isa}");
    }
}

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

            // FMA only on AVX2 + FMA: one rounding there (`f32::mul_add` is the fused reference),
            // two elsewhere. A non-fused AVX `mul_add` fails this on most random inputs.
            let mul_add: Reference = if L::ISA == Isa::Avx2 {
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
    let mut ran = Vec::new();
    for isa in Isa::available() {
        let failures = Dispatch::new(isa)
            .expect("available ISA runs")
            .run(OpsVsScalar { seed: 7 });
        assert!(
            failures.is_empty(),
            "{} failures, first: {:#?}",
            failures.len(),
            &failures[..failures.len().min(10)]
        );
        ran.push(isa);
    }
    // This machine has AVX2 + FMA: make sure the vector paths were not silently skipped.
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        assert_eq!(ran, Isa::ALL.to_vec());
    }
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

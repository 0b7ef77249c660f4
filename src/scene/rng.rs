//! Seeded random numbers: PCG32, identical on every platform.
//!
//! Generators, synthetic data and the "random" ray sets all draw from [`Rng`], so a seed names one
//! scene or one ray set everywhere. Every method uses only integer arithmetic and correctly
//! rounded float operations (`+`, `×`, `√`), never `sin`/`cos`/`exp`, whose last bits differ between
//! math libraries: the same seed gives the same bits on every target.

use glam::Vec3;

/// A small, fast, seeded pseudo-random generator: PCG32 (O'Neill 2014, "PCG: A Family of Simple
/// Fast Space-Efficient Statistically Good Algorithms for Random Number Generation", the
/// XSH-RR output function on a 64-bit linear congruential state).
///
/// Not cryptographic. The period is 2⁶⁴.
///
/// ```
/// use kdbeam::scene::rng::Rng;
/// let mut a = Rng::new(7);
/// let mut b = Rng::new(7);
/// assert_eq!(a.next_u32(), b.next_u32());
/// let x = a.range(-1.0, 1.0);
/// assert!((-1.0..1.0).contains(&x));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rng {
    state: u64,
}

/// The LCG multiplier of PCG32 (Knuth's MMIX constant).
const MULTIPLIER: u64 = 6_364_136_223_846_793_005;
/// The LCG increment (must be odd); PCG's default stream.
const INCREMENT: u64 = 1_442_695_040_888_963_407;

/// PCG's XSH-RR output function: xor the high bits down, keep 32 of them, rotate by the top 5.
#[inline]
fn xsh_rr(state: u64) -> u32 {
    let xorshifted = (((state >> 18) ^ state) >> 27) as u32;
    xorshifted.rotate_right((state >> 59) as u32)
}

impl Rng {
    /// A generator seeded with `seed`.
    ///
    /// The seed is first scrambled with SplitMix64 (Steele, Lea & Flood 2014), so that nearby seeds
    /// (0, 1, 2, …) start far apart in the sequence. Every `u64`, 0 included, is a valid seed.
    #[must_use]
    pub fn new(seed: u64) -> Rng {
        let mut z = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        // PCG's seeding procedure: step once, add the seed, step again.
        let mut rng = Rng { state: 0 };
        rng.step();
        rng.state = rng.state.wrapping_add(z);
        rng.step();
        rng
    }

    fn step(&mut self) {
        self.state = self.state.wrapping_mul(MULTIPLIER).wrapping_add(INCREMENT);
    }

    /// The next 32 uniformly distributed bits.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.step();
        xsh_rr(old)
    }

    /// The next 64 uniformly distributed bits: two [`Rng::next_u32`] draws, the first one high.
    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        let high = u64::from(self.next_u32());
        (high << 32) | u64::from(self.next_u32())
    }

    /// A uniform `f32` in [0, 1): one of the 2²⁴ multiples of 2⁻²⁴ below 1, each equally likely.
    ///
    /// Never 1, never NaN. The conversion is exact (24 bits fit the mantissa).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// A uniform `f32` in [a, b).
    ///
    /// Computed as a + (b − a)·u with u = [`Rng::next_f32`]. When rounding of that sum reaches
    /// `b` (possible only when |a| is much larger than b − a), `a` is returned instead, so the
    /// result always lies in [a, b). When `a < b` does not hold (a ≥ b, or either is NaN), or when
    /// b − a is not finite, the result is `a`; one draw is consumed in every case, so the sequence
    /// stays in step.
    #[inline]
    pub fn range(&mut self, a: f32, b: f32) -> f32 {
        let u = self.next_f32();
        // For finite a and b, b − a > 0 exactly when a < b (gradual underflow keeps it nonzero).
        let width = b - a;
        if !(width.is_finite() && width > 0.0) {
            return a;
        }
        let x = a + width * u;
        if x < b {
            x
        } else {
            a
        }
    }

    /// A uniform integer in [0, n), for n ≥ 1; 0 when n = 0.
    ///
    /// Lemire's multiply-and-shift ("Fast Random Integer Generation in an Interval", 2019), with
    /// his rejection step, so the result is exactly uniform.
    #[inline]
    pub fn below(&mut self, n: u32) -> u32 {
        if n == 0 {
            self.next_u32();
            return 0;
        }
        let threshold = n.wrapping_neg() % n;
        loop {
            let m = u64::from(self.next_u32()) * u64::from(n);
            if (m as u32) >= threshold {
                return (m >> 32) as u32;
            }
        }
    }

    /// A unit vector uniformly distributed on the sphere: [`Rng::unit_vector_in_cap`] with
    /// `min_z = −1`.
    pub fn unit_vector(&mut self) -> Vec3 {
        self.unit_vector_in_cap(-1.0)
    }

    /// A unit vector uniformly distributed on the spherical cap `z ≥ min_z`.
    ///
    /// Marsaglia's method (Ann. Math. Stat. 43, 1972) restricted to the cap: draw (x₁, x₂)
    /// uniform in the square [−r, r)², r = √((1 − min_z)/2), until s = x₁² + x₂² < r², then
    /// return (2x₁√(1−s), 2x₂√(1−s), 1 − 2s). As s is uniform on [0, r²), z = 1 − 2s is
    /// uniform on (min_z, 1], which by Archimedes' hat-box theorem is the uniform law on the
    /// cap. Each try is accepted with probability π/4; only `+`, `×` and `√` are used, so the
    /// result is the same on every platform. Its length is 1 within a few ulps.
    ///
    /// `min_z` is clamped to [−1, 1]: −1 gives the whole sphere, 1 always `+z`; NaN is treated
    /// as −1.
    pub fn unit_vector_in_cap(&mut self, min_z: f32) -> Vec3 {
        let min_z = if min_z.is_nan() {
            -1.0
        } else {
            min_z.clamp(-1.0, 1.0)
        };
        let r2 = 0.5 * (1.0 - min_z);
        if r2 == 0.0 {
            return Vec3::Z;
        }
        let r = r2.sqrt();
        loop {
            let x1 = self.range(-r, r);
            let x2 = self.range(-r, r);
            let s = x1 * x1 + x2 * x2;
            if s < r2 {
                let k = 2.0 * (1.0 - s).sqrt();
                return Vec3::new(x1 * k, x2 * k, 1.0 - 2.0 * s);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_sequence_and_different_seeds_differ() {
        let a: Vec<u32> = {
            let mut r = Rng::new(42);
            (0..64).map(|_| r.next_u32()).collect()
        };
        let b: Vec<u32> = {
            let mut r = Rng::new(42);
            (0..64).map(|_| r.next_u32()).collect()
        };
        let c: Vec<u32> = {
            let mut r = Rng::new(43);
            (0..64).map(|_| r.next_u32()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
    }

    #[test]
    fn pcg32_core_matches_the_reference_implementation() {
        // O'Neill's pcg32-demo: pcg32_srandom_r(42, 54) (increment 2·54 + 1 = 109) prints these.
        // Same multiplier and output function as ours, with the demo's seeding and stream.
        let increment = 109u64;
        let step = |s: u64| s.wrapping_mul(MULTIPLIER).wrapping_add(increment);
        let mut state = step(step(0).wrapping_add(42));
        let mut out = [0u32; 6];
        for o in &mut out {
            *o = xsh_rr(state);
            state = step(state);
        }
        assert_eq!(
            out,
            [0xa15c02b7, 0x7b47f409, 0xba1d3330, 0x83d2f293, 0xbfa4784b, 0xcbed606e]
        );
    }

    #[test]
    fn seed_0_sequence_is_pinned() {
        // Recorded once; integer arithmetic only, so identical on every platform. A change here
        // changes every seeded scene and ray set.
        let mut r = Rng::new(0);
        let first: Vec<u32> = (0..3).map(|_| r.next_u32()).collect();
        assert_eq!(first, [880_686_761, 653_768_305, 297_326_204]);
    }

    #[test]
    fn next_f32_is_in_unit_interval_with_plausible_mean() {
        let mut r = Rng::new(1);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += f64::from(x);
        }
        // Standard error of the mean of U(0,1) over 1e5 draws is 0.29/316 ≈ 0.0009; 0.005 is > 5σ.
        assert!((sum / f64::from(n) - 0.5).abs() < 0.005);
    }

    #[test]
    fn range_is_half_open_and_degenerate_bounds_give_a() {
        let mut r = Rng::new(2);
        for _ in 0..10_000 {
            let x = r.range(-3.0, 5.0);
            assert!((-3.0..5.0).contains(&x));
            // A huge offset with a tiny width: rounding would reach b without the guard.
            let y = r.range(1.0e7, 1.0e7 + 1.0);
            assert!((1.0e7..1.0e7 + 1.0).contains(&y));
        }
        assert_eq!(r.range(2.0, 2.0), 2.0);
        assert_eq!(r.range(3.0, 1.0), 3.0);
        assert_eq!(r.range(0.0, f32::NAN), 0.0);
        assert_eq!(r.range(-f32::MAX, f32::MAX), -f32::MAX);
    }

    #[test]
    fn below_stays_below_and_hits_every_value() {
        let mut r = Rng::new(3);
        let mut seen = [false; 7];
        for _ in 0..1000 {
            let k = r.below(7);
            assert!(k < 7);
            seen[k as usize] = true;
        }
        assert!(seen.iter().all(|&s| s));
        assert_eq!(r.below(0), 0);
    }

    #[test]
    fn unit_vectors_have_unit_length_and_zero_mean() {
        let mut r = Rng::new(4);
        let n = 100_000;
        let mut sum = glam::DVec3::ZERO;
        for _ in 0..n {
            let v = r.unit_vector();
            // Rounding in the formula: a few ulps of 1.
            assert!((v.length() - 1.0).abs() < 1e-6, "{v}");
            sum += v.as_dvec3();
        }
        // Each component of a uniform unit vector has variance 1/3: σ of the mean over 1e5 draws
        // is 0.0018; 0.01 is > 5σ.
        let mean = sum / f64::from(n);
        assert!(mean.abs().max_element() < 0.01, "{mean}");
    }

    #[test]
    fn cap_vectors_stay_in_the_cap_with_uniform_z() {
        let mut r = Rng::new(5);
        let n = 100_000;
        for min_z in [0.5f32, 0.0, -0.75] {
            let mut sum_z = 0.0f64;
            let mut sum_xy = glam::DVec2::ZERO;
            for _ in 0..n {
                let v = r.unit_vector_in_cap(min_z);
                assert!((v.length() - 1.0).abs() < 1e-6, "{v}");
                assert!(v.z >= min_z, "{v} below {min_z}");
                sum_z += f64::from(v.z);
                sum_xy += v.truncate().as_dvec2();
            }
            // z is uniform on [min_z, 1]: mean (1 + min_z)/2, σ of one draw ≤ 2/√12 = 0.58,
            // σ of the mean over 1e5 draws ≤ 0.0019; 0.01 is > 5σ. x and y have mean 0 by
            // symmetry (σ of one draw ≤ 1).
            let mean_z = sum_z / f64::from(n);
            let want = 0.5 * (1.0 + f64::from(min_z));
            assert!((mean_z - want).abs() < 0.01, "{min_z}: {mean_z} vs {want}");
            let mean_xy = sum_xy / f64::from(n);
            assert!(mean_xy.abs().max_element() < 0.02, "{mean_xy}");
        }
        assert_eq!(r.unit_vector_in_cap(1.0), Vec3::Z);
        assert_eq!(r.unit_vector_in_cap(7.0), Vec3::Z);
        // The whole sphere draws exactly what `unit_vector` draws.
        let (mut a, mut b) = (Rng::new(6), Rng::new(6));
        for _ in 0..100 {
            assert_eq!(a.unit_vector(), b.unit_vector_in_cap(-1.0));
            assert_eq!(a.unit_vector(), b.unit_vector_in_cap(f32::NAN));
        }
    }
}

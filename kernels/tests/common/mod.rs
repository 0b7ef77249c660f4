//! Helpers shared by the kernel tests: a seeded generator, special floats, random triangles and
//! rays, and packing rays into lanes.
#![allow(dead_code)] // Each test binary uses a different subset.

use kdbeam_kernels::intersect::LaneRays;
use kdbeam_kernels::{Lanes, Ray, Triangle, Vec3};

/// SplitMix64: small, seeded, good enough for test inputs.
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        (lo as f64 + (hi - lo) as f64 * self.unit()) as f32
    }

    /// Uniform in `0..n`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.unit() * n as f64) as usize % n
    }

    pub fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// A point uniform in the cube `[-h, h]^3`.
    pub fn in_cube(&mut self, h: f32) -> Vec3 {
        Vec3::new(self.range(-h, h), self.range(-h, h), self.range(-h, h))
    }

    /// A direction uniform on the unit sphere.
    pub fn on_sphere(&mut self) -> Vec3 {
        loop {
            let p = self.in_cube(1.0);
            let l = p.length();
            if l > 0.1 && l <= 1.0 {
                return p / l;
            }
        }
    }

    /// A float drawn from: special values, arbitrary bit patterns, ordinary magnitudes.
    pub fn any_f32(&mut self) -> f32 {
        match self.below(3) {
            0 => SPECIALS[self.below(SPECIALS.len())],
            1 => f32::from_bits(self.next_u64() as u32),
            _ => self.range(-100.0, 100.0),
        }
    }
}

/// Floats whose handling differs between careless implementations.
pub const SPECIALS: [f32; 16] = [
    f32::NAN,
    -f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    0.0,
    -0.0,
    f32::MIN_POSITIVE,
    -f32::MIN_POSITIVE,
    1e-40,
    -1e-40,
    f32::from_bits(1),
    f32::MAX,
    f32::MIN,
    1.0,
    -1.0,
    0.5,
];

/// Same bits, or both NaN (NaN payloads are not part of any contract here).
pub fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// A triangle with vertices uniform in `[-1, 1]^3`, no angle smaller than about 10 degrees
/// (|n| >= 0.3 · longest edge², so the tolerances of the accuracy tests hold).
pub fn well_shaped_triangle(rng: &mut Rng) -> Triangle {
    loop {
        let t = Triangle::new(rng.in_cube(1.0), rng.in_cube(1.0), rng.in_cube(1.0));
        let longest = [t.v1 - t.v0, t.v2 - t.v1, t.v0 - t.v2]
            .iter()
            .map(|e| e.length_squared())
            .fold(0.0, f32::max);
        if longest > 0.05 && t.double_area() >= 0.3 * longest {
            return t;
        }
    }
}

/// The point with barycentrics `(1 − u − v, u, v)`, computed in `f64` and rounded once.
pub fn barycentric_point(t: &Triangle, u: f64, v: f64) -> Vec3 {
    let p = t.v0.as_dvec3() * (1.0 - u - v) + t.v1.as_dvec3() * u + t.v2.as_dvec3() * v;
    p.as_vec3()
}

/// A ray from a random origin (at distance 1..4 from `target`) through `target`, with `t = 1`
/// at the target, not grazing the triangle's plane (|cos| >= 0.1).
pub fn ray_through(rng: &mut Rng, tri: &Triangle, target: Vec3) -> Ray {
    let n = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0).normalize();
    loop {
        let origin = target + rng.on_sphere() * rng.range(1.0, 4.0);
        let direction = target - origin;
        if n.dot(direction.normalize()).abs() >= 0.1 {
            return Ray::new(origin, direction);
        }
    }
}

/// Lane `i` holds ray `rays[i]` (`rays.len()` must be `L::WIDTH`).
pub fn gather<L: Lanes>(l: L, rays: &[Ray]) -> LaneRays<L> {
    let lanes = |f: &dyn Fn(&Ray) -> f32| {
        let v: Vec<f32> = rays.iter().map(f).collect();
        l.load(&v)
    };
    LaneRays::new(
        [
            lanes(&|r| r.origin.x),
            lanes(&|r| r.origin.y),
            lanes(&|r| r.origin.z),
        ],
        [
            lanes(&|r| r.direction.x),
            lanes(&|r| r.direction.y),
            lanes(&|r| r.direction.z),
        ],
    )
}

/// The lanes of `v` as a vector.
pub fn lanes_of<L: Lanes>(l: L, v: L::F32) -> Vec<f32> {
    let mut out = vec![0.0; L::WIDTH];
    l.store(v, &mut out);
    out
}

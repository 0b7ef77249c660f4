//! Single rays and their hits.

use glam::Vec3;

/// A ray `origin + t * direction` for `t` in `[tmin, tmax]`.
///
/// `direction` need not be normalised; `t` is measured in units of `|direction|`. A zero or NaN direction, or
/// a NaN origin, gives no hit (every test compares ordered, so NaN fails them), never a panic.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Where it goes (any length).
    pub direction: Vec3,
    /// Smallest accepted `t`.
    pub tmin: f32,
    /// Largest accepted `t`.
    pub tmax: f32,
}

impl Ray {
    /// A ray over `[0, +inf)`.
    #[inline]
    #[must_use]
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Ray {
            origin,
            direction,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// The point at parameter `t`.
    #[inline]
    #[must_use]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.direction * t
    }
}

/// The closest hit of a ray: distance, barycentrics and triangle id.
///
/// The hit point is `(1 - u - v) * v0 + u * v1 + v * v2` of triangle `triangle`. A miss is
/// [`Hit::NONE`]: `t = +inf`, `triangle = u32::MAX`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Hit {
    /// Ray parameter of the hit (`+inf` for a miss).
    pub t: f32,
    /// Barycentric weight of `v1`.
    pub u: f32,
    /// Barycentric weight of `v2`.
    pub v: f32,
    /// Index of the triangle in the mesh (`u32::MAX` for a miss).
    pub triangle: u32,
}

impl Hit {
    /// No hit.
    pub const NONE: Hit = Hit {
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
        triangle: u32::MAX,
    };

    /// Did the ray hit anything?
    #[inline]
    #[must_use]
    pub fn is_hit(&self) -> bool {
        self.triangle != u32::MAX
    }

    /// Is `(t, triangle)` closer than this hit? Ties in `t` go to the smaller triangle id, so the
    /// closest hit is unique whatever order triangles are tested in.
    #[inline]
    #[must_use]
    pub fn is_beaten_by(&self, t: f32, triangle: u32) -> bool {
        t < self.t || (t == self.t && triangle < self.triangle)
    }
}

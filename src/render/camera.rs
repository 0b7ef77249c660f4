//! The standard camera of DESIGN.md, so that every benchmark traces the same rays.

use glam::Vec3;
use kdbeam_kernels::{Aabb, Ray};

/// A pinhole camera looking along +z at a scene's box.
///
/// With `c` the box centre and `h = ½·max(x extent, y extent)`, the eye is at
/// `(cx, cy, zmin − 2h)`; pixel `(x, y)` of `W × H` looks along `normalize(u/2, v/2, 1)` with
/// `u = (x + ½)/W·2 − 1`, `v = (y + ½)/H·2 − 1`. A field of view of 2·atan(½) ≈ 53° frames the
/// box's front face.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Where the rays start.
    pub eye: Vec3,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// The standard camera for a scene bounded by `bounds` (an empty box gives an eye at the
    /// origin, every ray then misses).
    pub fn standard(bounds: &Aabb, width: u32, height: u32) -> Self {
        let eye = if bounds.is_empty() {
            Vec3::ZERO
        } else {
            let c = bounds.center();
            let e = bounds.extent();
            let h = 0.5 * e.x.max(e.y);
            Vec3::new(c.x, c.y, bounds.min.z - 2.0 * h)
        };
        Camera { eye, width, height }
    }

    /// The primary ray through the centre of pixel `(x, y)`, `t` over `[0, +inf)`.
    #[inline]
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let u = (x as f32 + 0.5) / self.width as f32 * 2.0 - 1.0;
        let v = (y as f32 + 0.5) / self.height as f32 * 2.0 - 1.0;
        Ray::new(self.eye, Vec3::new(0.5 * u, 0.5 * v, 1.0).normalize())
    }

    /// Every primary ray, row by row.
    pub fn rays(&self) -> Vec<Ray> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| self.ray(x, y)))
            .collect()
    }
}

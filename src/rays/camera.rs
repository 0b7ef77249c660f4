//! The standard camera, so that every renderer, test and benchmark traces the same rays.

use glam::Vec3;
use kdbeam_kernels::{Aabb, PacketShape, Ray, RayPacket};

use crate::{Error, Result};

/// A pinhole camera: the standard camera looking along +z at a scene's box, or any eye, target
/// and field of view ([`Camera::look_at`]).
///
/// Pixel `(x, y)` of `W × H` looks along `normalize(u·s·right + v·s·up + forward)` with
/// `u = (x + ½)/W·2 − 1`, `v = (y + ½)/H·2 − 1` and `s = tan(fov/2)`. The standard camera has
/// `right = +x`, `up = +y`, `forward = +z` and `s = ½` (a field of view of 2·atan(½) ≈ 53°,
/// which frames the box's front face): its rays are `normalize(u/2, v/2, 1)`, bit for bit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Where the rays start.
    pub eye: Vec3,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// `s·right`: the step of the direction per unit of `u`.
    right: Vec3,
    /// `s·up`: the step of the direction per unit of `v`.
    up: Vec3,
    /// The unit viewing direction.
    forward: Vec3,
}

impl Camera {
    /// The standard camera for a scene bounded by `bounds`: with `c` the box centre and
    /// `h = ½·max(x extent, y extent)`, the eye at `(cx, cy, zmin − 2h)`, looking along +z
    /// (an empty box gives an eye at the origin, every ray then misses).
    #[must_use]
    pub fn standard(bounds: &Aabb, width: u32, height: u32) -> Self {
        let eye = if bounds.is_empty() {
            Vec3::ZERO
        } else {
            let c = bounds.center();
            let e = bounds.extent();
            let h = 0.5 * e.x.max(e.y);
            Vec3::new(c.x, c.y, bounds.min.z - 2.0 * h)
        };
        Camera {
            eye,
            width,
            height,
            right: Vec3::new(0.5, 0.0, 0.0),
            up: Vec3::new(0.0, 0.5, 0.0),
            forward: Vec3::Z,
        }
    }

    /// A camera at `eye` looking at `target` with a vertical and horizontal field of view of
    /// `fov_degrees`, +y up: `forward = normalize(target − eye)`, `right = normalize(+y ×
    /// forward)`, `up = forward × right` (so that `eye = (cx, cy, zmin − 2h)`, `target = c`,
    /// 2·atan(½) degrees is the standard camera's frame).
    ///
    /// ```
    /// use kdbeam::{Aabb, Camera, Vec3};
    ///
    /// // The centre pixel of an odd-sized image looks at the target.
    /// let camera = Camera::look_at(Vec3::new(0.5, 0.5, -1.0), Vec3::splat(0.5), 60.0, 65, 65)?;
    /// assert!(camera.ray(32, 32).direction.abs_diff_eq(Vec3::Z, 1e-6));
    /// // The standard camera is the look-at camera of its eye, the box centre and 2·atan(½).
    /// let bounds = Aabb::from_points([Vec3::ZERO, Vec3::ONE]);
    /// let standard = Camera::standard(&bounds, 8, 8);
    /// let fov = 2.0 * 0.5f32.atan().to_degrees();
    /// let same = Camera::look_at(standard.eye, bounds.center(), fov, 8, 8)?;
    /// assert!(same.ray(1, 6).direction.abs_diff_eq(standard.ray(1, 6).direction, 1e-6));
    /// // Looking straight up or down has no "right": an error, as are a zero or bad angle.
    /// assert!(Camera::look_at(Vec3::ZERO, Vec3::Y, 60.0, 64, 64).is_err());
    /// assert!(Camera::look_at(Vec3::ZERO, Vec3::Z, 180.0, 64, 64).is_err());
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `eye` or `target` is not finite, when they coincide or
    /// the view is parallel to +y (no right vector), or when `fov_degrees` is not in (0, 180).
    pub fn look_at(
        eye: Vec3,
        target: Vec3,
        fov_degrees: f32,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        let invalid = |message: &str| Error::InvalidParameter {
            name: "camera",
            message: message.to_string(),
        };
        if !(eye.is_finite() && target.is_finite()) {
            return Err(invalid("eye and target must be finite"));
        }
        if !(fov_degrees > 0.0 && fov_degrees < 180.0) {
            return Err(invalid("the field of view must be in (0, 180) degrees"));
        }
        let forward = (target - eye).normalize_or_zero();
        let right = Vec3::Y.cross(forward).normalize_or_zero();
        if forward == Vec3::ZERO || right == Vec3::ZERO {
            return Err(invalid(
                "eye and target must differ, and the view must not be vertical",
            ));
        }
        let up = forward.cross(right);
        let s = (0.5 * fov_degrees.to_radians()).tan();
        Ok(Camera {
            eye,
            width,
            height,
            right: right * s,
            up: up * s,
            forward,
        })
    }

    /// The unit viewing direction (the direction through the image centre).
    #[must_use]
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// The same camera with an image of `width × height` pixels.
    #[must_use]
    pub fn with_size(self, width: u32, height: u32) -> Self {
        Camera {
            width,
            height,
            ..self
        }
    }

    /// The primary ray through the centre of pixel `(x, y)`, `t` over `[0, +inf)`.
    #[inline]
    #[must_use]
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let (dx, dy, dz) = self.direction(screen(x, self.width), screen(y, self.height));
        Ray::new(self.eye, Vec3::new(dx, dy, dz))
    }

    /// The rays of the `cols × rows` pixels from `(x0, y0)`, row by row, written into `packet`
    /// in place: the same bits as [`Camera::ray`] gives for each pixel (the loop over a row
    /// compiles to packed square roots and divisions, which round as the scalar ones do).
    ///
    /// Panics if `cols · rows > 64`.
    pub fn fill_packet(&self, x0: u32, y0: u32, cols: u32, rows: u32, packet: &mut RayPacket) {
        let cols = cols as usize;
        packet.set_len(cols * rows as usize);
        for r in 0..rows as usize {
            let v = screen(y0 + r as u32, self.height);
            let row = r * cols..(r + 1) * cols;
            let [direction_x, direction_y, direction_z] = &mut packet.direction;
            let directions = direction_x[row.clone()]
                .iter_mut()
                .zip(&mut direction_y[row.clone()])
                .zip(&mut direction_z[row.clone()]);
            for (c, ((dx, dy), dz)) in directions.enumerate() {
                (*dx, *dy, *dz) = self.direction(screen(x0 + c as u32, self.width), v);
            }
            for (a, origin) in packet.origin.iter_mut().enumerate() {
                origin[row.clone()].fill(self.eye[a]);
            }
            packet.tmin[row.clone()].fill(0.0);
            packet.tmax[row].fill(f32::INFINITY);
        }
    }

    /// Every primary ray as packets of `shape`'s pixel tiles: bands of `shape.height()` rows
    /// from row 0, tiles left to right within a band, each packet row by row (as
    /// [`Camera::fill_packet`] fills it). Tiles at the right and bottom edges are cut to the
    /// image, so every pixel is in exactly one packet.
    ///
    /// ```
    /// use kdbeam::{Aabb, Camera, PacketShape, Vec3};
    ///
    /// let camera = Camera::standard(&Aabb::from_points([Vec3::ZERO, Vec3::ONE]), 10, 6);
    /// let packets = camera.tile_packets(PacketShape::P4x4);
    /// assert_eq!(packets.len(), 3 * 2);
    /// assert_eq!(packets.iter().map(|p| p.len()).sum::<usize>(), 60);
    /// assert_eq!(packets[2].len(), 2 * 4); // the cut tile at the right edge
    /// ```
    #[must_use]
    pub fn tile_packets(&self, shape: PacketShape) -> Vec<RayPacket> {
        let (tw, th) = (shape.width() as u32, shape.height() as u32);
        let mut packets = Vec::new();
        for y0 in (0..self.height).step_by(th as usize) {
            for x0 in (0..self.width).step_by(tw as usize) {
                let (cols, rows) = (tw.min(self.width - x0), th.min(self.height - y0));
                let mut packet = RayPacket::from_rays(&[]);
                self.fill_packet(x0, y0, cols, rows, &mut packet);
                packets.push(packet);
            }
        }
        packets
    }

    /// Every primary ray, row by row.
    #[must_use]
    pub fn rays(&self) -> Vec<Ray> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| self.ray(x, y)))
            .collect()
    }
}

/// Pixel `i` of `n` on the screen axis: `(i + ½)/n·2 − 1`, in (−1, 1).
#[inline(always)]
fn screen(i: u32, n: u32) -> f32 {
    (i as f32 + 0.5) / n as f32 * 2.0 - 1.0
}

impl Camera {
    /// `normalize(u·right + v·up + forward)` rounded as glam rounds it: `w · (1 / √(w·w))`, the
    /// dot product summed x, y, z. For the standard camera the sum is exactly `(u/2, v/2, 1)`
    /// (the other terms are zeros), so its rays keep their bits.
    #[inline(always)]
    fn direction(&self, u: f32, v: f32) -> (f32, f32, f32) {
        let (r, up, f) = (self.right, self.up, self.forward);
        let x = u * r.x + v * up.x + f.x;
        let y = u * r.y + v * up.y + f.y;
        let z = u * r.z + v * up.z + f.z;
        let inv = 1.0 / (x * x + y * y + z * z).sqrt();
        (x * inv, y * inv, z * inv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packets_hold_the_rays_of_their_pixels_bit_for_bit() {
        let bounds = Aabb {
            min: Vec3::new(-1.0, -2.0, 3.0),
            max: Vec3::new(4.0, 0.5, 7.0),
        };
        let camera = Camera::standard(&bounds, 37, 23);
        let mut packet = RayPacket::from_rays(&[Ray::new(Vec3::ONE, Vec3::X); 64]);
        for (x0, y0, cols, rows) in [(0, 0, 8, 8), (32, 16, 5, 7), (36, 22, 1, 1), (3, 4, 2, 2)] {
            camera.fill_packet(x0, y0, cols, rows, &mut packet);
            let rays: Vec<Ray> = (0..rows)
                .flat_map(|dy| (0..cols).map(move |dx| (x0 + dx, y0 + dy)))
                .map(|(x, y)| camera.ray(x, y))
                .collect();
            assert_eq!(
                packet,
                RayPacket::from_rays(&rays),
                "{x0} {y0} {cols} {rows}"
            );
        }
    }

    #[test]
    fn directions_are_glams_normalisation() {
        let camera = Camera::standard(&Aabb::from_points([Vec3::ZERO, Vec3::ONE]), 64, 48);
        for (x, y) in [(0, 0), (63, 47), (17, 30), (32, 24)] {
            let u = (x as f32 + 0.5) / 64.0 * 2.0 - 1.0;
            let v = (y as f32 + 0.5) / 48.0 * 2.0 - 1.0;
            let want = Vec3::new(0.5 * u, 0.5 * v, 1.0).normalize();
            assert_eq!(camera.ray(x, y).direction, want, "{x} {y}");
        }
    }
}

//! The standard camera, so that every renderer, test and benchmark traces the same rays.

use glam::Vec3;
use kdbeam_kernels::{Aabb, PacketShape, Ray, RayPacket};

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
        Camera { eye, width, height }
    }

    /// The primary ray through the centre of pixel `(x, y)`, `t` over `[0, +inf)`.
    #[inline]
    #[must_use]
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let half_u = 0.5 * screen(x, self.width);
        let half_v = 0.5 * screen(y, self.height);
        let (dx, dy, dz) = unit_direction(half_u, half_v);
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
            let half_v = 0.5 * screen(y0 + r as u32, self.height);
            let row = r * cols..(r + 1) * cols;
            let [direction_x, direction_y, direction_z] = &mut packet.direction;
            let directions = direction_x[row.clone()]
                .iter_mut()
                .zip(&mut direction_y[row.clone()])
                .zip(&mut direction_z[row.clone()]);
            for (c, ((dx, dy), dz)) in directions.enumerate() {
                let half_u = 0.5 * screen(x0 + c as u32, self.width);
                (*dx, *dy, *dz) = unit_direction(half_u, half_v);
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

/// `normalize(x, y, 1)` rounded as glam rounds it: `v · (1 / √(v·v))`, the dot product summed
/// x, y, z.
#[inline(always)]
fn unit_direction(x: f32, y: f32) -> (f32, f32, f32) {
    let inv = 1.0 / (x * x + y * y + 1.0).sqrt();
    (x * inv, y * inv, inv)
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

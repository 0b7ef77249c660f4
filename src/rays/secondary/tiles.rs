//! Secondary rays as packets per pixel tile, the way a renderer traces them.

use kdbeam_kernels::{PacketShape, RayPacket};

use super::SecondaryRays;
use crate::Camera;

/// Secondary rays formed into packets: the packets, and which ray each lane holds.
#[derive(Clone, Debug, PartialEq)]
pub struct TilePackets {
    /// The packets, in tracing order.
    pub packets: Vec<RayPacket>,
    /// The index into [`SecondaryRays::rays`] of each lane, packet after packet
    /// (`packets[0].len()` entries for the first packet, and so on).
    pub rays: Vec<u32>,
}

impl SecondaryRays {
    /// The rays as packets per pixel tile of `shape`, as a renderer that shades tile by tile
    /// traces them: tiles in the order of [`Camera::tile_packets`], and for each tile one packet
    /// per sample (the `k`-th ray of every pixel of the tile that has rays, row by row). A
    /// packet is never empty and holds at most `shape.ray_count()` rays; tiles on silhouettes
    /// give partly filled packets, tiles that see only the background none.
    ///
    /// `camera` must be the camera the rays were made from (its size places the pixels);
    /// rays of pixels outside its image are left out.
    #[must_use]
    pub fn tile_packets(&self, camera: &Camera, shape: PacketShape) -> TilePackets {
        let (w, h) = (camera.width, camera.height);
        // The first ray of each pixel; its rays are consecutive.
        let mut first = vec![u32::MAX; w as usize * h as usize];
        for (i, &p) in self.pixels.iter().enumerate().rev() {
            if let Some(f) = first.get_mut(p as usize) {
                *f = i as u32;
            }
        }
        let per_hit = self.workload.rays_per_hit();
        let (tw, th) = (shape.width() as u32, shape.height() as u32);
        let mut out = TilePackets {
            packets: Vec::new(),
            rays: Vec::with_capacity(self.rays.len()),
        };
        let mut lanes = Vec::with_capacity(shape.ray_count());
        for y0 in (0..h).step_by(th as usize) {
            for x0 in (0..w).step_by(tw as usize) {
                for k in 0..per_hit {
                    lanes.clear();
                    for y in y0..(y0 + th).min(h) {
                        for x in x0..(x0 + tw).min(w) {
                            let f = first[(y * w + x) as usize];
                            if f != u32::MAX {
                                lanes.push(f + k);
                            }
                        }
                    }
                    if lanes.is_empty() {
                        continue;
                    }
                    let rays: Vec<_> = lanes.iter().map(|&i| self.rays[i as usize]).collect();
                    out.packets.push(RayPacket::from_rays(&rays));
                    out.rays.extend_from_slice(&lanes);
                }
            }
        }
        out
    }
}

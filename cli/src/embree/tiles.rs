//! Primary rays in the order of kdbeam's pixel tiles, so that Embree's packets are kdbeam's.

use kdbeam::{Camera, Error, PacketShape, Ray, Result};

/// Pixel indices `y · width + x` of a `width × height` image in the order
/// [`trace_primary`](crate::render::trace_primary) traces them with `shape`: bands of
/// `shape.height()` rows top to bottom, tiles left to right within a band, and inside a tile
/// rows top to bottom, pixels left to right. Tiles at the right and bottom edges are cut to
/// the image, so every pixel appears exactly once.
pub fn tile_order(width: u32, height: u32, shape: PacketShape) -> Vec<u32> {
    let (tw, th) = (shape.width() as u32, shape.height() as u32);
    let mut order = Vec::with_capacity(width as usize * height as usize);
    for y0 in (0..height).step_by(th as usize) {
        for x0 in (0..width).step_by(tw as usize) {
            for y in y0..(y0 + th).min(height) {
                order.extend((x0..(x0 + tw).min(width)).map(|x| y * width + x));
            }
        }
    }
    order
}

/// The primary rays of `camera`, ordered so that consecutive groups of `width` rays are
/// kdbeam's packets of `width` rays: 2×2, 4×2 and 4×4 pixel tiles for widths 4, 8 and 16
/// ([`PacketShape::from_len`]), and the 8×8 tile order for single rays (width 1). Returns the
/// rays with the pixel index (`y · camera.width + x`) of each.
///
/// When the image size is not a multiple of the tile, the cut edge tiles hold fewer rays than
/// a packet, and a packet there spans two of them.
///
/// # Errors
/// [`Error::InvalidParameter`] when `width` is not 1, 4, 8 or 16.
pub fn primary_rays(camera: &Camera, width: usize) -> Result<(Vec<Ray>, Vec<u32>)> {
    let shape = match width {
        1 => PacketShape::P8x8,
        4 | 8 | 16 => PacketShape::from_len(width).expect("4, 8 and 16 are packet shapes"),
        _ => {
            return Err(Error::InvalidParameter {
                name: "embree width",
                message: format!("must be 1, 4, 8 or 16, got {width}"),
            })
        }
    };
    let order = tile_order(camera.width, camera.height, shape);
    let rays = order
        .iter()
        .map(|&i| camera.ray(i % camera.width, i / camera.width))
        .collect();
    Ok((rays, order))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tile_order_is_a_permutation_in_tiles() {
        let order = tile_order(10, 5, PacketShape::P4x2);
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..50).collect::<Vec<u32>>());
        // First tile: pixels (0..4, 0..2); the third tile of the band is cut to 2 columns.
        assert_eq!(order[..8], [0, 1, 2, 3, 10, 11, 12, 13]);
        assert_eq!(order[16..20], [8, 9, 18, 19]);
        // The last band holds one row.
        assert_eq!(order[40..44], [40, 41, 42, 43]);
    }

    #[test]
    fn primary_rays_rejects_other_widths() {
        let camera = Camera::standard(&kdbeam::Aabb::EMPTY, 4, 4);
        assert!(primary_rays(&camera, 2).is_err());
        let (rays, pixels) = primary_rays(&camera, 4).expect("width 4 is valid");
        assert_eq!(rays.len(), 16);
        assert_eq!(rays[2], camera.ray(0, 1));
        assert_eq!(pixels[2], 4);
    }
}

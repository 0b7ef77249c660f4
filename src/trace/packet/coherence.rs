//! How far apart a packet's rays start and point: whether they traverse the tree as one
//! interval, and whether they build beams at all
//! ([`Frustum::Coherent`](crate::trace::Frustum::Coherent)).

use kdbeam_kernels::{RayPacket, Vec3};

/// The widest spread, on any axis, of the unit directions of a packet that traverses the tree
/// as one interval. A camera tile of 8 × 8 pixels spans about 0.008 at 1024² and a 60° field
/// of view, 0.016 at 512² (coherent), 0.03 at 256² (not); ambient-occlusion and diffuse rays
/// spread over a hemisphere (up to 2). The whole-packet traversal enters every leaf that any
/// ray's segment crosses, and builds one beam around them all, so it pays only where the rays
/// stay close.
pub(crate) const MAX_DIRECTION_SPREAD: f32 = 0.02;

/// The widest spread, on any axis, of the origins of a packet that traverses the tree as one
/// interval, relative to the scene's largest extent. The traversal keeps one `[t_enter,
/// t_exit]` for the whole packet, which bounds each ray's interval tightly only where the rays
/// start together: a pinhole camera's tiles (one origin), a thin lens of small aperture. Rays
/// that start on surfaces (shadow rays, which converge on the light, as well as
/// ambient-occlusion and diffuse rays) spread their origins over the tile's footprint, and the
/// per-ray traversal serves them better.
pub(crate) const MAX_ORIGIN_SPREAD: f32 = 1.0 / 1024.0;

/// The widest spread of unit directions for which a packet that is not coherent still builds
/// beams (with [`Frustum::Adaptive`](crate::trace::Frustum::Adaptive)): shadow rays of a tile,
/// which converge on the light. Ambient-occlusion and diffuse rays spread far wider, and their
/// beams cost more than they cull.
pub(crate) const MAX_BEAM_DIRECTION_SPREAD: f32 = 0.25;

/// Packets of at most this many active rays build no beam unless they are coherent: the beam's
/// cost is not spread over enough rays.
pub(crate) const MIN_BEAM_RAYS: u32 = 17;

/// How far apart a packet's rays start and point: the spread, on the widest axis, of the unit
/// directions and of the origins (relative to the scene's largest extent) of up to four of its
/// rays ([`spread`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Spread {
    pub direction: f32,
    pub origin: f32,
}

impl Spread {
    /// No spread: one ray, or rays that start and point together.
    pub(crate) const ZERO: Spread = Spread {
        direction: 0.0,
        origin: 0.0,
    };

    /// Within [`MAX_DIRECTION_SPREAD`] and [`MAX_ORIGIN_SPREAD`]?
    pub(crate) fn is_coherent(self) -> bool {
        self.direction <= MAX_DIRECTION_SPREAD && self.origin <= MAX_ORIGIN_SPREAD
    }
}

/// The [`Spread`] of the rays `active` of `packet`; `scale` is the scene's largest extent.
///
/// Up to four rays are compared (the first and last active ones and two between), not every
/// ray: the answer chooses a traversal, which changes the speed only, never a hit beyond what
/// [`Frustum::Packet`] documents, and a packet-wide pass (a square root and a division per ray)
/// would cost a camera packet a large part of what the whole-packet traversal saves it. A
/// direction that has no unit length (zero, or not finite) is left out, as the traversal
/// leaves out its ray (and so is its origin); no rays at all spread nowhere.
///
/// [`Frustum::Packet`]: crate::trace::Frustum::Packet
#[must_use]
pub(crate) fn spread(packet: &RayPacket, active: u64, scale: f32) -> Spread {
    let active = active & packet.full_mask();
    if active == 0 {
        return Spread::ZERO;
    }
    let (first, last) = (active.trailing_zeros(), 63 - active.leading_zeros());
    let step = (last - first) / 3;
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let (mut o_lo, mut o_hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for at in [first, first + step, last - step, last] {
        // The first active ray at or after `at` (`last` is active, so there is one).
        let i = (at + (active >> at).trailing_zeros()) as usize;
        let d = Vec3::new(
            packet.direction[0][i],
            packet.direction[1][i],
            packet.direction[2][i],
        );
        let o = Vec3::new(
            packet.origin[0][i],
            packet.origin[1][i],
            packet.origin[2][i],
        );
        let unit = d * d.length_recip();
        if unit.is_finite() {
            (lo, hi) = (lo.min(unit), hi.max(unit));
            (o_lo, o_hi) = (o_lo.min(o), o_hi.max(o));
        }
    }
    if lo.x > hi.x {
        return Spread::ZERO;
    }
    // Zero stays zero in a scene of no extent.
    let origin = (o_hi - o_lo).max_element();
    Spread {
        direction: (hi - lo).max_element(),
        origin: if origin == 0.0 { 0.0 } else { origin / scale },
    }
}

#[cfg(test)]
mod tests {
    use kdbeam_kernels::Ray;

    use super::*;

    fn is_coherent(packet: &RayPacket, active: u64, scale: f32) -> bool {
        spread(packet, active, scale).is_coherent()
    }

    fn packet(directions: &[Vec3]) -> RayPacket {
        let rays: Vec<Ray> = directions
            .iter()
            .map(|&d| Ray::new(Vec3::ZERO, d))
            .collect();
        RayPacket::from_rays(&rays)
    }

    #[test]
    fn camera_tiles_are_coherent_and_hemispheres_are_not() {
        let tile: Vec<Vec3> = (0..64)
            .map(|i| Vec3::new((i % 8) as f32 * 0.001, (i / 8) as f32 * 0.001, 1.0))
            .collect();
        assert!(is_coherent(&packet(&tile), u64::MAX, 1.0));
        let spread = [Vec3::Z, Vec3::new(0.05, 0.0, 1.0)];
        assert!(!is_coherent(&packet(&spread), u64::MAX, 1.0));
        // Only the active rays count, and lengths do not.
        assert!(is_coherent(&packet(&spread), 0b01, 1.0));
        assert!(is_coherent(
            &packet(&[Vec3::Z, 5.0 * Vec3::Z]),
            u64::MAX,
            1.0
        ));
        // The last ray is always compared.
        let mut late = tile.clone();
        late[63] = Vec3::X;
        assert!(!is_coherent(&packet(&late), u64::MAX, 1.0));
        // A zero or NaN direction is left out; no rays are coherent.
        let odd = [Vec3::Z, Vec3::ZERO, Vec3::splat(f32::NAN)];
        assert!(is_coherent(&packet(&odd), u64::MAX, 1.0));
        assert!(is_coherent(&packet(&spread), 0, 1.0));
    }

    #[test]
    fn parallel_rays_from_a_surface_are_not_coherent() {
        let rays: Vec<Ray> = (0..16)
            .map(|i| Ray::new(Vec3::new(i as f32 * 0.01, 0.0, 0.0), Vec3::Z))
            .collect();
        let p = RayPacket::from_rays(&rays);
        assert!(!is_coherent(&p, u64::MAX, 1.0));
        // Relative to the scene: in a scene 1000 times larger they start together.
        assert!(is_coherent(&p, u64::MAX, 1000.0));
    }
}

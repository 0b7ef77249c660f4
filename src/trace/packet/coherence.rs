//! How far apart a packet's rays start and point: whether they traverse the tree as one
//! interval, and whether they build beams at all
//! ([`Frustum::Coherent`](crate::trace::Frustum::Coherent)).

use kdbeam_kernels::{Aabb, RayPacket, Vec3};

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
/// per-ray traversal serves them better unless they run side by side
/// ([`MAX_SHARED_FOOTPRINT`]).
pub(crate) const MAX_ORIGIN_SPREAD: f32 = 1.0 / 1024.0;

/// The widest footprint ([`Spread::footprint`]) of a packet whose rays start apart that still
/// traverses the tree as one interval: rays that run side by side across the scene, within 2%
/// of its largest extent of each other, such as a pixel tile's shadow rays toward a distant
/// light, cross nearly the same cells.
pub(crate) const MAX_SHARED_FOOTPRINT: f32 = 0.02;

/// The widest spread, on any axis, of the origins of a packet traced ray by ray whose rays
/// still walk the wide nodes side by side, relative to the scene's largest extent: rays that
/// start within a sixteenth of the scene of each other, such as the ambient-occlusion and
/// diffuse rays of a pixel tile, cross the same nodes near the root and around their surface
/// whatever their directions; rays that start all over the scene share little beyond the root.
pub(crate) const MAX_SHARED_WALK_ORIGIN_SPREAD: f32 = 1.0 / 16.0;

/// The widest spread of unit directions for which a packet that is not coherent still builds
/// beams (with [`Frustum::Adaptive`](crate::trace::Frustum::Adaptive)): shadow rays of a tile,
/// which converge on the light. Ambient-occlusion and diffuse rays spread far wider, and their
/// beams cost more than they cull.
pub(crate) const MAX_BEAM_DIRECTION_SPREAD: f32 = 0.25;

/// Packets of at most this many active rays build no beam unless they are coherent: the beam's
/// cost is not spread over enough rays.
pub(crate) const MIN_BEAM_RAYS: u32 = 17;

/// The widest distance, relative to the scene's largest extent, between neighbouring rays of a
/// packet where they reach the scene, for which the packet is traced as a packet: beyond it each
/// ray is traced on its own. A packet's rays share its traversal's inner nodes and its leaves'
/// beams only while several of them land in one leaf; a mesh far from the camera, a few dozen
/// pixels wide (an instance in a large world), or a small image, puts each ray of a tile in
/// leaves of its own, and the packet's per-leaf and per-node work is then spent on one ray at
/// a time. On the bunny and the dragon from the standard camera, 8×8 tiles traced as packets
/// stop beating the same tiles traced ray by ray between 224² and 256² (neighbouring rays about
/// 0.55% of the mesh apart).
pub(crate) const MAX_RAY_SPACING: f32 = 0.0055;

/// How far apart a packet's rays start and point: the spread, on the widest axis, of the unit
/// directions and of the origins (relative to the scene's largest extent) of up to four of its
/// rays, and how wide they fan out by the time they reach the scene ([`spread`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Spread {
    pub direction: f32,
    pub origin: f32,
    /// `origin` plus `direction` times the distance from the first compared ray's origin to the
    /// scene's centre, relative to the scene's largest extent: the width of the packet's
    /// footprint across the scene.
    pub footprint: f32,
}

impl Spread {
    /// No spread: one ray, or rays that start and point together.
    pub(crate) const ZERO: Spread = Spread {
        direction: 0.0,
        origin: 0.0,
        footprint: 0.0,
    };

    /// Within [`MAX_DIRECTION_SPREAD`], and within [`MAX_ORIGIN_SPREAD`] or
    /// [`MAX_SHARED_FOOTPRINT`]?
    pub(crate) fn is_coherent(self) -> bool {
        self.direction <= MAX_DIRECTION_SPREAD
            && (self.origin <= MAX_ORIGIN_SPREAD || self.footprint <= MAX_SHARED_FOOTPRINT)
    }

    /// Do `rays` rays of this spread land farther apart than [`MAX_RAY_SPACING`]? The
    /// footprint is shared by about `√rays` rays across, as in a square tile. False for one ray
    /// (nothing is gained by taking it out of the packet) and for a footprint that is not a
    /// number (a scene without a finite box).
    pub(crate) fn is_sparse(self, rays: u32) -> bool {
        rays > 1 && self.footprint > MAX_RAY_SPACING * ((rays as f32).sqrt() - 1.0)
    }
}

/// The [`Spread`] of the rays `active` of `packet` in a scene of box `bounds`.
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
pub(crate) fn spread(packet: &RayPacket, active: u64, bounds: &Aabb) -> Spread {
    let active = active & packet.full_mask();
    if active == 0 {
        return Spread::ZERO;
    }
    let (first, last) = (active.trailing_zeros(), 63 - active.leading_zeros());
    let step = (last - first) / 3;
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let (mut o_lo, mut o_hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let mut start = None;
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
            start = start.or(Some(o));
        }
    }
    let Some(start) = start else {
        return Spread::ZERO;
    };
    let scale = bounds.extent().max_element();
    // Zero stays zero in a scene of no extent.
    let relative = |x: f32| if x == 0.0 { 0.0 } else { x / scale };
    let (direction, origin) = ((hi - lo).max_element(), (o_hi - o_lo).max_element());
    Spread {
        direction,
        origin: relative(origin),
        footprint: relative(origin + direction * start.distance(bounds.center())),
    }
}

#[cfg(test)]
mod tests {
    use kdbeam_kernels::Ray;

    use super::*;

    /// A scene box of largest extent `scale`, centred `distance` down the z axis.
    fn scene(scale: f32, distance: f32) -> Aabb {
        let half = Vec3::splat(0.5 * scale);
        let centre = Vec3::new(0.0, 0.0, distance);
        Aabb::new(centre - half, centre + half)
    }

    fn is_coherent(packet: &RayPacket, active: u64, scale: f32) -> bool {
        spread(packet, active, &scene(scale, 0.0)).is_coherent()
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

    #[test]
    fn a_tile_on_a_small_far_mesh_is_sparse_and_on_a_near_one_is_not() {
        // An 8 × 8 tile of a 1024² image of a 53° view: neighbouring rays about 0.001 apart.
        let tile: Vec<Vec3> = (0..64)
            .map(|i| Vec3::new((i % 8) as f32 * 0.001, (i / 8) as f32 * 0.001, 1.0))
            .collect();
        let p = packet(&tile);
        let sparse = |scale: f32, distance: f32, rays: u64| {
            spread(&p, rays, &scene(scale, distance)).is_sparse(rays.count_ones())
        };
        // A mesh as wide as it is far: the tile's rays land 0.1% of it apart.
        assert!(!sparse(1.0, 1.0, u64::MAX));
        // A mesh 40 times farther than it is wide (an instance a few dozen pixels across):
        // 4% apart, traced ray by ray.
        assert!(sparse(1.0, 40.0, u64::MAX));
        // One ray is never taken out of its packet; the rays compared are the active ones.
        assert!(!sparse(1.0, 40.0, 1));
        assert!(!sparse(1.0, 40.0, 0));
        // A scene without a finite box gives no answer to act on.
        assert!(!spread(&p, u64::MAX, &Aabb::EMPTY).is_sparse(64));
    }
}

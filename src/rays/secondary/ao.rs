//! Ambient-occlusion rays: a few short cosine-weighted rays per primary hit, any hit.

use kdbeam_kernels::Ray;

use super::hemisphere::cosine_direction;
use super::Surface;
use crate::scene::rng::Rng;

/// The reach of an ambient-occlusion ray, as a fraction of the scene box's diagonal.
pub const AO_RADIUS: f32 = 0.1;

/// The rays per hit when none is asked for.
pub const DEFAULT_AO_RAYS: u32 = 4;

/// One ambient-occlusion ray from `surface`: a cosine-weighted unit direction about its
/// normal, `t` over `[0, radius]`.
pub(super) fn ao_ray(surface: &Surface, radius: f32, rng: &mut Rng) -> Ray {
    Ray {
        origin: surface.origin,
        direction: cosine_direction(rng, surface.normal),
        tmin: 0.0,
        tmax: radius,
    }
}

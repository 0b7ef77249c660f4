//! Diffuse bounces: one cosine-weighted ray per primary hit, closest hit.

use kdbeam_kernels::Ray;

use super::hemisphere::cosine_direction;
use super::Surface;
use crate::scene::rng::Rng;

/// The diffuse bounce from `surface`: a cosine-weighted unit direction about its normal, `t`
/// over `[0, +inf)`.
pub(super) fn diffuse_ray(surface: &Surface, rng: &mut Rng) -> Ray {
    Ray::new(surface.origin, cosine_direction(rng, surface.normal))
}

//! Shadow rays: from each primary hit to one point light, any hit.

use glam::Vec3;
use kdbeam_kernels::{Aabb, Ray};

use super::Surface;

/// The point light of a scene bounded by `bounds`: `c + (0.5·e.x, 1.5·e.y, −1.0·e.z)` with `c`
/// the box centre and `e` its extent — above the box, to the right and on the standard
/// camera's side, so that every scene casts visible shadows. The origin for an empty box.
#[must_use]
pub fn light(bounds: &Aabb) -> Vec3 {
    if bounds.is_empty() {
        return Vec3::ZERO;
    }
    let e = bounds.extent();
    bounds.center() + Vec3::new(0.5 * e.x, 1.5 * e.y, -e.z)
}

/// The shadow ray from `surface` to `light`: a unit direction, `t` over `[0, |light − origin|]`,
/// so that any hit is an occluder between the two. A surface facing away from the light is
/// occluded by its own triangle, as it should be. A light at the origin itself gives a zero
/// direction, which no tracer traces (a miss: the point is lit).
pub(super) fn shadow_ray(surface: &Surface, light: Vec3) -> Ray {
    let to_light = light - surface.origin;
    Ray {
        origin: surface.origin,
        direction: to_light.normalize_or_zero(),
        tmin: 0.0,
        tmax: to_light.length(),
    }
}

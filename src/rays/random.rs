//! Random rays: the incoherent workload every traversal is also measured and tested on.

use glam::Vec3;
use kdbeam_kernels::{Aabb, Ray};

use crate::scene::rng::Rng;

/// `count` random rays: origins uniform in `bounds`, directions uniform on the unit sphere,
/// `t` over `[0, +inf)`; the same rays for the same `seed` on every platform. An empty box puts
/// every origin at the origin.
///
/// ```
/// use kdbeam::{rays::random_rays, Aabb, Vec3};
///
/// let bounds = Aabb::from_points([Vec3::ZERO, Vec3::ONE]);
/// let rays = random_rays(&bounds, 100, 7);
/// assert_eq!(rays, random_rays(&bounds, 100, 7));
/// assert!(rays.iter().all(|r| bounds.contains(r.origin)));
/// ```
#[must_use]
pub fn random_rays(bounds: &Aabb, count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let (lo, ext) = if bounds.is_empty() {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (bounds.min, bounds.extent())
    };
    (0..count)
        .map(|_| {
            let o = lo + ext * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            Ray::new(o, rng.unit_vector())
        })
        .collect()
}

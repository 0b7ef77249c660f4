//! The ray sets every benchmark and accuracy figure is measured on.

use kdbeam_kernels::{Aabb, Ray};

use super::Camera;
use crate::scene::rng::Rng;

/// Which rays a measurement traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum RaySet {
    /// The standard camera's primary rays, traced in pixel tiles.
    Primary,
    /// Origins uniform in the scene box, directions uniform on the sphere (seeded).
    Random,
}

impl RaySet {
    /// `primary` or `random`.
    pub fn name(self) -> &'static str {
        match self {
            RaySet::Primary => "primary",
            RaySet::Random => "random",
        }
    }
}

/// `count` random rays: origins uniform in `bounds`, directions uniform on the unit sphere,
/// `t` over `[0, +inf)`; the same rays for the same `seed` on every platform. An empty box puts
/// every origin at the origin.
pub fn random_rays(bounds: &Aabb, count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let (lo, ext) = if bounds.is_empty() {
        (glam::Vec3::ZERO, glam::Vec3::ZERO)
    } else {
        (bounds.min, bounds.extent())
    };
    (0..count)
        .map(|_| {
            let o = lo + ext * glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            Ray::new(o, rng.unit_vector())
        })
        .collect()
}

/// The rays of `set` for a scene bounded by `bounds`: the standard camera at `width × height`
/// for [`RaySet::Primary`], `width · height` random rays (seed 1) for [`RaySet::Random`].
pub fn ray_set(set: RaySet, bounds: &Aabb, width: u32, height: u32) -> Vec<Ray> {
    match set {
        RaySet::Primary => Camera::standard(bounds, width, height).rays(),
        RaySet::Random => random_rays(bounds, width as usize * height as usize, 1),
    }
}

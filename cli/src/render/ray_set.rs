//! The ray sets every benchmark and accuracy figure is measured on.

use kdbeam::rays::{random_rays, Camera};
use kdbeam::{Aabb, Ray};

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

/// The rays of `set` for a scene bounded by `bounds`: the standard camera at `width × height`
/// for [`RaySet::Primary`], `width · height` random rays (seed 1) for [`RaySet::Random`].
pub fn ray_set(set: RaySet, bounds: &Aabb, width: u32, height: u32) -> Vec<Ray> {
    match set {
        RaySet::Primary => Camera::standard(bounds, width, height).rays(),
        RaySet::Random => random_rays(bounds, width as usize * height as usize, 1),
    }
}

//! Ray generators: the standard camera's primary rays (one by one or as pixel-tile packets),
//! seeded random rays, the secondary-ray workloads of a renderer (shadow, ambient occlusion,
//! diffuse) and sorted streams. Renderers, tests and benchmarks trace the same rays from them.

mod camera;
mod random;
pub mod secondary;
pub mod stream;

pub use camera::Camera;
pub use random::random_rays;

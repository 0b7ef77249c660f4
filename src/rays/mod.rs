//! Ray generators: the standard camera's primary rays (one by one or as pixel-tile packets) and
//! seeded random rays. Renderers, tests and benchmarks trace the same rays from them.

mod camera;
mod random;

pub use camera::Camera;
pub use random::random_rays;

//! kdbeam: SIMD packet ray tracing through SAH kd-trees, with Reshetov's transient frustum.
#![deny(missing_docs)]
#![deny(unsafe_code)]

mod error;
pub mod kdtree;
pub mod scene;

pub use error::{Error, Result};
pub use kdbeam_kernels as kernels;
pub use kdbeam_kernels::{Aabb, Hit, Isa, Ray, Triangle};
pub use kdtree::{BuildParams, BuildStats, KdTree};
pub use scene::Mesh;

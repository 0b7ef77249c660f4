#![doc = include_str!("../README.md")]
#![deny(missing_docs)]
#![deny(unsafe_code)]

mod error;
pub mod kdtree;
pub mod rays;
pub mod scene;
pub mod trace;

pub use error::{Error, Result};
pub use glam::Vec3;
pub use kdbeam_kernels as kernels;
pub use kdbeam_kernels::{Aabb, Hit, HitPacket, Isa, PacketShape, Ray, RayPacket, Triangle};
pub use kdtree::{BuildParams, BuildStats, KdTree, KdTreeBuilder};
pub use rays::Camera;
pub use scene::Mesh;
pub use trace::{Intersector, Tracer};

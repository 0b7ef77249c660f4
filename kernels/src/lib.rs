//! The kernels of kdbeam: SIMD lanes, rays and packets, triangle forms, ray × triangle tests,
//! ray × box slabs, single-ray box culling, the transient frustum, and the counting and costing
//! of split planes over boxes. They know rays, triangles and boxes, never trees.
//!
//! `#![no_std]` and allocation-free; the `std` feature only adds run-time ISA detection.
#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]
#![deny(clippy::undocumented_unsafe_blocks)]

pub mod aabb;
pub mod beam;
pub mod groups;
pub mod intersect;
pub mod lanes;
pub mod packet;
pub mod ray;
pub mod raybox;
pub mod slab;
pub mod split_planes;
pub mod subspace;
pub mod triangle;

pub use aabb::Aabb;
pub use glam::{DVec3, Vec3};
pub use lanes::{Dispatch, Isa, LaneCount, LaneF32, LaneMask, LaneTask, Lanes};
pub use packet::{HitPacket, PacketShape, RayPacket, MAX_PACKET_RAYS};
pub use ray::{Hit, Ray};
pub use triangle::{KsTriangle, Triangle, TriangleBlock};

//! SIMD ray tracing through SAH kd-trees, with Reshetov's transient frustum culling.
//!
//! kdbeam builds a kd-tree over a triangle [`Mesh`] ([`KdTree::build`]) and traces rays through
//! it with a [`Tracer`]: single rays, packets of up to 64 rays ([`RayPacket`], 4 or 8 SIMD
//! lanes at a time) and streams cut into packets, for the closest hit ([`Hit`]) or any hit
//! (shadow rays). Each time a packet enters a leaf, a frustum is built around its active rays
//! and the triangles outside it are culled before any ray is tested (A. Reshetov, *Faster Ray
//! Packets – Triangle Intersection through Vertex Culling*, IEEE Symposium on Interactive Ray
//! Tracing 2007); [`Culling`] chooses the stages, and [`Culling::AUTO`], the default, chooses
//! per leaf.
//!
//! ```
//! use kdbeam::{BuildParams, Culling, HitPacket, KdTree, Mesh, Ray, RayPacket, Tracer, Vec3};
//!
//! let mesh = Mesh::from_indexed(&[[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], &[0, 1, 2])?;
//! let tree = KdTree::build(&mesh, &BuildParams::default())?;
//! let tracer = Tracer::new(&tree).with_culling(Culling::AUTO);
//!
//! let hit = tracer.intersect(&Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z));
//! assert_eq!((hit.triangle, hit.t), (0, 1.0));
//!
//! let packet = RayPacket::from_rays(&[Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z); 16]);
//! let mut hits = HitPacket::default();
//! tracer.intersect_packet(&packet, packet.full_mask(), &mut hits);
//! assert_eq!((hits.triangle[15], hits.t[15]), (0, 1.0));
//! # Ok::<(), kdbeam::Error>(())
//! ```
//!
//! # Modules
//!
//! - [`scene`]: [`Mesh`] (validated on construction), OBJ loading ([`scene::load_obj`], also
//!   `.obj.gz`), procedural scenes and the synthetic Kensler–Shirley data; [`Scene`]
//!   ([`scene::world`]): many meshes and instances, committed and traced together.
//! - [`kdtree`]: the SAH build ([`BuildParams`], [`KdTreeBuilder`] for rebuilds in place), the
//!   node layout and [`BuildStats`].
//! - [`trace`]: [`Tracer`], [`Intersector`], [`Culling`], streams and the f64 references.
//! - [`rays`]: the [`Camera`] (standard or look-at; pixel-tile packets), random ray sets, the
//!   secondary-ray workloads of a renderer ([`rays::secondary`]: shadow, ambient occlusion,
//!   diffuse) and sorted streams ([`rays::stream`]).
//! - [`kernels`]: the `no_std` kernels (SIMD lanes, ray × triangle tests, slabs, the beam).
//!
//! # ISA
//!
//! [`Tracer::new`] and [`KdTreeBuilder::new`] resolve the widest ISA this CPU runs (or the one
//! `KDBEAM_ISA=scalar|portable|sse|avx2|avx512` names) once; [`Tracer::with_isa`] forces one, and
//! fails with [`Error::IsaUnavailable`] when the CPU lacks it. Every ISA gives the scalar path's
//! hits.
//!
//! # Errors and edge cases
//!
//! Bad input (malformed OBJ, non-finite vertices, out-of-range indices, empty meshes, bad
//! parameters) gives a typed [`Error`], never a panic. Rays that cannot be traced (NaN or
//! infinite components, a zero direction, `tmin > tmax`) give [`Hit::NONE`] and never change
//! the other rays of their packet. Equal `t` goes to the smaller triangle id.
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
pub use scene::world::{GeometryId, InstanceId, Scene, SceneHit};
pub use scene::Mesh;
pub use trace::{Culling, Intersector, Tracer};

/// The README's examples, compiled and run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

//! Embree 3 side by side with kdbeam, on the same rays (the `embree` feature).
//!
//! Every performance claim of kdbeam is a ratio against baselines measured in the same run;
//! Embree's BVH and its rtcIntersect1/4/8/16 kernels are the outside one. This module
//! uploads a [`Mesh`](kdbeam::Mesh) to Embree ([`EmbreeScene`]) and traces slices of kdbeam
//! [`Ray`](kdbeam::Ray)s into kdbeam [`Hit`](kdbeam::Hit)s
//! ([`EmbreeScene::intersect_stream`]), in packets of 1, 4, 8 or 16 rays; [`EmbreeInstances`]
//! is the two-level scene of moving instances that the `animated` example compares.
//!
//! Packets are consecutive rays of the slice. For primary rays, [`primary_rays`] orders the
//! camera's rays so that those packets are exactly kdbeam's pixel tiles of the same size (2×2,
//! 4×2, 4×4; 8×8 tiles for single rays); for random rays the slice is traced as it is.
//!
//! Embree is linked from the system (`libembree3`, Debian's `libembree-dev`:
//! `scripts/install-embree.sh`). Its calls are `unsafe` foreign calls, so this module is the one
//! place above the kernels that allows `unsafe` code.
#![allow(unsafe_code)]

mod instances;
mod query;
mod scene;
mod tiles;

pub use instances::EmbreeInstances;
pub use query::{Context, EmbreeRays, QUERY_WIDTHS};
pub use scene::{BuildQuality, EmbreeOptions, EmbreeScene};
pub use tiles::{primary_rays, tile_order};

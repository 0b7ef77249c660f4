//! The harness behind the `kdbeam` command-line tool: what a measurement needs and a renderer
//! does not, kept out of the `kdbeam` library so that depending on it pulls none of this.
//!
//! - [`render`]: frames of primary rays traced in pixel tiles, shading, heat maps, PNG images;
//! - [`report`]: CSV tables, SVG plots and the accuracy comparison against the f64 oracle;
//! - [`scenes`]: where the shared test meshes are (`KDBEAM_SCENES`);
//! - `embree` (the `embree` feature): Embree 3 on the same rays, for side-by-side figures.
#![deny(missing_docs)]
#![deny(unsafe_code)]
#![deny(clippy::undocumented_unsafe_blocks)]

#[cfg(feature = "embree")]
pub mod embree;
mod error;
pub mod render;
pub mod report;
pub mod scenes;

pub use error::{Error, Result};

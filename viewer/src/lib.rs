//! The interactive viewer of kdbeam: a window (minifb) onto a mesh, traced every frame with
//! shadows, an orbit camera and the live figures — Mrays/s, frame time and the share of
//! ray–triangle tests the frustum culled — drawn over the picture.
//!
//! ```text
//! cargo run --release -p kdbeam-viewer --example viewer [SCENE] [--size WxH]
//! cargo run --release -p kdbeam-viewer --example viewer -- --frames 3 --screenshot shot.png
//! ```
//!
//! This crate is a workspace member of its own, outside the default members, so that
//! `cargo test` never builds the window crate.
#![deny(missing_docs)]
#![deny(unsafe_code)]

pub mod font;
pub mod frame;
pub mod orbit;

pub use font::draw_text;
pub use frame::{distinct_colours, render_frame, FrameStats};
pub use orbit::Orbit;

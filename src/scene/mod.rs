//! Scenes: validated meshes, OBJ loading, procedural and synthetic generators.

#[cfg(feature = "tobj")]
mod from_tobj;
mod mesh;
mod obj;
pub mod procedural;
pub mod rng;
pub mod synthetic;

pub use mesh::Mesh;
pub use obj::load_obj;

//! Scenes: validated meshes, OBJ loading, procedural and synthetic generators, and
//! [`world::Scene`], many meshes and instances traced together.

#[cfg(feature = "tobj")]
mod from_tobj;
mod mesh;
mod obj;
pub mod procedural;
pub mod rng;
pub mod synthetic;
pub mod world;

pub use mesh::Mesh;
pub use obj::load_obj;

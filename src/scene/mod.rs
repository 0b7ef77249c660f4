//! Scenes: validated meshes, OBJ loading, procedural and synthetic generators.

mod mesh;
mod obj;
pub mod procedural;
pub mod rng;
mod shared;
pub mod synthetic;

pub use mesh::Mesh;
pub use obj::load_obj;
pub use shared::{shared_scene, shared_scenes_dir, SharedScene, SHARED_SCENES};

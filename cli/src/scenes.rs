//! The shared test meshes (their folder's `SOURCES.md` says where each comes from): where they
//! are and what they hold, so that the commands accept `bunny` for the bunny's file.

use std::path::PathBuf;

use kdbeam::scene::{self, procedural};
use kdbeam::Mesh;

use crate::Result;

/// One shared test mesh: its short name and its file under the scenes directory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SharedScene {
    /// Short name: `bunny`, `sponza`, `dragon` or `killeroo`.
    pub name: &'static str,
    /// Path of the OBJ file relative to [`shared_scenes_dir`].
    pub file: &'static str,
}

/// The four shared meshes, smallest file first.
pub const SHARED_SCENES: &[SharedScene] = &[
    SharedScene {
        name: "killeroo",
        file: "killeroo/killeroo_cage.obj",
    },
    SharedScene {
        name: "sponza",
        file: "sponza_dabrovic/sponza.obj.gz",
    },
    SharedScene {
        name: "bunny",
        file: "bunny/stanford-bunny.obj",
    },
    SharedScene {
        name: "dragon",
        file: "dragon_100k/dragon.obj",
    },
];

/// The directory of the shared meshes, if it exists.
///
/// `$KDBEAM_SCENES` when that variable is set (and then only it), otherwise `shared/scenes`
/// beside the repository's checkout (found from this crate's path at compile time). `None` when
/// the chosen path is not a directory.
pub fn shared_scenes_dir() -> Option<PathBuf> {
    let dir = match std::env::var_os("KDBEAM_SCENES") {
        Some(dir) => PathBuf::from(dir),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes"),
    };
    dir.is_dir().then_some(dir)
}

/// The path of the shared mesh called `name` (see [`SHARED_SCENES`]), if the scenes directory
/// exists. `None` for an unknown name or a missing directory; the file itself is not checked.
pub fn shared_scene(name: &str) -> Option<PathBuf> {
    let scene = SHARED_SCENES.iter().find(|s| s.name == name)?;
    Some(shared_scenes_dir()?.join(scene.file))
}

/// Loads the mesh `name` names: `builtin:NAME[:SIZE]` ([`procedural::builtin`]), a shared
/// mesh's short name (see [`SHARED_SCENES`]), or a path to an `.obj` or `.obj.gz` file.
///
/// # Errors
/// What [`procedural::builtin`] or [`scene::load_obj`] returns (an unknown built-in, a missing
/// or malformed file).
pub fn load_scene(name: &str) -> Result<Mesh> {
    Ok(if let Some(builtin) = name.strip_prefix("builtin:") {
        procedural::builtin(builtin)?
    } else if let Some(path) = shared_scene(name) {
        scene::load_obj(path)?
    } else {
        scene::load_obj(name)?
    })
}

//! Where the shared test meshes are, for the tests and benches: `$KDBEAM_SCENES` when it is set
//! (and then only there), otherwise `shared/scenes` beside the checkout. The library knows no
//! such path; a clone without the meshes still builds and passes, each skip saying why.

use std::path::PathBuf;

use kdbeam::scene::load_obj;
use kdbeam::Mesh;

/// The shared meshes by short name, with their files under the scenes directory.
pub const SHARED_SCENES: [(&str, &str); 4] = [
    ("killeroo", "killeroo/killeroo_cage.obj"),
    ("sponza", "sponza_dabrovic/sponza.obj.gz"),
    ("bunny", "bunny/stanford-bunny.obj"),
    ("dragon", "dragon_100k/dragon.obj"),
];

/// The scenes directory, or why there is none.
pub fn scenes_dir() -> Result<PathBuf, String> {
    let (dir, source) = match std::env::var_os("KDBEAM_SCENES") {
        Some(dir) => (PathBuf::from(dir), "$KDBEAM_SCENES"),
        None => (
            PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/scenes"),
            "the default beside the checkout (set KDBEAM_SCENES to choose another)",
        ),
    };
    if dir.is_dir() {
        Ok(dir)
    } else {
        Err(format!("{} ({source}) is not a directory", dir.display()))
    }
}

/// The file of the shared mesh `name`, or why it cannot be had.
pub fn shared_scene(name: &str) -> Result<PathBuf, String> {
    let (_, file) = SHARED_SCENES
        .iter()
        .find(|(n, _)| *n == name)
        .ok_or_else(|| format!("{name} is not a shared scene"))?;
    let path = scenes_dir()?.join(file);
    if path.is_file() {
        Ok(path)
    } else {
        Err(format!("{} does not exist", path.display()))
    }
}

/// The shared mesh `name` loaded, or `None` after printing that it is skipped and why. A file
/// that exists but does not load is a failure, not a skip.
pub fn load_shared(name: &str) -> Option<Mesh> {
    match shared_scene(name) {
        Ok(path) => Some(load_obj(&path).unwrap_or_else(|e| panic!("shared scene {name}: {e}"))),
        Err(why) => {
            eprintln!("skipped: shared scene {name}: {why}");
            None
        }
    }
}

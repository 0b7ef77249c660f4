//! What the benches share.

use kdbeam::scene::procedural;
use kdbeam::Mesh;

#[path = "../../tests/common/scenes.rs"]
#[allow(dead_code)]
mod scenes;

/// The shared bunny, sponza and dragon when `KDBEAM_SCENES` (or the default beside the
/// checkout) finds them, each missing one skipped with a message saying why; the built-in
/// default scene when none is found.
pub fn scenes() -> Vec<(String, Mesh)> {
    let mut out: Vec<(String, Mesh)> = ["bunny", "sponza", "dragon"]
        .into_iter()
        .filter_map(|name| Some((name.to_string(), scenes::load_shared(name)?)))
        .collect();
    if out.is_empty() {
        eprintln!("no shared scene found: measuring builtin:default only");
        out.push((
            "builtin:default".into(),
            procedural::builtin("default").expect("built-in"),
        ));
    }
    out
}

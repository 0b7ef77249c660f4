//! What the benches share.

use kdbeam::scene::{self, procedural};
use kdbeam::Mesh;

/// The shared bunny, sponza and dragon when `KDBEAM_SCENES` finds them, else the built-in
/// default scene (saying so).
pub fn scenes() -> Vec<(String, Mesh)> {
    let mut out = Vec::new();
    for name in ["bunny", "sponza", "dragon"] {
        if let Some(path) = scene::shared_scene(name) {
            out.push((
                name.to_string(),
                scene::load_obj(path).expect("shared scene loads"),
            ));
        }
    }
    if out.is_empty() {
        eprintln!("shared scenes not found: measuring builtin:default only");
        out.push((
            "builtin:default".into(),
            procedural::builtin("default").expect("built-in"),
        ));
    }
    out
}

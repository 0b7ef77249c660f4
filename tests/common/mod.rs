//! Scenes, ray sets and temporary files shared by the integration tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use kdbeam::rays::{random_rays, Camera};
use kdbeam::scene::{procedural, rng::Rng};
use kdbeam::{Mesh, Ray, Vec3};

pub mod scenes;

/// Small procedural scenes (every generator) and, when present, the shared real meshes.
/// Prints a clear line when the shared scenes are skipped.
pub fn scenes(real: bool) -> Vec<(String, Mesh)> {
    let mut out: Vec<(String, Mesh)> = [
        "icosphere",
        "grid",
        "soup:3000",
        "hair:2000",
        "terrain:40",
        "default",
    ]
    .iter()
    .map(|n| {
        (
            format!("builtin:{n}"),
            procedural::builtin(n).expect("built-in scene"),
        )
    })
    .collect();
    if real {
        out.extend(real_scenes());
    }
    out
}

/// The shared real meshes that are present (each missing one is skipped with a message saying
/// why).
pub fn real_scenes() -> Vec<(String, Mesh)> {
    ["killeroo", "bunny", "sponza", "dragon"]
        .into_iter()
        .filter_map(|name| Some((name.to_string(), scenes::load_shared(name)?)))
        .collect()
}

/// Rays that stress a traversal: mixed direction signs, zero direction components, origins on
/// triangles (on surfaces and on split planes), axis-parallel rays through vertices, NaN,
/// infinite and zero-length rays, and rays with tmin > tmax.
pub fn adversarial_rays(mesh: &Mesh, count: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let b = mesh.bounds();
    let mut rays = random_rays(&b, count / 2, seed);
    let n = mesh.triangle_count().max(1);
    while rays.len() < count {
        let kind = rng.below(8);
        let tri = mesh.triangle(rng.below(n as u32) as usize);
        let on_surface = tri.v0 * 0.25 + tri.v1 * 0.25 + tri.v2 * 0.5;
        let mut direction = rng.unit_vector();
        let origin = match kind {
            0 => on_surface,
            1 => tri.v0,
            2 => {
                // Axis-parallel, through a vertex, from outside the box.
                let axis = rng.below(3) as usize;
                direction = Vec3::ZERO;
                direction[axis] = 1.0;
                let mut o = tri.v1;
                o[axis] = b.min[axis] - 1.0;
                o
            }
            3 => {
                direction[rng.below(3) as usize] = 0.0;
                direction[rng.below(3) as usize] = -0.0;
                on_surface - direction
            }
            4 => Vec3::new(f32::NAN, 0.0, 0.0),
            5 => {
                direction = Vec3::ZERO;
                on_surface
            }
            6 => {
                direction = Vec3::new(f32::INFINITY, 1.0, 0.0);
                on_surface
            }
            _ => on_surface - direction,
        };
        let mut r = Ray::new(origin, direction);
        if kind == 7 && rng.below(4) == 0 {
            r.tmin = 1.0;
            r.tmax = 0.5;
        }
        rays.push(r);
    }
    rays
}

/// `width × height` primary rays of the standard camera.
pub fn primary_rays(mesh: &Mesh, width: u32, height: u32) -> Vec<Ray> {
    Camera::standard(&mesh.bounds(), width, height).rays()
}

/// A file in a directory of its own under the system's temporary directory, removed (with the
/// directory) on drop.
pub struct TempFile {
    path: PathBuf,
}

impl TempFile {
    /// A path named `name` in a fresh directory unique to this process and call; the file itself
    /// is not created.
    pub fn new(name: &str) -> TempFile {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let dir = std::env::temp_dir().join(format!(
            "kdbeam-test-{}-{}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir).expect("create a temporary directory");
        TempFile {
            path: dir.join(name),
        }
    }

    /// A file named `name` holding `bytes`, as [`TempFile::new`].
    pub fn with_bytes(name: &str, bytes: &[u8]) -> TempFile {
        let file = TempFile::new(name);
        std::fs::write(&file.path, bytes).expect("write a temporary file");
        file
    }

    /// The file's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for TempFile {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(dir) = self.path.parent() {
            // Best effort: a leftover file in the temporary directory is harmless.
            let _ = std::fs::remove_dir_all(dir);
        }
    }
}

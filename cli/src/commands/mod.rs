//! The commands of the `kdbeam` tool, and what they share: the tree options, scene loading,
//! thread pools and progress display.

use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use kdbeam::trace::Intersector;
use kdbeam::{Aabb, BuildParams, Camera, KdTree, Mesh, PacketShape, Vec3};
use kdbeam_cli::{Error, Result};

pub(crate) mod accuracy;
pub(crate) mod bench;
pub(crate) mod build_bench;
pub(crate) mod figures;
pub(crate) mod leaf_size_sweep;
pub(crate) mod render;
pub(crate) mod sweep;
pub(crate) mod synthetic;

/// Options shared by every command that builds a tree and traces.
#[derive(clap::Args, Clone)]
pub(crate) struct TreeArgs {
    /// Ray–triangle test: kensler_shirley or watertight.
    #[arg(long, default_value = "kensler_shirley")]
    intersector: Intersector,
    /// SAH cost ratio of a ray–triangle test to a traversal step (default: from the scene's
    /// triangles, `BuildParams::for_mesh`).
    #[arg(long)]
    ci_over_ct: Option<f32>,
    /// SAH discount for splits with an empty side, in [0, 1).
    #[arg(long, default_value_t = BuildParams::default().empty_bonus)]
    empty_bonus: f32,
    /// Nodes of at most this many triangles choose their split exactly, larger ones by
    /// binning: lower builds faster, with slightly costlier trees.
    #[arg(long, default_value_t = BuildParams::default().exact_search_max)]
    exact_search_max: u32,
}

/// The camera options of `render` and `bench`: none gives the standard camera.
#[derive(clap::Args, Clone, Default)]
pub(crate) struct CameraArgs {
    /// Camera position X,Y,Z (default: the standard camera's eye).
    #[arg(long, value_parser = parse_point)]
    eye: Option<Vec3>,
    /// Point the camera looks at, X,Y,Z (default: the scene box's centre).
    #[arg(long, value_parser = parse_point)]
    look_at: Option<Vec3>,
    /// Field of view in degrees, horizontal and vertical (default: the standard camera's,
    /// 2·atan(½) ≈ 53.13).
    #[arg(long)]
    fov: Option<f32>,
}

impl CameraArgs {
    /// The standard camera of `bounds` when no option is given, otherwise the look-at camera
    /// of the options, each missing one taken from the standard camera.
    fn camera(&self, bounds: &Aabb, width: u32, height: u32) -> Result<Camera> {
        let standard = Camera::standard(bounds, width, height);
        if self.eye.is_none() && self.look_at.is_none() && self.fov.is_none() {
            return Ok(standard);
        }
        let eye = self.eye.unwrap_or(standard.eye);
        let target = self.look_at.unwrap_or(if bounds.is_empty() {
            Vec3::Z
        } else {
            bounds.center()
        });
        let fov = self.fov.unwrap_or(2.0 * 0.5f32.atan().to_degrees());
        Ok(Camera::look_at(eye, target, fov, width, height)?)
    }
}

fn parse_point(s: &str) -> std::result::Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|c| c.trim().parse::<f32>().map_err(|e| format!("{c:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("expected three finite numbers X,Y,Z, got {s:?}")),
    }
}

pub(crate) use kdbeam_cli::render::parse_size;

/// Loads `name`: `builtin:NAME`, a shared scene's short name, or a path.
fn load_scene(name: Option<&str>) -> Result<(String, Mesh)> {
    let name = name.unwrap_or("builtin:default");
    Ok((name.to_string(), kdbeam_cli::scenes::load_scene(name)?))
}

/// Runs `f`, showing a spinner with `message` if it takes longer than a second.
fn with_spinner<T>(message: &str, f: impl FnOnce() -> T) -> T {
    let bar = ProgressBar::hidden();
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} {elapsed}").expect("static template"),
    );
    bar.set_message(message.to_string());
    let shown = bar.clone();
    let (tx, rx) = std::sync::mpsc::channel::<()>();
    let watcher = std::thread::spawn(move || {
        if rx.recv_timeout(Duration::from_secs(1)).is_err() {
            shown.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            shown.enable_steady_tick(Duration::from_millis(100));
        }
    });
    let out = f();
    drop(tx);
    let _ = watcher.join();
    bar.finish_and_clear();
    out
}

/// A progress bar over `len` steps, drawn only once a second has passed.
fn delayed_bar(len: u64, message: &str) -> (ProgressBar, Instant) {
    let bar = ProgressBar::with_draw_target(Some(len), indicatif::ProgressDrawTarget::hidden());
    bar.set_style(
        ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} {elapsed}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_message(message.to_string());
    (bar, Instant::now())
}

impl TreeArgs {
    /// The SAH cost ratio of `mesh`'s tree: `--ci-over-ct`, or else the mesh's own
    /// ([`BuildParams::for_mesh`]).
    fn ci_over_ct(&self, mesh: &Mesh) -> f32 {
        self.ci_over_ct
            .unwrap_or_else(|| BuildParams::for_mesh(mesh).ci_over_ct)
    }

    /// These options with `mesh`'s SAH cost ratio settled, so that it is measured once.
    fn for_mesh(&self, mesh: &Mesh) -> TreeArgs {
        TreeArgs {
            ci_over_ct: Some(self.ci_over_ct(mesh)),
            ..self.clone()
        }
    }
}

fn build_tree(mesh: &Mesh, args: &TreeArgs) -> Result<KdTree> {
    let params = BuildParams::default()
        .with_ci_over_ct(args.ci_over_ct(mesh))
        .with_empty_bonus(args.empty_bonus)
        .with_exact_search_max(args.exact_search_max);
    Ok(with_spinner("building kd-tree", || {
        KdTree::build(mesh, &params)
    })?)
}

fn packet_shape(rays: usize) -> Result<PacketShape> {
    PacketShape::from_len(rays)
        .ok_or_else(|| Error::invalid("packet", format!("must be 4, 8, 16 or 64, got {rays}")))
}

fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        if n == 0 {
            return Err(Error::invalid("threads", "must be at least 1"));
        }
        b = b.num_threads(n);
    }
    b.build()
        .map_err(|e| Error::invalid("threads", e.to_string()))
}

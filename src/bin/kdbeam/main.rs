//! The kdbeam command-line tool: render a scene, benchmark the tracer.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::{Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use kdbeam::render::{self, Camera};
use kdbeam::scene::{self, procedural};
use kdbeam::trace::{Culling, Intersector};
use kdbeam::{BuildParams, Isa, KdTree, Mesh, PacketShape, Tracer};

#[derive(Parser)]
#[command(
    name = "kdbeam",
    version,
    about = "SIMD packet ray tracing through SAH kd-trees"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene with the standard camera to a PNG; print build and trace statistics.
    Render(RenderArgs),
    /// Measure Mrays/s per ISA and packet size (with --embree: next to Embree's).
    Bench(bench::BenchArgs),
    /// Sweep kd-tree size (ci_over_ct) against culling: Mrays/s and tests eliminated
    /// (Reshetov's Figs. 7–9).
    Sweep(sweep::SweepArgs),
    /// Measure kd-tree build time per ci_over_ct against Embree's BVH build (with the embree
    /// feature), and build + one frame of primary rays: the cost per frame of moving geometry.
    BuildBench(build_bench::BuildBenchArgs),
    /// Cycles per ray–triangle test on Kensler–Shirley synthetic data (one leaf, no tree), per
    /// culling setting next to the unculled baseline (Reshetov's Figs. 3–5).
    Synthetic(synthetic::SyntheticArgs),
    /// Run time against error: every intersector × ISA × culling mode against the f64 oracle
    /// (hit/miss disagreements, wrong triangle ids, edge ties, relative error of t).
    Accuracy(accuracy::AccuracyArgs),
    /// Reshetov's Figs. 3, 4, 5 (synthetic) and 7 (tree size), and the Embree comparison, as
    /// SVG + CSV with a markdown summary.
    Figures(figures::FiguresArgs),
}

/// Options shared by every command that builds a tree and traces.
#[derive(clap::Args, Clone)]
struct TreeArgs {
    /// Ray–triangle test: kensler_shirley or watertight.
    #[arg(long, default_value = "kensler_shirley")]
    intersector: Intersector,
    /// SAH cost ratio of a ray–triangle test to a traversal step.
    #[arg(long, default_value_t = BuildParams::default().ci_over_ct)]
    ci_over_ct: f32,
    /// SAH discount for splits with an empty side, in [0, 1).
    #[arg(long, default_value_t = BuildParams::default().empty_bonus)]
    empty_bonus: f32,
    /// Nodes of at most this many triangles choose their split exactly, larger ones by
    /// binning: lower builds faster, with slightly costlier trees.
    #[arg(long, default_value_t = BuildParams::default().exact_search_max)]
    exact_search_max: u32,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// A path to an .obj or .obj.gz, a shared scene (bunny, sponza, dragon, killeroo) or
    /// builtin:NAME (default builtin:default).
    scene: Option<String>,
    /// Where to write the picture.
    #[arg(long, default_value = "kdbeam.png")]
    out: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
    size: (u32, u32),
    /// Also draw heat maps of ray–triangle tests per pixel next to the picture: without
    /// culling, then with the chosen culling, on one log scale.
    #[arg(long)]
    heatmap: bool,
    /// Instruction set: scalar, portable, sse, avx2 (default: the widest this CPU runs, or
    /// KDBEAM_ISA).
    #[arg(long)]
    isa: Option<Isa>,
    /// Packet size in rays: 4, 8, 16 or 64.
    #[arg(long, default_value_t = 64)]
    packet: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Culling in the leaves: none, 4plane, 6plane, 4plane+aperture, 6plane+aperture or auto,
    /// optionally /masked|/maskless|/adaptive|/packet (whole-packet traversal) and
    /// ,distance-first|,aperture-first.
    #[arg(long, default_value = "auto")]
    culling: Culling,
    #[command(flatten)]
    tree: TreeArgs,
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or("expected WIDTHxHEIGHT, e.g. 1024x768")?;
    let parse = |v: &str| match v.trim().parse::<u32>() {
        Ok(n) if (1..=16384).contains(&n) => Ok(n),
        _ => Err(format!("{v:?} is not a size from 1 to 16384")),
    };
    Ok((parse(w)?, parse(h)?))
}

/// Loads `name`: `builtin:NAME`, a shared scene's short name, or a path.
fn load_scene(name: Option<&str>) -> kdbeam::Result<(String, Mesh)> {
    let name = name.unwrap_or("builtin:default");
    let mesh = if let Some(builtin) = name.strip_prefix("builtin:") {
        procedural::builtin(builtin)?
    } else if let Some(path) = scene::shared_scene(name) {
        scene::load_obj(path)?
    } else {
        scene::load_obj(name)?
    };
    Ok((name.to_string(), mesh))
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

fn build_tree(mesh: &Mesh, args: &TreeArgs) -> kdbeam::Result<KdTree> {
    let params = BuildParams {
        ci_over_ct: args.ci_over_ct,
        empty_bonus: args.empty_bonus,
        exact_search_max: args.exact_search_max,
        ..BuildParams::default()
    };
    with_spinner("building kd-tree", || KdTree::build(mesh, &params))
}

fn packet_shape(rays: usize) -> kdbeam::Result<PacketShape> {
    PacketShape::from_len(rays).ok_or(kdbeam::Error::InvalidParameter {
        name: "packet",
        message: format!("must be 4, 8, 16 or 64, got {rays}"),
    })
}

fn tracer<'t>(tree: &'t KdTree, args: &RenderArgs) -> kdbeam::Result<Tracer<'t>> {
    let t = Tracer::new(tree)
        .with_intersector(args.tree.intersector)
        .with_packet(packet_shape(args.packet)?)
        .with_culling(args.culling);
    match args.isa {
        Some(isa) => t.with_isa(isa),
        None => Ok(t),
    }
}

fn thread_pool(threads: Option<usize>) -> kdbeam::Result<rayon::ThreadPool> {
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = threads {
        if n == 0 {
            return Err(kdbeam::Error::InvalidParameter {
                name: "threads",
                message: "must be at least 1".into(),
            });
        }
        b = b.num_threads(n);
    }
    b.build().map_err(|e| kdbeam::Error::InvalidParameter {
        name: "threads",
        message: e.to_string(),
    })
}

fn render(args: RenderArgs) -> kdbeam::Result<()> {
    kdbeam::kernels::Dispatch::from_env()?;
    let pool = thread_pool(args.threads)?;
    pool.install(|| {
        let (name, mesh) = with_spinner("loading scene", || load_scene(args.scene.as_deref()))?;
        let tree = build_tree(&mesh, &args.tree)?;
        let stats = tree.stats();
        println!("scene      {name}: {} triangles", mesh.triangle_count());
        let sah_cost = tree.sah_cost(args.tree.ci_over_ct);
        println!("kd-tree    {stats}, SAH cost {sah_cost:.2}");
        let tracer = tracer(&tree, &args)?;
        let camera = Camera::standard(&tree.bounds(), args.size.0, args.size.1);
        let (bar, start) = delayed_bar(u64::from(camera.height), "tracing");
        let frame = render::trace_primary(&tracer, &camera, &|rows| {
            if start.elapsed() > Duration::from_secs(1) && bar.is_hidden() {
                bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
            }
            bar.inc(rows);
        });
        bar.finish_and_clear();
        let hit = frame.hits.iter().filter(|h| h.is_hit()).count();
        println!(
            "trace      {}x{} primary rays, {} isa, {} packets ({}, culling {}), {} threads: {:.2} Mrays/s, {:.1}% hit",
            camera.width,
            camera.height,
            tracer.isa(),
            tracer.packet().ray_count(),
            tracer.intersector().name(),
            tracer.culling(),
            rayon::current_num_threads(),
            frame.mrays_per_s(),
            100.0 * hit as f64 / frame.rays().max(1) as f64,
        );
        let c = &frame.counters;
        println!(
            "work       {:.2} leaves/ray, {:.2} tests/ray of {:.2} potential: {:.1}% eliminated, \
             {:.2} active rays per leaf visit, beams on {:.1}% of leaf visits; per packet {:.1} \
             inner nodes, {:.2} non-empty leaves",
            c.ray_leaf_visits as f64 / frame.rays().max(1) as f64,
            frame.tests_per_ray(),
            c.potential_tests as f64 / frame.rays().max(1) as f64,
            c.eliminated_percent(),
            c.ray_leaf_visits as f64 / c.leaf_visits.max(1) as f64,
            100.0 * c.beams as f64 / c.leaf_visits.max(1) as f64,
            c.inner_visits as f64 / c.packets.max(1) as f64,
            c.leaf_visits as f64 / c.packets.max(1) as f64,
        );
        if cfg!(feature = "stats") {
            let pct = |x: u64| 100.0 * x as f64 / c.potential_tests.max(1) as f64;
            println!(
                "culled     side planes {:.1}%, near/far {:.1}%, aperture {:.1}% of potential tests; \
                 {:.1}% of leaf visits have one active ray",
                pct(c.culled_planes),
                pct(c.culled_distance),
                pct(c.culled_aperture),
                c.single_ray_visits_percent(),
            );
        }
        let mut image = frame.shade(&mesh);
        if args.heatmap {
            // Tests per pixel without culling, then with this tracer's culling, on one scale.
            let unculled = tracer.with_culling(Culling::NONE);
            let reference = render::trace_primary(&unculled, &camera, &|_| {});
            let max = reference.tests.iter().chain(&frame.tests).copied().max();
            image = image
                .beside(&render::heatmap(&reference, max))
                .beside(&render::heatmap(&frame, max));
        }
        image.write_png(&args.out)?;
        println!("wrote      {}", args.out.display());
        Ok(())
    })
}

mod accuracy;
mod bench;
mod build_bench;
mod figures;
mod sweep;
mod synthetic;

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Render(args) => render(args),
        Command::Bench(args) => bench::run(args),
        Command::Sweep(args) => sweep::run(args),
        Command::BuildBench(args) => build_bench::run(args),
        Command::Synthetic(args) => synthetic::run(args),
        Command::Accuracy(args) => accuracy::run(args),
        Command::Figures(args) => figures::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

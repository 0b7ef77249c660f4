//! `kdbeam sweep`: kd-tree size against culling, as Reshetov's Figs. 7–9.

use std::path::PathBuf;

use kdbeam::trace::{Culling, Frustum, Planes};
use kdbeam::Camera;
use kdbeam::{BuildParams, Isa, KdTree, Tracer};
use kdbeam_cli::render;
use kdbeam_cli::report::{csv, LinePlot, Series};
use kdbeam_cli::Result;

use super::{load_scene, packet_shape, thread_pool, with_spinner};

#[derive(clap::Args)]
pub(crate) struct SweepArgs {
    /// The scene (default builtin:default).
    scene: Option<String>,
    /// Smallest ci_over_ct (the culled optimum of the shared scenes lies near 0.01–0.1).
    #[arg(long, default_value_t = 0.01)]
    from: f32,
    /// Largest ci_over_ct.
    #[arg(long, default_value_t = 10.0)]
    to: f32,
    /// Tree sizes: ci_over_ct values, evenly spaced on a log scale.
    #[arg(long, default_value_t = 13)]
    steps: usize,
    /// Image size of the primary rays, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = super::parse_size)]
    size: (u32, u32),
    /// Instruction set (default: the widest this CPU runs).
    #[arg(long)]
    isa: Option<Isa>,
    /// Packet size in rays.
    #[arg(long, default_value_t = 64)]
    packet: usize,
    /// Worker threads.
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Timed repetitions per point (the median is reported).
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// Folder for sweep.csv and sweep.svg (default: no files).
    #[arg(long)]
    out: Option<PathBuf>,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
pub(crate) struct Point {
    scene: String,
    ci_over_ct: f32,
    culling: String,
    mrays_per_s: f64,
    eliminated_pct: f64,
    tests_per_ray: f64,
    nodes_per_tri: f64,
    mean_leaf_size: f64,
}

pub(crate) fn run(args: SweepArgs) -> Result<()> {
    points(&args).map(|_| ())
}

/// Measures every point of the sweep (printing each), and writes the files `args.out` asks for.
pub(crate) fn points(args: &SweepArgs) -> Result<Vec<Point>> {
    let pool = thread_pool(Some(args.threads))?;
    let (name, mesh) = load_scene(args.scene.as_deref())?;
    let cullings = [
        ("none", Culling::NONE),
        ("maskless", Culling::FULL),
        ("masked", Culling::FULL.with_frustum(Frustum::Masked)),
        ("auto", Culling::AUTO),
        (
            "packet",
            Culling::planes(Planes::Six, false).with_frustum(Frustum::Packet),
        ),
    ];
    let steps = args.steps.max(2);
    let ratios: Vec<f32> = (0..steps)
        .map(|i| args.from * (args.to / args.from).powf(i as f32 / (steps - 1) as f32))
        .collect();
    if !args.json {
        println!(
            "{:<18} {:>8} {:<9} {:>9} {:>11} {:>10} {:>10} {:>10}",
            "scene",
            "ci/ct",
            "culling",
            "Mrays/s",
            "eliminated",
            "tests/ray",
            "nodes/tri",
            "leaf size"
        );
    }
    let mut points = Vec::new();
    for &ci in &ratios {
        let params = BuildParams::default().with_ci_over_ct(ci);
        let tree = with_spinner("building kd-tree", || KdTree::build(&mesh, &params))?;
        let camera = Camera::standard(&tree.bounds(), args.size.0, args.size.1);
        for (label, culling) in cullings {
            let mut t = Tracer::new(&tree)
                .with_packet(packet_shape(args.packet)?)
                .with_culling(culling);
            if let Some(isa) = args.isa {
                t = t.with_isa(isa)?;
            }
            let frames: Vec<_> = (0..args.reps.max(1) + 1)
                .map(|_| pool.install(|| render::trace_primary(&t, &camera, &|_| {})))
                .collect();
            let mut speeds: Vec<f64> = frames[1..].iter().map(|f| f.mrays_per_s()).collect();
            speeds.sort_by(f64::total_cmp);
            let f = &frames[0];
            let p = Point {
                scene: name.clone(),
                ci_over_ct: ci,
                culling: label.to_string(),
                mrays_per_s: speeds[speeds.len() / 2],
                eliminated_pct: f.counters.eliminated_percent(),
                tests_per_ray: f.tests_per_ray(),
                nodes_per_tri: tree.stats().nodes_per_triangle(),
                mean_leaf_size: tree.stats().mean_leaf_size(),
            };
            if args.json {
                println!("{}", serde_json::to_string(&p).expect("points serialise"));
            } else {
                println!(
                    "{:<18} {:>8.3} {:<9} {:>9.2} {:>10.1}% {:>10.2} {:>10.3} {:>10.2}",
                    p.scene,
                    p.ci_over_ct,
                    p.culling,
                    p.mrays_per_s,
                    p.eliminated_pct,
                    p.tests_per_ray,
                    p.nodes_per_tri,
                    p.mean_leaf_size
                );
            }
            points.push(p);
        }
    }
    if let (false, Some(line)) = (args.json, best_culled_vs_unculled(&points)) {
        println!("{line}");
    }
    if let Some(dir) = &args.out {
        write_files(dir, "sweep", &name, &points)?;
    }
    Ok(points)
}

/// The sweep's figure of merit: the fastest point with culling against the fastest without,
/// with their tree sizes, as one line of text (`None` without both kinds of point).
pub(crate) fn best_culled_vs_unculled(points: &[Point]) -> Option<String> {
    let fastest = |culled: bool| {
        points
            .iter()
            .filter(|p| (p.culling != "none") == culled)
            .max_by(|a, b| a.mrays_per_s.total_cmp(&b.mrays_per_s))
    };
    let (c, u) = (fastest(true)?, fastest(false)?);
    Some(format!(
        "best with culling: {:.2} Mrays/s ({}, ci_over_ct {:.3}, {:.2} nodes/triangle, {:.1}% of \
         tests eliminated); best without: {:.2} Mrays/s (ci_over_ct {:.3}, {:.2} nodes/triangle): \
         {:.2}x faster, with a {:.1}x smaller tree",
        c.mrays_per_s,
        c.culling,
        c.ci_over_ct,
        c.nodes_per_tri,
        c.eliminated_pct,
        u.mrays_per_s,
        u.ci_over_ct,
        u.nodes_per_tri,
        c.mrays_per_s / u.mrays_per_s,
        u.nodes_per_tri / c.nodes_per_tri
    ))
}

/// Writes `STEM.csv` and `STEM.svg` (Mrays/s against nodes per triangle, one line per culling).
pub(crate) fn write_files(
    dir: &std::path::Path,
    stem: &str,
    scene: &str,
    points: &[Point],
) -> Result<()> {
    let io = |path: PathBuf| move |source| kdbeam::Error::Io { path, source };
    std::fs::create_dir_all(dir).map_err(io(dir.to_path_buf()))?;
    let rows: Vec<Vec<String>> = points
        .iter()
        .map(|p| {
            vec![
                p.scene.clone(),
                p.ci_over_ct.to_string(),
                p.culling.clone(),
                format!("{:.3}", p.mrays_per_s),
                format!("{:.2}", p.eliminated_pct),
                format!("{:.3}", p.tests_per_ray),
                format!("{:.4}", p.nodes_per_tri),
                format!("{:.3}", p.mean_leaf_size),
            ]
        })
        .collect();
    let header = [
        "scene",
        "ci_over_ct",
        "culling",
        "mrays_per_s",
        "eliminated_pct",
        "tests_per_ray",
        "nodes_per_tri",
        "mean_leaf_size",
    ];
    let csv_path = dir.join(format!("{stem}.csv"));
    std::fs::write(&csv_path, csv(&header, &rows)).map_err(io(csv_path.clone()))?;
    let mut series: Vec<Series> = Vec::new();
    for p in points {
        match series.iter_mut().find(|s| s.name == p.culling) {
            Some(s) => s.points.push((p.nodes_per_tri, p.mrays_per_s)),
            None => series.push(Series {
                name: p.culling.clone(),
                points: vec![(p.nodes_per_tri, p.mrays_per_s)],
            }),
        }
    }
    let plot = LinePlot {
        title: format!("{scene}: Mrays/s against kd-tree size"),
        x_label: "kd-tree nodes per triangle".into(),
        y_label: "Mrays/s".into(),
        log_x: true,
        series,
    };
    let svg_path = dir.join(format!("{stem}.svg"));
    std::fs::write(&svg_path, plot.to_svg()).map_err(io(svg_path.clone()))?;
    println!(
        "wrote      {} and {}",
        csv_path.display(),
        svg_path.display()
    );
    Ok(())
}

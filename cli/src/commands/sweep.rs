//! `kdbeam sweep`: kd-tree size against culling, as Reshetov's Figs. 7–9.

use std::path::PathBuf;

use kdbeam::rays::secondary::DEFAULT_AO_RAYS;
use kdbeam::trace::{Culling, Frustum, Planes};
use kdbeam::Camera;
use kdbeam::{BuildParams, Isa, KdTree, Tracer};
use kdbeam_cli::render;
use kdbeam_cli::render::RaySet;
use kdbeam_cli::report::{csv, LinePlot, Series};
use kdbeam_cli::Result;

use super::{load_scene, packet_shape, thread_pool, with_spinner};

#[derive(clap::Args)]
pub(crate) struct SweepArgs {
    /// The scene (default builtin:default).
    pub(crate) scene: Option<String>,
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
    pub(crate) size: (u32, u32),
    /// Instruction sets, comma separated (default: the widest this CPU runs). Each tree is
    /// traced on each.
    #[arg(long, value_delimiter = ',')]
    pub(crate) isa: Vec<Isa>,
    /// Packet size in rays.
    #[arg(long, default_value_t = 64)]
    packet: usize,
    /// Worker threads.
    #[arg(long, default_value_t = 1)]
    pub(crate) threads: usize,
    /// Timed repetitions per point (the median is reported).
    #[arg(long, default_value_t = 3)]
    pub(crate) reps: usize,
    /// Folder for sweep.csv and sweep.svg (default: no files).
    #[arg(long)]
    out: Option<PathBuf>,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    pub(crate) json: bool,
    /// Instead of tree sizes, sweep leaf sizes, comma separated (nodes of at most N triangles
    /// become leaves), each traced as single rays without and with ray-box culling: build and
    /// trace times, tests per ray, share culled, memory.
    #[arg(long, value_delimiter = ',', value_parser = clap::value_parser!(u32).range(1..))]
    pub(crate) leaf_size: Vec<u32>,
    /// SAH cost ratio of the leaf-size sweep's trees: pbrt's 80 (its intersection cost over
    /// its traversal cost) by default, so that nodes split down to the leaf size.
    #[arg(long, default_value_t = 80.0)]
    pub(crate) leaf_ci_over_ct: f32,
    /// Ray set of the leaf-size sweep: primary, random, or the secondary rays of the camera's
    /// primary hits (shadow, ao, diffuse).
    #[arg(long, value_enum, default_value = "primary")]
    pub(crate) rays: RaySet,
    /// Ambient-occlusion rays per primary hit (`--rays ao`).
    #[arg(long, default_value_t = DEFAULT_AO_RAYS, value_parser = clap::value_parser!(u32).range(1..=64))]
    pub(crate) ao_rays: u32,
}

#[derive(serde::Serialize)]
pub(crate) struct Point {
    scene: String,
    isa: String,
    ci_over_ct: f32,
    culling: String,
    mrays_per_s: f64,
    eliminated_pct: f64,
    tests_per_ray: f64,
    nodes_per_tri: f64,
    mean_leaf_size: f64,
}

pub(crate) fn run(args: SweepArgs) -> Result<()> {
    if !args.leaf_size.is_empty() {
        return super::leaf_size_sweep::run(&args);
    }
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
    let isas = if args.isa.is_empty() {
        vec![Isa::detect()]
    } else {
        args.isa.clone()
    };
    let steps = args.steps.max(2);
    let ratios: Vec<f32> = (0..steps)
        .map(|i| args.from * (args.to / args.from).powf(i as f32 / (steps - 1) as f32))
        .collect();
    if !args.json {
        println!(
            "{:<18} {:<7} {:>8} {:<9} {:>9} {:>11} {:>10} {:>10} {:>10}",
            "scene",
            "isa",
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
        for (isa, (label, culling)) in isas
            .iter()
            .flat_map(|&isa| cullings.iter().map(move |&c| (isa, c)))
        {
            let t = Tracer::new(&tree)
                .with_packet(packet_shape(args.packet)?)
                .with_culling(culling)
                .with_isa(isa)?;
            let frames: Vec<_> = (0..args.reps.max(1) + 1)
                .map(|_| pool.install(|| render::trace_primary(&t, &camera, &|_| {})))
                .collect();
            let mut speeds: Vec<f64> = frames[1..].iter().map(|f| f.mrays_per_s()).collect();
            speeds.sort_by(f64::total_cmp);
            let f = &frames[0];
            let p = Point {
                scene: name.clone(),
                isa: isa.to_string(),
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
                    "{:<18} {:<7} {:>8.3} {:<9} {:>9.2} {:>10.1}% {:>10.2} {:>10.3} {:>10.2}",
                    p.scene,
                    p.isa,
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
    if !args.json {
        for line in findings(&points) {
            println!("{line}");
        }
    }
    if let Some(dir) = &args.out {
        write_files(dir, "sweep", &name, &points)?;
    }
    Ok(points)
}

/// Per ISA of `points`: the best culled tree against the best unculled one
/// ([`best_culled_vs_unculled`]), and the speeds of smaller trees ([`smaller_trees`]).
pub(crate) fn findings(points: &[Point]) -> Vec<String> {
    let mut isas: Vec<&str> = Vec::new();
    for p in points {
        if !isas.contains(&p.isa.as_str()) {
            isas.push(&p.isa);
        }
    }
    let mut lines = Vec::new();
    for isa in isas {
        let of_isa: Vec<&Point> = points.iter().filter(|p| p.isa == isa).collect();
        lines.extend(best_culled_vs_unculled(&of_isa).map(|line| format!("{isa}: {line}")));
        lines.extend(
            smaller_trees(&of_isa, &SMALLER_TREES)
                .into_iter()
                .map(|line| format!("{isa}: {line}")),
        );
    }
    lines
}

/// The sweep's figure of merit: the fastest point with culling against the fastest without,
/// with their tree sizes, as one line of text (`None` without both kinds of point).
fn best_culled_vs_unculled(points: &[&Point]) -> Option<String> {
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

/// How many times fewer nodes than the best unculled tree the culled speed is reported at: the
/// tree sizes of Reshetov's Thai statue (RT07, Fig. 9), where culling keeps most of the speed
/// that the unculled tracer loses in small trees.
const SMALLER_TREES: [f64; 3] = [10.0, 20.0, 60.0];

/// For each factor k of `factors`: the speed of each culling's trees at k times fewer nodes than
/// the best unculled tree, against that tree's speed, one line each. Speeds are interpolated
/// linearly in log(nodes per triangle) between the two sweep points around the target size;
/// a target outside a culling's swept sizes is said to be out of range, not extrapolated.
fn smaller_trees(points: &[&Point], factors: &[f64]) -> Vec<String> {
    let Some(best) = points
        .iter()
        .filter(|p| p.culling == "none")
        .max_by(|a, b| a.mrays_per_s.total_cmp(&b.mrays_per_s))
    else {
        return Vec::new();
    };
    let mut cullings: Vec<&str> = Vec::new();
    for p in points {
        if !cullings.contains(&p.culling.as_str()) {
            cullings.push(&p.culling);
        }
    }
    let mut lines = Vec::new();
    for &k in factors {
        let target = (best.nodes_per_tri / k).ln();
        let mut parts = Vec::new();
        for culling in &cullings {
            let mut curve: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.culling == *culling)
                .map(|p| (p.nodes_per_tri.ln(), p.mrays_per_s))
                .collect();
            curve.sort_by(|a, b| a.0.total_cmp(&b.0));
            let speed = curve.windows(2).find_map(|w| {
                let ((x0, y0), (x1, y1)) = (w[0], w[1]);
                (x0 <= target && target <= x1).then(|| {
                    if x1 > x0 {
                        y0 + (y1 - y0) * (target - x0) / (x1 - x0)
                    } else {
                        y0.max(y1)
                    }
                })
            });
            parts.push(match speed {
                Some(s) => format!("{culling} {:.2}x", s / best.mrays_per_s),
                None => format!("{culling} out of range"),
            });
        }
        lines.push(format!(
            "{k}x fewer nodes than the best unculled tree ({:.4} nodes/triangle), speed against \
             its {:.2} Mrays/s: {}",
            best.nodes_per_tri / k,
            best.mrays_per_s,
            parts.join(", ")
        ));
    }
    lines
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
                p.isa.clone(),
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
        "isa",
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
    let one_isa = points.iter().all(|p| p.isa == points[0].isa);
    let mut series: Vec<Series> = Vec::new();
    for p in points {
        let name = if one_isa {
            p.culling.clone()
        } else {
            format!("{} ({})", p.culling, p.isa)
        };
        match series.iter_mut().find(|s| s.name == name) {
            Some(s) => s.points.push((p.nodes_per_tri, p.mrays_per_s)),
            None => series.push(Series {
                name,
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

#[cfg(test)]
mod tests {
    use super::*;

    fn point(culling: &str, nodes_per_tri: f64, mrays_per_s: f64) -> Point {
        Point {
            scene: "s".into(),
            isa: "avx2".into(),
            ci_over_ct: 1.0,
            culling: culling.into(),
            mrays_per_s,
            eliminated_pct: 0.0,
            tests_per_ray: 0.0,
            nodes_per_tri,
            mean_leaf_size: 0.0,
        }
    }

    /// The best unculled tree has 1 node per triangle at 10 Mrays/s; the culled curve is 8 at
    /// 0.01 and 4 at 0.001 nodes per triangle, so at 60× fewer nodes (1/60, between 0.1 and
    /// 0.01 on the unculled curve, above 0.01 on the culled one) the culled speed is out of
    /// range and the unculled one interpolates in log(nodes).
    #[test]
    fn smaller_trees_interpolate_in_log_nodes_and_never_extrapolate() {
        let points = [
            point("none", 1.0, 10.0),
            point("none", 0.1, 6.0),
            point("none", 0.01, 2.0),
            point("masked", 0.01, 8.0),
            point("masked", 0.001, 4.0),
        ];
        let refs: Vec<&Point> = points.iter().collect();
        let lines = smaller_trees(&refs, &[10.0, 20.0, 100.0]);
        assert_eq!(lines.len(), 3);
        assert!(lines[0].contains("none 0.60x"), "{}", lines[0]);
        assert!(lines[0].contains("masked out of range"), "{}", lines[0]);
        // 1/20 lies log10(2) ≈ 0.301 of the way from 0.1 to 0.01: 6 − 4·0.301 = 4.80.
        assert!(lines[1].contains("none 0.48x"), "{}", lines[1]);
        // 1/100 = 0.01 is the culled curve's end: 8 Mrays/s, 0.80×.
        assert!(lines[2].contains("masked 0.80x"), "{}", lines[2]);
        assert!(lines[2].contains("none 0.20x"), "{}", lines[2]);
    }

    #[test]
    fn findings_are_given_per_isa() {
        let mut points = vec![point("none", 1.0, 10.0), point("masked", 0.1, 12.0)];
        let mut other = point("none", 1.0, 20.0);
        other.isa = "avx512".into();
        points.push(other);
        let lines = findings(&points);
        assert!(
            lines[0].starts_with("avx2: best with culling: 12.00"),
            "{lines:?}"
        );
        assert!(
            lines.iter().any(|l| l.starts_with("avx512: 10x fewer")),
            "{lines:?}"
        );
        assert!(
            !lines.iter().any(|l| l.starts_with("avx512: best")),
            "{lines:?}"
        );
    }
}

//! `kdbeam sweep --leaf-size N,…`: leaf size against ray-box culling of single rays (Nah, Park,
//! Kang & Han, *Ray-Box Culling for Tree Structures*, J. Inf. Sci. Eng.): larger leaves build
//! faster and smaller trees, and culling wins back the tests they add.

use std::time::{Duration, Instant};

use kdbeam::trace::{Culling, RayBoxes, RayCounters};
use kdbeam::{BuildParams, KdTree, Ray, Tracer};
use kdbeam_cli::render::Rays;
use kdbeam_cli::Result;
use rayon::prelude::*;

use super::sweep::SweepArgs;
use super::{load_scene, thread_pool, with_spinner};

/// One leaf size and culling setting, measured.
#[derive(serde::Serialize)]
struct Point {
    scene: String,
    rays: &'static str,
    isa: String,
    leaf_size: u32,
    culling: &'static str,
    /// The tree's build, and for ray-box culling the boxes' (built on first use).
    build_ms: f64,
    /// Median of the timed runs.
    trace_ms: f64,
    tests_per_ray: f64,
    culled_pct: f64,
    /// Nodes, leaf records, triangle blocks and, with ray-box culling, the boxes.
    memory_mb: f64,
}

/// Traces `rays` as single rays with `tracer` (any hit when `any`): seconds and summed counters.
fn trace(tracer: &Tracer<'_>, rays: &[Ray], any: bool) -> (f64, RayCounters) {
    let start = Instant::now();
    let counters = rays
        .par_iter()
        .map(|r| {
            if any {
                tracer.occluded_counted(r).1
            } else {
                tracer.intersect_counted(r).1
            }
        })
        .reduce(RayCounters::default, |a, b| RayCounters {
            leaves: a.leaves + b.leaves,
            tests: a.tests + b.tests,
            leaves_culled: a.leaves_culled + b.leaves_culled,
            culled: a.culled + b.culled,
        });
    (start.elapsed().as_secs_f64(), counters)
}

/// Runs the sweep over `args.leaf_size`, printing a row per leaf size and culling setting and
/// the best culled against the best unculled build + trace time.
pub(crate) fn run(args: &SweepArgs) -> Result<()> {
    let pool = thread_pool(Some(args.threads))?;
    let (name, mesh) = load_scene(args.scene.as_deref())?;
    let isa = args
        .isa
        .first()
        .copied()
        .unwrap_or_else(kdbeam::Isa::detect);
    let camera = kdbeam::Camera::standard(&mesh.bounds(), args.size.0, args.size.1);
    let rays = {
        let tree = KdTree::build(&mesh, &BuildParams::default())?;
        Rays::new(args.rays, &mesh, &Tracer::new(&tree), &camera, args.ao_rays)?.rays
    };
    let any = args.rays.any_hit();
    if !args.json {
        println!(
            "{:<16} {:<8} {:<7} {:>5} {:<7} {:>9} {:>9} {:>11} {:>9} {:>7} {:>9}",
            "scene",
            "rays",
            "isa",
            "leaf",
            "culling",
            "build ms",
            "trace ms",
            "build+trace",
            "tests/ray",
            "culled",
            "memory MB"
        );
    }
    let mut points = Vec::new();
    for &leaf_size in &args.leaf_size {
        let params = BuildParams::default()
            .with_leaf_size(leaf_size)
            .with_ci_over_ct(args.leaf_ci_over_ct);
        let tree = with_spinner("building kd-tree", || KdTree::build(&mesh, &params))?;
        for (label, culling) in [
            ("none", Culling::NONE),
            ("raybox", Culling::NONE.with_raybox(RayBoxes::On)),
        ] {
            let mut build = tree.stats().build_time;
            if culling.raybox != RayBoxes::Off {
                let start = Instant::now();
                let _ = tree.triangle_boxes();
                build += start.elapsed();
            }
            let tracer = Tracer::new(&tree).with_isa(isa)?.with_culling(culling);
            let (_, counters) = pool.install(|| trace(&tracer, &rays, any));
            let mut times: Vec<f64> = (0..args.reps.max(1))
                .map(|_| pool.install(|| trace(&tracer, &rays, any)).0)
                .collect();
            times.sort_by(f64::total_cmp);
            let n = rays.len().max(1) as f64;
            let considered = (counters.tests + counters.culled).max(1) as f64;
            let p = Point {
                scene: name.clone(),
                rays: args.rays.name(),
                isa: isa.to_string(),
                leaf_size,
                culling: label,
                build_ms: ms(build),
                trace_ms: times[times.len() / 2] * 1e3,
                tests_per_ray: counters.tests as f64 / n,
                culled_pct: 100.0 * counters.culled as f64 / considered,
                memory_mb: (tree.stats().bytes + tree.raybox_bytes()) as f64 / 1e6,
            };
            if args.json {
                println!("{}", serde_json::to_string(&p).expect("points serialise"));
            } else {
                println!(
                    "{:<16} {:<8} {:<7} {:>5} {:<7} {:>9.1} {:>9.1} {:>11.1} {:>9.2} {:>6.1}% {:>9.2}",
                    p.scene,
                    p.rays,
                    p.isa,
                    p.leaf_size,
                    p.culling,
                    p.build_ms,
                    p.trace_ms,
                    p.build_ms + p.trace_ms,
                    p.tests_per_ray,
                    p.culled_pct,
                    p.memory_mb
                );
            }
            points.push(p);
        }
    }
    if !args.json {
        if let Some(line) = best_culled_vs_unculled(&points) {
            println!("{line}");
        }
    }
    Ok(())
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// The fastest trace with ray-box culling against the fastest without, over every leaf size.
fn best_culled_vs_unculled(points: &[Point]) -> Option<String> {
    let fastest = |label: &str| {
        points
            .iter()
            .filter(|p| p.culling == label)
            .min_by(|a, b| a.trace_ms.total_cmp(&b.trace_ms))
    };
    let (c, u) = (fastest("raybox")?, fastest("none")?);
    Some(format!(
        "best with ray-box culling: {:.1} ms (leaf size {}, {:.1}% culled); best without: {:.1} \
         ms (leaf size {}): {:.2}x",
        c.trace_ms,
        c.leaf_size,
        c.culled_pct,
        u.trace_ms,
        u.leaf_size,
        u.trace_ms / c.trace_ms
    ))
}

//! `kdbeam bench`: Mrays/s per scene, ray set, ISA and packet size, optionally next to Embree.

use std::time::Instant;

use kdbeam::trace::PacketCounters;
use kdbeam::Camera;
use kdbeam::{Hit, Isa, Tracer};
use kdbeam_cli::render::{self, RaySet};
use kdbeam_cli::{Error, Result};
use rayon::prelude::*;

use super::{build_tree, load_scene, packet_shape, thread_pool, TreeArgs};

#[derive(clap::Args)]
pub(crate) struct BenchArgs {
    /// Scenes: paths, shared scene names or builtin:NAME (default builtin:default).
    scenes: Vec<String>,
    /// Ray set.
    #[arg(long, value_enum, default_value = "primary")]
    rays: RaySet,
    /// Image size (primary) or ray count = W·H (random), WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = super::parse_size)]
    size: (u32, u32),
    /// ISAs to measure, comma separated (default: every one this CPU runs).
    #[arg(long, value_delimiter = ',')]
    isa: Vec<Isa>,
    /// Packet sizes to measure, comma separated; 1 is the single-ray scalar path (default:
    /// 1, 4, 8, 16, 64).
    #[arg(long, value_delimiter = ',')]
    packet: Vec<usize>,
    /// Culling settings to measure, comma separated (see `kdbeam render --help`).
    #[arg(long, value_delimiter = ',', default_value = "none,auto")]
    culling: Vec<kdbeam::trace::Culling>,
    /// Worker threads (default 1).
    #[arg(long, default_value_t = 1)]
    threads: usize,
    /// Timed repetitions per configuration (the median is reported).
    #[arg(long, default_value_t = 5)]
    reps: usize,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
    /// Also measure Embree's rtcIntersect1/4/8/16 on the same rays (rows with isa "embree";
    /// primary rays in kdbeam's 2x2, 4x2, 4x4 and 8x8 tiles; tests/ray is not counted). Embree
    /// runs in robust mode (intersector "embree_robust") when --intersector is watertight,
    /// otherwise in its fast mode (intersector "embree"). Needs a build with `--features embree`.
    #[arg(long)]
    embree: bool,
    #[command(flatten)]
    tree: TreeArgs,
}

#[derive(serde::Serialize)]
pub(crate) struct Row {
    pub(crate) scene: String,
    rays: &'static str,
    pub(crate) isa: String,
    pub(crate) packet: usize,
    intersector: &'static str,
    pub(crate) culling: String,
    threads: usize,
    pub(crate) mrays_per_s: f64,
    /// NaN (JSON `null`) where not counted.
    tests_per_ray: f64,
    /// NaN (JSON `null`) when the run measures no scalar path (`--packet` without 1).
    speedup_vs_scalar: f64,
}

pub(crate) fn run(args: BenchArgs) -> Result<()> {
    rows(&args).map(|_| ())
}

/// Measures every configuration of `args`, printing each row as it is measured.
pub(crate) fn rows(args: &BenchArgs) -> Result<Vec<Row>> {
    let mut all = Vec::new();
    if args.embree && !cfg!(feature = "embree") {
        return Err(Error::invalid(
            "embree",
            "this kdbeam was built without Embree (cargo build --release --features embree)",
        ));
    }
    let pool = thread_pool(Some(args.threads))?;
    let isas: Vec<Isa> = if args.isa.is_empty() {
        Isa::available().collect()
    } else {
        args.isa.clone()
    };
    for &isa in &isas {
        kdbeam::trace::check_isa(isa)?;
    }
    let packets = if args.packet.is_empty() {
        vec![1, 4, 8, 16, 64]
    } else {
        args.packet.clone()
    };
    let scenes = scene_names(&args.scenes);
    if !args.json {
        println!(
            "{:<16} {:<8} {:<8} {:>6} {:<22} {:>7} {:>9} {:>9} {:>9}",
            "scene",
            "rays",
            "isa",
            "packet",
            "culling",
            "threads",
            "Mrays/s",
            "tests/ray",
            "vs scalar"
        );
    }
    for scene in scenes {
        let (name, mesh) = load_scene(scene)?;
        let tree = build_tree(&mesh, &args.tree)?;
        let rays = render::ray_set(args.rays, &tree.bounds(), args.size.0, args.size.1);
        let camera = Camera::standard(&tree.bounds(), args.size.0, args.size.1);
        let mut scalar = None;
        for &packet in &packets {
            let configs: Vec<Isa> = if packet == 1 {
                vec![Isa::Scalar]
            } else {
                isas.clone()
            };
            for &isa in &configs {
                // Single rays are never culled: one row for them.
                let cullings = if packet == 1 {
                    &args.culling[..1]
                } else {
                    &args.culling[..]
                };
                for &culling in cullings {
                    let base = Tracer::new(&tree)
                        .with_intersector(args.tree.intersector)
                        .with_isa(isa)?
                        .with_culling(culling);
                    let (mrays, tests) =
                        pool.install(|| measure(args, base, packet, &rays, &camera))?;
                    if packet == 1 {
                        scalar = Some(mrays);
                    }
                    let row = Row {
                        scene: name.clone(),
                        rays: args.rays.name(),
                        isa: if packet == 1 {
                            "scalar".into()
                        } else {
                            isa.to_string()
                        },
                        packet,
                        intersector: args.tree.intersector.name(),
                        culling: if packet == 1 {
                            "none".into()
                        } else {
                            culling.name()
                        },
                        threads: args.threads,
                        mrays_per_s: mrays,
                        tests_per_ray: tests,
                        speedup_vs_scalar: scalar.map_or(f64::NAN, |s| mrays / s),
                    };
                    print_row(&row, args.json);
                    all.push(row);
                }
            }
        }
        #[cfg(feature = "embree")]
        if args.embree {
            use kdbeam_cli::embree::{EmbreeOptions, EmbreeScene};
            let robust = args.tree.intersector == kdbeam::Intersector::Watertight;
            let options = EmbreeOptions {
                robust,
                ..EmbreeOptions::default()
            };
            let scene = pool.install(|| EmbreeScene::with_options(&mesh, &options))?;
            for width in kdbeam_cli::embree::QUERY_WIDTHS {
                let mrays = pool.install(|| measure_embree(args, &scene, width, &rays, &camera))?;
                let row = Row {
                    scene: name.clone(),
                    rays: args.rays.name(),
                    isa: "embree".into(),
                    packet: width,
                    intersector: if robust { "embree_robust" } else { "embree" },
                    culling: "none".into(),
                    threads: args.threads,
                    mrays_per_s: mrays,
                    tests_per_ray: f64::NAN,
                    speedup_vs_scalar: scalar.map_or(f64::NAN, |s| mrays / s),
                };
                print_row(&row, args.json);
                all.push(row);
            }
        }
    }
    Ok(all)
}

/// The scenes to load: those named, or the default scene (`None`) when none is.
pub(crate) fn scene_names(names: &[String]) -> Vec<Option<&str>> {
    if names.is_empty() {
        vec![None]
    } else {
        names.iter().map(|s| Some(s.as_str())).collect()
    }
}

/// Prints `row` as one line of JSON, or as the table line `table` makes.
pub(crate) fn print_json_or(
    row: &impl serde::Serialize,
    json: bool,
    table: impl FnOnce() -> String,
) {
    if json {
        println!("{}", serde_json::to_string(row).expect("rows serialise"));
    } else {
        println!("{}", table());
    }
}

fn print_row(r: &Row, json: bool) {
    print_json_or(r, json, || {
        format!(
            "{:<16} {:<8} {:<8} {:>6} {:<22} {:>7} {:>9.2} {:>9} {:>9}",
            r.scene,
            r.rays,
            r.isa,
            r.packet,
            r.culling,
            r.threads,
            r.mrays_per_s,
            or_dash(r.tests_per_ray, |t| format!("{t:.2}")),
            or_dash(r.speedup_vs_scalar, |x| format!("{x:.2}x")),
        )
    })
}

/// `value` formatted, or `-` when it was not measured (NaN).
fn or_dash(value: f64, format: impl FnOnce(f64) -> String) -> String {
    if value.is_nan() {
        "-".into()
    } else {
        format(value)
    }
}

/// Median Mrays/s over `args.reps` timed runs after one warm-up, and tests per ray.
fn measure(
    args: &BenchArgs,
    tracer: Tracer<'_>,
    packet: usize,
    rays: &[kdbeam::Ray],
    camera: &Camera,
) -> Result<(f64, f64)> {
    let mut hits = vec![Hit::NONE; rays.len()];
    let mut run = || -> Result<(f64, u64)> {
        if packet == 1 {
            let start = Instant::now();
            let tests: u64 = rays
                .par_iter()
                .zip(hits.par_iter_mut())
                .map(|(r, h)| {
                    let (hit, c) = tracer.intersect_counted(r);
                    *h = hit;
                    c.tests
                })
                .sum();
            return Ok((start.elapsed().as_secs_f64(), tests));
        }
        let shape = packet_shape(packet)?;
        let t = tracer.with_packet(shape);
        let (seconds, counters): (f64, PacketCounters) = match args.rays {
            RaySet::Primary => {
                let f = render::trace_primary(&t, camera, &|_| {});
                (f.seconds, f.counters)
            }
            RaySet::Random => {
                let start = Instant::now();
                let c = t.intersect_stream(rays, &mut hits)?;
                (start.elapsed().as_secs_f64(), c)
            }
        };
        Ok((seconds, counters.tests))
    };
    let (_, tests) = run()?;
    let median = median_seconds(args.reps, || Ok(run()?.0))?;
    Ok((
        rays.len() as f64 / median / 1e6,
        tests as f64 / rays.len() as f64,
    ))
}

/// The median of `reps` (at least 1) calls of `run`, which returns seconds.
pub(crate) fn median_seconds(reps: usize, mut run: impl FnMut() -> Result<f64>) -> Result<f64> {
    let mut times = Vec::with_capacity(reps.max(1));
    for _ in 0..reps.max(1) {
        times.push(run()?);
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

/// Median Mrays/s of Embree's rtcIntersect`width` over `args.reps` timed runs after one
/// warm-up, on the same rays as kdbeam: primary rays reordered into kdbeam's tiles of `width`
/// rays (reordering is not timed; kdbeam's timing includes making its rays), random rays as
/// they are.
#[cfg(feature = "embree")]
pub(crate) fn measure_embree(
    args: &BenchArgs,
    scene: &kdbeam_cli::embree::EmbreeScene,
    width: usize,
    rays: &[kdbeam::Ray],
    camera: &Camera,
) -> Result<f64> {
    let tiled;
    let rays = match args.rays {
        RaySet::Primary => {
            tiled = kdbeam_cli::embree::primary_rays(camera, width)?.0;
            &tiled[..]
        }
        RaySet::Random => rays,
    };
    let seconds = embree_frame_seconds(scene, width, rays, args.reps)?;
    Ok(rays.len() as f64 / seconds / 1e6)
}

/// Median seconds of Embree tracing `rays` with rtcIntersect`width`, after one warm-up.
#[cfg(feature = "embree")]
pub(crate) fn embree_frame_seconds(
    scene: &kdbeam_cli::embree::EmbreeScene,
    width: usize,
    rays: &[kdbeam::Ray],
    reps: usize,
) -> Result<f64> {
    let mut hits = vec![Hit::NONE; rays.len()];
    let mut run = || {
        let start = Instant::now();
        scene.intersect_stream(rays, width, &mut hits)?;
        Ok(start.elapsed().as_secs_f64())
    };
    run()?;
    median_seconds(reps, run)
}

//! `kdbeam bench`: Mrays/s per scene, ray set, tree size, thread count, ISA and packet size,
//! optionally next to Embree's, with kdbeam's best row against Embree's best per context.
//!
//! Both sides are timed the same way: the rays are made and converted into each side's own
//! layout (kdbeam's [`RayPacket`]s of pixel tiles or of consecutive rays, Embree's SoA packets)
//! before any timer starts, each configuration runs once untimed, and the median of the same
//! number of timed repetitions is reported. Only tracing is timed, writing every hit out.

use std::time::Instant;

use kdbeam::trace::{Culling, Intersector};
use kdbeam::{BuildParams, Camera, Hit, HitPacket, Isa, Ray, RayPacket, Tracer};
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
    /// Packet sizes to measure, comma separated; 1 is single rays, one ray against a vector of
    /// a leaf's triangles per test (on the scalar ISA: the scalar reference) (default: 1, 4,
    /// 8, 16, 64).
    #[arg(long, value_delimiter = ',')]
    packet: Vec<usize>,
    /// Culling settings to measure, comma separated: none, 4plane, 6plane or auto, `+aperture`
    /// to add the corner-ray test, then options after `/`: masked, maskless, adaptive, packet
    /// (whole-packet traversal), distance-first, aperture-first; e.g.
    /// `none,auto,6plane+aperture/masked/distance-first`.
    #[arg(long, value_delimiter = ',', default_value = "none,auto")]
    culling: Vec<Culling>,
    /// SAH cost ratios of the kd-trees to measure, comma separated: one tree per value.
    #[arg(long, value_delimiter = ',', default_values_t = [BuildParams::default().ci_over_ct])]
    ci_over_ct: Vec<f32>,
    /// Worker thread counts to measure, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    threads: Vec<usize>,
    /// Timed repetitions per configuration (the median is reported), after one untimed run.
    #[arg(long, default_value_t = 5)]
    reps: usize,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
    /// Also measure Embree's rtcIntersect1/4/8/16 on the same rays (rows with isa "embree";
    /// primary rays in kdbeam's 2x2, 4x2, 4x4 and 8x8 tiles; tests/ray is not counted), in
    /// each context of --embree-context. Embree runs in robust mode (intersector
    /// "embree_robust") when --intersector is watertight, otherwise with its default scene
    /// flags (intersector "embree"). Needs a build with `--features embree`.
    #[arg(long)]
    embree: bool,
    /// Embree's intersect contexts, comma separated: coherent (the frustum traversal of camera
    /// packets) and incoherent (lane by lane, for random and secondary rays).
    #[cfg(feature = "embree")]
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "coherent,incoherent"
    )]
    embree_context: Vec<kdbeam_cli::embree::Context>,
    /// Ray–triangle test: kensler_shirley or watertight.
    #[arg(long, default_value = "kensler_shirley")]
    intersector: Intersector,
    /// SAH discount for splits with an empty side, in [0, 1).
    #[arg(long, default_value_t = BuildParams::default().empty_bonus)]
    empty_bonus: f32,
    /// Nodes of at most this many triangles choose their split exactly, larger ones by
    /// binning.
    #[arg(long, default_value_t = BuildParams::default().exact_search_max)]
    exact_search_max: u32,
}

#[derive(serde::Serialize)]
pub(crate) struct Row {
    pub(crate) scene: String,
    rays: &'static str,
    pub(crate) isa: String,
    pub(crate) packet: usize,
    intersector: &'static str,
    pub(crate) culling: String,
    /// The kd-tree's SAH cost ratio; none for Embree.
    pub(crate) ci_over_ct: Option<f32>,
    /// Embree's intersect context (`coherent` or `incoherent`); none for kdbeam.
    pub(crate) context: Option<&'static str>,
    pub(crate) threads: usize,
    pub(crate) mrays_per_s: f64,
    /// NaN (JSON `null`) where not counted.
    tests_per_ray: f64,
    /// NaN (JSON `null`) when the run measures no scalar single-ray path (`--packet` without 1,
    /// or `--isa` without scalar).
    speedup_vs_scalar: f64,
}

impl Row {
    fn is_embree(&self) -> bool {
        self.context.is_some()
    }
}

/// kdbeam's fastest row of a scene and thread count against Embree's fastest in one context.
#[derive(serde::Serialize)]
struct Best {
    best_of: &'static str,
    scene: String,
    threads: usize,
    kdbeam_isa: String,
    kdbeam_packet: usize,
    kdbeam_culling: String,
    kdbeam_ci_over_ct: Option<f32>,
    kdbeam_mrays_per_s: f64,
    context: &'static str,
    /// Is `context` the one these rays call for (coherent for primary rays, incoherent for
    /// random ones), the fair comparison?
    context_matches_rays: bool,
    embree_packet: usize,
    embree_mrays_per_s: f64,
    /// kdbeam's Mrays/s over Embree's.
    ratio: f64,
}

pub(crate) fn run(args: BenchArgs) -> Result<()> {
    rows(&args).map(|_| ())
}

/// Measures every configuration of `args`, printing each row as it is measured, and after
/// each scene kdbeam's best row against Embree's best per context.
pub(crate) fn rows(args: &BenchArgs) -> Result<Vec<Row>> {
    let mut all = Vec::new();
    if args.embree && !cfg!(feature = "embree") {
        return Err(Error::invalid(
            "embree",
            "this kdbeam was built without Embree (cargo build --release --features embree)",
        ));
    }
    let pools = args
        .threads
        .iter()
        .map(|&n| Ok((n, thread_pool(Some(n))?)))
        .collect::<Result<Vec<_>>>()?;
    let isas: Vec<Isa> = if args.isa.is_empty() {
        Isa::available().collect()
    } else {
        args.isa.clone()
    };
    for &isa in &isas {
        kdbeam::kernels::Dispatch::new(isa)?;
    }
    let packets = if args.packet.is_empty() {
        vec![1, 4, 8, 16, 64]
    } else {
        args.packet.clone()
    };
    if !args.json {
        println!(
            "{:<16} {:<8} {:<8} {:>6} {:<22} {:>6} {:<10} {:>7} {:>9} {:>9} {:>9}",
            "scene",
            "rays",
            "isa",
            "packet",
            "culling",
            "ci",
            "context",
            "threads",
            "Mrays/s",
            "tests/ray",
            "vs scalar"
        );
    }
    for scene in scene_names(&args.scenes) {
        let (name, mesh) = load_scene(scene)?;
        let mut rows = Vec::new();
        let rays = RaysOf::new(args, &mesh.bounds());
        for &ci_over_ct in &args.ci_over_ct {
            let tree = build_tree(&mesh, &tree_args(args, ci_over_ct))?;
            // The scalar single-ray Mrays/s per thread count, once measured.
            let mut scalar = vec![None; pools.len()];
            for &packet in &packets {
                let layout = rays.kdbeam_layout(packet)?;
                // Single rays are never culled: one row per ISA for them.
                let cullings = if packet == 1 {
                    &args.culling[..1]
                } else {
                    &args.culling[..]
                };
                for ((threads, pool), scalar) in pools.iter().zip(&mut scalar) {
                    for &isa in &isas {
                        for &culling in cullings {
                            let tracer = Tracer::new(&tree)
                                .with_intersector(args.intersector)
                                .with_isa(isa)?
                                .with_culling(culling);
                            let (seconds, tests) =
                                pool.install(|| measure(args.reps, &tracer, &layout));
                            let mrays = layout.len() as f64 / seconds / 1e6;
                            if packet == 1 && isa == Isa::Scalar {
                                *scalar = Some(mrays);
                            }
                            let row = Row {
                                scene: name.clone(),
                                rays: args.rays.name(),
                                isa: isa.to_string(),
                                packet,
                                intersector: args.intersector.name(),
                                culling: if packet == 1 {
                                    "none".into()
                                } else {
                                    culling.name()
                                },
                                ci_over_ct: Some(ci_over_ct),
                                context: None,
                                threads: *threads,
                                mrays_per_s: mrays,
                                tests_per_ray: tests,
                                speedup_vs_scalar: scalar.map_or(f64::NAN, |s| mrays / s),
                            };
                            print_row(&row, args.json);
                            rows.push(row);
                        }
                    }
                }
            }
        }
        #[cfg(feature = "embree")]
        if args.embree {
            embree_rows(args, &name, &mesh, &rays, &pools, &mut rows)?;
        }
        print_best(&rows, args.json);
        all.extend(rows);
    }
    Ok(all)
}

/// The tree options of `args` with the SAH cost ratio `ci_over_ct`.
fn tree_args(args: &BenchArgs, ci_over_ct: f32) -> TreeArgs {
    TreeArgs {
        intersector: args.intersector,
        ci_over_ct,
        empty_bonus: args.empty_bonus,
        exact_search_max: args.exact_search_max,
    }
}

/// The rays of a scene, made once for every configuration.
pub(crate) struct RaysOf {
    set: RaySet,
    camera: Camera,
    /// Row by row for primary rays.
    rays: Vec<Ray>,
}

/// Rays in kdbeam's layout for one packet size.
pub(crate) enum KdbeamRays {
    /// Single rays.
    Single(Vec<Ray>),
    /// Packets: pixel tiles of primary rays, consecutive random rays.
    Packets(Vec<RayPacket>),
}

impl KdbeamRays {
    pub(crate) fn len(&self) -> usize {
        match self {
            KdbeamRays::Single(rays) => rays.len(),
            KdbeamRays::Packets(packets) => packets.iter().map(RayPacket::len).sum(),
        }
    }
}

impl RaysOf {
    pub(crate) fn new(args: &BenchArgs, bounds: &kdbeam::Aabb) -> RaysOf {
        Self::of(args.rays, bounds, args.size)
    }

    /// The rays of `set` for a scene bounded by `bounds` at `size` (the image, or W·H rays).
    pub(crate) fn of(set: RaySet, bounds: &kdbeam::Aabb, size: (u32, u32)) -> RaysOf {
        RaysOf {
            set,
            camera: Camera::standard(bounds, size.0, size.1),
            rays: render::ray_set(set, bounds, size.0, size.1),
        }
    }

    /// The rays as kdbeam traces them with packets of `packet` rays: the standard camera's
    /// pixel tiles for primary rays, consecutive rays for random ones (the same packets as
    /// Embree's), single rays for 1.
    pub(crate) fn kdbeam_layout(&self, packet: usize) -> Result<KdbeamRays> {
        if packet == 1 {
            return Ok(KdbeamRays::Single(self.rays.clone()));
        }
        let shape = packet_shape(packet)?;
        Ok(KdbeamRays::Packets(match self.set {
            RaySet::Primary => self.camera.tile_packets(shape),
            RaySet::Random => self
                .rays
                .chunks(shape.ray_count())
                .map(RayPacket::from_rays)
                .collect(),
        }))
    }

    /// The rays as Embree traces them with rtcIntersect`width`: primary rays reordered into
    /// kdbeam's tiles of `width` rays, random rays as they are.
    #[cfg(feature = "embree")]
    pub(crate) fn embree_layout(&self, width: usize) -> Result<kdbeam_cli::embree::EmbreeRays> {
        use kdbeam_cli::embree::{primary_rays, EmbreeRays};
        Ok(match self.set {
            RaySet::Primary => EmbreeRays::new(&primary_rays(&self.camera, width)?.0, width)?,
            RaySet::Random => EmbreeRays::new(&self.rays, width)?,
        })
    }
}

/// Median seconds of `tracer` on `rays` over `reps` timed runs after one untimed run, and
/// ray–triangle tests per ray.
pub(crate) fn measure(reps: usize, tracer: &Tracer<'_>, rays: &KdbeamRays) -> (f64, f64) {
    let n = rays.len();
    let mut hits = vec![Hit::NONE; n];
    let (seconds, tests) = match rays {
        KdbeamRays::Single(rays) => warm_then_median(reps, || {
            let start = Instant::now();
            let tests = rays
                .par_iter()
                .zip(hits.par_iter_mut())
                .map(|(r, h)| {
                    let (hit, c) = tracer.intersect_counted(r);
                    *h = hit;
                    c.tests
                })
                .sum();
            (start.elapsed().as_secs_f64(), tests)
        }),
        KdbeamRays::Packets(packets) => {
            // Each packet's share of `hits`, cut before timing.
            let mut slots: Vec<&mut [Hit]> = Vec::with_capacity(packets.len());
            let mut rest = &mut hits[..];
            for p in packets {
                let (slot, tail) = rest.split_at_mut(p.len());
                slots.push(slot);
                rest = tail;
            }
            warm_then_median(reps, || {
                let start = Instant::now();
                let tests = packets
                    .par_iter()
                    .zip(slots.par_iter_mut())
                    .map_init(HitPacket::default, |hp, (p, slot)| {
                        let c = tracer.intersect_packet(p, p.full_mask(), hp);
                        for (j, h) in slot.iter_mut().enumerate() {
                            *h = hp.hit(j);
                        }
                        c.tests
                    })
                    .sum();
                (start.elapsed().as_secs_f64(), tests)
            })
        }
    };
    (seconds, tests as f64 / n.max(1) as f64)
}

/// Runs `run` (which returns seconds and a count) once untimed, then `reps` (at least 1) more
/// times: the median seconds of those, and the first run's count.
fn warm_then_median(reps: usize, mut run: impl FnMut() -> (f64, u64)) -> (f64, u64) {
    let (_, count) = run();
    let mut times: Vec<f64> = (0..reps.max(1)).map(|_| run().0).collect();
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], count)
}

/// Embree's rows for one scene: rtcIntersect1/4/8/16 in each context of `--embree-context`,
/// per thread count, on the same rays as kdbeam's rows, each added to `rows` and printed.
#[cfg(feature = "embree")]
fn embree_rows(
    args: &BenchArgs,
    name: &str,
    mesh: &kdbeam::Mesh,
    rays: &RaysOf,
    pools: &[(usize, rayon::ThreadPool)],
    rows: &mut Vec<Row>,
) -> Result<()> {
    use kdbeam_cli::embree::{EmbreeOptions, EmbreeScene, QUERY_WIDTHS};
    // Kensler–Shirley against Embree's default scene, watertight against its robust mode.
    let robust = args.intersector == Intersector::Watertight;
    let options = EmbreeOptions {
        robust,
        ..EmbreeOptions::default()
    };
    let (_, first_pool) = pools.first().expect("at least one thread count");
    let scene = first_pool.install(|| EmbreeScene::with_options(mesh, &options))?;
    for width in QUERY_WIDTHS {
        let layout = rays.embree_layout(width)?;
        for (threads, pool) in pools {
            for &context in &args.embree_context {
                let seconds = pool.install(|| embree_seconds(args.reps, &scene, &layout, context));
                let mrays = layout.len() as f64 / seconds / 1e6;
                let scalar = rows
                    .iter()
                    .find(|r| r.packet == 1 && r.threads == *threads && r.isa == "scalar")
                    .map(|r| r.mrays_per_s);
                let row = Row {
                    scene: name.to_string(),
                    rays: args.rays.name(),
                    isa: "embree".into(),
                    packet: width,
                    intersector: if robust { "embree_robust" } else { "embree" },
                    culling: "none".into(),
                    ci_over_ct: None,
                    context: Some(context.name()),
                    threads: *threads,
                    mrays_per_s: mrays,
                    tests_per_ray: f64::NAN,
                    speedup_vs_scalar: scalar.map_or(f64::NAN, |s| mrays / s),
                };
                print_row(&row, args.json);
                rows.push(row);
            }
        }
    }
    Ok(())
}

/// Median seconds of Embree tracing `rays` in `context` over `reps` timed runs after one
/// untimed run. Each run traces a fresh copy of the untraced rays, copied before its timer
/// starts.
#[cfg(feature = "embree")]
pub(crate) fn embree_seconds(
    reps: usize,
    scene: &kdbeam_cli::embree::EmbreeScene,
    rays: &kdbeam_cli::embree::EmbreeRays,
    context: kdbeam_cli::embree::Context,
) -> f64 {
    let mut work = rays.clone();
    warm_then_median(reps, || {
        work.clone_from(rays);
        let start = Instant::now();
        scene.trace(&mut work, context);
        (start.elapsed().as_secs_f64(), 0)
    })
    .0
}

/// Prints, per thread count of `rows` (one scene's), kdbeam's fastest row against Embree's
/// fastest in each context measured.
fn print_best(rows: &[Row], json: bool) {
    let matching = |rays: &str| {
        if rays == RaySet::Primary.name() {
            "coherent"
        } else {
            "incoherent"
        }
    };
    let mut threads: Vec<usize> = rows.iter().map(|r| r.threads).collect();
    threads.sort_unstable();
    threads.dedup();
    for t in threads {
        let Some(kd) = fastest(rows.iter().filter(|r| r.threads == t && !r.is_embree())) else {
            continue;
        };
        let mut contexts: Vec<&'static str> = Vec::new();
        for context in rows.iter().filter_map(|r| r.context) {
            if !contexts.contains(&context) {
                contexts.push(context);
            }
        }
        for context in contexts {
            let Some(em) = fastest(
                rows.iter()
                    .filter(|r| r.threads == t && r.context == Some(context)),
            ) else {
                continue;
            };
            let best = Best {
                best_of: "kdbeam_vs_embree",
                scene: kd.scene.clone(),
                threads: t,
                kdbeam_isa: kd.isa.clone(),
                kdbeam_packet: kd.packet,
                kdbeam_culling: kd.culling.clone(),
                kdbeam_ci_over_ct: kd.ci_over_ct,
                kdbeam_mrays_per_s: kd.mrays_per_s,
                context,
                context_matches_rays: matching(kd.rays) == context,
                embree_packet: em.packet,
                embree_mrays_per_s: em.mrays_per_s,
                ratio: kd.mrays_per_s / em.mrays_per_s,
            };
            print_json_or(&best, json, || {
                format!(
                    "best       {}, threads {}: kdbeam {} packet {} culling {} ci {} at {:.2} Mrays/s \
                     = {:.2}x Embree's best {} (rtcIntersect{}, {:.2} Mrays/s){}",
                    best.scene,
                    t,
                    best.kdbeam_isa,
                    best.kdbeam_packet,
                    best.kdbeam_culling,
                    best.kdbeam_ci_over_ct.map_or("-".into(), |c| c.to_string()),
                    best.kdbeam_mrays_per_s,
                    best.ratio,
                    context,
                    best.embree_packet,
                    best.embree_mrays_per_s,
                    if best.context_matches_rays {
                        ": the context for these rays"
                    } else {
                        ""
                    },
                )
            });
        }
    }
}

/// The row of most Mrays/s.
fn fastest<'a>(rows: impl Iterator<Item = &'a Row>) -> Option<&'a Row> {
    rows.max_by(|a, b| a.mrays_per_s.total_cmp(&b.mrays_per_s))
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
            "{:<16} {:<8} {:<8} {:>6} {:<22} {:>6} {:<10} {:>7} {:>9.2} {:>9} {:>9}",
            r.scene,
            r.rays,
            r.isa,
            r.packet,
            r.culling,
            r.ci_over_ct.map_or("-".into(), |c| c.to_string()),
            r.context.unwrap_or("-"),
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

/// The median of `reps` (at least 1) calls of `run`, which returns seconds.
pub(crate) fn median_seconds(reps: usize, mut run: impl FnMut() -> Result<f64>) -> Result<f64> {
    let mut times = Vec::with_capacity(reps.max(1));
    for _ in 0..reps.max(1) {
        times.push(run()?);
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

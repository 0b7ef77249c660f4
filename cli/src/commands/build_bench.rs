//! `kdbeam build-bench`: kd-tree build time against Embree's BVH build, and build + one frame.
//!
//! For moving geometry the structure is rebuilt every frame, so the cost that matters is the
//! build plus one frame of primary rays. Each kd-tree row is one `ci_over_ct`; each Embree row
//! one build quality.

use std::time::Instant;

use kdbeam::{BuildParams, KdTree, KdTreeBuilder, Tracer};
use kdbeam_cli::{Error, Result};

use super::bench::{measure, median_seconds, print_json_or, scene_names, RaysOf};
use super::{load_scene, packet_shape, thread_pool};

#[derive(clap::Args)]
pub(crate) struct BuildBenchArgs {
    /// Scenes: paths, shared scene names or builtin:NAME (default builtin:default).
    scenes: Vec<String>,
    /// SAH cost ratios of the kd-trees, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "0.3,1,3,10")]
    ci_over_ct: Vec<f32>,
    /// The build-quality thresholds to compare ([`BuildParams::exact_search_max`]), comma
    /// separated: nodes of at most this many triangles choose their split exactly.
    #[arg(long, value_delimiter = ',', default_value = "64")]
    exact_search_max: Vec<u32>,
    /// Image size of the frame, WIDTHxHEIGHT (the standard camera's primary rays).
    #[arg(long, default_value = "1024x1024", value_parser = super::parse_size)]
    size: (u32, u32),
    /// kdbeam's packet size for the frame (4, 8, 16 or 64), on the widest ISA.
    #[arg(long, default_value_t = 64)]
    packet: usize,
    /// Embree's packet width for the frame (1, 4, 8 or 16); Embree rows need a build with
    /// `--features embree`.
    #[arg(long, default_value_t = 16)]
    embree_width: usize,
    /// Worker threads, for the builds (kd-tree and Embree) and the frame; comma separated, a
    /// row each, measured in turn in the same process.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    threads: Vec<usize>,
    /// Timed repetitions of each build and frame (the median is reported).
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct Row {
    scene: String,
    triangles: usize,
    /// `kdtree` or `embree`.
    structure: &'static str,
    /// `ci=… exact≤…` or `quality=…`.
    setting: String,
    threads: usize,
    build_ms: f64,
    /// Mesh triangles built per second, in millions.
    build_mtris_per_s: f64,
    /// The kd-tree rebuilt into the previous tree with one [`KdTreeBuilder`] (moving
    /// geometry); none for Embree.
    rebuild_ms: Option<f64>,
    /// The kd-tree's SAH cost ([`KdTree::sah_cost`]); none for Embree.
    sah_cost: Option<f64>,
    /// The structure's bytes per mesh triangle: the kd-tree's [`kdbeam::BuildStats::bytes`]
    /// (nodes, leaves, triangle copies), Embree's BVH as its memory monitor counts it (without
    /// the vertex and index buffers).
    bytes_per_triangle: f64,
    /// The process's peak resident memory over the row's builds and frames, in MiB (Linux;
    /// the mesh and the rays included).
    peak_rss_mib: Option<f64>,
    frame_ms: f64,
    build_plus_frame_ms: f64,
}

pub(crate) fn run(args: BuildBenchArgs) -> Result<()> {
    if ![1, 4, 8, 16].contains(&args.embree_width) {
        return Err(Error::invalid(
            "embree-width",
            format!("must be 1, 4, 8 or 16, got {}", args.embree_width),
        ));
    }
    let pools = args
        .threads
        .iter()
        .map(|&threads| Ok((threads, thread_pool(Some(threads))?)))
        .collect::<Result<Vec<_>>>()?;
    let shape = packet_shape(args.packet)?;
    let scenes = scene_names(&args.scenes);
    if !args.json {
        println!(
            "{:<22} {:>10} {:<8} {:<20} {:>8} {:>11} {:>10} {:>11} {:>9} {:>7} {:>9} {:>11} {:>13}",
            "scene",
            "triangles",
            "struct",
            "setting",
            "threads",
            "build ms",
            "M tri/s",
            "rebuild ms",
            "SAH cost",
            "B/tri",
            "peak MiB",
            "frame ms",
            "build+frame"
        );
    }
    for scene in scenes {
        let (name, mesh) = load_scene(scene)?;
        let rays = RaysOf::primary(&mesh.bounds(), args.size);
        let packets = rays.kdbeam_layout(shape.ray_count())?;
        let row = |structure, setting, threads, built: Built| Row {
            scene: name.clone(),
            triangles: mesh.triangle_count(),
            structure,
            setting,
            threads,
            build_ms: 1e3 * built.build,
            build_mtris_per_s: mesh.triangle_count() as f64 / built.build / 1e6,
            rebuild_ms: built.rebuild.map(|s| 1e3 * s),
            sah_cost: built.sah_cost,
            bytes_per_triangle: built.bytes as f64 / mesh.triangle_count().max(1) as f64,
            peak_rss_mib: built.peak_rss.map(|b| b as f64 / (1 << 20) as f64),
            frame_ms: 1e3 * built.frame,
            build_plus_frame_ms: 1e3 * (built.build + built.frame),
        };
        let settings = args.ci_over_ct.iter().flat_map(|&ci_over_ct| {
            args.exact_search_max
                .iter()
                .map(move |&exact_search_max| (ci_over_ct, exact_search_max))
        });
        for (ci_over_ct, exact_search_max) in settings {
            let params = BuildParams::default()
                .with_ci_over_ct(ci_over_ct)
                .with_exact_search_max(exact_search_max);
            params.validate()?;
            for (threads, pool) in &pools {
                reset_peak_rss();
                let built = pool.install(|| -> Result<Built> {
                    let build = median_seconds(args.reps, || {
                        let start = Instant::now();
                        let tree = KdTree::build(&mesh, &params)?;
                        let seconds = start.elapsed().as_secs_f64();
                        // Freeing the tree (its pages back to the system) is not the build's
                        // time, as Embree's scene is freed after its build time is taken.
                        drop(tree);
                        Ok(seconds)
                    })?;
                    let mut builder = KdTreeBuilder::new();
                    let mut tree = builder.build(&mesh, &params)?;
                    let rebuild = median_seconds(args.reps, || {
                        let start = Instant::now();
                        builder.rebuild(&mut tree, &mesh, &params)?;
                        Ok(start.elapsed().as_secs_f64())
                    })?;
                    let tracer = Tracer::new(&tree).with_packet(shape);
                    let frame = measure(args.reps, &tracer, &packets, false).seconds;
                    Ok(Built {
                        build,
                        rebuild: Some(rebuild),
                        sah_cost: Some(tree.sah_cost(ci_over_ct)),
                        bytes: tree.stats().bytes,
                        peak_rss: peak_rss_bytes(),
                        frame,
                    })
                })?;
                let setting = format!("ci={ci_over_ct} exact≤{exact_search_max}");
                print_row(&row("kdtree", setting, *threads, built), args.json);
            }
        }
        #[cfg(feature = "embree")]
        {
            use kdbeam_cli::embree::{BuildQuality, Context, EmbreeOptions, EmbreeScene};
            let embree_rays = rays.embree_layout(args.embree_width)?;
            let qualities = [BuildQuality::Low, BuildQuality::Medium, BuildQuality::High];
            for quality in qualities {
                let options = EmbreeOptions {
                    quality,
                    ..EmbreeOptions::default()
                };
                for (threads, pool) in &pools {
                    reset_peak_rss();
                    let built = pool.install(|| -> Result<Built> {
                        let build = median_seconds(args.reps, || {
                            Ok(EmbreeScene::with_options(&mesh, &options)?.build_seconds())
                        })?;
                        let scene = EmbreeScene::with_options(&mesh, &options)?;
                        // Camera packets: the coherent context, as in `kdbeam bench`.
                        let frame = super::bench::embree_seconds(
                            args.reps,
                            &scene,
                            &embree_rays,
                            Context::Coherent,
                            false,
                        );
                        Ok(Built {
                            build,
                            rebuild: None,
                            sah_cost: None,
                            bytes: scene.bvh_bytes(),
                            peak_rss: peak_rss_bytes(),
                            frame,
                        })
                    })?;
                    let setting = format!("quality={}", quality.name());
                    print_row(&row("embree", setting, *threads, built), args.json);
                }
            }
        }
    }
    Ok(())
}

/// What a row measured: seconds (medians) and bytes.
struct Built {
    build: f64,
    rebuild: Option<f64>,
    sah_cost: Option<f64>,
    bytes: usize,
    peak_rss: Option<u64>,
    frame: f64,
}

/// Resets the process's peak resident memory to its current one (Linux, `clear_refs`), so that
/// [`peak_rss_bytes`] reads the peak since; elsewhere nothing happens.
fn reset_peak_rss() {
    // Without /proc the peak is simply not reported.
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The process's peak resident memory in bytes (`VmHWM`, Linux), if known.
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line
        .trim_start_matches("VmHWM:")
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()?;
    Some(kib * 1024)
}

fn print_row(r: &Row, json: bool) {
    print_json_or(r, json, || {
        format!(
            "{:<22} {:>10} {:<8} {:<20} {:>8} {:>11.1} {:>10.2} {:>11} {:>9} {:>7.1} {:>9} {:>11.1} {:>13.1}",
            r.scene,
            r.triangles,
            r.structure,
            r.setting,
            r.threads,
            r.build_ms,
            r.build_mtris_per_s,
            r.rebuild_ms.map_or("-".into(), |ms| format!("{ms:.1}")),
            r.sah_cost.map_or("-".into(), |c| format!("{c:.2}")),
            r.bytes_per_triangle,
            r.peak_rss_mib.map_or("-".into(), |m| format!("{m:.0}")),
            r.frame_ms,
            r.build_plus_frame_ms
        )
    })
}

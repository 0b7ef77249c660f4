//! `kdbeam render`: one frame to a PNG — primary rays, then shadow rays to the point light and,
//! with `--shade ao`, ambient-occlusion rays, as a renderer traces them — with build and trace
//! statistics for each kind of ray.

use std::path::PathBuf;
use std::time::Duration;

use kdbeam::rays::secondary::{light, SecondaryRays, Workload, DEFAULT_AO_RAYS};
use kdbeam::trace::{Culling, PacketCounters};
use kdbeam::{BuildParams, Isa, KdTree, Mesh, Tracer};
use kdbeam_cli::render::{self, Frame, Light, SEED};
use kdbeam_cli::Result;

use super::{
    build_tree, delayed_bar, load_scene, packet_shape, parse_size, thread_pool, with_spinner,
    CameraArgs, TreeArgs,
};

/// How the picture is lit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Shade {
    /// A fixed key light and a sky fill: primary rays only.
    Flat,
    /// The point light of the shadow workload, with shadow rays (any hit).
    Shadow,
    /// Shadows, and ambient occlusion of the sky fill (`--ao-rays` rays per hit, any hit).
    Ao,
}

#[derive(clap::Args)]
pub(crate) struct RenderArgs {
    /// A path to an .obj or .obj.gz, a shared scene (bunny, sponza, dragon, killeroo) or
    /// builtin:NAME (default builtin:default).
    scene: Option<String>,
    /// Where to write the picture.
    #[arg(long, default_value = "kdbeam.png")]
    out: PathBuf,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = parse_size)]
    size: (u32, u32),
    #[command(flatten)]
    camera: CameraArgs,
    /// Lighting: flat (primary rays only), shadow (shadow rays to a point light) or ao
    /// (shadows and ambient occlusion).
    #[arg(long, value_enum, default_value = "shadow")]
    shade: Shade,
    /// Ambient-occlusion rays per primary hit (`--shade ao`).
    #[arg(long, default_value_t = DEFAULT_AO_RAYS, value_parser = clap::value_parser!(u32).range(1..=64))]
    ao_rays: u32,
    /// SAH cost ratio of the tree the ambient-occlusion rays are traced on (default: the
    /// library's tree for incoherent rays on the tracer's ISA, 0.3 below 16 lanes; on
    /// AVX-512 the primary rays' tree). Equal to `--ci-over-ct`, one tree serves both.
    #[arg(long)]
    ao_ci_over_ct: Option<f32>,
    /// Also draw heat maps of ray–triangle tests per pixel next to the picture: without
    /// culling, then with the chosen culling, on one log scale.
    #[arg(long)]
    heatmap: bool,
    /// Instruction set: scalar, portable, sse, avx2, avx512 (default: the widest this CPU runs, or
    /// KDBEAM_ISA).
    #[arg(long)]
    isa: Option<Isa>,
    /// Packet size in rays: 4, 8, 16 or 64.
    #[arg(long, default_value_t = 64)]
    packet: usize,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Culling in the leaves: none, 4plane, 6plane or auto, `+aperture` to add the corner-ray
    /// test, then options after `/`: masked, maskless, adaptive, packet (whole-packet
    /// traversal), distance-first, aperture-first; e.g. `6plane+aperture/masked/distance-first`.
    #[arg(long, default_value = "auto")]
    culling: Culling,
    #[command(flatten)]
    tree: TreeArgs,
}

fn tracer<'t>(tree: &'t KdTree, args: &RenderArgs) -> Result<Tracer<'t>> {
    let t = Tracer::new(tree)
        .with_intersector(args.tree.intersector)
        .with_packet(packet_shape(args.packet)?)
        .with_culling(args.culling);
    match args.isa {
        Some(isa) => Ok(t.with_isa(isa)?),
        None => Ok(t),
    }
}

pub(crate) fn run(args: RenderArgs) -> Result<()> {
    kdbeam::kernels::Dispatch::from_env()?;
    let pool = thread_pool(args.threads)?;
    pool.install(|| {
        let (name, mesh) = with_spinner("loading scene", || load_scene(args.scene.as_deref()))?;
        let tree_args = args.tree.for_mesh(&mesh);
        let tree = build_tree(&mesh, &tree_args)?;
        let stats = tree.stats();
        println!("scene      {name}: {} triangles", mesh.triangle_count());
        let sah_cost = tree.sah_cost(tree_args.ci_over_ct(&mesh));
        println!("kd-tree    {stats}, SAH cost {sah_cost:.2}");
        let tracer = tracer(&tree, &args)?;
        let camera = args.camera.camera(&mesh.bounds(), args.size.0, args.size.1)?;
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
            let rays = frame.rays().max(1) as f64;
            let per_ray = |x: u64| x as f64 / rays;
            let s = &c.cycles;
            println!(
                "cycles     TSC reference cycles per ray: {:.1} in all; ray generation {:.1}, \
                 packet setup and inner nodes {:.1}, beams {:.1}, culling {:.1}, tests and hit \
                 updates {:.1}, the rest (hit copies, loop) {:.1}",
                per_ray(frame.frame_cycles),
                per_ray(frame.generation_cycles),
                per_ray(s.traversal.saturating_sub(s.leaves)),
                per_ray(s.beams),
                per_ray(s.culling),
                per_ray(s.leaves.saturating_sub(s.beams + s.culling)),
                per_ray(
                    frame
                        .frame_cycles
                        .saturating_sub(frame.generation_cycles + s.traversal)
                ),
            );
        }
        let ao_tree = ao_tree(&args, &tree_args, &mesh, tracer.isa())?;
        let ao_tracer = match &ao_tree {
            Some((tree, ci_over_ct)) => {
                let ci_over_ct = *ci_over_ct;
                let sah_cost = tree.sah_cost(ci_over_ct);
                println!(
                    "kd-tree    for ao rays (ci_over_ct {ci_over_ct}): {}, SAH cost {sah_cost:.2}",
                    tree.stats()
                );
                self::tracer(tree, &args)?
            }
            None => tracer,
        };
        let mut image = shade(&args, &tracer, &ao_tracer, &mesh, &frame)?;
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

/// The tree of the ambient-occlusion rays and its SAH cost ratio, where `args` asks for them
/// and for a tree other than the primary rays' of `primary` (see
/// [`BuildParams::for_incoherent_rays`]).
fn ao_tree(
    args: &RenderArgs,
    primary: &TreeArgs,
    mesh: &Mesh,
    isa: Isa,
) -> Result<Option<(KdTree, f32)>> {
    if args.shade != Shade::Ao {
        return Ok(None);
    }
    let ci_over_ct = args
        .ao_ci_over_ct
        .unwrap_or(BuildParams::for_incoherent_rays(isa).ci_over_ct);
    if ci_over_ct == primary.ci_over_ct(mesh) {
        return Ok(None);
    }
    let tree_args = TreeArgs {
        ci_over_ct: Some(ci_over_ct),
        ..primary.clone()
    };
    Ok(Some((build_tree(mesh, &tree_args)?, ci_over_ct)))
}

/// The picture of `frame` as `args.shade` asks: secondary rays traced from its primary hits
/// (their throughput printed), shadow rays by `tracer`, ambient-occlusion rays by
/// `ao_tracer`, then shaded.
fn shade(
    args: &RenderArgs,
    tracer: &Tracer<'_>,
    ao_tracer: &Tracer<'_>,
    mesh: &Mesh,
    frame: &Frame,
) -> Result<render::Image> {
    if args.shade == Shade::Flat {
        return Ok(frame.shade(mesh));
    }
    let camera = &frame.camera;
    let pixels = frame.hits.len();
    let mut visible = vec![1.0f32; pixels];
    let mut ambient = vec![1.0f32; pixels];
    let mut workloads = vec![(Workload::Shadow, tracer, &mut visible)];
    if args.shade == Shade::Ao {
        let ao = Workload::AmbientOcclusion { rays: args.ao_rays };
        workloads.push((ao, ao_tracer, &mut ambient));
    }
    for (workload, tracer, share) in workloads {
        let rays = SecondaryRays::new(workload, mesh, camera, &frame.hits, SEED)?;
        let (occluded, seconds, counters) = render::trace_occlusion(tracer, &rays, camera);
        let per_hit = 1.0 / workload.rays_per_hit() as f32;
        for s in share.iter_mut() {
            *s = 0.0;
        }
        let mut has_rays = vec![false; pixels];
        for (&pixel, &o) in rays.pixels.iter().zip(&occluded) {
            has_rays[pixel as usize] = true;
            if !o {
                share[pixel as usize] += per_hit;
            }
        }
        // Pixels without rays (misses) stay lit.
        for (s, l) in share.iter_mut().zip(&has_rays) {
            if !l {
                *s = 1.0;
            }
        }
        print_secondary(workload, &rays, &occluded, seconds, &counters);
    }
    let position = light(&mesh.bounds());
    Ok(frame.shade_lit(mesh, |pixel| {
        Some(Light {
            position,
            visible: visible[pixel],
            ambient: ambient[pixel],
        })
    }))
}

fn print_secondary(
    workload: Workload,
    rays: &SecondaryRays,
    occluded: &[bool],
    seconds: f64,
    c: &PacketCounters,
) {
    let n = rays.len().max(1) as f64;
    println!(
        "{:<10} {} rays ({} per hit) in pixel-tile packets, any hit: {:.2} Mrays/s, {:.2} tests/ray, {:.1}% occluded",
        workload.name(),
        rays.len(),
        workload.rays_per_hit(),
        rays.len() as f64 / seconds.max(1e-12) / 1e6,
        c.tests as f64 / n,
        100.0 * occluded.iter().filter(|&&o| o).count() as f64 / n,
    );
}

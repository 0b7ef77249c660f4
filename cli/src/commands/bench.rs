//! `kdbeam bench`: Mrays/s per scene, ray set, tree size, thread count, ISA and packet size,
//! optionally next to Embree's, with kdbeam's best row against Embree's best per context.
//!
//! Both sides are timed the same way: the rays are made and converted into each side's own
//! layout (kdbeam's [`RayPacket`]s of pixel tiles or of consecutive rays, Embree's SoA packets
//! and stream arrays) before any timer starts, each configuration runs once untimed, and the
//! median of the same number of timed repetitions is reported. Only tracing is timed, writing
//! every hit (or occlusion flag, for shadow and AO rays) out — and, for kdbeam's sorted
//! streams, the sort and the gathering into packets, which a renderer pays for.

use std::time::Instant;

use kdbeam::rays::secondary::{TilePackets, DEFAULT_AO_RAYS};
use kdbeam::rays::stream::{intersect_sorted, occluded_sorted};
use kdbeam::trace::{Culling, Intersector, PacketCounters, RayBoxes};
use kdbeam::{Aabb, BuildParams, Hit, HitPacket, Isa, Mesh, Ray, RayPacket, Tracer};
use kdbeam_cli::render::{RaySet, Rays};
use kdbeam_cli::{Error, Result};
use rayon::prelude::*;

use super::{build_tree, load_scene, packet_shape, thread_pool, CameraArgs, TreeArgs};

/// How kdbeam's packets are made of the rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub(crate) enum Layout {
    /// Pixel tiles (primary and secondary rays) or consecutive rays (random rays).
    Tiles,
    /// The whole set sorted by octant and origin Morton code, then cut into packets (not for
    /// primary rays); the sort is timed.
    Stream,
}

#[derive(clap::Args)]
pub(crate) struct BenchArgs {
    /// Scenes: paths, shared scene names or builtin:NAME (default builtin:default).
    scenes: Vec<String>,
    /// Ray set: primary, random, or the secondary rays of the camera's primary hits (shadow,
    /// ao, diffuse).
    #[arg(long, value_enum, default_value = "primary")]
    rays: RaySet,
    /// Ambient-occlusion rays per primary hit (`--rays ao`).
    #[arg(long, default_value_t = DEFAULT_AO_RAYS, value_parser = clap::value_parser!(u32).range(1..=64))]
    ao_rays: u32,
    /// Image size (primary and secondary rays) or ray count = W·H (random), WIDTHxHEIGHT.
    #[arg(long, default_value = "1024x1024", value_parser = super::parse_size)]
    size: (u32, u32),
    #[command(flatten)]
    camera: CameraArgs,
    /// kdbeam's packet layouts, comma separated: tiles, stream (packet sizes above 1; primary
    /// rays only in tiles).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "tiles,stream"
    )]
    layout: Vec<Layout>,
    /// ISAs to measure, comma separated (default: every one this CPU runs).
    #[arg(long, value_delimiter = ',')]
    isa: Vec<Isa>,
    /// Packet sizes to measure, comma separated; 1 is single rays, one ray against a vector of
    /// a leaf's triangles per test (on the scalar ISA: the scalar reference) (default: 1, 4,
    /// 8, 16, 64).
    #[arg(long, value_delimiter = ',')]
    packet: Vec<usize>,
    /// Culling settings to measure, comma separated: none, 4plane, 6plane or auto, `+aperture`
    /// to add the corner-ray test, `+raybox` for ray-box culling and `+subspace`,
    /// `+subspace6`, `+subspace-exact` or `+subspace6-exact` for subspace culling of single
    /// rays (alone: none with them, e.g. `raybox+subspace`), then
    /// options after `/`: masked, maskless, adaptive, packet (whole-packet traversal),
    /// distance-first, aperture-first; e.g. `none,auto,6plane+aperture/masked/distance-first`.
    /// Single-ray rows (`--packet 1`) run only the single-ray stages.
    #[arg(long, value_delimiter = ',', default_value = "none,auto")]
    culling: Vec<Culling>,
    /// SAH cost ratios of the kd-trees to measure, comma separated: one tree per value
    /// (default: the tree each measured ISA traces these rays on: for primary and shadow rays
    /// the scene's own, `BuildParams::for_mesh`, 0.05 for even triangles; for random, AO and
    /// diffuse rays 0.3 below 16 lanes, 0.05 on AVX-512).
    #[arg(long, value_delimiter = ',')]
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
    /// Also measure Embree on the same rays (rows with isa "embree"; tests/ray is not
    /// counted), in each context of --embree-context: rtcIntersect1/4/8/16 and the stream call
    /// rtcIntersect1M, or rtcOccluded1/4/8/16/1M for shadow and AO rays. Packets of primary
    /// and secondary rays are kdbeam's pixel tiles of the same size (2x2, 4x2, 4x4; single
    /// rays in 8x8 tile order); streams are the rays in pixel order. Embree runs in robust mode (intersector
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
    /// `single`, `tiles`, `consecutive` (random rays in packets), `stream` (kdbeam: sorted;
    /// Embree: rtcIntersect1M/rtcOccluded1M) or `packets` (Embree's 4/8/16-wide calls).
    pub(crate) layout: &'static str,
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
    /// Share of the ray–triangle tests a single-ray culling stage removed, in percent; NaN
    /// (JSON `null`) for packets and Embree.
    culled_percent: f64,
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
    kdbeam_layout: &'static str,
    kdbeam_culling: String,
    kdbeam_ci_over_ct: Option<f32>,
    kdbeam_mrays_per_s: f64,
    context: &'static str,
    /// Is `context` the one these rays are usually given (coherent for primary rays,
    /// incoherent for the others)?
    context_matches_rays: bool,
    /// Is `context` the one Embree ran fastest in, of those measured: the fair comparison?
    fastest_context: bool,
    /// The Embree call of the best row, e.g. `rtcOccluded16` or `rtcIntersect1M`.
    embree_call: String,
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
            "{:<16} {:<8} {:<8} {:>6} {:<11} {:<22} {:>6} {:<10} {:>7} {:>9} {:>9} {:>7} {:>9}",
            "scene",
            "rays",
            "isa",
            "packet",
            "layout",
            "culling",
            "ci",
            "context",
            "threads",
            "Mrays/s",
            "tests/ray",
            "culled",
            "vs scalar"
        );
    }
    for scene in scene_names(&args.scenes) {
        let (name, mesh) = load_scene(scene)?;
        let mut rows = Vec::new();
        // Made from the first tree's primary hits: every tree and tracer gives the same hits.
        let mut rays: Option<RaysOf> = None;
        for ci_over_ct in tree_sizes(args, &isas, &mesh) {
            let tree = build_tree(&mesh, &tree_args(args, ci_over_ct))?;
            if rays.is_none() {
                rays = Some(RaysOf::new(args, &mesh, &Tracer::new(&tree))?);
            }
            let rays = rays.as_ref().expect("made above");
            // The scalar single-ray Mrays/s per thread count, once measured.
            let mut scalar = vec![None; pools.len()];
            for &packet in &packets {
                for layout in rays.kdbeam_layouts(packet, &args.layout)? {
                    for ((threads, pool), scalar) in pools.iter().zip(&mut scalar) {
                        for &isa in &isas {
                            let single;
                            let cullings = if packet == 1 {
                                single = single_ray_settings(&args.culling, isa);
                                &single
                            } else {
                                &args.culling
                            };
                            for &culling in cullings {
                                let mut tracer = Tracer::new(&tree)
                                    .with_intersector(args.intersector)
                                    .with_isa(isa)?
                                    .with_culling(culling);
                                if packet > 1 {
                                    tracer = tracer.with_packet(packet_shape(packet)?);
                                }
                                // Masks, tables and boxes are built on first use: not in
                                // the timing.
                                if let Some(stage) = culling.subspace {
                                    stage.prepare(&tree);
                                }
                                if culling.raybox != RayBoxes::Off {
                                    let _ = tree.triangle_boxes();
                                }
                                let m = pool.install(|| {
                                    measure(args.reps, &tracer, &layout, args.rays.any_hit())
                                });
                                let mrays = layout.len() as f64 / m.seconds / 1e6;
                                // The first single-ray setting given is the baseline.
                                if packet == 1 && isa == Isa::Scalar && scalar.is_none() {
                                    *scalar = Some(mrays);
                                }
                                let row = Row {
                                    scene: name.clone(),
                                    rays: args.rays.name(),
                                    isa: isa.to_string(),
                                    packet,
                                    layout: layout.name(args.rays),
                                    intersector: args.intersector.name(),
                                    culling: culling.name(),
                                    ci_over_ct: Some(ci_over_ct),
                                    context: None,
                                    threads: *threads,
                                    mrays_per_s: mrays,
                                    tests_per_ray: m.tests_per_ray,
                                    culled_percent: m.culled_percent,
                                    speedup_vs_scalar: scalar.map_or(f64::NAN, |s| mrays / s),
                                };
                                print_row(&row, args.json);
                                rows.push(row);
                            }
                        }
                    }
                }
            }
        }
        #[cfg(feature = "embree")]
        if let (true, Some(rays)) = (args.embree, &rays) {
            embree_rows(args, &name, &mesh, rays, &pools, &mut rows)?;
        }
        print_best(&rows, args.json);
        all.extend(rows);
    }
    Ok(all)
}

/// The SAH cost ratios of `mesh`'s trees to measure: `--ci-over-ct`, or else the tree each
/// ISA of `isas` traces the rays of `args` on by default, each once.
fn tree_sizes(args: &BenchArgs, isas: &[Isa], mesh: &Mesh) -> Vec<f32> {
    if !args.ci_over_ct.is_empty() {
        return args.ci_over_ct.clone();
    }
    let mut sizes: Vec<f32> = isas
        .iter()
        .map(|&isa| args.rays.build_params(isa, mesh).ci_over_ct)
        .collect();
    sizes.sort_by(f32::total_cmp);
    sizes.dedup();
    sizes
}

/// The tree options of `args` with the SAH cost ratio `ci_over_ct`.
fn tree_args(args: &BenchArgs, ci_over_ct: f32) -> TreeArgs {
    TreeArgs {
        intersector: args.intersector,
        ci_over_ct: Some(ci_over_ct),
        empty_bonus: args.empty_bonus,
        exact_search_max: args.exact_search_max,
    }
}

/// The rays of a scene, made once for every configuration.
pub(crate) struct RaysOf {
    rays: Rays,
    /// The scene box, over which streams are sorted.
    bounds: Aabb,
}

/// Rays in kdbeam's layout for one packet size.
pub(crate) enum KdbeamRays {
    /// Single rays.
    Single(Vec<Ray>),
    /// The camera's pixel tiles of primary rays, made as packets.
    Packets(Vec<RayPacket>),
    /// Packets of rays made one by one (pixel tiles of secondary rays, consecutive random
    /// rays), formed as they are traced.
    Formed(PacketRays),
    /// The rays, to be sorted over the box and cut into the tracer's packets.
    Stream(Vec<Ray>, Aabb),
}

impl KdbeamRays {
    pub(crate) fn len(&self) -> usize {
        match self {
            KdbeamRays::Single(rays) | KdbeamRays::Stream(rays, _) => rays.len(),
            KdbeamRays::Packets(packets) => packets.iter().map(RayPacket::len).sum(),
            KdbeamRays::Formed(packets) => packets.rays.len(),
        }
    }

    /// The row's layout name for rays of `set`.
    fn name(&self, set: RaySet) -> &'static str {
        match self {
            KdbeamRays::Single(_) => "single",
            KdbeamRays::Formed(_) if set == RaySet::Random => "consecutive",
            KdbeamRays::Packets(_) | KdbeamRays::Formed(_) => "tiles",
            KdbeamRays::Stream(..) => "stream",
        }
    }
}

impl RaysOf {
    /// The rays `args` asks for in `mesh`, secondary rays from the primary hits `tracer` finds.
    pub(crate) fn new(
        args: &BenchArgs,
        mesh: &kdbeam::Mesh,
        tracer: &Tracer<'_>,
    ) -> Result<RaysOf> {
        let bounds = mesh.bounds();
        let camera = args.camera.camera(&bounds, args.size.0, args.size.1)?;
        Ok(RaysOf {
            rays: Rays::new(args.rays, mesh, tracer, &camera, args.ao_rays)?,
            bounds,
        })
    }

    /// The standard camera's primary rays of a scene bounded by `bounds` at `size`.
    pub(crate) fn primary(bounds: &Aabb, size: (u32, u32)) -> RaysOf {
        RaysOf {
            rays: Rays::primary(&kdbeam::Camera::standard(bounds, size.0, size.1)),
            bounds: *bounds,
        }
    }

    /// The rays as kdbeam traces them with packets of `packet` rays: the camera's pixel tiles
    /// for primary rays, per pixel tile and sample for secondary rays, consecutive rays for
    /// random ones (the same packets as Embree's), single rays for 1.
    pub(crate) fn kdbeam_layout(&self, packet: usize) -> Result<KdbeamRays> {
        let r = &self.rays;
        if packet == 1 {
            return Ok(KdbeamRays::Single(r.rays.clone()));
        }
        let shape = packet_shape(packet)?;
        Ok(match (&r.secondary, r.set) {
            (Some(secondary), _) => KdbeamRays::Formed(PacketRays::from_tiles(
                &secondary.tile_packets(&r.camera, shape),
                &r.rays,
            )),
            (None, RaySet::Primary) => KdbeamRays::Packets(r.camera.tile_packets(shape)),
            (None, _) => KdbeamRays::Formed(PacketRays {
                rays: r.rays.clone(),
                ends: (1..=r.rays.len().div_ceil(shape.ray_count()))
                    .map(|k| (k * shape.ray_count()).min(r.rays.len()))
                    .collect(),
            }),
        })
    }

    /// The layouts of `layouts` for `packet`: single rays for 1, otherwise tiles and (but for
    /// primary rays) sorted streams, as asked.
    fn kdbeam_layouts(&self, packet: usize, layouts: &[Layout]) -> Result<Vec<KdbeamRays>> {
        if packet == 1 {
            return Ok(vec![self.kdbeam_layout(1)?]);
        }
        packet_shape(packet)?;
        let mut out = Vec::new();
        for layout in layouts {
            match layout {
                Layout::Tiles => out.push(self.kdbeam_layout(packet)?),
                Layout::Stream if self.rays.set != RaySet::Primary => {
                    out.push(KdbeamRays::Stream(self.rays.rays.clone(), self.bounds));
                }
                Layout::Stream => {}
            }
        }
        Ok(out)
    }

    /// The rays as Embree traces them with rtcIntersect`width` (rtcOccluded`width`): kdbeam's
    /// packets of `width` rays for 4, 8 and 16, single rays in 8×8 tile order for primary and
    /// secondary rays, random rays as they are.
    #[cfg(feature = "embree")]
    pub(crate) fn embree_layout(&self, width: usize) -> Result<kdbeam_cli::embree::EmbreeRays> {
        use kdbeam::PacketShape;
        use kdbeam_cli::embree::{primary_rays, EmbreeRays};
        let r = &self.rays;
        Ok(match (&r.secondary, r.set) {
            (Some(secondary), _) => {
                let shape = PacketShape::from_len(width).unwrap_or(PacketShape::P8x8);
                let tiles = secondary.tile_packets(&r.camera, shape);
                if width == 1 {
                    let rays: Vec<Ray> = tiles.rays.iter().map(|&i| r.rays[i as usize]).collect();
                    EmbreeRays::new(&rays, 1)?
                } else {
                    let packets: Vec<Vec<Ray>> = tiles
                        .packets
                        .iter()
                        .map(|p| (0..p.len()).map(|j| p.ray(j)).collect())
                        .collect();
                    let groups: Vec<&[Ray]> = packets.iter().map(Vec::as_slice).collect();
                    EmbreeRays::from_groups(&groups, width)?
                }
            }
            (None, RaySet::Primary) => EmbreeRays::new(&primary_rays(&r.camera, width)?.0, width)?,
            (None, _) => EmbreeRays::new(&r.rays, width)?,
        })
    }

    /// The rays in their own order (pixel by pixel, or as drawn) for Embree's stream calls.
    #[cfg(feature = "embree")]
    fn embree_stream(&self) -> kdbeam_cli::embree::EmbreeRays {
        kdbeam_cli::embree::EmbreeRays::stream(&self.rays.rays)
    }
}

/// The settings of `cullings` that single rays on `isa` run differently: each reduced to its
/// single-ray stages, and one row per distinct behaviour (ray-box culling `auto` runs on the
/// scalar ISA only, so elsewhere it is the same as `off`).
fn single_ray_settings(cullings: &[Culling], isa: Isa) -> Vec<Culling> {
    let runs = |c: &Culling| (c.subspace, c.runs_raybox_on_single_rays(isa));
    let mut single: Vec<Culling> = Vec::new();
    for c in cullings.iter().map(Culling::single_ray_stages) {
        if !single.iter().any(|s| runs(s) == runs(&c)) {
            single.push(c);
        }
    }
    single
}

/// What [`measure`] found: the median seconds, ray–triangle tests per ray, and for single rays
/// the share (percent) of tests their culling removed (NaN for packets and streams).
pub(crate) struct Measured {
    pub seconds: f64,
    pub tests_per_ray: f64,
    pub culled_percent: f64,
}

/// Packets of rays made one by one, as their rays, packet after packet: what a renderer holds
/// of its secondary rays before it forms each packet's [`RayPacket`] (64 lanes, whatever its
/// size) to trace it. Held as `RayPacket`s all at once, a frame of 16-ray packets would take
/// four times the memory of its rays and push the tree out of the cache, which a renderer
/// tracing tile by tile never does.
pub(crate) struct PacketRays {
    rays: Vec<Ray>,
    /// Where each packet's rays end in `rays`.
    ends: Vec<usize>,
}

impl PacketRays {
    /// The packets of `tiles`, whose lanes index `rays`.
    fn from_tiles(tiles: &TilePackets, rays: &[Ray]) -> Self {
        let ends = tiles
            .packets
            .iter()
            .scan(0, |end, p| {
                *end += p.len();
                Some(*end)
            })
            .collect();
        PacketRays {
            rays: tiles.rays.iter().map(|&i| rays[i as usize]).collect(),
            ends,
        }
    }

    /// The rays of packet `k`.
    fn packet(&self, k: usize) -> &[Ray] {
        let start = if k == 0 { 0 } else { self.ends[k - 1] };
        &self.rays[start..self.ends[k]]
    }

    /// Traces each packet, formed in a thread's reused [`RayPacket`] (its hits in a thread's
    /// reused [`HitPacket`], its work added to a thread's [`PacketCounters`]):
    /// `trace(packet, hits, counters, out)` for packet `k` and `outs[k]`; the tests performed.
    fn trace_each<T: Send>(
        &self,
        outs: &mut [T],
        trace: impl Fn(&RayPacket, &mut HitPacket, &mut PacketCounters, &mut T) + Sync,
    ) -> u64 {
        outs.par_iter_mut()
            .enumerate()
            .map_init(
                || {
                    (
                        Box::new(RayPacket::from_rays(&[])),
                        Box::<HitPacket>::default(),
                        Box::<PacketCounters>::default(),
                    )
                },
                |(packet, hits, counters), (k, out)| {
                    let rays = self.packet(k);
                    packet.set_len(rays.len());
                    for (i, r) in rays.iter().enumerate() {
                        packet.set(i, r);
                    }
                    let before = counters.tests;
                    trace(packet, hits, counters, out);
                    counters.tests - before
                },
            )
            .sum()
    }

    /// `hits` cut into each packet's part.
    fn split<'h>(&self, mut hits: &'h mut [Hit]) -> Vec<&'h mut [Hit]> {
        let mut start = 0;
        self.ends
            .iter()
            .map(|&end| {
                let (part, rest) = std::mem::take(&mut hits).split_at_mut(end - start);
                (hits, start) = (rest, end);
                part
            })
            .collect()
    }
}

/// Median seconds of `tracer` on `rays` over `reps` timed runs after one untimed run, and the
/// untimed run's counts: closest hits, or occlusion when `any` (shadow and AO rays).
pub(crate) fn measure(reps: usize, tracer: &Tracer<'_>, rays: &KdbeamRays, any: bool) -> Measured {
    let n = rays.len();
    let mut hits = vec![Hit::NONE; n];
    let mut occluded = vec![false; n];
    let sum = |a: (u64, u64), b: (u64, u64)| (a.0 + b.0, a.1 + b.1);
    let (seconds, (tests, culled)) = match rays {
        KdbeamRays::Single(rays) if any => warm_then_median(reps, || {
            let start = Instant::now();
            let counts = rays
                .par_iter()
                .zip(occluded.par_iter_mut())
                .map(|(r, o)| {
                    let (hit, c) = tracer.occluded_counted(r);
                    *o = hit;
                    (c.tests, c.culled)
                })
                .reduce(|| (0, 0), sum);
            (start.elapsed().as_secs_f64(), counts)
        }),
        KdbeamRays::Single(rays) => warm_then_median(reps, || {
            let start = Instant::now();
            let counts = rays
                .par_iter()
                .zip(hits.par_iter_mut())
                .map(|(r, h)| {
                    let (hit, c) = tracer.intersect_counted(r);
                    *h = hit;
                    (c.tests, c.culled)
                })
                .reduce(|| (0, 0), sum);
            (start.elapsed().as_secs_f64(), counts)
        }),
        KdbeamRays::Stream(rays, bounds) => warm_then_median(reps, || {
            let start = Instant::now();
            let counters = if any {
                occluded_sorted(tracer, rays, bounds, &mut occluded)
            } else {
                intersect_sorted(tracer, rays, bounds, &mut hits)
            }
            .expect("one output per ray");
            (start.elapsed().as_secs_f64(), (counters.tests, 0))
        }),
        // Each camera packet's answer stays in its own output, as Embree's packet calls leave
        // theirs in their ray structures: neither side's timing converts them.
        // A thread's counters are reused from packet to packet, as a renderer's would be.
        KdbeamRays::Packets(packets) if any => {
            let mut outs = vec![0u64; packets.len()];
            warm_then_median(reps, || {
                let start = Instant::now();
                let tests = packets
                    .par_iter()
                    .zip(outs.par_iter_mut())
                    .map_init(Box::<PacketCounters>::default, |c, (p, bits)| {
                        let before = c.tests;
                        *bits = tracer.occluded_packet_counted(p, p.full_mask(), c);
                        c.tests - before
                    })
                    .sum();
                (start.elapsed().as_secs_f64(), (tests, 0))
            })
        }
        KdbeamRays::Packets(packets) => {
            let mut outs = vec![HitPacket::default(); packets.len()];
            warm_then_median(reps, || {
                let start = Instant::now();
                let tests = packets
                    .par_iter()
                    .zip(outs.par_iter_mut())
                    .map_init(Box::<PacketCounters>::default, |c, (p, out)| {
                        let before = c.tests;
                        tracer.intersect_packet_counted(p, p.full_mask(), out, c);
                        c.tests - before
                    })
                    .sum();
                (start.elapsed().as_secs_f64(), (tests, 0))
            })
        }
        // kdbeam forms each packet from its rays and writes its closest hits back to them inside
        // its timing, as a renderer tracing tile by tile does; Embree's packet structures, as
        // small as their rays, are built before its timing and keep their answers.
        KdbeamRays::Formed(packets) if any => {
            let mut outs = vec![0u64; packets.ends.len()];
            warm_then_median(reps, || {
                let start = Instant::now();
                let tests = packets.trace_each(&mut outs, |p, _, c, bits| {
                    *bits = tracer.occluded_packet_counted(p, p.full_mask(), c);
                });
                (start.elapsed().as_secs_f64(), (tests, 0))
            })
        }
        KdbeamRays::Formed(packets) => {
            let mut outs = packets.split(&mut hits);
            warm_then_median(reps, || {
                let start = Instant::now();
                let tests = packets.trace_each(&mut outs, |p, scratch, c, out| {
                    tracer.intersect_packet_counted(p, p.full_mask(), scratch, c);
                    for (i, h) in out.iter_mut().enumerate() {
                        *h = scratch.hit(i);
                    }
                });
                (start.elapsed().as_secs_f64(), (tests, 0))
            })
        }
    };
    let culled_percent = match rays {
        KdbeamRays::Single(_) => 100.0 * culled as f64 / (tests + culled).max(1) as f64,
        _ => f64::NAN,
    };
    Measured {
        seconds,
        tests_per_ray: tests as f64 / n.max(1) as f64,
        culled_percent,
    }
}

/// Runs `run` (which returns seconds and a count) once untimed, then `reps` (at least 1) more
/// times: the median seconds of those, and the first run's count.
fn warm_then_median<T>(reps: usize, mut run: impl FnMut() -> (f64, T)) -> (f64, T) {
    let (_, count) = run();
    let mut times: Vec<f64> = (0..reps.max(1)).map(|_| run().0).collect();
    times.sort_by(f64::total_cmp);
    (times[times.len() / 2], count)
}

/// Embree's rows for one scene: rtcIntersect1/4/8/16 and rtcIntersect1M (rtcOccluded for
/// shadow and AO rays) in each context of `--embree-context`, per thread count, on the same
/// rays as kdbeam's rows, each added to `rows` and printed.
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
    let mut layouts = Vec::new();
    for width in QUERY_WIDTHS {
        let layout = if width == 1 { "single" } else { "packets" };
        layouts.push((width, layout, rays.embree_layout(width)?));
    }
    layouts.push((1, "stream", rays.embree_stream()));
    for (width, layout, embree_rays) in &layouts {
        for (threads, pool) in pools {
            for &context in &args.embree_context {
                let seconds = pool.install(|| {
                    embree_seconds(args.reps, &scene, embree_rays, context, args.rays.any_hit())
                });
                let mrays = embree_rays.len() as f64 / seconds / 1e6;
                let scalar = rows
                    .iter()
                    .find(|r| r.packet == 1 && r.threads == *threads && r.isa == "scalar")
                    .map(|r| r.mrays_per_s);
                let row = Row {
                    scene: name.to_string(),
                    rays: args.rays.name(),
                    isa: "embree".into(),
                    packet: *width,
                    layout,
                    intersector: if robust { "embree_robust" } else { "embree" },
                    culling: "none".into(),
                    ci_over_ct: None,
                    context: Some(context.name()),
                    threads: *threads,
                    mrays_per_s: mrays,
                    tests_per_ray: f64::NAN,
                    culled_percent: f64::NAN,
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
/// untimed run: closest hits, or occlusion when `any`. Each run traces a fresh copy of the
/// untraced rays, copied before its timer starts.
#[cfg(feature = "embree")]
pub(crate) fn embree_seconds(
    reps: usize,
    scene: &kdbeam_cli::embree::EmbreeScene,
    rays: &kdbeam_cli::embree::EmbreeRays,
    context: kdbeam_cli::embree::Context,
    any: bool,
) -> f64 {
    let mut work = rays.clone();
    warm_then_median(reps, || {
        work.clone_from(rays);
        let start = Instant::now();
        if any {
            scene.occlude(&mut work, context);
        } else {
            scene.trace(&mut work, context);
        }
        (start.elapsed().as_secs_f64(), 0)
    })
    .0
}

/// The Embree call of a row: `rtcIntersect16`, `rtcOccluded1M` and so on.
fn embree_call(row: &Row) -> String {
    let query = if row.rays == RaySet::Shadow.name() || row.rays == RaySet::Ao.name() {
        "rtcOccluded"
    } else {
        "rtcIntersect"
    };
    if row.layout == "stream" {
        format!("{query}1M")
    } else {
        format!("{query}{}", row.packet)
    }
}

/// Prints, per thread count of `rows` (one scene's), kdbeam's fastest row against Embree's
/// fastest in each context measured, of its single-ray, packet and stream calls.
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
        // Shadow rays in pixel tiles all run to one light: Embree's coherent traversal can beat
        // its incoherent calls on them, so the fair baseline is its fastest context.
        let fastest_context = fastest(rows.iter().filter(|r| r.threads == t && r.is_embree()))
            .and_then(|r| r.context);
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
                kdbeam_layout: kd.layout,
                kdbeam_culling: kd.culling.clone(),
                kdbeam_ci_over_ct: kd.ci_over_ct,
                kdbeam_mrays_per_s: kd.mrays_per_s,
                context,
                context_matches_rays: matching(kd.rays) == context,
                fastest_context: fastest_context == Some(context),
                embree_call: embree_call(em),
                embree_mrays_per_s: em.mrays_per_s,
                ratio: kd.mrays_per_s / em.mrays_per_s,
            };
            print_json_or(&best, json, || {
                format!(
                    "best       {} {}, threads {}: kdbeam {} packet {} {} culling {} ci {} at {:.2} Mrays/s \
                     = {:.2}x Embree's best {} ({}, {:.2} Mrays/s){}",
                    best.scene,
                    kd.rays,
                    t,
                    best.kdbeam_isa,
                    best.kdbeam_packet,
                    best.kdbeam_layout,
                    best.kdbeam_culling,
                    best.kdbeam_ci_over_ct.map_or("-".into(), |c| c.to_string()),
                    best.kdbeam_mrays_per_s,
                    best.ratio,
                    context,
                    best.embree_call,
                    best.embree_mrays_per_s,
                    match (best.fastest_context, best.context_matches_rays) {
                        (true, true) => ": the context for these rays, and Embree's fastest",
                        (true, false) => ": Embree's fastest context for these rays",
                        (false, true) => ": the context for these rays, not Embree's fastest",
                        (false, false) => "",
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
            "{:<16} {:<8} {:<8} {:>6} {:<11} {:<22} {:>6} {:<10} {:>7} {:>9.2} {:>9} {:>7} {:>9}",
            r.scene,
            r.rays,
            r.isa,
            r.packet,
            r.layout,
            r.culling,
            r.ci_over_ct.map_or("-".into(), |c| c.to_string()),
            r.context.unwrap_or("-"),
            r.threads,
            r.mrays_per_s,
            or_dash(r.tests_per_ray, |t| format!("{t:.2}")),
            or_dash(r.culled_percent, |c| format!("{c:.1}%")),
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

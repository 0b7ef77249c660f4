//! A moving scene: instances of one mesh walking over the built-in terrain, traced with
//! shadows every frame through a [`kdbeam::Scene`].
//!
//! ```text
//! cargo run --release --example animated -- --instances 100 --frames 8 --size 512x512 --out target/animated
//! cargo run --release --example animated --features embree -- --embree   # Embree side by side
//! ```
//!
//! Each frame moves every instance (`Scene::set_transform`), commits (the top-level BVH is
//! rebuilt, the mesh's kd-tree kept), traces the camera's primary rays in 8×8 pixel tiles
//! (`Scene::intersect_packet`) and a shadow ray per hit to a point light, each tile's shadow
//! rays as one packet (`Scene::occluded_packet`; with `--single-rays`, every ray one by one),
//! on all threads (rayon), writes the frame as a PNG and prints the time of each step. The
//! mesh is the bunny when `KDBEAM_SCENES` holds it, else a built-in icosphere (`--mesh` picks
//! another: a shared mesh's name, `builtin:NAME[:SIZE]` or an OBJ path).
//!
//! With `--embree` (a build with `--features embree`) the same scene is built in Embree as
//! Embree sets up moving instances — one high-quality mesh scene instanced under each
//! transform, the ground instanced once, the top level `RTC_BUILD_QUALITY_LOW` with
//! `RTC_SCENE_FLAG_DYNAMIC` — and traced on the same rays in the same run: primary rays by
//! rtcIntersect16 on 4×4 tiles with the `COHERENT` context, shadow rays (in kdbeam's tile
//! order) by the fastest of rtcOccluded1, 8 and 16 with the `INCOHERENT` context. The hits
//! are compared (hit or miss, instance, `t`).

use std::path::PathBuf;
use std::time::Instant;

use clap::Parser;
use glam::{Affine3A, Quat};
use kdbeam::scene::procedural::{terrain, terrain_height};
use kdbeam::scene::world::{Query, SceneHit};
use kdbeam::{Aabb, BuildParams, Camera, InstanceId, PacketShape, Ray, RayPacket, Scene, Vec3};
use kdbeam_cli::render::{parse_size, Image};
use kdbeam_cli::scenes::{load_scene, shared_scene};
use rayon::prelude::*;

/// The seed of the terrain and of the instances' paths.
const SEED: u64 = 7;

/// A moving scene traced with shadows through `kdbeam::Scene`, optionally beside Embree.
#[derive(Parser)]
struct Args {
    /// Instances of the mesh.
    #[arg(long, default_value_t = 100)]
    instances: usize,
    /// Frames to trace.
    #[arg(long, default_value_t = 8)]
    frames: usize,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, default_value = "512x512", value_parser = parse_size)]
    size: (u32, u32),
    /// Folder of the frames (frame_0000.png, …); created if missing.
    #[arg(long, default_value = "target/animated")]
    out: PathBuf,
    /// Threads (default: every core).
    #[arg(long)]
    threads: Option<usize>,
    /// The instanced mesh (default: the bunny if KDBEAM_SCENES has it, else builtin:icosphere:3).
    #[arg(long)]
    mesh: Option<String>,
    /// Grid side of the terrain (2·side² triangles).
    #[arg(long, default_value_t = 512)]
    terrain: u32,
    /// Trace every ray one by one (`Scene::intersect`, `Scene::occluded`) instead of in 8×8
    /// tile packets.
    #[arg(long)]
    single_rays: bool,
    /// SAH cost ratio of every mesh's kd-tree (default: each mesh's own,
    /// `BuildParams::for_mesh`).
    #[arg(long)]
    ci_over_ct: Option<f32>,
    /// Also trace the same scene with Embree (needs `--features embree`).
    #[arg(long)]
    embree: bool,
}

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let args = Args::parse();
    if args.embree && !cfg!(feature = "embree") {
        return Err("--embree needs a build with --features embree".into());
    }
    let mut pool = rayon::ThreadPoolBuilder::new();
    if let Some(n) = args.threads {
        pool = pool.num_threads(n);
    }
    pool.build()?.install(|| run(&args))
}

/// The walkers: each circles its own spot of the terrain, facing where it goes.
struct Walkers {
    /// Where each circles, its radius and phase.
    paths: Vec<(f32, f32, f32, f32)>,
    /// Scale and offset that stand the mesh on the origin, a walker's size.
    base: Affine3A,
}

impl Walkers {
    fn new(count: usize, mesh: &Aabb) -> Self {
        let side = (count as f32).sqrt().ceil().max(1.0);
        let spacing = 1.6 / side;
        let mut rng = kdbeam::scene::rng::Rng::new(SEED);
        let paths = (0..count)
            .map(|i| {
                let (gx, gz) = ((i as f32 % side), (i as f32 / side).floor());
                let x = -0.8 + (gx + 0.5) * spacing;
                let z = 0.15 + (gz + 0.5) * spacing;
                let radius = rng.range(0.15, 0.45) * spacing;
                (x, z, radius, rng.range(0.0, std::f32::consts::TAU))
            })
            .collect();
        let size = mesh.extent().max_element().max(f32::MIN_POSITIVE);
        let scale = 0.7 * spacing / size;
        let foot = Vec3::new(mesh.center().x, mesh.min.y, mesh.center().z);
        let base = Affine3A::from_scale(Vec3::splat(scale)) * Affine3A::from_translation(-foot);
        Walkers { paths, base }
    }

    /// Every walker's transform at `frame`.
    fn transforms(&self, frame: usize) -> Vec<Affine3A> {
        self.paths
            .iter()
            .enumerate()
            .map(|(i, &(x, z, r, phase))| {
                let speed = if i % 2 == 0 { 1.0 } else { -1.0 };
                let a = phase + speed * 0.15 * frame as f32;
                let (px, pz) = (x + r * a.cos(), z + r * a.sin());
                let ground = terrain_height(px, pz, SEED);
                let heading = Quat::from_rotation_y(-a * speed);
                Affine3A::from_rotation_translation(heading, Vec3::new(px, ground, pz)) * self.base
            })
            .collect()
    }
}

/// What one frame's tracing found and took.
struct Traced {
    /// The hit of each pixel, row by row.
    hits: Vec<SceneHit>,
    /// The shadow ray of each pixel with a hit.
    shadow_rays: Vec<(u32, Ray)>,
    /// Whether each shadow ray was blocked.
    blocked: Vec<bool>,
    primary_s: f64,
    shadow_s: f64,
}

fn run(args: &Args) -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let name = match &args.mesh {
        Some(name) => name.clone(),
        None if shared_scene("bunny").is_some_and(|p| p.is_file()) => "bunny".into(),
        None => "builtin:icosphere:3".into(),
    };
    let mesh = load_scene(&name)?;
    let ground = terrain(args.terrain, SEED);
    let walkers = Walkers::new(args.instances, &mesh.bounds());

    let start = Instant::now();
    let mut scene = Scene::new();
    if let Some(ci_over_ct) = args.ci_over_ct {
        scene.set_build_params(BuildParams::default().with_ci_over_ct(ci_over_ct))?;
    }
    let prototype = scene.add_prototype(mesh.clone())?;
    scene.add_mesh(ground.clone())?;
    let ids = walkers
        .transforms(0)
        .into_iter()
        .map(|m| scene.add_instance(prototype, m))
        .collect::<Result<Vec<InstanceId>, _>>()?;
    scene.commit()?;
    println!(
        "{} instances of {name} ({} triangles) over builtin terrain:{} ({} triangles), \
         {}x{}, {} threads, ISA {:?}: first commit {:.1} ms",
        ids.len(),
        mesh.triangle_count(),
        args.terrain,
        ground.triangle_count(),
        args.size.0,
        args.size.1,
        rayon::current_num_threads(),
        scene.isa(),
        1e3 * start.elapsed().as_secs_f64(),
    );

    let (width, height) = args.size;
    let bounds = ground.bounds();
    let eye = Vec3::new(0.0, bounds.max.y + 0.2, -0.8);
    let target = Vec3::new(0.0, 0.0, 1.1);
    let camera = Camera::look_at(eye, target, 50.0, width, height)?;
    let light = Vec3::new(-1.5, bounds.max.y + 3.0, -0.5);
    let offset = 1e-4 * bounds.extent().length();
    let shape = PacketShape::P8x8;
    let primary = if args.single_rays {
        Primary::Rays(camera.rays())
    } else {
        Primary::Packets(camera.tile_packets(shape), tiles(width, height, shape))
    };

    #[cfg(feature = "embree")]
    let mut embree = if args.embree {
        Some(side_by_side::Embree::new(
            &mesh,
            &ground,
            &walkers.transforms(0),
            &camera,
        )?)
    } else {
        None
    };

    std::fs::create_dir_all(&args.out)?;
    // Commit and frame (commit + trace) seconds of each frame: kdbeam's, Embree's.
    let mut times: Vec<[f64; 4]> = Vec::new();
    for frame in 0..args.frames {
        let moved = walkers.transforms(frame);
        let t = Instant::now();
        for (&id, m) in ids.iter().zip(&moved) {
            scene.set_transform(id, *m)?;
        }
        let update_s = t.elapsed().as_secs_f64();
        let t = Instant::now();
        scene.commit()?;
        let commit_s = t.elapsed().as_secs_f64();

        let traced = trace(&scene, &camera, &primary, light, offset);
        let rays = (traced.hits.len() + traced.shadow_rays.len()) as f64;
        let trace_s = traced.primary_s + traced.shadow_s;
        println!(
            "frame {frame:3}  kdbeam: update {:6.3} ms  commit {:6.3} ms  primary {:7.2} ms  \
             shadow {:7.2} ms  {:6.1} Mrays/s  frame {:7.2} ms",
            1e3 * update_s,
            1e3 * commit_s,
            1e3 * traced.primary_s,
            1e3 * traced.shadow_s,
            rays / trace_s / 1e6,
            1e3 * (commit_s + trace_s),
        );
        #[cfg(feature = "embree")]
        let embree_times = match &mut embree {
            Some(embree) => embree.frame(&moved, &traced, commit_s + trace_s)?,
            None => [f64::NAN; 2],
        };
        #[cfg(not(feature = "embree"))]
        let embree_times = [f64::NAN; 2];
        times.push([
            commit_s,
            commit_s + trace_s,
            embree_times[0],
            embree_times[1],
        ]);

        let image = shade(&scene, &camera, &traced, light);
        image.write_png(&args.out.join(format!("frame_{frame:04}.png")))?;
    }
    let median = |k: usize| {
        let mut v: Vec<f64> = times.iter().map(|t| t[k]).collect();
        v.sort_by(f64::total_cmp);
        1e3 * v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
    };
    println!(
        "median of {} frames: kdbeam commit {:.3} ms, frame {:.2} ms",
        times.len(),
        median(0),
        median(1)
    );
    if args.embree {
        println!(
            "                     embree commit {:.3} ms, frame {:.2} ms; kdbeam's commit \
             {:.2}x Embree's time, kdbeam's frame rate {:.2}x Embree's",
            median(2),
            median(3),
            median(0) / median(2),
            median(3) / median(1)
        );
    }
    println!("frames written to {}", args.out.display());
    Ok(())
}

/// The pixel rectangle `(x0, y0, cols, rows)` of each of `Camera::tile_packets`' packets.
fn tiles(width: u32, height: u32, shape: PacketShape) -> Vec<(u32, u32, u32, u32)> {
    let (tw, th) = (shape.width() as u32, shape.height() as u32);
    let mut out = Vec::new();
    for y0 in (0..height).step_by(th as usize) {
        for x0 in (0..width).step_by(tw as usize) {
            out.push((x0, y0, tw.min(width - x0), th.min(height - y0)));
        }
    }
    out
}

/// The camera's rays, made once: in pixel-tile packets with their rectangles, or one by one.
enum Primary {
    Packets(Vec<RayPacket>, Vec<(u32, u32, u32, u32)>),
    Rays(Vec<Ray>),
}

/// Traces the primary rays and a shadow ray per hit, on all threads.
fn trace(scene: &Scene, camera: &Camera, primary: &Primary, light: Vec3, offset: f32) -> Traced {
    let width = camera.width as usize;
    let t = Instant::now();
    let (hits, primary_s) = match primary {
        Primary::Packets(packets, tiles) => {
            let tile_hits: Vec<Vec<SceneHit>> = packets
                .par_iter()
                .map(|p| {
                    let mut hits = vec![SceneHit::NONE; p.len()];
                    scene
                        .intersect_packet(p, p.full_mask(), &Query::default(), &mut hits)
                        .expect("a hit per ray");
                    hits
                })
                .collect();
            let primary_s = t.elapsed().as_secs_f64();
            let mut hits = vec![SceneHit::NONE; width * camera.height as usize];
            for (&(x0, y0, cols, _), tile) in tiles.iter().zip(&tile_hits) {
                for (k, h) in tile.iter().enumerate() {
                    let (x, y) = (
                        x0 as usize + k % cols as usize,
                        y0 as usize + k / cols as usize,
                    );
                    hits[y * width + x] = *h;
                }
            }
            (hits, primary_s)
        }
        Primary::Rays(rays) => {
            let mut hits = vec![SceneHit::NONE; rays.len()];
            scene
                .intersect_stream(rays, &mut hits, &Query::default())
                .expect("a committed scene and a hit per ray");
            (hits, t.elapsed().as_secs_f64())
        }
    };
    // A shadow ray per hit, in pixel-tile order: with primary packets, each tile's shadow rays
    // are one packet, as coherent as its camera rays since they all end at the light.
    let groups: Vec<Vec<usize>> = match primary {
        Primary::Packets(_, tiles) => tiles
            .iter()
            .map(|&(x0, y0, cols, rows)| {
                (y0..y0 + rows)
                    .flat_map(|y| (x0..x0 + cols).map(move |x| y as usize * width + x as usize))
                    .collect()
            })
            .collect(),
        Primary::Rays(rays) => (0..rays.len())
            .step_by(256)
            .map(|i| (i..(i + 256).min(rays.len())).collect())
            .collect(),
    };
    let shadow_ray = |i: usize| {
        let h = &hits[i];
        let ray = camera.ray((i % width) as u32, (i / width) as u32);
        let n = scene.normal(h)?;
        let n = if n.dot(ray.direction) > 0.0 { -n } else { n };
        let origin = ray.at(h.t) + offset * n;
        Some((
            i as u32,
            Ray {
                tmax: 1.0,
                ..Ray::new(origin, light - origin)
            },
        ))
    };
    let grouped: Vec<Vec<(u32, Ray)>> = groups
        .par_iter()
        .map(|g| g.iter().filter_map(|&i| shadow_ray(i)).collect())
        .collect();
    let shadow_rays: Vec<(u32, Ray)> = grouped.iter().flatten().copied().collect();
    let (blocked, shadow_s): (Vec<bool>, f64) = match primary {
        Primary::Packets(..) => {
            // Packed before the clock starts, as Embree's rays are.
            let packets: Vec<RayPacket> = grouped
                .iter()
                .filter(|g| !g.is_empty())
                .map(|g| RayPacket::from_rays(&g.iter().map(|(_, r)| *r).collect::<Vec<_>>()))
                .collect();
            let t = Instant::now();
            let masks: Vec<u64> = packets
                .par_iter()
                .map(|p| scene.occluded_packet(p, p.full_mask(), &Query::default()))
                .collect();
            let seconds = t.elapsed().as_secs_f64();
            let blocked = packets
                .iter()
                .zip(masks)
                .flat_map(|(p, m)| (0..p.len()).map(move |i| m >> i & 1 == 1))
                .collect();
            (blocked, seconds)
        }
        Primary::Rays(_) => {
            let t = Instant::now();
            let blocked = shadow_rays
                .par_chunks(256)
                .flat_map_iter(|chunk| chunk.iter().map(|(_, r)| scene.occluded(r)))
                .collect();
            (blocked, t.elapsed().as_secs_f64())
        }
    };
    Traced {
        hits,
        shadow_rays,
        blocked,
        primary_s,
        shadow_s,
    }
}

/// Lambert under the point light (dark where the shadow ray was blocked), a sky fill, and a
/// colour per instance.
fn shade(scene: &Scene, camera: &Camera, traced: &Traced, light: Vec3) -> Image {
    let (width, height) = (camera.width, camera.height);
    let mut lit = vec![1.0f32; traced.hits.len()];
    for ((i, _), &b) in traced.shadow_rays.iter().zip(&traced.blocked) {
        if b {
            lit[*i as usize] = 0.0;
        }
    }
    let mut image = Image::new(width, height);
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let ray = camera.ray(x, y);
            let h = &traced.hits[i];
            let colour = match scene.normal(h) {
                None => {
                    let k = 0.5 * (1.0 - ray.direction.normalize().y);
                    Vec3::new(0.55, 0.65, 0.85).lerp(Vec3::new(0.9, 0.92, 0.95), k)
                }
                Some(n) => {
                    let n = if n.dot(ray.direction) > 0.0 { -n } else { n };
                    let p = ray.at(h.t);
                    let key = n.dot((light - p).normalize()).max(0.0) * lit[i];
                    let fill = 0.5 + 0.5 * n.y;
                    let albedo = if h.instance == InstanceId::NONE {
                        Vec3::new(0.55, 0.6, 0.45)
                    } else {
                        let k = h.instance.0 as f32 * 0.618_034;
                        let hue = k - k.floor();
                        Vec3::new(0.8, 0.35 + 0.4 * hue, 0.3 + 0.5 * (1.0 - hue))
                    };
                    albedo * (0.85 * key + 0.25 * fill)
                }
            };
            image.set_linear(x, y, colour.into());
        }
    }
    image
}

/// Embree beside kdbeam on the same scene and rays (the `embree` feature).
#[cfg(feature = "embree")]
mod side_by_side {
    use std::time::Instant;

    use glam::Affine3A;
    use kdbeam::scene::world::SceneHit;
    use kdbeam::{Camera, Hit, InstanceId, Mesh, Ray};
    use kdbeam_cli::embree::{primary_rays, Context, EmbreeInstances, EmbreeRays};

    use super::Traced;

    /// Relative tolerance on `t` where both hit the same instance: both carry the ray into the
    /// instance's space in `f32` and test the same triangle, which differs by a few ulps
    /// (~1e-7 relative) and more for grazing hits; 1e-3 still catches a wrong transform.
    const T_TOLERANCE: f32 = 1e-3;

    /// The widths of Embree's shadow-ray calls tried each frame, the fastest counted.
    const SHADOW_WIDTHS: [usize; 3] = [1, 8, 16];

    /// Embree's scene, its primary rays in 4×4 tiles and their pixels.
    pub struct Embree {
        scene: EmbreeInstances,
        primary: EmbreeRays,
        pixels: Vec<u32>,
        instances: usize,
    }

    impl Embree {
        pub fn new(
            mesh: &Mesh,
            ground: &Mesh,
            placements: &[Affine3A],
            camera: &Camera,
        ) -> Result<Self, Box<dyn std::error::Error + Send + Sync>> {
            let t = Instant::now();
            let scene = EmbreeInstances::new(mesh, ground, placements)?;
            println!(
                "embree: two-level scene built in {:.1} ms (mesh and ground high quality, top \
                 level low quality + dynamic); primary rtcIntersect16 coherent, shadow \
                 rtcOccluded1/8/16 incoherent (the fastest each frame)",
                1e3 * t.elapsed().as_secs_f64()
            );
            let (rays, pixels) = primary_rays(camera, 16)?;
            Ok(Embree {
                scene,
                primary: EmbreeRays::new(&rays, 16)?,
                pixels,
                instances: placements.len(),
            })
        }

        /// Moves, commits and traces one frame; prints its times beside kdbeam's and how far
        /// the hits agree. Returns the seconds of the commit and of the frame (commit and
        /// tracing).
        pub fn frame(
            &mut self,
            moved: &[Affine3A],
            kdbeam: &Traced,
            kdbeam_frame_s: f64,
        ) -> Result<[f64; 2], Box<dyn std::error::Error + Send + Sync>> {
            let t = Instant::now();
            for (i, m) in moved.iter().enumerate() {
                self.scene.set_transform(i, m)?;
            }
            let update_s = t.elapsed().as_secs_f64();
            let t = Instant::now();
            self.scene.commit()?;
            let commit_s = t.elapsed().as_secs_f64();

            let mut primary = self.primary.clone();
            let t = Instant::now();
            self.scene.trace(&mut primary, Context::Coherent);
            let primary_s = t.elapsed().as_secs_f64();
            // Embree at its best on the shadow rays (kdbeam's tile order, the `INCOHERENT`
            // context of secondary rays): the fastest of rtcOccluded1, 8 and 16. (With the
            // `COHERENT` context, rtcOccluded16 did not return within a minute here.)
            let rays: Vec<Ray> = kdbeam.shadow_rays.iter().map(|(_, r)| *r).collect();
            let mut best: Option<(f64, usize, EmbreeRays)> = None;
            for width in SHADOW_WIDTHS {
                let mut shadow = EmbreeRays::new(&rays, width)?;
                let t = Instant::now();
                self.scene.occlude(&mut shadow, Context::Incoherent);
                let s = t.elapsed().as_secs_f64();
                if best.as_ref().is_none_or(|(b, ..)| s < *b) {
                    best = Some((s, width, shadow));
                }
            }
            let (shadow_s, shadow_width, shadow) = best.expect("at least one width");

            let total = (kdbeam.hits.len() + rays.len()) as f64;
            let frame_s = commit_s + primary_s + shadow_s;
            println!(
                "           embree: update {:6.3} ms  commit {:6.3} ms  primary {:7.2} ms  \
                 shadow {:7.2} ms (rtcOccluded{shadow_width})  {:6.1} Mrays/s  frame {:7.2} ms   \
                 kdbeam's frame rate {:.2}x Embree's",
                1e3 * update_s,
                1e3 * commit_s,
                1e3 * primary_s,
                1e3 * shadow_s,
                total / (primary_s + shadow_s) / 1e6,
                1e3 * frame_s,
                frame_s / kdbeam_frame_s,
            );

            let mut hits = vec![Hit::NONE; primary.len()];
            let mut instances = vec![0u32; primary.len()];
            primary.hits(&mut hits)?;
            primary.instances(&mut instances)?;
            let mut blocked = vec![false; shadow.len()];
            shadow.occluded(&mut blocked)?;
            let differ = self.disagreements(&kdbeam.hits, &hits, &instances);
            let shadow_differ = blocked
                .iter()
                .zip(&kdbeam.blocked)
                .filter(|(a, b)| a != b)
                .count();
            println!(
                "           agreement: {} of {} primary rays differ (hit or miss, instance, \
                 t within {T_TOLERANCE:e} relative), {} of {} shadow rays",
                differ,
                hits.len(),
                shadow_differ,
                blocked.len()
            );
            Ok([commit_s, frame_s])
        }

        /// How many primary rays Embree and kdbeam answer differently.
        fn disagreements(&self, kdbeam: &[SceneHit], hits: &[Hit], instances: &[u32]) -> usize {
            let mut differ = 0;
            for ((&pixel, h), &inst) in self.pixels.iter().zip(hits).zip(instances) {
                let k = &kdbeam[pixel as usize];
                let inst = if inst as usize == self.instances {
                    InstanceId::NONE
                } else {
                    InstanceId(inst)
                };
                let same = match (k.is_hit(), h.is_hit()) {
                    (false, false) => true,
                    (true, true) => {
                        k.instance == inst && (k.t - h.t).abs() <= T_TOLERANCE * k.t.abs()
                    }
                    _ => false,
                };
                differ += usize::from(!same);
            }
            differ
        }
    }
}

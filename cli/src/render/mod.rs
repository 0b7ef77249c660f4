//! Frames of primary rays traced in pixel tiles, shading, heat maps and PNGs.

mod image;
mod ray_set;
mod shade;

use std::time::Instant;

use kdbeam::rays::secondary::SecondaryRays;
use kdbeam::trace::{PacketCounters, Tracer};
use kdbeam::{Camera, Hit, HitPacket, Mesh, RayPacket};
use rayon::prelude::*;

pub use image::{heat_color, parse_size, Image};
pub use ray_set::{RaySet, Rays, SEED};
pub use shade::{shade, shade_lit, Light};

/// The primary hits of one frame and what they cost.
#[derive(Clone, Debug)]
pub struct Frame {
    /// The camera the rays came from.
    pub camera: Camera,
    /// Hit per pixel, row by row.
    pub hits: Vec<Hit>,
    /// Ray–triangle tests per pixel (after culling), row by row.
    pub tests: Vec<u32>,
    /// Traversal work summed over packets.
    pub counters: PacketCounters,
    /// Wall-clock seconds spent tracing.
    pub seconds: f64,
    /// TSC reference cycles spent generating the rays (with the `stats` feature, else 0).
    pub generation_cycles: u64,
    /// TSC reference cycles of the whole frame, summed over threads (with `stats`, else 0).
    pub frame_cycles: u64,
}

impl Frame {
    /// Rays traced.
    pub fn rays(&self) -> u64 {
        self.hits.len() as u64
    }

    /// Millions of rays per second.
    pub fn mrays_per_s(&self) -> f64 {
        self.rays() as f64 / self.seconds.max(1e-12) / 1e6
    }

    /// Ray–triangle tests performed per ray.
    pub fn tests_per_ray(&self) -> f64 {
        self.counters.tests as f64 / self.rays().max(1) as f64
    }

    /// Shades the frame under the fixed key light.
    pub fn shade(&self, mesh: &Mesh) -> Image {
        self.shade_lit(mesh, |_| None)
    }

    /// Shades the frame, pixel `y · width + x` lit as `light` says ([`shade_lit`]).
    pub fn shade_lit(&self, mesh: &Mesh, light: impl Fn(usize) -> Option<Light>) -> Image {
        let mut img = Image::new(self.camera.width, self.camera.height);
        for y in 0..self.camera.height {
            for x in 0..self.camera.width {
                let pixel = (y * self.camera.width + x) as usize;
                let hit = &self.hits[pixel];
                // Row y = 0 looks down (v = −1): draw it at the bottom, and mirror x, so the
                // picture is upright as seen from the eye.
                let (px, py) = (self.camera.width - 1 - x, self.camera.height - 1 - y);
                let colour = shade_lit(mesh, &self.camera.ray(x, y), hit, light(pixel));
                img.set_linear(px, py, colour);
            }
        }
        img
    }
}

/// Traces the primary rays of `camera` through `tracer` in packets of pixel tiles of the
/// tracer's packet shape, on all threads of the current rayon pool. `progress` is called with
/// the number of pixel rows finished, as they finish.
pub fn trace_primary(
    tracer: &Tracer<'_>,
    camera: &Camera,
    progress: &(dyn Fn(u64) + Sync),
) -> Frame {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let (tw, th) = (tracer.packet().width(), tracer.packet().height());
    let mut hits = vec![(Hit::NONE, 0u32); w * h];
    let band = |(band, out): (usize, &mut [(Hit, u32)])| {
        let band_start = stamp();
        let mut generation = 0;
        let mut counters = PacketCounters::default();
        let mut p = RayPacket::from_rays(&[]);
        let rows = out.len() / w;
        let mut hp = HitPacket::default();
        for tx in (0..w).step_by(tw) {
            let cols = tw.min(w - tx);
            let (x0, y0) = (tx as u32, (band * th) as u32);
            let fill_start = stamp();
            camera.fill_packet(x0, y0, cols as u32, rows as u32, &mut p);
            generation += stamp() - fill_start;
            tracer.intersect_packet_counted(&p, p.full_mask(), &mut hp, &mut counters);
            for dy in 0..rows {
                for dx in 0..cols {
                    let j = dy * cols + dx;
                    out[dy * w + tx + dx] = (hp.hit(j), hp.tests[j]);
                }
            }
        }
        progress(rows as u64);
        (counters, generation, stamp() - band_start)
    };
    let start = Instant::now();
    let per_band: Vec<_> = hits.par_chunks_mut(w * th).enumerate().map(band).collect();
    let seconds = start.elapsed().as_secs_f64();
    let mut counters = PacketCounters::default();
    let (mut generation_cycles, mut frame_cycles) = (0, 0);
    for (c, generation, total) in &per_band {
        counters.add(c);
        generation_cycles += generation;
        frame_cycles += total;
    }
    let (hits, tests) = hits.into_iter().unzip();
    Frame {
        camera: *camera,
        hits,
        tests,
        counters,
        seconds,
        generation_cycles,
        frame_cycles,
    }
}

/// The time-stamp counter with the `stats` feature (TSC reference cycles), 0 without it.
fn stamp() -> u64 {
    if cfg!(feature = "stats") {
        kdbeam::kernels::lanes::tsc().unwrap_or(0)
    } else {
        0
    }
}

/// Whether each of `rays` hits anything, traced by `tracer` in the packets per pixel tile and
/// sample of its packet shape ([`SecondaryRays::tile_packets`]) on all threads of the current
/// rayon pool: the answers in the order of the rays, the seconds spent tracing and the work.
pub fn trace_occlusion(
    tracer: &Tracer<'_>,
    rays: &SecondaryRays,
    camera: &Camera,
) -> (Vec<bool>, f64, PacketCounters) {
    let start = Instant::now();
    let tiles = rays.tile_packets(camera, tracer.packet());
    let per_packet: Vec<(u64, PacketCounters)> = tiles
        .packets
        .par_iter()
        .map(|p| {
            let mut c = PacketCounters::default();
            (tracer.occluded_packet_counted(p, p.full_mask(), &mut c), c)
        })
        .collect();
    let seconds = start.elapsed().as_secs_f64();
    let mut occluded = vec![false; rays.len()];
    let mut counters = PacketCounters::default();
    let mut lanes = tiles.rays.iter();
    for ((bits, c), p) in per_packet.iter().zip(&tiles.packets) {
        counters.add(c);
        for (j, &i) in lanes.by_ref().take(p.len()).enumerate() {
            occluded[i as usize] = bits >> j & 1 != 0;
        }
    }
    (occluded, seconds, counters)
}

/// Ray–triangle tests per pixel, as a heat map on a log scale from 1 to `max` (the frame's own
/// largest count when `None`, so that two maps can share a scale).
pub fn heatmap(frame: &Frame, max: Option<u32>) -> Image {
    let camera = &frame.camera;
    let max = max
        .unwrap_or_else(|| frame.tests.iter().copied().max().unwrap_or(0))
        .max(1) as f32;
    let mut img = Image::new(camera.width, camera.height);
    for (i, &t) in frame.tests.iter().enumerate() {
        let (x, y) = (i as u32 % camera.width, i as u32 / camera.width);
        let (px, py) = (camera.width - 1 - x, camera.height - 1 - y);
        img.set_linear(px, py, heat_color((1.0 + t as f32).ln() / (1.0 + max).ln()));
    }
    img
}

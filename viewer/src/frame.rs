//! One frame of the viewer: primary rays in pixel-tile packets, a shadow ray per hit, shading,
//! and the figures drawn over it.

use std::time::Instant;

use kdbeam::rays::secondary::{light, SecondaryRays, Workload};
use kdbeam::{Camera, Mesh, Result, Tracer};
use kdbeam_cli::render::{self, Light, SEED};

/// What a frame took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Primary and shadow rays traced.
    pub rays: u64,
    /// Rays per second of tracing (shading and drawing not counted), in millions.
    pub mrays_per_s: f64,
    /// Wall-clock milliseconds of the whole frame: tracing, shading, drawing.
    pub frame_ms: f64,
    /// The share of the primary rays' ray–triangle tests the frustum culled, in percent.
    pub culled_percent: f64,
}

impl FrameStats {
    /// The line drawn over the picture.
    #[must_use]
    pub fn overlay(&self) -> String {
        format!(
            "{:.1} MRAYS/S  {:.1} MS  CULLED {:.0}%",
            self.mrays_per_s, self.frame_ms, self.culled_percent
        )
    }
}

/// Traces `camera`'s view of `mesh` through `tracer` with shadows from the point light of
/// [`light`], on all threads of the current rayon pool, into `pixels` (`0x00RRGGBB`, row by
/// row; resized to the camera's size).
///
/// # Errors
/// What [`SecondaryRays::new`] returns (never, for a tracer built on `mesh`).
pub fn render_frame(
    tracer: &Tracer<'_>,
    mesh: &Mesh,
    camera: &Camera,
    pixels: &mut Vec<u32>,
) -> Result<FrameStats> {
    let start = Instant::now();
    let frame = render::trace_primary(tracer, camera, &|_| {});
    let shadow = SecondaryRays::new(Workload::Shadow, mesh, camera, &frame.hits, SEED)?;
    let (occluded, shadow_seconds, _) = render::trace_occlusion(tracer, &shadow, camera);
    let mut visible = vec![1.0f32; frame.hits.len()];
    for (&pixel, &o) in shadow.pixels.iter().zip(&occluded) {
        if o {
            visible[pixel as usize] = 0.0;
        }
    }
    let position = light(&mesh.bounds());
    let image = frame.shade_lit(mesh, |pixel| {
        Some(Light {
            position,
            visible: visible[pixel],
            ambient: 1.0,
        })
    });
    pixels.clear();
    pixels.extend(
        image
            .rgb
            .chunks_exact(3)
            .map(|c| u32::from(c[0]) << 16 | u32::from(c[1]) << 8 | u32::from(c[2])),
    );
    let rays = frame.rays() + shadow.len() as u64;
    Ok(FrameStats {
        rays,
        mrays_per_s: rays as f64 / (frame.seconds + shadow_seconds).max(1e-12) / 1e6,
        frame_ms: 1e3 * start.elapsed().as_secs_f64(),
        culled_percent: frame.counters.eliminated_percent(),
    })
}

/// How many different colours `pixels` holds: a picture of one colour is blank.
#[must_use]
pub fn distinct_colours(pixels: &[u32]) -> usize {
    let mut sorted = pixels.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    sorted.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use kdbeam::{BuildParams, KdTree};

    #[test]
    fn a_frame_of_the_default_scene_is_not_blank_and_counts_its_rays() {
        let mesh = kdbeam::scene::procedural::builtin("icosphere:2").unwrap();
        let tree = KdTree::build(&mesh, &BuildParams::default()).unwrap();
        let tracer = Tracer::new(&tree);
        let camera = Camera::standard(&mesh.bounds(), 32, 24);
        let mut pixels = Vec::new();
        let stats = render_frame(&tracer, &mesh, &camera, &mut pixels).unwrap();
        assert_eq!(pixels.len(), 32 * 24);
        assert!(stats.rays > 32 * 24, "primary rays and some shadow rays");
        assert!(distinct_colours(&pixels) > 2);
        assert_eq!(distinct_colours(&[7, 7, 7]), 1);
        assert!(stats.overlay().contains("MRAYS/S"));
    }
}

//! Secondary-ray workloads as a renderer makes them: shadow rays to a point light, ambient
//! occlusion and one diffuse bounce, from a camera's primary hits, deterministic from a seed.
//!
//! With `c` the scene box's centre, `e` its extent and `D` the length of its diagonal, every
//! secondary ray starts at its primary hit point moved `OFFSET·D` (`OFFSET` = 10⁻⁴) along the
//! hit triangle's geometric normal turned towards the incoming ray, so that it does not hit
//! the surface it leaves ([`Surface`]):
//! - [`Workload::Shadow`]: one ray to the point light [`light`]`(bounds)`, `tmax` at the light;
//!   any hit.
//! - [`Workload::AmbientOcclusion`]: `rays` cosine-weighted rays (default
//!   [`DEFAULT_AO_RAYS`]) about the normal, `tmax` = [`AO_RADIUS`]`·D`; any hit.
//! - [`Workload::Diffuse`]: one cosine-weighted ray about the normal, `tmax` infinite; closest hit.
//!
//! The rays of a pixel depend only on the seed, the pixel and its primary hit, never on the
//! order rays are made or traced in, so every packet size, stream order and outside tracer
//! (Embree) gets exactly the same rays. [`SecondaryRays::tile_packets`] forms them into
//! packets per pixel tile, as a renderer does; [`crate::rays::stream`] sorts them into a
//! stream.
//!
//! ```
//! use kdbeam::rays::secondary::{SecondaryRays, Workload};
//! use kdbeam::{scene::procedural, BuildParams, Camera, KdTree, PacketShape, Tracer};
//!
//! let mesh = procedural::builtin("icosphere")?;
//! let tree = KdTree::build(&mesh, &BuildParams::default())?;
//! let tracer = Tracer::new(&tree);
//! let camera = Camera::standard(&mesh.bounds(), 32, 32);
//! let ao = SecondaryRays::from_camera(Workload::AmbientOcclusion { rays: 4 }, &tracer, &mesh, &camera, 1)?;
//! assert_eq!(ao.rays.len() % 4, 0);
//! // A sphere seen from outside occludes none of its own hemisphere rays.
//! assert!(ao.rays.iter().all(|r| !tracer.occluded(r)));
//! // The same rays as 4×4-pixel packets: each holds one sample of the hit pixels of a tile.
//! let tiles = ao.tile_packets(&camera, PacketShape::P4x4);
//! assert_eq!(tiles.packets.iter().map(|p| p.len()).sum::<usize>(), ao.rays.len());
//! # Ok::<(), kdbeam::Error>(())
//! ```

mod ao;
mod diffuse;
mod hemisphere;
mod shadow;
mod surface;
mod tiles;

use kdbeam_kernels::{Hit, HitPacket, Ray};

pub use ao::{AO_RADIUS, DEFAULT_AO_RAYS};
pub use shadow::light;
pub use surface::Surface;
pub use tiles::TilePackets;

use crate::scene::rng::Rng;
use crate::{Camera, Error, Mesh, Result, Tracer};

/// The offset of a secondary ray's origin from its surface, as a fraction of the scene box's
/// diagonal: far above the rounding of a hit point (≈ 10⁻⁷ of its coordinates), far below
/// the features of the shared scenes.
pub const OFFSET: f32 = 1e-4;

/// Which secondary rays to make from each primary hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Workload {
    /// One ray to the point light ([`light`]), any hit.
    Shadow,
    /// `rays` cosine-weighted rays within [`AO_RADIUS`] of the diagonal, any hit.
    AmbientOcclusion {
        /// Rays per primary hit.
        rays: u32,
    },
    /// One cosine-weighted bounce, closest hit.
    Diffuse,
}

impl Workload {
    /// `shadow`, `ao` or `diffuse`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Workload::Shadow => "shadow",
            Workload::AmbientOcclusion { .. } => "ao",
            Workload::Diffuse => "diffuse",
        }
    }

    /// Rays per primary hit.
    #[must_use]
    pub fn rays_per_hit(self) -> u32 {
        match self {
            Workload::AmbientOcclusion { rays } => rays,
            Workload::Shadow | Workload::Diffuse => 1,
        }
    }

    /// Does a renderer ask only whether anything is hit (shadow and AO rays), rather than for
    /// the closest hit?
    #[must_use]
    pub fn any_hit(self) -> bool {
        !matches!(self, Workload::Diffuse)
    }
}

/// The secondary rays of one frame, pixel by pixel: the rays of each pixel with a primary hit,
/// consecutive, row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct SecondaryRays {
    /// What they are.
    pub workload: Workload,
    /// The rays.
    pub rays: Vec<Ray>,
    /// The pixel (`y · width + x`) each ray starts from.
    pub pixels: Vec<u32>,
}

impl SecondaryRays {
    /// The rays of `workload` from `primary`, the closest hits of `camera`'s rays on `mesh`
    /// (row by row, as [`Camera::rays`] orders them), drawn from `seed`.
    ///
    /// The scene box is `mesh.bounds()`. Pixels whose primary ray missed give no rays; so does a
    /// hit on a triangle id outside the mesh. Every ray has `tmin = 0`.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] when `primary` does not hold one hit per pixel.
    pub fn new(
        workload: Workload,
        mesh: &Mesh,
        camera: &Camera,
        primary: &[Hit],
        seed: u64,
    ) -> Result<SecondaryRays> {
        let pixels = camera.width as usize * camera.height as usize;
        if primary.len() != pixels {
            return Err(Error::InvalidParameter {
                name: "primary hits",
                message: format!("{} hits for {pixels} pixels", primary.len()),
            });
        }
        let bounds = mesh.bounds();
        let diagonal = if bounds.is_empty() {
            0.0
        } else {
            bounds.extent().length()
        };
        let light = light(&bounds);
        let per_hit = workload.rays_per_hit() as usize;
        let mut out = SecondaryRays {
            workload,
            rays: Vec::with_capacity(pixels * per_hit),
            pixels: Vec::with_capacity(pixels * per_hit),
        };
        for (pixel, hit) in primary.iter().enumerate() {
            let (x, y) = (pixel as u32 % camera.width, pixel as u32 / camera.width);
            let Some(surface) = Surface::at(mesh, &camera.ray(x, y), hit, OFFSET * diagonal) else {
                continue;
            };
            let mut rng = pixel_rng(seed, pixel as u32);
            for _ in 0..per_hit {
                out.rays.push(match workload {
                    Workload::Shadow => shadow::shadow_ray(&surface, light),
                    Workload::AmbientOcclusion { .. } => {
                        ao::ao_ray(&surface, AO_RADIUS * diagonal, &mut rng)
                    }
                    Workload::Diffuse => diffuse::diffuse_ray(&surface, &mut rng),
                });
                out.pixels.push(pixel as u32);
            }
        }
        Ok(out)
    }

    /// [`SecondaryRays::new`] on the primary hits `tracer` finds for `camera`
    /// ([`primary_hits`]).
    ///
    /// # Errors
    /// None for a tracer built on `mesh`; the signature matches [`SecondaryRays::new`].
    pub fn from_camera(
        workload: Workload,
        tracer: &Tracer<'_>,
        mesh: &Mesh,
        camera: &Camera,
        seed: u64,
    ) -> Result<SecondaryRays> {
        SecondaryRays::new(workload, mesh, camera, &primary_hits(tracer, camera), seed)
    }

    /// How many rays.
    #[must_use]
    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// Are there no rays (every primary ray missed)?
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }
}

/// The closest hit of each of `camera`'s primary rays, row by row, traced by `tracer` in
/// pixel-tile packets of its packet shape (the hits [`Tracer::intersect`] gives each ray).
#[must_use]
pub fn primary_hits(tracer: &Tracer<'_>, camera: &Camera) -> Vec<Hit> {
    let shape = tracer.packet();
    let (tw, th) = (shape.width() as u32, shape.height() as u32);
    let mut hits = vec![Hit::NONE; camera.width as usize * camera.height as usize];
    let mut packet = kdbeam_kernels::RayPacket::from_rays(&[]);
    let mut hp = HitPacket::default();
    for y0 in (0..camera.height).step_by(th as usize) {
        for x0 in (0..camera.width).step_by(tw as usize) {
            let (cols, rows) = (tw.min(camera.width - x0), th.min(camera.height - y0));
            camera.fill_packet(x0, y0, cols, rows, &mut packet);
            tracer.intersect_packet(&packet, packet.full_mask(), &mut hp);
            for dy in 0..rows {
                for dx in 0..cols {
                    let pixel = (y0 + dy) as usize * camera.width as usize + (x0 + dx) as usize;
                    hits[pixel] = hp.hit((dy * cols + dx) as usize);
                }
            }
        }
    }
    hits
}

/// The generator of one pixel's rays: its own stream, so that a pixel's rays never depend on
/// the other pixels.
fn pixel_rng(seed: u64, pixel: u32) -> Rng {
    Rng::new(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ u64::from(pixel))
}

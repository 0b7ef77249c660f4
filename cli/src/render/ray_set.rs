//! The ray sets every benchmark and accuracy figure is measured on.

use kdbeam::rays::secondary::{SecondaryRays, Workload};
use kdbeam::rays::{random_rays, Camera};
use kdbeam::{BuildParams, Isa, Mesh, Ray, Result, Tracer};

/// Which rays a measurement traces.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum RaySet {
    /// The camera's primary rays, traced in pixel tiles.
    Primary,
    /// Origins uniform in the scene box, directions uniform on the sphere (seeded).
    Random,
    /// One ray per primary hit to the point light, any hit.
    Shadow,
    /// Cosine-weighted ambient-occlusion rays per primary hit, any hit.
    Ao,
    /// One cosine-weighted diffuse bounce per primary hit, closest hit.
    Diffuse,
}

/// The seed of the random and secondary ray sets.
pub const SEED: u64 = 1;

impl RaySet {
    /// `primary`, `random`, `shadow`, `ao` or `diffuse`.
    pub fn name(self) -> &'static str {
        match self {
            RaySet::Primary => "primary",
            RaySet::Random => "random",
            RaySet::Shadow => "shadow",
            RaySet::Ao => "ao",
            RaySet::Diffuse => "diffuse",
        }
    }

    /// The secondary workload of this set, with `ao_rays` rays per hit for [`RaySet::Ao`].
    pub fn workload(self, ao_rays: u32) -> Option<Workload> {
        match self {
            RaySet::Primary | RaySet::Random => None,
            RaySet::Shadow => Some(Workload::Shadow),
            RaySet::Ao => Some(Workload::AmbientOcclusion { rays: ao_rays }),
            RaySet::Diffuse => Some(Workload::Diffuse),
        }
    }

    /// The tree these rays are traced on by default on `isa` in `mesh`:
    /// [`BuildParams::for_mesh`] for camera rays and shadow rays (coherent in pixel tiles:
    /// beams cull most of a large leaf of small triangles), [`BuildParams::for_incoherent_rays`]
    /// for random, AO and diffuse rays.
    pub fn build_params(self, isa: Isa, mesh: &Mesh) -> BuildParams {
        match self {
            RaySet::Primary | RaySet::Shadow => BuildParams::for_mesh(mesh),
            RaySet::Random | RaySet::Ao | RaySet::Diffuse => BuildParams::for_incoherent_rays(isa),
        }
    }

    /// Does a renderer ask only whether these rays hit anything (shadow and AO rays)?
    pub fn any_hit(self) -> bool {
        self.workload(1).is_some_and(Workload::any_hit)
    }
}

/// The rays of a set for one scene and camera, made once for every measurement.
#[derive(Clone, Debug)]
pub struct Rays {
    /// Which set.
    pub set: RaySet,
    /// The camera of the primary rays (and of the primary hits of secondary rays).
    pub camera: Camera,
    /// The rays: row by row for primary rays, pixel by pixel for secondary ones.
    pub rays: Vec<Ray>,
    /// The secondary rays with their pixels, for the secondary sets.
    pub secondary: Option<SecondaryRays>,
}

impl Rays {
    /// The primary rays of `camera`.
    pub fn primary(camera: &Camera) -> Rays {
        Rays {
            set: RaySet::Primary,
            camera: *camera,
            rays: camera.rays(),
            secondary: None,
        }
    }

    /// The rays of `set` seen by `camera` in `mesh`: its primary rays, `width · height` random
    /// rays in the box (seed [`SEED`]), or the secondary rays of its primary hits (found by
    /// `tracer`, a tracer of `mesh`) with `ao_rays` rays per hit for ambient occlusion.
    ///
    /// # Errors
    /// None for a tracer of `mesh` (see [`SecondaryRays::new`]).
    pub fn new(
        set: RaySet,
        mesh: &Mesh,
        tracer: &Tracer<'_>,
        camera: &Camera,
        ao_rays: u32,
    ) -> Result<Rays> {
        let (rays, secondary) = match set.workload(ao_rays) {
            None if set == RaySet::Primary => (camera.rays(), None),
            None => (
                random_rays(
                    &mesh.bounds(),
                    camera.width as usize * camera.height as usize,
                    SEED,
                ),
                None,
            ),
            Some(w) => {
                let s = SecondaryRays::from_camera(w, tracer, mesh, camera, SEED)?;
                (s.rays.clone(), Some(s))
            }
        };
        Ok(Rays {
            set,
            camera: *camera,
            rays,
            secondary,
        })
    }
}

//! A two-level Embree scene for moving instances: one mesh instanced many times over a static
//! ground, as a renderer sets it up (Embree's `dynamic_scene` and instancing tutorials).
//!
//! The mesh and the ground are scenes of their own, built once at high quality; the top level
//! holds an `RTC_GEOMETRY_TYPE_INSTANCE` per placement (the ground too, under the identity, so
//! that moving the instances never rebuilds it) and is built with `RTC_BUILD_QUALITY_LOW` and
//! `RTC_SCENE_FLAG_DYNAMIC`, Embree's setting for a top level that changes every frame.

use std::ptr;

use embree::sys;
use glam::Affine3A;

use kdbeam::Mesh;

use super::query::{query, Committed};
use super::scene::{attach_triangles, check, new_device};
use super::{BuildQuality, Context, EmbreeRays};
use crate::{Error, Result};

/// Instances of one mesh over a ground mesh in Embree: top-level geometry ids `0..n` are the
/// instances in the order given, `n` the ground.
///
/// Tracing is thread-safe through `&self`; moving instances and committing take `&mut self`.
pub struct EmbreeInstances {
    device: sys::RTCDevice,
    /// The mesh, high quality.
    prototype: sys::RTCScene,
    /// The ground, high quality.
    ground: sys::RTCScene,
    /// The instances and the ground's instance: low quality, dynamic.
    top: sys::RTCScene,
    /// The instance geometries, by top-level id (the ground's last); the top scene holds a
    /// reference of its own to each.
    instances: Vec<sys::RTCGeometry>,
}

// SAFETY: the handles are owned by this value and released once, in `Drop`. Embree allows
// concurrent queries on a committed scene from any thread; every change takes `&mut self`.
unsafe impl Send for EmbreeInstances {}
// SAFETY: as for `Send`: the only operations through `&self` are concurrent-safe queries.
unsafe impl Sync for EmbreeInstances {}

impl std::fmt::Debug for EmbreeInstances {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EmbreeInstances")
            .field("instances", &(self.instances.len() - 1))
            .finish_non_exhaustive()
    }
}

impl EmbreeInstances {
    /// Builds `mesh` and `ground` (high quality) and a top level with an instance of `mesh` per
    /// transform of `placements` and the ground under the identity, committed. The device
    /// builds with the current rayon pool's thread count.
    ///
    /// # Errors
    /// [`Error::Embree`] when Embree fails to create or build anything, or a transform is not
    /// finite.
    pub fn new(mesh: &Mesh, ground: &Mesh, placements: &[Affine3A]) -> Result<Self> {
        let device = new_device()?;
        let mut out = EmbreeInstances {
            device,
            prototype: ptr::null_mut(),
            ground: ptr::null_mut(),
            top: ptr::null_mut(),
            instances: Vec::with_capacity(placements.len() + 1),
        };
        out.prototype = out.mesh_scene(mesh)?;
        out.ground = out.mesh_scene(ground)?;
        out.top = out.new_scene()?;
        // SAFETY: `out.top` is a live, uncommitted scene.
        unsafe {
            sys::rtcSetSceneFlags(out.top, sys::RTCSceneFlags::DYNAMIC);
            sys::rtcSetSceneBuildQuality(out.top, BuildQuality::Low.to_sys());
        }
        for placement in placements {
            out.add_instance(out.prototype, placement)?;
        }
        out.add_instance(out.ground, &Affine3A::IDENTITY)?;
        out.commit()?;
        Ok(out)
    }

    /// How many instances of the mesh (the ground's not counted).
    pub fn len(&self) -> usize {
        self.instances.len() - 1
    }

    /// Are there no instances of the mesh?
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Moves instance `i` to `to_world` (seen by queries after [`EmbreeInstances::commit`]):
    /// rtcSetGeometryTransform and rtcCommitGeometry.
    ///
    /// # Errors
    /// [`Error::Embree`] when `i` is not an instance of the mesh or the transform is not
    /// finite.
    pub fn set_transform(&mut self, i: usize, to_world: &Affine3A) -> Result<()> {
        if i >= self.len() {
            return Err(Error::Embree(format!("no instance {i}")));
        }
        set_transform(self.instances[i], to_world)?;
        check(self.device, "rtcSetGeometryTransform")
    }

    /// Rebuilds the top level over the instances' current transforms: rtcCommitScene.
    ///
    /// # Errors
    /// [`Error::Embree`] when Embree reports an error while building.
    pub fn commit(&mut self) -> Result<()> {
        // SAFETY: `self.top` is a live scene whose geometries are committed; `&mut self`
        // keeps queries out.
        unsafe { sys::rtcCommitScene(self.top) };
        check(self.device, "rtcCommitScene")
    }

    /// Traces `rays` as [`super::EmbreeScene::trace`] does; [`EmbreeRays::instances`] then
    /// gives each hit's top-level instance.
    pub fn trace(&self, rays: &mut EmbreeRays, context: Context) {
        query(self, rays, context, false);
    }

    /// Asks whether each ray hits anything, as [`super::EmbreeScene::occlude`] does.
    pub fn occlude(&self, rays: &mut EmbreeRays, context: Context) {
        query(self, rays, context, true);
    }

    /// A new scene on this device, or the device's error.
    fn new_scene(&self) -> Result<sys::RTCScene> {
        // SAFETY: `self.device` is a live device handle.
        let scene = unsafe { sys::rtcNewScene(self.device) };
        check(self.device, "rtcNewScene")?;
        if scene.is_null() {
            return Err(Error::Embree("rtcNewScene failed".into()));
        }
        Ok(scene)
    }

    /// A committed high-quality scene holding `mesh` (none for an empty mesh).
    fn mesh_scene(&self, mesh: &Mesh) -> Result<sys::RTCScene> {
        let scene = self.new_scene()?;
        // SAFETY: `scene` is live and uncommitted.
        unsafe { sys::rtcSetSceneBuildQuality(scene, BuildQuality::High.to_sys()) };
        let built = if mesh.is_empty() {
            Ok(())
        } else {
            attach_triangles(self.device, scene, mesh, BuildQuality::High)
        };
        // SAFETY: `scene` is live; its geometry, if any, is committed.
        unsafe { sys::rtcCommitScene(scene) };
        match built.and_then(|()| check(self.device, "rtcCommitScene")) {
            Ok(()) => Ok(scene),
            Err(e) => {
                // SAFETY: `scene` is owned here and released once.
                unsafe { sys::rtcReleaseScene(scene) };
                Err(e)
            }
        }
    }

    /// Attaches an instance of `scene` under `to_world` to the top level.
    fn add_instance(&mut self, scene: sys::RTCScene, to_world: &Affine3A) -> Result<()> {
        // SAFETY: `self.device` is live; a failure returns null and is checked below.
        let geometry = unsafe { sys::rtcNewGeometry(self.device, sys::RTCGeometryType::INSTANCE) };
        if geometry.is_null() {
            check(self.device, "rtcNewGeometry")?;
            return Err(Error::Embree("rtcNewGeometry(INSTANCE) failed".into()));
        }
        // SAFETY: `geometry` is a live instance geometry and `scene` a committed scene of the
        // same device; the top level takes a reference of its own to the geometry, and this
        // value keeps its own until `Drop`.
        unsafe {
            sys::rtcSetGeometryInstancedScene(geometry, scene);
            sys::rtcAttachGeometry(self.top, geometry);
        }
        self.instances.push(geometry);
        set_transform(geometry, to_world)?;
        check(self.device, "attaching an instance")
    }
}

/// Sets `geometry`'s transform at time step 0 to `to_world` and commits the geometry.
fn set_transform(geometry: sys::RTCGeometry, to_world: &Affine3A) -> Result<()> {
    if !to_world.is_finite() {
        return Err(Error::Embree("a transform is not finite".into()));
    }
    // RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR: the three columns of the linear part, then the
    // translation.
    let m = to_world.matrix3;
    let t = to_world.translation;
    let columns: [f32; 12] = [
        m.x_axis.x, m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.y, m.y_axis.z, m.z_axis.x,
        m.z_axis.y, m.z_axis.z, t.x, t.y, t.z,
    ];
    // SAFETY: `geometry` is a live instance geometry; `columns` holds the 12 floats the format
    // names and outlives the call (Embree copies them).
    unsafe {
        sys::rtcSetGeometryTransform(
            geometry,
            0,
            sys::RTCFormat::FLOAT3X4_COLUMN_MAJOR,
            columns.as_ptr().cast(),
        );
        sys::rtcCommitGeometry(geometry);
    }
    Ok(())
}

impl Committed for EmbreeInstances {
    fn handle(&self) -> sys::RTCScene {
        self.top
    }
}

impl Drop for EmbreeInstances {
    fn drop(&mut self) {
        // SAFETY: every handle is owned by `self` and released exactly once; null scenes
        // (construction failed before they were made) are skipped. Geometries go before the
        // scenes they belong to, scenes before the device.
        unsafe {
            for &g in &self.instances {
                sys::rtcReleaseGeometry(g);
            }
            for scene in [self.top, self.ground, self.prototype] {
                if !scene.is_null() {
                    sys::rtcReleaseScene(scene);
                }
            }
            sys::rtcReleaseDevice(self.device);
        }
    }
}

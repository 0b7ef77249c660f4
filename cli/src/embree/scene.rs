//! Uploading a mesh to Embree: device, scene, one triangle geometry, BVH build.

use std::ffi::c_void;
use std::ffi::CString;
use std::ptr;
use std::sync::atomic::{AtomicIsize, Ordering};
use std::time::Instant;

use embree::sys;

use kdbeam::Mesh;

use crate::{Error, Result};

/// Embree's BVH build quality (`RTC_BUILD_QUALITY_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BuildQuality {
    /// Morton-code build: fastest to build, slowest to trace; Embree's choice for dynamic scenes.
    Low,
    /// Binned SAH: Embree's default.
    #[default]
    Medium,
    /// Binned SAH with spatial splits: slowest to build, fastest to trace.
    High,
}

impl BuildQuality {
    /// `low`, `medium` or `high`.
    pub fn name(self) -> &'static str {
        match self {
            BuildQuality::Low => "low",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        }
    }

    pub(super) fn to_sys(self) -> sys::RTCBuildQuality {
        match self {
            BuildQuality::Low => sys::RTCBuildQuality::LOW,
            BuildQuality::Medium => sys::RTCBuildQuality::MEDIUM,
            BuildQuality::High => sys::RTCBuildQuality::HIGH,
        }
    }
}

/// How Embree builds and traces a scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct EmbreeOptions {
    /// BVH build quality.
    pub quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: traversal and intersection avoid optimisations that lose
    /// accuracy, so that rays do not slip between triangles sharing an edge (the counterpart of
    /// kdbeam's watertight test).
    pub robust: bool,
}

impl Default for EmbreeOptions {
    /// Medium quality, robust.
    fn default() -> Self {
        EmbreeOptions {
            quality: BuildQuality::Medium,
            robust: true,
        }
    }
}

/// A mesh committed to Embree: one triangle geometry (geometry id 0) whose primitive ids are
/// the mesh's triangle indices.
///
/// Tracing is thread-safe (Embree allows concurrent queries on a committed scene); the scene
/// is immutable after [`EmbreeScene::new`].
pub struct EmbreeScene {
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    build_seconds: f64,
    /// The bytes the commit allocated and kept: the BVH.
    bvh_bytes: usize,
    options: EmbreeOptions,
    /// The bytes the device holds, kept by [`count_memory`]; boxed, so that its address, which
    /// the device holds, stays put. Dropped after the device (fields drop after `Drop::drop`).
    memory: Box<AtomicIsize>,
}

// SAFETY: the handles are owned by this value and released once, in `Drop`. Embree's device
// and committed scenes are reference-counted objects whose query functions (rtcIntersect*) may
// be called from any number of threads at once; nothing mutates the scene after `new`.
unsafe impl Send for EmbreeScene {}
// SAFETY: as for `Send`: the only operations through `&self` are concurrent-safe queries.
unsafe impl Sync for EmbreeScene {}

impl std::fmt::Debug for EmbreeScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EmbreeScene")
            .field("options", &self.options)
            .field("build_seconds", &self.build_seconds)
            .finish_non_exhaustive()
    }
}

impl EmbreeScene {
    /// `mesh` built with [`EmbreeOptions::default`] (medium quality, robust).
    ///
    /// # Errors
    /// As [`EmbreeScene::with_options`].
    pub fn new(mesh: &Mesh) -> Result<Self> {
        Self::with_options(mesh, &EmbreeOptions::default())
    }

    /// Uploads `mesh` to a new Embree device and builds its BVH.
    ///
    /// The device's build threads are the current rayon pool's thread count, so that Embree
    /// builds on as many cores as kdbeam's kd-tree build.
    /// [`EmbreeScene::build_seconds`] times everything from the new scene to the committed BVH,
    /// vertex and index upload included; creating the device is not timed. An empty mesh gives
    /// a scene without geometry, which every ray misses.
    ///
    /// # Errors
    /// [`Error::Embree`] when Embree fails to create the device or reports an error while
    /// building (out of memory, or a library without triangle support).
    pub fn with_options(mesh: &Mesh, options: &EmbreeOptions) -> Result<Self> {
        let device = new_device()?;
        let mut out = EmbreeScene {
            device,
            scene: ptr::null_mut(),
            build_seconds: 0.0,
            bvh_bytes: 0,
            options: *options,
            memory: Box::new(AtomicIsize::new(0)),
        };
        // SAFETY: `device` is live; the counter is boxed in `out`, which releases the device
        // before dropping it, so the pointer outlives every call of the monitor.
        unsafe {
            sys::rtcSetDeviceMemoryMonitorFunction(
                device,
                Some(count_memory),
                ptr::from_ref::<AtomicIsize>(&out.memory).cast_mut().cast(),
            );
        }
        let start = Instant::now();
        // SAFETY: `device` is a live device handle owned by `out`.
        out.scene = unsafe { sys::rtcNewScene(device) };
        out.check("rtcNewScene")?;
        if out.scene.is_null() {
            return Err(Error::Embree("rtcNewScene failed".into()));
        }
        let flags = if options.robust {
            sys::RTCSceneFlags::ROBUST
        } else {
            sys::RTCSceneFlags::NONE
        };
        // SAFETY: `out.scene` is a live, uncommitted scene handle.
        unsafe {
            sys::rtcSetSceneFlags(out.scene, flags);
            sys::rtcSetSceneBuildQuality(out.scene, options.quality.to_sys());
        }
        if !mesh.is_empty() {
            attach_triangles(out.device, out.scene, mesh, options.quality)?;
        }
        let uploaded = out.memory.load(Ordering::Relaxed);
        // SAFETY: `out.scene` is a live scene whose geometry is committed.
        unsafe { sys::rtcCommitScene(out.scene) };
        out.check("rtcCommitScene")?;
        out.build_seconds = start.elapsed().as_secs_f64();
        out.bvh_bytes = (out.memory.load(Ordering::Relaxed) - uploaded).max(0) as usize;
        Ok(out)
    }

    /// Wall-clock seconds the upload and BVH build took.
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    /// The bytes Embree allocated while building the BVH and holds after it (its memory
    /// monitor's count: the BVH's nodes and leaves; the copies of the vertices and indices
    /// uploaded before are not counted).
    pub fn bvh_bytes(&self) -> usize {
        self.bvh_bytes
    }

    /// The options the scene was built with.
    pub fn options(&self) -> EmbreeOptions {
        self.options
    }

    /// [`Error::Embree`] naming `what` when the device has recorded an error.
    fn check(&self, what: &str) -> Result<()> {
        check(self.device, what)
    }
}

impl super::query::Committed for EmbreeScene {
    fn handle(&self) -> sys::RTCScene {
        self.scene
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: both handles are owned by `self` and released exactly once; a null scene
        // (construction failed before it was made) is skipped.
        unsafe {
            if !self.scene.is_null() {
                sys::rtcReleaseScene(self.scene);
            }
            sys::rtcReleaseDevice(self.device);
        }
    }
}

/// Creates a triangle geometry on `device` holding a copy of `mesh`, built at `quality`, and
/// attaches it to `scene` (geometry 0 of a new scene).
pub(super) fn attach_triangles(
    device: sys::RTCDevice,
    scene: sys::RTCScene,
    mesh: &Mesh,
    quality: BuildQuality,
) -> Result<()> {
    let positions: &[f32] = bytemuck::cast_slice(mesh.positions());
    let indices: &[u32] = bytemuck::cast_slice(mesh.faces());
    // SAFETY: the caller's `device` is live; a failure returns null and is checked below.
    let geometry = unsafe { sys::rtcNewGeometry(device, sys::RTCGeometryType::TRIANGLE) };
    if geometry.is_null() {
        check(device, "rtcNewGeometry")?;
        return Err(Error::Embree("rtcNewGeometry failed".into()));
    }
    let filled = fill_buffer(
        device,
        geometry,
        sys::RTCBufferType::VERTEX,
        sys::RTCFormat::FLOAT3,
        positions,
    )
    .and_then(|()| {
        fill_buffer(
            device,
            geometry,
            sys::RTCBufferType::INDEX,
            sys::RTCFormat::UINT3,
            indices,
        )
    });
    if filled.is_ok() {
        // SAFETY: `geometry` is a live geometry with both buffers set; `scene` is a live scene
        // of the same device. Attaching takes a reference of its own.
        unsafe {
            sys::rtcSetGeometryBuildQuality(geometry, quality.to_sys());
            sys::rtcCommitGeometry(geometry);
            sys::rtcAttachGeometry(scene, geometry);
        }
    }
    // SAFETY: drops this function's reference; the scene keeps its own when attached.
    unsafe { sys::rtcReleaseGeometry(geometry) };
    filled?;
    check(device, "attaching the triangles")
}

/// Has Embree allocate slot 0 of `kind` for `data.len() / 3` items of three 4-byte components
/// (`format`) and copies `data` into it.
fn fill_buffer<T: bytemuck::Pod>(
    device: sys::RTCDevice,
    geometry: sys::RTCGeometry,
    kind: sys::RTCBufferType,
    format: sys::RTCFormat,
    data: &[T],
) -> Result<()> {
    debug_assert_eq!(std::mem::size_of::<T>(), 4);
    let items = data.len() / 3;
    // SAFETY: `geometry` is a live triangle geometry; a stride of 12 bytes is the packed layout
    // of FLOAT3 and UINT3. Embree returns null on failure (checked below).
    let buffer = unsafe { sys::rtcSetNewGeometryBuffer(geometry, kind, 0, format, 12, items) };
    if buffer.is_null() {
        check(device, "rtcSetNewGeometryBuffer")?;
        return Err(Error::Embree("rtcSetNewGeometryBuffer failed".into()));
    }
    // SAFETY: Embree allocated `items · 12` bytes at `buffer` (plus padding), aligned to at
    // least 16 bytes, for this geometry alone; nothing else reads or writes it until the
    // geometry is committed, and `data` is a different allocation.
    let dst = unsafe { std::slice::from_raw_parts_mut(buffer.cast::<T>(), 3 * items) };
    dst.copy_from_slice(&data[..3 * items]);
    Ok(())
}

/// [`Error::Embree`] naming `what` when `device` has recorded an error.
pub(super) fn check(device: sys::RTCDevice, what: &str) -> Result<()> {
    // SAFETY: the caller's `device` is a live device handle.
    match unsafe { sys::rtcGetDeviceError(device) } {
        sys::RTCError::NONE => Ok(()),
        code => Err(Error::Embree(format!("{what}: {code:?}"))),
    }
}

/// Embree's memory monitor: adds the `bytes` of each allocation (negative for a release) to
/// the counter at `counter`, and lets it happen.
///
/// # Safety
/// `counter` points to a live `AtomicIsize`.
unsafe extern "C" fn count_memory(counter: *mut c_void, bytes: sys::ssize_t, _post: bool) -> bool {
    // SAFETY: the caller's contract; the counter is only ever accessed atomically.
    let counter = unsafe { &*counter.cast::<AtomicIsize>() };
    counter.fetch_add(bytes, Ordering::Relaxed);
    true
}

/// A new Embree device that builds with the current rayon pool's threads, so that Embree
/// builds on as many cores as kdbeam.
pub(super) fn new_device() -> Result<sys::RTCDevice> {
    let config = CString::new(format!("threads={}", rayon::current_num_threads()))
        .expect("a formatted number holds no NUL");
    // SAFETY: `config` is a NUL-terminated string that outlives the call.
    let device = unsafe { sys::rtcNewDevice(config.as_ptr()) };
    if device.is_null() {
        return Err(Error::Embree("rtcNewDevice failed".into()));
    }
    Ok(device)
}

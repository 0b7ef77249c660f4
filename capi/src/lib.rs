//! The C ABI of kdbeam: scenes of meshes and instances, built and traced from C and C++.
//!
//! The header `include/kdbeam.h` is generated from this file by cbindgen (the test
//! `tests/header.rs` fails when it is stale) and documents every function. Every function
//! catches panics (none crosses the boundary), checks its pointers, and reports failures by
//! its return value and [`kdbeam_last_error`].
#![deny(clippy::undocumented_unsafe_blocks)]

mod last_error;

use std::ffi::{c_char, c_int};
use std::slice;

use glam::Affine3A;
use kdbeam::scene::world::{InstanceId, Query, Scene, SceneHit};
use kdbeam::{BuildParams, GeometryId, Mesh, Ray, Vec3};

use last_error::{guard, Failure};

/// The id of no geometry and no instance: returned on failure, and in the ids of a miss.
pub const KDBEAM_INVALID_ID: u32 = u32::MAX;

/// Success.
pub const KDBEAM_OK: i32 = 0;
/// A pointer argument was NULL.
pub const KDBEAM_ERROR_NULL_POINTER: i32 = -1;
/// An argument out of its range (a count too large, a bad build parameter).
pub const KDBEAM_ERROR_INVALID_ARGUMENT: i32 = -2;
/// A geometry or instance id this scene never issued, or one removed.
pub const KDBEAM_ERROR_UNKNOWN_ID: i32 = -3;
/// The scene was traced before its first successful `kdbeam_scene_commit`.
pub const KDBEAM_ERROR_NOT_COMMITTED: i32 = -4;
/// A mesh with a NaN or infinite coordinate, an index out of range, or (update) another vertex
/// count.
pub const KDBEAM_ERROR_INVALID_MESH: i32 = -5;
/// A transform with a NaN or infinite entry, or one that cannot be inverted.
pub const KDBEAM_ERROR_INVALID_TRANSFORM: i32 = -6;
/// A geometry still used by instances cannot be removed.
pub const KDBEAM_ERROR_IN_USE: i32 = -7;
/// Not a failure: `kdbeam_scene_get_build_params` on a scene that sizes each mesh's tree by
/// its own triangles (no parameters set for every mesh).
pub const KDBEAM_BUILD_PARAMS_PER_MESH: i32 = 1;
/// A bug in kdbeam, caught before it reached the caller.
pub const KDBEAM_ERROR_INTERNAL: i32 = -99;

/// A scene: meshes, instances of them, and the trees built by the last commit. Opaque.
pub struct KdbeamScene(Scene);

/// The kd-tree build parameters of a scene's meshes. A new scene sizes each mesh's tree by its
/// own triangles (`kdbeam_scene_get_geometry_build_params` says with what);
/// `kdbeam_scene_set_build_params` sets one for every mesh instead. Fill one with
/// `kdbeam_build_params_default` or `kdbeam_build_params_for_incoherent_rays` and change what
/// you need.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdbeamBuildParams {
    /// The cost of a ray–triangle test over that of a traversal step: larger values build
    /// bigger trees with smaller leaves. Finite and > 0. The default (0.05) serves camera and
    /// shadow rays, which trace in packets; single incoherent rays want more
    /// (`kdbeam_build_params_for_incoherent_rays`).
    pub ci_over_ct: f32,
    /// The fraction by which a split's cost is reduced when one side is empty, in `[0, 1)`.
    pub empty_bonus: f32,
    /// The deepest a tree may grow, at most 64; 0 for the default rule, `8 + 1.3·log2(N)` for
    /// `N` triangles.
    pub max_depth: u32,
    /// Nodes with at most this many triangles become leaves (at least 1).
    pub leaf_size: u32,
    /// Nodes with at most this many triangles choose their split exactly, larger ones among
    /// binned candidates: lower builds faster, with slightly costlier trees.
    pub exact_search_max: u32,
}

impl From<&BuildParams> for KdbeamBuildParams {
    fn from(p: &BuildParams) -> KdbeamBuildParams {
        KdbeamBuildParams {
            ci_over_ct: p.ci_over_ct,
            empty_bonus: p.empty_bonus,
            max_depth: p.max_depth.unwrap_or(0),
            leaf_size: p.leaf_size,
            exact_search_max: p.exact_search_max,
        }
    }
}

impl From<&KdbeamBuildParams> for BuildParams {
    fn from(p: &KdbeamBuildParams) -> BuildParams {
        BuildParams::default()
            .with_ci_over_ct(p.ci_over_ct)
            .with_empty_bonus(p.empty_bonus)
            .with_max_depth((p.max_depth != 0).then_some(p.max_depth))
            .with_leaf_size(p.leaf_size)
            .with_exact_search_max(p.exact_search_max)
    }
}

/// A ray `org + t·dir` over `[tnear, tfar]`. `dir` need not be normalised; `tfar` may be
/// `INFINITY`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdbeamRay {
    pub org_x: f32,
    pub org_y: f32,
    pub org_z: f32,
    pub tnear: f32,
    pub dir_x: f32,
    pub dir_y: f32,
    pub dir_z: f32,
    pub tfar: f32,
}

/// A hit: `t` along the ray, barycentrics `u` (of the triangle's second vertex) and `v` (of
/// its third), the triangle's index in its mesh, the mesh's geometry id and the instance id
/// (`KDBEAM_INVALID_ID` for a mesh added with `kdbeam_scene_add_mesh`). A miss has `t =
/// INFINITY` and every id `KDBEAM_INVALID_ID`.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdbeamHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub triangle: u32,
    pub geometry: u32,
    pub instance: u32,
}

const MISS: KdbeamHit = KdbeamHit {
    t: f32::INFINITY,
    u: 0.0,
    v: 0.0,
    triangle: KDBEAM_INVALID_ID,
    geometry: KDBEAM_INVALID_ID,
    instance: KDBEAM_INVALID_ID,
};

impl From<&KdbeamRay> for Ray {
    fn from(r: &KdbeamRay) -> Ray {
        Ray {
            origin: Vec3::new(r.org_x, r.org_y, r.org_z),
            direction: Vec3::new(r.dir_x, r.dir_y, r.dir_z),
            tmin: r.tnear,
            tmax: r.tfar,
        }
    }
}

impl From<SceneHit> for KdbeamHit {
    fn from(h: SceneHit) -> KdbeamHit {
        if !h.is_hit() {
            return MISS;
        }
        KdbeamHit {
            t: h.t,
            u: h.u,
            v: h.v,
            triangle: h.triangle,
            geometry: h.geometry.0,
            instance: h.instance.0,
        }
    }
}

/// `&T` from a pointer that is NULL or valid.
///
/// # Safety
/// `p` is NULL or points to a live `T` not written during `'a`.
unsafe fn deref<'a, T>(p: *const T, what: &str) -> Result<&'a T, Failure> {
    // SAFETY: the caller promises `p` is NULL (None) or valid for reads.
    unsafe { p.as_ref() }.ok_or_else(|| Failure::null(what))
}

/// `&mut T` from a pointer that is NULL or valid.
///
/// # Safety
/// `p` is NULL or points to a live `T` not otherwise accessed during `'a`.
unsafe fn deref_mut<'a, T>(p: *mut T, what: &str) -> Result<&'a mut T, Failure> {
    // SAFETY: the caller promises `p` is NULL (None) or valid and unaliased.
    unsafe { p.as_mut() }.ok_or_else(|| Failure::null(what))
}

/// The `count` items at `p`; NULL is allowed for `count == 0`.
///
/// # Safety
/// When `count > 0`, `p` is NULL or points to `count` live, initialised `T`.
unsafe fn items<'a, T>(p: *const T, count: usize, what: &str) -> Result<&'a [T], Failure> {
    if count == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(Failure::null(what));
    }
    if count
        .checked_mul(size_of::<T>())
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Failure::new(
            KDBEAM_ERROR_INVALID_ARGUMENT,
            format!("{what}: {count} items do not fit in memory"),
        ));
    }
    // SAFETY: non-NULL, `count` items that the caller promises are live, within isize::MAX
    // bytes (checked).
    Ok(unsafe { slice::from_raw_parts(p, count) })
}

/// [`items`] for writing.
///
/// # Safety
/// When `count > 0`, `p` is NULL or points to `count` writable `T` not otherwise accessed.
unsafe fn items_mut<'a, T>(p: *mut T, count: usize, what: &str) -> Result<&'a mut [T], Failure> {
    if count == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(Failure::null(what));
    }
    if count
        .checked_mul(size_of::<T>())
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Failure::new(
            KDBEAM_ERROR_INVALID_ARGUMENT,
            format!("{what}: {count} items do not fit in memory"),
        ));
    }
    // SAFETY: as in `items`, and the caller promises no other access.
    Ok(unsafe { slice::from_raw_parts_mut(p, count) })
}

/// A mesh from the caller's buffers (copied).
///
/// # Safety
/// As [`items`] for `vertex_count * 3` floats and `triangle_count * 3` indices.
unsafe fn mesh_from(
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
) -> Result<Mesh, Failure> {
    let too_many = |what: &str| {
        Failure::new(
            KDBEAM_ERROR_INVALID_ARGUMENT,
            format!("{what} count overflows"),
        )
    };
    let floats = vertex_count
        .checked_mul(3)
        .ok_or_else(|| too_many("vertex"))?;
    let index_count = triangle_count
        .checked_mul(3)
        .ok_or_else(|| too_many("triangle"))?;
    // SAFETY: the caller's promise, passed on.
    let positions = unsafe { items(positions, floats, "positions") }?;
    // SAFETY: the caller's promise, passed on.
    let indices = unsafe { items(indices, index_count, "indices") }?;
    let positions: Vec<[f32; 3]> = positions
        .chunks_exact(3)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    Ok(Mesh::from_indexed(&positions, indices)?)
}

/// An affine transform from 12 floats, column-major 3×4.
///
/// # Safety
/// `m` is NULL or points to 12 floats.
unsafe fn transform_from(m: *const f32) -> Result<Affine3A, Failure> {
    // SAFETY: the caller's promise.
    let m = unsafe { items(m, 12, "transform") }?;
    let mut cols = [0f32; 12];
    cols.copy_from_slice(m);
    Ok(Affine3A::from_cols_array(&cols))
}

/// Creates an empty scene. Free it with `kdbeam_scene_free`. Returns NULL only if kdbeam
/// failed internally (`kdbeam_last_error` says why).
#[no_mangle]
pub extern "C" fn kdbeam_scene_new() -> *mut KdbeamScene {
    guard(
        |_| std::ptr::null_mut(),
        || Ok(Box::into_raw(Box::new(KdbeamScene(Scene::new())))),
    )
}

/// Frees a scene made by `kdbeam_scene_new` (NULL: nothing happens). The scene must not be
/// used afterwards, nor be traced by another thread meanwhile.
///
/// # Safety
/// `scene` is NULL or a scene from `kdbeam_scene_new` not yet freed.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_free(scene: *mut KdbeamScene) {
    guard(
        |_| (),
        || {
            if !scene.is_null() {
                // SAFETY: the caller passes a pointer from `Box::into_raw` in
                // `kdbeam_scene_new`, not freed before.
                drop(unsafe { Box::from_raw(scene) });
            }
            Ok(())
        },
    )
}

/// Adds a mesh traced as it is: `vertex_count` xyz positions (`3 * vertex_count` floats) and
/// `triangle_count` triangles (`3 * triangle_count` indices). The buffers are copied. Its hits
/// have `instance = KDBEAM_INVALID_ID`; it may also be instanced. Returns the geometry id (0, 1,
/// … in the order added; ids are never reused), or `KDBEAM_INVALID_ID` with
/// `kdbeam_last_error()` set (NULL pointer, a NaN or infinite coordinate, an index out of
/// range). Seen by queries after the next commit.
///
/// # Safety
/// `scene` is NULL or a live scene; `positions` and `indices` are NULL or point to as many
/// values as said (NULL is allowed for a count of 0).
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_add_mesh(
    scene: *mut KdbeamScene,
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
) -> u32 {
    guard(
        |_| KDBEAM_INVALID_ID,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            // SAFETY: the caller's promise.
            let mesh = unsafe { mesh_from(positions, vertex_count, indices, triangle_count) }?;
            Ok(scene.0.add_mesh(mesh)?.0)
        },
    )
}

/// As `kdbeam_scene_add_mesh`, but the mesh is traced only through its instances
/// (`kdbeam_scene_add_instance`).
///
/// # Safety
/// As `kdbeam_scene_add_mesh`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_add_prototype(
    scene: *mut KdbeamScene,
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
) -> u32 {
    guard(
        |_| KDBEAM_INVALID_ID,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            // SAFETY: the caller's promise.
            let mesh = unsafe { mesh_from(positions, vertex_count, indices, triangle_count) }?;
            Ok(scene.0.add_prototype(mesh)?.0)
        },
    )
}

/// Gives a mesh new positions (`3 * vertex_count` floats, copied), its triangles unchanged;
/// `vertex_count` must be the mesh's. The next commit rebuilds its tree. Returns 0, or an error
/// code (the mesh unchanged).
///
/// # Safety
/// `scene` is NULL or a live scene; `positions` as in `kdbeam_scene_add_mesh`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_update_positions(
    scene: *mut KdbeamScene,
    geometry: u32,
    positions: *const f32,
    vertex_count: usize,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            let floats = vertex_count.checked_mul(3).ok_or_else(|| {
                Failure::new(KDBEAM_ERROR_INVALID_ARGUMENT, "vertex count overflows")
            })?;
            // SAFETY: the caller's promise.
            let p = unsafe { items(positions, floats, "positions") }?;
            let p: Vec<[f32; 3]> = p.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
            scene.0.update_positions(GeometryId(geometry), &p)?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Removes a mesh (its id is never issued again). Fails with `KDBEAM_ERROR_IN_USE` while
/// instances of it remain. Returns 0, or an error code.
///
/// # Safety
/// `scene` is NULL or a live scene.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_remove_geometry(
    scene: *mut KdbeamScene,
    geometry: u32,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            scene.0.remove_geometry(GeometryId(geometry))?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Adds an instance of a mesh: `transform` is 12 floats, a 3×4 matrix in column-major order
/// (the images of the x, y and z axes, then the translation) taking the mesh to world space.
/// The instance is seen by rays whose mask shares a bit with `mask` (`0xFFFFFFFF`: every
/// ray). Returns the instance id (0, 1, … in the order added, never reused), or
/// `KDBEAM_INVALID_ID` with `kdbeam_last_error()` set (unknown geometry, a NaN, infinite or
/// singular transform).
///
/// # Safety
/// `scene` is NULL or a live scene; `transform` is NULL or points to 12 floats.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_add_instance(
    scene: *mut KdbeamScene,
    geometry: u32,
    transform: *const f32,
    mask: u32,
) -> u32 {
    guard(
        |_| KDBEAM_INVALID_ID,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            // SAFETY: the caller's promise.
            let m = unsafe { transform_from(transform) }?;
            Ok(scene
                .0
                .add_instance_masked(GeometryId(geometry), m, mask)?
                .0)
        },
    )
}

/// Moves an instance: `transform` as in `kdbeam_scene_add_instance`. Returns 0, or an error
/// code (the instance unchanged).
///
/// # Safety
/// `scene` is NULL or a live scene; `transform` is NULL or points to 12 floats.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_set_transform(
    scene: *mut KdbeamScene,
    instance: u32,
    transform: *const f32,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            // SAFETY: the caller's promise.
            let m = unsafe { transform_from(transform) }?;
            scene.0.set_transform(InstanceId(instance), m)?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Sets an instance's mask (see `kdbeam_scene_add_instance`). Returns 0, or an error code.
///
/// # Safety
/// `scene` is NULL or a live scene.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_set_instance_mask(
    scene: *mut KdbeamScene,
    instance: u32,
    mask: u32,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            scene.0.set_instance_mask(InstanceId(instance), mask)?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Removes an instance (its id is never issued again). Returns 0, or an error code.
///
/// # Safety
/// `scene` is NULL or a live scene.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_remove_instance(
    scene: *mut KdbeamScene,
    instance: u32,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            scene.0.remove_instance(InstanceId(instance))?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Applies every change since the last commit: builds the kd-trees of new and updated meshes
/// (in parallel) and the top level over the instances. Must not overlap any other call on this
/// scene. Returns 0, or an error code (queries then see the previous commit).
///
/// # Safety
/// `scene` is NULL or a live scene.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_commit(scene: *mut KdbeamScene) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            scene.0.commit()?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Writes the default build parameters to `*params`: the tree for camera and shadow rays
/// (traced in packets) of a mesh of even triangles, which a new scene gives such a mesh.
/// Returns 0, or `KDBEAM_ERROR_NULL_POINTER`.
///
/// # Safety
/// `params` is NULL or points to a writable `KdbeamBuildParams`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_build_params_default(params: *mut KdbeamBuildParams) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let params = unsafe { deref_mut(params, "params") }?;
            *params = KdbeamBuildParams::from(&BuildParams::default());
            Ok(KDBEAM_OK)
        },
    )
}

/// Writes `of(scene)`'s parameters to `*params` and returns its code.
///
/// # Safety
/// As `kdbeam_scene_get_build_params`.
unsafe fn write_build_params(
    scene: *const KdbeamScene,
    params: *mut KdbeamBuildParams,
    of: impl FnOnce(&Scene) -> Result<(BuildParams, c_int), Failure>,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref(scene, "scene") }?;
            // SAFETY: the caller's promise.
            let params = unsafe { deref_mut(params, "params") }?;
            let (chosen, code) = of(&scene.0)?;
            *params = KdbeamBuildParams::from(&chosen);
            Ok(code)
        },
    )
}

/// Writes to `*params` the build parameters for a scene traced mostly by single incoherent
/// rays (ambient occlusion, diffuse bounces, rays from anywhere) on the ISA `scene` traces
/// with: smaller leaves than the default below 16 SIMD lanes, the default on AVX-512. Returns
/// 0, or `KDBEAM_ERROR_NULL_POINTER`.
///
/// # Safety
/// `scene` is NULL or a live scene; `params` is NULL or points to a writable
/// `KdbeamBuildParams`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_build_params_for_incoherent_rays(
    scene: *const KdbeamScene,
    params: *mut KdbeamBuildParams,
) -> c_int {
    // SAFETY: the caller's promise, passed on.
    unsafe {
        write_build_params(scene, params, |s| {
            Ok((BuildParams::for_incoherent_rays(s.isa()), KDBEAM_OK))
        })
    }
}

/// Writes the build parameters set for every mesh of the scene to `*params` and returns 0.
/// When none are set (a new scene, or after `kdbeam_scene_reset_build_params`: each mesh's
/// tree sized by its own triangles) writes the default parameters and returns
/// `KDBEAM_BUILD_PARAMS_PER_MESH`. Returns `KDBEAM_ERROR_NULL_POINTER` for a NULL argument.
///
/// # Safety
/// `scene` is NULL or a live scene; `params` is NULL or points to a writable
/// `KdbeamBuildParams`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_get_build_params(
    scene: *const KdbeamScene,
    params: *mut KdbeamBuildParams,
) -> c_int {
    // SAFETY: the caller's promise, passed on.
    unsafe {
        write_build_params(scene, params, |s| {
            Ok(match s.build_params() {
                Some(set) => (*set, KDBEAM_OK),
                None => (BuildParams::default(), KDBEAM_BUILD_PARAMS_PER_MESH),
            })
        })
    }
}

/// Writes to `*params` the build parameters of a mesh's tree: those set for every mesh, or
/// else the mesh's own, sized by its triangles (a mesh whose surface is held by a few large
/// triangles, such as an interior's walls, gets a bigger tree than one of even triangles).
/// Returns 0, `KDBEAM_ERROR_NULL_POINTER`, or `KDBEAM_ERROR_UNKNOWN_ID`.
///
/// # Safety
/// `scene` is NULL or a live scene; `params` is NULL or points to a writable
/// `KdbeamBuildParams`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_get_geometry_build_params(
    scene: *const KdbeamScene,
    geometry: u32,
    params: *mut KdbeamBuildParams,
) -> c_int {
    // SAFETY: the caller's promise, passed on.
    unsafe {
        write_build_params(scene, params, |s| {
            Ok((s.geometry_build_params(GeometryId(geometry))?, KDBEAM_OK))
        })
    }
}

/// Sets the build parameters of every mesh of the scene; the next commit rebuilds the trees
/// built with others. Returns 0, `KDBEAM_ERROR_NULL_POINTER`, or
/// `KDBEAM_ERROR_INVALID_ARGUMENT` for a value out of its range (a NaN or non-positive
/// `ci_over_ct`, an `empty_bonus` outside `[0, 1)`, a `max_depth` above 64, a `leaf_size` of
/// 0), which leaves the scene unchanged. Must not overlap any other call on this scene.
///
/// # Safety
/// `scene` is NULL or a live scene; `params` is NULL or points to a `KdbeamBuildParams`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_set_build_params(
    scene: *mut KdbeamScene,
    params: *const KdbeamBuildParams,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            // SAFETY: the caller's promise.
            let params = unsafe { deref(params, "params") }?;
            scene.0.set_build_params(BuildParams::from(params))?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Back to the default: each mesh's tree sized by its own triangles; the next commit rebuilds
/// the trees built with others. Returns 0, or `KDBEAM_ERROR_NULL_POINTER`. Must not
/// overlap any other call on this scene.
///
/// # Safety
/// `scene` is NULL or a live scene.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_scene_reset_build_params(scene: *mut KdbeamScene) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref_mut(scene, "scene") }?;
            scene.0.reset_build_params();
            Ok(KDBEAM_OK)
        },
    )
}

/// The committed scene, or the failure of tracing one never committed.
fn committed(scene: &KdbeamScene) -> Result<&Scene, Failure> {
    if scene.0.is_committed() {
        Ok(&scene.0)
    } else {
        Err(kdbeam::Error::NotCommitted.into())
    }
}

/// The closest hit of `*ray` seen by instances whose mask shares a bit with `mask`.
///
/// # Safety
/// As `kdbeam_intersect1`.
unsafe fn intersect_masked(
    scene: *const KdbeamScene,
    ray: *const KdbeamRay,
    hit: *mut KdbeamHit,
    mask: u32,
) {
    guard(
        |_| (),
        || {
            // SAFETY: the caller's promise.
            let hit = unsafe { deref_mut(hit, "hit") }?;
            *hit = MISS;
            // SAFETY: the caller's promise.
            let scene = committed(unsafe { deref(scene, "scene") }?)?;
            // SAFETY: the caller's promise.
            let ray = Ray::from(unsafe { deref(ray, "ray") }?);
            *hit = scene
                .intersect_with(&ray, &Query { mask, filter: None })
                .into();
            Ok(())
        },
    )
}

/// Whether `*ray` is occluded among instances whose mask shares a bit with `mask`.
///
/// # Safety
/// As `kdbeam_occluded1`.
unsafe fn occluded_masked(scene: *const KdbeamScene, ray: *const KdbeamRay, mask: u32) -> bool {
    guard(
        |_| false,
        || {
            // SAFETY: the caller's promise.
            let scene = committed(unsafe { deref(scene, "scene") }?)?;
            // SAFETY: the caller's promise.
            let ray = Ray::from(unsafe { deref(ray, "ray") }?);
            Ok(scene.occluded_with(&ray, &Query { mask, filter: None }))
        },
    )
}

/// Writes the closest hit of `*ray` in the committed scene to `*hit`: a miss (`t = INFINITY`,
/// ids `KDBEAM_INVALID_ID`) when nothing is hit in `[tnear, tfar]`, for a ray with a NaN or
/// infinite component, a zero direction or `tnear > tfar`, and — with `kdbeam_last_error()`
/// set — for a NULL `scene` or `ray` or a scene never committed. Nothing is written when `hit`
/// is NULL. Many threads may trace one scene at once, but not while it is changed or committed.
///
/// # Safety
/// Each pointer is NULL or valid; `scene` is a live scene.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_intersect1(
    scene: *const KdbeamScene,
    ray: *const KdbeamRay,
    hit: *mut KdbeamHit,
) {
    // SAFETY: the caller's promise, passed on.
    unsafe { intersect_masked(scene, ray, hit, u32::MAX) }
}

/// `kdbeam_intersect1` seeing only the instances whose mask shares a bit with `mask` (meshes
/// added with `kdbeam_scene_add_mesh` are seen by every non-zero mask).
///
/// # Safety
/// As `kdbeam_intersect1`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_intersect1_masked(
    scene: *const KdbeamScene,
    ray: *const KdbeamRay,
    mask: u32,
    hit: *mut KdbeamHit,
) {
    // SAFETY: the caller's promise, passed on.
    unsafe { intersect_masked(scene, ray, hit, mask) }
}

/// Whether anything is hit in `[tnear, tfar]` (a shadow ray). `false` for a ray that cannot be
/// traced (as in `kdbeam_intersect1`), and — with `kdbeam_last_error()` set — for a NULL
/// `scene` or `ray` or a scene never committed.
///
/// # Safety
/// As `kdbeam_intersect1`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_occluded1(
    scene: *const KdbeamScene,
    ray: *const KdbeamRay,
) -> bool {
    // SAFETY: the caller's promise, passed on.
    unsafe { occluded_masked(scene, ray, u32::MAX) }
}

/// `kdbeam_occluded1` seeing only the instances whose mask shares a bit with `mask`.
///
/// # Safety
/// As `kdbeam_intersect1`.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_occluded1_masked(
    scene: *const KdbeamScene,
    ray: *const KdbeamRay,
    mask: u32,
) -> bool {
    // SAFETY: the caller's promise, passed on.
    unsafe { occluded_masked(scene, ray, mask) }
}

/// The closest hits of `count` rays, `hits[i]` for `rays[i]` (each as `kdbeam_intersect1`),
/// traced on all cores. Returns 0; or an error code — for a NULL pointer (with `count > 0`)
/// nothing is written, for a scene never committed every hit is a miss.
///
/// # Safety
/// `scene` is NULL or a live scene; `rays` and `hits` are NULL or point to `count` rays and
/// `count` writable hits.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_intersect_stream(
    scene: *const KdbeamScene,
    rays: *const KdbeamRay,
    hits: *mut KdbeamHit,
    count: usize,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let hits = unsafe { items_mut(hits, count, "hits") }?;
            // SAFETY: the caller's promise.
            let rays = unsafe { items(rays, count, "rays") }?;
            hits.fill(MISS);
            // SAFETY: the caller's promise.
            let scene = committed(unsafe { deref(scene, "scene") }?)?;
            let rays: Vec<Ray> = rays.iter().map(Ray::from).collect();
            let mut out = vec![SceneHit::NONE; rays.len()];
            scene.intersect_stream(&rays, &mut out, &Query::default())?;
            for (h, o) in hits.iter_mut().zip(out) {
                *h = o.into();
            }
            Ok(KDBEAM_OK)
        },
    )
}

/// Whether each of `count` rays is occluded, `occluded[i]` for `rays[i]` (each as
/// `kdbeam_occluded1`), traced on all cores. Returns 0; or an error code — for a NULL pointer
/// (with `count > 0`) nothing is written, for a scene never committed every entry is `false`.
///
/// # Safety
/// As `kdbeam_intersect_stream`, `occluded` pointing to `count` writable bools.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_occluded_stream(
    scene: *const KdbeamScene,
    rays: *const KdbeamRay,
    occluded: *mut bool,
    count: usize,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let out = unsafe { items_mut(occluded, count, "occluded") }?;
            // SAFETY: the caller's promise.
            let rays = unsafe { items(rays, count, "rays") }?;
            out.fill(false);
            // SAFETY: the caller's promise.
            let scene = committed(unsafe { deref(scene, "scene") }?)?;
            let rays: Vec<Ray> = rays.iter().map(Ray::from).collect();
            scene.occluded_stream(&rays, out, &Query::default())?;
            Ok(KDBEAM_OK)
        },
    )
}

/// Writes the unit geometric normal of `*hit` in world space to `normal[0..3]`: the triangle's
/// `(v1 − v0) × (v2 − v0)` carried by the inverse transpose of its instance's transform.
/// Returns 0, or an error code for a NULL pointer, a miss, a degenerate triangle or a hit the
/// last commit does not hold (`normal` then untouched).
///
/// # Safety
/// Each pointer is NULL or valid; `normal` points to 3 writable floats.
#[no_mangle]
pub unsafe extern "C" fn kdbeam_hit_normal(
    scene: *const KdbeamScene,
    hit: *const KdbeamHit,
    normal: *mut f32,
) -> c_int {
    guard(
        |code| code,
        || {
            // SAFETY: the caller's promise.
            let scene = unsafe { deref(scene, "scene") }?;
            // SAFETY: the caller's promise.
            let hit = unsafe { deref(hit, "hit") }?;
            // SAFETY: the caller's promise.
            let normal = unsafe { items_mut(normal, 3, "normal") }?;
            let h = SceneHit {
                t: hit.t,
                u: hit.u,
                v: hit.v,
                triangle: hit.triangle,
                geometry: GeometryId(hit.geometry),
                instance: InstanceId(hit.instance),
            };
            let n = scene.0.normal(&h).ok_or_else(|| {
                Failure::new(
                    KDBEAM_ERROR_INVALID_ARGUMENT,
                    "no normal: a miss, a degenerate triangle, or a hit of another commit",
                )
            })?;
            normal.copy_from_slice(&n.to_array());
            Ok(KDBEAM_OK)
        },
    )
}

/// The text of the error of the last `kdbeam_*` call on this thread: "" when it succeeded.
/// Never NULL. Each thread has its own; the text stays valid until this thread's next
/// `kdbeam_*` call (other than `kdbeam_last_error`).
#[no_mangle]
pub extern "C" fn kdbeam_last_error() -> *const c_char {
    last_error::text()
}

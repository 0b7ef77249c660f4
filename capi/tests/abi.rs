//! The C ABI called as C would: null pointers, NaN rays, a scene never committed, stale ids,
//! the per-thread last error, streams against single rays.

use std::ffi::CStr;
use std::ptr::{null, null_mut};

use kdbeam_capi::*;

fn last_error() -> String {
    // SAFETY: kdbeam_last_error never returns NULL, and the text lives until the next call.
    unsafe { CStr::from_ptr(kdbeam_last_error()) }
        .to_string_lossy()
        .into_owned()
}

const POSITIONS: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
const INDICES: [u32; 3] = [0, 1, 2];

fn ray(z: f32) -> KdbeamRay {
    KdbeamRay {
        org_x: 0.2,
        org_y: 0.2,
        org_z: z,
        tnear: 0.0,
        dir_x: 0.0,
        dir_y: 0.0,
        dir_z: 1.0,
        tfar: f32::INFINITY,
    }
}

fn translation(z: f32) -> [f32; 12] {
    [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, z]
}

#[test]
fn a_scene_through_the_c_abi() {
    // SAFETY: every pointer below is NULL (which the functions must reject) or valid.
    unsafe {
        let scene = kdbeam_scene_new();
        assert!(!scene.is_null());
        let mut hit = KdbeamHit {
            t: 0.0,
            u: 0.0,
            v: 0.0,
            triangle: 0,
            geometry: 0,
            instance: 0,
        };

        // Never committed: a miss with the error set.
        kdbeam_intersect1(scene, &ray(-5.0), &mut hit);
        assert_eq!(
            (hit.t, hit.geometry, hit.instance, hit.triangle),
            (
                f32::INFINITY,
                KDBEAM_INVALID_ID,
                KDBEAM_INVALID_ID,
                KDBEAM_INVALID_ID
            )
        );
        assert!(last_error().contains("never committed"), "{}", last_error());
        assert!(!kdbeam_occluded1(scene, &ray(-5.0)));
        assert!(!last_error().is_empty());
        let mut hits = [hit; 2];
        assert_eq!(
            kdbeam_intersect_stream(scene, [ray(-5.0); 2].as_ptr(), hits.as_mut_ptr(), 2),
            KDBEAM_ERROR_NOT_COMMITTED
        );

        // Meshes: ids in order; bad input rejected with a typed code and a message.
        assert_eq!(
            kdbeam_scene_add_mesh(scene, POSITIONS.as_ptr(), 3, INDICES.as_ptr(), 1),
            0
        );
        assert_eq!(last_error(), "");
        assert_eq!(
            kdbeam_scene_add_mesh(scene, null(), 3, INDICES.as_ptr(), 1),
            KDBEAM_INVALID_ID
        );
        assert!(last_error().contains("positions is NULL"));
        assert_eq!(
            kdbeam_scene_add_mesh(scene, POSITIONS.as_ptr(), 3, [0, 1, 7].as_ptr(), 1),
            KDBEAM_INVALID_ID
        );
        assert!(last_error().contains("vertex 7"), "{}", last_error());
        let nan = [f32::NAN; 9];
        assert_eq!(
            kdbeam_scene_add_mesh(scene, nan.as_ptr(), 3, INDICES.as_ptr(), 1),
            KDBEAM_INVALID_ID
        );
        assert_eq!(
            kdbeam_scene_add_mesh(null_mut(), POSITIONS.as_ptr(), 3, INDICES.as_ptr(), 1),
            KDBEAM_INVALID_ID
        );
        assert_eq!(
            kdbeam_scene_add_mesh(scene, POSITIONS.as_ptr(), usize::MAX, INDICES.as_ptr(), 1),
            KDBEAM_INVALID_ID
        );
        let proto = kdbeam_scene_add_prototype(scene, POSITIONS.as_ptr(), 3, INDICES.as_ptr(), 1);
        assert_eq!(proto, 1);
        assert_eq!(
            kdbeam_scene_add_instance(scene, proto, translation(2.0).as_ptr(), 0b01),
            0
        );
        assert_eq!(
            kdbeam_scene_add_instance(scene, proto, translation(-1.0).as_ptr(), 0b10),
            1
        );
        let singular = [0.0f32; 12];
        assert_eq!(
            kdbeam_scene_add_instance(scene, proto, singular.as_ptr(), 1),
            KDBEAM_INVALID_ID
        );
        assert!(last_error().contains("transform"));
        assert_eq!(
            kdbeam_scene_add_instance(scene, 9, translation(0.0).as_ptr(), 1),
            KDBEAM_INVALID_ID
        );
        assert_eq!(kdbeam_scene_commit(scene), KDBEAM_OK);
        assert_eq!(kdbeam_scene_commit(null_mut()), KDBEAM_ERROR_NULL_POINTER);

        // Closest hits, masks, normals.
        kdbeam_intersect1(scene, &ray(-5.0), &mut hit);
        assert_eq!((hit.t, hit.geometry, hit.instance), (4.0, proto, 1));
        kdbeam_intersect1_masked(scene, &ray(-5.0), 0b01, &mut hit);
        assert_eq!(
            (hit.t, hit.geometry, hit.instance),
            (5.0, 0, KDBEAM_INVALID_ID)
        );
        let mut n = [0f32; 3];
        assert_eq!(kdbeam_hit_normal(scene, &hit, n.as_mut_ptr()), KDBEAM_OK);
        assert_eq!(n, [0.0, 0.0, 1.0]);
        assert!(kdbeam_occluded1(scene, &ray(-5.0)));
        assert!(!kdbeam_occluded1_masked(scene, &ray(1.5), 0b10));
        assert!(kdbeam_occluded1_masked(scene, &ray(1.5), 0b01));

        // NaN rays, NULL pointers: misses, never a crash.
        let mut bad = ray(-5.0);
        bad.dir_y = f32::NAN;
        kdbeam_intersect1(scene, &bad, &mut hit);
        assert_eq!(hit.geometry, KDBEAM_INVALID_ID);
        kdbeam_intersect1(scene, null(), &mut hit);
        assert_eq!(hit.geometry, KDBEAM_INVALID_ID);
        assert!(last_error().contains("ray is NULL"));
        kdbeam_intersect1(scene, &ray(-5.0), null_mut());
        assert!(last_error().contains("hit is NULL"));
        assert!(!kdbeam_occluded1(null(), &ray(-5.0)));
        assert_eq!(
            kdbeam_intersect_stream(scene, null(), hits.as_mut_ptr(), 2),
            KDBEAM_ERROR_NULL_POINTER
        );
        assert_eq!(
            kdbeam_intersect_stream(scene, null(), null_mut(), 0),
            KDBEAM_OK
        );

        // Streams: the single-ray answers.
        let rays = [ray(-5.0), bad, ray(1.5), ray(3.0)];
        let mut stream = [hit; 4];
        assert_eq!(
            kdbeam_intersect_stream(scene, rays.as_ptr(), stream.as_mut_ptr(), 4),
            KDBEAM_OK
        );
        let mut occluded = [true; 4];
        assert_eq!(
            kdbeam_occluded_stream(scene, rays.as_ptr(), occluded.as_mut_ptr(), 4),
            KDBEAM_OK
        );
        for ((r, s), o) in rays.iter().zip(&stream).zip(occluded) {
            kdbeam_intersect1(scene, r, &mut hit);
            assert_eq!(*s, hit);
            assert_eq!(o, kdbeam_occluded1(scene, r));
        }
        assert_eq!(stream[3].geometry, KDBEAM_INVALID_ID);

        // Removal, stale ids, ids never reused.
        assert_eq!(
            kdbeam_scene_remove_geometry(scene, proto),
            KDBEAM_ERROR_IN_USE
        );
        assert_eq!(kdbeam_scene_remove_instance(scene, 1), KDBEAM_OK);
        assert_eq!(
            kdbeam_scene_remove_instance(scene, 1),
            KDBEAM_ERROR_UNKNOWN_ID
        );
        assert_eq!(
            kdbeam_scene_set_transform(scene, 1, translation(0.0).as_ptr()),
            KDBEAM_ERROR_UNKNOWN_ID
        );
        assert_eq!(
            kdbeam_scene_set_transform(scene, 0, null()),
            KDBEAM_ERROR_NULL_POINTER
        );
        assert_eq!(
            kdbeam_scene_set_transform(scene, 0, [f32::INFINITY; 12].as_ptr()),
            KDBEAM_ERROR_INVALID_TRANSFORM
        );
        assert_eq!(kdbeam_scene_set_instance_mask(scene, 0, 0b11), KDBEAM_OK);
        assert_eq!(
            kdbeam_scene_add_instance(scene, proto, translation(-3.0).as_ptr(), 1),
            2
        );
        assert_eq!(
            kdbeam_scene_update_positions(scene, 0, POSITIONS.as_ptr(), 2),
            KDBEAM_ERROR_INVALID_MESH
        );
        let moved: Vec<f32> = POSITIONS
            .iter()
            .enumerate()
            .map(|(i, &p)| if i % 3 == 2 { p - 4.0 } else { p })
            .collect();
        assert_eq!(
            kdbeam_scene_update_positions(scene, 0, moved.as_ptr(), 3),
            KDBEAM_OK
        );
        assert_eq!(kdbeam_scene_commit(scene), KDBEAM_OK);
        kdbeam_intersect1(scene, &ray(-5.0), &mut hit);
        assert_eq!(
            (hit.t, hit.geometry, hit.instance),
            (1.0, 0, KDBEAM_INVALID_ID)
        );
        kdbeam_intersect1(scene, &ray(-3.5), &mut hit);
        assert_eq!((hit.t, hit.geometry, hit.instance), (0.5, proto, 2));
        kdbeam_scene_free(scene);
        kdbeam_scene_free(null_mut());
    }
}

#[test]
fn the_last_error_is_per_thread() {
    // SAFETY: NULL is rejected by the function.
    assert_eq!(
        unsafe { kdbeam_scene_commit(null_mut()) },
        KDBEAM_ERROR_NULL_POINTER
    );
    assert!(last_error().contains("scene is NULL"));
    let other = std::thread::spawn(last_error).join().unwrap();
    assert_eq!(other, "");
    assert!(last_error().contains("scene is NULL"));
}

/// A hit with every field other than a query's answer.
fn ray_hit_unset() -> KdbeamHit {
    let v = f32::NAN;
    let id = 7;
    KdbeamHit {
        t: v,
        u: v,
        v,
        triangle: id,
        geometry: id,
        instance: id,
    }
}

#[test]
fn build_params_through_the_c_abi() {
    let zeroed = KdbeamBuildParams {
        ci_over_ct: 0.0,
        empty_bonus: 0.0,
        max_depth: 0,
        leaf_size: 0,
        exact_search_max: 0,
    };
    // SAFETY: every pointer below is NULL (which the functions must reject) or valid.
    unsafe {
        let mut default = zeroed;
        assert_eq!(kdbeam_build_params_default(&mut default), KDBEAM_OK);
        let rust = kdbeam::BuildParams::default();
        assert_eq!(
            (default.ci_over_ct, default.empty_bonus, default.leaf_size),
            (rust.ci_over_ct, rust.empty_bonus, rust.leaf_size)
        );
        assert_eq!(default.max_depth, 0, "the default depth rule");
        assert_eq!(
            kdbeam_build_params_default(null_mut()),
            KDBEAM_ERROR_NULL_POINTER
        );

        let scene = kdbeam_scene_new();
        let mut got = zeroed;
        assert_eq!(
            kdbeam_scene_get_build_params(scene, &mut got),
            KDBEAM_BUILD_PARAMS_PER_MESH,
            "a new scene sizes each mesh's tree"
        );
        assert_eq!(got, default);
        let mut incoherent = zeroed;
        assert_eq!(
            kdbeam_build_params_for_incoherent_rays(scene, &mut incoherent),
            KDBEAM_OK
        );
        let isa = kdbeam::scene::world::Scene::new().isa();
        let want = kdbeam::BuildParams::for_incoherent_rays(isa);
        assert_eq!(incoherent.ci_over_ct, want.ci_over_ct, "{isa}");
        assert_eq!(
            kdbeam_build_params_for_incoherent_rays(null(), &mut incoherent),
            KDBEAM_ERROR_NULL_POINTER
        );

        assert_eq!(
            kdbeam_scene_add_mesh(scene, POSITIONS.as_ptr(), 3, INDICES.as_ptr(), 1),
            0
        );
        // A large triangle beside a small one: a bigger tree than the even triangle's.
        let uneven: [f32; 18] = [
            0.0, 0.0, 9.0, 1.0, 0.0, 9.0, 0.0, 1.0, 9.0, //
            0.0, 0.0, 8.0, 10.0, 0.0, 8.0, 0.0, 10.0, 8.0,
        ];
        let uneven_indices: [u32; 6] = [0, 1, 2, 3, 4, 5];
        assert_eq!(
            kdbeam_scene_add_mesh(scene, uneven.as_ptr(), 6, uneven_indices.as_ptr(), 2),
            1
        );
        assert_eq!(
            kdbeam_scene_get_geometry_build_params(scene, 0, &mut got),
            KDBEAM_OK
        );
        assert_eq!(got, default, "one triangle: the default");
        let mut own = zeroed;
        assert_eq!(
            kdbeam_scene_get_geometry_build_params(scene, 1, &mut own),
            KDBEAM_OK
        );
        assert!(own.ci_over_ct > default.ci_over_ct, "{own:?}");
        assert_eq!(
            kdbeam_scene_get_geometry_build_params(scene, 2, &mut got),
            KDBEAM_ERROR_UNKNOWN_ID
        );
        assert_eq!(
            kdbeam_scene_get_geometry_build_params(null(), 0, &mut got),
            KDBEAM_ERROR_NULL_POINTER
        );
        assert_eq!(kdbeam_scene_commit(scene), KDBEAM_OK);
        let mut before = ray_hit_unset();
        kdbeam_intersect1(scene, &ray(-5.0), &mut before);
        assert_eq!(before.triangle, 0);

        // Out of range: rejected with the parameter named, the scene unchanged.
        for (bad, name) in [
            (
                KdbeamBuildParams {
                    ci_over_ct: f32::NAN,
                    ..default
                },
                "ci_over_ct",
            ),
            (
                KdbeamBuildParams {
                    ci_over_ct: 0.0,
                    ..default
                },
                "ci_over_ct",
            ),
            (
                KdbeamBuildParams {
                    empty_bonus: 1.0,
                    ..default
                },
                "empty_bonus",
            ),
            (
                KdbeamBuildParams {
                    max_depth: 65,
                    ..default
                },
                "max_depth",
            ),
            (
                KdbeamBuildParams {
                    leaf_size: 0,
                    ..default
                },
                "leaf_size",
            ),
        ] {
            assert_eq!(
                kdbeam_scene_set_build_params(scene, &bad),
                KDBEAM_ERROR_INVALID_ARGUMENT,
                "{bad:?}"
            );
            assert!(last_error().contains(name), "{}", last_error());
            assert_eq!(
                kdbeam_scene_get_build_params(scene, &mut got),
                KDBEAM_BUILD_PARAMS_PER_MESH
            );
        }
        assert_eq!(
            kdbeam_scene_set_build_params(scene, null()),
            KDBEAM_ERROR_NULL_POINTER
        );
        assert_eq!(
            kdbeam_scene_set_build_params(null_mut(), &default),
            KDBEAM_ERROR_NULL_POINTER
        );

        // Set, read back, rebuilt by the next commit: the same hit.
        let chosen = KdbeamBuildParams {
            max_depth: 12,
            leaf_size: 4,
            ..incoherent
        };
        assert_eq!(kdbeam_scene_set_build_params(scene, &chosen), KDBEAM_OK);
        assert_eq!(kdbeam_scene_get_build_params(scene, &mut got), KDBEAM_OK);
        assert_eq!(got, chosen);
        assert_eq!(
            kdbeam_scene_get_geometry_build_params(scene, 1, &mut got),
            KDBEAM_OK
        );
        assert_eq!(got, chosen, "set for every mesh");
        assert_eq!(kdbeam_scene_commit(scene), KDBEAM_OK);
        let mut after = ray_hit_unset();
        kdbeam_intersect1(scene, &ray(-5.0), &mut after);
        assert_eq!(after, before);

        // Reset: each mesh's own again.
        assert_eq!(kdbeam_scene_reset_build_params(scene), KDBEAM_OK);
        assert_eq!(
            kdbeam_scene_get_build_params(scene, &mut got),
            KDBEAM_BUILD_PARAMS_PER_MESH
        );
        assert_eq!(
            kdbeam_scene_get_geometry_build_params(scene, 1, &mut got),
            KDBEAM_OK
        );
        assert_eq!(got, own);
        assert_eq!(
            kdbeam_scene_reset_build_params(null_mut()),
            KDBEAM_ERROR_NULL_POINTER
        );
        assert_eq!(kdbeam_scene_commit(scene), KDBEAM_OK);
        kdbeam_intersect1(scene, &ray(-5.0), &mut after);
        assert_eq!(after, before);
        kdbeam_scene_free(scene);
    }
}

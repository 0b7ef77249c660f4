//! `include/kdbeam.h` is what cbindgen makes of the crate: this fails when it is stale.
//! `KDBEAM_UPDATE_HEADER=1 cargo test -p kdbeam-capi --test header` rewrites it.

use std::path::Path;

#[test]
fn committed_header_is_up_to_date() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let mut generated = Vec::new();
    cbindgen::Builder::new()
        .with_config(config)
        .with_src(dir.join("src/lib.rs"))
        .generate()
        .expect("cbindgen parses the crate")
        .write(&mut generated);
    let generated = String::from_utf8(generated).expect("UTF-8");
    let path = dir.join("include/kdbeam.h");
    if std::env::var_os("KDBEAM_UPDATE_HEADER").is_some() {
        std::fs::write(&path, &generated).expect("write the header");
    }
    let committed = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "capi/include/kdbeam.h is stale: run KDBEAM_UPDATE_HEADER=1 cargo test -p kdbeam-capi --test header"
    );
}

/// The declarations C clients are compiled against, as the issue gives them, each present
/// verbatim (the structs as cbindgen lays them out, field for field).
#[test]
fn header_holds_the_promised_declarations() {
    let header =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("include/kdbeam.h"))
            .expect("header");
    let squeezed: String = header.split_whitespace().collect::<Vec<_>>().join(" ");
    for declaration in [
        "#define KDBEAM_INVALID_ID 0xFFFFFFFFu",
        "typedef struct KdbeamScene KdbeamScene;",
        "typedef struct { float org_x; float org_y; float org_z; float tnear; float dir_x; float dir_y; float dir_z; float tfar; } KdbeamRay;",
        "typedef struct { float t; float u; float v; uint32_t triangle; uint32_t geometry; uint32_t instance; } KdbeamHit;",
        "KdbeamScene *kdbeam_scene_new(void);",
        "void kdbeam_scene_free(KdbeamScene *scene);",
        "uint32_t kdbeam_scene_add_mesh(KdbeamScene *scene, const float *positions, size_t vertex_count, const uint32_t *indices, size_t triangle_count);",
        "int kdbeam_scene_commit(KdbeamScene *scene);",
        "void kdbeam_intersect1(const KdbeamScene *scene, const KdbeamRay *ray, KdbeamHit *hit);",
        "bool kdbeam_occluded1(const KdbeamScene *scene, const KdbeamRay *ray);",
        "int kdbeam_intersect_stream(const KdbeamScene *scene, const KdbeamRay *rays, KdbeamHit *hits, size_t count);",
        "const char *kdbeam_last_error(void);",
    ] {
        assert!(squeezed.contains(declaration), "kdbeam.h lacks {declaration}");
    }
}

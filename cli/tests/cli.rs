//! The command line as a user runs it: the README's main job, the bench table's columns when
//! a run leaves a baseline out, and one row per setting that runs differently.

use std::process::{Command, Output};

#[path = "../../tests/common/mod.rs"]
mod common;
use common::TempFile;

/// Runs the `kdbeam` binary with `args`, one worker thread, and returns its output, after
/// checking that it succeeded.
fn kdbeam(args: &[&str]) -> Output {
    let out = Command::new(env!("CARGO_BIN_EXE_kdbeam"))
        .args(args)
        .args(["--threads", "1"])
        .output()
        .expect("the kdbeam binary runs");
    assert!(
        out.status.success(),
        "kdbeam {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn render_writes_a_png_of_the_default_scene_and_prints_its_statistics() {
    let png = TempFile::new("default.png");
    let out = kdbeam(&[
        "render",
        "--size",
        "64x48",
        "--out",
        png.path().to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "kd-tree",
        "Mrays/s",
        "tests/ray",
        "eliminated",
        "shadow",
        "occluded",
    ] {
        assert!(stdout.contains(needle), "no {needle:?} in:\n{stdout}");
    }
    let bytes = std::fs::read(&png).expect("render wrote the PNG");
    let decoder = png::Decoder::new(bytes.as_slice());
    let info = decoder.read_info().expect("a valid PNG").info().clone();
    assert_eq!((info.width, info.height), (64, 48));
}

#[test]
fn bench_without_the_scalar_path_shows_no_speedup_over_it() {
    let args = [
        "bench",
        "builtin:icosphere",
        "--packet",
        "8",
        "--isa",
        "portable",
        "--culling",
        "none",
        "--size",
        "16x16",
        "--reps",
        "1",
    ];
    let table = String::from_utf8_lossy(&kdbeam(&args).stdout).into_owned();
    let row = table.lines().nth(1).expect("a row under the header");
    assert!(!table.contains("NaN"), "{table}");
    assert!(
        row.ends_with(" -"),
        "the speedup column is not '-': {row:?}"
    );

    let json =
        String::from_utf8_lossy(&kdbeam(&[&args[..], &["--json"]].concat()).stdout).into_owned();
    let row: serde_json::Value = serde_json::from_str(json.lines().next().unwrap()).unwrap();
    assert!(row["speedup_vs_scalar"].is_null(), "{row}");
    assert!(row["mrays_per_s"].as_f64().unwrap() > 0.0, "{row}");
}

#[test]
fn single_rays_get_a_row_per_setting_that_runs_differently() {
    // `auto` runs ray-box culling on single rays on the scalar ISA only: on the portable
    // lanes it runs as `none` does, so it gets no row of its own there.
    let rows = |isa: &str| {
        let out = kdbeam(&[
            "bench",
            "builtin:icosphere",
            "--packet",
            "1",
            "--isa",
            isa,
            "--culling",
            "none,auto",
            "--size",
            "8x8",
            "--reps",
            "1",
            "--json",
        ]);
        String::from_utf8_lossy(&out.stdout).lines().count()
    };
    assert_eq!(rows("scalar"), 2);
    assert_eq!(rows("portable"), 1);
}

#[test]
fn synthetic_prints_the_baseline_once_when_asked_for_it() {
    // `synthetic` runs on one thread and takes no `--threads`.
    let out = Command::new(env!("CARGO_BIN_EXE_kdbeam"))
        .args(["synthetic", "--isa", "scalar", "--culling", "none,4plane"])
        .args(["--packets", "4", "--reps", "1", "--json"])
        .output()
        .expect("the kdbeam binary runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let cullings: Vec<String> = stdout
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap()["culling"].to_string())
        .collect();
    assert_eq!(cullings, ["\"none\"", "\"4plane\""], "{stdout}");
}

#[test]
fn ambient_occlusion_gets_its_own_tree_and_the_same_picture() {
    // On four lanes the AO rays default to the tree for incoherent rays (ci_over_ct 0.3);
    // given the primary rays' ratio, they share its tree. Any-hit answers do not depend
    // on the tree, so the pictures are the same to the byte.
    let render = |ao_ci: Option<&str>| {
        let png = TempFile::new("ao.png");
        let mut args = vec![
            "render",
            "--shade",
            "ao",
            "--size",
            "48x32",
            "--isa",
            "portable",
            "--ci-over-ct",
            "0.05",
        ];
        args.extend(["--out", png.path().to_str().unwrap()]);
        if let Some(ci) = ao_ci {
            args.extend(["--ao-ci-over-ct", ci]);
        }
        let stdout = String::from_utf8_lossy(&kdbeam(&args).stdout).into_owned();
        (stdout, std::fs::read(&png).expect("render wrote the PNG"))
    };
    let (own, own_png) = render(None);
    assert!(
        own.contains("kd-tree    for ao rays (ci_over_ct 0.3)"),
        "{own}"
    );
    let (shared, shared_png) = render(Some("0.05"));
    assert!(!shared.contains("for ao rays"), "{shared}");
    assert!(shared.lines().any(|l| l.starts_with("ao ")), "{shared}");
    assert!(own_png == shared_png, "the AO tree changed the picture");
}

#[test]
fn bench_measures_each_kind_of_ray_on_its_default_tree() {
    let trees_of = |scene: &str, rays: &str, isa: &str| {
        let out = kdbeam(&[
            "bench",
            scene,
            "--rays",
            rays,
            "--packet",
            "1",
            "--isa",
            isa,
            "--culling",
            "none",
            "--size",
            "8x8",
            "--reps",
            "1",
            "--json",
        ]);
        let mut ci: Vec<f32> = String::from_utf8_lossy(&out.stdout)
            .lines()
            .map(|l| {
                let row = serde_json::from_str::<serde_json::Value>(l).unwrap();
                row["ci_over_ct"].as_f64().expect("a tree's ci_over_ct") as f32
            })
            .collect();
        ci.dedup();
        ci
    };
    let trees = |rays: &str, isa: &str| trees_of("builtin:icosphere", rays, isa);
    // The icosphere's triangles are alike: the default.
    assert_eq!(trees("primary", "scalar,portable"), [0.05]);
    assert_eq!(trees("shadow", "portable"), [0.05]);
    assert_eq!(trees("ao", "scalar,portable"), [0.3]);
    assert_eq!(trees("diffuse", "portable"), [0.3]);
    assert_eq!(trees("random", "portable"), [0.3]);
    // Camera rays on the scene's own tree: the default scene's spheres and valley.
    let mesh = kdbeam::scene::procedural::builtin("default").unwrap();
    let own = kdbeam::BuildParams::for_mesh(&mesh).ci_over_ct;
    assert!(own > 0.05, "{own}");
    assert_eq!(trees_of("builtin:default", "primary", "portable"), [own]);
}

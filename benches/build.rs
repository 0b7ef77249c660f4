//! kd-tree builds on real and built-in scenes, on one thread and on the default rayon pool.
//!
//! `cargo bench --bench build`; `KDBEAM_SCENES` points at the shared meshes (the built-in
//! default scene is measured when they are missing). Throughput is in mesh triangles.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdbeam::scene::{self, procedural};
use kdbeam::{BuildParams, KdTree, Mesh};

fn scenes() -> Vec<(String, Mesh)> {
    let mut out = Vec::new();
    for name in ["bunny", "sponza", "dragon"] {
        if let Some(path) = scene::shared_scene(name) {
            out.push((
                name.to_string(),
                scene::load_obj(path).expect("shared scene loads"),
            ));
        }
    }
    if out.is_empty() {
        eprintln!("shared scenes not found: measuring builtin:default only");
        out.push((
            "builtin:default".into(),
            procedural::builtin("default").expect("built-in"),
        ));
    }
    out
}

fn build(c: &mut Criterion) {
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let default = rayon::ThreadPoolBuilder::new().build().expect("pool");
    let pools = [
        ("1-thread".to_string(), &one),
        (
            format!("{}-threads", default.current_num_threads()),
            &default,
        ),
    ];
    for (name, mesh) in scenes() {
        let mut g = c.benchmark_group(format!("build/{name}"));
        g.throughput(Throughput::Elements(mesh.triangle_count() as u64));
        g.sample_size(10);
        for ci_over_ct in [1.0, BuildParams::default().ci_over_ct, 10.0] {
            let params = BuildParams {
                ci_over_ct,
                ..BuildParams::default()
            };
            for (threads, pool) in &pools {
                g.bench_with_input(
                    BenchmarkId::new(threads, format!("ci{ci_over_ct}")),
                    &params,
                    |b, params| {
                        b.iter(|| pool.install(|| KdTree::build(&mesh, params).expect("tree")))
                    },
                );
            }
        }
        g.finish();
    }
}

criterion_group!(benches, build);
criterion_main!(benches);

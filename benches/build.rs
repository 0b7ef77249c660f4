//! kd-tree builds on real and built-in scenes, on one thread and on the default rayon pool.
//!
//! `cargo bench --bench build`; `KDBEAM_SCENES` points at the shared meshes (the built-in
//! default scene is measured when they are missing). Throughput is in mesh triangles.

use common::scenes;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdbeam::{BuildParams, KdTree};

mod common;

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
            let params = BuildParams::default().with_ci_over_ct(ci_over_ct);
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

//! One leaf of Kensler–Shirley synthetic data (ratio 4, 8 × 8 packets, jitter 4%): time per
//! repetition per ISA and culling, with TSC cycles per ray–triangle test printed next to it.
//!
//! `cargo bench --bench synthetic`. Throughput is in potential ray–triangle tests
//! (rays × triangles), so criterion's elements/s is tests/s; `kdbeam synthetic` sweeps the
//! parameters.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdbeam::kernels::Dispatch;
use kdbeam::scene::synthetic::{self, SyntheticParams};
use kdbeam::trace::leaf::{trace_leaf, Leaf};
use kdbeam::trace::synthetic::measure;
use kdbeam::trace::{Culling, Planes};
use kdbeam::HitPacket;

fn synthetic_leaf(c: &mut Criterion) {
    let params = SyntheticParams {
        packets: 256,
        ..SyntheticParams::default()
    };
    let cell = synthetic::generate(&params).expect("default parameters are valid");
    let leaf = Leaf::from(&cell);
    let potential = (cell.rays() * cell.triangles.len()) as u64;
    let mut hits = vec![HitPacket::default(); cell.packets.len()];
    let mut group = c.benchmark_group("synthetic_ratio4_8x8_jitter4");
    group.throughput(Throughput::Elements(potential));
    for dispatch in Dispatch::available() {
        let mut baseline = f64::NAN;
        for (name, culling) in [
            ("none", Culling::NONE),
            ("4plane", Culling::planes(Planes::Four, false)),
            ("6plane+aperture", Culling::FULL),
        ] {
            let m = measure(&cell, dispatch, culling, 9, &mut hits);
            if culling == Culling::NONE {
                baseline = m.cycles_per_test;
            }
            eprintln!(
                "{dispatch} {name}: {:.3} TSC cycles/test, {:.2}x the baseline, {:.1}% eliminated",
                m.cycles_per_test,
                baseline / m.cycles_per_test,
                m.eliminated_percent()
            );
            group.bench_function(BenchmarkId::new(name, dispatch), |b| {
                b.iter(|| trace_leaf(dispatch, culling, leaf, &cell.packets, &mut hits))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, synthetic_leaf);
criterion_main!(benches);

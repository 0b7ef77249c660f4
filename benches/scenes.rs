//! Primary rays through real and built-in scenes, per ISA and packet size, single thread.
//!
//! `cargo bench --bench scenes`; `KDBEAM_SCENES` points at the shared meshes (the built-in
//! default scene is measured when they are missing). The scalar single-ray path is the
//! baseline in the same group.

use common::scenes;
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use kdbeam::{BuildParams, Camera, HitPacket, Isa, KdTree, PacketShape, RayPacket, Tracer};

mod common;

const SIZE: u32 = 256;

fn primary(c: &mut Criterion) {
    for (name, mesh) in scenes() {
        let tree = KdTree::build(&mesh, &BuildParams::default()).expect("tree");
        let camera = Camera::standard(&tree.bounds(), SIZE, SIZE);
        let rays = camera.rays();
        let mut g = c.benchmark_group(format!("primary/{name}"));
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.sample_size(10);
        let scalar = Tracer::new(&tree).with_isa(Isa::Scalar).expect("scalar");
        g.bench_function("scalar-single-ray", |b| {
            b.iter(|| rays.iter().filter(|r| scalar.intersect(r).is_hit()).count())
        });
        for isa in Isa::available() {
            for shape in [PacketShape::P2x2, PacketShape::P4x4, PacketShape::P8x8] {
                let t = Tracer::new(&tree)
                    .with_isa(isa)
                    .expect("available")
                    .with_packet(shape);
                let packets = camera.tile_packets(shape);
                g.bench_with_input(
                    BenchmarkId::new(isa.name(), shape.ray_count()),
                    &t,
                    |b, t| b.iter(|| trace(t, &packets)),
                );
            }
        }
        g.finish();
    }
}

/// Traces every packet; returns the number of hits, so that nothing is optimised away.
fn trace(tracer: &Tracer<'_>, packets: &[RayPacket]) -> usize {
    let mut hits = HitPacket::default();
    packets
        .iter()
        .map(|p| {
            tracer.intersect_packet(p, p.full_mask(), &mut hits);
            (0..p.len()).filter(|&j| hits.hit(j).is_hit()).count()
        })
        .sum()
}

criterion_group!(benches, primary);
criterion_main!(benches);

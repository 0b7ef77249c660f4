//! `Scene::commit` after moving every instance: the top-level rebuild a renderer pays per
//! frame, and the moves alone for comparison.
//!
//! `cargo bench --bench scene_commit`. 1000 and 10 000 instances of one icosphere, scattered
//! over a 200-unit square; each iteration moves every instance (a new transform each time, so
//! the tree is really rebuilt) and commits. Single-ray tracing of the moved scene is measured
//! beside it, per ray.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use glam::{Affine3A, Quat};
use kdbeam::rays::random_rays;
use kdbeam::scene::procedural::icosphere;
use kdbeam::scene::rng::Rng;
use kdbeam::{Aabb, InstanceId, Scene, Vec3};

/// Where instance `i` is in frame `frame`: on a circle of its own around its home.
fn placement(home: Vec3, i: usize, frame: u32) -> Affine3A {
    let a = frame as f32 * 0.05 + i as f32;
    Affine3A::from_rotation_translation(
        Quat::from_rotation_y(a),
        home + Vec3::new(a.cos(), 0.0, a.sin()) * 3.0,
    )
}

fn scene(n: usize) -> (Scene, Vec<(InstanceId, Vec3)>) {
    let mut rng = Rng::new(1);
    let mut scene = Scene::new();
    let sphere = scene
        .add_prototype(icosphere(Vec3::ZERO, 1.0, 3))
        .expect("mesh");
    let instances = (0..n)
        .map(|i| {
            let home = Vec3::new(rng.range(-100.0, 100.0), 0.0, rng.range(-100.0, 100.0));
            let id = scene
                .add_instance(sphere, placement(home, i, 0))
                .expect("instance");
            (id, home)
        })
        .collect();
    scene.commit().expect("commit");
    (scene, instances)
}

fn commit(c: &mut Criterion) {
    let mut g = c.benchmark_group("scene_commit");
    for n in [1000, 10_000] {
        let (mut scene, instances) = scene(n);
        g.throughput(Throughput::Elements(n as u64));
        let mut frame = 0;
        g.bench_function(BenchmarkId::new("move", n), |b| {
            b.iter(|| {
                frame += 1;
                for (i, &(id, home)) in instances.iter().enumerate() {
                    scene
                        .set_transform(id, placement(home, i, frame))
                        .expect("move");
                }
            })
        });
        g.bench_function(BenchmarkId::new("move+commit", n), |b| {
            b.iter(|| {
                frame += 1;
                for (i, &(id, home)) in instances.iter().enumerate() {
                    scene
                        .set_transform(id, placement(home, i, frame))
                        .expect("move");
                }
                scene.commit().expect("commit")
            })
        });
        let bounds = Aabb::new(
            Vec3::new(-100.0, -5.0, -100.0),
            Vec3::new(100.0, 5.0, 100.0),
        );
        let rays = random_rays(&bounds, 4096, 3);
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(BenchmarkId::new("intersect-per-ray", n), |b| {
            b.iter(|| rays.iter().filter(|r| scene.intersect(r).is_hit()).count())
        });
    }
    g.finish();
}

criterion_group!(benches, commit);
criterion_main!(benches);

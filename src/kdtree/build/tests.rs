//! The builder against itself: rebuilds, every search and ISA, threads.

use kdbeam_kernels::Isa;

use super::classify::sides_of;
use crate::kdtree::{BuildParams, BuildStats, KdTree, KdTreeBuilder, WideNode};
use crate::Mesh;

/// A seeded soup of `n` small triangles in the unit cube (a local LCG: the scene
/// generators are not this module's).
fn soup(n: usize, seed: u64) -> Mesh {
    let mut state = seed;
    let mut next = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut positions = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let c = [next(), next(), next()];
        for _ in 0..3 {
            positions.push(c.map(|x| x + 0.05 * (next() - 0.5)));
        }
    }
    Mesh::from_soup(&positions).unwrap()
}

fn same_tree(a: &KdTree, b: &KdTree) -> bool {
    a.nodes == b.nodes
        && a.leaves == b.leaves
        && a.blocks == b.blocks
        && same_wide(a.wide.nodes(), b.wide.nodes())
}

/// Whether two sets of wide nodes are the same tree: from the roots down, the same boxes and
/// leaves in the same slots, whatever the order of the nodes in their arrays.
fn same_wide(a: &[WideNode], b: &[WideNode]) -> bool {
    let mut work = vec![(0, 0)];
    while let Some((i, j)) = work.pop() {
        let (x, y) = (&a[i], &b[j]);
        if x.planes != y.planes {
            return false;
        }
        for (&c, &d) in x.children.iter().zip(&y.children) {
            match (c.is_node(), d.is_node()) {
                (true, true) => work.push((c.index() as usize, d.index() as usize)),
                (false, false) if c == d => {}
                _ => return false,
            }
        }
    }
    a.len() == b.len()
}

/// The stats but for the build time.
fn stats_but_time(t: &KdTree) -> BuildStats {
    BuildStats {
        build_time: std::time::Duration::ZERO,
        ..t.stats
    }
}

#[test]
fn sides_follow_wald_and_havrans_classification() {
    // Boxes [lo, hi] against the plane at 1, the planar ones sent either way.
    let cases = [
        ((0.0, 0.5), [(true, false), (true, false)]),
        ((0.0, 1.0), [(true, false), (true, false)]),
        ((0.0, 2.0), [(false, false), (false, false)]),
        ((1.0, 2.0), [(false, true), (false, true)]),
        ((1.5, 2.0), [(false, true), (false, true)]),
        ((0.5, 0.5), [(true, false), (true, false)]),
        ((1.5, 1.5), [(false, true), (false, true)]),
        ((1.0, 1.0), [(true, false), (false, true)]),
    ];
    for ((lo, hi), sides) in cases {
        for (planar_below, want) in [true, false].into_iter().zip(sides) {
            assert_eq!(sides_of(lo, hi, 1.0, planar_below), want, "[{lo}, {hi}]");
        }
    }
}

#[test]
fn rebuilding_into_an_old_tree_gives_the_fresh_build() {
    let (big, small) = (soup(3000, 1), soup(500, 2));
    let params = BuildParams::default();
    let mut builder = KdTreeBuilder::new();
    let mut tree = builder.build(&big, &params).unwrap();
    // Smaller, larger, smaller again: nothing of the previous tree or build may survive.
    for mesh in [&small, &big, &small] {
        // The ray-box culling boxes of the old tree must not survive either.
        let _ = tree.triangle_boxes();
        builder.rebuild(&mut tree, mesh, &params).unwrap();
        let fresh = KdTree::build(mesh, &params).unwrap();
        assert_eq!(tree.raybox_bytes(), 0);
        assert_eq!(tree.triangle_boxes(), fresh.triangle_boxes());
        assert!(same_tree(&tree, &fresh));
        assert_eq!(tree.bounds, fresh.bounds);
        assert_eq!(tree.mesh_triangles, fresh.mesh_triangles);
        assert_eq!(stats_but_time(&tree), stats_but_time(&fresh));
    }
    // A failed rebuild leaves the tree as it was.
    let before = tree.clone();
    let bad = BuildParams {
        ci_over_ct: -1.0,
        ..params
    };
    assert!(builder.rebuild(&mut tree, &big, &bad).is_err());
    assert!(same_tree(&tree, &before) && tree.bounds == before.bounds);
}

#[test]
fn counted_swept_and_binned_searches_build_the_same_tree_on_every_isa() {
    // A soup, and a box of grids whose flat triangles put planar boxes on the planes.
    let meshes = [
        soup(1500, 3),
        crate::scene::procedural::closed_grid_box(8, glam::Vec3::ZERO, glam::Vec3::ONE),
    ];
    // Exact searches only, and binned ones above the default threshold.
    let settings = [0.1, 1.5, 10.0].into_iter().flat_map(|ci_over_ct| {
        [200, BuildParams::default().exact_search_max].map(|exact| (ci_over_ct, exact))
    });
    for mesh in &meshes {
        for (ci_over_ct, exact_search_max) in settings.clone() {
            let params = BuildParams {
                ci_over_ct,
                exact_search_max,
                ..BuildParams::default()
            };
            let swept = KdTreeBuilder::new()
                .with_count_max(0)
                .build(mesh, &params)
                .unwrap();
            assert!(swept.stats.nodes > 50, "{}", swept.stats);
            for isa in Isa::available() {
                let counted = KdTreeBuilder::new()
                    .with_isa(isa)
                    .unwrap()
                    .build(mesh, &params)
                    .unwrap();
                assert!(
                    same_tree(&counted, &swept),
                    "{isa}, ci/ct {ci_over_ct}, exact≤{exact_search_max}"
                );
            }
        }
    }
}

#[cfg(feature = "parallel")]
#[test]
fn one_thread_and_many_threads_build_the_same_tree() {
    // 20k triangles: several nodes above the parallel threshold of `rayon::join`; 150k, and a
    // terrain of 80k whose flat triangles put planar boxes on the planes: nodes above
    // `PARALLEL_NODE_MIN`, binned and split in parallel chunks.
    let meshes = [
        soup(20_000, 7),
        soup(150_000, 8),
        crate::scene::procedural::terrain(200, 9),
    ];
    assert!(meshes[1].triangle_count() > 2 * super::parallel::PARALLEL_NODE_MIN);
    assert!(meshes[2].triangle_count() > super::parallel::PARALLEL_NODE_MIN);
    let mut wide_in_parallel = false;
    let pool = |threads| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
    };
    let (one, two, four) = (pool(1), pool(2), pool(4));
    for (m, mesh) in meshes.iter().enumerate() {
        for ci_over_ct in [0.1, 1.0, 10.0] {
            let params = BuildParams {
                ci_over_ct,
                ..BuildParams::default()
            };
            let serial = one.install(|| KdTree::build(mesh, &params).unwrap());
            assert!(serial.stats.nodes > 1000, "{}", serial.stats);
            wide_in_parallel |= serial.stats.nodes >= crate::kdtree::wide::PARALLEL_MIN_NODES;
            for (threads, pool) in [(2, &two), (4, &four)] {
                let parallel = pool.install(|| KdTree::build(mesh, &params).unwrap());
                assert!(
                    same_tree(&serial, &parallel) && serial.bounds == parallel.bounds,
                    "mesh {m}, ci/ct {ci_over_ct}, {threads} threads"
                );
                assert_eq!(stats_but_time(&serial), stats_but_time(&parallel));
            }
            // A kept builder's rebuild, on many threads, is the same tree again.
            let mut builder = KdTreeBuilder::new();
            let mut tree = four.install(|| builder.build(&meshes[0], &params).unwrap());
            four.install(|| builder.rebuild(&mut tree, mesh, &params).unwrap());
            assert!(
                same_tree(&serial, &tree),
                "mesh {m}, ci/ct {ci_over_ct}, rebuilt"
            );
        }
    }
    assert!(
        wide_in_parallel,
        "no tree large enough for parallel wide nodes"
    );
}

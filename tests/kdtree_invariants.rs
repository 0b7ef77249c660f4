//! Structural invariants of `KdTree::build`, checked against an independent f64 clipper:
//! coverage (every triangle in every leaf whose cell it enters, in none it does not touch),
//! tight and conservative leaf boxes, depth and leaf-size limits, statistics, parameter
//! validation, and robustness on degenerate, flat, empty and far-from-origin meshes.
//!
//! The real-scene tests are named `real_scene_*`: they need the shared scenes (found as
//! `tests/common/scenes.rs` says), and are skipped, with a message saying why, without them.

use std::collections::BTreeSet;

use kdbeam::kdtree::{LeafRecord, WideChild, WideNode, WIDE_STACK};
use kdbeam::kernels::triangle::BLOCK;
use kdbeam::kernels::{KsTriangle, TriangleBlock, Vec3};
use kdbeam::{Aabb, BuildParams, Error, KdTree, Mesh, Triangle};

mod common;

// ---------------------------------------------------------------------------------------------
// Meshes (small local generators: the scene generators belong to another module).

/// A seeded 64-bit LCG giving floats in [0, 1).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `n` random triangles of size up to `size` in the unit cube, shifted by `offset`.
fn soup(n: usize, size: f32, offset: [f32; 3], seed: u64) -> Mesh {
    let mut rng = Lcg(seed);
    let mut positions = Vec::with_capacity(3 * n);
    for _ in 0..n {
        let c = [rng.next(), rng.next(), rng.next()];
        for _ in 0..3 {
            let mut p = [0.0; 3];
            for k in 0..3 {
                p[k] = offset[k] + c[k] + size * (rng.next() - 0.5);
            }
            positions.push(p);
        }
    }
    Mesh::from_soup(&positions).unwrap()
}

/// An `n × n` grid of quads (two triangles each) in the plane z = 0: a flat mesh.
fn grid(n: u32) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            positions.push([i as f32, j as f32, 0.0]);
        }
    }
    let mut indices = Vec::new();
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            indices.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            indices.extend([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh::from_indexed(&positions, &indices).unwrap()
}

/// A UV sphere of radius `r` around `center`: `stacks × slices` quads, poles as fans.
fn sphere(stacks: u32, slices: u32, r: f32, center: [f32; 3]) -> Mesh {
    let mut positions = Vec::new();
    for s in 0..=stacks {
        let theta = std::f32::consts::PI * s as f32 / stacks as f32;
        for l in 0..slices {
            let phi = 2.0 * std::f32::consts::PI * l as f32 / slices as f32;
            positions.push([
                center[0] + r * theta.sin() * phi.cos(),
                center[1] + r * theta.sin() * phi.sin(),
                center[2] + r * theta.cos(),
            ]);
        }
    }
    let mut indices = Vec::new();
    let at = |s: u32, l: u32| s * slices + l % slices;
    for s in 0..stacks {
        for l in 0..slices {
            indices.extend([at(s, l), at(s + 1, l), at(s + 1, l + 1)]);
            indices.extend([at(s, l), at(s + 1, l + 1), at(s, l + 1)]);
        }
    }
    Mesh::from_indexed(&positions, &indices).unwrap()
}

fn params(ci_over_ct: f32) -> BuildParams {
    BuildParams::default().with_ci_over_ct(ci_over_ct)
}

// ---------------------------------------------------------------------------------------------
// An independent reference: the part of a triangle inside a box, in f64.

type P = [f64; 3];

/// The polygon `tri ∩ [lo, hi]` by Sutherland–Hodgman clipping (empty if they do not meet).
fn clip(tri: &Triangle, lo: P, hi: P) -> Vec<P> {
    let mut poly: Vec<P> = [tri.v0, tri.v1, tri.v2]
        .iter()
        .map(|v| [v.x as f64, v.y as f64, v.z as f64])
        .collect();
    for k in 0..3 {
        for (plane, sign) in [(lo[k], 1.0), (hi[k], -1.0)] {
            let d = |p: &P| sign * (p[k] - plane);
            let mut out = Vec::new();
            for (i, a) in poly.iter().enumerate() {
                let b = &poly[(i + 1) % poly.len()];
                if d(a) >= 0.0 {
                    out.push(*a);
                }
                if (d(a) >= 0.0) != (d(b) >= 0.0) {
                    let t = d(a) / (d(a) - d(b));
                    let mut p = [0.0; 3];
                    for m in 0..3 {
                        p[m] = a[m] + t * (b[m] - a[m]);
                    }
                    p[k] = plane;
                    out.push(p);
                }
            }
            poly = out;
            if poly.is_empty() {
                return poly;
            }
        }
    }
    poly
}

fn polygon_box(poly: &[P]) -> (P, P) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in poly {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

fn f64s(v: Vec3) -> P {
    [v.x as f64, v.y as f64, v.z as f64]
}

/// Tolerance for "touches" and "enters": 8 f32 ulps of the largest coordinate of the mesh.
/// The builder rounds its clipped boxes outward by about one ulp, so a triangle within this
/// distance of a cell may or may not be referenced by it; the f64 reference clip itself is
/// exact to ~1e-16 relative, far below this.
fn tolerance(mesh: &Mesh) -> f64 {
    let magnitude = mesh
        .positions()
        .iter()
        .fold(0.0f32, |m, p| m.max(p.abs().max_element()));
    8.0 * f32::EPSILON as f64 * (magnitude as f64).max(1.0)
}

// ---------------------------------------------------------------------------------------------
// The checker.

/// One leaf found by walking the tree: its cell, record, depth.
struct LeafVisit {
    cell: Aabb,
    record: LeafRecord,
    depth: u32,
}

/// The tree walked from the root with cells, after checking node indices and the depth-first
/// order: the leaves in node order, each leaf's index by node index, and for each inner node
/// its depth and how many distinct triangles lie below it, counted up to `cap`.
struct Walk {
    leaves: Vec<LeafVisit>,
    leaf_of_node: Vec<usize>,
    inner: Vec<(u32, usize)>,
}

fn walk(tree: &KdTree, cap: usize) -> Result<Walk, String> {
    /// Returns the distinct ids below `index` (at most `cap` of them) and the next node index.
    fn visit(
        tree: &KdTree,
        w: &mut Walk,
        cap: usize,
        index: usize,
        cell: Aabb,
        depth: u32,
    ) -> Result<(BTreeSet<u32>, usize), String> {
        let node = *tree.nodes().get(index).ok_or("node index out of range")?;
        if node.is_leaf() {
            let record = *tree
                .leaves()
                .get(node.leaf_record() as usize)
                .ok_or("leaf record out of range")?;
            let ids: Vec<u32> = tree.leaf_triangles(&record).ids().collect();
            w.leaf_of_node[index] = w.leaves.len();
            w.leaves.push(LeafVisit {
                cell,
                record,
                depth,
            });
            return Ok((ids.iter().copied().take(cap).collect(), index + 1));
        }
        let (axis, split) = (node.axis(), node.split());
        if !(split > cell.min[axis] && split < cell.max[axis]) {
            return Err(format!(
                "node {index}: split {split} not inside the cell {cell:?} on axis {axis}"
            ));
        }
        let (mut below, mut above) = (cell, cell);
        below.max[axis] = split;
        above.min[axis] = split;
        let (mut ids, end) = visit(tree, w, cap, index + 1, below, depth + 1)?;
        if node.above_child() as usize != end {
            return Err(format!(
                "node {index}: above child {} is not right after the below subtree ({end})",
                node.above_child()
            ));
        }
        let (above_ids, end) = visit(tree, w, cap, end, above, depth + 1)?;
        let is_empty_leaf = |child: usize| {
            let child = tree.nodes()[child];
            child.is_leaf() && tree.leaves()[child.leaf_record() as usize].count == 0
        };
        let marked = (
            is_empty_leaf(index + 1),
            is_empty_leaf(node.above_child() as usize),
        );
        if node.empty_children() != marked {
            return Err(format!(
                "node {index}: children marked empty {:?}, but they are {marked:?}",
                node.empty_children()
            ));
        }
        ids.extend(above_ids);
        while ids.len() > cap {
            ids.pop_last();
        }
        w.inner.push((depth, ids.len()));
        Ok((ids, end))
    }
    let mut w = Walk {
        leaves: Vec::new(),
        leaf_of_node: vec![usize::MAX; tree.nodes().len()],
        inner: Vec::new(),
    };
    let (_, end) = visit(tree, &mut w, cap, 0, tree.bounds(), 0)?;
    if end != tree.nodes().len() {
        return Err(format!("{} nodes, {end} reachable", tree.nodes().len()));
    }
    Ok(w)
}

/// The leaves (indices into `w.leaves`) whose cells come within `tol` of box `b`.
fn leaves_near(tree: &KdTree, w: &Walk, b: &Aabb, tol: f64) -> Vec<usize> {
    let mut found = Vec::new();
    let mut stack = vec![(0usize, tree.bounds())];
    while let Some((index, cell)) = stack.pop() {
        let near = (0..3).all(|k| {
            b.max[k] as f64 >= cell.min[k] as f64 - tol
                && b.min[k] as f64 <= cell.max[k] as f64 + tol
        });
        if !near {
            continue;
        }
        let node = tree.nodes()[index];
        if node.is_leaf() {
            found.push(w.leaf_of_node[index]);
            continue;
        }
        let (mut below, mut above) = (cell, cell);
        below.max[node.axis()] = node.split();
        above.min[node.axis()] = node.split();
        stack.push((index + 1, below));
        stack.push((node.above_child() as usize, above));
    }
    found
}

/// Checks every invariant of `tree` built from `mesh` with `params`.
fn check(mesh: &Mesh, params: &BuildParams, tree: &KdTree) -> Result<(), String> {
    let tol = tolerance(mesh);
    let w = walk(tree, params.leaf_size as usize + 1)?;
    let leaves = &w.leaves;
    if tree.bounds() != mesh.bounds() {
        return Err("root box is not the mesh's box".into());
    }
    if tree.mesh_triangle_count() != mesh.triangle_count() {
        return Err("mesh triangle count".into());
    }

    // (c) depth limit and leaf-size rule.
    let limit = params.depth_limit(mesh.triangle_count());
    if let Some(deep) = leaves.iter().find(|l| l.depth > limit) {
        return Err(format!("leaf at depth {} > limit {limit}", deep.depth));
    }
    if let Some((depth, count)) = w
        .inner
        .iter()
        .find(|&&(_, count)| count <= params.leaf_size as usize)
    {
        return Err(format!(
            "inner node at depth {depth} over only {count} triangles (leaf_size {})",
            params.leaf_size
        ));
    }

    // Leaf contents: each triangle once, exact triangles, (b) boxes, (a) no reference to a
    // triangle that does not come within `tol` of the cell.
    let mut referenced_by: Vec<Vec<usize>> = vec![Vec::new(); mesh.triangle_count()];
    for (leaf_index, leaf) in leaves.iter().enumerate() {
        let content = tree.leaf_triangles(&leaf.record);
        let leaf_ids: Vec<u32> = content.ids().collect();
        let mut ids = leaf_ids.clone();
        ids.sort_unstable();
        if ids.windows(2).any(|w| w[0] == w[1]) {
            return Err(format!(
                "leaf {leaf_index}: a triangle referenced twice {leaf_ids:?}"
            ));
        }
        let (cell_lo, cell_hi) = (f64s(leaf.cell.min), f64s(leaf.cell.max));
        let mut union = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        if content.blocks.len() != content.len().div_ceil(BLOCK) {
            return Err(format!(
                "leaf {leaf_index}: {} blocks",
                content.blocks.len()
            ));
        }
        for lane in content.len()..content.blocks.len() * BLOCK {
            let block = &content.blocks[lane / BLOCK];
            let pad = block.triangle(lane % BLOCK);
            if block.ids[lane % BLOCK] != u32::MAX || pad.v0 != pad.v1 || pad.v0 != pad.v2 {
                return Err(format!("leaf {leaf_index}: padding lane {lane} is {pad:?}"));
            }
        }
        for (i, &id) in leaf_ids.iter().enumerate() {
            let tri = mesh.triangle(id as usize);
            if content.triangle(i) != tri || content.ks(i) != KsTriangle::from(&tri) {
                return Err(format!(
                    "leaf {leaf_index}: triangle {id} not laid out as in the mesh"
                ));
            }
            referenced_by[id as usize].push(leaf_index);
            let grown = clip(&tri, cell_lo.map(|x| x - tol), cell_hi.map(|x| x + tol));
            if grown.is_empty() {
                return Err(format!(
                    "leaf {leaf_index} (cell {:?}) references triangle {id} {tri:?}, which does \
                     not touch it",
                    leaf.cell
                ));
            }
            let part = clip(&tri, cell_lo, cell_hi);
            if !part.is_empty() {
                let (lo, hi) = polygon_box(&part);
                for k in 0..3 {
                    union.0[k] = union.0[k].min(lo[k]);
                    union.1[k] = union.1[k].max(hi[k]);
                }
            }
        }
        let b = leaf.record.bounds;
        if content.is_empty() {
            if !b.is_empty() {
                return Err(format!("empty leaf {leaf_index} with a box {b:?}"));
            }
            continue;
        }
        if !leaf.cell.contains_box(&b) || b.is_empty() {
            return Err(format!(
                "leaf {leaf_index}: box {b:?} not inside the cell {:?}",
                leaf.cell
            ));
        }
        // Conservative: holds every clipped part (up to the reference clip's f64 rounding,
        // 1e-12 relative, below an f32 ulp). Tight: no more than `tol` larger than their union.
        let slack = tol * 1e-5;
        for k in 0..3 {
            let (lo, hi) = (b.min[k] as f64, b.max[k] as f64);
            if union.0[k] <= union.1[k]
                && (lo > union.0[k] + slack
                    || hi < union.1[k] - slack
                    || lo < union.0[k] - tol
                    || hi > union.1[k] + tol)
            {
                return Err(format!(
                    "leaf {leaf_index}: box {b:?} vs clipped parts {union:?} on axis {k}"
                ));
            }
        }
    }

    // (a) every triangle is referenced by every leaf whose interior its part enters by more
    // than `tol` (on each axis where the cell has thickness).
    for (id, refs) in referenced_by.iter().enumerate() {
        let tri = mesh.triangle(id);
        let tri_box = Aabb::from_points([tri.v0, tri.v1, tri.v2]);
        for leaf_index in leaves_near(tree, &w, &tri_box, tol) {
            if refs.contains(&leaf_index) {
                continue;
            }
            let leaf = &leaves[leaf_index];
            let (cell_lo, cell_hi) = (f64s(leaf.cell.min), f64s(leaf.cell.max));
            let part = clip(&tri, cell_lo, cell_hi);
            if part.is_empty() {
                continue;
            }
            let (lo, hi) = polygon_box(&part);
            let enters = (0..3).all(|k| {
                cell_lo[k] == cell_hi[k] || (hi[k] > cell_lo[k] + tol && lo[k] < cell_hi[k] - tol)
            });
            if enters {
                return Err(format!(
                    "triangle {id} {tri:?} enters leaf {leaf_index} (cell {:?}) but is not in it",
                    leaf.cell
                ));
            }
        }
    }

    // (g) the wide nodes reach every non-empty leaf once, inside boxes holding its tight box,
    // and no deeper than their traversal's stack allows.
    check_wide(tree)?;

    // (d) statistics agree with a recount.
    let s = tree.stats();
    let nonempty = leaves.iter().filter(|l| l.record.count > 0).count();
    let refs: usize = leaves.iter().map(|l| l.record.count as usize).sum();
    let expected = (
        mesh.triangle_count(),
        tree.nodes().len(),
        leaves.len(),
        nonempty,
        refs,
        leaves.iter().map(|l| l.depth).max().unwrap_or(0),
        tree.nodes().len() * 8
            + tree.wide_nodes().bytes()
            + std::mem::size_of_val(tree.leaves())
            + leaves
                .iter()
                .map(|l| (l.record.count as usize).div_ceil(BLOCK))
                .sum::<usize>()
                * size_of::<TriangleBlock>(),
    );
    let got = (
        s.triangles,
        s.nodes,
        s.leaves,
        s.nonempty_leaves,
        s.triangle_refs,
        s.max_depth,
        s.bytes,
    );
    if got != expected {
        return Err(format!("stats {got:?} != recount {expected:?}"));
    }
    if tree.leaves().len() != nonempty + 1 {
        return Err(format!(
            "{} leaf records for {nonempty} non-empty leaves (+1 shared empty)",
            tree.leaves().len()
        ));
    }
    Ok(())
}

/// The wide nodes' invariants: each non-empty leaf record is the child of exactly one wide
/// node, whose box for it holds the leaf's tight box; a node's box for a child node holds
/// every box of that child; missing children have the empty box `(+inf, −inf)`; and a path
/// from the root leaves at most `WIDE_STACK` children pending.
fn check_wide(tree: &KdTree) -> Result<(), String> {
    let nodes = tree.wide_nodes().nodes();
    let child_box = |n: &WideNode, i: usize| {
        let p = &n.planes;
        Aabb::new(
            Vec3::new(p[0][i], p[1][i], p[2][i]),
            Vec3::new(p[3][i], p[4][i], p[5][i]),
        )
    };
    let mut seen = vec![0u32; tree.leaves().len()];
    let mut visited = vec![false; nodes.len()];
    // (node, box its parent gave it, children pending along the path)
    let mut work = vec![(
        0usize,
        Aabb::new(Vec3::NEG_INFINITY, Vec3::INFINITY),
        0usize,
    )];
    while let Some((at, outer, pending)) = work.pop() {
        if std::mem::replace(&mut visited[at], true) {
            return Err(format!("wide node {at} reached twice"));
        }
        let node = &nodes[at];
        let children = node
            .children
            .iter()
            .filter(|&&c| c != WideChild::NONE)
            .count();
        let pending = pending + children.saturating_sub(1);
        if pending + 1 > WIDE_STACK {
            return Err(format!("{pending} children pending at wide node {at}"));
        }
        for (i, &child) in node.children.iter().enumerate() {
            let b = child_box(node, i);
            if child == WideChild::NONE {
                if b.min != Vec3::INFINITY || b.max != Vec3::NEG_INFINITY {
                    return Err(format!("missing child {i} of wide node {at} has box {b:?}"));
                }
                continue;
            }
            if !outer.contains_box(&b) {
                return Err(format!("wide node {at} child {i}: {b:?} outside {outer:?}"));
            }
            if child.is_node() {
                work.push((child.index() as usize, b, pending));
            } else {
                let record = &tree.leaves()[child.index() as usize];
                seen[child.index() as usize] += 1;
                if record.count == 0 || !b.contains_box(&record.bounds) {
                    return Err(format!(
                        "wide node {at} child {i}: leaf {} of {} triangles, box {:?} in {b:?}",
                        child.index(),
                        record.count,
                        record.bounds
                    ));
                }
            }
        }
    }
    if visited.contains(&false) {
        return Err("a wide node is unreachable".into());
    }
    // Record 0 is the shared empty leaf; every other is reached once.
    match seen.iter().skip(1).position(|&n| n != 1) {
        Some(r) => Err(format!(
            "leaf record {} reached {} times",
            r + 1,
            seen[r + 1]
        )),
        None => Ok(()),
    }
}

fn build_and_check(mesh: &Mesh, params: &BuildParams) -> KdTree {
    let tree = KdTree::build(mesh, params).unwrap();
    if let Err(e) = check(mesh, params, &tree) {
        panic!("{params:?}: {e}\n{}", tree.stats());
    }
    tree
}

// ---------------------------------------------------------------------------------------------
// Generated meshes.

#[test]
fn soup_grid_and_sphere_satisfy_every_invariant_for_each_cost_ratio() {
    let meshes = [
        ("soup", soup(1500, 0.08, [0.0; 3], 1)),
        ("large-triangle soup", soup(300, 0.6, [0.0; 3], 2)),
        ("grid", grid(24)),
        ("sphere", sphere(16, 32, 1.0, [0.0; 3])),
    ];
    for (name, mesh) in &meshes {
        let mut nodes = Vec::new();
        for ci in [0.1, 1.0, 10.0] {
            let tree = build_and_check(mesh, &params(ci));
            println!("{name} ci/ct {ci}: {}", tree.stats());
            nodes.push(tree.stats().nodes);
        }
        // A larger intersection cost makes splitting pay: the tree never shrinks, and grows
        // from 0.1 to 10.
        assert!(
            nodes[0] <= nodes[1] && nodes[1] <= nodes[2] && nodes[0] < nodes[2],
            "{name}: nodes {nodes:?}"
        );
    }
}

#[test]
fn every_exact_search_threshold_satisfies_every_invariant() {
    // All binned, the default, and all exact, on a soup (many straddlers) and a grid (many
    // triangles in the binned boundaries' planes and sharing positions).
    let meshes = [("soup", soup(1500, 0.08, [0.0; 3], 9)), ("grid", grid(24))];
    for (name, mesh) in &meshes {
        let mut costs = Vec::new();
        for exact_search_max in [0, 8, 64, u32::MAX] {
            let p = BuildParams::default().with_exact_search_max(exact_search_max);
            let tree = build_and_check(mesh, &p);
            println!("{name} exact ≤ {exact_search_max}: {}", tree.stats());
            costs.push(tree.sah_cost(p.ci_over_ct));
        }
        // The exact search finds the cheapest plane of each node, binning an estimate. Greedy
        // choices do not make the exact tree always cheaper, but binning everything must not be
        // much better (a wrong count in the sweep would show here): 5%, where the exact trees
        // measured 7% (soup) and 10% (grid) cheaper.
        assert!(costs[3] <= costs[0] * 1.05, "{name}: SAH costs {costs:?}");
    }
}

#[test]
fn leaf_size_depth_limit_and_empty_bonus_are_respected() {
    let mesh = soup(800, 0.1, [0.0; 3], 3);
    for p in [
        BuildParams::default()
            .with_leaf_size(8)
            .with_ci_over_ct(10.0),
        BuildParams::default()
            .with_max_depth(Some(3))
            .with_ci_over_ct(10.0),
        BuildParams::default().with_max_depth(Some(0)),
        BuildParams::default().with_empty_bonus(0.0),
        BuildParams::default().with_empty_bonus(0.95),
    ] {
        let tree = build_and_check(&mesh, &p);
        if p.max_depth == Some(0) {
            assert_eq!(tree.nodes().len(), 1);
        }
    }
}

#[test]
fn sah_separates_distant_clusters_and_cuts_off_empty_space() {
    // Two clusters at opposite corners of a big box: no leaf may hold triangles of both, and
    // the leaf boxes must be far smaller than the root.
    let mut mesh = soup(100, 0.05, [0.0; 3], 4);
    mesh.append(&soup(100, 0.05, [99.0, 99.0, 99.0], 5))
        .unwrap();
    let tree = build_and_check(&mesh, &BuildParams::default());
    for leaf in tree.leaves() {
        let ids: Vec<u32> = tree.leaf_triangles(leaf).ids().collect();
        assert!(
            ids.iter().all(|&i| i < 100) || ids.iter().all(|&i| i >= 100),
            "mixed leaf {ids:?}"
        );
        if leaf.count > 0 {
            assert!(leaf.bounds.extent().max_element() <= 1.1, "{leaf:?}");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (e) Parameters.

#[test]
fn invalid_parameters_are_rejected_by_name() {
    let mesh = soup(10, 0.1, [0.0; 3], 6);
    let d = BuildParams::default();
    let cases = [
        ("ci_over_ct", d.with_ci_over_ct(0.0)),
        ("ci_over_ct", d.with_ci_over_ct(-1.0)),
        ("ci_over_ct", d.with_ci_over_ct(f32::NAN)),
        ("ci_over_ct", d.with_ci_over_ct(f32::INFINITY)),
        ("empty_bonus", d.with_empty_bonus(1.0)),
        ("empty_bonus", d.with_empty_bonus(-0.1)),
        ("empty_bonus", d.with_empty_bonus(f32::NAN)),
        ("max_depth", d.with_max_depth(Some(65))),
        ("leaf_size", d.with_leaf_size(0)),
    ];
    for (field, p) in cases {
        match KdTree::build(&mesh, &p) {
            Err(Error::InvalidParameter { name, .. }) => assert_eq!(name, field, "{p:?}"),
            other => panic!("{p:?}: expected InvalidParameter({field}), got {other:?}"),
        }
    }
}

// ---------------------------------------------------------------------------------------------
// (f) Robustness.

#[test]
fn empty_mesh_is_one_empty_leaf() {
    let mesh = Mesh::default();
    let tree = build_and_check(&mesh, &BuildParams::default());
    assert_eq!(tree.nodes().len(), 1);
    assert!(tree.nodes()[0].is_leaf());
    assert!(tree.bounds().is_empty());
    assert_eq!(tree.stats().nonempty_leaves, 0);
}

#[test]
fn single_triangle_is_one_leaf_with_its_box() {
    let mesh = Mesh::from_soup(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.5]]).unwrap();
    let tree = build_and_check(&mesh, &params(10.0));
    assert_eq!(tree.nodes().len(), 1);
    assert_eq!(tree.leaves()[1].bounds, mesh.bounds());
}

#[test]
fn degenerate_triangles_build_and_stay_referenced() {
    // Points, segments (collinear vertices) and repeated vertices, mixed with real triangles.
    let mut positions = Vec::new();
    let mut rng = Lcg(8);
    for i in 0..300 {
        let p = [rng.next(), rng.next(), rng.next()];
        let q = [rng.next(), rng.next(), rng.next()];
        let mid = [0, 1, 2].map(|k| 0.5 * (p[k] + q[k]));
        match i % 3 {
            0 => positions.extend([p, p, p]),
            1 => positions.extend([p, mid, q]),
            _ => positions.extend([p, q, [q[0], p[1], rng.next()]]),
        }
    }
    let mesh = Mesh::from_soup(&positions).unwrap();
    for ci in [0.1, 1.0, 10.0] {
        let tree = build_and_check(&mesh, &params(ci));
        let ids: BTreeSet<u32> = tree
            .leaves()
            .iter()
            .flat_map(|l| tree.leaf_triangles(l).ids())
            .collect();
        assert_eq!(
            ids.len(),
            mesh.triangle_count(),
            "every triangle in some leaf"
        );
    }
}

#[test]
fn all_vertices_equal_is_one_leaf() {
    let mesh = Mesh::from_soup(&[[3.0, -2.0, 1.0]; 30]).unwrap();
    let tree = build_and_check(&mesh, &params(10.0));
    assert_eq!(tree.nodes().len(), 1);
    assert_eq!(tree.leaves()[1].count, 10);
}

#[test]
fn flat_meshes_build_on_each_axis() {
    // The grid lies in z = 0; rotate it into x = 0 and y = 0 as well, and add a flat segment
    // mesh (zero thickness on two axes).
    let g = grid(12);
    for perm in [[0, 1, 2], [2, 0, 1], [1, 2, 0]] {
        let positions: Vec<Vec3> = g
            .positions()
            .iter()
            .map(|p| Vec3::new(p[perm[0]], p[perm[1]], p[perm[2]]))
            .collect();
        let mesh = Mesh::from_faces(positions, g.faces().to_vec()).unwrap();
        for ci in [0.1, 1.0, 10.0] {
            let tree = build_and_check(&mesh, &params(ci));
            assert!(tree.stats().nodes > 1, "a flat grid is still split");
        }
    }
    let line: Vec<[f32; 3]> = (0..60).map(|i| [i as f32 / 3.0, 0.0, 0.0]).collect();
    build_and_check(&Mesh::from_soup(&line).unwrap(), &params(10.0));
}

#[test]
fn duplicated_triangles_build() {
    let one = soup(40, 0.2, [0.0; 3], 9);
    let mut mesh = one.clone();
    for _ in 0..20 {
        mesh.append(&one).unwrap();
    }
    for ci in [0.1, 1.0, 10.0] {
        build_and_check(&mesh, &params(ci));
    }
}

#[test]
fn huge_offsets_build() {
    // The leak tests' sphere far from the origin, and a soup 1e5 away.
    let center = [148376.0, 1234.0, -223423.0];
    for ci in [0.1, 1.0, 10.0] {
        build_and_check(&sphere(12, 24, 50.0, center), &params(ci));
        build_and_check(&soup(500, 0.05, [1e5, -1e5, 1e5], 10), &params(ci));
    }
}

// ---------------------------------------------------------------------------------------------
// Real scenes.

/// Builds the shared scene `name` at two tree sizes and checks every invariant; skipped, saying
/// why, when the scene is not there.
fn real_scene(name: &str) {
    let Some(mesh) = common::scenes::load_shared(name) else {
        return;
    };
    for ci in [1.0, 10.0] {
        let tree = build_and_check(&mesh, &params(ci));
        println!("{name} ci/ct {ci}: {}", tree.stats());
    }
}

#[test]
fn real_scene_bunny() {
    real_scene("bunny");
}

#[test]
fn real_scene_sponza() {
    real_scene("sponza");
}

#[test]
fn real_scene_dragon() {
    real_scene("dragon");
}

#[test]
fn real_scene_killeroo() {
    real_scene("killeroo");
}

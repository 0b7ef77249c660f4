//! Build statistics.

use std::fmt;
use std::time::Duration;

use kdbeam_kernels::{Aabb, DVec3};

use super::Node;

/// What a build produced and how long it took.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuildStats {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// All nodes, inner and leaf.
    pub nodes: usize,
    /// Leaf nodes, empty ones included.
    pub leaves: usize,
    /// Leaves holding at least one triangle.
    pub nonempty_leaves: usize,
    /// Triangle references summed over leaves (a triangle straddling splits counts once per leaf).
    pub triangle_refs: usize,
    /// Deepest leaf (the root has depth 0).
    pub max_depth: u32,
    /// Bytes of nodes, wide nodes, leaf records and leaf-ordered triangle arrays.
    pub bytes: usize,
    /// Wall-clock time of the build.
    pub build_time: Duration,
}

/// The SAH cost of a tree ([`super::KdTree::sah_cost`]; MacDonald & Booth 1990; Wald &
/// Havran 2006, eq. 1), summed in f64 over the cells the splits make from `root`, with
/// `leaf_count(record)` the triangles of a leaf's record.
pub(super) fn sah_cost(
    nodes: &[Node],
    root: Aabb,
    ci_over_ct: f32,
    leaf_count: impl Fn(u32) -> u32,
) -> f64 {
    let area = |b: &Aabb| {
        let e = (b.max - b.min).as_dvec3().max(DVec3::ZERO);
        2.0 * (e.x * e.y + e.y * e.z + e.z * e.x)
    };
    let root_area = area(&root);
    let weight = |b: &Aabb| {
        if root_area > 0.0 && root_area.is_finite() {
            area(b) / root_area
        } else {
            1.0
        }
    };
    let mut cost = 0.0;
    let mut stack = vec![(0usize, root)];
    while let Some((at, cell)) = stack.pop() {
        let node = nodes[at];
        if node.is_leaf() {
            cost +=
                weight(&cell) * f64::from(ci_over_ct) * f64::from(leaf_count(node.leaf_record()));
            continue;
        }
        cost += weight(&cell);
        let (mut below, mut above) = (cell, cell);
        below.max[node.axis()] = node.split();
        above.min[node.axis()] = node.split();
        stack.push((node.above_child() as usize, above));
        stack.push((at + 1, below));
    }
    cost
}

impl BuildStats {
    /// Mean triangles per non-empty leaf (0 when there are none).
    #[must_use]
    pub fn mean_leaf_size(&self) -> f64 {
        ratio(self.triangle_refs, self.nonempty_leaves)
    }

    /// Nodes per triangle: the tree-size axis of Reshetov's Figs. 7–9.
    #[must_use]
    pub fn nodes_per_triangle(&self) -> f64 {
        ratio(self.nodes, self.triangles)
    }

    /// Bytes per mesh triangle.
    #[must_use]
    pub fn bytes_per_triangle(&self) -> f64 {
        ratio(self.bytes, self.triangles)
    }

    /// Mesh triangles built per second.
    #[must_use]
    pub fn triangles_per_second(&self) -> f64 {
        self.triangles as f64 / self.build_time.as_secs_f64().max(1e-9)
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

impl fmt::Display for BuildStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} triangles, {} nodes ({:.2}/triangle), {} leaves ({} non-empty, {:.2} triangles each), \
             depth {}, {:.1} MiB ({:.0} B/triangle), built in {:.3} s ({:.2} M triangles/s)",
            self.triangles,
            self.nodes,
            self.nodes_per_triangle(),
            self.leaves,
            self.nonempty_leaves,
            self.mean_leaf_size(),
            self.max_depth,
            self.bytes as f64 / (1 << 20) as f64,
            self.bytes_per_triangle(),
            self.build_time.as_secs_f64(),
            self.triangles_per_second() / 1e6,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use kdbeam_kernels::Vec3;

    #[test]
    fn sah_cost_weighs_each_node_by_its_cells_area() {
        // The unit cube split at x = 0.5: the below half (area 4 of 6) holds 2 triangles, the
        // above half is empty. Cost = 1 + 1.5 · (4/6) · 2 = 3 (exact in f64 up to rounding of
        // 4/6, hence the 1e-12 tolerance).
        let nodes = [Node::inner(0, 0.5, 2), Node::leaf(1), Node::leaf(0)];
        let root = Aabb::new(Vec3::ZERO, Vec3::ONE);
        let cost = sah_cost(&nodes, root, 1.5, |r| [0, 2][r as usize]);
        assert!((cost - 3.0).abs() < 1e-12, "{cost}");
        // A root on a line weighs every cell 1: 1 + 1.5 · 2.
        let line = Aabb::new(Vec3::ZERO, Vec3::X);
        let cost = sah_cost(&nodes, line, 1.5, |r| [0, 2][r as usize]);
        assert!((cost - 4.0).abs() < 1e-12, "{cost}");
    }
}

//! Wide nodes: the kd-tree seen by single rays, three levels and more at a time, with boxes.
//!
//! A single ray steps through a binary kd-tree one split at a time, and most of the cells it
//! crosses around a surface are empty (the SAH's empty-space cuts): a short ray from a surface
//! visits dozens of inner nodes for one or two leaves that hold triangles. The wide nodes
//! collapse the tree into nodes of up to [`WIDE`] children, each child with the box of the
//! geometry below it: the tight boxes of its non-empty leaves, joined. A ray tests all the
//! children's boxes of a node in one SIMD step, as Embree's BVH8 does, and never enters empty
//! space, as the boxes hold only geometry. The children are disjoint kd-tree cells (a box lies
//! in its child's cell), and the leaves are the tree's own leaves, so the packet paths and the
//! single rays read one leaf layout.
//!
//! Every box is padded outward by [`BOX_PAD`] of its size and position: a triangle's part in a
//! cell, clipped with rounding, and a hit that the triangle test reports on its edge lie inside
//! the padded box of every leaf that holds the triangle. It is padded further by a part of the
//! tree's magnitude ([`WideNodes::reach`]), which holds the rounding of a ray's fused plane
//! distances when its origin lies within that magnitude, so that such rays take their boxes'
//! intervals as computed.

use kdbeam_kernels::{Aabb, Vec3};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::{pages, LeafRecord, Node};

/// Children per wide node.
pub const WIDE: usize = 8;

/// Relative padding of the children's boxes (2⁻¹⁸ of their extent plus their coordinates'
/// magnitude): far above the rounding of a clipped triangle's bounds and of a triangle test's
/// edge functions, which are a few ulps (2⁻²³).
pub const BOX_PAD: f32 = 1.0 / 262_144.0;

/// Pending entries a traversal of wide nodes can hold: each node leaves at most `WIDE - 1`
/// children for later, and a path from the root meets at most 22 nodes, as each wide node
/// spans at least three levels of a tree at most 64 deep ([`WideNodes::build`]).
pub const WIDE_STACK: usize = 22 * (WIDE - 1) + 1;

/// A child of a wide node: a wide node, a non-empty leaf or nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WideChild(u32);

const LEAF_BIT: u32 = 1 << 31;

impl WideChild {
    /// No child: its box is empty, so no ray enters it.
    pub const NONE: WideChild = WideChild(u32::MAX);

    /// The root node, node 0.
    pub const ROOT: WideChild = WideChild(0);

    /// The wide node of index `index`.
    #[inline(always)]
    #[must_use]
    pub fn node(index: u32) -> WideChild {
        debug_assert!(index < LEAF_BIT);
        WideChild(index)
    }

    /// The leaf of record `record` (a [`Node::leaf_record`], below 2³⁰).
    #[inline(always)]
    #[must_use]
    pub fn leaf(record: u32) -> WideChild {
        debug_assert!(record < LEAF_BIT);
        WideChild(record | LEAF_BIT)
    }

    /// Is this a wide node (as opposed to a leaf or nothing)?
    #[inline(always)]
    #[must_use]
    pub fn is_node(self) -> bool {
        self.0 & LEAF_BIT == 0
    }

    /// The wide node's index, or the leaf's record: whichever this child is.
    #[inline(always)]
    #[must_use]
    pub fn index(self) -> u32 {
        self.0 & !LEAF_BIT
    }
}

/// Up to [`WIDE`] children and their padded boxes, in structure-of-arrays form.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WideNode {
    /// `planes[a][i]`: the `min` (`a` = axis 0, 1, 2) and `max` (`a` = 3 + axis) of child
    /// `i`'s box; `+inf` and `−inf` for [`WideChild::NONE`].
    pub planes: [[f32; WIDE]; 6],
    /// The children, in no particular order.
    pub children: [WideChild; WIDE],
}

impl WideNode {
    /// A node without children.
    const NONE: WideNode = WideNode {
        planes: [
            [f32::INFINITY; WIDE],
            [f32::INFINITY; WIDE],
            [f32::INFINITY; WIDE],
            [f32::NEG_INFINITY; WIDE],
            [f32::NEG_INFINITY; WIDE],
            [f32::NEG_INFINITY; WIDE],
        ],
        children: [WideChild::NONE; WIDE],
    };
}

/// The wide nodes of a kd-tree, root first.
#[derive(Clone, Debug)]
pub struct WideNodes {
    nodes: Vec<WideNode>,
    reach: f32,
}

impl Default for WideNodes {
    fn default() -> Self {
        WideNodes {
            nodes: Vec::new(),
            reach: f32::NEG_INFINITY,
        }
    }
}

/// The part of a kd-tree's magnitude `M` (its largest coordinate) that pads every box of its
/// wide nodes besides [`BOX_PAD`]: it holds the rounding of a fused plane distance, at most
/// 2⁻²⁴·(3|plane| + 3|o|) in space, for every ray whose origin lies within `M` on every
/// axis, with room to spare (`2⁻¹⁹·M` against `6·2⁻²⁴·M`).
const REACH_PAD: f32 = 1.0 / 524_288.0;

impl WideNodes {
    /// The nodes; node 0 is the root (without children for a tree with no triangles).
    #[inline(always)]
    #[must_use]
    pub fn nodes(&self) -> &[WideNode] {
        &self.nodes
    }

    /// The largest `|o|` on every axis of a ray whose walk needs no widening of its boxes'
    /// intervals: the tree's magnitude, whose [`REACH_PAD`] pads every box; `−inf` for nodes
    /// not padded so (a scene's top level).
    #[inline(always)]
    #[must_use]
    pub fn reach(&self) -> f32 {
        self.reach
    }

    /// Bytes the nodes take.
    #[must_use]
    pub fn bytes(&self) -> usize {
        self.nodes.len() * size_of::<WideNode>()
    }

    /// Replaces the nodes with those of the kd-tree `nodes` (root first, depth first) whose
    /// leaves are `leaves`: each wide node opens, breadth first, the shallowest inner node
    /// among its children until it has [`WIDE`] of them or only leaves, each child with its
    /// subtree's padded box, the leaves of no triangle dropped. `boxes` is a buffer for the
    /// subtrees' boxes, kept by the caller from one build to the next. A large tree's boxes
    /// and nodes are made on `rayon`'s threads, when there are more than one; the nodes are the
    /// same either way.
    pub fn build(&mut self, nodes: &[Node], leaves: &[LeafRecord], boxes: &mut Vec<Aabb>) {
        #[cfg(feature = "parallel")]
        let parallel = rayon::current_num_threads() > 1 && nodes.len() >= PARALLEL_MIN_NODES;
        #[cfg(not(feature = "parallel"))]
        let parallel = false;
        let magnitude = leaves
            .iter()
            .filter(|leaf| leaf.count > 0 && !leaf.bounds.is_empty())
            .map(|leaf| {
                leaf.bounds
                    .min
                    .abs()
                    .max(leaf.bounds.max.abs())
                    .max_element()
            })
            .fold(0.0, f32::max);
        let padded_leaves = PaddedLeaves {
            nodes,
            leaves,
            reach_pad: magnitude * REACH_PAD,
        };
        subtree_boxes(padded_leaves, boxes, parallel);
        self.reach = magnitude;
        let tree = KdSubtrees {
            nodes,
            leaves,
            boxes,
        };
        #[cfg(feature = "parallel")]
        if parallel {
            return self.collapse_in_parallel(&tree);
        }
        self.collapse(&tree);
    }

    /// Replaces the nodes with those of the binary tree `tree`, at most 64 levels deep.
    ///
    /// Each wide node takes a subtree's root and opens, breadth first, the shallowest inner
    /// node among its children until it has [`WIDE`] of them or only leaves, dropping subtrees
    /// whose box is empty. Breadth first, every inner child lies at least three levels below
    /// the node's own root (two levels hold at most four nodes, and opening each of them adds
    /// at most one child), so that a path meets at most ⌈64 / 3⌉ wide nodes in a tree at most
    /// 64 deep: what [`WIDE_STACK`] holds.
    ///
    /// The reach is left as it is: a kd-tree's build sets it, and nodes made only by collapsing
    /// (a scene's top level) keep the default's `−inf`, as their boxes carry no such padding.
    pub(crate) fn collapse(&mut self, tree: &impl BinaryBoxes) {
        self.nodes.clear();
        self.nodes.push(WideNode::NONE);
        collapse_into(tree, 0, &mut self.nodes, None);
    }

    /// [`WideNodes::collapse`], the subtrees below the wide nodes of depth [`PARALLEL_DEPTH`]
    /// collapsed in parallel, each into a buffer of its own, then moved into place.
    #[cfg(feature = "parallel")]
    fn collapse_in_parallel<T: BinaryBoxes + Sync>(&mut self, tree: &T) {
        self.nodes.clear();
        self.nodes.push(WideNode::NONE);
        let mut deferred = Vec::new();
        collapse_into(tree, 0, &mut self.nodes, Some(&mut deferred));
        let subtrees: Vec<Vec<WideNode>> = deferred
            .par_iter()
            .map(|&(root, _)| {
                let mut nodes = vec![WideNode::NONE];
                collapse_into(tree, root, &mut nodes, None);
                nodes
            })
            .collect();
        // A subtree's root replaces its placeholder; its other nodes go after the top ones,
        // node `i` of subtree `k` at `offsets[k] + i - 1`.
        let top = self.nodes.len();
        let mut offsets = Vec::with_capacity(subtrees.len());
        let mut end = top;
        for nodes in &subtrees {
            offsets.push(end);
            end += nodes.len() - 1;
        }
        for ((&(_, slot), nodes), &offset) in deferred.iter().zip(&subtrees).zip(&offsets) {
            self.nodes[slot] = nodes[0].shifted(offset - 1);
        }
        pages::reserve(&mut self.nodes, end - top);
        self.nodes
            .par_extend(rayon::iter::repeat_n(WideNode::NONE, end - top));
        let mut places = Vec::with_capacity(subtrees.len());
        let mut rest = &mut self.nodes[top..];
        for nodes in &subtrees {
            let (place, after) = std::mem::take(&mut rest).split_at_mut(nodes.len() - 1);
            places.push(place);
            rest = after;
        }
        subtrees
            .par_iter()
            .zip(places)
            .zip(&offsets)
            .for_each(|((nodes, place), &offset)| {
                for (to, node) in place.iter_mut().zip(&nodes[1..]) {
                    *to = node.shifted(offset - 1);
                }
            });
    }
}

/// Trees of at least this many nodes get their wide nodes in parallel: below it, a thread's
/// share is too small to pay for the hand-over.
#[cfg(feature = "parallel")]
pub(super) const PARALLEL_MIN_NODES: usize = 1 << 15;

/// The depth of the wide nodes whose subtrees [`WideNodes::collapse_in_parallel`] collapses in
/// parallel: up to `WIDE²` = 64 subtrees, enough for `rayon` to balance uneven ones.
#[cfg(feature = "parallel")]
const PARALLEL_DEPTH: u32 = 2;

impl WideNode {
    /// The node with the indices of its wide children raised by `by`.
    #[cfg(feature = "parallel")]
    fn shifted(mut self, by: usize) -> WideNode {
        for child in &mut self.children {
            if child.is_node() {
                *child = WideChild::node(child.index() + by as u32);
            }
        }
        self
    }
}

/// Collapses the subtree of `tree`'s node `root` into `nodes`, whose last node is the
/// subtree's wide root (still [`WideNode::NONE`]), as [`WideNodes::collapse`] describes;
/// new wide nodes are pushed. With `deferred`, the wide nodes at depth [`PARALLEL_DEPTH`] below
/// the root are left as placeholders, and each is listed with its binary root, to be collapsed
/// later: `(binary root, wide index)`.
fn collapse_into(
    tree: &impl BinaryBoxes,
    root: u32,
    nodes: &mut Vec<WideNode>,
    mut deferred: Option<&mut Vec<(u32, usize)>>,
) {
    let mut work = vec![(root, nodes.len() - 1, 0u32)];
    while let Some((root, at, wide_depth)) = work.pop() {
        let mut slots = [(0u32, 0u32); WIDE];
        let mut len = 0;
        if !tree.bounds(root).is_empty() {
            slots[0] = (root, 0);
            len = 1;
        }
        while len < WIDE {
            let shallowest = slots[..len]
                .iter()
                .enumerate()
                .filter(|(_, &(n, _))| tree.children(n).is_some())
                .min_by_key(|(_, &(_, depth))| depth)
                .map(|(i, _)| i);
            let Some(i) = shallowest else { break };
            let (n, depth) = slots[i];
            slots[i] = slots[len - 1];
            len -= 1;
            for child in tree.children(n).into_iter().flatten() {
                if !tree.bounds(child).is_empty() {
                    slots[len] = (child, depth + 1);
                    len += 1;
                }
            }
        }
        let mut node = WideNode::NONE;
        for (i, &(n, _)) in slots[..len].iter().enumerate() {
            let b = tree.bounds(n);
            for axis in 0..3 {
                node.planes[axis][i] = b.min[axis];
                node.planes[3 + axis][i] = b.max[axis];
            }
            node.children[i] = if tree.children(n).is_none() {
                WideChild::leaf(tree.leaf(n))
            } else {
                let index = nodes.len();
                nodes.push(WideNode::NONE);
                match deferred.as_deref_mut() {
                    #[cfg(feature = "parallel")]
                    Some(later) if wide_depth + 1 == PARALLEL_DEPTH => later.push((n, index)),
                    _ => work.push((n, index, wide_depth + 1)),
                }
                WideChild::node(index as u32)
            };
        }
        nodes[at] = node;
    }
}

/// A binary tree of boxes, as [`WideNodes::collapse`] reads it: node 0 is the root.
pub(crate) trait BinaryBoxes {
    /// The two children of node `n`, or `None` when `n` is a leaf.
    fn children(&self, n: u32) -> Option<[u32; 2]>;
    /// The box of everything under node `n`, padded as the rays that test it need; empty when
    /// nothing under it is to be traced.
    fn bounds(&self, n: u32) -> Aabb;
    /// What the leaf `n` is to a traversal: the index of its [`WideChild::leaf`], below 2³¹.
    fn leaf(&self, n: u32) -> u32;
}

/// A kd-tree's nodes with the padded box of each subtree's leaves.
struct KdSubtrees<'a> {
    nodes: &'a [Node],
    leaves: &'a [LeafRecord],
    boxes: &'a [Aabb],
}

impl BinaryBoxes for KdSubtrees<'_> {
    fn children(&self, n: u32) -> Option<[u32; 2]> {
        let node = self.nodes[n as usize];
        (!node.is_leaf()).then(|| [n + 1, node.above_child()])
    }

    fn bounds(&self, n: u32) -> Aabb {
        self.boxes[n as usize]
    }

    fn leaf(&self, n: u32) -> u32 {
        let record = self.nodes[n as usize].leaf_record();
        debug_assert!(self.leaves[record as usize].count > 0);
        record
    }
}

/// Replaces `boxes` with the padded box of every subtree's leaves, by node: children follow
/// their parent in `nodes`, so one backward pass joins them; with `parallel`, the two
/// subtrees of a large node are joined side by side (a subtree's nodes are contiguous, depth
/// first).
fn subtree_boxes(tree: PaddedLeaves<'_>, boxes: &mut Vec<Aabb>, parallel: bool) {
    let nodes = tree.nodes;
    #[cfg(feature = "parallel")]
    if parallel {
        pages::zeroed(boxes, nodes.len(), Aabb::EMPTY);
        join_boxes_in_parallel(tree, 0, boxes);
        return;
    }
    let _ = parallel;
    boxes.clear();
    pages::reserve(boxes, nodes.len());
    boxes.resize(nodes.len(), Aabb::EMPTY);
    join_boxes(tree, 0, boxes);
}

/// A kd-tree's nodes and leaves, and the absolute padding of its leaves' boxes.
#[derive(Clone, Copy)]
struct PaddedLeaves<'a> {
    nodes: &'a [Node],
    leaves: &'a [LeafRecord],
    reach_pad: f32,
}

/// Writes the box of every node of the subtree whose nodes are `tree.nodes[first..][..out.len()]`
/// to `out`, by one backward pass; returns the subtree's box.
fn join_boxes(tree: PaddedLeaves<'_>, first: usize, out: &mut [Aabb]) -> Aabb {
    for i in (0..out.len()).rev() {
        let node = tree.nodes[first + i];
        out[i] = if node.is_leaf() {
            leaf_box(&tree.leaves[node.leaf_record() as usize], tree.reach_pad)
        } else {
            out[i + 1].union(out[node.above_child() as usize - first])
        };
    }
    out.first().copied().unwrap_or(Aabb::EMPTY)
}

/// [`join_boxes`], the two subtrees of a node of at least [`PARALLEL_MIN_NODES`] nodes
/// joined in parallel.
#[cfg(feature = "parallel")]
fn join_boxes_in_parallel(tree: PaddedLeaves<'_>, first: usize, out: &mut [Aabb]) -> Aabb {
    let node = tree.nodes[first];
    if out.len() < PARALLEL_MIN_NODES || node.is_leaf() {
        return join_boxes(tree, first, out);
    }
    let above = node.above_child() as usize;
    let (own, rest) = out.split_at_mut(1);
    let (below_out, above_out) = rest.split_at_mut(above - first - 1);
    let (below, above) = rayon::join(
        || join_boxes_in_parallel(tree, first + 1, below_out),
        || join_boxes_in_parallel(tree, above, above_out),
    );
    own[0] = below.union(above);
    own[0]
}

/// A leaf's padded box: empty for a leaf of no triangle.
fn leaf_box(leaf: &LeafRecord, reach_pad: f32) -> Aabb {
    match (leaf.count, leaf.bounds.is_empty()) {
        (0, _) => Aabb::EMPTY,
        // The builder never makes this; were it to, the leaf would stay reachable.
        (_, true) => Aabb::new(Vec3::NEG_INFINITY, Vec3::INFINITY),
        (_, false) => padded(leaf.bounds, reach_pad),
    }
}

/// `b` grown by [`BOX_PAD`] of its extent and its coordinates' magnitude, and by `reach_pad`,
/// on every side.
fn padded(b: Aabb, reach_pad: f32) -> Aabb {
    if b.is_empty() {
        return b;
    }
    let pad = (b.extent() + b.min.abs().max(b.max.abs())) * BOX_PAD + Vec3::splat(reach_pad);
    let pad = pad.max(Vec3::splat(f32::MIN_POSITIVE));
    Aabb::new(b.min - pad, b.max + pad)
}

#[cfg(test)]
mod tests {
    use super::{padded, REACH_PAD};
    use crate::scene::rng::Rng;
    use kdbeam_kernels::lanes::Dispatch;
    use kdbeam_kernels::slab::{clip_planes_fused, exact_interval, fused_offsets};
    use kdbeam_kernels::{Aabb, LaneTask, Lanes, Ray, Vec3};

    /// Rays from within magnitude `m` and boxes within it: small boxes near 0 met by rays from
    /// `±m`, boxes at `±m`, tiny and zero direction components, origins on face planes, half
    /// of the rays aimed at their box.
    fn rays_and_boxes(rng: &mut Rng, count: usize) -> Vec<(Ray, Aabb, f32)> {
        (0..count)
            .map(|_| {
                let m = [1e-3, 1.0, 7.0, 1e4][rng.below(4) as usize];
                let coordinate = |rng: &mut Rng| rng.range(-m, m);
                let point =
                    |rng: &mut Rng| Vec3::new(coordinate(rng), coordinate(rng), coordinate(rng));
                let size = m * [1e-6, 1e-3, 0.1, 1.0][rng.below(4) as usize];
                let corner = point(rng) * [1.0, 1e-3][rng.below(2) as usize];
                let far = corner
                    + Vec3::new(
                        rng.range(0.0, size),
                        rng.range(0.0, size),
                        rng.range(0.0, size),
                    );
                let b = Aabb::new(corner.max(Vec3::splat(-m)), far.min(Vec3::splat(m)));
                let mut o = point(rng);
                let mut d = Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                );
                for k in 0..3 {
                    match rng.below(8) {
                        0 => o[k] = if rng.below(2) == 0 { m } else { -m },
                        1 => o[k] = b.min[k],
                        2 => d[k] = 0.0,
                        3 => d[k] = 1e-20,
                        _ => {}
                    }
                }
                if rng.below(2) == 0 {
                    d = b.center() - o;
                }
                let tmin = if rng.below(2) == 0 {
                    0.0
                } else {
                    rng.range(0.0, 1.0)
                };
                let ray = Ray {
                    origin: o,
                    direction: d,
                    tmin,
                    tmax: f32::INFINITY,
                };
                (ray, b, m)
            })
            .collect()
    }

    /// The walk's interval of each case's box, padded by `REACH_PAD·m`, as the ISA's
    /// `clip_planes_fused` computes it (FMA or not), unwidened; `None` for boxes the ray does not
    /// meet exactly without that padding, and the cases whose interval misses the exact one.
    struct WalkIntervals(Vec<(Ray, Aabb, f32)>);

    impl LaneTask for WalkIntervals {
        type Output = (usize, Vec<String>);

        #[inline(always)]
        fn run<L: Lanes>(self, l: L) -> (usize, Vec<String>) {
            let (mut met, mut failures) = (0, Vec::new());
            for (ray, b, m) in self.0 {
                let Some((n, f)) = exact_interval(&ray, &padded(b, 0.0)) else {
                    continue;
                };
                met += 1;
                let reach_padded = padded(b, m * REACH_PAD);
                let inv = ray.direction.recip();
                let splat = |v: [f32; 3]| [l.splat(v[0]), l.splat(v[1]), l.splat(v[2])];
                let planes = |lo: Vec3, hi: Vec3| {
                    splat([0, 1, 2].map(|k| if inv[k] < 0.0 { hi[k] } else { lo[k] }))
                };
                let (near, far) = clip_planes_fused(
                    &splat(fused_offsets(ray.origin, inv)),
                    &splat(inv.to_array()),
                    planes(reach_padded.min, reach_padded.max),
                    planes(reach_padded.max, reach_padded.min),
                    l.splat(ray.tmin),
                    l.splat(ray.tmax),
                );
                let (mut cn, mut cf) = ([0.0; 16], [0.0; 16]);
                l.store(near, &mut cn);
                l.store(far, &mut cf);
                if !(f64::from(cn[0]) <= n && f64::from(cf[0]) >= f) {
                    failures.push(format!(
                        "{}: ({}, {}) misses ({n}, {f}): {ray:?} {b:?} m {m}",
                        L::ISA,
                        cn[0],
                        cf[0]
                    ));
                }
            }
            (met, failures)
        }
    }

    /// A ray from within a tree's magnitude `M`, its box intervals taken as the walk computes
    /// them on every ISA (with FMA and without) and not widened, holds the exact interval of
    /// every box it meets once the box carries `REACH_PAD·M` besides `BOX_PAD`.
    #[test]
    fn the_reach_padding_holds_the_rounding_of_rays_from_within_it() {
        let cases = rays_and_boxes(&mut Rng::new(41), 200_000);
        for dispatch in Dispatch::available() {
            let (met, failures) = dispatch.run(WalkIntervals(cases.clone()));
            assert!(
                failures.is_empty(),
                "{} failures, first {:#?}",
                failures.len(),
                &failures[..failures.len().min(4)]
            );
            assert!(met > 50_000, "only {met} boxes met");
        }
    }
}

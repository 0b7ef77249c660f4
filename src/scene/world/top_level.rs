//! The top level: a binary BVH over the world boxes of the scene's instances.
//!
//! Why a BVH and not a second kd-tree: instances overlap (a forest of trees on a terrain), and
//! a kd-tree would split their boxes and reference one instance from many leaves, so a ray
//! would descend into the same instance's tree more than once; a BVH holds each instance
//! exactly once, and its build is a partition of the items with no clipping. It is rebuilt
//! from scratch on every commit that moves anything, by binned SAH (I. Wald, *On fast
//! Construction of SAH-based Bounding Volume Hierarchies*, IEEE Symposium on Interactive Ray
//! Tracing 2007): `O(n log n)` with 16 bins per node and leaves of at most 2 instances, as
//! descending into an instance (transforming the ray, traversing its kd-tree) costs far more
//! than a box test. Rebuilding rather than refitting keeps the tree good however far
//! instances move.

use glam::Vec3A;
use kdbeam_kernels::Aabb;

use crate::kdtree::{BinaryBoxes, WideNodes};

/// At most this many instances per leaf.
const LEAF_SIZE: usize = 2;
/// Bins of the SAH sweep.
const BINS: usize = 16;
/// Deepest the tree gets: the build splits ranges of `n > LEAF_SIZE` items into two non-empty
/// parts, so depth is below `n`; beyond this it makes a leaf of what is left.
pub(super) const MAX_DEPTH: usize = 64;

/// A node: an inner node when `count == 0` (children at `first` and `first + 1`), else a leaf
/// of items `items[first..first + count]`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Node {
    pub bounds: Aabb,
    pub first: u32,
    pub count: u32,
}

/// A box in SIMD registers, for the build's many unions.
#[derive(Clone, Copy, Debug)]
struct Box3 {
    min: Vec3A,
    max: Vec3A,
}

impl Box3 {
    const EMPTY: Box3 = Box3 {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    #[inline(always)]
    fn union(self, o: Box3) -> Box3 {
        Box3 {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    #[inline(always)]
    fn grow(self, p: Vec3A) -> Box3 {
        Box3 {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Half the surface area (0 when empty).
    #[inline(always)]
    fn half_area(self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    fn aabb(self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// A node waiting to be split: its depth and the box of its items' centroids.
struct Pending {
    node: usize,
    depth: usize,
    centroids: Box3,
}

/// The BVH: nodes, root first (absent when there are no items), the item order its leaves
/// index, and the same tree in wide nodes, whose leaves are the BVH's leaf nodes.
#[derive(Clone, Debug, Default)]
pub(super) struct TopLevel {
    pub nodes: Vec<Node>,
    pub items: Vec<u32>,
    /// For single rays: a vector of child boxes per step ([`crate::trace::wide::walk`]), as
    /// the instances' kd-trees are traced; packets walk `nodes`, a vector of rays per box.
    pub wide: WideNodes,
    boxes: Vec<Box3>,
    centroids: Vec<Vec3A>,
    /// The bin of each item at the current split.
    bins: Vec<u8>,
}

/// Where a node splits: the right part's start, and both parts' boxes and centroid boxes.
struct Split {
    mid: usize,
    bounds: [Box3; 2],
    centroids: [Box3; 2],
}

impl TopLevel {
    /// Rebuilds over `boxes`, reusing the memory: every item whose box is not empty is in
    /// exactly one leaf, every leaf's box holds its items' boxes and every inner node's box its
    /// children's.
    pub(super) fn rebuild(&mut self, boxes: &[Aabb]) {
        self.nodes.clear();
        self.items.clear();
        self.boxes.clear();
        self.centroids.clear();
        self.bins.clear();
        self.bins.resize(boxes.len(), 0);
        self.boxes.extend(boxes.iter().map(|b| Box3 {
            min: b.min.into(),
            max: b.max.into(),
        }));
        self.centroids
            .extend(self.boxes.iter().map(|b| (b.min + b.max) * 0.5));
        self.items
            .extend((0..boxes.len() as u32).filter(|&i| !boxes[i as usize].is_empty()));
        if self.items.is_empty() {
            self.wide = WideNodes::default();
            return;
        }
        let (mut all, mut centroids) = (Box3::EMPTY, Box3::EMPTY);
        for &i in &self.items {
            all = all.union(self.boxes[i as usize]);
            centroids = centroids.grow(self.centroids[i as usize]);
        }
        self.nodes.push(Node {
            bounds: all.aabb(),
            first: 0,
            count: self.items.len() as u32,
        });
        let mut stack = vec![Pending {
            node: 0,
            depth: 0,
            centroids,
        }];
        while let Some(p) = stack.pop() {
            let Node { first, count, .. } = self.nodes[p.node];
            let range = first as usize..(first + count) as usize;
            if range.len() <= LEAF_SIZE || p.depth >= MAX_DEPTH {
                continue;
            }
            let split = self.split(range.clone(), p.centroids);
            let children = self.nodes.len();
            for (side, r) in [range.start..split.mid, split.mid..range.end]
                .into_iter()
                .enumerate()
            {
                self.nodes.push(Node {
                    bounds: split.bounds[side].aabb(),
                    first: r.start as u32,
                    count: r.len() as u32,
                });
                stack.push(Pending {
                    node: children + side,
                    depth: p.depth + 1,
                    centroids: split.centroids[side],
                });
            }
            self.nodes[p.node].first = children as u32;
            self.nodes[p.node].count = 0;
        }
        let mut wide = std::mem::take(&mut self.wide);
        wide.collapse(self);
        self.wide = wide;
    }

    /// Partitions `items[range]` at the cheapest binned SAH plane of the widest axis of `cb`,
    /// its centroids' box; both parts are non-empty. Items whose centroids coincide are split
    /// in half.
    fn split(&mut self, range: std::ops::Range<usize>, cb: Box3) -> Split {
        let items = &mut self.items[range.clone()];
        let extent = cb.max - cb.min;
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let scale = BINS as f32 / extent[axis];
        let mut counts = [0u32; BINS];
        let mut bounds = [Box3::EMPTY; BINS];
        let mut cbounds = [Box3::EMPTY; BINS];
        if extent[axis] > 0.0 && scale.is_finite() {
            for &i in items.iter() {
                let c = self.centroids[i as usize];
                let b = (((c[axis] - cb.min[axis]) * scale) as usize).min(BINS - 1);
                self.bins[i as usize] = b as u8;
                counts[b] += 1;
                bounds[b] = bounds[b].union(self.boxes[i as usize]);
                cbounds[b] = cbounds[b].grow(c);
            }
        }
        // Cost of a split after bin k: area(left)·n(left) + area(right)·n(right).
        let mut right_cost = [0f32; BINS];
        let (mut acc, mut n) = (Box3::EMPTY, 0u32);
        for k in (1..BINS).rev() {
            acc = acc.union(bounds[k]);
            n += counts[k];
            right_cost[k - 1] = acc.half_area() * n as f32;
        }
        let (mut acc, mut n) = (Box3::EMPTY, 0u32);
        let mut best = (f32::INFINITY, usize::MAX);
        for k in 0..BINS - 1 {
            acc = acc.union(bounds[k]);
            n += counts[k];
            let right = items.len() as u32 - n;
            if n == 0 || right == 0 {
                continue;
            }
            let cost = acc.half_area() * n as f32 + right_cost[k];
            if cost < best.0 {
                best = (cost, k);
            }
        }
        let (mut b, mut c) = ([Box3::EMPTY; 2], [Box3::EMPTY; 2]);
        let mid = if best.1 == usize::MAX {
            let mid = items.len() / 2;
            for (j, &i) in items.iter().enumerate() {
                let side = usize::from(j >= mid);
                b[side] = b[side].union(self.boxes[i as usize]);
                c[side] = c[side].grow(self.centroids[i as usize]);
            }
            mid
        } else {
            let mut left = 0;
            for j in 0..items.len() {
                if self.bins[items[j] as usize] as usize <= best.1 {
                    items.swap(left, j);
                    left += 1;
                }
            }
            for k in 0..BINS {
                let side = usize::from(k > best.1);
                b[side] = b[side].union(bounds[k]);
                c[side] = c[side].union(cbounds[k]);
            }
            left
        };
        Split {
            mid: range.start + mid,
            bounds: b,
            centroids: c,
        }
    }
}

/// The BVH as [`WideNodes::collapse`] reads it: a wide leaf is a leaf node, by its index.
impl BinaryBoxes for TopLevel {
    fn children(&self, n: u32) -> Option<[u32; 2]> {
        let node = &self.nodes[n as usize];
        (node.count == 0).then_some([node.first, node.first + 1])
    }

    fn bounds(&self, n: u32) -> Aabb {
        self.nodes[n as usize].bounds
    }

    fn leaf(&self, n: u32) -> u32 {
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::WideChild;
    use crate::scene::rng::Rng;
    use glam::Vec3;

    /// Every non-empty item in exactly one leaf, every box holding what is under it.
    fn check(t: &TopLevel, boxes: &[Aabb]) {
        let mut seen = vec![0; boxes.len()];
        let holds = |outer: &Aabb, inner: &Aabb| {
            inner.min.cmpge(outer.min).all() && inner.max.cmple(outer.max).all()
        };
        for n in &t.nodes {
            if n.count == 0 {
                for c in [n.first, n.first + 1] {
                    assert!(holds(&n.bounds, &t.nodes[c as usize].bounds));
                }
            } else {
                assert!(n.count as usize <= LEAF_SIZE || t.nodes.len() > 2 * MAX_DEPTH);
                for &i in &t.items[n.first as usize..(n.first + n.count) as usize] {
                    seen[i as usize] += 1;
                    assert!(holds(&n.bounds, &boxes[i as usize]));
                }
            }
        }
        for (i, b) in boxes.iter().enumerate() {
            assert_eq!(seen[i], usize::from(!b.is_empty()), "item {i}");
        }
        check_wide(t);
    }

    /// Every leaf node of the BVH a leaf of the wide nodes exactly once, under the box of its
    /// node, and every wide node reached once.
    fn check_wide(t: &TopLevel) {
        let wide = t.wide.nodes();
        if t.nodes.is_empty() {
            assert!(wide.is_empty());
            return;
        }
        let mut leaves = vec![0; t.nodes.len()];
        let mut reached = vec![0; wide.len()];
        let mut todo = vec![0usize];
        reached[0] = 1;
        while let Some(w) = todo.pop() {
            let node = &wide[w];
            for (k, &child) in node.children.iter().enumerate() {
                if child == WideChild::NONE {
                    continue;
                }
                let b = Aabb::new(
                    Vec3::new(node.planes[0][k], node.planes[1][k], node.planes[2][k]),
                    Vec3::new(node.planes[3][k], node.planes[4][k], node.planes[5][k]),
                );
                if child.is_node() {
                    reached[child.index() as usize] += 1;
                    todo.push(child.index() as usize);
                } else {
                    let n = &t.nodes[child.index() as usize];
                    assert!(n.count > 0, "wide leaf {} is an inner node", child.index());
                    assert_eq!(b, n.bounds);
                    leaves[child.index() as usize] += 1;
                }
            }
        }
        assert!(reached.iter().all(|&r| r == 1), "{reached:?}");
        for (i, n) in t.nodes.iter().enumerate() {
            assert_eq!(leaves[i], usize::from(n.count > 0), "node {i}");
        }
    }

    #[test]
    fn every_item_in_one_leaf_under_boxes_that_hold_it() {
        let mut rng = Rng::new(5);
        let mut t = TopLevel::default();
        for n in [0, 1, 2, 3, 17, 1000] {
            let boxes: Vec<Aabb> = (0..n)
                .map(|i| {
                    if i % 7 == 3 {
                        return Aabb::EMPTY;
                    }
                    let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 100.0;
                    Aabb::new(c, c + Vec3::splat(rng.next_f32() * 5.0))
                })
                .collect();
            t.rebuild(&boxes);
            check(&t, &boxes);
        }
        // Coincident boxes: split in half, not forever.
        let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 100];
        t.rebuild(&same);
        check(&t, &same);
    }
}

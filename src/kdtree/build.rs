//! The SAH build in O(N log N) (Wald & Havran, "On building fast kd-trees for ray tracing, and
//! on doing that in O(N log N)", RT06).
//!
//! Every node owns one sorted event list per axis ([`events`]); the lists are sorted once, at
//! the root. At a node:
//! 1. one sweep per axis finds the cheapest plane ([`CostModel::best_split`]);
//! 2. one pass over the chosen axis's events classifies each triangle as below only, above
//!    only, or straddling (§4.3): an end event at or below the plane means below only, a start
//!    event at or above it above only, a planar event goes by its side of the plane (and, in
//!    the plane, to the side the sweep chose);
//! 3. straddling triangles are clipped to each child cell ([`clip`], "perfect splits"); their
//!    new events are sorted (there are O(√N) of them) and merged into the children's lists,
//!    while the events of one-sided triangles are copied in order: no list is ever re-sorted.
//!
//! Triangles are indexed locally in each node, so the classification and the index maps are
//! arrays of the node's size, reused from node to node. With the `parallel` feature, the two
//! children of a large node are built with `rayon::join` and their layouts stitched.

use std::time::Instant;

use kdbeam_kernels::{Aabb, KsTriangle, Triangle};

use super::clip::split_clipped_bounds;
use super::events::{
    kind, local, merge_into, pos_key, push_box_events, relocated, span, unkey, Event, END,
    MAX_LOCAL, PLANAR, START,
};
use super::layout::Layout;
use super::sah::{Bins, Candidates, CostModel, Split};
use super::{BuildParams, BuildStats, KdTree, LeafRecord, Node};
use crate::{Error, Mesh, Result};

/// Nodes with more triangles than this build their children in parallel.
#[cfg(feature = "parallel")]
const PARALLEL_MIN_TRIANGLES: usize = 4096;

/// Nodes with more triangles than this are split by binning, smaller ones by the exact sweep.
const EXACT_MAX: usize = 64;

/// A node waiting to be built, in the form its size calls for.
enum Pending {
    /// More than [`EXACT_MAX`] triangles.
    Binned(BoxNode),
    /// At most [`EXACT_MAX`] triangles.
    Exact(NodeInput),
}

/// A large node: its triangles (mesh ids) and their boxes clipped to its cell.
struct BoxNode {
    ids: Vec<u32>,
    boxes: Vec<Aabb>,
    cell: Aabb,
}

/// A small node: its triangles (mesh ids, in local index order), its sorted event lists and
/// its cell.
struct NodeInput {
    ids: Vec<u32>,
    events: [Vec<Event>; 3],
    cell: Aabb,
}

/// What stays the same for the whole build.
struct Context<'a> {
    /// The mesh's triangles, by id.
    triangles: &'a [Triangle],
    costs: CostModel,
    leaf_size: usize,
    depth_limit: u32,
    /// Whether to build children with `rayon::join` (not with a one-thread pool).
    #[cfg(feature = "parallel")]
    parallel: bool,
}

/// Where a triangle goes at a split, as bits so that classification can OR them in.
type Side = u8;
/// Straddles the plane: clipped into both children.
const BOTH: Side = 0;
/// Below (or in) the plane only.
const BELOW: Side = 1;
/// Above (or in) the plane only.
const ABOVE: Side = 2;

/// Per-thread buffers, reused by every node the thread splits.
#[derive(Default)]
struct Scratch {
    free_events: Vec<Vec<Event>>,
    free_ids: Vec<Vec<u32>>,
    sides: Vec<Side>,
    below_index: Vec<u32>,
    above_index: Vec<u32>,
    new_below: [Vec<Event>; 3],
    new_above: [Vec<Event>; 3],
    candidates: Candidates,
}

impl Scratch {
    fn take_events(&mut self) -> Vec<Event> {
        self.free_events.pop().unwrap_or_default()
    }

    fn take_ids(&mut self) -> Vec<u32> {
        self.free_ids.pop().unwrap_or_default()
    }

    /// Returns a node's buffers for reuse.
    fn recycle(&mut self, node: NodeInput) {
        let NodeInput {
            mut ids,
            events,
            cell: _,
        } = node;
        ids.clear();
        self.free_ids.push(ids);
        for mut list in events {
            list.clear();
            self.free_events.push(list);
        }
    }
}

impl KdTree {
    /// Builds an SAH kd-tree over `mesh`.
    ///
    /// The root cell is the mesh's bounding box. Splits minimise the SAH cost
    /// `1 + ci_over_ct · (P_below · N_below + P_above · N_above) · λ` over every event plane
    /// strictly inside the cell (λ = `1 − empty_bonus` when a side is empty), with triangles
    /// clipped to the cells ("perfect splits"); a node becomes a leaf when it holds at most
    /// `leaf_size` triangles, reaches [`BuildParams::depth_limit`], or no plane costs less than
    /// `ci_over_ct · N`. Degenerate triangles are kept (and referenced where they lie).
    ///
    /// The output is deterministic: the same with any number of threads.
    ///
    /// Edge cases: an empty mesh gives a single empty leaf and an empty root box; a mesh flat on
    /// some axis is split on the other axes only; a mesh whose extent overflows f32 is one leaf.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if `params` fails [`BuildParams::validate`] or the tree would
    /// outgrow its 30-bit node indices; [`Error::MalformedMesh`] for more than 2³⁰ triangles.
    ///
    /// ```
    /// let mesh = kdbeam::Mesh::from_soup(&[
    ///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
    ///     [5.0, 0.0, 0.0], [6.0, 0.0, 0.0], [5.0, 1.0, 0.0],
    /// ])?;
    /// let tree = kdbeam::KdTree::build(&mesh, &kdbeam::BuildParams::default())?;
    /// assert_eq!(tree.stats().nonempty_leaves, 2);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    pub fn build(mesh: &Mesh, params: &BuildParams) -> Result<KdTree> {
        params.validate()?;
        let started = Instant::now();
        let n = mesh.triangle_count();
        if n > MAX_LOCAL as usize + 1 {
            return Err(Error::MalformedMesh(format!(
                "{n} triangles exceed the kd-tree's limit of 2^30"
            )));
        }
        let mesh_triangles: Vec<Triangle> = mesh.triangles().collect();
        let bounds = mesh.bounds();
        let context = Context {
            triangles: &mesh_triangles,
            costs: CostModel::new(params),
            leaf_size: params.leaf_size as usize,
            depth_limit: params.depth_limit(n),
            #[cfg(feature = "parallel")]
            parallel: rayon::current_num_threads() > 1,
        };
        let mut layout = Layout::default();
        let mut scratch = Scratch::default();
        let root = root_node(&context, bounds, &mut scratch);
        build_subtree(&context, root, 0, &mut scratch, &mut layout)?;
        let out = layout.finish();

        let triangles: Vec<Triangle> = out
            .ids
            .iter()
            .map(|&id| mesh_triangles[id as usize])
            .collect();
        let ks_triangles: Vec<KsTriangle> = triangles.iter().map(KsTriangle::from).collect();
        let leaves = out.nodes.iter().filter(|n| n.is_leaf()).count();
        let stats = BuildStats {
            triangles: n,
            nodes: out.nodes.len(),
            leaves,
            nonempty_leaves: out.leaves.len() - 1,
            triangle_refs: out.ids.len(),
            max_depth: out.max_depth,
            bytes: out.nodes.len() * size_of::<Node>()
                + out.leaves.len() * size_of::<LeafRecord>()
                + out.ids.len()
                    * (size_of::<Triangle>() + size_of::<KsTriangle>() + size_of::<u32>()),
            build_time: started.elapsed(),
        };
        Ok(KdTree {
            nodes: out.nodes,
            leaves: out.leaves,
            triangles,
            ks_triangles,
            ids: out.ids,
            bounds,
            mesh_triangles: n,
            stats,
        })
    }
}

/// The root: every triangle with its vertex box.
fn root_node(context: &Context<'_>, cell: Aabb, scratch: &mut Scratch) -> Pending {
    let boxes = context
        .triangles
        .iter()
        .map(|t| Aabb::from_points([t.v0, t.v1, t.v2]))
        .collect();
    let ids = (0..context.triangles.len() as u32).collect();
    pending(BoxNode { ids, boxes, cell }, scratch)
}

/// `node` in the form its size calls for: as it is if large, else with its boxes' events,
/// sorted (there are at most 6·[`EXACT_MAX`] per axis).
fn pending(node: BoxNode, scratch: &mut Scratch) -> Pending {
    if node.ids.len() > EXACT_MAX {
        return Pending::Binned(node);
    }
    let mut events: [Vec<Event>; 3] = [
        scratch.take_events(),
        scratch.take_events(),
        scratch.take_events(),
    ];
    for (local, b) in node.boxes.iter().enumerate() {
        push_box_events(&mut events, b, local as u32);
    }
    for list in &mut events {
        list.sort_unstable();
    }
    Pending::Exact(NodeInput {
        ids: node.ids,
        events,
        cell: node.cell,
    })
}

/// Builds `node` at `depth` and everything below it into `out`, depth first.
fn build_subtree(
    context: &Context<'_>,
    node: Pending,
    depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    match node {
        Pending::Binned(node) => build_binned(context, node, depth, scratch, out),
        Pending::Exact(node) => build_exact(context, node, depth, scratch, out),
    }
}

/// Whether a node of `n` triangles at `depth` may be split at all.
fn may_split(context: &Context<'_>, n: usize, depth: u32) -> bool {
    n > context.leaf_size && depth < context.depth_limit
}

/// Builds large `node` with the binned search.
fn build_binned(
    context: &Context<'_>,
    mut node: BoxNode,
    mut depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    let n = node.ids.len();
    let bins = Bins::new(&node.boxes);
    let mut open = Vec::new();
    let split = cut_off_empty_space(context, n, &mut node.cell, &mut depth, out, &mut open, |cell| {
        context.costs.best_binned_split(&bins, cell)
    })?;
    match split {
        None => {
            node.ids.sort_unstable();
            out.push_leaf(depth, &node.ids, bins.union())?;
        }
        Some(split) => {
            let (below, above) = split_boxes(context, node, &split, scratch);
            build_children(context, below, above, &split, n, depth, scratch, out)?;
        }
    }
    close_cuts(out, open)
}

/// Builds small `node` with the exact sweep.
fn build_exact(
    context: &Context<'_>,
    mut node: NodeInput,
    mut depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    let n = node.ids.len();
    let mut candidates = std::mem::take(&mut scratch.candidates);
    if may_split(context, n, depth) {
        candidates.gather(&node.events, n, &node.cell);
    }
    let mut open = Vec::new();
    let split = cut_off_empty_space(context, n, &mut node.cell, &mut depth, out, &mut open, |cell| {
        context.costs.best_split(&candidates, cell)
    });
    scratch.candidates = candidates;
    match split? {
        None => make_leaf(node, depth, scratch, out)?,
        Some(split) => {
            let (below, above) = split_node(context, node, &split, scratch);
            build_children(
                context,
                Pending::Exact(below),
                Pending::Exact(above),
                &split,
                n,
                depth,
                scratch,
                out,
            )?;
        }
    }
    close_cuts(out, open)
}

/// An inner node cutting off empty space above: its below child, the rest of the node, is
/// being built; its above child will be an empty leaf.
struct OpenCut {
    at: usize,
    axis: usize,
    position: f32,
    /// The empty leaf's depth.
    depth: u32,
}

/// Takes the node of `n` triangles at `depth` in `cell` down the chain of splits with an
/// empty side that `best` (its cheapest plane in a cell) chooses, and returns the split that
/// follows, if any beats a leaf. `cell` and `depth` end as those of the rest of the node.
///
/// A split with an empty side is emitted at once: an empty leaf, and on the other side the
/// node itself in the smaller cell. No classification is needed: with one side empty every
/// triangle lies on the other side (the counts are exact for such planes), so none is clipped
/// and the node's triangles, boxes or event lists, and its plane counts, carry over unchanged;
/// only the costs change with the cell. Cuts whose empty leaf comes after the rest of the node
/// are left in `open` for [`close_cuts`].
fn cut_off_empty_space(
    context: &Context<'_>,
    n: usize,
    cell: &mut Aabb,
    depth: &mut u32,
    out: &mut Layout,
    open: &mut Vec<OpenCut>,
    best: impl Fn(&Aabb) -> Option<Split>,
) -> Result<Option<Split>> {
    loop {
        if !may_split(context, n, *depth) {
            return Ok(None);
        }
        let Some(split) = best(cell).filter(|s| s.cost < context.costs.leaf_cost(n)) else {
            return Ok(None);
        };
        if split.below_count != 0 && split.above_count != 0 {
            return Ok(Some(split));
        }
        let position = unkey(split.pos_key);
        let at = out.open_inner();
        if split.below_count == 0 {
            out.push_empty_leaf(*depth + 1);
            out.close_inner(at, split.axis, position)?;
            cell.min[split.axis] = position;
        } else {
            open.push(OpenCut {
                at,
                axis: split.axis,
                position,
                depth: *depth + 1,
            });
            cell.max[split.axis] = position;
        }
        *depth += 1;
    }
}

/// Closes the cuts [`cut_off_empty_space`] left open, innermost first, once the rest of the
/// node has been built: each gets its empty above leaf.
fn close_cuts(out: &mut Layout, open: Vec<OpenCut>) -> Result<()> {
    for cut in open.into_iter().rev() {
        out.close_inner(cut.at, cut.axis, cut.position)?;
        out.push_empty_leaf(cut.depth);
    }
    Ok(())
}

/// Builds the children of a node of `n` triangles at `depth` split at `split`, and the inner
/// node itself (in parallel for large nodes when allowed).
#[allow(clippy::too_many_arguments)]
fn build_children(
    context: &Context<'_>,
    below: Pending,
    above: Pending,
    split: &Split,
    n: usize,
    depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    let position = unkey(split.pos_key);
    #[cfg(feature = "parallel")]
    if context.parallel && n > PARALLEL_MIN_TRIANGLES {
        let (mut below_out, mut above_out) = (Layout::default(), Layout::default());
        let (built_below, built_above) = rayon::join(
            || build_subtree(context, below, depth + 1, scratch, &mut below_out),
            || {
                let mut scratch = Scratch::default();
                build_subtree(context, above, depth + 1, &mut scratch, &mut above_out)
            },
        );
        built_below?;
        built_above?;
        let at = out.open_inner();
        out.append(below_out)?;
        out.close_inner(at, split.axis, position)?;
        return out.append(above_out);
    }
    #[cfg(not(feature = "parallel"))]
    let _ = n;

    let at = out.open_inner();
    build_subtree(context, below, depth + 1, scratch, out)?;
    out.close_inner(at, split.axis, position)?;
    build_subtree(context, above, depth + 1, scratch, out)
}

/// Emits `node` as a leaf: its ids sorted ascending, its box the span of its events (the
/// union of its triangles' clipped boxes, which lie inside the cell).
fn make_leaf(node: NodeInput, depth: u32, scratch: &mut Scratch, out: &mut Layout) -> Result<()> {
    let mut node = node;
    if node.ids.is_empty() {
        out.push_empty_leaf(depth);
    } else {
        node.ids.sort_unstable();
        out.push_leaf(depth, &node.ids, span(&node.events))?;
    }
    scratch.recycle(node);
    Ok(())
}

/// Which side of the plane at `p` on a split's axis a box spanning `[lo, hi]` there lies on:
/// the classification of the events (Wald & Havran §4.3), on the box itself.
#[inline(always)]
fn side_of(lo: f32, hi: f32, p: f32, planar_below: bool) -> Side {
    if lo == hi {
        if lo < p || (lo == p && planar_below) {
            BELOW
        } else {
            ABOVE
        }
    } else if hi <= p {
        BELOW
    } else if lo >= p {
        ABOVE
    } else {
        BOTH
    }
}

/// Splits large `node` at `split` (which has triangles on both sides): one-sided triangles go
/// to their side with their boxes, straddling ones are clipped to each child cell.
fn split_boxes(
    context: &Context<'_>,
    node: BoxNode,
    split: &Split,
    scratch: &mut Scratch,
) -> (Pending, Pending) {
    let axis = split.axis;
    let p = unkey(split.pos_key);
    let (mut below_cell, mut above_cell) = (node.cell, node.cell);
    below_cell.max[axis] = p;
    above_cell.min[axis] = p;
    let capacity = |count: u32| count as usize + count as usize / 8;
    let mut below = BoxNode {
        ids: Vec::with_capacity(capacity(split.below_count)),
        boxes: Vec::with_capacity(capacity(split.below_count)),
        cell: below_cell,
    };
    let mut above = BoxNode {
        ids: Vec::with_capacity(capacity(split.above_count)),
        boxes: Vec::with_capacity(capacity(split.above_count)),
        cell: above_cell,
    };
    for (&id, b) in node.ids.iter().zip(&node.boxes) {
        match side_of(b.min[axis], b.max[axis], p, split.planar_below) {
            BELOW => {
                below.ids.push(id);
                below.boxes.push(*b);
            }
            ABOVE => {
                above.ids.push(id);
                above.boxes.push(*b);
            }
            _ => {
                let tri = &context.triangles[id as usize];
                let parts = split_clipped_bounds(tri, &node.cell, axis, p);
                for (child, part) in [&mut below, &mut above].into_iter().zip(parts) {
                    if let Some(clipped) = part {
                        child.ids.push(id);
                        child.boxes.push(clipped);
                    }
                }
            }
        }
    }
    (pending(below, scratch), pending(above, scratch))
}

/// Splits `node` at `split` into its below and above children (Wald & Havran §4.3).
fn split_node(
    context: &Context<'_>,
    node: NodeInput,
    split: &Split,
    scratch: &mut Scratch,
) -> (NodeInput, NodeInput) {
    let n = node.ids.len();
    let axis = split.axis;
    let plane = split.pos_key;

    // Classify: a triangle with no deciding event straddles the plane. Of a triangle's start
    // and end events at most one decides, so OR-ing the verdicts in needs no branch.
    scratch.sides.clear();
    scratch.sides.resize(n, BOTH);
    let planar_below = split.planar_below;
    for &e in &node.events[axis] {
        let (at, k) = (pos_key(e), kind(e));
        let planar = k == PLANAR;
        let below =
            (k == END && at <= plane) | (planar & ((at < plane) | (at == plane && planar_below)));
        let above = (k == START && at >= plane)
            | (planar & ((at > plane) | (at == plane && !planar_below)));
        scratch.sides[local(e) as usize] |= Side::from(below) | (Side::from(above) << 1);
    }

    let position = unkey(plane);
    let (mut below_cell, mut above_cell) = (node.cell, node.cell);
    below_cell.max[axis] = position;
    above_cell.min[axis] = position;

    // New local indices (in parent order), and the clipped events of straddling triangles.
    let mut below_ids = scratch.take_ids();
    let mut above_ids = scratch.take_ids();
    scratch.below_index.clear();
    scratch.below_index.resize(n, u32::MAX);
    scratch.above_index.clear();
    scratch.above_index.resize(n, u32::MAX);
    for (i, &id) in node.ids.iter().enumerate() {
        let side = scratch.sides[i];
        let [below_part, above_part] = if side == BOTH {
            let tri = &context.triangles[id as usize];
            split_clipped_bounds(tri, &node.cell, axis, position).map(Part::Clipped)
        } else {
            [BELOW, ABOVE].map(|only| if side == only { Part::Whole } else { Part::None })
        };
        scratch.below_index[i] = admit(below_part, id, &mut below_ids, &mut scratch.new_below);
        scratch.above_index[i] = admit(above_part, id, &mut above_ids, &mut scratch.new_above);
    }

    // Distribute the one-sided triangles' events in order, then merge in the clipped ones.
    let mut below_events: [Vec<Event>; 3] = Default::default();
    let mut above_events: [Vec<Event>; 3] = Default::default();
    for a in 0..3 {
        let (mut b_list, mut a_list) = (scratch.take_events(), scratch.take_events());
        b_list.reserve(2 * below_ids.len());
        a_list.reserve(2 * above_ids.len());
        for &e in &node.events[a] {
            let i = local(e) as usize;
            match scratch.sides[i] {
                BELOW => b_list.push(relocated(e, scratch.below_index[i])),
                ABOVE => a_list.push(relocated(e, scratch.above_index[i])),
                _ => {}
            }
        }
        merge_into(&mut b_list, &mut scratch.new_below[a]);
        merge_into(&mut a_list, &mut scratch.new_above[a]);
        below_events[a] = b_list;
        above_events[a] = a_list;
    }
    scratch.recycle(node);
    (
        NodeInput {
            ids: below_ids,
            events: below_events,
            cell: below_cell,
        },
        NodeInput {
            ids: above_ids,
            events: above_events,
            cell: above_cell,
        },
    )
}

/// What of a triangle a child gets.
enum Part {
    /// All of it: it lies on the child's side only.
    Whole,
    /// It straddles the plane; the box of its part in the child's cell, if any.
    Clipped(Option<Aabb>),
    /// Nothing: it lies on the other side only.
    None,
}

/// Admits triangle `id` to a child as `part` says: whole, or clipped if anything is left (its
/// new events go to `new_events`). Returns its index in the child, `u32::MAX` if left out.
fn admit(part: Part, id: u32, ids: &mut Vec<u32>, new_events: &mut [Vec<Event>; 3]) -> u32 {
    let clipped = match part {
        Part::Whole => None,
        Part::Clipped(Some(b)) => Some(b),
        Part::Clipped(None) | Part::None => return u32::MAX,
    };
    let index = ids.len() as u32;
    ids.push(id);
    if let Some(b) = clipped {
        push_box_events(new_events, &b, index);
    }
    index
}

#[cfg(all(test, feature = "parallel"))]
mod tests {
    use super::*;

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
            && a.ids == b.ids
            && a.triangles == b.triangles
            && a.ks_triangles == b.ks_triangles
    }

    #[test]
    fn one_thread_and_many_threads_build_the_same_tree() {
        // 20k triangles: several nodes above the parallel threshold.
        let mesh = soup(20_000, 7);
        for ci_over_ct in [0.1, 1.0, 10.0] {
            let params = BuildParams {
                ci_over_ct,
                ..BuildParams::default()
            };
            let one = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap()
                .install(|| KdTree::build(&mesh, &params).unwrap());
            let four = rayon::ThreadPoolBuilder::new()
                .num_threads(4)
                .build()
                .unwrap()
                .install(|| KdTree::build(&mesh, &params).unwrap());
            assert!(one.stats.nodes > 1000, "{}", one.stats);
            assert!(same_tree(&one, &four), "ci/ct {ci_over_ct}");
        }
    }
}

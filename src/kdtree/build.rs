//! The SAH build (Wald & Havran, "On building fast kd-trees for ray tracing, and on doing that
//! in O(N log N)", RT06), with binning on large nodes.
//!
//! A node is its triangles (mesh ids) with their boxes clipped to its cell. At a node:
//! 1. the cheapest plane is searched for: in a node of more than
//!    [`BuildParams::exact_search_max`] triangles (default 64) among binned planes ([`Bins`]:
//!    the 31 boundaries of 32 bins per axis across the boxes' union, and the union's faces;
//!    Hunt, Mark & Stoll 2006, Shevtsov et al. 2007), whose counts are
//!    estimates at the boundaries; in a smaller one among every event plane, with exact counts,
//!    as Wald & Havran do ([`ExactPlanes`]). Up to [`COUNTED_SEARCH_MAX`] triangles each plane
//!    is counted against each box in SIMD lanes, on the builder's ISA; above, the boxes' events
//!    are sorted per axis and swept once. Both give the same planes and counts, costed in lanes;
//! 2. while that plane has an empty side it is emitted at once with an empty leaf, and the
//!    search repeats in the smaller cell with the same counts ([`cut_off_empty_space`]);
//! 3. otherwise each triangle is classified by its box (§4.3): below only, above only, or
//!    straddling; straddling ones are clipped to each child cell ([`split_clipped_bounds`],
//!    "perfect splits"), the others keep their boxes.
//!
//! O(N log N): a binned node costs O(n); a small node O(n²) for n ≤ [`COUNTED_SEARCH_MAX`], or
//! O(n log `exact_search_max`), a constant per triangle either way; the depth limit keeps the
//! levels O(log N). Counting replaced the sort and sweep of nodes up to 64 triangles: 16% fewer
//! instructions in the dragon's build, and 8–11% less time on the dragon and the bunny (AVX2,
//! three A/B rounds). Three alternatives for the small nodes had measured more
//! instructions than the sort: keeping their event lists sorted through the splits, as Wald &
//! Havran do (12% more); counting each candidate's sides with 4-wide compares in the baseline
//! ISA, the costs left scalar, in nodes of at most 16 triangles (4%); and sweeping the sorted
//! events at each search of a node instead of storing its candidates once (5%). The default
//! threshold and the bin count were chosen by measured build time and SAH tree cost on the
//! shared scenes.
//!
//! A node's references ([`Ref`]: ids and clipped boxes) are a run of one per-thread stack:
//! a split writes its below child's over them and pushes its above child's, which are popped
//! once the subtree is built, so no node allocates.
//!
//! With the `parallel` feature, the two children of a large node are built with `rayon::join`
//! and their layouts stitched; the search and the classification do not depend on it, so the
//! tree is the same with any number of threads.

use std::ops::Range;
use std::time::Instant;

use bytemuck::Zeroable;
use kdbeam_kernels::lanes::prefetch;
use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::{Aabb, Isa, KsTriangle, Triangle};

use super::clip::split_clipped_bounds;
use super::events::{push_box_events, unkey, Event};
use super::layout::Layout;
use super::refs::{Bounds, Ref};
use super::sah::{Bins, CostModel, ExactPlanes, Split, COUNTED_SEARCH_MAX};
use super::{BuildParams, BuildStats, KdTree, LeafRecord, Node};
use crate::{Error, Mesh, Result};

/// Nodes with more triangles than this build their children in parallel.
#[cfg(feature = "parallel")]
const PARALLEL_MIN_TRIANGLES: usize = 4096;

/// The most triangles a mesh may have (counts are `u32`, and node indices 30 bits).
const MAX_TRIANGLES: usize = 1 << 30;

/// A node waiting to be built: its run of the thread's references ([`Scratch::refs`]), its
/// cell, and the union of its boxes (which lies inside the cell) when it may be binned: an
/// exact search does not need it, and a leaf takes it from its few boxes.
struct BoxNode {
    refs: Range<usize>,
    cell: Aabb,
    union: Option<Aabb>,
}

/// What stays the same for the whole build.
struct Context<'a> {
    /// The mesh's triangles, by id.
    triangles: &'a [Triangle],
    costs: CostModel,
    leaf_size: usize,
    depth_limit: u32,
    /// [`BuildParams::exact_search_max`].
    exact_max: usize,
    /// Exact searches of nodes of at most this many triangles count their planes in SIMD
    /// lanes; larger ones sort and sweep their events.
    count_max: usize,
    /// The ISA of the plane counting and costing.
    dispatch: Dispatch,
    /// Whether to build children with `rayon::join` (not with a one-thread pool).
    #[cfg(feature = "parallel")]
    parallel: bool,
}

/// Per-thread buffers, reused by every node the thread builds.
///
/// `refs[..top]` is a stack: a node's references are a run of it; when it is split, its below
/// child's take their place and its above child's are pushed, and a subtree's are popped when
/// it has been built. No allocation per node, and each node's references lie together in
/// memory.
#[derive(Default)]
struct Scratch {
    /// The stack, and stale references above `top`: it only grows, so that a split writes its
    /// children's references by index, with its cursors in registers.
    refs: Vec<Ref>,
    top: usize,
    /// The ids of a split's straddling triangles, to be clipped; only grows, so that the
    /// classification writes them by index.
    straddling: Vec<u32>,
    events: [Vec<Event>; 3],
    planes: ExactPlanes,
    /// A stack of the cuts of empty space still open ([`cut_off_empty_space`]): a node's are
    /// on top while its subtree is built (a `Vec` per node would cost an allocation for each
    /// node that has one).
    open_cuts: Vec<OpenCut>,
}

/// Three references fill the bytes of two Kensler–Shirley triangles (96), with the same
/// alignment (16).
const REFS_PER_KS_PAIR: usize = 3;
const _: () = assert!(
    REFS_PER_KS_PAIR * size_of::<Ref>() == 2 * size_of::<KsTriangle>()
        && align_of::<Ref>() == align_of::<KsTriangle>()
);

/// The stack's first reservation, in references per triangle (address space: its pages are
/// touched only as the stack reaches them). The scenes of the benches reach 2.0–3.1 at the
/// deepest (terrain, bunny, dragon, sponza, killeroo), so the stack seldom grows, which would
/// copy it into new pages; and [`Scratch::hand_over_stack`] can lend it to trees of up to 2⅔
/// references per triangle (the dragon's has 2.56).
const STACK_PER_TRIANGLE: usize = 4;

/// Makes room for `len` references in the stack `refs`, growing it geometrically, to a capacity
/// that is a multiple of [`REFS_PER_KS_PAIR`]: a whole number of Kensler–Shirley triangles, so
/// that [`Scratch::hand_over_stack`] can recycle it.
fn reserve_stack(refs: &mut Vec<Ref>, len: usize) {
    if refs.capacity() < len {
        let capacity = len
            .max(2 * refs.capacity())
            .next_multiple_of(REFS_PER_KS_PAIR);
        refs.reserve_exact(capacity - refs.len());
    }
}

impl Scratch {
    /// Hands the reference stack, which the build of the nodes no longer needs, to a tree as
    /// the memory of its `needed` Kensler–Shirley triangles `ks`, and takes theirs in exchange.
    ///
    /// For a builder about to be dropped ([`KdTree::build`]): a process's first build otherwise
    /// writes its 48 bytes per triangle reference on fresh pages from the system, each costing
    /// a page fault, while the stack's pages (32 bytes per reference at its deepest) have been
    /// written already. On the dragon that saves 1,704 of 8,832 page faults. Nothing happens
    /// when the stack cannot hold `needed` triangles (growing it would copy its stale bytes
    /// to a new allocation) or its capacity is not a whole number of triangles.
    fn hand_over_stack(&mut self, ks: &mut Vec<KsTriangle>, needed: usize) {
        if self.refs.capacity() / REFS_PER_KS_PAIR * 2 < needed {
            return;
        }
        let mut stack = std::mem::take(&mut self.refs);
        stack.clear();
        match bytemuck::allocation::try_cast_vec::<Ref, KsTriangle>(stack) {
            Ok(stack) => {
                let mut theirs = std::mem::replace(ks, stack);
                theirs.clear();
                self.refs = bytemuck::allocation::try_cast_vec(theirs).unwrap_or_default();
            }
            Err((_, stack)) => self.refs = stack,
        }
    }
}

/// Fills `planes` with those of a small node with references `refs` in `cell` by Wald &
/// Havran's sweep: the boxes' events, sorted per axis in `events`, swept.
fn sweep_planes(events: &mut [Vec<Event>; 3], planes: &mut ExactPlanes, refs: &[Ref], cell: &Aabb) {
    for list in events.iter_mut() {
        list.clear();
    }
    for r in refs {
        push_box_events(events, &r.aabb());
    }
    for list in events.iter_mut() {
        list.sort_unstable();
    }
    planes.sweep(events, refs.len(), cell);
}

impl KdTree {
    /// Builds an SAH kd-tree over `mesh`.
    ///
    /// The root cell is the mesh's bounding box. Splits minimise the SAH cost
    /// `1 + ci_over_ct · (P_below · N_below + P_above · N_above) · λ` (λ = `1 − empty_bonus`
    /// when a side is empty) over every event plane strictly inside the cell in nodes of at
    /// most [`BuildParams::exact_search_max`] triangles, over binned planes in larger ones
    /// (module docs), with triangles clipped to the cells ("perfect splits"); a node becomes a
    /// leaf when it holds at most `leaf_size` triangles, reaches [`BuildParams::depth_limit`],
    /// or no plane costs less than `ci_over_ct · N`. Degenerate triangles are kept (and
    /// referenced where they lie).
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
        let mut tree = KdTree::empty();
        KdTreeBuilder::new().build_into(&mut tree, mesh, params, true)?;
        Ok(tree)
    }

    /// A tree of no nodes and no memory, to be built into.
    fn empty() -> KdTree {
        KdTree {
            nodes: Vec::new(),
            leaves: Vec::new(),
            triangles: Vec::new(),
            ks_triangles: Vec::new(),
            ids: Vec::new(),
            bounds: Aabb::EMPTY,
            mesh_triangles: 0,
            stats: BuildStats::default(),
        }
    }
}

/// Buffers for building kd-trees, kept from one build to the next.
///
/// A renderer of moving geometry rebuilds its tree every frame. Building through one
/// `KdTreeBuilder`, into the previous frame's tree ([`KdTreeBuilder::rebuild`]), reuses the
/// memory of both instead of asking the system for fresh pages: the trees are the same as
/// [`KdTree::build`]'s, bit for bit. The builder holds its buffers (about 80 bytes per
/// triangle reference of the largest tree it built: 20 MB for the 100k-triangle dragon, whose
/// tree has 256k references) until it is dropped.
///
/// ```
/// use kdbeam::{BuildParams, KdTree, KdTreeBuilder, Mesh};
/// let frame = |x: f32| Mesh::from_soup(&[[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 1.0, 0.0]]);
/// let mut builder = KdTreeBuilder::new();
/// let mut tree = builder.build(&frame(0.0)?, &BuildParams::default())?;
/// builder.rebuild(&mut tree, &frame(2.0)?, &BuildParams::default())?;
/// assert_eq!(tree.bounds().min.x, 2.0);
/// # Ok::<(), kdbeam::Error>(())
/// ```
pub struct KdTreeBuilder {
    /// The mesh's triangles, by id.
    triangles: Vec<Triangle>,
    scratch: Scratch,
    layout: Layout,
    /// The ISA of the split search's SIMD lanes, resolved once, when the builder is made.
    dispatch: Dispatch,
    /// [`Context::count_max`].
    count_max: usize,
}

impl Default for KdTreeBuilder {
    fn default() -> Self {
        Self::new()
    }
}

impl KdTreeBuilder {
    /// A builder with no buffers yet, whose split search runs on the widest ISA of this CPU
    /// (or the one `KDBEAM_ISA` names, as for [`crate::Tracer`]).
    pub fn new() -> Self {
        KdTreeBuilder {
            triangles: Vec::new(),
            scratch: Scratch::default(),
            layout: Layout::default(),
            dispatch: Dispatch::preferred(),
            count_max: COUNTED_SEARCH_MAX,
        }
    }

    /// The same builder with its split search on `isa`. The trees are the same on every ISA,
    /// bit for bit; only the build time differs.
    ///
    /// # Errors
    /// [`Error::IsaUnavailable`] if this CPU does not run `isa`.
    pub fn with_isa(self, isa: Isa) -> Result<Self> {
        Ok(self.with_dispatch(Dispatch::new(isa)?))
    }

    /// The same builder with its split search on an ISA already checked.
    pub fn with_dispatch(self, dispatch: Dispatch) -> Self {
        KdTreeBuilder { dispatch, ..self }
    }

    /// The ISA of the split search.
    pub fn isa(&self) -> Isa {
        self.dispatch.isa()
    }

    /// The same builder with the exact searches of nodes above `count_max` triangles swept.
    #[cfg(test)]
    fn with_count_max(self, count_max: usize) -> Self {
        KdTreeBuilder { count_max, ..self }
    }

    /// Builds an SAH kd-tree over `mesh`: [`KdTree::build`], with this builder's buffers.
    ///
    /// # Errors
    /// As [`KdTree::build`].
    pub fn build(&mut self, mesh: &Mesh, params: &BuildParams) -> Result<KdTree> {
        let mut tree = KdTree::empty();
        self.rebuild(&mut tree, mesh, params)?;
        Ok(tree)
    }

    /// Replaces `tree` with an SAH kd-tree over `mesh`, reusing its memory and this builder's:
    /// afterwards `tree` is what [`KdTree::build`] returns for `mesh` and `params` (its
    /// [`BuildStats::build_time`] aside).
    ///
    /// # Errors
    /// As [`KdTree::build`]; `tree` is then left as it was.
    pub fn rebuild(&mut self, tree: &mut KdTree, mesh: &Mesh, params: &BuildParams) -> Result<()> {
        self.build_into(tree, mesh, params, false)
    }

    /// [`KdTreeBuilder::rebuild`]; when `hand_over_stack` (the builder is dropped next), the
    /// tree's Kensler–Shirley triangles may take the builder's reference stack as their memory
    /// ([`Scratch::hand_over_stack`]) if theirs is too small.
    fn build_into(
        &mut self,
        tree: &mut KdTree,
        mesh: &Mesh,
        params: &BuildParams,
        hand_over_stack: bool,
    ) -> Result<()> {
        params.validate()?;
        let started = Instant::now();
        let n = mesh.triangle_count();
        if n > MAX_TRIANGLES {
            return Err(Error::MalformedMesh(format!(
                "{n} triangles exceed the kd-tree's limit of 2^30"
            )));
        }
        let Self {
            triangles: mesh_triangles,
            scratch,
            layout,
            dispatch,
            count_max,
        } = self;
        mesh_triangles.clear();
        mesh_triangles.extend(mesh.triangles());
        let context = Context {
            triangles: mesh_triangles,
            costs: CostModel::new(params),
            leaf_size: params.leaf_size as usize,
            depth_limit: params.depth_limit(n),
            exact_max: params.exact_search_max as usize,
            count_max: *count_max,
            dispatch: *dispatch,
            #[cfg(feature = "parallel")]
            parallel: rayon::current_num_threads() > 1,
        };
        layout.clear();
        layout.reserve_for(n);
        let root = root_node(&context, scratch);
        let bounds = root.cell;
        build_subtree(&context, root, 0, scratch, layout)?;

        let max_depth = layout.finish_into(&mut tree.nodes, &mut tree.leaves, &mut tree.ids);
        tree.triangles.clear();
        tree.triangles
            .extend(tree.ids.iter().map(|&id| mesh_triangles[id as usize]));
        if hand_over_stack && tree.ks_triangles.capacity() < tree.ids.len() {
            scratch.hand_over_stack(&mut tree.ks_triangles, tree.ids.len());
        }
        tree.ks_triangles.clear();
        tree.ks_triangles
            .extend(tree.triangles.iter().map(KsTriangle::from));
        tree.bounds = bounds;
        tree.mesh_triangles = n;
        let build_time = started.elapsed();
        let (nodes, leaves, ids) = (&tree.nodes, &tree.leaves, &tree.ids);
        tree.stats = BuildStats {
            triangles: n,
            nodes: nodes.len(),
            leaves: nodes.iter().filter(|n| n.is_leaf()).count(),
            nonempty_leaves: leaves.len() - 1,
            triangle_refs: ids.len(),
            max_depth,
            bytes: nodes.len() * size_of::<Node>()
                + leaves.len() * size_of::<LeafRecord>()
                + ids.len() * (size_of::<Triangle>() + size_of::<KsTriangle>() + size_of::<u32>()),
            build_time,
        };
        Ok(())
    }
}

/// The root: every triangle with its vertex box, the only references on `scratch`'s stack; its
/// cell is the boxes' union, the mesh's bounds (those of the vertices its triangles use).
fn root_node(context: &Context<'_>, scratch: &mut Scratch) -> BoxNode {
    let mut union = Bounds::EMPTY;
    // A build that failed may have left cuts open.
    scratch.open_cuts.clear();
    let refs = &mut scratch.refs;
    refs.clear();
    reserve_stack(refs, STACK_PER_TRIANGLE * context.triangles.len());
    refs.extend(context.triangles.iter().zip(0..).map(|(t, id)| {
        let r = Ref::new(id, &Aabb::from_points([t.v0, t.v1, t.v2]));
        union.add(&r);
        r
    }));
    scratch.top = refs.len();
    BoxNode {
        refs: 0..scratch.top,
        cell: union.aabb(),
        union: Some(union.aabb()),
    }
}

/// Builds `node` at `depth` and everything below it into `out`, depth first; pops the
/// references its children pushed.
fn build_subtree(
    context: &Context<'_>,
    mut node: BoxNode,
    mut depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    let n = node.refs.len();
    let open_mark = scratch.open_cuts.len();
    // Large nodes are searched by binning, small ones exactly; the search runs only while the
    // node may be split, so neither is prepared otherwise.
    let searched = may_split(context, n, depth);
    let refs = &scratch.refs[node.refs.clone()];
    let bins = (searched && n > context.exact_max)
        .then(|| Bins::new(refs, node.union.unwrap_or_else(|| union_of(refs))));
    if searched && n <= context.exact_max {
        let Scratch { events, planes, .. } = scratch;
        if n <= context.count_max {
            planes.count(context.dispatch, refs, &node.cell);
        } else {
            sweep_planes(events, planes, refs, &node.cell);
        }
    }
    let planes = &scratch.planes;
    let split = cut_off_empty_space(
        context,
        n,
        &mut node.cell,
        &mut depth,
        out,
        &mut scratch.open_cuts,
        |cell| match &bins {
            Some(bins) => context
                .costs
                .best_binned_split(context.dispatch, bins, cell),
            None => context.costs.best_split(context.dispatch, planes, cell),
        },
    )?;
    match split {
        None => make_leaf(&node, scratch, depth, out)?,
        Some(split) => {
            let mark = scratch.top;
            let (below, above) = split_boxes(context, &node, &split, scratch);
            build_children(context, below, above, &split, n, depth, scratch, out)?;
            scratch.top = mark;
        }
    }
    close_cuts(out, &mut scratch.open_cuts, open_mark)
}

/// The union of the boxes of `refs`.
fn union_of(refs: &[Ref]) -> Aabb {
    let mut union = Bounds::EMPTY;
    for r in refs {
        union.add(r);
    }
    union.aabb()
}

/// Whether a node of `n` triangles at `depth` may be split at all.
fn may_split(context: &Context<'_>, n: usize, depth: u32) -> bool {
    n > context.leaf_size && depth < context.depth_limit
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
/// and the node's triangles and boxes, and its plane counts, carry over unchanged; only the
/// costs change with the cell. Cuts whose empty leaf comes after the rest of the node are
/// left in `open` for [`close_cuts`]. `best` is called only while the node may be split.
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

/// Closes the cuts [`cut_off_empty_space`] left open above `mark` (a node's), innermost first,
/// once the rest of the node has been built: each gets its empty above leaf.
fn close_cuts(out: &mut Layout, open: &mut Vec<OpenCut>, mark: usize) -> Result<()> {
    for cut in open.drain(mark..).rev() {
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
    below: BoxNode,
    above: BoxNode,
    split: &Split,
    n: usize,
    depth: u32,
    scratch: &mut Scratch,
    out: &mut Layout,
) -> Result<()> {
    let position = unkey(split.pos_key);
    #[cfg(feature = "parallel")]
    if context.parallel && n > PARALLEL_MIN_TRIANGLES {
        // The above child moves to a stack of its own, for the other thread.
        let mut above_scratch = Scratch::default();
        above_scratch
            .refs
            .extend_from_slice(&scratch.refs[above.refs.clone()]);
        above_scratch.top = above_scratch.refs.len();
        let above = BoxNode {
            refs: 0..above_scratch.top,
            ..above
        };
        let (mut below_out, mut above_out) = (Layout::default(), Layout::default());
        let (built_below, built_above) = rayon::join(
            || build_subtree(context, below, depth + 1, scratch, &mut below_out),
            || {
                build_subtree(
                    context,
                    above,
                    depth + 1,
                    &mut above_scratch,
                    &mut above_out,
                )
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

/// Emits `node` as a leaf: its ids in the order of its references, its box the union of its
/// triangles' clipped boxes (which lies inside the cell).
///
/// The ids are not sorted: the closest hit breaks ties in `t` by the smaller id wherever the
/// triangles lie ([`kdbeam_kernels::Hit::is_beaten_by`]), so the order changes no result, and
/// sorting the small leaves took 3% of the dragon's build.
fn make_leaf(node: &BoxNode, scratch: &Scratch, depth: u32, out: &mut Layout) -> Result<()> {
    if node.refs.is_empty() {
        out.push_empty_leaf(depth);
        return Ok(());
    }
    let refs = &scratch.refs[node.refs.clone()];
    let union = node.union.unwrap_or_else(|| union_of(refs));
    out.push_leaf(depth, refs.iter().map(Ref::id), union)
}

/// Which sides of the plane at `p` on a split's axis a box spanning `[lo, hi]` there goes to,
/// as `(below, above)` (Wald & Havran §4.3): a flat box to its side of the plane, and in the
/// plane to the split's choice; any other box below if it ends at or before `p`, above if it
/// starts at or after it, else to neither: it straddles the plane and is clipped into both.
/// Without branches, as the sides come as good as at random: a box both ending by `p` and
/// starting from it lies in the plane (`lo ≤ hi`).
#[inline(always)]
fn sides_of(lo: f32, hi: f32, p: f32, planar_below: bool) -> (bool, bool) {
    let (ends_by, starts_from) = (hi <= p, lo >= p);
    let below = ends_by & (!starts_from | planar_below);
    let above = starts_from & (!ends_by | !planar_below);
    (below, above)
}

/// Splits `node` at `split` (which has triangles on both sides): one-sided triangles go to
/// their side with their boxes, straddling ones are clipped to each child cell (and left out
/// of a child they do not meet). The below child's references replace the node's on
/// `scratch.refs`, and the above child's are pushed on top, so that the stack grows by the
/// above children alone on the way down; within each, the one-sided triangles come first, in
/// the node's order, then the clipped ones.
fn split_boxes(
    context: &Context<'_>,
    node: &BoxNode,
    split: &Split,
    scratch: &mut Scratch,
) -> (BoxNode, BoxNode) {
    // The axis as a constant, so that coordinates along it are picked without a branch.
    match split.axis {
        0 => split_boxes_on::<0>(context, node, split, scratch),
        1 => split_boxes_on::<1>(context, node, split, scratch),
        _ => split_boxes_on::<2>(context, node, split, scratch),
    }
}

/// [`split_boxes`] on axis `AXIS` (`split.axis`).
fn split_boxes_on<const AXIS: usize>(
    context: &Context<'_>,
    node: &BoxNode,
    split: &Split,
    scratch: &mut Scratch,
) -> (BoxNode, BoxNode) {
    let axis = AXIS;
    let p = unkey(split.pos_key);
    let (mut below_cell, mut above_cell) = (node.cell, node.cell);
    below_cell.max[axis] = p;
    above_cell.min[axis] = p;
    let Scratch {
        refs,
        top,
        straddling,
        ..
    } = scratch;
    // Each reference has at most one part on either side, and its below part is written
    // after it has been read: the below child's references take the node's place, and the
    // above child's at most `n` slots at the stack's top.
    let (first, n, above_first) = (node.refs.start, node.refs.len(), *top);
    if refs.len() < above_first + n {
        reserve_stack(refs, above_first + n);
        refs.resize(above_first + n, Ref::zeroed());
    }
    if straddling.len() < n {
        straddling.resize(n, 0);
    }
    let (refs, straddling) = (&mut refs[..], &mut straddling[..n]);
    let (mut below_end, mut above_end, mut straddlers) = (first, above_first, 0);
    // Without a branch on the sides, which come as good as at random: a reference is written
    // to the end of the child it goes to (to the below child's, unkept, when it straddles; that
    // slot's reference has been read), and its id to the straddlers' end (kept when it does).
    for i in node.refs.clone() {
        let r = refs[i];
        // From the vectors' lanes, so that the reference stays in two vector registers.
        let (lo, hi) = (r.lo()[AXIS], r.hi()[AXIS]);
        let (below, above) = sides_of(lo, hi, p, split.planar_below);
        refs[if above { above_end } else { below_end }] = r;
        below_end += usize::from(below);
        above_end += usize::from(above);
        straddling[straddlers] = r.id();
        // At most one side: a box both ending by `p` and starting from it lies in the plane.
        straddlers += 1 - usize::from(below) - usize::from(above);
    }
    let straddling = &straddling[..straddlers];
    // Triangles are random in the mesh: each is prefetched a few clips ahead.
    const AHEAD: usize = 4;
    for &id in straddling.iter().take(AHEAD) {
        prefetch(&context.triangles[id as usize]);
    }
    for (k, &id) in straddling.iter().enumerate() {
        if let Some(&next) = straddling.get(k + AHEAD) {
            prefetch(&context.triangles[next as usize]);
        }
        let tri = &context.triangles[id as usize];
        let [below_part, above_part] = split_clipped_bounds::<AXIS>(tri, &node.cell, p);
        if let Some(part) = below_part {
            refs[below_end] = Ref::new(id, &part);
            below_end += 1;
        }
        if let Some(part) = above_part {
            refs[above_end] = Ref::new(id, &part);
            above_end += 1;
        }
    }
    *top = above_end;
    // The children's unions only where they may be binned: a node's children are no larger.
    let binned = n > context.exact_max;
    (
        BoxNode {
            refs: first..below_end,
            cell: below_cell,
            union: binned.then(|| union_of(&refs[first..below_end])),
        },
        BoxNode {
            refs: above_first..above_end,
            cell: above_cell,
            union: binned.then(|| union_of(&refs[above_first..above_end])),
        },
    )
}

#[cfg(test)]
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
            builder.rebuild(&mut tree, mesh, &params).unwrap();
            let fresh = KdTree::build(mesh, &params).unwrap();
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
    fn a_dropped_builders_stack_becomes_the_trees_triangles_memory() {
        let mut scratch = Scratch::default();
        reserve_stack(&mut scratch.refs, 1000);
        scratch.refs.resize(10, Ref::zeroed());
        let (stack, capacity) = (scratch.refs.as_ptr() as usize, scratch.refs.capacity());
        assert!(capacity >= 1000 && capacity.is_multiple_of(REFS_PER_KS_PAIR));
        let mut ks = vec![KsTriangle::zeroed(); 4];
        let theirs = ks.as_ptr() as usize;
        // More triangles than the stack holds: it is kept.
        scratch.hand_over_stack(&mut ks, capacity);
        assert_eq!((ks.as_ptr() as usize, ks.len()), (theirs, 4));
        assert_eq!(scratch.refs.as_ptr() as usize, stack);
        scratch.hand_over_stack(&mut ks, 600);
        assert_eq!((ks.as_ptr() as usize, ks.len()), (stack, 0));
        assert_eq!(ks.capacity(), capacity / REFS_PER_KS_PAIR * 2);
        assert_eq!(scratch.refs.as_ptr() as usize, theirs);
        assert_eq!((scratch.refs.len(), scratch.refs.capacity()), (0, 6));
        // A tree's odd capacity cannot hold whole references: the stack is then new.
        let mut ks = Vec::with_capacity(3);
        ks.push(KsTriangle::zeroed());
        scratch.hand_over_stack(&mut ks, 4);
        assert_eq!((ks.as_ptr() as usize, ks.len()), (theirs, 0));
        assert_eq!(scratch.refs.capacity(), 0);
        // A tree built by `KdTree::build` is the one a kept builder builds.
        let mesh = soup(2000, 5);
        let params = BuildParams::default();
        let kept = KdTreeBuilder::new().build(&mesh, &params).unwrap();
        assert!(same_tree(&KdTree::build(&mesh, &params).unwrap(), &kept));
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

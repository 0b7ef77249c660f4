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
//! levels O(log N). Small nodes are counted rather than sorted and swept: the counting is
//! branch-free and runs in SIMD lanes, where the sort's comparisons are mispredicted. The
//! default threshold and the bin count trade build time against SAH tree cost.
//!
//! A node's references ([`Ref`]: ids and clipped boxes) are a run of one per-thread stack:
//! a split writes its below child's over them and pushes its above child's, which are popped
//! once the subtree is built, so no node allocates.
//!
//! With the `parallel` feature, the two children of a large node are built with `rayon::join`
//! and their layouts stitched, and the largest nodes (the root first) bin and split their
//! references in parallel chunks (module `parallel`), which put their results where one thread
//! puts them: the search and the classification do not depend on the threads, so the tree is
//! the same with any number of threads.

mod builder;
mod classify;
mod empty_space;
#[cfg(feature = "parallel")]
mod parallel;
mod recurse;
mod stack;
#[cfg(test)]
mod tests;

use std::ops::Range;

use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::{Aabb, Triangle};

use super::events::Event;
use super::refs::Ref;
use super::sah::{CostModel, ExactPlanes};
pub use builder::KdTreeBuilder;
use empty_space::OpenCut;

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
    /// Nodes of at least this many references (and more than [`parallel::PARALLEL_NODE_MIN`])
    /// split in parallel chunks: those of more than twice a thread's share of the root, above
    /// which fewer subtrees than threads are being built. Below, each thread splits its own
    /// nodes in one pass, and a chunked split's extra passes would only cost.
    #[cfg(feature = "parallel")]
    chunked_min: usize,
    /// The buffers of subtrees built by other threads.
    #[cfg(feature = "parallel")]
    pool: &'a ScratchPool,
}

/// [`Scratch`]es of subtrees handed to other threads, returned when their subtree is built and
/// taken by the next one, in this build and the builder's next: a new buffer's pages are
/// faulted in at first touch, which costs as much as filling them.
///
/// Kept by size class (the bit length of the subtree's reference count), so that a subtree gets
/// a buffer grown by one of its size class: buffers handed out regardless of size would each
/// grow, build after build, to the largest subtree they ever served.
///
/// A one-off build ([`KdTree::build`](crate::KdTree::build)) keeps none: there the memory of a
/// finished subtree's buffer is better handed back to the allocator, which gives it to the next
/// subtree whatever its size, than held until the build ends.
#[cfg(feature = "parallel")]
#[derive(Default)]
struct ScratchPool {
    classes: std::sync::Mutex<Vec<Vec<Scratch>>>,
    keep: bool,
}

#[cfg(feature = "parallel")]
impl ScratchPool {
    /// A pool that keeps the scratches returned to it when `keep`, else drops them.
    fn new(keep: bool) -> Self {
        ScratchPool {
            keep,
            ..ScratchPool::default()
        }
    }

    /// The size class of a subtree of `n` references.
    fn class(n: usize) -> usize {
        (usize::BITS - n.leading_zeros()) as usize
    }

    /// A scratch of `n`'s size class from the pool, or a new one; its stack empty.
    fn take(&self, n: usize) -> Scratch {
        // Nothing panics while the lock is held; were it poisoned, its scratches are whole.
        let mut pool = (self.classes.lock()).unwrap_or_else(std::sync::PoisonError::into_inner);
        let mut scratch = pool
            .get_mut(Self::class(n))
            .and_then(Vec::pop)
            .unwrap_or_default();
        scratch.top = 0;
        scratch.open_cuts.clear();
        scratch
    }

    /// Returns `scratch`, taken for `n` references, to the pool.
    fn put(&self, scratch: Scratch, n: usize) {
        if !self.keep {
            return;
        }
        let mut pool = (self.classes.lock()).unwrap_or_else(std::sync::PoisonError::into_inner);
        let class = Self::class(n);
        if pool.len() <= class {
            pool.resize_with(class + 1, Vec::new);
        }
        pool[class].push(scratch);
    }
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

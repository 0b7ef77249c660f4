//! The entry points: [`KdTree::build`] and the reusable [`KdTreeBuilder`].

use std::sync::OnceLock;
use std::time::Instant;

use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::{Aabb, Isa, Triangle, TriangleBlock};
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::recurse::{build_subtree, root_node};
#[cfg(feature = "parallel")]
use super::ScratchPool;
use super::{Context, Scratch, MAX_TRIANGLES};
use crate::kdtree::layout::Layout;
use crate::kdtree::node::mark_empty_children;
use crate::kdtree::pages;
use crate::kdtree::sah::{CostModel, COUNTED_SEARCH_MAX};
use crate::kdtree::{BuildParams, BuildStats, KdTree, LeafRecord, Node};
use crate::{Error, Mesh, Result};

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
    /// outgrow its 28-bit node indices; [`Error::MalformedMesh`] for more than 2³⁰ triangles.
    ///
    /// ```
    /// let mesh = kdbeam::Mesh::from_soup(&[
    ///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
    ///     [5.0, 0.0, 0.0], [6.0, 0.0, 0.0], [5.0, 1.0, 0.0],
    /// ])?;
    /// // Splitting two triangles pays when a test costs more than a traversal step.
    /// let params = kdbeam::BuildParams::default().with_ci_over_ct(1.5);
    /// let tree = kdbeam::KdTree::build(&mesh, &params)?;
    /// assert_eq!(tree.stats().nonempty_leaves, 2);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    pub fn build(mesh: &Mesh, params: &BuildParams) -> Result<KdTree> {
        let mut tree = KdTree::empty();
        KdTreeBuilder::one_off().build_into(&mut tree, mesh, params)?;
        Ok(tree)
    }

    /// A tree of no nodes and no memory, to be built into.
    fn empty() -> KdTree {
        KdTree {
            nodes: Vec::new(),
            leaves: Vec::new(),
            blocks: Vec::new(),
            wide: Default::default(),
            bounds: Aabb::EMPTY,
            mesh_triangles: 0,
            stats: BuildStats::default(),
            triangle_boxes: OnceLock::new(),
            subspace: Default::default(),
        }
    }
}

/// Buffers for building kd-trees, kept from one build to the next.
///
/// A renderer of moving geometry rebuilds its tree every frame. Building through one
/// `KdTreeBuilder`, into the previous frame's tree ([`KdTreeBuilder::rebuild`]), reuses the
/// memory of both instead of asking the system for fresh pages: the trees are the same as
/// [`KdTree::build`]'s, bit for bit. The builder holds its buffers (about 80 bytes per
/// triangle reference of the largest tree it built, and, on several threads, the stacks of the
/// subtrees that other threads built, which [`KdTree::build`] frees as it goes) until it is
/// dropped.
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
    /// The scratches of subtrees built by other threads.
    #[cfg(feature = "parallel")]
    pool: ScratchPool,
    layout: Layout,
    /// The kd-tree's subtree boxes, from which its wide nodes are made.
    subtree_boxes: Vec<Aabb>,
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
    #[must_use]
    pub fn new() -> Self {
        KdTreeBuilder {
            #[cfg(feature = "parallel")]
            pool: ScratchPool::new(true),
            ..Self::one_off()
        }
    }

    /// A builder for one build: it keeps no buffer of a subtree built by another thread.
    fn one_off() -> Self {
        KdTreeBuilder {
            triangles: Vec::new(),
            scratch: Scratch::default(),
            #[cfg(feature = "parallel")]
            pool: ScratchPool::new(false),
            layout: Layout::default(),
            subtree_boxes: Vec::new(),
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
    #[must_use]
    pub fn with_dispatch(self, dispatch: Dispatch) -> Self {
        KdTreeBuilder { dispatch, ..self }
    }

    /// The ISA of the split search.
    #[must_use]
    pub fn isa(&self) -> Isa {
        self.dispatch.isa()
    }

    /// The same builder with the exact searches of nodes above `count_max` triangles swept.
    #[cfg(test)]
    pub(super) fn with_count_max(self, count_max: usize) -> Self {
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
        self.build_into(tree, mesh, params)
    }

    /// [`KdTreeBuilder::rebuild`].
    fn build_into(&mut self, tree: &mut KdTree, mesh: &Mesh, params: &BuildParams) -> Result<()> {
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
            #[cfg(feature = "parallel")]
            pool,
            layout,
            subtree_boxes,
            dispatch,
            count_max,
        } = self;
        // Whether to build with `rayon` (not in a one-thread pool).
        #[cfg(feature = "parallel")]
        let parallel = rayon::current_num_threads() > 1;
        #[cfg(not(feature = "parallel"))]
        let parallel = false;
        copy_triangles(mesh, mesh_triangles, parallel);
        let context = Context {
            triangles: mesh_triangles,
            costs: CostModel::new(params),
            leaf_size: params.leaf_size as usize,
            depth_limit: params.depth_limit(n),
            exact_max: params.exact_search_max as usize,
            count_max: *count_max,
            dispatch: *dispatch,
            #[cfg(feature = "parallel")]
            parallel,
            #[cfg(feature = "parallel")]
            chunked_min: (2 * n).div_ceil(rayon::current_num_threads().max(1)),
            #[cfg(feature = "parallel")]
            pool,
        };
        layout.clear();
        layout.reserve_for(n);
        let root = root_node(&context, scratch);
        let bounds = root.cell;
        build_subtree(&context, root, 0, scratch, layout)?;

        let (max_depth, refs) = layout.finish_into(
            &mut tree.nodes,
            &mut tree.leaves,
            &mut tree.blocks,
            mesh_triangles,
        );
        mark_empty_children(&mut tree.nodes, &tree.leaves);
        tree.wide.build(&tree.nodes, &tree.leaves, subtree_boxes);
        tree.bounds = bounds;
        tree.mesh_triangles = n;
        tree.triangle_boxes = OnceLock::new();
        tree.subspace = Default::default();
        let build_time = started.elapsed();
        let (nodes, leaves, blocks) = (&tree.nodes, &tree.leaves, &tree.blocks);
        tree.stats = BuildStats {
            triangles: n,
            nodes: nodes.len(),
            leaves: count_leaves(nodes, parallel),
            nonempty_leaves: leaves.len() - 1,
            triangle_refs: refs,
            max_depth,
            bytes: nodes.len() * size_of::<Node>()
                + leaves.len() * size_of::<LeafRecord>()
                + blocks.len() * size_of::<TriangleBlock>()
                + tree.wide.bytes(),
            build_time,
        };
        Ok(())
    }
}

/// How many of `nodes` are leaves (counted in parallel chunks when `parallel`).
fn count_leaves(nodes: &[Node], parallel: bool) -> usize {
    #[cfg(feature = "parallel")]
    if parallel {
        return nodes.par_iter().filter(|n| n.is_leaf()).count();
    }
    let _ = parallel;
    nodes.iter().filter(|n| n.is_leaf()).count()
}

/// Replaces `out` with the triangles of `mesh`, by id (in parallel chunks when `parallel`).
fn copy_triangles(mesh: &Mesh, out: &mut Vec<Triangle>, parallel: bool) {
    out.clear();
    pages::reserve_exact(out, mesh.triangle_count());
    #[cfg(feature = "parallel")]
    if parallel {
        out.par_extend(
            (0..mesh.triangle_count())
                .into_par_iter()
                .map(|i| mesh.triangle(i)),
        );
        return;
    }
    let _ = parallel;
    out.extend(mesh.triangles());
}

//! SAH kd-trees: build, node layout, leaf records, statistics.

mod build;
mod clip;
mod events;
mod layout;
mod node;
mod pages;
mod refs;
mod sah;
mod stats;
mod subspace;
mod triangle_boxes;
mod wide;

use std::sync::OnceLock;

use kdbeam_kernels::raybox::BoxBlock;
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Aabb, Isa, KsTriangle, Triangle, TriangleBlock};

use crate::Mesh;

pub use build::KdTreeBuilder;
pub use node::{Node, MAX_NODE_INDEX};
pub use stats::BuildStats;
pub use subspace::{LeafMask, SubspaceMasks, SubspaceResolution};
pub(crate) use wide::BinaryBoxes;
pub use wide::{WideChild, WideNode, WideNodes, BOX_PAD, WIDE, WIDE_STACK};

use crate::{Error, Result};

/// Parameters of the SAH build.
///
/// Start from [`BuildParams::default`] and change fields with the `with_*` methods (the struct
/// is `#[non_exhaustive]`: parameters may be added, so it cannot be written as a literal outside
/// this crate); the fields stay public to read and assign.
///
/// ```
/// use kdbeam::BuildParams;
///
/// let params = BuildParams::default().with_ci_over_ct(0.5).with_leaf_size(2);
/// assert_eq!((params.ci_over_ct, params.leaf_size), (0.5, 2));
/// assert!(params.validate().is_ok());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct BuildParams {
    /// Cost of one ray–triangle test over the cost of one traversal step (`Ci / Ct`), the
    /// horizontal axis of Reshetov's Figs. 7–9. Larger values split more: bigger trees, smaller
    /// leaves. Must be finite and > 0. The default, 0.05, serves primary and shadow rays on one
    /// tree of an evenly tessellated mesh: culled packets want fewer nodes than the unculled
    /// SAH optimum; a mesh whose surface is held by large triangles wants more
    /// ([`BuildParams::for_mesh`]), and so do single rays
    /// ([`BuildParams::for_incoherent_rays`]);
    /// docs/benchmarks.md ("Defaults") has what it costs each kind of ray on each shared scene.
    pub ci_over_ct: f32,
    /// Fraction by which the SAH cost of a split is reduced when one side is empty, in `[0, 1)`.
    pub empty_bonus: f32,
    /// Maximum depth; `None` means `8 + 1.3 · log2(N)` (pbrt's rule).
    pub max_depth: Option<u32>,
    /// Nodes with at most this many triangles become leaves without trying to split (>= 1).
    pub leaf_size: u32,
    /// Nodes with at most this many triangles choose their plane exactly, among every face of
    /// their triangles' clipped boxes (counted in SIMD lanes up to 128 triangles, by Wald &
    /// Havran's sweep above); larger ones among 32 bins per axis. The build-quality
    /// knob: lower builds faster and gives slightly costlier trees. `0` bins
    /// every node (on a regular grid, whose triangles line the bins' boundaries, that can take
    /// many more nodes); `u32::MAX` searches every node exactly, in O(N log² N) time and with
    /// up to 144 bytes of scratch per triangle of the root (its sorted events and candidates).
    pub exact_search_max: u32,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            ci_over_ct: 0.05,
            empty_bonus: 0.5,
            max_depth: None,
            leaf_size: 1,
            exact_search_max: 64,
        }
    }
}

impl BuildParams {
    /// The same parameters with [`ci_over_ct`](BuildParams::ci_over_ct) set.
    #[must_use]
    pub const fn with_ci_over_ct(self, ci_over_ct: f32) -> Self {
        BuildParams { ci_over_ct, ..self }
    }

    /// The same parameters with [`empty_bonus`](BuildParams::empty_bonus) set.
    #[must_use]
    pub const fn with_empty_bonus(self, empty_bonus: f32) -> Self {
        BuildParams {
            empty_bonus,
            ..self
        }
    }

    /// The same parameters with [`max_depth`](BuildParams::max_depth) set (`None`: pbrt's rule).
    #[must_use]
    pub const fn with_max_depth(self, max_depth: Option<u32>) -> Self {
        BuildParams { max_depth, ..self }
    }

    /// The same parameters with [`leaf_size`](BuildParams::leaf_size) set.
    #[must_use]
    pub const fn with_leaf_size(self, leaf_size: u32) -> Self {
        BuildParams { leaf_size, ..self }
    }

    /// The same parameters with [`exact_search_max`](BuildParams::exact_search_max) set.
    #[must_use]
    pub const fn with_exact_search_max(self, exact_search_max: u32) -> Self {
        BuildParams {
            exact_search_max,
            ..self
        }
    }

    /// Checks every field's range.
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] naming the first field out of range.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, message: String| Err(Error::InvalidParameter { name, message });
        if !(self.ci_over_ct.is_finite() && self.ci_over_ct > 0.0) {
            return bad(
                "ci_over_ct",
                format!("must be finite and > 0, got {}", self.ci_over_ct),
            );
        }
        if !(0.0..1.0).contains(&self.empty_bonus) {
            return bad(
                "empty_bonus",
                format!("must be in [0, 1), got {}", self.empty_bonus),
            );
        }
        if self.max_depth.is_some_and(|d| d > 64) {
            return bad(
                "max_depth",
                format!("must be at most 64, got {:?}", self.max_depth),
            );
        }
        if self.leaf_size == 0 {
            return bad("leaf_size", "must be at least 1".into());
        }
        Ok(())
    }

    /// The build for camera and shadow rays traced in packets on `mesh`: the default with
    /// [`ci_over_ct`](BuildParams::ci_over_ct) `0.05 · s^0.75` (within `[0.05, 3]`), where `s`
    /// is how unevenly the mesh's surface is shared among its triangles
    /// ([`Mesh::area_spread`]).
    ///
    /// A packet's beam culls the triangles of a leaf that its rays miss (Reshetov, Soupikov &
    /// Hurley's transient frustum). Where small triangles hold the surface (a scanned model,
    /// `s` near 1), it removes most of a leaf's tests, and a small tree of large leaves is
    /// fastest: the default. Where large triangles hold most of it (an interior's walls and
    /// floors), every packet meets them, their tests stay, and smaller leaves pay. The rule
    /// follows the fastest sizes of the shared scenes' camera rays (docs/benchmarks.md, "The
    /// default tree from the scene's triangles"): the bunny (`s` = 0.98), the dragon (1.96) and
    /// killeroo (2.71) run within a few percent between 0.03 and 0.1, sponza (207) fastest
    /// near 3.
    ///
    /// ```
    /// use kdbeam::{BuildParams, Mesh};
    ///
    /// let even = Mesh::from_soup(&[
    ///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
    ///     [0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0],
    /// ])?;
    /// // Equal triangles: the default.
    /// assert_eq!(BuildParams::for_mesh(&even), BuildParams::default());
    /// // A large triangle beside a small one: a bigger tree.
    /// let uneven = Mesh::from_soup(&[
    ///     [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0],
    ///     [0.0, 0.0, 1.0], [10.0, 0.0, 1.0], [0.0, 10.0, 1.0],
    /// ])?;
    /// assert!(BuildParams::for_mesh(&uneven).ci_over_ct > 0.08);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    #[must_use]
    pub fn for_mesh(mesh: &Mesh) -> Self {
        let even = BuildParams::default();
        let ci_over_ct = even.ci_over_ct * mesh.area_spread().powf(0.75);
        even.with_ci_over_ct(ci_over_ct.clamp(even.ci_over_ct, 3.0))
    }

    /// The build for incoherent rays traced on `isa`: ambient-occlusion and diffuse rays,
    /// random rays, rays traced one by one.
    ///
    /// A single ray tests a leaf's triangles a vector of [`Isa::width`] at a time, and the
    /// default's large leaves (made for beams that cull most of a leaf for a whole packet)
    /// cost it several vectors per leaf. On ISAs of fewer than 16 lanes this returns the
    /// default with [`ci_over_ct`](BuildParams::ci_over_ct) set to
    /// [`INCOHERENT_CI_OVER_CT`](BuildParams::INCOHERENT_CI_OVER_CT), about a quarter of the
    /// tests per ray; on 16 AVX-512 lanes, where the smaller leaves ran no faster, the default
    /// itself. docs/benchmarks.md ("A tree for incoherent rays") has what each costs. Camera
    /// rays and shadow rays traced in pixel tiles stay fastest on the default tree, so a
    /// renderer that traces both kinds builds two trees.
    ///
    /// ```
    /// use kdbeam::{BuildParams, Isa};
    ///
    /// let avx2 = BuildParams::for_incoherent_rays(Isa::Avx2);
    /// assert_eq!(avx2.ci_over_ct, BuildParams::INCOHERENT_CI_OVER_CT);
    /// assert_eq!(BuildParams::for_incoherent_rays(Isa::Avx512), BuildParams::default());
    /// ```
    #[must_use]
    pub fn for_incoherent_rays(isa: Isa) -> Self {
        if isa.width() >= 16 {
            BuildParams::default()
        } else {
            BuildParams::default().with_ci_over_ct(Self::INCOHERENT_CI_OVER_CT)
        }
    }

    /// The SAH cost ratio of [`BuildParams::for_incoherent_rays`] on ISAs of fewer than 16
    /// lanes.
    pub const INCOHERENT_CI_OVER_CT: f32 = 0.3;

    /// The depth limit for `triangles` triangles.
    #[must_use]
    pub fn depth_limit(&self, triangles: usize) -> u32 {
        self.max_depth
            .unwrap_or_else(|| (8.0 + 1.3 * (triangles.max(1) as f64).log2()).round() as u32)
            .min(64)
    }
}

/// What a leaf holds: a run of the tree's triangle blocks and its tight box.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LeafRecord {
    /// Index of the leaf's first block in the tree's triangle blocks (see
    /// [`KdTree::leaf_triangles`]); its `⌈count / BLOCK⌉` blocks follow.
    pub first: u32,
    /// Number of triangles (0 for an empty leaf); the last block's lanes beyond it are padding.
    pub count: u32,
    /// The cell ∩ the union of the leaf's triangles clipped to the cell (empty when `count = 0`).
    /// The transient frustum is built against this box.
    pub bounds: Aabb,
}

/// A leaf's triangles: `len` triangles in `⌈len / BLOCK⌉` [`TriangleBlock`]s, triangle `i` in
/// lane `i % BLOCK` of block `i / BLOCK`; the lanes after the last are point-triangle padding
/// that never hits.
///
/// ```
/// let mesh = kdbeam::scene::procedural::builtin("icosphere:1")?;
/// let tree = kdbeam::KdTree::build(&mesh, &kdbeam::BuildParams::default())?;
/// let leaf = tree.leaves().iter().find(|l| l.count > 0).expect("a non-empty leaf");
/// let tris = tree.leaf_triangles(leaf);
/// let id = tris.id(0);
/// assert_eq!(tris.triangle(0), mesh.triangle(id as usize));
/// # Ok::<(), kdbeam::Error>(())
/// ```
#[derive(Clone, Copy, Debug)]
pub struct LeafTriangles<'a> {
    /// The blocks.
    pub blocks: &'a [TriangleBlock],
    /// Number of triangles.
    pub len: usize,
}

impl<'a> LeafTriangles<'a> {
    /// The first `len` triangles of `blocks`. Panics if `blocks` holds fewer.
    #[must_use]
    pub fn new(blocks: &'a [TriangleBlock], len: usize) -> Self {
        assert!(
            len <= blocks.len() * BLOCK,
            "{len} triangles in {} blocks",
            blocks.len()
        );
        LeafTriangles { blocks, len }
    }

    /// Number of triangles.
    #[inline(always)]
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// No triangles?
    #[inline(always)]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Mesh id of triangle `i` (`u32::MAX` for a padding lane, `len <= i` in the last block).
    /// Panics past the last block.
    #[inline(always)]
    #[must_use]
    pub fn id(&self, i: usize) -> u32 {
        self.blocks[i / BLOCK].ids[i % BLOCK]
    }

    /// Triangle `i` by its vertices (the point-triangle padding for `len <= i` in the last
    /// block). Panics past the last block.
    #[inline(always)]
    #[must_use]
    pub fn triangle(&self, i: usize) -> Triangle {
        self.blocks[i / BLOCK].triangle(i % BLOCK)
    }

    /// Triangle `i` in Kensler–Shirley form (padding as for [`LeafTriangles::triangle`]).
    /// Panics past the last block.
    #[inline(always)]
    #[must_use]
    pub fn ks(&self, i: usize) -> KsTriangle {
        self.blocks[i / BLOCK].ks_triangle(i % BLOCK)
    }

    /// The mesh ids, in leaf order.
    pub fn ids(&self) -> impl Iterator<Item = u32> + 'a {
        let leaf = *self;
        (0..leaf.len).map(move |i| leaf.id(i))
    }
}

/// An SAH kd-tree over a mesh, its triangles re-laid out in leaf order, in blocks of [`BLOCK`].
#[derive(Clone, Debug)]
pub struct KdTree {
    nodes: Vec<Node>,
    leaves: Vec<LeafRecord>,
    blocks: Vec<TriangleBlock>,
    /// The same tree in wide nodes, for single rays.
    wide: WideNodes,
    bounds: Aabb,
    mesh_triangles: usize,
    stats: BuildStats,
    /// [`KdTree::triangle_boxes`], made on first use and dropped by a rebuild.
    triangle_boxes: OnceLock<Vec<BoxBlock>>,
    /// Subspace-culling masks, built on first use.
    subspace: subspace::SubspaceCache,
}

impl KdTree {
    /// The nodes, root first.
    #[inline(always)]
    #[must_use]
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The tree collapsed into nodes of up to [`WIDE`] children with their geometry's boxes,
    /// which single rays on SIMD lanes traverse; their leaves are [`KdTree::leaves`].
    #[inline(always)]
    #[must_use]
    pub fn wide_nodes(&self) -> &WideNodes {
        &self.wide
    }

    /// Leaf records, indexed by [`Node::leaf_record`].
    #[inline(always)]
    #[must_use]
    pub fn leaves(&self) -> &[LeafRecord] {
        &self.leaves
    }

    /// The triangles of leaf record `leaf`.
    #[inline(always)]
    #[must_use]
    pub fn leaf_triangles(&self, leaf: &LeafRecord) -> LeafTriangles<'_> {
        let first = leaf.first as usize;
        let n = leaf.count as usize;
        LeafTriangles {
            blocks: &self.blocks[first..first + n.div_ceil(BLOCK)],
            len: n,
        }
    }

    /// The root cell: the mesh's bounding box (empty for an empty mesh).
    #[inline]
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// How many triangles the mesh had.
    #[inline]
    #[must_use]
    pub fn mesh_triangle_count(&self) -> usize {
        self.mesh_triangles
    }

    /// Build statistics.
    #[inline]
    #[must_use]
    pub fn stats(&self) -> &BuildStats {
        &self.stats
    }

    /// The tree's SAH cost under the cost ratio `ci_over_ct` (the one it was built with, or
    /// another, to compare trees on one scale): the expected work of a ray crossing the root
    /// box, in units of one traversal step,
    /// `Σ_inner SA(cell)/SA(root) + Ci/Ct · Σ_leaf SA(cell)/SA(root) · n(leaf)`. The measure
    /// of tree quality the build minimises greedily; lower is better. Computed on demand, in
    /// O(nodes), so that builds for moving geometry do not pay for it.
    ///
    /// Edge cases: when the root's surface area is 0 (a mesh on a line or a point) or not
    /// finite, every cell counts with weight 1; an empty tree (one empty leaf) costs 0.
    ///
    /// ```
    /// let mesh = kdbeam::scene::procedural::builtin("icosphere:2")?;
    /// let params = kdbeam::BuildParams::default().with_ci_over_ct(1.5);
    /// let tree = kdbeam::KdTree::build(&mesh, &params)?;
    /// // A leaf of every triangle would cost 1.5 · n.
    /// assert!(tree.sah_cost(1.5) < 1.5 * mesh.triangle_count() as f64);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    #[must_use]
    pub fn sah_cost(&self, ci_over_ct: f32) -> f64 {
        stats::sah_cost(&self.nodes, self.bounds, ci_over_ct, |record| {
            self.leaves[record as usize].count
        })
    }
}

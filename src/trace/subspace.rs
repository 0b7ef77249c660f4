//! Subspace culling of single rays in kd-tree leaves, after A. Yoshimura and T. Harada,
//! *Subspace Culling for Ray-Box Intersection* (Proc. ACM on Computer Graphics and
//! Interactive Techniques, 2023).
//!
//! Entering a leaf, the ray's segment in the leaf's grid gives its ray mask (the paper's
//! look-up table keyed by the cells of the entry and exit points, Algorithm 1, or the exact
//! mask, the paper's "ideal culling"); the leaf is skipped when the mask misses every cell its
//! triangles touch, and a triangle is dropped when it misses that triangle's cells.
//!
//! Why it is conservative: a hit the intersector reports in a leaf lies on the triangle (up to
//! the intersector's rounding, inside the ray's rounding tube), in the leaf's tight box when
//! it is this leaf's to find; its cell is then in both the triangle's mask ([`voxelise`]) and
//! the ray's ([`Segment`]). A triangle dropped here for a hit outside the leaf's box is found,
//! with the same `t`, `u`, `v`, in the leaf whose box holds the hit: the tree references a
//! triangle in every leaf its clipped part overlaps, and the traversal enters that leaf before
//! any farther hit can stop it. So the closest hit, and whether there is one, do not change.
//!
//! [`voxelise`]: kdbeam_kernels::subspace::voxelise::voxelise
//! [`Segment`]: kdbeam_kernels::subspace::segment::Segment

use std::sync::OnceLock;

use kdbeam_kernels::lanes::Dispatch;
use kdbeam_kernels::subspace::segment::{build_table, segment};
use kdbeam_kernels::subspace::{Mask6, VoxelMask};
use kdbeam_kernels::triangle::BLOCK;
use kdbeam_kernels::{Hit, Lanes, Ray, Vec3};

use super::single::{LeafEntry, RayCounters, TriangleCull};
use super::{single_ray, Intersector};
use crate::kdtree::{KdTree, SubspaceMasks, SubspaceResolution};

/// Which subspace culling single rays run: the resolution, and the ray mask from the paper's
/// look-up table or exact.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Subspace {
    /// R = 4 (a `u64` per mask), the ray mask from the look-up table (`+subspace`).
    Table4,
    /// R = 6 (216 bits per mask), the ray mask from the look-up table (`+subspace6`).
    Table6,
    /// R = 4, the exact ray mask per ray and leaf: the paper's "ideal culling", to measure the
    /// table's loss against (`+subspace-exact`).
    Exact4,
    /// R = 6, the exact ray mask (`+subspace6-exact`).
    Exact6,
}

impl Subspace {
    /// Every variant.
    pub const ALL: [Subspace; 4] = [
        Subspace::Table4,
        Subspace::Table6,
        Subspace::Exact4,
        Subspace::Exact6,
    ];

    /// Its stage in the culling grammar, without the `+`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Subspace::Table4 => "subspace",
            Subspace::Table6 => "subspace6",
            Subspace::Exact4 => "subspace-exact",
            Subspace::Exact6 => "subspace6-exact",
        }
    }

    /// Builds the masks of its resolution in `tree` and its look-up table now, so that the
    /// first ray does not pay for them.
    pub fn prepare(self, tree: &KdTree) {
        match self {
            Subspace::Table4 | Subspace::Exact4 => {
                tree.subspace_masks::<u64>();
                u64::table();
            }
            Subspace::Table6 | Subspace::Exact6 => {
                tree.subspace_masks::<Mask6>();
                Mask6::table();
            }
        }
    }
}

/// A resolution with its look-up table of ray masks, built once per process.
trait RayTable: SubspaceResolution {
    /// The table ([`build_table`]).
    fn table() -> &'static [Self];
}

/// The table of `M`, built on first use.
fn make_table<M: VoxelMask>() -> Vec<M> {
    let n = M::R * M::R * M::R;
    let mut t = vec![M::EMPTY; n * n];
    build_table(&mut t);
    t
}

impl RayTable for u64 {
    fn table() -> &'static [u64] {
        static TABLE: OnceLock<Vec<u64>> = OnceLock::new();
        TABLE.get_or_init(make_table)
    }
}

impl RayTable for Mask6 {
    fn table() -> &'static [Mask6] {
        static TABLE: OnceLock<Vec<Mask6>> = OnceLock::new();
        TABLE.get_or_init(make_table)
    }
}

/// The [`TriangleCull`] of subspace culling at resolution `M`.
struct SubspaceCull<'a, M: 'static> {
    masks: &'a SubspaceMasks<M>,
    /// The look-up table, or `None` for the exact ray mask.
    table: Option<&'static [M]>,
    inv_direction: Vec3,
    /// The largest `|origin|` component, for the rounding bound.
    magnitude: f32,
    /// The ray's mask in the leaf last entered.
    ray_mask: M,
}

impl<'a, M: RayTable> SubspaceCull<'a, M> {
    fn new(tree: &'a KdTree, ray: &Ray, exact: bool) -> Self {
        SubspaceCull {
            masks: tree.subspace_masks::<M>(),
            table: (!exact).then(M::table),
            inv_direction: ray.direction.recip(),
            magnitude: ray.origin.abs().max_element(),
            ray_mask: M::FULL,
        }
    }
}

impl<M: RayTable> TriangleCull for SubspaceCull<'_, M> {
    #[inline(always)]
    fn enter(&mut self, ray: &Ray, leaf: &LeafEntry<'_>) -> bool {
        let leaf_mask = &self.masks.leaves[leaf.index as usize];
        let Some(grid) = &leaf_mask.grid else {
            self.ray_mask = M::FULL;
            return true;
        };
        let Some(s) = segment(
            grid,
            M::R,
            ray,
            self.inv_direction,
            self.magnitude,
            ray.tmax,
        ) else {
            return false;
        };
        self.ray_mask = match self.table {
            Some(table) => s.table_mask(table),
            None => s.exact_mask(),
        };
        !self.ray_mask.and(leaf_mask.mask).is_empty()
    }

    #[inline(always)]
    fn lanes<L: Lanes>(
        &mut self,
        _: L,
        _: &Ray,
        block: usize,
        first: usize,
        valid: u32,
        _: f32,
    ) -> u32 {
        let start = block * BLOCK + first;
        let masks = &self.masks.triangles[start..start + L::WIDTH];
        let mut kept = 0u32;
        for (i, m) in masks.iter().enumerate() {
            kept |= u32::from(!m.and(self.ray_mask).is_empty()) << i;
        }
        kept & valid
    }
}

/// [`single_ray`] with subspace culling `subspace`, then the stage `then` on what it keeps.
#[inline]
pub(crate) fn single_ray_culled<const ANY: bool>(
    dispatch: Dispatch,
    tree: &KdTree,
    intersector: Intersector,
    ray: &Ray,
    subspace: Subspace,
    then: impl TriangleCull,
    accept: impl FnMut(&Hit) -> bool,
) -> (bool, Hit, RayCounters) {
    match subspace {
        Subspace::Table4 | Subspace::Exact4 => {
            let cull = SubspaceCull::<u64>::new(tree, ray, subspace == Subspace::Exact4);
            single_ray::<ANY>(dispatch, tree, intersector, ray, (cull, then), accept)
        }
        Subspace::Table6 | Subspace::Exact6 => {
            let cull = SubspaceCull::<Mask6>::new(tree, ray, subspace == Subspace::Exact6);
            single_ray::<ANY>(dispatch, tree, intersector, ray, (cull, then), accept)
        }
    }
}

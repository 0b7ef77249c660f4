//! Occupancy masks of a tree's leaves and triangles for subspace culling (Yoshimura & Harada,
//! *Subspace Culling for Ray-Box Intersection*, Proc. ACM CGIT 2023), built on first use.

use std::sync::OnceLock;

use kdbeam_kernels::subspace::voxelise::voxelise;
use kdbeam_kernels::subspace::{Grid, Mask6, VoxelMask};
use kdbeam_kernels::triangle::BLOCK;
#[cfg(feature = "parallel")]
use rayon::prelude::*;

use super::KdTree;

/// A leaf's grid and the union of its triangles' masks.
#[derive(Clone, Copy, Debug)]
pub struct LeafMask<M> {
    /// The grid over the leaf's tight box ([`LeafRecord::bounds`](super::LeafRecord::bounds)),
    /// `None` for an empty leaf or one whose box has no grid ([`Grid::around`]).
    pub grid: Option<Grid>,
    /// Every cell one of the leaf's triangles touches.
    pub mask: M,
}

/// The masks of one resolution for every leaf and every triangle slot of a [`KdTree`].
#[derive(Clone, Debug)]
pub struct SubspaceMasks<M> {
    /// Per leaf record, as [`KdTree::leaves`].
    pub leaves: Vec<LeafMask<M>>,
    /// Per triangle slot of the tree's blocks (`block · BLOCK + lane`): the triangle voxelised
    /// in its leaf's grid ([`VoxelMask::FULL`] in a leaf without a grid, empty for padding).
    pub triangles: Vec<M>,
}

/// The masks of every resolution, each built once on first use and dropped with the tree's
/// layout on a rebuild.
#[derive(Clone, Debug, Default)]
pub struct SubspaceCache {
    r4: OnceLock<SubspaceMasks<u64>>,
    r6: OnceLock<SubspaceMasks<Mask6>>,
}

/// A mask resolution a tree caches masks for.
pub trait SubspaceResolution: VoxelMask {
    /// Its slot in the cache.
    #[doc(hidden)]
    fn slot(cache: &SubspaceCache) -> &OnceLock<SubspaceMasks<Self>>;
}

impl SubspaceResolution for u64 {
    fn slot(cache: &SubspaceCache) -> &OnceLock<SubspaceMasks<u64>> {
        &cache.r4
    }
}

impl SubspaceResolution for Mask6 {
    fn slot(cache: &SubspaceCache) -> &OnceLock<SubspaceMasks<Mask6>> {
        &cache.r6
    }
}

impl KdTree {
    /// The subspace masks at resolution `M` (`u64`: R = 4, [`Mask6`]: R = 6), built on the
    /// first call (in parallel with the `parallel` feature) and kept until the tree is rebuilt.
    ///
    /// Each leaf gets a grid over its tight box and, per triangle, the cells of that grid the
    /// triangle touches ([`voxelise`]); the leaf's mask is their union. A ray whose segment in
    /// the grid touches none of a leaf's (or a triangle's) cells cannot hit it there.
    pub fn subspace_masks<M: SubspaceResolution>(&self) -> &SubspaceMasks<M> {
        M::slot(&self.subspace).get_or_init(|| build(self))
    }
}

/// The masks of `tree` at resolution `M`.
fn build<M: VoxelMask>(tree: &KdTree) -> SubspaceMasks<M> {
    let grids: Vec<Option<Grid>> = tree
        .leaves()
        .iter()
        .map(|l| (l.count > 0).then(|| Grid::around(&l.bounds)).flatten())
        .collect();
    // The leaf and count of every block.
    let mut owner = vec![(u32::MAX, 0usize); tree.blocks.len()];
    for (i, l) in tree.leaves().iter().enumerate() {
        let count = l.count as usize;
        for b in 0..count.div_ceil(BLOCK) {
            owner[l.first as usize + b] = (i as u32, (count - b * BLOCK).min(BLOCK));
        }
    }
    let block_masks = |(block, &(leaf, count)): (&kdbeam_kernels::TriangleBlock, &(u32, usize))| {
        let mut masks = [M::EMPTY; BLOCK];
        if leaf == u32::MAX {
            return masks;
        }
        for (slot, m) in masks.iter_mut().enumerate().take(count) {
            *m = match &grids[leaf as usize] {
                Some(grid) => voxelise(grid, &block.triangle(slot)),
                None => M::FULL,
            };
        }
        masks
    };
    #[cfg(feature = "parallel")]
    let per_block: Vec<[M; BLOCK]> = tree
        .blocks
        .par_iter()
        .zip(owner.par_iter())
        .map(block_masks)
        .collect();
    #[cfg(not(feature = "parallel"))]
    let per_block: Vec<[M; BLOCK]> = tree
        .blocks
        .iter()
        .zip(owner.iter())
        .map(block_masks)
        .collect();
    let leaves = tree
        .leaves()
        .iter()
        .zip(&grids)
        .map(|(l, &grid)| {
            let first = l.first as usize;
            let blocks = &per_block[first..first + (l.count as usize).div_ceil(BLOCK)];
            let mask = blocks.iter().flatten().fold(M::EMPTY, |acc, &m| acc.or(m));
            LeafMask { grid, mask }
        })
        .collect();
    SubspaceMasks {
        leaves,
        triangles: per_block.into_iter().flatten().collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BuildParams, KdTreeBuilder};

    #[test]
    fn masks_cover_every_slot_and_are_dropped_on_rebuild() {
        let mesh = crate::scene::procedural::builtin("icosphere:2").unwrap();
        let mut builder = KdTreeBuilder::new();
        let mut tree = builder.build(&mesh, &BuildParams::default()).unwrap();
        let m = tree.subspace_masks::<u64>();
        assert_eq!(m.leaves.len(), tree.leaves().len());
        assert_eq!(m.triangles.len(), tree.blocks.len() * BLOCK);
        for (l, lm) in tree.leaves().iter().zip(&m.leaves) {
            assert_eq!(l.count > 0, lm.grid.is_some());
            assert_eq!(l.count > 0, lm.mask != 0);
        }
        let first = m as *const SubspaceMasks<u64>;
        assert!(std::ptr::eq(first, tree.subspace_masks::<u64>()));
        let small = crate::scene::procedural::builtin("icosphere:1").unwrap();
        builder
            .rebuild(&mut tree, &small, &BuildParams::default())
            .unwrap();
        assert_eq!(
            tree.subspace_masks::<Mask6>().leaves.len(),
            tree.leaves().len()
        );
        assert_eq!(
            tree.subspace_masks::<u64>().leaves.len(),
            tree.leaves().len()
        );
    }
}

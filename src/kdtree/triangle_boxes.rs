//! The boxes of a tree's triangles, each clipped to its leaf, for ray-box culling: built on
//! first use, since only single rays with that stage on read them.

use kdbeam_kernels::raybox::BoxBlock;
use kdbeam_kernels::triangle::BLOCK;

use super::KdTree;

impl KdTree {
    /// One [`BoxBlock`] per triangle block of the tree (same index as the blocks a
    /// [`LeafRecord::first`](super::LeafRecord::first) points into): the boxes of the block's
    /// triangles, each clipped to its leaf's tight box, the padding lanes empty.
    ///
    /// Built on the first call (in O(triangle references)) and kept until the tree is rebuilt;
    /// later calls, from any thread, return the same slice.
    ///
    /// ```
    /// let mesh = kdbeam::scene::procedural::builtin("icosphere:2")?;
    /// let tree = kdbeam::KdTree::build(&mesh, &kdbeam::BuildParams::default())?;
    /// assert_eq!(tree.raybox_bytes(), 0);
    /// let leaf = tree.leaves().iter().find(|l| l.count > 0).expect("a non-empty leaf");
    /// let b = tree.triangle_boxes()[leaf.first as usize].get(0);
    /// assert!(!b.is_empty() && leaf.bounds.union(b).extent().max_element() < 1.001 * leaf.bounds.extent().max_element() + 1e-6);
    /// assert!(tree.raybox_bytes() > 0);
    /// # Ok::<(), kdbeam::Error>(())
    /// ```
    #[must_use]
    pub fn triangle_boxes(&self) -> &[BoxBlock] {
        self.triangle_boxes.get_or_init(|| {
            let mut boxes = vec![BoxBlock::EMPTY; self.blocks.len()];
            for leaf in &self.leaves {
                let (first, count) = (leaf.first as usize, leaf.count as usize);
                for b in 0..count.div_ceil(BLOCK) {
                    let at = first + b;
                    boxes[at] =
                        BoxBlock::clipped(&self.blocks[at], count - b * BLOCK, &leaf.bounds);
                }
            }
            boxes
        })
    }

    /// Bytes of [`KdTree::triangle_boxes`]: 0 until the first call, then
    /// `size_of::<BoxBlock>()` per triangle block (a third of what the blocks take).
    #[must_use]
    pub fn raybox_bytes(&self) -> usize {
        self.triangle_boxes
            .get()
            .map_or(0, |b| size_of_val(b.as_slice()))
    }
}

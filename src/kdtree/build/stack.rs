//! The per-thread stack of references, and its hand-over to a tree as its triangles' memory.

use kdbeam_kernels::KsTriangle;

use super::Scratch;
use crate::kdtree::refs::Ref;

/// Three references fill the bytes of two Kensler–Shirley triangles (96), with the same
/// alignment (16).
pub(super) const REFS_PER_KS_PAIR: usize = 3;
const _: () = assert!(
    REFS_PER_KS_PAIR * size_of::<Ref>() == 2 * size_of::<KsTriangle>()
        && align_of::<Ref>() == align_of::<KsTriangle>()
);

/// The stack's first reservation, in references per triangle (address space: its pages are
/// touched only as the stack reaches them). Meshes seldom need more than three at the
/// deepest, so the stack seldom grows, which would copy it into new pages; and
/// [`Scratch::hand_over_stack`] can lend it to trees of up to 2⅔ references per triangle, as
/// most are.
pub(super) const STACK_PER_TRIANGLE: usize = 4;

/// Makes room for `len` references in the stack `refs`, growing it geometrically, to a capacity
/// that is a multiple of [`REFS_PER_KS_PAIR`]: a whole number of Kensler–Shirley triangles, so
/// that [`Scratch::hand_over_stack`] can recycle it.
#[inline]
pub(super) fn reserve_stack(refs: &mut Vec<Ref>, len: usize) {
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
    /// written already, so fewer pages are faulted in. Nothing happens
    /// when the stack cannot hold `needed` triangles (growing it would copy its stale bytes
    /// to a new allocation) or its capacity is not a whole number of triangles.
    pub(super) fn hand_over_stack(&mut self, ks: &mut Vec<KsTriangle>, needed: usize) {
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

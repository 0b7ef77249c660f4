//! The per-thread stack of references.

use crate::kdtree::pages;
use crate::kdtree::refs::Ref;

/// The stack's first reservation, in references per triangle (address space: its pages are
/// touched only as the stack reaches them). Meshes seldom need more than three at the
/// deepest, so the stack seldom grows, which would copy it into new pages.
pub(super) const STACK_PER_TRIANGLE: usize = 4;

/// Makes room for `len` references in the stack `refs`, growing it geometrically.
#[inline]
pub(super) fn reserve_stack(refs: &mut Vec<Ref>, len: usize) {
    if refs.capacity() < len {
        let capacity = len.max(2 * refs.capacity());
        pages::reserve_exact(refs, capacity - refs.len());
    }
}

//! The per-thread scratch of packet traversals: the per-ray traversal's stack of per-ray
//! intervals, and the rays' reciprocal directions for the whole-packet traversal.

use super::{Column, N};
use crate::trace::single::STACK_DEPTH;

/// A packet traversal's scratch, 33 KiB, kept per thread rather than zeroed on the machine
/// stack for every packet (a camera packet that misses everything would spend more on that
/// than on its traversal).
pub(crate) struct Stack {
    pub(super) enter: [Column; STACK_DEPTH],
    pub(super) exit: [Column; STACK_DEPTH],
    /// The reciprocal directions of the whole-packet traversal's rays, by axis.
    pub(super) reciprocals: [Column; 3],
}

thread_local! {
    static STACK: std::cell::RefCell<Box<Stack>> = std::cell::RefCell::new(Box::new(Stack {
        enter: [[0.0; N]; STACK_DEPTH],
        exit: [[0.0; N]; STACK_DEPTH],
        reciprocals: [[0.0; N]; 3],
    }));
}

/// Runs `f` with this thread's traversal stack. Call it outside the ISA's `#[target_feature]`
/// entry point: the closure is not inlined.
pub(crate) fn with_stack<R>(f: impl FnOnce(&mut Stack) -> R) -> R {
    STACK.with(|s| f(&mut s.borrow_mut()))
}

//! The per-thread stack of per-ray intervals of the per-ray traversal.

use super::{Column, N};
use crate::trace::single::STACK_DEPTH;

/// The per-ray intervals of a traversal stack: 32 KiB, kept per thread rather than zeroed on
/// the machine stack for every packet.
pub(crate) struct Stack {
    pub(super) enter: [Column; STACK_DEPTH],
    pub(super) exit: [Column; STACK_DEPTH],
}

thread_local! {
    static STACK: std::cell::RefCell<Box<Stack>> = std::cell::RefCell::new(Box::new(Stack {
        enter: [[0.0; N]; STACK_DEPTH],
        exit: [[0.0; N]; STACK_DEPTH],
    }));
}

/// Runs `f` with this thread's traversal stack. Call it outside the ISA's `#[target_feature]`
/// entry point: the closure is not inlined.
pub(crate) fn with_stack<R>(f: impl FnOnce(&mut Stack) -> R) -> R {
    STACK.with(|s| f(&mut s.borrow_mut()))
}

//! The one `unsafe` idiom of the vector implementations: calling `#[target_feature]` intrinsics on
//! values whose existence proves the CPU supports them.

/// Evaluates `$e`, an expression of `#[target_feature]` intrinsics that take and return values
/// (no pointers), in an `unsafe` block justified by the token proof.
///
/// Only use it inside a `Lanes` implementation, on operands that are that implementation's vector
/// or mask values (or inside methods of its token): their fields are private and they can only be
/// made through the token, whose constructors either detect the ISA or require the caller to
/// promise it (`new_unchecked`). So whenever such an expression runs, the CPU supports the ISA.
macro_rules! proven {
    ($e:expr) => {
        // SAFETY: the operands (or `self`) exist only if this file's token was made, which
        // proves the CPU supports every intrinsic `$e` calls; `$e` dereferences no pointer.
        unsafe { $e }
    };
}

pub(super) use proven;

//! Placeholder.
/// Placeholder.
#[derive(Clone, Copy, Debug)]
pub struct Avx;
/// Placeholder.
pub struct AvxF32;
/// Placeholder.
pub struct AvxMask;

//! Placeholder.
/// Placeholder.
#[derive(Clone, Copy, Debug)]
pub struct Portable;
/// Placeholder.
pub struct PortableMask;

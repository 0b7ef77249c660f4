//! Placeholder.
/// Placeholder.
#[derive(Clone, Copy, Debug)]
pub struct Sse;
/// Placeholder.
pub struct SseF32;
/// Placeholder.
pub struct SseMask;

//! Procedural scenes (placeholder).

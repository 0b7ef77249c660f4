//! SAH build (placeholder).

//! Seeded random numbers (placeholder).

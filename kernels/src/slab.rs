//! Ray and packet × box clipping.

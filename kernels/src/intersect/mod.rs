//! Ray × triangle tests.

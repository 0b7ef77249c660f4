//! The surface area heuristic and the event sweep that finds a node's best plane
//! (Wald & Havran 2006, §3 and §4.2, Algorithm 4), and the binned search used instead on large
//! nodes (Hunt, Mark & Stoll 2006; Shevtsov, Soupikov & Kapustin 2007).
//!
//! [`cost`]: the cost model and the search for the cheapest candidate; [`exact`]: the candidates
//! of small nodes, every face with exact counts; [`bins`]: those of large nodes, bin boundaries.

mod bins;
mod cost;
mod exact;

#[cfg(feature = "parallel")]
pub(crate) use bins::BinCounts;
pub(crate) use bins::Bins;
pub(crate) use cost::{CostModel, Split};
pub(crate) use exact::{ExactPlanes, COUNTED_SEARCH_MAX};

/// Boxes spanning `spans` on x and `[0, 1]` on y and z.
#[cfg(test)]
fn boxes_x(spans: &[(f32, f32)]) -> Vec<kdbeam_kernels::Aabb> {
    use kdbeam_kernels::{Aabb, Vec3};
    spans
        .iter()
        .map(|&(lo, hi)| Aabb::new(Vec3::new(lo, 0.0, 0.0), Vec3::new(hi, 1.0, 1.0)))
        .collect()
}

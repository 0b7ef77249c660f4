//! Tables and plots for the benchmarks and figures.

pub mod accuracy;
mod plot;

pub use plot::{LinePlot, Series};

/// Writes `rows` as CSV with `header`; fields are written as given (numbers, plain names).
pub fn csv(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut out = header.join(",");
    out.push('\n');
    for r in rows {
        out.push_str(&r.join(","));
        out.push('\n');
    }
    out
}

//! The kdbeam command-line tool: render a scene, benchmark the tracer.
#![deny(clippy::undocumented_unsafe_blocks)]

use std::process::ExitCode;

use clap::{Parser, Subcommand};

use commands::{accuracy, bench, build_bench, figures, render, sweep, synthetic};

mod commands;

#[derive(Parser)]
#[command(
    name = "kdbeam",
    version,
    about = "SIMD packet ray tracing through SAH kd-trees"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene with the standard camera to a PNG; print build and trace statistics.
    Render(render::RenderArgs),
    /// Measure Mrays/s per ISA and packet size (with --embree: next to Embree's).
    Bench(bench::BenchArgs),
    /// Sweep kd-tree size (ci_over_ct) against culling: Mrays/s and tests eliminated
    /// (Reshetov's Figs. 7–9).
    Sweep(sweep::SweepArgs),
    /// Measure kd-tree build time per ci_over_ct against Embree's BVH build (with the embree
    /// feature), and build + one frame of primary rays: the cost per frame of moving geometry.
    BuildBench(build_bench::BuildBenchArgs),
    /// Cycles per ray–triangle test on Kensler–Shirley synthetic data (one leaf, no tree), per
    /// culling setting next to the unculled baseline (Reshetov's Figs. 3–5).
    Synthetic(synthetic::SyntheticArgs),
    /// Run time against error: every intersector × ISA × culling mode against the f64 oracle
    /// (hit/miss disagreements, wrong triangle ids, edge ties, relative error of t).
    Accuracy(accuracy::AccuracyArgs),
    /// Reshetov's Figs. 3, 4, 5 (synthetic) and 7 (tree size), and the Embree comparison, as
    /// SVG + CSV with a markdown summary.
    Figures(figures::FiguresArgs),
}

fn main() -> ExitCode {
    let result = match Cli::parse().command {
        Command::Render(args) => render::run(args),
        Command::Bench(args) => bench::run(args),
        Command::Sweep(args) => sweep::run(args),
        Command::BuildBench(args) => build_bench::run(args),
        Command::Synthetic(args) => synthetic::run(args),
        Command::Accuracy(args) => accuracy::run(args),
        Command::Figures(args) => figures::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

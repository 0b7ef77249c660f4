//! `kdbeam figures --out DIR`: Reshetov's Figs. 3, 4 and 5 (the synthetic cell), Fig. 7 (a tree
//! size sweep on a real scene) and the Embree comparison, as SVG with CSV next to each and a
//! markdown summary.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use clap::Parser;

use crate::{Cli, Command};
use kdbeam::scene::synthetic::{self, SyntheticParams};
use kdbeam::trace::{Culling, Planes};
use kdbeam::Isa;
use kdbeam_cli::report::{csv, LinePlot, Series};
use kdbeam_cli::{Error, Result};

use super::{bench, sweep};

#[derive(clap::Args)]
pub(crate) struct FiguresArgs {
    /// Folder for the figures, their CSV and summary.md.
    #[arg(long, default_value = "figures")]
    out: PathBuf,
    /// Scene of the tree-size sweep and the Embree comparison.
    #[arg(long, default_value = "bunny")]
    scene: String,
    /// ISA of the synthetic figures (default: the widest this CPU runs).
    #[arg(long)]
    isa: Option<Isa>,
    /// Fewer packets, smaller images and fewer points: a quick look, not a measurement.
    #[arg(long)]
    quick: bool,
}

/// One synthetic curve point: x, then cycles per test for the baseline, 4-plane and
/// 6-plane + aperture.
type Curve = Vec<(f64, [f64; 3])>;

/// A synthetic figure: file stem, title, x label, log x axis, and the parameters of each point.
struct Figure {
    stem: &'static str,
    title: &'static str,
    x_label: &'static str,
    log_x: bool,
    points: Vec<(f64, SyntheticParams)>,
}

const CULLINGS: [(&str, Culling); 3] = [
    ("Kensler–Shirley", Culling::NONE),
    ("4-plane", Culling::planes(Planes::Four, false)),
    ("6-plane + aperture", Culling::FULL),
];

pub(crate) fn run(args: FiguresArgs) -> Result<()> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| kdbeam::Error::Io { path, source }
    };
    std::fs::create_dir_all(&args.out).map_err(io(&args.out))?;
    let isa = match args.isa {
        Some(isa) => kdbeam::kernels::Dispatch::new(isa)?.isa(),
        None => Isa::detect(),
    };
    let base = SyntheticParams {
        packets: if args.quick { 64 } else { 1024 },
        ..SyntheticParams::default()
    };
    let reps = if args.quick { 3 } else { 9 };
    let mut summary = format!(
        "# kdbeam figures\n\nMade by `kdbeam figures{}` on {isa}; cycles are TSC reference \
         cycles per ray–triangle test (median of {reps}); every ratio is against the \
         Kensler–Shirley baseline of the same run.\n\n",
        if args.quick { " --quick" } else { "" }
    );

    let figs = [
        Figure {
            stem: "fig3",
            title: "Fig. 3: cycles per test against leaf edge / triangle edge (8×8, jitter 4%)",
            x_label: "leaf edge / triangle edge",
            log_x: false,
            points: (1..=10)
                .map(|r| {
                    (
                        f64::from(r),
                        SyntheticParams {
                            ratio: r as f32,
                            ..base
                        },
                    )
                })
                .collect(),
        },
        Figure {
            stem: "fig4",
            title: "Fig. 4: cycles per test against packet size n×n (ratio 4, jitter 4%)",
            x_label: "rays per packet side n",
            log_x: true,
            points: [2usize, 4, 8, 16]
                .iter()
                .map(|&n| {
                    (
                        n as f64,
                        SyntheticParams {
                            packet_n: n,
                            ..base
                        },
                    )
                })
                .collect(),
        },
        Figure {
            stem: "fig5",
            title:
                "Fig. 5: cycles per test against packet cross-section / cell edge (ratio 4, 8×8)",
            x_label: "jitter (cross-section / cell edge)",
            log_x: true,
            points: [0.01f64, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64, 1.0]
                .iter()
                .map(|&j| {
                    (
                        j,
                        SyntheticParams {
                            jitter: j as f32,
                            ..base
                        },
                    )
                })
                .collect(),
        },
    ];
    for Figure {
        stem,
        title,
        x_label,
        log_x,
        points,
    } in figs
    {
        let curve = synthetic_curve(isa, reps, &points)?;
        write_curve(&args.out, stem, title, x_label, log_x, &curve)?;
        let _ = writeln!(
            summary,
            "## {title}\n\n![{stem}]({stem}.svg) ([CSV]({stem}.csv))\n"
        );
        summary.push_str("| x | Kensler–Shirley | 4-plane | 6-plane + aperture | speedup |\n|---:|---:|---:|---:|---:|\n");
        for (x, c) in &curve {
            let _ = writeln!(
                summary,
                "| {x} | {:.2} | {:.2} | {:.2} | {:.1}× |",
                c[0],
                c[1],
                c[2],
                c[0] / c[2]
            );
        }
        summary.push('\n');
    }

    let size = if args.quick { "256x256" } else { "1024x1024" };
    let sweep_args = match parse(&[
        "sweep",
        &args.scene,
        "--from",
        "0.03",
        "--to",
        "3",
        "--steps",
        if args.quick { "3" } else { "5" },
        "--size",
        size,
    ])? {
        Command::Sweep(a) => a,
        _ => unreachable!("parsed as sweep"),
    };
    let points = sweep::points(&sweep_args)?;
    sweep::write_files(&args.out, "fig7", &args.scene, &points)?;
    let _ = writeln!(
        summary,
        "## Fig. 7: {} primary rays ({size}, one thread): Mrays/s against kd-tree size\n\n![fig7](fig7.svg) ([CSV](fig7.csv))\n\n{}\n",
        args.scene,
        sweep::best_culled_vs_unculled(&points).unwrap_or_default()
    );

    let mut bench_args = vec![
        "bench",
        &args.scene,
        "--threads",
        "1",
        "--packet",
        "1,8,64",
        "--culling",
        "none,auto,6plane/packet",
        "--ci-over-ct",
        "0.03",
        "--size",
        size,
    ];
    if cfg!(feature = "embree") {
        bench_args.push("--embree");
    }
    let bench_args = match parse(&bench_args)? {
        Command::Bench(a) => a,
        _ => unreachable!("parsed as bench"),
    };
    let rows = bench::rows(&bench_args)?;
    let header = [
        "scene",
        "isa",
        "packet",
        "culling",
        "context",
        "mrays_per_s",
    ];
    let table: Vec<Vec<String>> = rows
        .iter()
        .map(|r| {
            vec![
                r.scene.clone(),
                r.isa.clone(),
                r.packet.to_string(),
                r.culling.clone(),
                r.context.unwrap_or("-").to_string(),
                format!("{:.2}", r.mrays_per_s),
            ]
        })
        .collect();
    let path = args.out.join("embree.csv");
    std::fs::write(&path, csv(&header, &table)).map_err(io(&path))?;
    let _ = writeln!(
        summary,
        "## kdbeam against Embree 3 ({} primary rays, {size}, one thread, ci_over_ct 0.03)\n\n([CSV](embree.csv)){}\n\n| isa | packet | culling | Embree context | Mrays/s |\n|---|---:|---|---|---:|",
        args.scene,
        if cfg!(feature = "embree") { "" } else { " — built without `--features embree`: kdbeam rows only" }
    );
    for r in &rows {
        let _ = writeln!(
            summary,
            "| {} | {} | {} | {} | {:.2} |",
            r.isa,
            r.packet,
            r.culling,
            r.context.unwrap_or("-"),
            r.mrays_per_s
        );
    }
    let path = args.out.join("summary.md");
    std::fs::write(&path, summary).map_err(io(&path))?;
    println!("wrote      {}", path.display());
    Ok(())
}

/// The subcommand `argv` names, parsed as the command line would be.
fn parse(argv: &[&str]) -> Result<Command> {
    Cli::try_parse_from(std::iter::once("kdbeam").chain(argv.iter().copied()))
        .map(|cli| cli.command)
        .map_err(|e| Error::invalid("figures", e.to_string()))
}

/// Cycles per test of each culling at each point, on `isa`.
fn synthetic_curve(isa: Isa, reps: usize, points: &[(f64, SyntheticParams)]) -> Result<Curve> {
    let mut hits = Vec::new();
    let mut curve = Vec::new();
    for (x, params) in points {
        let cell = synthetic::generate(params)?;
        let mut cycles = [f64::NAN; 3];
        for (c, (_, culling)) in cycles.iter_mut().zip(CULLINGS) {
            let dispatch = kdbeam::kernels::Dispatch::new(isa)?;
            *c = kdbeam::trace::synthetic::measure(&cell, dispatch, culling, reps, &mut hits)
                .cycles_per_test;
        }
        println!(
            "{x:>8} {:>8.2} {:>8.2} {:>8.2}",
            cycles[0], cycles[1], cycles[2]
        );
        curve.push((*x, cycles));
    }
    Ok(curve)
}

fn write_curve(
    dir: &Path,
    stem: &str,
    title: &str,
    x_label: &str,
    log_x: bool,
    curve: &Curve,
) -> Result<()> {
    let rows: Vec<Vec<String>> = curve
        .iter()
        .map(|(x, c)| {
            vec![
                x.to_string(),
                format!("{:.4}", c[0]),
                format!("{:.4}", c[1]),
                format!("{:.4}", c[2]),
            ]
        })
        .collect();
    let io = |path: PathBuf| move |source| kdbeam::Error::Io { path, source };
    let path = dir.join(format!("{stem}.csv"));
    std::fs::write(
        &path,
        csv(
            &["x", "kensler_shirley", "four_plane", "six_plane_aperture"],
            &rows,
        ),
    )
    .map_err(io(path.clone()))?;
    let plot = LinePlot {
        title: title.to_string(),
        x_label: x_label.to_string(),
        y_label: "TSC cycles per ray–triangle test".into(),
        log_x,
        series: CULLINGS
            .iter()
            .enumerate()
            .map(|(k, (name, _))| Series {
                name: name.to_string(),
                points: curve.iter().map(|(x, c)| (*x, c[k])).collect(),
            })
            .collect(),
    };
    let path = dir.join(format!("{stem}.svg"));
    Ok(std::fs::write(&path, plot.to_svg()).map_err(io(path.clone()))?)
}

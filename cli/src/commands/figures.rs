//! `kdbeam figures --out DIR`: Reshetov's Figs. 3, 4a, 4b and 5 (the synthetic cell, five curves
//! each), Figs. 7–9 (tree-size sweeps on real scenes, masked and maskless), on every vector ISA,
//! and the Embree comparison, as SVG with CSV next to each and a markdown summary.

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
    /// Scenes of the tree-size sweeps, comma separated: Figs. 7, 8, 9, … in this order (the
    /// paper's Fig. 9 is a 10M-triangle statue; `builtin:terrain:2237` has 10M triangles).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "bunny,dragon,builtin:terrain:2237"
    )]
    sweep_scenes: Vec<String>,
    /// Scene of the Embree comparison.
    #[arg(long, default_value = "bunny")]
    scene: String,
    /// ISAs of every figure, comma separated (default: every vector ISA this CPU runs).
    #[arg(long, value_delimiter = ',')]
    isa: Vec<Isa>,
    /// Fewer packets, smaller images and fewer points: a quick look, not a measurement.
    #[arg(long)]
    quick: bool,
}

/// One synthetic curve point: x, then cycles per test for each of [`CULLINGS`].
type Curve = Vec<(f64, [f64; CULLINGS.len()])>;

/// A synthetic figure: file stem, title, x label, log x axis, and the parameters of each point.
struct Figure {
    stem: &'static str,
    title: &'static str,
    x_label: &'static str,
    log_x: bool,
    points: Vec<(f64, SyntheticParams)>,
}

/// Reshetov's five curves of Fig. 3, the baseline first.
const CULLINGS: [(&str, Culling); 5] = [
    ("Kensler–Shirley", Culling::NONE),
    ("4-plane", Culling::planes(Planes::Four, false)),
    ("4-plane + aperture", Culling::planes(Planes::Four, true)),
    ("6-plane", Culling::planes(Planes::Six, false)),
    ("6-plane + aperture", Culling::planes(Planes::Six, true)),
];

/// The synthetic figures: Fig. 3 (leaf edge / triangle edge), Figs. 4a and 4b (packet size at
/// ratio 1 and 4), Fig. 5 (packet cross-section).
fn synthetic_figures(base: SyntheticParams) -> [Figure; 4] {
    let with = |x: f64, params: SyntheticParams| (x, params);
    let packets = |ratio: f32| {
        [2usize, 4, 8, 16]
            .iter()
            .map(|&n| {
                with(
                    n as f64,
                    SyntheticParams {
                        packet_n: n,
                        ratio,
                        ..base
                    },
                )
            })
            .collect()
    };
    [
        Figure {
            stem: "fig3",
            title: "Fig. 3: cycles per test against leaf edge / triangle edge (8×8, jitter 4%)",
            x_label: "leaf edge / triangle edge",
            log_x: false,
            points: (1..=10)
                .map(|r| {
                    with(
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
            stem: "fig4a",
            title: "Fig. 4a: cycles per test against packet size n×n (ratio 1, jitter 4%)",
            x_label: "rays per packet side n",
            log_x: true,
            points: packets(1.0),
        },
        Figure {
            stem: "fig4b",
            title: "Fig. 4b: cycles per test against packet size n×n (ratio 4, jitter 4%)",
            x_label: "rays per packet side n",
            log_x: true,
            points: packets(4.0),
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
                    with(
                        j,
                        SyntheticParams {
                            jitter: j as f32,
                            ..base
                        },
                    )
                })
                .collect(),
        },
    ]
}

pub(crate) fn run(args: FiguresArgs) -> Result<()> {
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| kdbeam::Error::Io { path, source }
    };
    std::fs::create_dir_all(&args.out).map_err(io(&args.out))?;
    let isas: Vec<Isa> = if args.isa.is_empty() {
        Isa::available()
            .filter(|i| !matches!(i, Isa::Scalar | Isa::Portable))
            .collect()
    } else {
        args.isa.clone()
    };
    for &isa in &isas {
        kdbeam::kernels::Dispatch::new(isa)?;
    }
    let isa_list = isas
        .iter()
        .map(|i| i.to_string())
        .collect::<Vec<_>>()
        .join(",");
    let base = SyntheticParams {
        packets: if args.quick { 64 } else { 1024 },
        ..SyntheticParams::default()
    };
    let reps = if args.quick { 3 } else { 9 };
    let mut summary = format!(
        "# kdbeam figures\n\nMade by `kdbeam figures{}` on {isa_list}; cycles are TSC reference \
         cycles per ray–triangle test (median of {reps}); every ratio is against the \
         Kensler–Shirley baseline of the same run.\n\n",
        if args.quick { " --quick" } else { "" }
    );

    for Figure {
        stem,
        title,
        x_label,
        log_x,
        points,
    } in synthetic_figures(base)
    {
        let _ = writeln!(summary, "## {title}\n");
        for &isa in &isas {
            let stem = format!("{stem}-{isa}");
            let title = format!("{title}, {isa}");
            let curve = synthetic_curve(isa, reps, &points)?;
            write_curve(&args.out, &stem, &title, x_label, log_x, &curve)?;
            let _ = writeln!(
                summary,
                "### {isa}\n\n![{stem}]({stem}.svg) ([CSV]({stem}.csv))\n"
            );
            summary.push_str("| x |");
            for (name, _) in CULLINGS {
                let _ = write!(summary, " {name} |");
            }
            summary.push_str(" best speedup |\n|---:|");
            summary.push_str(&"---:|".repeat(CULLINGS.len() + 1));
            summary.push('\n');
            for (x, c) in &curve {
                let _ = write!(summary, "| {x} |");
                for cycles in c {
                    let _ = write!(summary, " {cycles:.2} |");
                }
                let best = c[1..].iter().copied().fold(f64::INFINITY, f64::min);
                let _ = writeln!(summary, " {:.1}× |", c[0] / best);
            }
            summary.push('\n');
        }
    }

    let size = if args.quick { "256x256" } else { "1024x1024" };
    for (k, scene) in args.sweep_scenes.iter().enumerate() {
        let stem = format!("fig{}", 7 + k);
        let sweep_args = match parse(&[
            "sweep",
            scene,
            "--isa",
            &isa_list,
            "--from",
            "0.003",
            "--to",
            "3",
            "--steps",
            if args.quick { "4" } else { "7" },
            "--packet",
            "64",
            "--size",
            size,
        ])? {
            Command::Sweep(a) => a,
            _ => unreachable!("parsed as sweep"),
        };
        let points = sweep::points(&sweep_args)?;
        sweep::write_files(&args.out, &stem, scene, &points)?;
        let _ = writeln!(
            summary,
            "## Fig. {}: {scene} primary rays ({size}, one thread, 8×8 packets): Mrays/s against \
             kd-tree size, masked and maskless, on {isa_list}\n\n![{stem}]({stem}.svg) \
             ([CSV]({stem}.csv))\n",
            7 + k
        );
        for line in sweep::findings(&points) {
            let _ = writeln!(summary, "- {line}");
        }
        summary.push('\n');
    }

    let mut bench_args = vec![
        "bench",
        &args.scene,
        "--threads",
        "1",
        "--isa",
        &isa_list,
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
        let mut cycles = [f64::NAN; CULLINGS.len()];
        for (c, (_, culling)) in cycles.iter_mut().zip(CULLINGS) {
            let dispatch = kdbeam::kernels::Dispatch::new(isa)?;
            *c = kdbeam::trace::synthetic::measure(&cell, dispatch, culling, reps, &mut hits)
                .cycles_per_test;
        }
        println!(
            "{isa:<7} {x:>8} {}",
            cycles
                .iter()
                .map(|c| format!("{c:>8.2}"))
                .collect::<String>()
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
            std::iter::once(x.to_string())
                .chain(c.iter().map(|v| format!("{v:.4}")))
                .collect()
        })
        .collect();
    let io = |path: PathBuf| move |source| kdbeam::Error::Io { path, source };
    let path = dir.join(format!("{stem}.csv"));
    std::fs::write(
        &path,
        csv(
            &[
                "x",
                "kensler_shirley",
                "four_plane",
                "four_plane_aperture",
                "six_plane",
                "six_plane_aperture",
            ],
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

//! `kdbeam synthetic`: cycles per ray–triangle test on Kensler–Shirley synthetic data, per
//! culling setting, next to the unculled baseline of the same run (Reshetov's Figs. 3–5).

use kdbeam::scene::synthetic::{self, SyntheticParams};
use kdbeam::trace::Culling;
use kdbeam::Isa;
use kdbeam_cli::Result;

use super::bench::print_json_or;

#[derive(clap::Args)]
pub(crate) struct SyntheticArgs {
    /// Cell edge over triangle edge, comma separated (1 to 1000; Fig. 3 sweeps 1 to 10).
    #[arg(long, value_delimiter = ',', default_value = "4")]
    ratio: Vec<f32>,
    /// Rays per packet side, comma separated: 2, 4, 8 or 16 (16 × 16 runs as four 8 × 8).
    #[arg(long, value_delimiter = ',', default_value = "8")]
    packet: Vec<usize>,
    /// Packet cross-section over cell edge, comma separated, in (0, 1].
    #[arg(long, value_delimiter = ',', default_value = "0.04")]
    jitter: Vec<f32>,
    /// ISAs to measure, comma separated (default: every one this CPU runs).
    #[arg(long, value_delimiter = ',')]
    isa: Vec<Isa>,
    /// Culling settings measured against the unculled baseline (always measured), comma
    /// separated (see `kdbeam render --help`).
    #[arg(long, value_delimiter = ',', default_value = "4plane,6plane+aperture")]
    culling: Vec<Culling>,
    /// Triangles in the cell.
    #[arg(long, default_value_t = SyntheticParams::default().triangles)]
    triangles: usize,
    /// Packets traced per repetition.
    #[arg(long, default_value_t = SyntheticParams::default().packets)]
    packets: usize,
    /// Largest angle between a triangle's normal and the packets' mean direction, in degrees:
    /// 0 faces every triangle to the packets, 90 orients them uniformly.
    #[arg(long, default_value_t = SyntheticParams::default().normal_cone)]
    normal_cone: f32,
    /// Seed of the triangles and packets.
    #[arg(long, default_value_t = SyntheticParams::default().seed)]
    seed: u64,
    /// Timed repetitions per configuration (the median is reported).
    #[arg(long, default_value_t = 9)]
    reps: usize,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct Row {
    ratio: f32,
    packet: usize,
    jitter: f32,
    isa: String,
    culling: String,
    /// TSC reference cycles per potential ray–triangle test (NaN, JSON `null`, without a TSC).
    cycles_per_test: f64,
    speedup_vs_baseline: f64,
    /// Share of ray–triangle pairs that intersect (all pairs, not closest hits).
    hit_rate: f64,
    eliminated_pct: f64,
}

pub(crate) fn run(args: SyntheticArgs) -> Result<()> {
    let isas: Vec<Isa> = if args.isa.is_empty() {
        Isa::available().collect()
    } else {
        args.isa.clone()
    };
    let base = SyntheticParams {
        triangles: args.triangles,
        packets: args.packets,
        seed: args.seed,
        normal_cone: args.normal_cone,
        ..SyntheticParams::default()
    };
    let (tmax, rate) = synthetic::calibrate_tmax(&base, 0.25)?;
    let base = SyntheticParams { tmax, ..base };
    eprintln!(
        "tmax {tmax}: {:.1}% of ray–triangle pairs intersect at ratio 1 (RT06 aims at 25%); \
         cycles are TSC reference cycles",
        100.0 * rate
    );
    if !args.json {
        println!(
            "{:>5} {:>6} {:>6} {:<8} {:<26} {:>12} {:>8} {:>8} {:>11}",
            "ratio",
            "packet",
            "jitter",
            "isa",
            "culling",
            "cycles/test",
            "speedup",
            "hit%",
            "eliminated%"
        );
    }
    let mut hits = Vec::new();
    for &ratio in &args.ratio {
        for &packet_n in &args.packet {
            for &jitter in &args.jitter {
                let params = SyntheticParams {
                    ratio,
                    packet_n,
                    jitter,
                    ..base
                };
                let cell = synthetic::generate(&params)?;
                let hit_rate = synthetic::hit_rate(&cell);
                for &isa in &isas {
                    let measure = |c: Culling, hits: &mut Vec<_>| {
                        let dispatch = kdbeam::kernels::Dispatch::new(isa)?;
                        Ok::<_, kdbeam::Error>(kdbeam::trace::synthetic::measure(
                            &cell, dispatch, c, args.reps, hits,
                        ))
                    };
                    let baseline = measure(Culling::NONE, &mut hits)?;
                    // The baseline's row once, even when `--culling` names `none` too.
                    let settings = args.culling.iter().copied().filter(|&c| c != Culling::NONE);
                    for c in std::iter::once(Culling::NONE).chain(settings) {
                        let m = if c == Culling::NONE {
                            baseline
                        } else {
                            measure(c, &mut hits)?
                        };
                        let row = Row {
                            ratio,
                            packet: packet_n,
                            jitter,
                            isa: isa.to_string(),
                            culling: c.name(),
                            cycles_per_test: m.cycles_per_test,
                            speedup_vs_baseline: baseline.cycles_per_test / m.cycles_per_test,
                            hit_rate,
                            eliminated_pct: m.eliminated_percent(),
                        };
                        print_row(&row, args.json);
                    }
                }
            }
        }
    }
    Ok(())
}

fn print_row(r: &Row, json: bool) {
    print_json_or(r, json, || {
        format!(
            "{:>5} {:>6} {:>5.1}% {:<8} {:<26} {:>12.3} {:>7.2}x {:>7.1}% {:>10.1}%",
            r.ratio,
            format!("{0}x{0}", r.packet),
            100.0 * r.jitter,
            r.isa,
            r.culling,
            r.cycles_per_test,
            r.speedup_vs_baseline,
            100.0 * r.hit_rate,
            r.eliminated_pct
        )
    })
}

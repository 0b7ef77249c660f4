//! `kdbeam accuracy`: run time against error for every intersector × ISA × culling mode.

use std::path::{Path, PathBuf};

use kdbeam::{BuildParams, Intersector, Isa, KdTree, PacketShape, Tracer};
use kdbeam_cli::render::RaySet;
use kdbeam_cli::report::accuracy::{reference_hits, Measurement, Workload, CULLINGS};
use kdbeam_cli::report::{csv, LinePlot, Series};
use kdbeam_cli::Result;

use super::bench::print_json_or;
use super::{load_scene, thread_pool, with_spinner};

#[derive(clap::Args)]
pub(crate) struct AccuracyArgs {
    /// Scenes: paths, shared scene names or builtin:NAME (default: builtin:default and, when
    /// found, bunny, sponza and dragon).
    scenes: Vec<String>,
    /// Image size of the primary rays (and W·H random rays), WIDTHxHEIGHT.
    #[arg(long, default_value = "512x512", value_parser = super::parse_size)]
    size: (u32, u32),
    /// Ray sets, comma separated: primary, random (slower: incoherent packets), and the
    /// secondary rays of the primary hits: shadow, ao, diffuse.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "primary")]
    rays: Vec<RaySet>,
    /// Ambient-occlusion rays per primary hit (`--rays ao`).
    #[arg(long, default_value_t = kdbeam::rays::secondary::DEFAULT_AO_RAYS, value_parser = clap::value_parser!(u32).range(1..=64))]
    ao_rays: u32,
    /// ISAs to measure, comma separated (default: every one this CPU runs).
    #[arg(long, value_delimiter = ',')]
    isa: Vec<Isa>,
    /// Timed repetitions per configuration, on one thread (the median is reported).
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// One JSON object per line instead of a table.
    #[arg(long)]
    json: bool,
    /// Folder for accuracy.csv and accuracy.svg (default: no files).
    #[arg(long)]
    out: Option<PathBuf>,
}

#[derive(serde::Serialize)]
struct Row {
    scene: String,
    rays: &'static str,
    intersector: &'static str,
    isa: String,
    culling: String,
    ns_per_ray: f64,
    disagreements: u64,
    wrong_ids: u64,
    ties: u64,
    t_rel_err_median: f64,
    t_rel_err_p99: f64,
    t_rel_err_max: f64,
    #[serde(skip)]
    disagreements_per_million: f64,
}

impl Row {
    fn new(scene: &str, set: RaySet, tracer: &Tracer<'_>, m: &Measurement) -> Row {
        let a = &m.accuracy;
        Row {
            scene: scene.to_string(),
            rays: set.name(),
            intersector: tracer.intersector().name(),
            isa: tracer.isa().to_string(),
            culling: tracer.culling().name(),
            ns_per_ray: m.ns_per_ray,
            disagreements: a.disagreements,
            wrong_ids: a.wrong_ids,
            ties: a.ties,
            t_rel_err_median: a.t_rel_err_median,
            t_rel_err_p99: a.t_rel_err_p99,
            t_rel_err_max: a.t_rel_err_max,
            disagreements_per_million: a.disagreements_per_million(),
        }
    }

    fn fields(&self) -> Vec<String> {
        vec![
            self.scene.clone(),
            self.rays.to_string(),
            self.intersector.to_string(),
            self.isa.clone(),
            self.culling.clone(),
            format!("{:.2}", self.ns_per_ray),
            self.disagreements.to_string(),
            self.wrong_ids.to_string(),
            self.ties.to_string(),
            format!("{:.3e}", self.t_rel_err_median),
            format!("{:.3e}", self.t_rel_err_p99),
            format!("{:.3e}", self.t_rel_err_max),
        ]
    }
}

const HEADER: [&str; 12] = [
    "scene",
    "rays",
    "intersector",
    "isa",
    "culling",
    "ns_per_ray",
    "disagreements",
    "wrong_ids",
    "ties",
    "t_rel_err_median",
    "t_rel_err_p99",
    "t_rel_err_max",
];

/// The default scenes: the built-in default scene and the shared scenes that are present.
fn default_scenes() -> Vec<Option<String>> {
    let mut out = vec![None];
    for name in ["bunny", "sponza", "dragon"] {
        if kdbeam_cli::scenes::shared_scene(name).is_some_and(|p| p.is_file()) {
            out.push(Some(name.to_string()));
        }
    }
    out
}

pub(crate) fn run(args: AccuracyArgs) -> Result<()> {
    let pool = thread_pool(Some(1))?;
    let isas: Vec<Isa> = if args.isa.is_empty() {
        Isa::available().collect()
    } else {
        let checked = args
            .isa
            .iter()
            .map(|&isa| Ok(kdbeam::kernels::Dispatch::new(isa)?.isa()));
        checked.collect::<kdbeam::Result<_>>()?
    };
    let scenes = if args.scenes.is_empty() {
        default_scenes()
    } else {
        args.scenes.iter().cloned().map(Some).collect()
    };
    if !args.json {
        println!(
            "{:<16} {:<7} {:<15} {:<8} {:<24} {:>8} {:>7} {:>7} {:>6} {:>9} {:>9} {:>9}",
            "scene",
            "rays",
            "intersector",
            "isa",
            "culling",
            "ns/ray",
            "disagr",
            "wrongid",
            "ties",
            "t med",
            "t p99",
            "t max"
        );
    }
    let mut rows = Vec::new();
    for scene in scenes {
        let (name, mesh) = with_spinner("loading scene", || load_scene(scene.as_deref()))?;
        let tree = with_spinner("building kd-tree", || {
            KdTree::build(&mesh, &BuildParams::default())
        })?;
        for &set in &args.rays {
            let work = Workload::new(set, &mesh, &tree, args.size.0, args.size.1, args.ao_rays)?;
            let reference =
                with_spinner("f64 oracle reference", || reference_hits(&tree, &work.rays));
            for intersector in Intersector::ALL {
                for &isa in &isas {
                    for culling in CULLINGS {
                        let tracer = Tracer::new(&tree)
                            .with_intersector(intersector)
                            .with_isa(isa)?
                            .with_packet(PacketShape::P8x8)
                            .with_culling(culling);
                        let m =
                            pool.install(|| work.measure(&tracer, &mesh, &reference, args.reps))?;
                        let row = Row::new(&name, set, &tracer, &m);
                        print_json_or(&row, args.json, || table_line(&row));
                        rows.push(row);
                    }
                }
            }
        }
    }
    if let Some(dir) = &args.out {
        write_files(dir, &rows)?;
    }
    Ok(())
}

fn table_line(r: &Row) -> String {
    format!(
        "{:<16} {:<7} {:<15} {:<8} {:<24} {:>8.1} {:>7} {:>7} {:>6} {:>9.2e} {:>9.2e} {:>9.2e}",
        r.scene,
        r.rays,
        r.intersector,
        r.isa,
        r.culling,
        r.ns_per_ray,
        r.disagreements,
        r.wrong_ids,
        r.ties,
        r.t_rel_err_median,
        r.t_rel_err_p99,
        r.t_rel_err_max
    )
}

/// accuracy.csv, and two plots of ns per ray against error: disagreements per million rays
/// (accuracy.svg) and the p99 relative `t` error in units of 1e-7, as the plot prints 3
/// decimals (accuracy_t.svg), one series per scene, ray
/// set and intersector, its points sorted by run time.
fn write_files(dir: &Path, rows: &[Row]) -> Result<()> {
    let io = |path: PathBuf| move |source| kdbeam::Error::Io { path, source };
    std::fs::create_dir_all(dir).map_err(io(dir.to_path_buf()))?;
    let csv_path = dir.join("accuracy.csv");
    let fields: Vec<Vec<String>> = rows.iter().map(Row::fields).collect();
    std::fs::write(&csv_path, csv(&HEADER, &fields)).map_err(io(csv_path.clone()))?;
    eprintln!("wrote      {}", csv_path.display());
    type Metric = fn(&Row) -> f64;
    let plots: [(&str, &str, Metric); 2] = [
        (
            "accuracy.svg",
            "hit/miss disagreements per million rays",
            |r| r.disagreements_per_million,
        ),
        ("accuracy_t.svg", "p99 relative t error", |r| {
            r.t_rel_err_p99
        }),
    ];
    for (file, y_label, metric) in plots {
        let mut series: Vec<Series> = Vec::new();
        for r in rows {
            let name = format!("{} {} {}", r.scene, r.rays, r.intersector);
            let point = (r.ns_per_ray, metric(r));
            match series.iter_mut().find(|s| s.name == name) {
                Some(s) => s.points.push(point),
                None => series.push(Series {
                    name,
                    points: vec![point],
                }),
            }
        }
        for s in &mut series {
            s.points.sort_by(|a, b| a.0.total_cmp(&b.0));
        }
        let plot = LinePlot {
            title: format!("Run time against error ({y_label})"),
            x_label: "ns per ray (one thread)".into(),
            y_label: y_label.into(),
            log_x: true,
            series,
        };
        let path = dir.join(file);
        std::fs::write(&path, plot.to_svg()).map_err(io(path.clone()))?;
        eprintln!("wrote      {}", path.display());
    }
    Ok(())
}

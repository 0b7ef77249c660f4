//! Line plots of the figures, drawn as SVG by plotters (its SVG backend, no font library: the
//! labels stay SVG text, set by the viewer's sans-serif font).

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

/// One named line of `(x, y)` points.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points, in drawing order. Non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
}

/// A line plot with a linear or logarithmic x axis and a linear y axis starting at 0.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePlot {
    /// Title above the plot.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Logarithmic x axis (points with x ≤ 0 are skipped).
    pub log_x: bool,
    /// The lines.
    pub series: Vec<Series>,
}

const SIZE: (u32, u32) = (760, 460);

/// Line colours, in series order (matplotlib's first eight, distinct in print and on screen).
const COLORS: [RGBColor; 8] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0xe3, 0x77, 0xc2),
    RGBColor(0x17, 0xbe, 0xcf),
];

impl LinePlot {
    /// The plot as an SVG document. An empty plot (no drawable point) draws only the axes.
    pub fn to_svg(&self) -> String {
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
            // Drawing into a String cannot fail: the backend's only errors are I/O errors.
            let _ = self.draw(&root);
        }
        svg
    }

    /// The drawable points of `series`: finite, and x > 0 on a logarithmic axis.
    fn points<'a>(&self, series: &'a Series) -> impl Iterator<Item = (f64, f64)> + 'a {
        let log_x = self.log_x;
        series
            .points
            .iter()
            .copied()
            .filter(move |&(x, y)| x.is_finite() && y.is_finite() && (!log_x || x > 0.0))
    }

    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
        root.fill(&WHITE)?;
        let all: Vec<(f64, f64)> = self.series.iter().flat_map(|s| self.points(s)).collect();
        let (x0, x1) = all
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.0), b.max(p.0))
            });
        let (x0, x1) = match (x0 < x1, self.log_x) {
            (true, _) => (x0, x1),
            (false, true) if x0.is_finite() => (x0 / 2.0, x0 * 2.0),
            (false, false) if x0.is_finite() => (x0 - 1.0, x0 + 1.0),
            (false, true) => (0.1, 10.0),
            (false, false) => (0.0, 1.0),
        };
        let y1 = all.iter().fold(0.0f64, |a, p| a.max(p.1)) * 1.08;
        let y1 = if y1 > 0.0 { y1 } else { 1.0 };
        if self.log_x {
            let ticks = log_ticks(x0, x1);
            self.draw_on(root, (x0..x1).log_scale().with_key_points(ticks), y1)
        } else {
            self.draw_on(root, x0..x1, y1)
        }
    }

    fn draw_on<DB: DrawingBackend, X>(
        &self,
        root: &DrawingArea<DB, plotters::coord::Shift>,
        x: X,
        y1: f64,
    ) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
    where
        X: AsRangedCoord<Value = f64>,
        X::CoordDescType: ValueFormatter<f64>,
    {
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, ("sans-serif", 17))
            .margin(12)
            .x_label_area_size(42)
            .y_label_area_size(64)
            .build_cartesian_2d(x, 0.0..y1)?;
        chart
            .configure_mesh()
            .x_desc(&self.x_label)
            .y_desc(&self.y_label)
            .label_style(("sans-serif", 13))
            .x_label_formatter(&|x| format_tick(*x))
            .y_label_formatter(&|y| format_tick(*y))
            .light_line_style(WHITE.mix(0.0))
            .draw()?;
        for (k, series) in self.series.iter().enumerate() {
            let color = COLORS[k % COLORS.len()];
            let points: Vec<(f64, f64)> = self.points(series).collect();
            chart
                .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))?
                .label(&series.name)
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart.draw_series(
                points
                    .into_iter()
                    .map(|p| Circle::new(p, 3, color.filled())),
            )?;
        }
        if !self.series.is_empty() {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::MiddleRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.4))
                .label_font(("sans-serif", 13))
                .draw()?;
        }
        root.present()
    }
}

/// Ticks of a logarithmic axis over `[x0, x1]`: 1, 2 and 5 times each power of ten in it
/// (plotters' own log axis labels only the powers of ten, which leaves a sweep from 0.03 to 3
/// with two labels).
fn log_ticks(x0: f64, x1: f64) -> Vec<f64> {
    let mut ticks = Vec::new();
    let mut decade = 10f64.powf(x0.log10().floor());
    while decade <= x1 {
        for m in [1.0, 2.0, 5.0] {
            let t = decade * m;
            if (x0..=x1).contains(&t) {
                ticks.push(t);
            }
        }
        decade *= 10.0;
    }
    ticks
}

/// A tick label: at most six significant decimals, no trailing zeros (`2`, `0.25`, `1.5`).
fn format_tick(v: f64) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".into()
    } else {
        s.into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn svg_has_one_line_per_series_labels_as_text_and_skips_bad_points() {
        let p = LinePlot {
            title: "a < b".into(),
            x_label: "leaf edge / triangle edge".into(),
            y_label: "Mrays/s".into(),
            log_x: true,
            series: vec![
                Series {
                    name: "one".into(),
                    points: vec![(0.1, 1.0), (1.0, 2.0), (10.0, f64::NAN)],
                },
                Series {
                    name: "two".into(),
                    points: vec![(0.0, 5.0), (1.0, 3.0)],
                },
            ],
        };
        let svg = p.to_svg();
        assert!(svg.starts_with("<svg"), "{svg}");
        // Each series' colour strokes its line and its legend entry.
        for color in ["#1F77B4", "#D62728"] {
            let strokes = svg.matches(&format!("stroke=\"{color}\"")).count();
            assert_eq!(strokes, 2, "{color} in {svg}");
        }
        assert_eq!(
            svg.matches("<circle").count(),
            3,
            "NaN and x <= 0 on a log axis are skipped"
        );
        // Plotters writes each label as the text of its own element, on a line of its own.
        for text in [
            "a &lt; b",
            "leaf edge / triangle edge",
            "Mrays/s",
            "one",
            "two",
        ] {
            assert!(svg.contains(&format!("\n{text}\n")), "no {text:?} in {svg}");
        }
        assert!(!svg.contains("NaN"));
    }

    #[test]
    fn log_ticks_are_one_two_five_per_decade_inside_the_range() {
        let ticks: Vec<String> = log_ticks(0.03, 3.0).into_iter().map(format_tick).collect();
        assert_eq!(ticks, ["0.05", "0.1", "0.2", "0.5", "1", "2"]);
        assert_eq!(log_ticks(1.0, 1.0), [1.0]);
    }

    #[test]
    fn an_empty_plot_still_draws_its_axes() {
        let p = LinePlot {
            title: "empty".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            log_x: false,
            series: vec![],
        };
        let svg = p.to_svg();
        assert!(
            svg.contains("\nempty\n") && svg.contains("<polyline"),
            "{svg}"
        );
    }

    #[test]
    fn ticks_are_short() {
        assert_eq!(format_tick(2.0), "2");
        assert_eq!(format_tick(0.25), "0.25");
        assert_eq!(format_tick(25.181_000_000_1), "25.181");
        assert_eq!(format_tick(-0.0), "0");
    }
}

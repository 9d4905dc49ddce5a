//! Line and scatter charts as PNG files (headless, pure Rust, with a vendored DejaVu Sans font),
//! for the validation and performance reports.

use std::path::Path;

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::register_font;

use tetfem::base::error::{Error, Result};

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// Registers the vendored font as "sans-serif" (idempotent): for charts drawn outside
/// [`Chart`], such as the stability map.
pub fn register() {
    let _ = register_font("sans-serif", FontStyle::Normal, FONT);
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// Straight segments between consecutive points.
    Line,
    /// Dashed segments (for reference or theory lines).
    Dashed,
    /// Filled circles only.
    Points,
    /// Segments and circles.
    LinePoints,
}

/// One named series of (x, y) points.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    /// Legend text.
    pub label: String,
    /// The points, in drawing order.
    pub points: Vec<(f64, f64)>,
    /// How to draw them.
    pub mark: Mark,
}

impl Series {
    /// A series from label, points and mark.
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>, mark: Mark) -> Self {
        Series {
            label: label.into(),
            points,
            mark,
        }
    }
}

/// A chart: title, axis labels (with units), linear or logarithmic axes, series.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// x-axis label, with units.
    pub x_label: String,
    /// y-axis label, with units.
    pub y_label: String,
    /// Logarithmic x axis.
    pub log_x: bool,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// The data.
    pub series: Vec<Series>,
}

/// The series' colours in order (matplotlib's "tab10"): ten before a colour comes again.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

impl Chart {
    /// Writes the chart as a `width`×`height` PNG, atomically (temporary file, then rename).
    /// Points that cannot be drawn (non-finite, or ≤ 0 on a log axis) are skipped.
    pub fn write_png(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        register();
        let mut temporary = path.as_os_str().to_owned();
        temporary.push(format!(".tmp-{}.png", std::process::id()));
        let temporary = std::path::PathBuf::from(temporary);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| Error::Io {
                path: dir.to_path_buf(),
                source,
            })?;
        }
        let drawn = self.draw(&temporary, width, height);
        let result = drawn.and_then(|()| {
            std::fs::rename(&temporary, path).map_err(|source| Error::Io {
                path: path.to_path_buf(),
                source,
            })
        });
        if result.is_err() {
            let _ = std::fs::remove_file(&temporary);
        }
        result
    }

    fn visible(&self, (x, y): (f64, f64)) -> bool {
        x.is_finite() && y.is_finite() && (!self.log_x || x > 0.0) && (!self.log_y || y > 0.0)
    }

    fn range(&self, axis: usize, log: bool) -> (f64, f64) {
        let values = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&p| self.visible(p))
            .map(|p| if axis == 0 { p.0 } else { p.1 });
        let (lo, hi) = values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
        if !lo.is_finite() {
            return if log { (0.1, 10.0) } else { (0.0, 1.0) };
        }
        if log {
            let (lo, hi) = if lo == hi {
                (lo / 2.0, hi * 2.0)
            } else {
                (lo, hi)
            };
            (lo / 1.3, hi * 1.3)
        } else {
            let pad = if hi > lo {
                0.05 * (hi - lo)
            } else {
                lo.abs().max(1.0) * 0.1
            };
            (lo - pad, hi + pad)
        }
    }

    /// Where the legend goes so that it hides no data, and the y range that makes room for it.
    ///
    /// The legend box is estimated in pixels (14 px text, about 7.5 px per character, 18 px per
    /// row) as a fraction of the plot area; the corner whose box holds the fewest points wins
    /// (upper left on a tie). If every corner would cover a point, the y range grows at the top
    /// by the legend's height, so the upper left corner is empty by construction.
    fn legend_placement(
        &self,
        (width, height): (u32, u32),
        (x0, x1): (f64, f64),
        (y0, y1): (f64, f64),
    ) -> (SeriesLabelPosition, f64) {
        let plot_width = (f64::from(width) - 80.0 - 28.0).max(1.0);
        let plot_height = (f64::from(height) - 48.0 - 28.0 - 36.0).max(1.0);
        let longest = self
            .series
            .iter()
            .map(|s| s.label.chars().count())
            .max()
            .unwrap_or(0) as f64;
        // Box size plus the gap plotters leaves to the plot's edge, with 10 % to spare.
        let box_width = (1.1 * (48.0 + 7.5 * longest + 10.0) / plot_width).min(1.0);
        let box_height = (1.1 * (18.0 * self.series.len() as f64 + 20.0) / plot_height).min(0.9);
        let fraction = |v: f64, (lo, hi): (f64, f64), log: bool| {
            if log {
                (v.ln() - lo.ln()) / (hi.ln() - lo.ln())
            } else {
                (v - lo) / (hi - lo)
            }
        };
        let points: Vec<(f64, f64)> = self
            .series
            .iter()
            .flat_map(|s| s.points.iter().copied())
            .filter(|&p| self.visible(p))
            .map(|(x, y)| {
                (
                    fraction(x, (x0, x1), self.log_x),
                    fraction(y, (y0, y1), self.log_y),
                )
            })
            .collect();
        let covered = |left: bool, upper: bool| {
            points
                .iter()
                .filter(|&&(x, y)| {
                    let in_x = if left {
                        x <= box_width
                    } else {
                        x >= 1.0 - box_width
                    };
                    let in_y = if upper {
                        y >= 1.0 - box_height
                    } else {
                        y <= box_height
                    };
                    in_x && in_y
                })
                .count()
        };
        let corners = [
            (SeriesLabelPosition::UpperLeft, covered(true, true)),
            (SeriesLabelPosition::UpperRight, covered(false, true)),
            (SeriesLabelPosition::LowerLeft, covered(true, false)),
            (SeriesLabelPosition::LowerRight, covered(false, false)),
        ];
        if let Some((position, _)) = corners.iter().find(|(_, count)| *count == 0) {
            return (position.clone(), y1);
        }
        // Data now span the lower (1 − box_height) of the new range.
        let grown = if self.log_y {
            (y0.ln() + (y1.ln() - y0.ln()) / (1.0 - box_height)).exp()
        } else {
            y0 + (y1 - y0) / (1.0 - box_height)
        };
        (SeriesLabelPosition::UpperLeft, grown)
    }

    fn draw(&self, path: &Path, width: u32, height: u32) -> Result<()> {
        let fail = |e: String| Error::Io {
            path: path.to_path_buf(),
            source: std::io::Error::other(e),
        };
        let root = BitMapBackend::new(path, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| fail(e.to_string()))?;
        let (x0, x1) = self.range(0, self.log_x);
        let (y0, y1) = self.range(1, self.log_y);
        let (legend_position, y1) = self.legend_placement((width, height), (x0, x1), (y0, y1));
        let mut builder = ChartBuilder::on(&root);
        builder
            .caption(&self.title, ("sans-serif", 22))
            .margin(14)
            .x_label_area_size(48)
            .y_label_area_size(80);
        macro_rules! render {
            ($chart:expr) => {{
                let mut chart = $chart.map_err(|e| fail(e.to_string()))?;
                chart
                    .configure_mesh()
                    .x_desc(&self.x_label)
                    .y_desc(&self.y_label)
                    .x_labels(20)
                    .y_labels(20)
                    .label_style(("sans-serif", 14))
                    .axis_desc_style(("sans-serif", 16))
                    .x_label_formatter(&|v| format_tick(*v, self.log_x, (x0, x1)))
                    .y_label_formatter(&|v| format_tick(*v, self.log_y, (y0, y1)))
                    .draw()
                    .map_err(|e| fail(e.to_string()))?;
                for (k, series) in self.series.iter().enumerate() {
                    let color = PALETTE[k % PALETTE.len()];
                    let points: Vec<(f64, f64)> = series
                        .points
                        .iter()
                        .copied()
                        .filter(|&p| self.visible(p))
                        .collect();
                    let legend_style = color.stroke_width(2);
                    let anno = match series.mark {
                        Mark::Line | Mark::LinePoints => chart
                            .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))
                            .map_err(|e| fail(e.to_string()))?,
                        Mark::Dashed => chart
                            .draw_series(DashedLineSeries::new(
                                points.clone(),
                                8,
                                6,
                                color.stroke_width(2),
                            ))
                            .map_err(|e| fail(e.to_string()))?,
                        Mark::Points => chart
                            .draw_series(points.iter().map(|&p| Circle::new(p, 4, color.filled())))
                            .map_err(|e| fail(e.to_string()))?,
                    };
                    // The legend shows the series' own mark: a dot for points, a line else.
                    let dots = series.mark == Mark::Points;
                    anno.label(series.label.clone()).legend(move |(x, y)| {
                        // Relative to (x, y): a dot of radius 4 and no line, or a line alone.
                        let (radius, end) = if dots { (4, 10) } else { (0, 20) };
                        let start = if dots { 10 } else { 0 };
                        EmptyElement::at((x, y))
                            + Circle::new((10, 0), radius, color.filled())
                            + PathElement::new(vec![(start, 0), (end, 0)], legend_style)
                    });
                    if series.mark == Mark::LinePoints {
                        chart
                            .draw_series(points.iter().map(|&p| Circle::new(p, 3, color.filled())))
                            .map_err(|e| fail(e.to_string()))?;
                    }
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .label_font(("sans-serif", 14))
                    .position(legend_position.clone())
                    .draw()
                    .map_err(|e| fail(e.to_string()))?;
            }};
        }
        // plotters labels a log axis only from its first power of ten on, which leaves a
        // narrow range (say 2.3 … 110) with one label; our own ticks label 2 and 5 as well.
        let log_axis = |lo: f64, hi: f64| {
            let (bold, light) = log_ticks(lo, hi);
            (lo..hi)
                .log_scale()
                .with_key_points(bold)
                .with_light_points(light)
        };
        match (self.log_x, self.log_y) {
            (true, true) => render!(builder.build_cartesian_2d(log_axis(x0, x1), log_axis(y0, y1))),
            (true, false) => render!(builder.build_cartesian_2d(log_axis(x0, x1), y0..y1)),
            (false, true) => render!(builder.build_cartesian_2d(x0..x1, log_axis(y0, y1))),
            (false, false) => render!(
                builder.build_cartesian_2d::<RangedCoordf64, RangedCoordf64>(
                    (x0..x1).into(),
                    (y0..y1).into()
                )
            ),
        }
        root.present().map_err(|e| fail(e.to_string()))
    }
}

/// Ticks of a log axis over `lo … hi`: bold (labelled) at 1, 2 and 5 times each power of ten
/// when the axis spans at most three decades, else at the powers of ten alone; light at every
/// integer multiple of a power of ten.
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    let few_decades = hi / lo <= 1e3;
    let (mut bold, mut light) = (Vec::new(), Vec::new());
    for exponent in (lo.log10().floor() as i32)..=(hi.log10().ceil() as i32) {
        for mantissa in 1..=9 {
            let v = f64::from(mantissa) * 10f64.powi(exponent);
            if v < lo || v > hi {
                continue;
            }
            light.push(v);
            if mantissa == 1 || (few_decades && (mantissa == 2 || mantissa == 5)) {
                bold.push(v);
            }
        }
    }
    (bold, light)
}

/// Compact tick labels, one notation per axis: plain numbers when the axis `range` lies within
/// 1e-3 … 1e5, scientific notation for every tick otherwise (so "0.01" never sits beside
/// "1e-4"); on a log axis only 1, 2 and 5 times a power of ten are labelled, so labels never
/// collide.
fn format_tick(v: f64, log: bool, (lo, hi): (f64, f64)) -> String {
    let a = v.abs();
    if log && a > 0.0 {
        let mantissa = a / 10f64.powf(a.log10().floor());
        if ![1.0, 2.0, 5.0]
            .iter()
            .any(|m| (mantissa - m).abs() < 1e-6 * m)
        {
            return String::new();
        }
    }
    let plain = |x: f64| x == 0.0 || (1e-3..1e5).contains(&x.abs());
    if a == 0.0 {
        "0".into()
    } else if plain(lo) && plain(hi) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else if log {
        // The mantissa is 1, 2 or 5 here, so no digit is lost.
        format!("{v:.0e}")
    } else {
        format!("{v:.1e}")
    }
}

//! SVG line plots for reports, in the manner of the paper's figures: panels of x–y series, each
//! solid, dashed or dotted, optionally with a logarithmic y axis (Figure 2 of the paper).
//!
//! This is the one module that sees plotters. SVG needs no system font library (plotters' default
//! features, which pull in font-kit, stay off), so text is laid out with plotters' naive metrics
//! and drawn by the SVG viewer.

use crate::error::{Error, Result};
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;
use std::path::Path;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// A continuous line.
    #[default]
    Solid,
    /// Dashes (the paper's down-sweeps).
    Dashed,
    /// Dots (the paper's locked-rotor references).
    Dotted,
    /// A filled circle at each point and no line (cases of a design study drawn at random).
    Points,
}

/// One curve: points `(x[i], y[i])`, a legend label, a colour index into a fixed palette and a
/// line style. Non-finite points (and, on a log axis, non-positive `y`) are skipped.
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Legend text (empty: no legend entry).
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
    /// Index into the palette (same index, same colour across panels).
    pub color: usize,
    /// Line style.
    pub style: LineStyle,
}

/// One set of axes.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// Title above the axes.
    pub title: String,
    /// x-axis label (with units).
    pub x_label: String,
    /// y-axis label (with units).
    pub y_label: String,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Fixed x range; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data (with a margin).
    pub y_range: Option<(f64, f64)>,
    /// Vertical reference lines (e.g. n_t, n_r), each with a label.
    pub markers: Vec<(f64, String)>,
    /// The curves.
    pub series: Vec<Series>,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Writes `panels` side by side (one row) to an SVG file of `width`×`height` pixels per panel.
pub fn write_svg(path: &Path, panels: &[Panel], width: u32, height: u32) -> Result<()> {
    let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        let cols = panels.len().max(1) as u32;
        let root = SVGBackend::new(path, (width * cols, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, cols as usize));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            draw_panel(panel, area)?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| plot_error(path, e))
}

/// A drawing error as the I/O error of the plot file it was writing.
fn plot_error(path: &Path, e: Box<dyn std::error::Error>) -> Error {
    Error::Io { file: path.to_path_buf(), action: "cannot write plot", source: std::io::Error::other(e.to_string()) }
}

fn keep(log_y: bool) -> impl Fn(&(f64, f64)) -> bool {
    move |&(x, y)| x.is_finite() && y.is_finite() && (!log_y || y > 0.0)
}

fn data_range(panel: &Panel) -> ((f64, f64), (f64, f64)) {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for s in &panel.series {
        for p in s.x.iter().copied().zip(s.y.iter().copied()).filter(keep(panel.log_y)) {
            x0 = x0.min(p.0);
            x1 = x1.max(p.0);
            y0 = y0.min(p.1);
            y1 = y1.max(p.1);
        }
    }
    if !x0.is_finite() {
        (x0, x1) = (0.0, 1.0);
    }
    if !y0.is_finite() {
        (y0, y1) = if panel.log_y { (0.1, 1.0) } else { (0.0, 1.0) };
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    // A margin so curves do not run along the frame.
    if panel.log_y {
        if y1 <= y0 {
            y1 = y0 * 10.0;
        }
        let f = (y1 / y0).powf(0.05);
        (y0, y1) = (y0 / f, y1 * f);
    } else {
        if y1 <= y0 {
            y1 = y0 + 1.0;
        }
        let d = 0.05 * (y1 - y0);
        (y0, y1) = (y0 - d, y1 + d);
    }
    (panel.x_range.unwrap_or((x0, x1)), panel.y_range.unwrap_or((y0, y1)))
}

/// A tick label: at most four significant digits, exponent form only for very large or small values
/// (plotters prints log-axis ticks as `9.999999999999999e-6` otherwise).
fn tick(v: f64) -> String {
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.0e}")
    } else {
        let s = format!("{:.*}", (3 - a.log10().floor() as i32).clamp(0, 6) as usize, v);
        if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
    }
}

type DynResult = std::result::Result<(), Box<dyn std::error::Error>>;

fn draw_panel(panel: &Panel, area: &DrawingArea<SVGBackend, plotters::coord::Shift>) -> DynResult {
    let ((x0, x1), (y0, y1)) = data_range(panel);
    let mut builder = ChartBuilder::on(area);
    builder.caption(&panel.title, ("sans-serif", 18)).margin(12).x_label_area_size(40).y_label_area_size(70);
    // The two branches differ only in the y coordinate type; everything drawn is generic over it.
    let (w, h) = area.dim_in_pixel();
    let corner = legend_corner(panel, ((x0, x1), (y0, y1)), legend_size(panel, w, h));
    if panel.log_y {
        let mut chart = builder.build_cartesian_2d(x0..x1, (y0..y1).log_scale())?;
        fill(&mut chart, panel, y0, y1, corner)
    } else {
        let mut chart = builder.build_cartesian_2d(x0..x1, y0..y1)?;
        fill(&mut chart, panel, y0, y1, corner)
    }
}

/// The legend box as fractions of the plotting area (width, height), estimated from the label
/// lengths and the entry count for a panel of w × h pixels (the fonts' sizes, the label and
/// caption areas of [`draw_panel`]).
fn legend_size(panel: &Panel, w: u32, h: u32) -> (f64, f64) {
    let labels: Vec<&Series> = panel.series.iter().filter(|s| !s.label.is_empty()).collect();
    let chars = labels.iter().map(|s| s.label.chars().count()).max().unwrap_or(0) as f64;
    let (plot_w, plot_h) = ((w as f64 - 100.0).max(1.0), (h as f64 - 100.0).max(1.0));
    ((7.0 * chars + 45.0) / plot_w, (22.0 * labels.len() as f64 + 16.0) / plot_h)
}

/// The place for the legend (the four corners, then the middles of the four edges) where the
/// least curve length falls under its box (`size`: fractions of the plotting area), upper right
/// first on ties: the legend used to sit upper right always and hid the rising resonance curves
/// there.
fn legend_corner(
    panel: &Panel,
    ((x0, x1), (y0, y1)): ((f64, f64), (f64, f64)),
    size: (f64, f64),
) -> SeriesLabelPosition {
    use SeriesLabelPosition as P;
    let fy = |y: f64| if panel.log_y { (y / y0).ln() / (y1 / y0).ln() } else { (y - y0) / (y1 - y0) };
    // Where the box sits along each axis: 0 at the low end, 1 centred, 2 at the high end.
    let places = [
        (P::UpperRight, 2, 2),
        (P::UpperLeft, 0, 2),
        (P::LowerRight, 2, 0),
        (P::LowerLeft, 0, 0),
        (P::UpperMiddle, 1, 2),
        (P::LowerMiddle, 1, 0),
        (P::MiddleRight, 2, 1),
        (P::MiddleLeft, 0, 1),
    ];
    let inside = |t: f64, at: u8, len: f64| match at {
        0 => t <= len,
        1 => (t - 0.5).abs() <= 0.5 * len,
        _ => t >= 1.0 - len,
    };
    // The curves in plot-area units (0..1 on both axes).
    let curves: Vec<Vec<(f64, f64)>> = panel
        .series
        .iter()
        .map(|s| {
            s.x.iter()
                .copied()
                .zip(s.y.iter().copied())
                .filter(keep(panel.log_y))
                .map(|(x, y)| ((x - x0) / (x1 - x0), fy(y)))
                .collect()
        })
        .collect();
    // Coverage: the length of drawn curve under the box, so a dense sampled trace weighs no more
    // than a sparse line across the same place.
    let covered = |ax: u8, ay: u8| {
        let under = |u: f64, v: f64| {
            (0.0..=1.0).contains(&u) && (0.0..=1.0).contains(&v) && inside(u, ax, size.0) && inside(v, ay, size.1)
        };
        let mut length = 0.0;
        for pts in &curves {
            for w in pts.windows(2) {
                let ((u0, v0), (u1, v1)) = (w[0], w[1]);
                let len = (u1 - u0).hypot(v1 - v0);
                let k = (len / 0.01).ceil().clamp(1.0, 1000.0) as usize;
                for i in 0..k {
                    let t = (i as f64 + 0.5) / k as f64;
                    if under(u0 + t * (u1 - u0), v0 + t * (v1 - v0)) {
                        length += len / k as f64;
                    }
                }
            }
        }
        length
    };
    let mut best = (f64::INFINITY, P::UpperRight);
    for (pos, ax, ay) in places {
        let c = covered(ax, ay);
        if c < best.0 {
            best = (c, pos);
        }
    }
    best.1
}

fn fill<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    panel: &Panel,
    y0: f64,
    y1: f64,
    corner: SeriesLabelPosition,
) -> DynResult
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_mesh()
        .x_desc(&panel.x_label)
        .y_desc(&panel.y_label)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    for (x, label) in &panel.markers {
        chart.draw_series(DashedLineSeries::new(vec![(*x, y0), (*x, y1)], 3, 4, BLACK.mix(0.4).stroke_width(1)))?;
        chart.draw_series(std::iter::once(Text::new(label.clone(), (*x, y1), ("sans-serif", 13).into_font())))?;
    }
    for s in &panel.series {
        let pts: Vec<(f64, f64)> = s.x.iter().copied().zip(s.y.iter().copied()).filter(keep(panel.log_y)).collect();
        let c = color(s.color);
        let style = c.stroke_width(2);
        let anno = match s.style {
            LineStyle::Solid => chart.draw_series(LineSeries::new(pts, style))?,
            LineStyle::Dashed => chart.draw_series(DashedLineSeries::new(pts, 8, 5, style))?,
            LineStyle::Dotted => chart.draw_series(DashedLineSeries::new(pts, 2, 4, style))?,
            LineStyle::Points => chart.draw_series(pts.into_iter().map(|p| Circle::new(p, 3, c.filled())))?,
        };
        if !s.label.is_empty() {
            // NOTE: a legend sample is one path; a short stub for dashed/dotted lines reads well
            // enough next to the label, which names the style's meaning (up/down, locked).
            let len = match s.style {
                LineStyle::Solid => 20,
                LineStyle::Dashed => 8,
                LineStyle::Dotted | LineStyle::Points => 3,
            };
            anno.label(&s.label).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + len, y)], c.stroke_width(2)));
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .position(corner)
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_an_svg_with_all_styles_and_a_log_axis() {
        let dir = std::env::temp_dir().join(format!("kanedyn_plot_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let x: Vec<f64> = (0..50).map(|i| 2.9 + 0.008 * i as f64).collect();
        let s = |style, color, f: fn(f64) -> f64| Series {
            label: format!("{style:?}"),
            x: x.clone(),
            y: x.iter().map(|&v| f(v)).collect(),
            color,
            style,
        };
        let panel = Panel {
            title: "test".into(),
            x_label: "order n".into(),
            y_label: "rad/s²".into(),
            log_y: true,
            markers: vec![(3.11, "n_t".into())],
            series: vec![
                s(LineStyle::Solid, 0, |v| v * v),
                s(LineStyle::Dashed, 1, |v| v),
                s(LineStyle::Dotted, 2, |v| (v - 3.0).abs()),
            ],
            ..Panel::default()
        };
        let lin = Panel { log_y: false, ..panel.clone() };
        let path = dir.join("p.svg");
        write_svg(&path, &[panel, lin], 500, 350).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.starts_with("<svg"));
        assert!(text.contains("order n") && text.contains("Dashed") && text.contains("n_t"));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A curve rising into the upper right sends the legend to the empty upper left; with every
    /// corner free the legend stays upper right.
    #[test]
    fn legend_avoids_the_curves() {
        let x: Vec<f64> = (0..100).map(|i| i as f64 / 99.0).collect();
        let rising = Series {
            label: "a".into(),
            x: x.clone(),
            y: x.iter().map(|v| v * v).collect(),
            color: 0,
            style: LineStyle::Solid,
        };
        let panel = Panel { series: vec![rising], ..Panel::default() };
        let ranges = ((0.0, 1.0), (0.0, 1.0));
        assert!(matches!(legend_corner(&panel, ranges, (0.3, 0.2)), SeriesLabelPosition::UpperLeft));
        let flat = Series { label: "b".into(), x: x.clone(), y: vec![0.5; 100], color: 1, style: LineStyle::Dashed };
        let panel = Panel { series: vec![flat], ..Panel::default() };
        assert!(matches!(legend_corner(&panel, ranges, (0.3, 0.2)), SeriesLabelPosition::UpperRight));
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick(9.999999999999999e-6), "1e-5");
        assert_eq!(tick(2.95), "2.95");
        assert_eq!(tick(600.0), "600");
        assert_eq!(tick(0.001), "0.001");
        assert_eq!(tick(123456.0), "1e5");
        assert_eq!(tick(0.0), "0");
    }
}

/// A colour map of `z` over a grid of cells (an order–rpm map): `z[i][j]` at `x[i]`, `y[j]`
/// (cell centres, increasing), drawn in decibels relative to the largest value over
/// `db_range` dB, viridis colours, with a colour bar.
#[derive(Debug, Clone, Default)]
pub struct Heatmap {
    /// Title above the axes.
    pub title: String,
    /// x-axis label (with units).
    pub x_label: String,
    /// y-axis label (with units).
    pub y_label: String,
    /// What the colours measure (with units), for the colour bar.
    pub z_label: String,
    /// Cell centres along x, increasing.
    pub x: Vec<f64>,
    /// Cell centres along y, increasing.
    pub y: Vec<f64>,
    /// `z[i][j]`: the value at `(x[i], y[j])`; non-finite cells are left blank.
    pub z: Vec<Vec<f64>>,
    /// Decibels below the largest value that the colours span (values further below draw in the
    /// lowest colour).
    pub db_range: f64,
    /// Horizontal reference lines `y = c` with their labels (the excitation orders).
    pub y_markers: Vec<(f64, String)>,
}

/// The most cells drawn along one axis: larger maps are reduced by taking the largest value of
/// each group of cells (a peak stays visible), which keeps the SVG near a megabyte.
const MAX_CELLS: usize = 160;

/// Groups `n` indices into at most `MAX_CELLS` consecutive runs.
fn groups(n: usize) -> Vec<std::ops::Range<usize>> {
    let g = n.div_ceil(MAX_CELLS).max(1);
    (0..n).step_by(g).map(|s| s..(s + g).min(n)).collect()
}

/// The edges of cells centred on `c` (increasing), halfway between centres and mirrored at the
/// ends.
fn edges(c: &[f64]) -> Vec<f64> {
    let n = c.len();
    let mut e = Vec::with_capacity(n + 1);
    let half = |i: usize| if n > 1 { 0.5 * (c[i + 1] - c[i]) } else { 0.5 };
    e.push(c[0] - half(0));
    for i in 0..n.saturating_sub(1) {
        e.push(0.5 * (c[i] + c[i + 1]));
    }
    e.push(c[n - 1] + half(n.saturating_sub(2)));
    e
}

/// Writes `map` to an SVG file of `width`×`height` pixels.
pub fn write_heatmap_svg(path: &Path, map: &Heatmap, width: u32, height: u32) -> Result<()> {
    use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
    let draw = || -> DynResult {
        let root = SVGBackend::new(path, (width, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let (main, bar) = root.split_horizontally(width.saturating_sub(90));
        if map.x.is_empty() || map.y.is_empty() || map.z.len() != map.x.len() {
            root.present()?;
            return Ok(());
        }
        let (xe, ye) = (edges(&map.x), edges(&map.y));
        let peak = map.z.iter().flatten().copied().filter(|v| v.is_finite()).fold(0.0, f64::max);
        let range = if map.db_range > 0.0 { map.db_range } else { 60.0 };
        let level = |v: f64| {
            if peak > 0.0 && v > 0.0 { (1.0 + 20.0 * (v / peak).log10() / range).clamp(0.0, 1.0) } else { 0.0 }
        };
        let mut chart = ChartBuilder::on(&main)
            .caption(&map.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(xe[0]..xe[xe.len() - 1], ye[0]..ye[ye.len() - 1])?;
        let (gx, gy) = (groups(map.x.len()), groups(map.y.len()));
        let mut cells = Vec::with_capacity(gx.len() * gy.len());
        for rx in &gx {
            for ry in &gy {
                let v = rx
                    .clone()
                    .flat_map(|i| map.z[i].get(ry.clone()).unwrap_or(&[]).iter().copied())
                    .filter(|v| v.is_finite())
                    .fold(f64::NAN, f64::max);
                if v.is_finite() {
                    let c = ViridisRGB.get_color(level(v) as f32);
                    cells.push(Rectangle::new([(xe[rx.start], ye[ry.start]), (xe[rx.end], ye[ry.end])], c.filled()));
                }
            }
        }
        chart.draw_series(cells)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(&map.x_label)
            .y_desc(&map.y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()?;
        for (y, label) in &map.y_markers {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(xe[0], *y), (xe[xe.len() - 1], *y)],
                WHITE.mix(0.6).stroke_width(1),
            )))?;
            chart.draw_series(std::iter::once(Text::new(
                label.clone(),
                (xe[0], *y),
                ("sans-serif", 12).into_font().color(&WHITE),
            )))?;
        }
        // The colour bar: dB below the peak.
        let mut bar_chart = ChartBuilder::on(&bar)
            .margin_top(40)
            .margin_bottom(52)
            .margin_right(8)
            .y_label_area_size(44)
            .caption(&map.z_label, ("sans-serif", 13))
            .build_cartesian_2d(0.0..1.0, -range..0.0)?;
        let steps = 64;
        bar_chart.draw_series((0..steps).map(|k| {
            let (a, b) = (-range + range * k as f64 / steps as f64, -range + range * (k + 1) as f64 / steps as f64);
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                ViridisRGB.get_color(((k as f64 + 0.5) / steps as f64) as f32).filled(),
            )
        }))?;
        bar_chart
            .configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc("dB re peak")
            .y_label_style(("sans-serif", 12))
            .axis_desc_style(("sans-serif", 12))
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| plot_error(path, e))
}

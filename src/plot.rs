//! SVG line plots for reports, in the manner of the paper's figures: panels of x–y series, each
//! solid, dashed or dotted, optionally with a logarithmic y axis (Figure 2 of the paper).
//!
//! This is the one module that sees plotters. SVG needs no system font library (plotters' default
//! features, which pull in font-kit, stay off), so text is laid out with plotters' naive metrics
//! and drawn by the SVG viewer.
//!
//! plotters works in whole backend pixels, which made the figures pixel images in SVG clothing
//! (staircases when zoomed, a quarter of the points repeating the one before). So every figure
//! is drawn [`FINE`] times larger and [`vector`] writes the result back at its nominal size with
//! two decimals, dropping repeated points: a thin pass over plotters' regular output rather than
//! an SVG writer of our own.

use crate::error::{Error, Result};
use plotters::chart::MeshStyle;
use plotters::coord::ranged1d::ValueFormatter;
use plotters::prelude::*;
use std::fmt::Write as _;
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
    /// The points as a closed polygon, filled in a light tint of the colour and not outlined (a
    /// region of a parameter plane, drawn under the curves that bound it).
    Region,
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

/// A point marked and labelled on a panel (a resonance on a Campbell diagram), or with
/// `marker: false` a label alone (an order line's name at its end). Labels are placed next to
/// their points where they overlap neither another label nor a marker, pushed further out (with a
/// leader line) when every near place is taken, so close points keep readable labels.
#[derive(Debug, Clone, Default)]
pub struct PointLabel {
    /// Abscissa of the point.
    pub x: f64,
    /// Ordinate of the point.
    pub y: f64,
    /// The label.
    pub text: String,
    /// Draw a marker (an open circle) at the point.
    pub marker: bool,
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
    /// Labelled points, drawn over the curves.
    pub labels: Vec<PointLabel>,
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

/// Backend units per SVG pixel: plotters rounds to whole backend units, so drawing 100 times
/// larger keeps positions to 1/100 pixel, the two decimals [`vector`] writes.
pub const FINE: u32 = 100;

/// `v` pixels in backend units.
const fn px(v: u32) -> u32 {
    v * FINE
}

/// The sans-serif font at `size` pixels.
fn font(size: u32) -> FontDesc<'static> {
    ("sans-serif", f64::from(px(size))).into_font()
}

/// Draws into an SVG of `width`×`height` pixels through `draw` (which sees a backend [`FINE`]
/// times larger), then writes it to `path` at its nominal size ([`vector`]).
fn write_fine(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(DrawingArea<SVGBackend, plotters::coord::Shift>) -> DynResult,
) -> Result<()> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (px(width), px(height))).into_drawing_area();
        draw(root).map_err(|e| plot_error(path, e))?;
    }
    std::fs::write(path, groups_for_readers(&vector(&text))).map_err(|source| Error::Io {
        file: path.to_path_buf(),
        action: "cannot write plot",
        source,
    })
}

/// plotters' SVG (drawn [`FINE`] times larger) at its nominal size: every coordinate and length
/// divided by [`FINE`] with exactly two decimals (integer arithmetic, so the text is the same
/// on every machine), font sizes and stroke widths likewise, and a point equal to the one before
/// it dropped from each polyline and polygon. Text between tags is left alone (plotters escapes
/// `<` and `>` in it).
pub fn vector(svg: &str) -> String {
    let mut out = String::with_capacity(svg.len());
    let mut rest = svg;
    while let Some(open) = rest.find('<') {
        out.push_str(&rest[..open]);
        let Some(len) = rest[open..].find('>') else { break };
        out.push_str(&vector_tag(&rest[open..open + len]));
        out.push('>');
        rest = &rest[open + len + 1..];
    }
    out.push_str(rest);
    out
}

/// One tag (`<name a="v" …`, without the closing `>`) rescaled.
fn vector_tag(tag: &str) -> String {
    let root = tag.starts_with("<svg");
    let mut out = String::with_capacity(tag.len());
    let mut rest = tag;
    while let Some(eq) = rest.find("=\"") {
        let name_start = rest[..eq].rfind([' ', '\n']).map_or(0, |i| i + 1);
        let name = &rest[name_start..eq];
        let Some(end) = rest[eq + 2..].find('"') else { break };
        let value = &rest[eq + 2..eq + 2 + end];
        out.push_str(&rest[..eq + 2]);
        out.push_str(&rescale(root, name, value));
        out.push('"');
        rest = &rest[eq + 3 + end..];
    }
    out.push_str(rest);
    out
}

/// An attribute's value at nominal size.
fn rescale(root: bool, name: &str, value: &str) -> String {
    let whole = |v: &str| v.parse::<i64>().map_or_else(|_| v.to_string(), |n| (n / i64::from(FINE)).to_string());
    match name {
        "width" | "height" if root => whole(value),
        "viewBox" => value.split(' ').map(whole).collect::<Vec<_>>().join(" "),
        "x" | "y" | "x1" | "y1" | "x2" | "y2" | "cx" | "cy" | "r" | "width" | "height" => coord(value),
        "font-size" | "stroke-width" => {
            value.parse::<f64>().map_or_else(|_| value.to_string(), |v| trim(format!("{:.2}", v / f64::from(FINE))))
        }
        "points" => {
            let mut pts: Vec<String> = Vec::new();
            for p in value.split_whitespace() {
                let p = p.split(',').map(coord).collect::<Vec<_>>().join(",");
                if pts.last() != Some(&p) {
                    pts.push(p);
                }
            }
            pts.iter().map(|p| format!("{p} ")).collect()
        }
        // `rotate(angle, x, y)`: the angle stays, the centre scales.
        "transform" => match value.strip_prefix("rotate(").and_then(|v| v.strip_suffix(')')) {
            Some(args) => {
                let a: Vec<&str> = args.split(", ").collect();
                match a.as_slice() {
                    [angle, x, y] => format!("rotate({angle}, {}, {})", coord(x), coord(y)),
                    _ => value.to_string(),
                }
            }
            None => value.to_string(),
        },
        _ => value.to_string(),
    }
}

/// A whole number of backend units as pixels with two decimals.
fn coord(v: &str) -> String {
    match v.trim().parse::<i64>() {
        Ok(n) => {
            let f = i64::from(FINE);
            let sign = if n < 0 { "-" } else { "" };
            let a = n.abs();
            format!("{sign}{}.{:02}", a / f, (a % f) * 100 / f)
        }
        Err(_) => v.to_string(),
    }
}

/// A decimal without trailing zeros (`2.00` → `2`, `9.70` → `9.7`).
fn trim(s: String) -> String {
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

/// Starts a marker that [`groups_for_readers`] turns into an SVG `<g>` tag: a text element whose
/// content begins with this private-use character. plotters writes no groups of its own, and
/// a drawn text is the one element whose content it passes through untouched (escaped).
const MARK: char = '\u{E000}';
/// Separates the fields of a marker (labels may hold spaces).
const FIELD: char = '\u{E001}';

/// Turns the marker texts that [`fill`] draws into groups: `panel` opens a
/// `<g class="kd-panel">` that carries the axes' mapping (`data-px`: the pixel columns of the
/// x range's ends, `data-py`: the pixel rows of the y range's ends, `data-x`, `data-y`: those
/// ends in data units, `data-log-y`, the axis labels), `series` opens a `<g class="kd-series">`
/// with the curve's label, `end` closes a group. A reader of the figure (report.html's zoom
/// and hover layer) can then tell the curves from the grid and turn a point's pixels back into
/// data values, without the figure carrying its data twice.
fn groups_for_readers(svg: &str) -> String {
    let mut out = String::with_capacity(svg.len());
    let mut rest = svg;
    while let Some(m) = rest.find(MARK) {
        let (Some(open), Some(close)) = (rest[..m].rfind("<text"), rest[m..].find("</text>")) else { break };
        let end = m + close + "</text>".len();
        let end = if rest[end..].starts_with('\n') { end + 1 } else { end };
        out.push_str(&rest[..open]);
        let content = rest[m + MARK.len_utf8()..m + close].trim_end();
        let f: Vec<&str> = content.split(FIELD).collect();
        match f.as_slice() {
            ["panel", pl, pr, pb, pt, x0, x1, y0, y1, log, xl, yl] => {
                let _ = writeln!(
                    out,
                    "<g class=\"kd-panel\" data-px=\"{pl} {pr}\" data-py=\"{pb} {pt}\" data-x=\"{x0} {x1}\" \
                     data-y=\"{y0} {y1}\" data-log-y=\"{log}\" data-x-label=\"{xl}\" data-y-label=\"{yl}\">"
                );
            }
            ["series", label] => {
                let _ = writeln!(out, "<g class=\"kd-series\" data-label=\"{label}\">");
            }
            _ => out.push_str("</g>\n"),
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// Draws the marker `fields` (see [`groups_for_readers`]) at the data point `at`.
fn mark<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    at: (f64, f64),
    fields: &[&str],
) -> DynResult
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let mut text = String::from(MARK);
    text.push_str(&fields.join(&FIELD.to_string()));
    chart.draw_series(std::iter::once(Text::new(text, at, font(1))))?;
    Ok(())
}

/// Writes `panels` side by side (one row) to an SVG file of `width`×`height` pixels per panel.
pub fn write_svg(path: &Path, panels: &[Panel], width: u32, height: u32) -> Result<()> {
    let cols = panels.len().max(1) as u32;
    write_fine(path, (width * cols, height), |root| {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, cols as usize));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            draw_panel(panel, area)?;
        }
        root.present()?;
        Ok(())
    })
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

/// A number as the figures write it, in legends, labels, titles and ticks alike: at most `sig`
/// significant digits, trailing zeros dropped, in exponent form (`5e-4`, `2.5e5`) only below
/// 1e-3 or from 1e5 on. One format for every figure: they used to switch between `0.3859`,
/// `1.0057e-1` and plotters' `9.999999999999999e-6`.
pub fn num(v: f64, sig: usize) -> String {
    let sig = sig.max(1);
    // Rounded to `sig` digits first, so that the form follows the number as written (99 999.9
    // at four digits is 1e5, not 100000).
    let v: f64 = format!("{v:.*e}", sig - 1).parse().unwrap_or(v);
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() {
        format!("{v}")
    } else if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.*e}", sig - 1);
        match s.split_once('e') {
            Some((m, e)) if m.contains('.') => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
            _ => s,
        }
    } else {
        let decimals = (sig as i32 - 1 - a.log10().floor() as i32).clamp(0, 12) as usize;
        trim(format!("{v:.decimals$}"))
    }
}

/// A tick label: [`num`] with four significant digits.
fn tick(v: f64) -> String {
    num(v, 4)
}

type DynResult = std::result::Result<(), Box<dyn std::error::Error>>;

/// Draws `title` (`size` pixels) centred at the top of `area` below a margin of `top` pixels (the
/// centre taken without a right margin of `right` pixels) and returns the area below it, as
/// plotters' chart caption does but with its 5-pixel gaps above and below the text in pixels:
/// plotters caps them at 5 backend units, a twentieth of a pixel at [`FINE`] scale.
fn caption<'a>(
    area: &DrawingArea<SVGBackend<'a>, plotters::coord::Shift>,
    title: &str,
    size: u32,
    (top, right): (u32, u32),
) -> std::result::Result<DrawingArea<SVGBackend<'a>, plotters::coord::Shift>, Box<dyn std::error::Error>> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let style = TextStyle::from(font(size)).pos(Pos::new(HPos::Center, VPos::Top));
    let (_, h) = area.estimate_text_size(title, &style)?;
    let (w, _) = area.dim_in_pixel();
    area.draw_text(title, &style, ((w.saturating_sub(px(right)) / 2) as i32, px(top + 5) as i32))?;
    Ok(area.margin(px(top + 10) + h, 0, 0, 0))
}

fn draw_panel(panel: &Panel, area: &DrawingArea<SVGBackend, plotters::coord::Shift>) -> DynResult {
    let ((x0, x1), (y0, y1)) = data_range(panel);
    let below = caption(area, &panel.title, 18, (12, 12))?;
    let mut builder = ChartBuilder::on(&below);
    builder.margin(px(12)).margin_top(0).x_label_area_size(px(40)).y_label_area_size(px(70));
    // The two branches differ only in the y coordinate type; everything drawn is generic over it.
    let (w, h) = area.dim_in_pixel();
    let (w, h) = (w / FINE, h / FINE);
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
    mesh(chart.configure_mesh().x_desc(&panel.x_label).y_desc(&panel.y_label))
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    for (x, label) in &panel.markers {
        chart.draw_series(DashedLineSeries::new(
            vec![(*x, y0), (*x, y1)],
            px(3),
            px(4),
            BLACK.mix(0.4).stroke_width(px(1)),
        ))?;
        chart.draw_series(std::iter::once(Text::new(label.clone(), (*x, y1), font(13))))?;
    }
    // The curves in a group that records the axes' mapping, each curve in its own group.
    let (xr, yr) = (chart.x_range(), chart.y_range());
    let ((xa, ya), (xb, yb)) = (chart.backend_coord(&(xr.start, yr.start)), chart.backend_coord(&(xr.end, yr.end)));
    let pixel = |v: i32| coord(&v.to_string());
    let (xs, ys) = ([xr.start, xr.end].map(|v| format!("{v:e}")), [yr.start, yr.end].map(|v| format!("{v:e}")));
    let fields = [
        "panel",
        &pixel(xa),
        &pixel(xb),
        &pixel(ya),
        &pixel(yb),
        &xs[0],
        &xs[1],
        &ys[0],
        &ys[1],
        if panel.log_y { "1" } else { "0" },
        &panel.x_label,
        &panel.y_label,
    ];
    mark(chart, (xr.start, yr.start), &fields)?;
    for s in &panel.series {
        mark(chart, (xr.start, yr.start), &["series", &s.label])?;
        let pts: Vec<(f64, f64)> = s.x.iter().copied().zip(s.y.iter().copied()).filter(keep(panel.log_y)).collect();
        let c = color(s.color);
        let style = c.stroke_width(px(2));
        let anno = match s.style {
            LineStyle::Solid => chart.draw_series(LineSeries::new(pts, style))?,
            LineStyle::Dashed => chart.draw_series(DashedLineSeries::new(pts, px(8), px(5), style))?,
            LineStyle::Dotted => chart.draw_series(DashedLineSeries::new(pts, px(2), px(4), style))?,
            LineStyle::Points => chart.draw_series(pts.into_iter().map(|p| Circle::new(p, px(3), c.filled())))?,
            LineStyle::Region => chart.draw_series(std::iter::once(Polygon::new(pts, c.mix(0.15).filled())))?,
        };
        if !s.label.is_empty() {
            // NOTE: a legend sample is one path; a short stub for dashed/dotted lines reads well
            // enough next to the label, which names the style's meaning (up/down, locked).
            let len = px(match s.style {
                LineStyle::Solid => 20,
                LineStyle::Dashed => 8,
                LineStyle::Dotted | LineStyle::Points => 3,
                LineStyle::Region => 12,
            }) as i32;
            anno.label(&s.label)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + len, y)], c.stroke_width(px(2))));
        }
        mark(chart, (xr.start, yr.start), &["end"])?;
    }
    mark(chart, (xr.start, yr.start), &["end"])?;
    draw_labels(chart, &panel.labels)?;
    let legend_font: TextStyle = font(12).into();
    let at = legend_place(chart, panel, &legend_font, corner)?;
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3).stroke_width(px(1)))
        .margin(px(10))
        .legend_area_size(px(30))
        .label_font(legend_font)
        .position(at)
        .draw()?;
    Ok(())
}

/// The mesh's fonts, tick marks and line widths at [`FINE`] scale: plotters' defaults are whole
/// pixels (12-pixel labels, 5-pixel ticks, 1-pixel lines) and would shrink with the drawing.
fn mesh<'m, 'a, 'b, X, Y>(
    m: &'m mut MeshStyle<'a, 'b, X, Y, SVGBackend<'a>>,
) -> &'m mut MeshStyle<'a, 'b, X, Y, SVGBackend<'a>>
where
    X: Ranged + ValueFormatter<X::ValueType>,
    Y: Ranged + ValueFormatter<Y::ValueType>,
{
    m.label_style(font(12))
        .axis_desc_style(font(12))
        .set_all_tick_mark_size(px(5))
        .bold_line_style(BLACK.mix(0.2).stroke_width(px(1)))
        .light_line_style(BLACK.mix(0.1).stroke_width(px(1)))
        .axis_style(BLACK.stroke_width(px(1)))
}

/// The legend's upper-left corner for plotters' `corner`, with its 5-pixel inset from the frame
/// kept at [`FINE`] scale (plotters insets by 5 backend units). The box is measured as plotters
/// measures it: the labels' text block, the sample area and two margins.
fn legend_place<'a, X, Y>(
    chart: &ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    panel: &Panel,
    style: &TextStyle,
    corner: SeriesLabelPosition,
) -> std::result::Result<SeriesLabelPosition, Box<dyn std::error::Error>>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    use SeriesLabelPosition as P;
    let mut text = MultiLineText::<_, &str>::new((0, 0), style);
    for s in panel.series.iter().filter(|s| !s.label.is_empty()) {
        text.push_line(s.label.as_str());
    }
    let (w, h) = text.estimate_dimension()?;
    let (w, h) = (w + px(30 + 2 * 10) as i32, h + px(2 * 10) as i32);
    let (aw, ah) = chart.plotting_area().dim_in_pixel();
    let (aw, ah, inset) = (aw as i32, ah as i32, px(5) as i32);
    let x = match corner {
        P::UpperLeft | P::MiddleLeft | P::LowerLeft => inset,
        P::UpperMiddle | P::MiddleMiddle | P::LowerMiddle => (aw - w) / 2,
        _ => aw - w - inset,
    };
    let y = match corner {
        P::UpperLeft | P::UpperMiddle | P::UpperRight => inset,
        P::MiddleLeft | P::MiddleMiddle | P::MiddleRight => (ah - h) / 2,
        _ => ah - h - inset,
    };
    Ok(P::Coordinate(x, y))
}

/// A box in backend units: left, top, right, bottom.
type Rect = (i32, i32, i32, i32);

fn overlaps(a: Rect, b: Rect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// Draws `labels` (markers and texts) with each text placed greedily in the first free place
/// around its point: the four diagonal neighbours, then the same places pushed outwards step by
/// step, joined to the point by a thin leader line. A place is free when it stays inside the
/// plotting area and overlaps no text placed before and no marker. When none is free the text
/// takes its first place anyway: every label is drawn.
fn draw_labels<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    labels: &[PointLabel],
) -> DynResult
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    if labels.is_empty() {
        return Ok(());
    }
    let area = chart.plotting_area().strip_coord_spec();
    let (bx, by) = area.get_base_pixel();
    let (aw, ah) = area.dim_in_pixel();
    let style: TextStyle = font(12).into();
    let at: Vec<(i32, i32)> = labels
        .iter()
        .map(|l| {
            let (x, y) = chart.backend_coord(&(l.x, l.y));
            (x - bx, y - by)
        })
        .collect();
    let r = px(4) as i32;
    let mut taken: Vec<Rect> =
        labels.iter().zip(&at).filter(|(l, _)| l.marker).map(|(_, &(x, y))| (x - r, y - r, x + r, y + r)).collect();
    let (gap, step) = (px(3) as i32, px(2) as i32);
    for (l, &(x, y)) in labels.iter().zip(&at) {
        if l.marker {
            area.draw(&Circle::new((x, y), px(4), BLACK.stroke_width(px(1))))?;
        }
        let (w, h) = area.estimate_text_size(&l.text, &style)?;
        let (w, h) = (w as i32, h as i32);
        let corners = [(gap, -gap - h), (gap, gap), (-gap - w, -gap - h), (-gap - w, gap)];
        let mut places = Vec::new();
        for k in 0..12 {
            for (i, &(dx, dy)) in corners.iter().enumerate() {
                let push = k * (h + step) * if i % 2 == 0 { -1 } else { 1 };
                places.push((k, (x + dx, y + dy + push)));
            }
        }
        let inside =
            |&(_, (px0, py0)): &(i32, (i32, i32))| px0 >= 0 && py0 >= 0 && px0 + w <= aw as i32 && py0 + h <= ah as i32;
        let free = |p: &(i32, (i32, i32))| {
            inside(p) && !taken.iter().any(|&t| overlaps(t, (p.1.0, p.1.1, p.1.0 + w, p.1.1 + h)))
        };
        let (k, (tx, ty)) =
            places.iter().find(|p| free(p)).or_else(|| places.iter().find(|p| inside(p))).copied().unwrap_or(places[0]);
        if k > 0 {
            // The leader ends at the text's nearer upright edge, half a line from its point's side.
            let ex = if tx > x { tx } else { tx + w };
            let ey = if ty > y { ty } else { ty + h };
            area.draw(&PathElement::new(vec![(x, y), (ex, ey)], BLACK.mix(0.5).stroke_width(px(1))))?;
        }
        area.draw(&Text::new(l.text.clone(), (tx, ty), style.clone()))?;
        taken.push((tx, ty, tx + w, ty + h));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_an_svg_with_all_styles_and_a_log_axis() {
        let tmp = tempfile::Builder::new().prefix("kanedyn-plot-").tempdir().unwrap();
        let dir = tmp.path();
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

    /// The rewrite divides by [`FINE`] exactly, keeps the rotation angle and the text, and drops a
    /// point equal to the one before it (here 1234,500 twice after 1234,500: plotters' whole units).
    #[test]
    fn vector_writes_two_decimals_and_drops_repeated_points() {
        let fine = "<svg width=\"76000\" height=\"52000\" viewBox=\"0 0 76000 52000\" xmlns=\"http://www.w3.org/2000/svg\">\n\
            <polyline fill=\"none\" stroke-width=\"200\" points=\"1234,500 1234,500 -7,12345 1234,500 \"/>\n\
            <text x=\"100\" y=\"2005\" font-size=\"967.741935483871\" transform=\"rotate(270, 100, 2005)\">\n\
            x = 3 &lt; 4\n</text>\n</svg>\n";
        let v = vector(fine);
        assert!(v.starts_with("<svg width=\"760\" height=\"520\" viewBox=\"0 0 760 520\""), "{v}");
        assert!(v.contains("stroke-width=\"2\" points=\"12.34,5.00 -0.07,123.45 12.34,5.00 \""), "{v}");
        assert!(v.contains("x=\"1.00\" y=\"20.05\" font-size=\"9.68\" transform=\"rotate(270, 1.00, 20.05)\""), "{v}");
        assert!(v.contains("\nx = 3 &lt; 4\n</text>"), "{v}");
    }

    /// The figure's groups let a reader turn pixels back into data: each curve sits in its own
    /// `kd-series` group inside a `kd-panel` group whose mapping, inverted, gives the curve's
    /// first point back (linear x, logarithmic y), and no marker text is left in the file.
    #[test]
    fn groups_carry_the_axes_mapping() {
        let tmp = tempfile::Builder::new().prefix("kanedyn-plot-groups-").tempdir().unwrap();
        let dir = tmp.path();
        let x: Vec<f64> = (0..40).map(|i| 1.0 + 0.05 * i as f64).collect();
        let y: Vec<f64> = x.iter().map(|v| v.powi(3)).collect();
        let series = Series { label: "cubic \"c\"".into(), x: x.clone(), y: y.clone(), ..Series::default() };
        let panel = Panel {
            x_label: "x, m".into(),
            y_label: "y, N".into(),
            log_y: true,
            series: vec![series],
            ..Panel::default()
        };
        let path = dir.join("g.svg");
        write_svg(&path, &[panel], 500, 350).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(!svg.contains(MARK) && !svg.contains(FIELD));
        assert_eq!(svg.matches("<g ").count(), svg.matches("</g>").count());
        let attr = |name: &str| -> Vec<f64> {
            let key = format!(" {name}=\"");
            let v = &svg[svg.find(&key).unwrap_or_else(|| panic!("{name}")) + key.len()..];
            v[..v.find('"').unwrap()].split(' ').map(|t| t.parse().unwrap()).collect()
        };
        let (pxs, pys, xs, ys) = (attr("data-px"), attr("data-py"), attr("data-x"), attr("data-y"));
        assert!(svg.contains("data-log-y=\"1\" data-x-label=\"x, m\" data-y-label=\"y, N\""));
        let series = svg.find("<g class=\"kd-series\" data-label=\"cubic &quot;c&quot;\">").expect("the curve's group");
        let pts = &svg[series..];
        let pts = &pts[pts.find("points=\"").unwrap() + 8..];
        let first: Vec<f64> = pts.split_whitespace().next().unwrap().split(',').map(|t| t.parse().unwrap()).collect();
        let xv = xs[0] + (first[0] - pxs[0]) / (pxs[1] - pxs[0]) * (xs[1] - xs[0]);
        let yv = ys[0] * (ys[1] / ys[0]).powf((first[1] - pys[0]) / (pys[1] - pys[0]));
        assert!((xv - x[0]).abs() < 1e-4, "{xv}");
        assert!((yv / y[0] - 1.0).abs() < 1e-3, "{yv}");
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick(9.999999999999999e-6), "1e-5");
        assert_eq!(tick(2.95), "2.95");
        assert_eq!(tick(600.0), "600");
        assert_eq!(tick(0.001), "0.001");
        assert_eq!(tick(123456.0), "1.235e5");
        assert_eq!(tick(2e5), "2e5");
        assert_eq!(tick(0.0), "0");
    }

    #[test]
    fn numbers_have_one_format() {
        assert_eq!(num(5e-4, 5), "5e-4");
        assert_eq!(num(1.0057e-1, 5), "0.10057");
        assert_eq!(num(0.38594, 4), "0.3859");
        assert_eq!(num(2.940_412, 5), "2.9404");
        assert_eq!(num(3.0, 5), "3");
        assert_eq!(num(-622.5, 5), "-622.5");
        assert_eq!(num(2.512_675_2e5, 4), "2.513e5");
        assert_eq!(num(99_999.9, 4), "1e5");
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

/// The far edge of the group of cells `r` (edges `e`), moved on by a third of the group's width
/// when another group follows: cells drawn edge to edge at sub-pixel positions leave hairline
/// seams where the viewer's anti-aliasing lets the background through; the next group, drawn
/// later, covers the overlap (a group is at least 1/`MAX_CELLS` of the axis, a few pixels).
fn over(e: &[f64], r: &std::ops::Range<usize>) -> f64 {
    if r.end + 1 < e.len() { e[r.end] + (e[r.end] - e[r.start]) / 3.0 } else { e[r.end] }
}

/// Writes `map` to an SVG file of `width`×`height` pixels.
pub fn write_heatmap_svg(path: &Path, map: &Heatmap, width: u32, height: u32) -> Result<()> {
    use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
    write_fine(path, (width, height), |root| {
        root.fill(&WHITE)?;
        let (main, bar) = root.split_horizontally(px(width.saturating_sub(90)));
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
        let below = caption(&main, &map.title, 18, (12, 12))?;
        let mut chart = ChartBuilder::on(&below)
            .margin(px(12))
            .margin_top(0)
            .x_label_area_size(px(40))
            .y_label_area_size(px(60))
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
                    cells.push(Rectangle::new(
                        [(xe[rx.start], ye[ry.start]), (over(&xe, rx), over(&ye, ry))],
                        c.filled(),
                    ));
                }
            }
        }
        chart.draw_series(cells)?;
        mesh(&mut chart.configure_mesh())
            .disable_mesh()
            .x_desc(&map.x_label)
            .y_desc(&map.y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .draw()?;
        for (y, label) in &map.y_markers {
            chart.draw_series(std::iter::once(PathElement::new(
                vec![(xe[0], *y), (xe[xe.len() - 1], *y)],
                WHITE.mix(0.6).stroke_width(px(1)),
            )))?;
            chart.draw_series(std::iter::once(Text::new(label.clone(), (xe[0], *y), font(12).color(&WHITE))))?;
        }
        // The colour bar: dB below the peak.
        let below = caption(&bar, &map.z_label, 13, (40, 8))?;
        let mut bar_chart = ChartBuilder::on(&below)
            .margin_bottom(px(52))
            .margin_right(px(8))
            .y_label_area_size(px(44))
            .build_cartesian_2d(0.0..1.0, -range..0.0)?;
        let steps = 64;
        bar_chart.draw_series((0..steps).map(|k| {
            // Overlapping the next step by a third hides the seams, as for the cells.
            let b = if k + 1 < steps { k as f64 + 4.0 / 3.0 } else { (k + 1) as f64 };
            let (a, b) = (-range + range * k as f64 / steps as f64, -range + range * b / steps as f64);
            Rectangle::new(
                [(0.0, a), (1.0, b)],
                ViridisRGB.get_color(((k as f64 + 0.5) / steps as f64) as f32).filled(),
            )
        }))?;
        mesh(&mut bar_chart.configure_mesh())
            .disable_mesh()
            .disable_x_axis()
            .y_desc("dB re peak")
            .y_label_formatter(&|v| format!("{v:.0}"))
            .draw()?;
        root.present()?;
        Ok(())
    })
}

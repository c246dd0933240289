//! Colour maps (the order–rpm map of a transient).

use super::panel::{caption, mesh};
use super::*;

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

//! One panel of a line plot: its data range, title, axes and curves.

use super::legend::{draw_labels, keep, legend_corner, legend_place, legend_size};
use super::vector::{coord, mark};
use super::*;
use plotters::chart::MeshStyle;
use plotters::coord::ranged1d::ValueFormatter;

pub(super) fn data_range(panel: &Panel) -> ((f64, f64), (f64, f64)) {
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

/// Draws `title` (`size` pixels) centred at the top of `area` below a margin of `top` pixels (the
/// centre taken without a right margin of `right` pixels) and returns the area below it, as
/// plotters' chart caption does but with its 5-pixel gaps above and below the text in pixels:
/// plotters caps them at 5 backend units, a twentieth of a pixel at [`FINE`] scale.
pub(super) fn caption<'a>(
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

pub(super) fn draw_panel(panel: &Panel, area: &DrawingArea<SVGBackend, plotters::coord::Shift>) -> DynResult {
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

pub(super) fn fill<'a, X, Y>(
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
pub(super) fn mesh<'m, 'a, 'b, X, Y>(
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

//! Where a panel's legend and its point labels go: the legend where it hides the least curve,
//! each label in the first free place near its point.

use super::*;

/// The legend box as fractions of the plotting area (width, height), estimated from the label
/// lengths and the entry count for a panel of w × h pixels (the fonts' sizes, the label and
/// caption areas of [`draw_panel`]).
pub(super) fn legend_size(panel: &Panel, w: u32, h: u32) -> (f64, f64) {
    let labels: Vec<&Series> = panel.series.iter().filter(|s| !s.label.is_empty()).collect();
    let chars = labels.iter().map(|s| s.label.chars().count()).max().unwrap_or(0) as f64;
    let (plot_w, plot_h) = ((w as f64 - 100.0).max(1.0), (h as f64 - 100.0).max(1.0));
    ((7.0 * chars + 45.0) / plot_w, (22.0 * labels.len() as f64 + 16.0) / plot_h)
}

/// The points a panel draws: finite ones, and on a logarithmic y axis only positive values
/// (the legend places itself by the same points the panel plots).
pub(super) fn keep(log_y: bool) -> impl Fn(&(f64, f64)) -> bool {
    move |&(x, y)| x.is_finite() && y.is_finite() && (!log_y || y > 0.0)
}

/// The place for the legend (the four corners, then the middles of the four edges) where the
/// least curve length falls under its box (`size`: fractions of the plotting area), upper right
/// first on ties: the legend used to sit upper right always and hid the rising resonance curves
/// there.
pub(super) fn legend_corner(
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

/// The legend's upper-left corner for plotters' `corner`, with its 5-pixel inset from the frame
/// kept at [`FINE`] scale (plotters insets by 5 backend units). The box is measured as plotters
/// measures it: the labels' text block, the sample area and two margins.
pub(super) fn legend_place<'a, X, Y>(
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
pub(super) type Rect = (i32, i32, i32, i32);

pub(super) fn overlaps(a: Rect, b: Rect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// Draws `labels` (markers and texts) with each text placed greedily in the first free place
/// around its point: the four diagonal neighbours, then the same places pushed outwards step by
/// step, joined to the point by a thin leader line. A place is free when it stays inside the
/// plotting area and overlaps no text placed before and no marker. When none is free the text
/// takes its first place anyway: every label is drawn.
pub(super) fn draw_labels<'a, X, Y>(
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

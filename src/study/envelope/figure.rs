//! The map's chart: each boundary drawn in the plane (the second parameter on a logarithmic axis
//! where it spans a decade or more), its region tinted and named (the curve closed along the
//! map's edge on the side that holds the points just past its cusp or onset, found by an
//! even–odd point-in-polygon test in the chart's unit square), the codimension-two points marked.

use super::{Boundary, BoundaryKind, EnvelopeResult, MapPoint, TORQUE_COLUMN};
use crate::plot::{LineStyle, Panel, PointLabel, Series};

/// The orders where boundary `b`'s polyline crosses the second parameter's value `t` (linear
/// between points in the chart's coordinate `f`: log T, or the value itself), ascending.
fn crossings(b: &Boundary, t: f64, f: impl Fn(f64) -> f64) -> Vec<f64> {
    let lt = f(t);
    let mut out: Vec<f64> = b
        .values
        .windows(2)
        .zip(b.second_values.windows(2))
        .filter_map(|(n, tq)| {
            let (a, c) = (f(tq[0]) - lt, f(tq[1]) - lt);
            if a * c > 0.0 || a == c {
                return None;
            }
            let w = a / (a - c);
            Some(n[0] + w * (n[1] - n[0]))
        })
        .collect();
    out.sort_by(f64::total_cmp);
    out.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    out
}

/// A point of the map in unit coordinates: u along the first parameter, v along the second
/// (its logarithm on a logarithmic axis).
type Unit = (f64, f64);

/// The map's unit coordinates of (first, second), and back.
struct Frame {
    n: (f64, f64),
    lt: (f64, f64),
    log: bool,
}

impl Frame {
    fn of(r: &EnvelopeResult) -> Self {
        let log = r.log_second;
        let f = |t: f64| if log { t.ln() } else { t };
        Self { n: (r.range[0], r.range[1]), lt: (f(r.second_range[0]), f(r.second_range[1])), log }
    }
    /// The chart's coordinate of a second-parameter value.
    fn f(&self, t: f64) -> f64 {
        if self.log { t.ln() } else { t }
    }
    fn unit(&self, n: f64, t: f64) -> Unit {
        ((n - self.n.0) / (self.n.1 - self.n.0), (self.f(t) - self.lt.0) / (self.lt.1 - self.lt.0))
    }
    fn back(&self, (u, v): Unit) -> (f64, f64) {
        let t = self.lt.0 + v * (self.lt.1 - self.lt.0);
        (self.n.0 + u * (self.n.1 - self.n.0), if self.log { t.exp() } else { t })
    }
}

/// The position of a point of the unit square's edge along its perimeter, counter-clockwise
/// from the lower-left corner (bottom 0–1, right 1–2, top 2–3, left 3–4), from the nearest edge.
fn perimeter((u, v): Unit) -> f64 {
    let d = [v, 1.0 - u, 1.0 - v, u];
    let edge = (0..4).min_by(|&a, &b| d[a].total_cmp(&d[b])).unwrap_or(0);
    match edge {
        0 => u,
        1 => 1.0 + v,
        2 => 3.0 - u,
        _ => 4.0 - v,
    }
}

/// The curve (unit coordinates, clamped into the square) closed along the square's edge from
/// its last point back to its first, counter-clockwise when `ccw`, through the corners between.
fn closed(curve: &[Unit], ccw: bool) -> Vec<Unit> {
    const CORNERS: [(f64, Unit); 4] = [(0.0, (0.0, 0.0)), (1.0, (1.0, 0.0)), (2.0, (1.0, 1.0)), (3.0, (0.0, 1.0))];
    let mut out = curve.to_vec();
    let (Some(&last), Some(&first)) = (curve.last(), curve.first()) else { return out };
    let (a, b) = (perimeter(last), perimeter(first));
    // Distance travelled along the perimeter from a, in the walk's direction.
    let along = |t: f64| if ccw { (t - a).rem_euclid(4.0) } else { (a - t).rem_euclid(4.0) };
    let mut corners: Vec<(f64, Unit)> =
        CORNERS.iter().map(|&(t, p)| (along(t), p)).filter(|&(d, _)| d > 0.0 && d < along(b)).collect();
    corners.sort_by(|x, y| x.0.total_cmp(&y.0));
    out.extend(corners.into_iter().map(|(_, p)| p));
    out
}

/// Even–odd point-in-polygon test.
fn contains(poly: &[Unit], (x, y): Unit) -> bool {
    let mut inside = false;
    for (i, &(xa, ya)) in poly.iter().enumerate() {
        let (xb, yb) = poly[(i + 1) % poly.len()];
        if (ya > y) != (yb > y) && x < xa + (y - ya) / (yb - ya) * (xb - xa) {
            inside = !inside;
        }
    }
    inside
}

/// The widest interval of the polygon along the line v = `v` (even–odd), as its midpoint.
fn widest_inside(poly: &[Unit], v: f64) -> Option<Unit> {
    let mut xs: Vec<f64> = (0..poly.len())
        .filter_map(|i| {
            let ((xa, ya), (xb, yb)) = (poly[i], poly[(i + 1) % poly.len()]);
            ((ya > v) != (yb > v)).then(|| xa + (v - ya) / (yb - ya) * (xb - xa))
        })
        .collect();
    xs.sort_by(f64::total_cmp);
    xs.chunks_exact(2).max_by(|a, b| (a[1] - a[0]).total_cmp(&(b[1] - b[0]))).map(|w| (0.5 * (w[0] + w[1]), v))
}

/// A boundary's region as a closed polygon in unit coordinates: the curve closed along the
/// map's edge on the side that holds the region just past one of its codimension-two points
/// (between the two crossings nearest its order, both close to it: inside a jump wedge above
/// its cusp in torque, below it in a damping, inside a unison-loss tongue above its onset).
/// The points are tried from the lowest up, above before below. None for a boundary without
/// such a point, whose inside the map alone cannot tell.
fn region(r: &EnvelopeResult, frame: &Frame, i: usize) -> Option<Vec<Unit>> {
    let b = &r.boundaries[i];
    let mut points: Vec<&MapPoint> = r.points.iter().filter(|p| p.boundary == i).collect();
    points.sort_by(|a, c| a.second_value.total_cmp(&c.second_value));
    let curve: Vec<Unit> = b
        .values
        .iter()
        .zip(&b.second_values)
        .map(|(&n, &t)| {
            let (u, v) = frame.unit(n, t);
            (u.clamp(0.0, 1.0), v.clamp(0.0, 1.0))
        })
        .collect();
    // Just past the point (a hundredth of the way to the map's edge), between the two
    // crossings nearest its order (both lie on one side of a cusp, which is a spike), both within
    // a tenth of the map's width of it.
    let inside = |p: &MapPoint, up: bool| -> Option<Unit> {
        let (up_, vp) = frame.unit(p.value, p.second_value);
        let v = if up { vp + 0.01 * (1.0 - vp) } else { vp - 0.01 * vp };
        let t = frame.back((0.0, v)).1;
        let mut x = crossings(b, t, |t| frame.f(t));
        x.sort_by(|a, c| (a - p.value).abs().total_cmp(&(c - p.value).abs()));
        let (&a, &c) = (x.first()?, x.get(1)?);
        let q = frame.unit(0.5 * (a + c), t);
        let near = |n: f64| (frame.unit(n, t).0 - up_).abs() < 0.1;
        (near(a) && near(c)).then_some(q)
    };
    let q = points.iter().find_map(|p| inside(p, true).or_else(|| inside(p, false)))?;
    [true, false].into_iter().map(|ccw| closed(&curve, ccw)).find(|poly| contains(poly, q))
}

/// The chart: each boundary's region tinted and named, the boundaries drawn, the
/// codimension-two points marked.
pub(super) fn panel(r: &EnvelopeResult) -> Panel {
    let frame = Frame::of(r);
    let mut series = Vec::new();
    let mut labels = Vec::new();
    let color = |k: BoundaryKind| match k {
        BoundaryKind::Jump => 1,
        BoundaryKind::UnisonLoss => 3,
        BoundaryKind::PeriodDoubling => 5,
    };
    let mut legend = [true, true, true];
    let mut jump_regions = Vec::new();
    for (i, b) in r.boundaries.iter().enumerate() {
        let c = color(b.kind);
        if let Some(poly) = region(r, &frame, i) {
            let (x, y): (Vec<f64>, Vec<f64>) = poly.iter().map(|&p| frame.back(p)).unzip();
            series.push(Series { label: String::new(), x, y, color: c, style: LineStyle::Region });
            // The region's name three quarters of the way up from its lowest point, in its
            // widest part there.
            let low = poly.iter().map(|p| p.1).fold(1.0, f64::min);
            let high = poly.iter().map(|p| p.1).fold(0.0, f64::max);
            // (A region that narrows upwards, a jump wedge below its cusp in a damping, is named a
            // quarter of the way up instead.)
            let at = widest_inside(&poly, low + 0.75 * (high - low))
                .filter(|&q| contains(&poly, q))
                .or_else(|| widest_inside(&poly, low + 0.25 * (high - low)));
            if let Some(at) = at {
                let (x, y) = frame.back(at);
                let text = match b.kind {
                    BoundaryKind::Jump => "several states: jump possible",
                    BoundaryKind::UnisonLoss => "unison lost",
                    BoundaryKind::PeriodDoubling if b.set.is_some() => "period doubled, out of unison",
                    BoundaryKind::PeriodDoubling => "period doubled",
                };
                labels.push(PointLabel { x, y, text: text.into(), marker: false });
            }
            if b.kind == BoundaryKind::Jump {
                jump_regions.push(poly);
            }
        }
        let k = match b.kind {
            BoundaryKind::Jump => 0,
            BoundaryKind::UnisonLoss => 1,
            BoundaryKind::PeriodDoubling => 2,
        };
        let label = if std::mem::take(&mut legend[k]) {
            match b.kind {
                BoundaryKind::Jump => "jump boundary (folds)".to_string(),
                BoundaryKind::UnisonLoss => "unison-loss boundary (+1 branch points)".to_string(),
                BoundaryKind::PeriodDoubling => "period-doubling boundary (−1 multipliers)".to_string(),
            }
        } else {
            String::new()
        };
        let style = if b.kind == BoundaryKind::Jump { LineStyle::Solid } else { LineStyle::Dashed };
        series.push(Series { label, x: b.values.clone(), y: b.second_values.clone(), color: c, style });
    }
    for p in &r.points {
        labels.push(PointLabel {
            x: p.value,
            y: p.second_value,
            text: format!("{} {}, {}", p.kind.words(), r.value_words(p.value, 6), r.second_words(p.second_value, 4)),
            marker: true,
        });
    }
    // "One steady state" where no jump region reaches: the first free one of a few places.
    for at in [(0.2, 0.15), (0.8, 0.15), (0.5, 0.05), (0.15, 0.85), (0.85, 0.85)] {
        if jump_regions.iter().all(|poly| !contains(poly, at)) {
            let (x, y) = frame.back(at);
            labels.push(PointLabel { x, y, text: "one steady state".into(), marker: false });
            break;
        }
    }
    Panel {
        title: format!("Operating envelope {}", r.held_words()),
        x_label: match r.parameter.as_str() {
            "order" => "excitation order n",
            TORQUE_COLUMN => "torque amplitude T, N·m",
            _ => "mean speed, rpm",
        }
        .into(),
        y_label: r.second_label.clone(),
        log_y: r.log_second,
        x_range: Some((r.range[0], r.range[1])),
        y_range: Some((r.second_range[0], r.second_range[1])),
        series,
        labels,
        ..Panel::default()
    }
}

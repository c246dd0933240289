//! plotters' SVG back at nominal size ([`vector`]) and the groups that let a reader of a figure
//! tell its panels and curves apart ([`groups_for_readers`]).

use super::*;
use std::fmt::Write as _;

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
pub(super) fn vector_tag(tag: &str) -> String {
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
pub(super) fn rescale(root: bool, name: &str, value: &str) -> String {
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
pub(super) fn coord(v: &str) -> String {
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
pub(super) fn trim(s: String) -> String {
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

/// Starts a marker that [`groups_for_readers`] turns into an SVG `<g>` tag: a text element whose
/// content begins with this private-use character. plotters writes no groups of its own, and
/// a drawn text is the one element whose content it passes through untouched (escaped).
pub(super) const MARK: char = '\u{E000}';
/// Separates the fields of a marker (labels may hold spaces).
pub(super) const FIELD: char = '\u{E001}';

/// Turns the marker texts that [`fill`] draws into groups: `panel` opens a
/// `<g class="kd-panel">` that carries the axes' mapping (`data-px`: the pixel columns of the
/// x range's ends, `data-py`: the pixel rows of the y range's ends, `data-x`, `data-y`: those
/// ends in data units, `data-log-y`, the axis labels), `series` opens a `<g class="kd-series">`
/// with the curve's label, `end` closes a group. A reader of the figure (report.html's zoom
/// and hover layer) can then tell the curves from the grid and turn a point's pixels back into
/// data values, without the figure carrying its data twice.
pub(super) fn groups_for_readers(svg: &str) -> String {
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
pub(super) fn mark<'a, X, Y>(
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

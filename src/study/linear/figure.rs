//! The linear response's figure (the paper's Fig. 2): per variant the response normalised by
//! the locked twin (or per unit torque without one) against the order, with the tuning order n_t
//! and the rotor's eigen-order n_r marked, and a panel of the elements per N·m.

use super::{LinearResponseSpec, LinearResult, legend};
use crate::error::Result;
use crate::plot::{LineStyle, Panel, Series};
use crate::study::Study;
use std::path::{Path, PathBuf};

/// `<name>.svg`: the response panel and, with elements, their panel.
pub(super) fn response_figure(
    study: &Study,
    spec: &LinearResponseSpec,
    result: &LinearResult,
    dir: &Path,
) -> Result<PathBuf> {
    let legends: Vec<String> = result
        .variants
        .iter()
        .map(|r| {
            spec.variants.iter().find(|v| v.label == r.label).map_or_else(|| r.label.clone(), |v| legend(study, v))
        })
        .collect();
    let mut panels = vec![response_panel(study, spec, result, &legends)];
    panels.extend(element_panel(spec, result, &legends));
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 480)?;
    Ok(svg)
}

/// The orders' scale on the axis: n_t for `relative` orders, else 1.
fn scale(spec: &LinearResponseSpec, result: &LinearResult) -> f64 {
    if spec.relative { result.n_t.unwrap_or(1.0) } else { 1.0 }
}

/// The axis label of the orders.
fn x_label(spec: &LinearResponseSpec) -> &'static str {
    if spec.relative { "n / n_t" } else { "excitation order n" }
}

/// The markers of n_t and of the rotor eigen-order n_r: the free mode nearest n_t (for a CPVA,
/// eq. 17), unless it is n_t itself.
fn markers(spec: &LinearResponseSpec, result: &LinearResult) -> Vec<(f64, String)> {
    let (n_t, scale) = (result.n_t, scale(spec, result));
    let mut markers = Vec::new();
    if let Some(nt) = n_t {
        markers.push((nt / scale, "n_t".to_string()));
    }
    if let (Some(nt), Some((nr, _))) = (
        n_t,
        result
            .free_orders
            .iter()
            .min_by(|a, b| (a.0 - n_t.unwrap_or(0.0)).abs().total_cmp(&(b.0 - n_t.unwrap_or(0.0)).abs())),
    ) && (nr - nt).abs() > 1e-9
    {
        markers.push((nr / scale, "n_r".to_string()));
    }
    markers
}

/// The response per variant: normalised by the locked twin with the line of unity, or (without
/// a locked twin) per unit torque.
fn response_panel(study: &Study, spec: &LinearResponseSpec, result: &LinearResult, legends: &[String]) -> Panel {
    // Without a locked twin the response is not normalised: ratios, n_t and the crossing of 1 do
    // not apply, and none is drawn (they would read 1 and NaN).
    let normalised = !study.spec.lock.is_empty();
    let scale = scale(spec, result);
    let mut series: Vec<Series> = result
        .variants
        .iter()
        .enumerate()
        .map(|(k, r)| Series {
            label: legends[k].clone(),
            x: r.orders.iter().map(|n| n / scale).collect(),
            y: if normalised { r.ratio.clone() } else { r.response.clone() },
            color: k,
            style: LineStyle::Solid,
        })
        .collect();
    if normalised {
        series.push(Series {
            label: "unity".into(),
            x: vec![spec.from, spec.to],
            y: vec![1.0, 1.0],
            color: 7,
            style: LineStyle::Dotted,
        });
    }
    let body = &study.spec.response_body;
    Panel {
        title: if normalised {
            format!("Linear response normalised by the locked twin, {} rpm", spec.rpm)
        } else {
            format!("Linear response, {} rpm", spec.rpm)
        },
        x_label: x_label(spec).into(),
        y_label: if normalised {
            format!("{body} acceleration / locked")
        } else {
            format!("{body} acceleration per torque, rad/s² per N·m")
        },
        log_y: true,
        x_range: Some((spec.from, spec.to)),
        markers: markers(spec, result),
        series,
        ..Panel::default()
    }
}

/// The elements' amplitudes per N·m: one curve per element and variant (None without elements).
fn element_panel(spec: &LinearResponseSpec, result: &LinearResult, legends: &[String]) -> Option<Panel> {
    let (results, scale) = (&result.variants, scale(spec, result));
    let element_series: Vec<Series> = results
        .iter()
        .enumerate()
        .flat_map(|(v, r)| {
            let legend = &legends[v];
            r.elements.iter().enumerate().map(move |(e, el)| Series {
                label: if results.len() > 1 { format!("{} ({legend})", el.joint) } else { el.joint.clone() },
                x: r.orders.iter().map(|n| n / scale).collect(),
                y: el.amplitude.clone(),
                color: e,
                style: [LineStyle::Solid, LineStyle::Dashed, LineStyle::Dotted][v % 3],
            })
        })
        .collect();
    (!element_series.is_empty()).then(|| Panel {
        title: format!("Elements per N·m, {} rpm", spec.rpm),
        x_label: x_label(spec).into(),
        y_label: "amplitude per torque, rad per N·m (m per N·m for slides)".into(),
        log_y: true,
        x_range: Some((spec.from, spec.to)),
        series: element_series,
        ..Panel::default()
    })
}

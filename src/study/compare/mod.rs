//! The comparison analysis: the same analyses run on several mechanisms (absorber paths, design
//! alternatives), each mechanism's results written as the analyses write them, plus one overlay
//! figure per analysis and a comparison table.
//!
//! Each mechanism becomes a study of its own (the study file's settings, that mechanism, the
//! comparison's analyses renamed `<comparison>_<label>_<analysis>` so their files and results
//! stay apart), read and checked when the study file is read: an error in a compared mechanism
//! or in an analysis that does not fit it is located in the study file. At run time one
//! mechanism's failure costs the others nothing, and each inner analysis has the watchdog's
//! budget of its own plan, so one that overruns costs the others no time either.
//!
//! Overlays: order sweeps and harmonic-balance branches draw the response's main order and the
//! first reported element's main-order amplitude per torque amplitude, one colour per mechanism
//! (sweeps: up solid, down dashed; branches: stable solid, unstable dashed); free oscillations
//! draw every mechanism's backbone in one panel. The other kinds keep their own figures.

mod analysis;
mod spec;
pub use spec::*;

use super::backbone::{self, FreeOscillationResult};
use super::hbm::HbmBranch;
use super::sweep::SweepRun;
use super::table::fmt_num;
use super::{AnalysisSpec, Direction, LoadOptions, Output, Study, StudyReport, StudySpec};
use crate::error::{Error, Result};
use crate::io::Source;
use crate::plot::{LineStyle, Panel, Series};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Most mechanisms in one comparison (the palette's colours).
pub(crate) const MAX_MECHANISMS: usize = 8;

/// The studies of one comparison: per mechanism, its label and its study.
pub type Compared = Vec<(String, Study)>;

/// An overlay figure (if the kind has one) and a finding per mechanism `(label, finding)`.
type Overlay = (Option<PathBuf>, Vec<(String, String)>);

/// What a comparison ran.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct CompareResult {
    /// The analysis name.
    pub name: String,
    /// Per mechanism, in the file's order.
    pub mechanisms: Vec<ComparedMechanism>,
}

/// One mechanism of a comparison.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ComparedMechanism {
    /// Its label.
    pub label: String,
    /// Its mechanism's name.
    pub mechanism: String,
    /// The names its analyses ran under (`<comparison>_<label>_<analysis>`), in the file's order.
    pub analyses: Vec<String>,
    /// Per analysis: whether it ran to the end.
    pub completed: Vec<bool>,
}

/// The name an analysis of comparison `c` runs under for mechanism `label`.
fn inner_name(c: &str, label: &str, analysis: &str) -> String {
    format!("{c}_{label}_{analysis}")
}

/// `a` renamed for mechanism `label` of comparison `c` (with the analyses it names).
pub(crate) fn renamed(c: &str, label: &str, a: &AnalysisSpec) -> AnalysisSpec {
    let mut a = a.clone();
    a.rename(&|n| inner_name(c, label, n));
    a
}

/// Reads every comparison's mechanisms as studies of their own (see the module docs); errors
/// are moved to their place in the study file.
pub(crate) fn load(spec: &StudySpec, src: &Source, opts: &LoadOptions) -> Result<Vec<(usize, Compared)>> {
    let mut out = Vec::new();
    for (k, a) in spec.analyses.iter().enumerate() {
        let AnalysisSpec::Compare(c) = a else { continue };
        let mut studies = Vec::with_capacity(c.mechanisms.len());
        for (v, m) in c.mechanisms.iter().enumerate() {
            let analyses = c.analyses.iter().map(|a| renamed(&c.name, &m.label, a)).collect();
            let sub = StudySpec {
                mechanism: m.mechanism.clone(),
                analyses,
                lock: m.lock.clone().unwrap_or_else(|| spec.lock.clone()),
                elements: m.elements.clone().unwrap_or_else(|| spec.elements.clone()),
                ..spec.clone()
            };
            let study = Study::from_spec(sub, src.clone(), opts).map_err(|e| relocate(e, src, k, v, &m.label))?;
            studies.push((m.label.clone(), study));
        }
        out.push((k, studies));
    }
    Ok(out)
}

/// An error of mechanism `v` (labelled `label`) of comparison `k`, located in the study file:
/// an analysis's field under the comparison's `analyses`, anything else (the mechanism file
/// itself, a joint or body the mechanism lacks) at the mechanism's entry. Errors located in
/// other files (the mechanism's own) stay where they are.
fn relocate(e: Error, src: &Source, k: usize, v: usize, label: &str) -> Error {
    // A limit's refusal moved to its place is still a limit's.
    let limit = e.is_limit();
    match e {
        Error::Input { location, message } | Error::Limit { location, message } if location.file == src.file => {
            let path = &location.path;
            if let Some(rest) = path.strip_prefix("analyses") {
                src.error(&format!("analyses[{k}].analyses{rest}"), message)
            } else {
                let field = if path == "mechanism" {
                    format!("analyses[{k}].mechanisms[{v}].mechanism")
                } else {
                    format!("analyses[{k}].mechanisms[{v}]")
                };
                src.error(&field, format!("mechanism `{label}`: {path}: {message}"))
            }
        }
        other => other,
    }
    .limit_if(limit)
}

/// Runs the comparison's analyses on each mechanism, then writes the overlays and the table.
pub(crate) fn run(
    study: &Study,
    spec: &CompareSpec,
    dir: &Path,
    progress: &super::sim::Progress,
    report: &mut StudyReport,
) -> Result<Output> {
    let studies = study
        .sub_studies
        .iter()
        .find(|(k, _)| study.spec.analyses.get(*k).is_some_and(|a| a.name() == spec.name))
        .map(|(_, s)| s)
        .ok_or_else(|| Error::Model {
            mechanism: study.mechanism.name.clone(),
            message: format!("comparison `{}` was not prepared", spec.name),
        })?;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "## Comparison `{}`: {} on {}\n",
        spec.name,
        spec.analyses.iter().map(|a| format!("{} `{}`", a.kind(), a.name())).collect::<Vec<_>>().join(", "),
        studies.iter().map(|(l, s)| format!("`{l}` ({})", s.mechanism.name)).collect::<Vec<_>>().join(", ")
    );
    let mut mechanisms = Vec::with_capacity(studies.len());
    let mut sections = String::new();
    for (label, sub) in studies {
        let mut completed = Vec::with_capacity(sub.spec.analyses.len());
        let _ = writeln!(sections, "### Mechanism `{label}` (`{}`)\n", sub.mechanism.name);
        let plan = sub.plan();
        for (i, a) in sub.spec.analyses.iter().enumerate() {
            let timed = own_budget(study, sub, plan.analyses[i].cpu_s);
            let (section, done) = run_guarded_inner(timed.as_ref().unwrap_or(sub), a, dir, progress, report);
            completed.push(done);
            sections += &demote(&section);
        }
        mechanisms.push(ComparedMechanism {
            label: label.clone(),
            mechanism: sub.mechanism.name.clone(),
            analyses: sub.spec.analyses.iter().map(|a| a.name().to_string()).collect(),
            completed,
        });
    }
    let result = CompareResult { name: spec.name.clone(), mechanisms };
    let mut files = Vec::new();
    let _ = writeln!(md, "| analysis | mechanism | finding |\n|---|---|---|");
    for (i, a) in spec.analyses.iter().enumerate() {
        let names: Vec<(String, String)> =
            result.mechanisms.iter().map(|m| (m.label.clone(), m.analyses[i].clone())).collect();
        let (figure, rows) = overlay(a, &names, report, dir, &spec.name)?;
        files.extend(figure);
        for (label, finding) in rows {
            let _ = writeln!(md, "| {} `{}` | `{label}` | {finding} |", a.kind(), a.name());
        }
    }
    md.push('\n');
    for f in &files {
        let _ = writeln!(md, "Overlay: `{}`.", f.file_name().map(|n| n.to_string_lossy()).unwrap_or_default());
    }
    md.push('\n');
    md += &sections;
    Ok(Output { markdown: md, files, failures: Vec::new(), results: Box::new(result) })
}

/// Mechanism `sub` with the watchdog's budget of one inner analysis planned at `cpu_s`, counted
/// from now: each inner analysis gets its own share as a top-level analysis does, so one that
/// runs away (a torque that whirls a pendulum) is stopped alone and cannot leave the
/// mechanisms after it unrun. `None` when the comparison runs without a watchdog (a library
/// call without a deadline).
fn own_budget(study: &Study, sub: &Study, cpu_s: f64) -> Option<Study> {
    let watchdog = study.spec.integration.watchdog;
    study.spec.integration.deadline.map(|_| sub.with_deadline(watchdog.budget_s(cpu_s)))
}

/// One inner analysis, contained like a top-level one; its failures carry no location prefix
/// here (the study runner adds the comparison's).
fn run_guarded_inner(
    sub: &Study,
    a: &AnalysisSpec,
    dir: &Path,
    progress: &super::sim::Progress,
    report: &mut StudyReport,
) -> (String, bool) {
    let before = report.failures.len();
    let (section, done) = super::run_guarded(sub, a, "", dir, progress, report);
    for f in &mut report.failures[before..] {
        // `run_guarded` wrote "Kind `name` (): …"; the empty location is dropped.
        *f = f.replacen(" (): ", ": ", 1);
    }
    (section, done)
}

/// The summary section of an inner analysis, its headings one level down.
fn demote(section: &str) -> String {
    section.lines().map(|l| if l.starts_with('#') { format!("##{l}\n") } else { format!("{l}\n") }).collect()
}

/// The overlay figure of analysis `a` over the mechanisms (`(label, inner name)`), if its kind
/// has one, and a finding per mechanism for the comparison table.
fn overlay(
    a: &AnalysisSpec,
    names: &[(String, String)],
    report: &StudyReport,
    dir: &Path,
    cname: &str,
) -> Result<Overlay> {
    let path = dir.join(format!("{cname}_{}.svg", a.name()));
    match a {
        AnalysisSpec::OrderSweep(s) => sweep_overlay(s, names, report, path),
        AnalysisSpec::HarmonicBalance(h) => hbm_overlay(h, names, report, path),
        AnalysisSpec::FreeOscillation(_) => free_overlay(names, report, path),
        _ => Ok((None, Vec::new())),
    }
}

/// An order sweep's overlay: per amplitude, the main-order response and the first element's
/// main-order amplitude of every mechanism, up solid and down dashed; per mechanism and run its
/// smallest response after the ramp-in and the first element's peak.
fn sweep_overlay(
    s: &super::SweepSpec,
    names: &[(String, String)],
    report: &StudyReport,
    path: PathBuf,
) -> Result<Overlay> {
    let mut panels = Vec::new();
    let mut rows = Vec::new();
    for &amp in &s.amplitudes {
        let (mut resp, mut elem) = (Vec::new(), Vec::new());
        for (c, (label, name)) in names.iter().enumerate() {
            let runs: Vec<&SweepRun> =
                report.sweeps.iter().filter(|r| &r.analysis == name && !r.locked && r.amplitude == amp).collect();
            for r in &runs {
                let style = if r.direction == Direction::Up { LineStyle::Solid } else { LineStyle::Dashed };
                let dir_word = if r.direction == Direction::Up { "up" } else { "down" };
                if let Some(t) = r.trace(1.0) {
                    resp.push(Series {
                        label: format!("{label}, {dir_word}"),
                        x: t.order.clone(),
                        y: t.amplitude.clone(),
                        color: c,
                        style,
                    });
                    let (o, v) = min_after(&t.order, &t.amplitude, &t.time_s, 5.0);
                    let el = r.elements.first();
                    let peak = el.map_or(f64::NAN, |e| e.peak);
                    rows.push((
                        label.clone(),
                        format!(
                            "{} N·m {dir_word}: smallest main-order response {} rad/s² at order {}; largest `{}` {} {}",
                            fmt_num(amp),
                            super::cell(v, 1),
                            super::cell(o, 4),
                            el.map_or("", |e| e.joint.as_str()),
                            super::cell(peak, 5),
                            el.map_or("", |e| e.unit),
                        ),
                    ));
                }
                if let Some(e) = r.elements.first()
                    && let Some(t) = e.traces.iter().find(|t| (t.multiple - 1.0).abs() < 1e-12)
                {
                    elem.push(Series {
                        label: format!("{label}, {dir_word}"),
                        x: t.order.clone(),
                        y: t.amplitude.clone(),
                        color: c,
                        style,
                    });
                }
            }
        }
        let unit = first_unit(report, names);
        panels.push(Panel {
            title: format!("{} N·m: response, main order", fmt_num(amp)),
            x_label: "excitation order n".into(),
            y_label: "main-order acceleration, rad/s²".into(),
            x_range: Some((s.order_min, s.order_max)),
            series: resp,
            ..Panel::default()
        });
        panels.push(Panel {
            title: format!("{} N·m: first element, main order", fmt_num(amp)),
            x_label: "excitation order n".into(),
            y_label: format!("main-order amplitude, {unit}"),
            x_range: Some((s.order_min, s.order_max)),
            series: elem,
            ..Panel::default()
        });
    }
    crate::plot::write_svg(&path, &panels, 620, 460)?;
    Ok((Some(path), rows))
}

/// A harmonic balance's overlay: per amplitude, every mechanism's branches (response and first
/// element, stable solid, unstable dashed); per mechanism its folds.
fn hbm_overlay(h: &super::HbmSpec, names: &[(String, String)], report: &StudyReport, path: PathBuf) -> Result<Overlay> {
    let mut panels = Vec::new();
    let mut rows = Vec::new();
    let amps: Vec<f64> = if h.amplitudes.is_empty() { vec![f64::NAN] } else { h.amplitudes.clone() };
    for &amp in &amps {
        let (mut resp, mut elem) = (Vec::new(), Vec::new());
        for (c, (label, name)) in names.iter().enumerate() {
            let branches: Vec<&HbmBranch> =
                report.hbm.iter().filter(|b| &b.analysis == name && (b.amplitude == amp || amp.is_nan())).collect();
            let mut folds: Vec<f64> = branches.iter().flat_map(|b| b.folds.iter().copied()).collect();
            folds.sort_by(f64::total_cmp);
            folds.dedup_by(|a, b| (*a - *b).abs() <= 1e-6 * b.abs().max(1.0));
            rows.push((
                label.clone(),
                format!(
                    "{} N·m: folds at {}",
                    fmt_num(amp),
                    if folds.is_empty() {
                        "none (no jump)".to_string()
                    } else {
                        folds.iter().map(|f| format!("{f:.4}")).collect::<Vec<_>>().join(", ")
                    }
                ),
            ));
            for (bi, b) in branches.iter().enumerate() {
                push_stability(&mut resp, label, bi == 0, c, &b.curve_parameter, &b.curve_accel[0], &b.curve_stable);
                let e: Vec<f64> = b
                    .elements
                    .iter()
                    .map(|p| p.first().and_then(|e| e.amplitude.first().copied()).unwrap_or(f64::NAN))
                    .collect();
                push_stability(&mut elem, label, bi == 0, c, &b.parameter, &e, &b.stable);
            }
        }
        let unit = first_unit(report, names);
        let x_label = match h.parameter {
            super::HbmParameter::Order => "excitation order n".to_string(),
            super::HbmParameter::Speed { .. } => "speed, rpm".to_string(),
            super::HbmParameter::Torque { .. } => "torque amplitude, N·m".to_string(),
        };
        panels.push(Panel {
            title: format!("{} N·m: harmonic balance, response", fmt_num(amp)),
            x_label: x_label.clone(),
            y_label: "main-order acceleration, rad/s²".into(),
            series: resp,
            ..Panel::default()
        });
        panels.push(Panel {
            title: format!("{} N·m: harmonic balance, first element", fmt_num(amp)),
            x_label,
            y_label: format!("main-order amplitude, {unit}"),
            series: elem,
            ..Panel::default()
        });
    }
    crate::plot::write_svg(&path, &panels, 620, 460)?;
    Ok((Some(path), rows))
}

/// A free oscillation's overlay: every mechanism's backbone; per mechanism its linear order and
/// how far the order has moved at the largest amplitude.
fn free_overlay(names: &[(String, String)], report: &StudyReport, path: PathBuf) -> Result<Overlay> {
    let results: Vec<(String, &FreeOscillationResult)> =
        names.iter().filter_map(|(l, n)| report.free.iter().find(|r| &r.name == n).map(|r| (l.clone(), r))).collect();
    let rows = results
        .iter()
        .map(|(l, r)| {
            let ratios = r.order_ratios();
            let last = ratios.iter().rev().find(|v| v.is_finite()).copied().unwrap_or(f64::NAN);
            let top = r.amplitudes.last().copied().unwrap_or(f64::NAN);
            (
                l.clone(),
                format!(
                    "linear order {:.5}; at {} {} the order is {} of it",
                    r.linear_order,
                    fmt_num(top),
                    r.unit,
                    super::cell(last, 6)
                ),
            )
        })
        .collect();
    crate::plot::write_svg(&path, &[backbone::panel(&results)], 760, 520)?;
    Ok((Some(path), rows))
}

/// The unit of the first element reported by any of the sweeps or branches of `names`.
fn first_unit(report: &StudyReport, names: &[(String, String)]) -> &'static str {
    let is = |n: &str| names.iter().any(|(_, m)| m == n);
    report
        .sweeps
        .iter()
        .filter(|r| is(&r.analysis))
        .find_map(|r| r.elements.first().map(|e| e.unit))
        .or_else(|| {
            report.hbm.iter().filter(|b| is(&b.analysis)).find_map(|b| b.elements.first()?.first().map(|e| e.unit))
        })
        .unwrap_or("")
}

/// The smallest value of a trace after `t0` seconds, with its order: the antiresonance a
/// sweep passes.
fn min_after(order: &[f64], y: &[f64], t: &[f64], t0: f64) -> (f64, f64) {
    order
        .iter()
        .zip(y)
        .zip(t)
        .filter(|((_, v), t)| **t >= t0 && v.is_finite())
        .map(|((o, v), _)| (*o, *v))
        .fold((f64::NAN, f64::INFINITY), |b, p| if p.1 < b.1 { p } else { b })
}

/// Splits a curve into runs of equal stability: solid where stable (or not computed), dashed
/// where unstable; the first run of the first branch carries the legend.
fn push_stability(
    series: &mut Vec<Series>,
    label: &str,
    legend: bool,
    color: usize,
    x: &[f64],
    y: &[f64],
    stable: &[Option<bool>],
) {
    let len = x.len().min(y.len()).min(stable.len());
    let mut i = 0;
    let mut first = legend;
    while i < len {
        let s = stable[i] != Some(false);
        let mut j = i;
        while j + 1 < len && (stable[j + 1] != Some(false)) == s {
            j += 1;
        }
        let end = (j + 1).min(len - 1);
        series.push(Series {
            label: if first { label.to_string() } else { String::new() },
            x: x[i..=end].to_vec(),
            y: y[i..=end].to_vec(),
            color,
            style: if s { LineStyle::Solid } else { LineStyle::Dashed },
        });
        first = false;
        i = j + 1;
    }
}

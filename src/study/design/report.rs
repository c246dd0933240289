//! What a design study writes: its CSV table with status and error, its figure and its summary
//! section.

use super::{CaseRow, DesignResult, DesignSpec, Sampling, parameter_columns};
use crate::error::{Error, Result};
use crate::study::{AnalysisSpec, Study};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Which group of the figure a case falls in.
type Grouping = Box<dyn Fn(&CaseRow) -> usize>;

/// Most groups of cases drawn apart in the figure (the palette's size).
const GROUPS: usize = 8;

/// The figure: the first result (a harmonic balance's peak main-order acceleration, on a log
/// axis; a linear response's n_t) against the first parameter, one colour per value of the second
/// parameter (a grid's values when there are at most eight, else eight equal bins of its range).
/// A grid of at most two parameters is drawn as lines through the first parameter's values;
/// anything else as points, which a line would join in no meaningful order.
pub(super) fn figure(spec: &DesignSpec, r: &DesignResult) -> crate::plot::Panel {
    use crate::plot::{LineStyle, Panel, Series};
    let x_col = &r.parameters[0];
    let y_col = r.results.first().map_or(("", "1"), |c| (c.name.as_str(), c.unit));
    let second = r.parameters.get(1).map(|c| c.name.clone());
    let mut distinct: Vec<f64> = r.cases.iter().filter_map(|c| c.values.get(1).copied()).collect();
    distinct.sort_by(f64::total_cmp);
    distinct.dedup();
    let lines = spec.sampling == Sampling::Grid && r.parameters.len() <= 2 && distinct.len() <= GROUPS;
    // Each case's group and the groups' labels.
    let (group, labels): (Grouping, Vec<String>) = match &second {
        None => (Box::new(|_| 0), vec![String::new()]),
        Some(name) if distinct.len() <= GROUPS => {
            let labels = distinct.iter().map(|v| format!("{name} = {v}")).collect();
            let d = distinct.clone();
            (Box::new(move |c: &CaseRow| d.iter().position(|v| *v == c.values[1]).unwrap_or(0)), labels)
        }
        Some(name) => {
            let (lo, hi) = (distinct[0], distinct[distinct.len() - 1]);
            let log = spec.parameters[1].log && lo > 0.0;
            let t = move |v: f64| if log { (v / lo).ln() / (hi / lo).ln() } else { (v - lo) / (hi - lo) };
            let edge = move |k: usize| {
                let f = k as f64 / GROUPS as f64;
                if log { lo * (hi / lo).powf(f) } else { lo + (hi - lo) * f }
            };
            let labels = (0..GROUPS).map(|k| format!("{name} {:.3e} to {:.3e}", edge(k), edge(k + 1))).collect();
            (Box::new(move |c: &CaseRow| ((t(c.values[1]) * GROUPS as f64) as usize).min(GROUPS - 1)), labels)
        }
    };
    let series = labels
        .iter()
        .enumerate()
        .map(|(k, label)| {
            let mut pts: Vec<(f64, f64)> = r
                .cases
                .iter()
                .filter(|c| group(c) == k)
                .map(|c| (c.values[0], c.results.first().copied().unwrap_or(f64::NAN)))
                .collect();
            pts.sort_by(|a, b| a.0.total_cmp(&b.0));
            Series {
                label: label.clone(),
                x: pts.iter().map(|p| p.0).collect(),
                y: pts.iter().map(|p| p.1).collect(),
                color: k,
                style: if lines { LineStyle::Solid } else { LineStyle::Points },
            }
        })
        .collect();
    Panel {
        title: format!("Design study `{}`: {} cases", spec.name, r.cases.len()),
        x_label: format!("{} ({})", x_col.name, x_col.unit),
        y_label: format!("{} ({})", y_col.0, y_col.1),
        log_y: matches!(spec.analysis.as_ref(), AnalysisSpec::HarmonicBalance(_)),
        series,
        ..Panel::default()
    }
}

/// `name = value, …` of a case.
pub(super) fn describe_case(r: &DesignResult, c: &CaseRow) -> String {
    r.parameters.iter().zip(&c.values).map(|(p, v)| format!("{} = {v}", p.name)).collect::<Vec<_>>().join(", ")
}

/// Writes `<name>.csv`: `case`, the parameters, the results (empty cells for NaN), `status`,
/// `error`.
pub(super) fn write_csv(r: &DesignResult, dir: &Path) -> Result<PathBuf> {
    let path = dir.join(format!("{}.csv", r.name));
    let io = |e: csv::Error| Error::Io { file: path.clone(), action: "cannot write", source: e.into() };
    let mut w = crate::study::output::CsvWriter::from_path(&path).map_err(io)?;
    let mut header = vec!["case".to_string()];
    header.extend(r.parameters.iter().chain(&r.results).map(|c| c.name.clone()));
    header.extend(["status".to_string(), "error".to_string()]);
    w.write_record(&header).map_err(io)?;
    for c in &r.cases {
        let mut rec = vec![c.index.to_string()];
        rec.extend(c.values.iter().chain(&c.results).map(|&v| crate::study::output::csv_number(v)));
        rec.push(c.status.as_str().to_string());
        rec.push(c.error.clone());
        w.write_record(&rec).map_err(io)?;
    }
    w.flush().map_err(|e| Error::Io { file: path.clone(), action: "cannot write", source: e })?;
    Ok(path)
}

/// The summary section: what was varied and how, the case counts, the fractions of cases that
/// jump or lose unison in the operating range, and per result column its smallest and largest
/// value with the case and its 5 %, 50 % and 95 % quantiles.
pub(super) fn summary(study: &Study, spec: &DesignSpec, r: &DesignResult) -> String {
    let mut md = String::new();
    let sampling = match spec.sampling {
        Sampling::Grid => "full grid".to_string(),
        Sampling::LatinHypercube { n, seed } => format!("Latin hypercube, {n} cases, seed {seed}"),
        Sampling::MonteCarlo { n, seed } => format!("Monte Carlo, {n} cases, seed {seed}"),
    };
    let on = format!(" of mechanism `{}`", study.mechanism.name);
    let _ = writeln!(
        md,
        "## Design study `{}`{on}: {} `{}` per case, {sampling}\n",
        spec.name,
        spec.analysis.kind(),
        spec.analysis.name()
    );
    let _ = writeln!(md, "| parameter | quantity | unit | values |\n|---|---|---|---|");
    for (p, c) in spec.parameters.iter().zip(parameter_columns(study, spec)) {
        let values = match (&p.values, p.from, p.to) {
            (Some(v), ..) => v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "),
            (None, Some(a), Some(b)) => format!(
                "{a} to {b}{}{}{}",
                p.points.map_or(String::new(), |n| format!(", {n} points")),
                if p.log { ", logarithmic" } else { "" },
                match p.distribution {
                    super::Distribution::Uniform => String::new(),
                    super::Distribution::Normal { mean, sd } => format!(", normal: mean {mean}, sd {sd}, truncated"),
                }
            ),
            _ => String::new(),
        };
        let _ = writeln!(md, "| `{}` | {} | {} | {values} |", c.name, p.quantity.describe(), c.unit);
    }
    let (ok, partial, failed) = r.counts();
    let _ = writeln!(
        md,
        "\nCases: {} ({ok} ok, {partial} partial, {failed} failed); table `{}.csv`.\n",
        r.cases.len(),
        r.name
    );
    let f = super::findings(r);
    if let (Some((lo, hi)), Some(j), Some(u), Some(e)) =
        (r.operating, f.jump_fraction, f.unison_loss_fraction, f.jump_or_unison_loss_fraction)
    {
        let pc = |x: f64| format!("{:.1} %", 100.0 * x);
        let _ = writeln!(
            md,
            "Inside the operating range {lo} to {hi}: {} of the cases with results jump (have a fold), {} \
             lose the absorbers' unison (a branch point, or a fold that parts them), {} do either.\n",
            pc(j),
            pc(u),
            pc(e)
        );
    }
    let _ = writeln!(
        md,
        "| result | unit | smallest | case | 5 % | median | 95 % | largest | case |\n|---|---|---|---|---|---|---|---|---|"
    );
    for (k, (col, q)) in r.results.iter().zip(&f.quantiles).enumerate() {
        let pick = |better: fn(f64, f64) -> bool| {
            r.cases.iter().filter(|c| c.results[k].is_finite()).fold(None, |best: Option<&CaseRow>, c| match best {
                Some(b) if !better(c.results[k], b.results[k]) => Some(b),
                _ => Some(c),
            })
        };
        let show = |c: Option<&CaseRow>| {
            c.map_or(("undefined".to_string(), "–".to_string()), |c| (num(c.results[k]), c.index.to_string()))
        };
        let (lo, lo_case) = show(pick(|a, b| a < b));
        let (hi, hi_case) = show(pick(|a, b| a > b));
        let quant = |v: f64| if v.is_finite() { num(v) } else { "–".to_string() };
        let _ = writeln!(
            md,
            "| `{}` | {} | {lo} | {lo_case} | {} | {} | {} | {hi} | {hi_case} |",
            col.name,
            col.unit,
            quant(q.p05),
            quant(q.p50),
            quant(q.p95)
        );
    }
    md.push('\n');
    md
}

/// A number for the summary: six decimals when moderate, exponent form when tiny or huge.
fn num(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:.5e}") } else { format!("{v:.6}") }
}

//! Load case 1 (paper section 4.1, Figs. 3 and 4): a single-order torque swept in order, up and
//! down, at each amplitude; order traces of the response by the short-time FFT.

mod analysis;
mod spec;
pub use spec::*;

use super::elements::ElementTraces;
use super::sim::{self, Progress};
use super::table::Table;
use super::{Output, Study};
use crate::error::Result;
use crate::model::excitation::{Excitation, Harmonic, Order, rpm_to_rad_s};
use crate::plot::{LineStyle, Panel, Series};
use crate::signal::OrderTrace;
use crate::signal::findings::{at_order, branch_differences, exceeds, skip_ramp, trace_minimum};
use crate::time::probe::{Outcome, simulate_streamed};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One sweep run: the order traces of the response and what the run did. Serialised into
/// `results.json` without the time series (which is there as a table, like its CSV).
#[derive(Debug, Clone, serde::Serialize, schemars::JsonSchema)]
pub struct SweepRun {
    /// The analysis name.
    pub analysis: String,
    /// Torque amplitude T_n, N·m.
    pub amplitude: f64,
    /// Sweep direction.
    pub direction: Direction,
    /// True for the locked twin.
    pub locked: bool,
    /// One trace per tracked multiple (time, order, amplitude in rad/s²).
    pub traces: Vec<OrderTrace>,
    /// Largest |q| of the joints other than the spin joint (the pendulum angles φ), rad.
    pub max_relative_angle: f64,
    /// The simulation's statistics and outcome.
    pub sim: Outcome,
    /// The sampled time series, when asked for.
    #[serde(skip)]
    pub time_series: Option<sim::TimeSeries>,
    /// Each reported element's order traces (none for the locked twin).
    pub elements: Vec<ElementTraces>,
}

impl SweepRun {
    /// The trace of multiple `m` (1 = main order), if tracked.
    pub fn trace(&self, m: f64) -> Option<&OrderTrace> {
        self.traces.iter().find(|t| (t.multiple - m).abs() < 1e-12)
    }

    /// The run's file label: `<analysis>_<amplitude>Nm_<up|down>[_locked]`.
    pub fn label(&self) -> String {
        job_label(&self.analysis, self.amplitude, self.direction, self.locked)
    }
}

/// The file label of a run: `<analysis>_<amplitude>Nm_<up|down>[_locked]`.
fn job_label(analysis: &str, amplitude: f64, direction: Direction, locked: bool) -> String {
    let dir = match direction {
        Direction::Up => "up",
        Direction::Down => "down",
    };
    format!("{analysis}_{}Nm_{dir}{}", fmt_num(amplitude), if locked { "_locked" } else { "" })
}

pub(crate) use super::table::fmt_num;

struct Job {
    amplitude: f64,
    direction: Direction,
    locked: bool,
}

/// Runs the sweep ([`compute`]) and writes its outputs ([`render`]).
pub(crate) fn run(study: &Study, spec: &SweepSpec, dir: &Path, progress: &Progress) -> Result<Output> {
    let (runs, failures) = compute(study, spec, progress);
    let (markdown, files) = render(study, spec, &runs, dir)?;
    Ok(Output { markdown, files, failures, results: Box::new(runs) })
}

/// Runs every amplitude × direction (and the locked twin once per amplitude: it is linear, so
/// its traces do not depend on the direction), in parallel; a failed run is listed, never lost
/// with the others.
pub(crate) fn compute(study: &Study, spec: &SweepSpec, progress: &Progress) -> (Vec<SweepRun>, Vec<String>) {
    let omega = rpm_to_rad_s(spec.rpm);
    let mut jobs = Vec::new();
    for &amplitude in &spec.amplitudes {
        for &direction in &spec.directions {
            jobs.push(Job { amplitude, direction, locked: false });
        }
        if study.locked.is_some() {
            jobs.push(Job { amplitude, direction: Direction::Up, locked: true });
        }
    }
    let shared = study.shared_models(study.locked.is_some());
    let results: Vec<Result<SweepRun>> =
        jobs.par_iter().map(|job| Ok(run_recorded(study, &shared, spec, omega, job, progress, false)?.0)).collect();
    let mut runs = Vec::with_capacity(results.len());
    let mut failures = Vec::new();
    for (job, r) in jobs.iter().zip(results) {
        match r {
            Ok(run) => runs.push(run),
            Err(e) => {
                failures.push(format!("{}: {e}", job_label(&spec.name, job.amplitude, job.direction, job.locked)))
            }
        }
    }
    for r in &runs {
        if let Some(e) = &r.sim.error {
            failures.push(format!("{}: {e}", r.label()));
        }
        if let Some((t, i)) =
            r.traces.iter().find_map(|t| t.amplitude.iter().position(|a| !a.is_finite()).map(|i| (t, i)))
        {
            failures.push(format!(
                "{}: the {} trace is not finite at t = {} s (left empty in the CSV)",
                r.label(),
                order_name(t.multiple),
                t.time_s[i]
            ));
        }
    }
    (runs, failures)
}

/// The sweep's CSV tables, in the order they are written: the time series of every run when
/// asked for, then per run (the locked twin has none of its own) the traces side by side with
/// the locked reference at the same orders and the ratios.
pub(crate) fn tables(spec: &SweepSpec, runs: &[&SweepRun]) -> Vec<Table> {
    let mut out = Vec::new();
    for r in runs.iter().copied() {
        if let Some(ts) = &r.time_series
            && spec.write_time_series
        {
            let mut t = Table::new(format!("{}_time_series", r.label()));
            for ((name, unit), col) in ts.names.iter().zip(&ts.units).zip(&ts.columns) {
                t.push(name, unit, col.clone());
            }
            out.push(t);
        }
    }
    for r in runs.iter().filter(|r| !r.locked) {
        let locked = runs.iter().find(|l| l.locked && l.amplitude == r.amplitude);
        let Some(main) = r.traces.first() else { continue };
        let mut table = Table::new(r.label());
        table.push("time_s", "s", main.time_s.clone());
        table.push("order", "1", main.order.clone());
        for t in &r.traces {
            table.push(format!("amp_{}x_rad_s2", fmt_num(t.multiple)), "rad/s²", t.amplitude.clone());
        }
        if let Some(l) = locked {
            let scale = l.traces.iter().flat_map(|t| t.amplitude.iter().copied()).fold(0.0, f64::max);
            for t in &r.traces {
                let lt = l.trace(t.multiple);
                let ref_amp: Vec<f64> = t.order.iter().map(|&n| lt.map_or(f64::NAN, |lt| at_order(lt, n))).collect();
                let ratio = t.amplitude.iter().zip(&ref_amp).map(|(a, b)| super::ratio(*a, *b, scale)).collect();
                table.push(format!("locked_{}x_rad_s2", fmt_num(t.multiple)), "rad/s²", ref_amp);
                table.push(format!("ratio_{}x", fmt_num(t.multiple)), "1", ratio);
            }
        }
        // Each reported element's traces on the same windows: coordinate per order, and the
        // spring-and-damper torque per order (N·m; N for a slide).
        for e in &r.elements {
            let force = if e.unit == "m" { ("N", "N") } else { ("Nm", "N·m") };
            for t in &e.traces {
                table.push(format!("{}_{}x_{}", e.joint, fmt_num(t.multiple), e.unit), e.unit, t.amplitude.clone());
            }
            for t in e.torque.iter().flatten() {
                let name = format!("{}_torque_{}x_{}", e.joint, fmt_num(t.multiple), force.0);
                table.push(name, force.1, t.amplitude.clone());
            }
        }
        out.push(table);
    }
    out
}

/// Writes the sweep's CSVs ([`tables`]), its figure (the paper's Figs. 3 and 4) and returns its
/// summary section with the files written.
pub(crate) fn render(study: &Study, spec: &SweepSpec, runs: &[SweepRun], dir: &Path) -> Result<(String, Vec<PathBuf>)> {
    let mut files = Vec::new();
    let refs: Vec<&SweepRun> = runs.iter().collect();
    for t in tables(spec, &refs) {
        files.push(t.write_csv(dir)?);
    }

    // Figures 3 and 4: one panel per amplitude; main and second order, up solid, down dashed.
    let panels: Vec<Panel> = spec
        .amplitudes
        .iter()
        .map(|&amp| {
            let mut series = Vec::new();
            for r in runs.iter().filter(|r| r.amplitude == amp) {
                for (k, t) in r.traces.iter().enumerate() {
                    // The locked twin is linear: it answers at the excitation order only, and its
                    // higher-order traces are numerical noise (1e-6 of the main order).
                    if r.locked && t.multiple != 1.0 {
                        continue;
                    }
                    let (style, what) = match (r.locked, r.direction) {
                        (true, _) => (LineStyle::Dotted, "locked"),
                        (false, Direction::Up) => (LineStyle::Solid, "up"),
                        (false, Direction::Down) => (LineStyle::Dashed, "down"),
                    };
                    series.push(Series {
                        label: format!("{} {what}", order_name(t.multiple)),
                        x: t.order.clone(),
                        y: t.amplitude.clone(),
                        color: if r.locked { 7 } else { k },
                        style,
                    });
                }
            }
            Panel {
                title: format!("T_n = {} N·m, {} rpm", fmt_num(amp), fmt_num(spec.rpm)),
                x_label: "excitation order n".into(),
                y_label: format!("{} angular acceleration, rad/s²", study.spec.response_body),
                log_y: true,
                x_range: Some((spec.order_min, spec.order_max)),
                series,
                ..Panel::default()
            }
        })
        .collect();
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &panels, 640, 440)?;
    files.push(svg);
    // The elements' main-order traces, one panel per amplitude, up solid and down dashed.
    if runs.iter().any(|r| !r.elements.is_empty()) {
        let panels: Vec<Panel> = spec
            .amplitudes
            .iter()
            .map(|&amp| {
                let mut series = Vec::new();
                for r in runs.iter().filter(|r| r.amplitude == amp && !r.locked) {
                    let (style, what) = match r.direction {
                        Direction::Up => (LineStyle::Solid, "up"),
                        Direction::Down => (LineStyle::Dashed, "down"),
                    };
                    for (e, el) in r.elements.iter().enumerate() {
                        if let Some(t) = el.traces.first() {
                            series.push(Series {
                                label: format!("{} {what}", el.joint),
                                x: t.order.clone(),
                                y: t.amplitude.clone(),
                                color: e,
                                style,
                            });
                        }
                    }
                }
                Panel {
                    title: format!("Elements, {}, T_n = {} N·m", order_name(spec.multiples[0]), fmt_num(amp)),
                    x_label: "excitation order n".into(),
                    y_label: "amplitude, rad (m for slides)".into(),
                    log_y: true,
                    x_range: Some((spec.order_min, spec.order_max)),
                    series,
                    ..Panel::default()
                }
            })
            .collect();
        let svg = dir.join(format!("{}_elements.svg", spec.name));
        crate::plot::write_svg(&svg, &panels, 640, 440)?;
        files.push(svg);
    }

    Ok((summary(spec, runs), files))
}

/// "main order" for m = 1, "2nd order" for m = 2, …
pub(crate) fn order_name(m: f64) -> String {
    match m {
        1.0 => "main order".into(),
        2.0 => "2nd order".into(),
        3.0 => "3rd order".into(),
        _ => format!("{}× order", fmt_num(m)),
    }
}

/// One run of the sweep, analysed as it goes; with `whole_record` the recorder keeps every column
/// of the run too, and is returned (the tests' reference for the streamed analysis).
fn run_recorded(
    study: &Study,
    shared: &sim::SharedModels,
    spec: &SweepSpec,
    omega: f64,
    job: &Job,
    progress: &Progress,
    whole_record: bool,
) -> Result<(SweepRun, Option<crate::time::probe::Recorder>)> {
    let (from, to) = match job.direction {
        Direction::Up => (spec.order_min, spec.order_max),
        Direction::Down => (spec.order_max, spec.order_min),
    };
    let mech = if job.locked { study.locked.as_ref().unwrap_or(&study.mechanism) } else { &study.mechanism };
    let body = if job.locked { study.locked_body.unwrap_or(study.body) } else { study.body };
    let spin = mech.joint_index(&study.spec.spin_joint).unwrap_or(study.spin);
    let excitation = Excitation {
        mean: spec.mean_torque.unwrap_or_else(|| Study::loss_torque(mech, spin, omega)),
        rpm: spec.rpm,
        order: Order::Sweep { from, to, duration_s: spec.duration_s },
        harmonics: vec![Harmonic { multiple: 1.0, amplitude: job.amplitude, phase: 0.0 }],
        ramp_s: spec.ramp_s,
    };
    let mut kane = study.kane_from(shared, job.locked)?;
    study.apply_excitation(&mut kane, mech, &spec.excite, &excitation);
    let x0 = Study::initial_state(mech, spin, omega);
    let label = format!(
        "{} {} N·m {}{}",
        spec.name,
        fmt_num(job.amplitude),
        if job.direction == Direction::Up { "up" } else { "down" },
        if job.locked { " locked" } else { "" }
    );
    let bar = progress.bar(spec.duration_s, &label);
    // The elements are the mechanism's joints; the locked twin reports none.
    let elements: &[usize] = if job.locked { &[] } else { &study.elements };
    let mut rec = sim::recorder(mech, spin, body, spec.write_time_series, elements)?;
    // The analysis runs on the samples as they come; the record is kept only for the time
    // series, when it is asked for (its columns, not the elements' or the analysis's own).
    let series = rec.columns.len() - 2 * elements.len();
    let asked = spec.write_time_series;
    rec.store_only(|c| whole_record || (asked && (c == sim::ACCEL || (sim::SERIES..series).contains(&c))));
    let (opts, choice) =
        sim::options_for(study, mech, omega, spec.order_min.max(spec.order_max) * omega / std::f64::consts::TAU);
    let fs = study.spec.integration.sample_hz;
    let order = excitation.order;
    let order_at = move |t: f64| order.at(t);
    let skip = (spec.ramp_s * fs).ceil() as usize;
    let mut stream =
        sim::RunStream::new(mech, elements, fs, omega, &order_at, &spec.multiples, &study.spec.order_tracking, skip);
    let info = simulate_streamed(
        &mut kane,
        &x0,
        0.0,
        spec.duration_s,
        &opts,
        &mut rec,
        &mut |_, row| stream.push(row),
        &mut |t| bar.set_position((t * 1000.0) as u64),
    );
    bar.finish_and_clear();
    let mut info = info;
    info.integrator = Some(choice);
    let (traces, max_relative_angle, element_traces) = stream.finish(&mech.name)?;
    let whole = whole_record.then(|| rec.clone());
    let run = SweepRun {
        analysis: spec.name.clone(),
        amplitude: job.amplitude,
        direction: job.direction,
        locked: job.locked,
        traces,
        max_relative_angle,
        sim: info,
        time_series: sim::time_series(mech, body, rec, elements.len()),
        elements: element_traces,
    };
    Ok((run, whole))
}

fn fmt_intervals(iv: &[(f64, f64)]) -> String {
    if iv.is_empty() {
        return "none".into();
    }
    iv.iter().map(|(a, b)| format!("{a:.3}–{b:.3}")).collect::<Vec<_>>().join(", ")
}

/// What the summary reads off a sweep's traces (also in `results.json`). Order intervals are
/// `(from, to)` pairs of excitation orders.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct SweepFindings {
    /// Windows centred before this time are left out (the ramp-in plus 1 s), s.
    pub skip_before_s: f64,
    /// One entry per run, in the order of the runs.
    pub runs: Vec<RunFindings>,
    /// One entry per amplitude that has both an up and a down run.
    pub amplitudes: Vec<AmplitudeFindings>,
}

/// What the summary reads off one sweep run.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct RunFindings {
    /// The run's file label ([`SweepRun::label`]).
    pub label: String,
    /// Excitation order of the main-order trace's minimum, and that amplitude in rad/s² (None
    /// without a main-order trace).
    pub main_order_minimum: Option<(f64, f64)>,
    /// Order intervals where the second-order trace lies above the main-order one (None unless
    /// both are tracked).
    pub second_over_main: Option<Vec<(f64, f64)>>,
    /// Right-hand-side evaluations, the integrator's and those at the samples.
    pub rhs_evals: usize,
}

/// Where the up and the down sweep of one amplitude differ.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct AmplitudeFindings {
    /// Torque amplitude T_n, N·m.
    pub amplitude: f64,
    /// Order intervals where the main-order traces differ by more than [`BRANCH_FACTOR`] (one
    /// is over 1.5 times the other).
    pub up_down_differ: Vec<(f64, f64)>,
}

/// Up and down traces "differ" when one is this many times the other.
pub(crate) const BRANCH_FACTOR: f64 = 1.5;

/// The summary's readings of the runs (see [`SweepFindings`]).
pub(crate) fn findings(spec: &SweepSpec, runs: &[&SweepRun]) -> SweepFindings {
    let skip = spec.ramp_s + 1.0;
    let runs_out = runs
        .iter()
        .map(|r| RunFindings {
            label: r.label(),
            main_order_minimum: r.trace(1.0).and_then(|t| trace_minimum(t, skip)),
            second_over_main: match (r.trace(1.0), r.trace(2.0)) {
                (Some(m), Some(s)) => Some(exceeds(m, s, skip)),
                _ => None,
            },
            rhs_evals: r.sim.rhs_evals(),
        })
        .collect();
    let mut amplitudes = Vec::new();
    for &amp in &spec.amplitudes {
        let up = runs.iter().find(|r| !r.locked && r.amplitude == amp && r.direction == Direction::Up);
        let down = runs.iter().find(|r| !r.locked && r.amplitude == amp && r.direction == Direction::Down);
        if let (Some(u), Some(d)) = (up.and_then(|r| r.trace(1.0)), down.and_then(|r| r.trace(1.0))) {
            let up_down_differ = branch_differences(&skip_ramp(u, skip), &skip_ramp(d, skip), BRANCH_FACTOR);
            amplitudes.push(AmplitudeFindings { amplitude: amp, up_down_differ });
        }
    }
    SweepFindings { skip_before_s: skip, runs: runs_out, amplitudes }
}

fn summary(spec: &SweepSpec, runs: &[SweepRun]) -> String {
    let mut md = String::new();
    let _ = writeln!(
        md,
        "## Order sweep `{}`: {} rpm, n from {} to {} over {} s\n",
        spec.name,
        fmt_num(spec.rpm),
        spec.order_min,
        spec.order_max,
        fmt_num(spec.duration_s)
    );
    let _ = writeln!(
        md,
        "| run | max abs relative angle (rad) | main-order minimum at n | its amplitude (rad/s²) | orders where 2nd > main | RHS evaluations | steps (rejected) | wall time (s) |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|");
    let found = findings(spec, &runs.iter().collect::<Vec<_>>());
    for (r, f) in runs.iter().zip(&found.runs) {
        let min = f.main_order_minimum;
        let _ = writeln!(
            md,
            "| {} | {:.4} | {} | {} | {} | {} | {} ({}) | {:.3} |",
            f.label,
            r.max_relative_angle,
            min.map_or("–".into(), |m| format!("{:.4}", m.0)),
            min.map_or("–".into(), |m| format!("{:.4}", m.1)),
            f.second_over_main.as_deref().map_or("–".into(), fmt_intervals),
            f.rhs_evals,
            r.sim.stats.accepted,
            r.sim.stats.rejected,
            r.sim.wall_s
        );
    }
    md.push('\n');
    if let Some(c) = runs.first().and_then(|r| r.sim.integrator.as_ref()) {
        let _ = writeln!(md, "Integrator: {:?} ({})\n", c.method, c.reason);
    }
    for a in &found.amplitudes {
        let _ = writeln!(
            md,
            "- T_n = {} N·m: up and down main-order traces differ by more than {BRANCH_FACTOR}× at n = {}",
            fmt_num(a.amplitude),
            fmt_intervals(&a.up_down_differ)
        );
    }
    md.push('\n');
    // Element by element: every absorber and spring, not only the largest excursion.
    let mut rows = String::new();
    for r in runs.iter().filter(|r| !r.locked) {
        for e in &r.elements {
            let largest = |t: &OrderTrace| t.amplitude.iter().copied().filter(|a| a.is_finite()).fold(0.0, f64::max);
            let amps: Vec<String> = e.traces.iter().map(|t| crate::plot::num(largest(t), 5)).collect();
            let torque = e.torque.as_ref().map_or("–".to_string(), |ts| {
                let per: Vec<String> = ts.iter().map(|t| crate::plot::num(largest(t), 5)).collect();
                format!("{}; peak {}", per.join(", "), crate::plot::num(e.torque_peak, 5))
            });
            let _ = writeln!(
                rows,
                "| {} | `{}` | {} {} | {} | {torque} |",
                r.label(),
                e.joint,
                amps.join(", "),
                e.unit,
                crate::plot::num(e.peak, 5)
            );
        }
    }
    if !rows.is_empty() {
        let orders: Vec<String> = spec.multiples.iter().map(|m| order_name(*m)).collect();
        let _ = writeln!(
            md,
            "Elements over each sweep after the ramp-in: largest amplitude per order ({}), peak |q|, and \
             their spring-and-damper torque (N·m; N for a slide):\n",
            orders.join(", ")
        );
        let _ = writeln!(md, "| run | joint | largest amplitude | peak | torque |\n|---|---|---|---|---|\n{rows}");
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::Source;
    use crate::study::LoadOptions;

    /// The analysis made as the run goes equals the analysis of the whole record of the same run
    /// (the independent route: the batch STFT, [`super::super::elements::traces`] and the
    /// column's maximum), on a shaft with springs, dampers and a pendulum, so every element has a
    /// torque: the same numbers, bit for bit, since both routes do the same arithmetic on the
    /// same samples. Up and down, one with the ramp-in longer than a window.
    #[test]
    fn the_streamed_analysis_is_the_whole_record_analysis() {
        let text = r#"Study(name: "s", mechanism: "shaft_cpva.ron", spin_joint: "spin", response_body: "rotor",
            integration: (sample_hz: 1000.0),
            analyses: [OrderSweep(name: "sweep", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 12.0,
                                  amplitudes: [300.0])])"#;
        let study = Study::from_source(Source::from_text("examples/s.ron", text), &LoadOptions::default()).unwrap();
        assert!(study.elements.len() >= 2, "{:?}", study.elements);
        let fs = study.spec.integration.sample_hz;
        let omega = rpm_to_rad_s(1000.0);
        for (direction, ramp_s) in [(Direction::Up, 2.0), (Direction::Down, 2.5)] {
            let spec = SweepSpec {
                name: "sweep".into(),
                rpm: 1000.0,
                order_min: 2.9,
                order_max: 3.3,
                duration_s: 12.0,
                amplitudes: vec![300.0],
                directions: vec![direction],
                multiples: vec![1.0, 2.0],
                ramp_s,
                mean_torque: None,
                write_time_series: false,
                excite: Vec::new(),
            };
            let job = Job { amplitude: 300.0, direction, locked: false };
            let shared = study.shared_models(false);
            let progress = Progress::new(false);
            let (run, rec) = run_recorded(&study, &shared, &spec, omega, &job, &progress, true).unwrap();
            let rec = rec.unwrap();
            assert!(run.sim.error.is_none() && rec.time.len() == 12001, "{} samples", rec.time.len());
            let (from, to) = if direction == Direction::Up { (2.9, 3.3) } else { (3.3, 2.9) };
            let order = Order::Sweep { from, to, duration_s: 12.0 };
            let order_at = move |t: f64| order.at(t);
            let tracking = &study.spec.order_tracking;
            let accel = &rec.columns[sim::ACCEL];
            let want = crate::study::track::track("s", accel, fs, omega, &order_at, &spec.multiples, tracking).unwrap();
            assert_eq!(run.traces, want);
            assert_eq!(run.traces[0].len(), (12000 - 2000) / 250 + 1);
            let relative = rec.columns[sim::RELATIVE].iter().copied().fold(0.0, f64::max);
            assert_eq!(run.max_relative_angle, relative);
            let cols = sim::element_columns(&rec, study.elements.len());
            let skip = (ramp_s * fs).ceil() as usize;
            let want = super::super::elements::traces(
                &study.mechanism,
                &study.elements,
                &cols,
                fs,
                omega,
                &order_at,
                &spec.multiples,
                tracking,
                skip,
            )
            .unwrap();
            assert!(want.iter().all(|e| e.torque.is_some() && e.peak > 0.0), "{want:?}");
            assert_eq!(run.elements, want);
        }
    }
}

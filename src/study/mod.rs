//! Studies: one RON file in, every trace, table and figure out.
//!
//! A study names a mechanism, the spin joint that carries the excitation torque, the body whose
//! angular acceleration is reported, the joints to lock for the reference twin, and a list of
//! analyses (the paper's load cases). [`run`] executes them (independent runs in parallel with
//! rayon), writes CSV and SVG files into `<out>/<study name>/`, and returns a summary that is also
//! written as Markdown.

pub mod hbm;
mod linear;
mod multi;
mod sim;
pub mod spec;
pub mod sweep;

use crate::error::{Error, Result};
use crate::io::Source;
use crate::kane::Kane;
use crate::mechanism::Mechanism;
pub use spec::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// A study ready to run: the spec, its mechanism and the locked twin, with names resolved.
#[derive(Debug, Clone)]
pub struct Study {
    /// The spec as read.
    pub spec: StudySpec,
    /// The study file.
    pub file: PathBuf,
    /// The mechanism.
    pub mechanism: Mechanism,
    /// The mechanism with the `lock` joints locked at q = 0, if any are named.
    pub locked: Option<Mechanism>,
    /// Index of the spin joint (= its coordinate).
    pub spin: usize,
    /// Index of the response body.
    pub body: usize,
    /// Index of the response body in the locked twin.
    pub locked_body: Option<usize>,
}

/// What a study produced: the Markdown summary and the files written.
#[derive(Debug, Clone, Default)]
pub struct StudyReport {
    /// Markdown summary (also written to `summary.md`).
    pub summary: String,
    /// Files written, in order.
    pub files: Vec<PathBuf>,
    /// Runs that failed (their partial output is still written), with the reason.
    pub failures: Vec<String>,
    /// Sweep results, for tests and further processing.
    pub sweeps: Vec<sweep::SweepRun>,
    /// Multi-order results.
    pub multi: Vec<multi::MultiOrderResult>,
    /// Linear frequency-response results.
    pub linear: Vec<linear::LinearResult>,
    /// Harmonic-balance branches.
    pub hbm: Vec<hbm::HbmBranch>,
}

pub use linear::{LinearResult, ResponseVariant};
pub use multi::{MultiOrderResult, SpeedResult};
pub use sweep::SweepRun;

impl Study {
    /// Reads a study file and its mechanism, resolving every name; errors name the file, the
    /// line:column and the field.
    pub fn from_file(path: &Path) -> Result<Self> {
        let src = Source::read(path)?;
        let spec: StudySpec = src.parse()?;
        let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
        let mech_path = base.join(&spec.mechanism);
        let mechanism = Mechanism::from_file(&mech_path).map_err(|e| match e {
            Error::Io { .. } => src.error("mechanism", format!("cannot read mechanism file: {e}")),
            other => other,
        })?;
        let joint_names = || mechanism.joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ");
        let spin = mechanism.joint_index(&spec.spin_joint).ok_or_else(|| {
            src.error("spin_joint", format!("unknown joint `{}` (joints: {})", spec.spin_joint, joint_names()))
        })?;
        if mechanism.joints[spin].parent.is_some() {
            return Err(src.error(
                "spin_joint",
                format!("joint `{}` does not connect to ground: the spin joint must", spec.spin_joint),
            ));
        }
        let body = mechanism.body_index(&spec.response_body).ok_or_else(|| {
            let names: Vec<&str> = mechanism.bodies.iter().map(|b| b.name.as_str()).collect();
            src.error("response_body", format!("unknown body `{}` (bodies: {})", spec.response_body, names.join(", ")))
        })?;
        let mut locked = None;
        for (i, j) in spec.lock.iter().enumerate() {
            let m = locked.as_ref().unwrap_or(&mechanism);
            if m.joint_index(j).is_none() {
                return Err(
                    src.error(&format!("lock[{i}]"), format!("unknown joint `{j}` (joints: {})", joint_names()))
                );
            }
            if *j == spec.spin_joint {
                return Err(src.error(&format!("lock[{i}]"), "the spin joint cannot be locked"));
            }
            locked = Some(m.lock(j, 0.0).map_err(|e| src.error(&format!("lock[{i}]"), e.to_string()))?);
        }
        let locked_body = match &locked {
            Some(m) => Some(m.body_index(&spec.response_body).ok_or_else(|| {
                src.error("lock", format!("locking merges the response body `{}` away", spec.response_body))
            })?),
            None => None,
        };
        check_spec(&spec, &mechanism, &src)?;
        Ok(Study { spec, file: path.to_path_buf(), mechanism, locked, spin, body, locked_body })
    }

    /// Mean torque that holds the spin joint's subtree in rigid rotation at `omega` (rad/s): the
    /// viscous losses of the spinning bodies to ground and of the spin joint itself, `Σ c·Ω`.
    /// In rigid rotation about a fixed axis the inertia forces point at the axis and have no
    /// moment about it, and the joint dampers inside the subtree see no relative rate, so these are
    /// all the losses (for the CPVA, `T_m = c_r·Ω`).
    pub fn loss_torque(mech: &Mechanism, spin: usize, omega: f64) -> f64 {
        let in_subtree = |b: usize| mech.path_to(b).contains(&spin);
        let ground: f64 = mech.loads.ground_dampers.iter().filter(|g| in_subtree(g.body)).map(|g| g.c).sum();
        (ground + mech.joints[spin].damper) * omega
    }

    /// The initial state of a sweep or steady run (DESIGN.md): q = 0, the spin joint turning at
    /// `omega` and every other joint at rest relative to its parent.
    pub fn initial_state(mech: &Mechanism, spin: usize, omega: f64) -> Vec<f64> {
        let n = mech.ndof();
        let mut qdot = vec![0.0; n];
        qdot[spin] = omega;
        let mut u = vec![0.0; n];
        mech.speeds.u_from_qdot(&mech.parents(), &qdot, &mut u);
        let mut x = vec![0.0; 2 * n];
        x[n..].copy_from_slice(&u);
        x
    }

    /// Builds the evaluator of the mechanism (or the locked twin).
    pub(crate) fn kane(&self, locked: bool) -> Result<Kane> {
        match (locked, &self.locked) {
            (true, Some(m)) => Kane::new(m),
            _ => Kane::new(&self.mechanism),
        }
    }
}

fn check_spec(spec: &StudySpec, mech: &Mechanism, src: &Source) -> Result<()> {
    let pos = |v: f64| v.is_finite() && v > 0.0;
    let i = spec.integration;
    if !pos(i.rtol) || !pos(i.atol) {
        return Err(src.error("integration", "rtol and atol must be finite and positive"));
    }
    if !pos(i.sample_hz) {
        return Err(src.error("integration.sample_hz", "sample rate must be finite and positive (Hz)"));
    }
    let o = spec.order_tracking;
    if !pos(o.window_s) || !pos(o.hop_s) {
        return Err(src.error("order_tracking", "window_s and hop_s must be finite and positive (s)"));
    }
    if spec.analyses.is_empty() {
        return Err(src.error("analyses", "no analyses: nothing to run"));
    }
    let mut names = std::collections::HashSet::new();
    for (k, a) in spec.analyses.iter().enumerate() {
        let path = format!("analyses[{k}]");
        let name = match a {
            AnalysisSpec::OrderSweep(s) => {
                if !pos(s.rpm) {
                    return Err(src.error(&format!("{path}.rpm"), "speed must be finite and positive (rpm)"));
                }
                if !(pos(s.order_min) && pos(s.order_max) && s.order_min < s.order_max) {
                    return Err(src.error(&format!("{path}.order_min"), "need 0 < order_min < order_max"));
                }
                if !pos(s.duration_s) {
                    return Err(src.error(&format!("{path}.duration_s"), "duration must be positive (s)"));
                }
                if s.duration_s < 2.0 * o.window_s {
                    return Err(src.error(
                        &format!("{path}.duration_s"),
                        format!("a sweep shorter than two tracking windows ({} s) gives no trace", 2.0 * o.window_s),
                    ));
                }
                if s.amplitudes.is_empty() || s.amplitudes.iter().any(|a| !a.is_finite()) {
                    return Err(src.error(&format!("{path}.amplitudes"), "give at least one finite amplitude (N·m)"));
                }
                check_common(src, &path, &s.multiples, s.ramp_s, s.mean_torque)?;
                &s.name
            }
            AnalysisSpec::MultiOrder(m) => {
                if !pos(m.order) {
                    return Err(src.error(&format!("{path}.order"), "order must be finite and positive"));
                }
                if m.speeds.is_empty() {
                    return Err(src.error(&format!("{path}.speeds"), "give at least one operating speed"));
                }
                for (j, p) in m.speeds.iter().enumerate() {
                    if !pos(p.rpm) {
                        return Err(src.error(&format!("{path}.speeds[{j}].rpm"), "speed must be positive (rpm)"));
                    }
                    for (h, hm) in p.harmonics.iter().enumerate() {
                        if !(pos(hm.multiple) && hm.amplitude.is_finite() && hm.phase.is_finite()) {
                            return Err(src.error(
                                &format!("{path}.speeds[{j}].harmonics[{h}]"),
                                "multiple must be positive, amplitude and phase finite",
                            ));
                        }
                    }
                }
                if !pos(m.window_s)
                    || !pos(m.steady_tol)
                    || m.max_time_s.is_nan()
                    || m.max_time_s < m.ramp_s + 2.0 * m.window_s
                {
                    return Err(src.error(
                        &format!("{path}.max_time_s"),
                        "need positive window_s and steady_tol, and max_time_s ≥ ramp_s + 2·window_s",
                    ));
                }
                check_common(src, &path, &m.multiples, m.ramp_s, m.mean_torque)?;
                &m.name
            }
            AnalysisSpec::LinearResponse(l) => {
                if !pos(l.rpm) {
                    return Err(src.error(&format!("{path}.rpm"), "speed must be finite and positive (rpm)"));
                }
                if !(pos(l.from) && l.to.is_finite() && l.from < l.to) {
                    return Err(src.error(&format!("{path}.from"), "need 0 < from < to"));
                }
                if l.points < 2 {
                    return Err(src.error(&format!("{path}.points"), "need at least 2 points"));
                }
                if l.relative && spec.lock.is_empty() {
                    return Err(src.error(
                        &format!("{path}.relative"),
                        "orders relative to n_t need a locked joint (`lock`) to define the tuning order",
                    ));
                }
                for (j, v) in l.variants.iter().enumerate() {
                    for (d, (joint, c)) in v.dampers.iter().enumerate() {
                        let at = format!("{path}.variants[{j}].dampers[{d}]");
                        if mech.joint_index(joint).is_none() {
                            return Err(src.error(&at, format!("unknown joint `{joint}`")));
                        }
                        if !(c.is_finite() && *c >= 0.0) {
                            return Err(src.error(&at, format!("damping must be finite and non-negative, got {c}")));
                        }
                    }
                }
                &l.name
            }
            AnalysisSpec::HarmonicBalance(h) => {
                let order_range = !(h.order_min == 0.0 && h.order_max == 0.0);
                // A continuation range: a positive order and 0 < min < max.
                let range_ok = |order: f64, min: f64, max: f64, message: &str| {
                    if pos(order) && pos(min) && pos(max) && min < max {
                        Ok(())
                    } else {
                        Err(src.error(&format!("{path}.parameter"), message))
                    }
                };
                let (needs_rpm, needs_orders, needs_amplitudes) = match h.parameter {
                    HbmParameter::Order => (true, true, true),
                    HbmParameter::Speed { order, rpm_min, rpm_max } => {
                        range_ok(order, rpm_min, rpm_max, "Speed needs order > 0 and 0 < rpm_min < rpm_max")?;
                        (false, false, true)
                    }
                    HbmParameter::Torque { order, min, max } => {
                        range_ok(order, min, max, "Torque needs order > 0 and 0 < min < max (N·m)")?;
                        (true, false, false)
                    }
                };
                let what = "a Speed or Torque continuation takes its range from `parameter`";
                if needs_rpm && !pos(h.rpm) {
                    return Err(src.error(&format!("{path}.rpm"), "speed must be finite and positive (rpm)"));
                }
                if !needs_rpm && h.rpm != 0.0 {
                    return Err(src.error(&format!("{path}.rpm"), format!("{what}: leave `rpm` out")));
                }
                if needs_orders && !(pos(h.order_min) && pos(h.order_max) && h.order_min < h.order_max) {
                    return Err(src.error(&format!("{path}.order_min"), "need 0 < order_min < order_max"));
                }
                if !needs_orders && order_range {
                    return Err(src.error(&format!("{path}.order_min"), format!("{what}: leave the order range out")));
                }
                if !needs_orders && h.overlay.is_some() {
                    return Err(src.error(&format!("{path}.overlay"), "sweeps can only be overlaid on order branches"));
                }
                if needs_amplitudes && (h.amplitudes.is_empty() || h.amplitudes.iter().any(|a| !a.is_finite())) {
                    return Err(src.error(&format!("{path}.amplitudes"), "give at least one finite amplitude (N·m)"));
                }
                if !needs_amplitudes && !h.amplitudes.is_empty() {
                    return Err(src.error(&format!("{path}.amplitudes"), format!("{what}: leave `amplitudes` out")));
                }
                if h.harmonics == 0 || h.harmonics > 64 {
                    return Err(src.error(&format!("{path}.harmonics"), "need 1 to 64 harmonics"));
                }
                if h.max_step.is_some_and(|d| !(d.is_finite() && d >= 1e-6)) {
                    return Err(src.error(&format!("{path}.max_step"), "must be finite and at least 1e-6"));
                }
                check_common(src, &path, &h.multiples, 0.0, None)?;
                if let Some(o) = &h.overlay {
                    let earlier =
                        spec.analyses[..k].iter().any(|a| matches!(a, AnalysisSpec::OrderSweep(s) if &s.name == o));
                    if !earlier {
                        return Err(src.error(
                            &format!("{path}.overlay"),
                            format!("no OrderSweep named `{o}` before this analysis"),
                        ));
                    }
                }
                &h.name
            }
            AnalysisSpec::Campbell(c) => {
                if !(c.rpm_min.is_finite() && c.rpm_min >= 0.0 && c.rpm_max.is_finite() && c.rpm_max > c.rpm_min) {
                    return Err(src.error(&format!("{path}.rpm_min"), "need 0 ≤ rpm_min < rpm_max"));
                }
                if c.points < 2 || c.orders.iter().any(|o| !pos(*o)) {
                    return Err(src.error(&format!("{path}.points"), "need ≥ 2 points and positive orders"));
                }
                &c.name
            }
        };
        if !names.insert(name.clone()) {
            return Err(src.error(&format!("{path}.name"), format!("duplicate analysis name `{name}`")));
        }
        if name.is_empty() || name.contains(['/', '\\']) {
            return Err(src.error(&format!("{path}.name"), "name must be non-empty and contain no path separator"));
        }
    }
    Ok(())
}

fn check_common(src: &Source, path: &str, multiples: &[f64], ramp_s: f64, mean: Option<f64>) -> Result<()> {
    if multiples.is_empty() || multiples.iter().any(|m| !(m.is_finite() && *m > 0.0)) {
        return Err(src.error(&format!("{path}.multiples"), "give positive harmonic multiples (1 = main order)"));
    }
    if !(ramp_s.is_finite() && ramp_s >= 0.0) {
        return Err(src.error(&format!("{path}.ramp_s"), "ramp must be a finite, non-negative duration (s)"));
    }
    if mean.is_some_and(|m| !m.is_finite()) {
        return Err(src.error(&format!("{path}.mean_torque"), "mean torque must be finite (N·m)"));
    }
    Ok(())
}

/// Options of [`run`].
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output root; the study writes into `<out>/<study name>/` (default `out`).
    pub out: Option<PathBuf>,
    /// Show progress bars on stderr (only drawn when stderr is a terminal).
    pub progress: bool,
}

/// Runs every analysis of the study, writes the outputs and returns the summary. A failing run
/// (e.g. an integration error) does not stop the others: its partial output is written and the
/// failure is listed in the summary and in [`StudyReport::failures`].
pub fn run(study: &Study, opts: &RunOptions) -> Result<StudyReport> {
    let dir = opts.out.clone().unwrap_or_else(|| PathBuf::from("out")).join(&study.spec.name);
    std::fs::create_dir_all(&dir).map_err(|e| Error::Io { file: dir.clone(), action: "cannot create", source: e })?;
    let progress = sim::Progress::new(opts.progress);
    let mut report = StudyReport::default();
    let mut md = String::new();
    let _ = writeln!(md, "# Study `{}`\n", study.spec.name);
    let _ = writeln!(
        md,
        "Mechanism `{}` ({} DOF), excitation on joint `{}`, response: angular acceleration of `{}`{}.\n",
        study.mechanism.name,
        study.mechanism.ndof(),
        study.spec.spin_joint,
        study.spec.response_body,
        if study.spec.lock.is_empty() {
            String::new()
        } else {
            format!("; locked twin with {} locked", study.spec.lock.join(", "))
        }
    );
    for a in &study.spec.analyses {
        match a {
            AnalysisSpec::OrderSweep(s) => {
                let out = sweep::run(study, s, &dir, &progress)?;
                md += &out.markdown;
                report.files.extend(out.files);
                report.failures.extend(out.failures);
                report.sweeps.extend(out.runs);
            }
            AnalysisSpec::MultiOrder(m) => {
                let out = multi::run(study, m, &dir, &progress)?;
                md += &out.markdown;
                report.files.extend(out.files);
                report.failures.extend(out.failures);
                report.multi.push(out.result);
            }
            AnalysisSpec::LinearResponse(l) => {
                let (out, result) = linear::run_response(study, l, &dir)?;
                md += &out.markdown;
                report.files.extend(out.files);
                report.linear.push(result);
            }
            AnalysisSpec::Campbell(c) => {
                let out = linear::run_campbell(study, c, &dir)?;
                md += &out.markdown;
                report.files.extend(out.files);
            }
            AnalysisSpec::HarmonicBalance(h) => {
                let out = hbm::run(study, h, &report.sweeps, &dir)?;
                md += &out.markdown;
                report.files.extend(out.files);
                report.hbm.extend(out.branches);
            }
        }
    }
    if !report.failures.is_empty() {
        let _ = writeln!(md, "## Failures\n");
        for f in &report.failures {
            let _ = writeln!(md, "- {f}");
        }
        md.push('\n');
    }
    let path = dir.join("summary.md");
    write_file(&path, &md)?;
    report.files.push(path);
    report.summary = md;
    Ok(report)
}

/// Writes a text file, naming it on failure.
pub(crate) fn write_file(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e })
}

/// Writes a CSV file with a header row and columns of equal length.
pub(crate) fn write_csv(path: &Path, header: &[&str], columns: &[&[f64]]) -> Result<()> {
    let io = |e: csv::Error| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e.into() };
    let mut w = csv::Writer::from_path(path).map_err(io)?;
    w.write_record(header).map_err(io)?;
    let rows = columns.iter().map(|c| c.len()).min().unwrap_or(0);
    let mut rec = Vec::with_capacity(columns.len());
    for r in 0..rows {
        rec.clear();
        rec.extend(columns.iter().map(|c| c[r].to_string()));
        w.write_record(&rec).map_err(io)?;
    }
    w.flush().map_err(|e| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e })
}

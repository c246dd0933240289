//! The plan of a study: for each analysis, its runs, samples, memory, output size and CPU time,
//! estimated from the files alone, and the limits they are checked against before any work.
//!
//! The estimates are deliberately coarse upper bounds (a factor of a few), built from how the
//! analyses spend their effort:
//! - a time-domain run keeps 3 signals per sample (24 B), plus `4 + DOF` columns when its time
//!   series is written, and takes about [`STEPS_PER_PERIOD`] DOP853 steps (12 right-hand sides
//!   each) per period of its highest excitation line, scaled by `(1e-9/rtol)^(1/8)` (an 8th-order
//!   method), plus one right-hand side per sample;
//! - a right-hand side costs about `RHS_BASE_S + RHS_PER_DOF2_S·DOF²`;
//! - a multi-order speed runs at most `max_time_s`;
//! - a harmonic-balance branch has `100 + (4 + Δλ)/ds_max` points (at most
//!   `ContinuationOptions::max_points`; `study::hbm::planned_points`), each a few
//!   Newton steps on `DOF·(2H + 1)` unknowns with `4(H + 1)` time samples, and a Floquet
//!   monodromy;
//! - a linear point solves one complex `DOF`-system, a Campbell point one eigenproblem;
//! - the output is the CSV files, and `results.json` about twice their size (each CSV number
//!   again in its table, and most once more in the analysis's results; the paper study writes
//!   0.9 MB of CSV and a 1.9 MB `results.json`).

use super::{Study, StudySpec};
use std::fmt;

/// DOP853 steps per period of the highest excitation line, for the estimate (the paper's sweeps
/// take 9 to 17).
pub(crate) const STEPS_PER_PERIOD: f64 = 20.0;
/// Fixed cost of one right-hand side, s.
pub(crate) const RHS_BASE_S: f64 = 40e-9;
/// Cost of one right-hand side per squared degree of freedom, s.
pub(crate) const RHS_PER_DOF2_S: f64 = 15e-9;
/// Bytes per CSV cell (a shortest round-trip f64 and a comma).
pub(crate) const CSV_CELL_BYTES: f64 = 22.0;
/// Bytes of `results.json` per byte of CSV (see the module docs).
pub(crate) const JSON_PER_CSV_BYTE: f64 = 2.0;

/// Upper bounds on what a study may ask for, checked when it is loaded. Each can be raised on
/// the command line (`kanedyn run --max-memory-mb …`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Largest estimated memory of the whole study's results and signals, bytes (`--max-memory-mb`).
    pub max_memory_bytes: f64,
    /// Largest estimated size of the files written, bytes (`--max-output-mb`).
    pub max_output_bytes: f64,
    /// Largest estimated CPU time of the whole study, s (`--max-cpu-hours`).
    pub max_cpu_s: f64,
    /// How long each analysis may run against its plan.
    pub watchdog: Watchdog,
}

impl Default for Limits {
    /// 2 GiB of memory, 2 GiB of files, 12 CPU hours: a night's run on a shared machine.
    fn default() -> Self {
        Self {
            max_memory_bytes: 2.0 * GIB,
            max_output_bytes: 2.0 * GIB,
            max_cpu_s: 12.0 * 3600.0,
            watchdog: Watchdog::default(),
        }
    }
}

/// The watchdog of a run: an analysis may take `factor ×` its planned CPU time plus `floor_s`;
/// once both its wall time and the process's CPU time since it started are past that budget
/// (`crate::deadline`: a loaded machine stretches the wall time, not the work), its loops stop
/// (a located entry under Failures) and the study goes on with the next analysis. Each
/// analysis inside a comparison has the budget of its own plan. The plan is an upper bound
/// within a few times (see the module docs and `tests/plan_calibration.rs`), so only an
/// analysis whose cost the plan cannot see (a stiff model, a branch that creeps) reaches the
/// limit; the floor keeps small analyses, whose plans are the least exact, from being stopped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Watchdog {
    /// Multiple of the planned CPU time.
    pub factor: f64,
    /// Time added to it, s.
    pub floor_s: f64,
}

impl Default for Watchdog {
    /// Ten times the plan plus a minute.
    fn default() -> Self {
        Self { factor: 10.0, floor_s: 60.0 }
    }
}

impl Watchdog {
    /// The time budget of an analysis planned at `cpu_s`, s.
    pub fn budget_s(&self, cpu_s: f64) -> f64 {
        let b = self.factor * cpu_s + self.floor_s;
        if b.is_finite() { b } else { f64::MAX }
    }
}

const GIB: f64 = 1024.0 * 1024.0 * 1024.0;
const MIB: f64 = 1024.0 * 1024.0;

/// The estimate of one analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalysisPlan {
    /// The analysis name.
    pub name: String,
    /// Its kind (`OrderSweep`, …).
    pub kind: &'static str,
    /// Index in the study's `analyses`.
    pub index: usize,
    /// Independent runs, branches or variants.
    pub runs: usize,
    /// Samples (time points, orders, speeds or branch points) of its longest run.
    pub samples_per_run: f64,
    /// Estimated memory held, bytes.
    pub memory_bytes: f64,
    /// Estimated size of its files, bytes.
    pub output_bytes: f64,
    /// Estimated CPU time, s.
    pub cpu_s: f64,
    /// The field that drives the estimate most (for messages).
    pub driver: &'static str,
}

/// The plan of a whole study.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// One entry per analysis, in file order.
    pub analyses: Vec<AnalysisPlan>,
}

impl Plan {
    /// Total estimated memory, bytes.
    pub fn memory_bytes(&self) -> f64 {
        self.analyses.iter().map(|a| a.memory_bytes).sum()
    }
    /// Total estimated output size, bytes.
    pub fn output_bytes(&self) -> f64 {
        self.analyses.iter().map(|a| a.output_bytes).sum()
    }
    /// Total estimated CPU time, s.
    pub fn cpu_s(&self) -> f64 {
        self.analyses.iter().map(|a| a.cpu_s).sum()
    }

    /// The first limit the plan exceeds: the analysis index, its driving field and the message.
    pub fn exceeds(&self, limits: &Limits) -> Option<(usize, &'static str, String)> {
        let biggest = |f: fn(&AnalysisPlan) -> f64| {
            self.analyses.iter().max_by(|a, b| f(a).total_cmp(&f(b))).map(|a| (a.index, a.driver, a.name.clone()))
        };
        let checks: [LimitCheck; 3] = [
            (self.memory_bytes(), limits.max_memory_bytes, "memory", "--max-memory-mb", |a| a.memory_bytes, mb),
            (self.output_bytes(), limits.max_output_bytes, "output files", "--max-output-mb", |a| a.output_bytes, mb),
            (self.cpu_s(), limits.max_cpu_s, "CPU time", "--max-cpu-hours", |a| a.cpu_s, hours),
        ];
        for (value, limit, what, flag, per, show) in checks {
            // NaN compares false: treat a non-finite estimate as exceeding.
            if value.is_nan() || value > limit {
                let (index, driver, name) = biggest(per)?;
                return Some((
                    index,
                    driver,
                    format!(
                        "the study needs an estimated {} of {what} (analysis `{name}` the most), over the limit of {}; \
                         reduce this field, or raise the limit on purpose with `kanedyn run {flag} …`",
                        show(value),
                        show(limit)
                    ),
                ));
            }
        }
        None
    }
}

/// A total, its limit, what it measures, the flag raising it, the per-analysis share, and how
/// to print it.
type LimitCheck = (f64, f64, &'static str, &'static str, fn(&AnalysisPlan) -> f64, fn(f64) -> String);

fn mb(b: f64) -> String {
    format!("{:.1} MB", b / MIB)
}
fn hours(s: f64) -> String {
    if s < 120.0 { format!("{s:.2} s") } else { format!("{:.2} h", s / 3600.0) }
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "| analysis | kind | runs | samples per run | memory | output | CPU time |")?;
        writeln!(f, "|---|---|---|---|---|---|---|")?;
        for a in &self.analyses {
            writeln!(
                f,
                "| {} | {} | {} | {:.0} | {} | {} | {} |",
                a.name,
                a.kind,
                a.runs,
                a.samples_per_run,
                mb(a.memory_bytes),
                mb(a.output_bytes),
                hours(a.cpu_s)
            )?;
        }
        writeln!(
            f,
            "| total | | {} | | {} | {} | {} |",
            self.analyses.iter().map(|a| a.runs).sum::<usize>(),
            mb(self.memory_bytes()),
            mb(self.output_bytes()),
            hours(self.cpu_s())
        )
    }
}

/// Fixed cost of one linear analysis (an operating point by Newton, the modes with the spin free
/// and held, of the mechanism and its locked twin), s, plus [`LINEAR_SETUP_PER_DOF3_S`]`·DOF³`;
/// a design study of a two-point linear response spent ~130 µs per case on the CPVA and ~720 µs
/// on the truck driveline, all of it here, where the estimate had counted none.
pub(crate) const LINEAR_SETUP_S: f64 = 100e-6;
/// See [`LINEAR_SETUP_S`].
pub(crate) const LINEAR_SETUP_PER_DOF3_S: f64 = 6e-6;
/// Cost of one Campbell point (the equilibrium and the eigenproblems with the spin free and held,
/// tracked between speeds), s, plus [`CAMPBELL_PER_DOF3_S`]`·DOF³`: measured 45 µs on the
/// dual-mass flywheel and the CPVA (2 DOF) and 105 µs on the truck driveline (5 DOF), where the
/// estimate had been 6.6 µs.
pub(crate) const CAMPBELL_POINT_S: f64 = 60e-6;
/// See [`CAMPBELL_POINT_S`].
pub(crate) const CAMPBELL_PER_DOF3_S: f64 = 1e-6;
/// Fixed cost of one design-study case (the mechanism rebuilt with the case's values, its
/// equations of motion and its locked twin checked), s, plus a `DOF³` part like the linear
/// analyses'.
pub(crate) const CASE_SETUP_S: f64 = 50e-6;
/// An explicit Runge–Kutta method is stable for steps below about this many time constants of
/// the fastest decay (DOP853's stability region reaches ~−6 on the real axis, and its step
/// control keeps about half of that): a damper whose
/// decay rate `c/J` is far above the excitation forces steps of `~3/(c/J)` whatever the
/// tolerance.
pub(crate) const STABLE_STEP_RATES: f64 = 3.0;

/// Cost of the order tracking per sample of a window and per `log₂` of its length, s (a
/// windowed real FFT and the band sums): a 20 s sweep sampled at 1 MHz (81 windows of 2·10⁶
/// samples, found by `tests/fuzz_runs.rs`) spends about a second per run here, which the plan
/// did not count.
pub(crate) const STFT_PER_POINT_S: f64 = 3e-10;

/// Estimated CPU time of the order tracking of `windows` windows of `samples` samples each.
pub(crate) fn stft_s(windows: f64, samples: f64) -> f64 {
    windows * samples * samples.max(2.0).log2() * STFT_PER_POINT_S
}

/// Cost of one right-hand side of a mechanism with `n` degrees of freedom, s.
pub(crate) fn rhs_s(n: f64) -> f64 {
    RHS_BASE_S + RHS_PER_DOF2_S * n * n
}

/// Estimated CPU time of one time-domain run over `duration_s` whose highest excitation line is
/// at `f_hz`, sampled at `fs`, capped by the integrator's step limit. The mechanism's own time
/// scales count too ([`time_scales`]): its fastest spring's natural frequency is a line the
/// steps must resolve like an excitation, and its fastest damper's decay rate bounds the stable
/// step (a stiff shaft damper used to make a run take 10 to 1000 times its estimate).
pub(crate) fn time_run_s(study: &Study, duration_s: f64, f_hz: f64) -> f64 {
    let i = study.spec.integration;
    let n = study.mechanism.ndof() as f64;
    let (f_spring, decay) = time_scales(&study.mechanism);
    let accurate = duration_s * STEPS_PER_PERIOD * f_hz.max(f_spring).max(1.0) * (1e-9 / i.rtol).powf(0.125);
    let stable = duration_s * decay / STABLE_STEP_RATES;
    let steps = accurate.max(stable).min(i.max_steps as f64);
    (12.0 * steps + duration_s * i.sample_hz) * rhs_s(n)
}

/// The speed (rpm) a time run's dynamics is planned at when an alternating torque of amplitude
/// `torque_nm` acts on the spin joint at orders from `order_min` of `rpm` for `duration_s`: the
/// nominal speed plus the mean of the speed's swing. On the rigid driveline (inertia
/// `J = uᵀ M(0) u` about the spin joint, `u` the steady rotation at unit rate) the torque
/// swings the speed by `Δω = T/(J n Ω)` (and by no more than `T·t/J` at orders near zero);
/// a torque large enough that `Δω` passes `Ω` whirls the rotor and its absorbers at rates
/// near `Δω`, whose lines the steps must follow (a 1e9 N·m sweep on the paper's rotor spun it
/// near 10⁶ rad/s and took over 1000 times its plan at the nominal speed). Over a period the
/// mean of `|ω|` is `Ω + (2/π) Δω` at most; an ordinary torque moves it by a fraction of a
/// percent.
pub(crate) fn swung_rpm(study: &Study, torque_nm: f64, rpm: f64, order_min: f64, duration_s: f64) -> f64 {
    let inertia = spin_inertia(study);
    let omega = rpm.abs() * std::f64::consts::PI / 30.0;
    let dwell = (1.0 / (order_min.abs() * omega)).min(duration_s.abs());
    let swing = torque_nm.abs() / inertia * dwell;
    if !(swing.is_finite() && inertia > 0.0) {
        return rpm;
    }
    rpm.abs() + 2.0 / std::f64::consts::PI * swing * 30.0 / std::f64::consts::PI
}

/// The inertia of the rigidly turning driveline about the spin joint, kg·m² (0 when the mass
/// matrix cannot be formed).
fn spin_inertia(study: &Study) -> f64 {
    let mech = &study.mechanism;
    let n = mech.ndof();
    let Ok(mut kane) = crate::kane::Kane::new(mech) else { return 0.0 };
    let x = Study::initial_state(mech, study.spin, 1.0);
    let u = nalgebra::DVector::from_column_slice(&x[n..]);
    let m = kane.mass_matrix(&x[..n]);
    u.dot(&(m * &u))
}

/// The mechanism's fastest time scales at q = 0: the highest natural frequency of its springs,
/// stages, stops and meshes (Hz) and the highest decay rate of its dampers (1/s), each on the
/// inertia it acts on (`model::time_scales`, the same figures the loader checks against
/// its ranges). A coarse bound, not an eigen-analysis: it is there to see a stiff model, which the
/// excitation alone does not show. `(0, 0)` when the mass matrix cannot be formed or the
/// mechanism has over 200 coordinates.
pub(crate) fn time_scales(mech: &crate::model::mechanism::Mechanism) -> (f64, f64) {
    use crate::model::time_scales::{compliances, time_scales};
    // The plan is asked once per time-domain analysis (and per comparison's mechanism): past 200
    // coordinates the O(n³) compliances would cost more than the estimate is worth.
    let n = mech.ndof();
    if n == 0 || n > 200 {
        return (0.0, 0.0);
    }
    let Ok(mut kane) = crate::kane::Kane::new(mech) else { return (0.0, 0.0) };
    let Some(diag) = compliances(mech, kane.mass_matrix(&vec![0.0; n])) else { return (0.0, 0.0) };
    let (mut f, mut decay) = (0.0_f64, 0.0_f64);
    for ts in time_scales(mech, &diag) {
        if ts.is_stiffness() {
            f = f.max(ts.rate());
        } else {
            decay = decay.max(ts.rate());
        }
    }
    (if f.is_finite() { f } else { 0.0 }, if decay.is_finite() { decay } else { 0.0 })
}

impl Study {
    /// The estimated work of every analysis (see the module docs of `plan` for the model).
    pub fn plan(&self) -> Plan {
        let analyses = self
            .spec
            .analyses
            .iter()
            .enumerate()
            .map(|(index, a)| {
                let (kind, name) = (a.kind(), a.name().to_string());
                let base = AnalysisPlan {
                    name,
                    kind,
                    index,
                    runs: 0,
                    samples_per_run: 0.0,
                    memory_bytes: 0.0,
                    output_bytes: 0.0,
                    cpu_s: 0.0,
                    driver: "",
                };
                a.analysis().plan(self, base)
            })
            .map(|p| AnalysisPlan { output_bytes: p.output_bytes * (1.0 + JSON_PER_CSV_BYTE), ..p })
            .collect();
        Plan { analyses }
    }
}

/// Upper bound of one harmonic-balance branch's CPU time: `points` points of about 5 Newton
/// steps, each a dense factorisation of `DOF·(2H+1)` unknowns and `4(H+1)` Jacobian samples,
/// plus a Floquet monodromy of 256 RK4 steps on `2·DOF` states.
pub(crate) fn hbm_branch_s(n: f64, h: f64, points: f64) -> f64 {
    let u = n * (2.0 * h + 1.0);
    let newton = u * u * u / 3.0 * 1e-9 + 4.0 * (h + 1.0) * rhs_s(n) * 2.0 * n;
    let floquet = 256.0 * 4.0 * 2.0 * n * rhs_s(n) * 2.0 * n;
    points * (5.0 * newton + floquet)
}

/// What most estimates start from: the study as written, its sample rate (Hz), its degrees of
/// freedom and whether a locked twin runs beside each time run (0 or 1).
pub(crate) fn basics(study: &Study) -> (&StudySpec, f64, f64, usize) {
    let spec = &study.spec;
    (spec, spec.integration.sample_hz, study.mechanism.ndof() as f64, usize::from(study.locked.is_some()))
}

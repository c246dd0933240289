//! Design studies: one analysis (harmonic balance or the linear order response) run over many
//! variants of the mechanism and its excitation, collected in one table with a row per case.
//!
//! A design study names its parameters (a body's mass, inertia or centre-of-mass radius, a
//! joint's stiffness, damping or radius, the speed, torque amplitude or order of the analysis),
//! how they are sampled, and the analysis to run per case:
//! - `Grid`: the full factorial product of each parameter's values (a list, or `points` values
//!   spaced evenly, or geometrically with `log: true`, from `from` to `to`); case `i` is the
//!   mixed-radix decomposition of `i` with the first parameter varying slowest, as nested loops
//!   in file order;
//! - `LatinHypercube(n, seed)`: McKay, Beckman and Conover's Latin hypercube sampling: each
//!   parameter's range is cut into `n` equal strata (equal in the logarithm with `log: true`)
//!   and every stratum is hit by exactly one case, the strata of the parameters paired by
//!   independent random permutations, each case uniform inside its stratum;
//! - `MonteCarlo(n, seed)`: `n` independent uniform draws per parameter.
//!
//! The random numbers are ChaCha8 (`rand_chacha::ChaCha8Rng`, whose stream rand_chacha keeps
//! value-stable) seeded by `ChaCha8Rng::seed_from_u64(seed)` (rand_core's documented PCG32
//! expansion of the seed), read as `next_u64` only: a uniform number in [0, 1) is the top 53
//! bits times 2⁻⁵³, an integer in 0..k is `next_u64 mod k` after rejecting draws at or above the
//! largest multiple of k (no modulo bias). Latin hypercube: per parameter in file order, a
//! Fisher–Yates shuffle of the strata 0..n (for j from n − 1 down to 1, swap j with a draw in
//! 0..=j), then the n in-stratum offsets, case by case. Monte Carlo: case by case, one draw per
//! parameter in file order. The same seed gives the same cases on every machine.
//!
//! Each case substitutes its values into the typed mechanism and analysis (never a text
//! round-trip), rebuilds the locked twin, checks the mass matrix, and runs the analysis alone; its
//! row holds a small set of scalars read off the results (see [`result_columns`]) and a status.
//! A case is a pure function of the study and its index, so the local rayon run, a run of one case
//! by index ([`run_case`]) and a run spread over a cluster give the same numbers bit for bit. One
//! failed case (an invalid mechanism, a harmonic balance that does not converge, a panic) never
//! costs the others their results: its row says why.

use super::plan::AnalysisPlan;
use super::table::{Table, fmt_num};
use super::validate::{MAX_ORDER, MAX_RPM, MAX_TORQUE_NM, check_file_name};
use super::{AnalysisSpec, HbmParameter, Output, Results, Study, StudySpec};
use crate::error::{Error, Result};
use crate::io::Source;
use crate::kane::Kane;
use crate::model::joint::{JointKind, Spring};
use crate::model::mechanism::Mechanism;
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Most parameters of one design study.
pub const MAX_PARAMETERS: usize = 16;
/// Most cases of one design study (a grid's product, or `n`).
pub const MAX_CASES: usize = 100_000;
/// Most values of one grid parameter.
pub const MAX_VALUES: usize = 1000;
/// Largest magnitude of a mechanism parameter (kg, kg·m², m, N·m/rad, N·m·s/rad): far beyond any
/// machine, small enough that its squares stay finite.
pub const MAX_MECHANISM_VALUE: f64 = 1e12;
/// Relative distance below which two folds of a case's branches count as one (the branches from
/// each end of the range pass the same folds and locate them to about 1e-9).
pub const FOLD_MERGE_TOL: f64 = 1e-6;

/// A design study as written in the study file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignSpec {
    /// Name (file prefix of `<name>.csv`).
    pub name: String,
    /// The varied quantities, 1 to [`MAX_PARAMETERS`].
    pub parameters: Vec<DesignParameter>,
    /// How the cases are drawn (default `Grid`).
    #[serde(default)]
    pub sampling: Sampling,
    /// The analysis run per case: `HarmonicBalance(…)` or `LinearResponse(…)`, written as in
    /// `analyses`; the parameters replace its fields and the mechanism's values case by case.
    pub analysis: Box<AnalysisSpec>,
}

/// One varied quantity and its values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DesignParameter {
    /// Column name (letters, digits, `_`, `-`, `.`); the CSV column is `<name>_<unit>`.
    pub name: String,
    /// What is varied.
    pub quantity: Quantity,
    /// Lower end of the range, in the quantity's unit.
    #[serde(default)]
    pub from: Option<f64>,
    /// Upper end of the range.
    #[serde(default)]
    pub to: Option<f64>,
    /// Number of grid values from `from` to `to`, both included (`Grid` only).
    #[serde(default)]
    pub points: Option<usize>,
    /// The grid values themselves, in place of `from`/`to`/`points` (`Grid` only).
    #[serde(default)]
    pub values: Option<Vec<f64>>,
    /// Space the values (or strata) evenly in the logarithm (needs `from > 0`; default false).
    #[serde(default)]
    pub log: bool,
}

/// A quantity a design study can vary, with its SI unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Quantity {
    /// A body's mass, kg (its centre of mass and centroidal inertia kept).
    BodyMass(String),
    /// A body's centroidal moment of inertia, kg·m².
    BodyInertia(String),
    /// The distance of a body's centre of mass from its inboard joint point (its frame's origin),
    /// m, in the direction it has in the file (the CPVA pendulum's L).
    BodyComRadius(String),
    /// A joint spring's stiffness, N·m/rad (N/m for a slide); a joint without a spring gets one
    /// relaxed at q = 0.
    JointStiffness(String),
    /// A joint's viscous damping, N·m·s/rad (N·s/m for a slide).
    JointDamping(String),
    /// The distance of a joint's point from its parent's origin, m, in the direction it has in
    /// the file (the CPVA's pivot radius R).
    JointRadius(String),
    /// The analysis's mean speed, rpm.
    Rpm,
    /// The analysis's torque amplitude T_n, N·m (harmonic balance in order or speed).
    TorqueAmplitude,
    /// The analysis's fixed excitation order (harmonic balance in speed or torque).
    Order,
}

impl Quantity {
    /// The unit as the CSV column suffix: `kg`, `kg_m2`, `m`, `Nm_per_rad`, …; empty for an
    /// order. `slide`: the joint is prismatic.
    fn suffix(&self, slide: bool) -> &'static str {
        match self {
            Quantity::BodyMass(_) => "kg",
            Quantity::BodyInertia(_) => "kg_m2",
            Quantity::BodyComRadius(_) | Quantity::JointRadius(_) => "m",
            Quantity::JointStiffness(_) if slide => "N_per_m",
            Quantity::JointStiffness(_) => "Nm_per_rad",
            Quantity::JointDamping(_) if slide => "Ns_per_m",
            Quantity::JointDamping(_) => "Nms_per_rad",
            Quantity::Rpm => "rpm",
            Quantity::TorqueAmplitude => "Nm",
            Quantity::Order => "",
        }
    }

    /// The SI unit (`"1"` for an order).
    fn unit(&self, slide: bool) -> &'static str {
        match self {
            Quantity::BodyMass(_) => "kg",
            Quantity::BodyInertia(_) => "kg·m²",
            Quantity::BodyComRadius(_) | Quantity::JointRadius(_) => "m",
            Quantity::JointStiffness(_) if slide => "N/m",
            Quantity::JointStiffness(_) => "N·m/rad",
            Quantity::JointDamping(_) if slide => "N·s/m",
            Quantity::JointDamping(_) => "N·m·s/rad",
            Quantity::Rpm => "rpm",
            Quantity::TorqueAmplitude => "N·m",
            Quantity::Order => "1",
        }
    }

    /// The joint it names, if any.
    fn joint(&self) -> Option<&str> {
        match self {
            Quantity::JointStiffness(j) | Quantity::JointDamping(j) | Quantity::JointRadius(j) => Some(j),
            _ => None,
        }
    }

    /// The body it names, if any.
    fn body(&self) -> Option<&str> {
        match self {
            Quantity::BodyMass(b) | Quantity::BodyInertia(b) | Quantity::BodyComRadius(b) => Some(b),
            _ => None,
        }
    }

    /// The quantity in words, for the summary and messages.
    pub fn describe(&self) -> String {
        match self {
            Quantity::BodyMass(b) => format!("mass of `{b}`"),
            Quantity::BodyInertia(b) => format!("centroidal inertia of `{b}`"),
            Quantity::BodyComRadius(b) => format!("centre-of-mass radius of `{b}`"),
            Quantity::JointStiffness(j) => format!("stiffness of `{j}`"),
            Quantity::JointDamping(j) => format!("damping of `{j}`"),
            Quantity::JointRadius(j) => format!("radius of joint `{j}`"),
            Quantity::Rpm => "speed".into(),
            Quantity::TorqueAmplitude => "torque amplitude T_n".into(),
            Quantity::Order => "excitation order".into(),
        }
    }
}

/// How the cases of a design study are drawn (see the module docs for the exact algorithm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Sampling {
    /// Every combination of the parameters' values.
    #[default]
    Grid,
    /// `n` cases, each parameter's `n` strata hit once each.
    LatinHypercube {
        /// Number of cases.
        n: usize,
        /// Seed of the random stream.
        seed: u64,
    },
    /// `n` independent uniform cases.
    MonteCarlo {
        /// Number of cases.
        n: usize,
        /// Seed of the random stream.
        seed: u64,
    },
}

/// The status of one case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum CaseStatus {
    /// Every run of the case's analysis succeeded.
    Ok,
    /// Some runs failed (a branch of a harmonic balance); the row holds the others' results.
    Partial,
    /// The case gave no result (its results are NaN).
    Failed,
}

impl CaseStatus {
    /// `ok`, `partial` or `failed`.
    pub fn as_str(self) -> &'static str {
        match self {
            CaseStatus::Ok => "ok",
            CaseStatus::Partial => "partial",
            CaseStatus::Failed => "failed",
        }
    }
}

/// One case's row of the table.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CaseRow {
    /// Case index, from 0.
    pub index: usize,
    /// The parameter values, in the parameters' order and units.
    pub values: Vec<f64>,
    /// The results, in [`DesignResult::results`]'s order (NaN where none exists).
    pub results: Vec<f64>,
    /// Whether it ran.
    pub status: CaseStatus,
    /// Why it failed or is partial (empty when ok).
    pub error: String,
}

/// A column of the case table: CSV header and SI unit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ColumnInfo {
    /// The CSV header.
    pub name: String,
    /// SI unit, `"1"` when dimensionless.
    pub unit: &'static str,
}

/// The results of a design study.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignResult {
    /// Analysis name.
    pub name: String,
    /// The parameter columns.
    pub parameters: Vec<ColumnInfo>,
    /// The result columns.
    pub results: Vec<ColumnInfo>,
    /// One row per case, in case order.
    pub cases: Vec<CaseRow>,
}

impl DesignResult {
    /// The numeric columns as a table `<name>`: `case`, the parameters, the results (the CSV's
    /// columns but `status` and `error`).
    pub fn table(&self) -> Table {
        let mut t = Table::new(self.name.clone());
        t.push("case", "1", self.cases.iter().map(|c| c.index as f64).collect());
        for (k, p) in self.parameters.iter().enumerate() {
            t.push(p.name.clone(), p.unit, self.cases.iter().map(|c| c.values[k]).collect());
        }
        for (k, r) in self.results.iter().enumerate() {
            t.push(r.name.clone(), r.unit, self.cases.iter().map(|c| c.results[k]).collect());
        }
        t
    }

    /// Cases by status: (ok, partial, failed).
    pub fn counts(&self) -> (usize, usize, usize) {
        let n = |s: CaseStatus| self.cases.iter().filter(|c| c.status == s).count();
        (n(CaseStatus::Ok), n(CaseStatus::Partial), n(CaseStatus::Failed))
    }
}

/// What the summary reads off a design study (also in `results.json`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DesignFindings {
    /// Cases run.
    pub cases: usize,
    /// Cases complete.
    pub ok: usize,
    /// Cases with some runs failed.
    pub partial: usize,
    /// Cases without results.
    pub failed: usize,
}

/// The findings of `r`.
pub fn findings(r: &DesignResult) -> DesignFindings {
    let (ok, partial, failed) = r.counts();
    DesignFindings { cases: r.cases.len(), ok, partial, failed }
}

// ---------------------------------------------------------------------------------------------
// Sampling

/// The number of cases, saturating (checked against [`MAX_CASES`] at load).
pub fn case_count(spec: &DesignSpec) -> usize {
    match spec.sampling {
        Sampling::Grid => spec.parameters.iter().map(grid_len).fold(1usize, usize::saturating_mul),
        Sampling::LatinHypercube { n, .. } | Sampling::MonteCarlo { n, .. } => n,
    }
}

fn grid_len(p: &DesignParameter) -> usize {
    match &p.values {
        Some(v) => v.len(),
        None => p.points.unwrap_or(0),
    }
}

/// The point at fraction `t` ∈ [0, 1] of a parameter's range (geometric with `log`).
fn at_fraction(p: &DesignParameter, t: f64) -> f64 {
    let (a, b) = (p.from.unwrap_or(0.0), p.to.unwrap_or(0.0));
    if p.log { a * (b / a).powf(t) } else { a + (b - a) * t }
}

/// The `k`-th of a grid parameter's values.
fn grid_value(p: &DesignParameter, k: usize) -> f64 {
    if let Some(v) = &p.values {
        return v[k];
    }
    let points = p.points.unwrap_or(2);
    // The ends exactly as written: `a + (b − a)·1` may round away from b.
    if k + 1 == points { p.to.unwrap_or(0.0) } else { at_fraction(p, k as f64 / (points - 1) as f64) }
}

/// A uniform number in [0, 1) from the top 53 bits of one draw.
pub fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform integer in 0..k (k ≥ 1) by rejection: draws at or above the largest multiple of k
/// are redrawn, so every value is equally likely.
pub fn below(rng: &mut ChaCha8Rng, k: u64) -> u64 {
    let zone = u64::MAX - u64::MAX % k;
    loop {
        let x = rng.next_u64();
        if x < zone {
            return x % k;
        }
    }
}

/// Every case's parameter values (outer index: case), as the module docs define them.
pub fn case_values(spec: &DesignSpec) -> Vec<Vec<f64>> {
    let d = spec.parameters.len();
    match spec.sampling {
        Sampling::Grid => {
            let lens: Vec<usize> = spec.parameters.iter().map(grid_len).collect();
            let n = case_count(spec);
            (0..n)
                .map(|i| {
                    let mut rest = i;
                    let mut row = vec![0.0; d];
                    for k in (0..d).rev() {
                        row[k] = grid_value(&spec.parameters[k], rest % lens[k]);
                        rest /= lens[k];
                    }
                    row
                })
                .collect()
        }
        Sampling::LatinHypercube { n, seed } => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let mut rows = vec![vec![0.0; d]; n];
            for (k, p) in spec.parameters.iter().enumerate() {
                let mut strata: Vec<usize> = (0..n).collect();
                for j in (1..n).rev() {
                    strata.swap(j, below(&mut rng, j as u64 + 1) as usize);
                }
                for (row, &s) in rows.iter_mut().zip(&strata) {
                    row[k] = at_fraction(p, (s as f64 + uniform(&mut rng)) / n as f64);
                }
            }
            rows
        }
        Sampling::MonteCarlo { n, seed } => {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            (0..n).map(|_| spec.parameters.iter().map(|p| at_fraction(p, uniform(&mut rng))).collect()).collect()
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Validation

/// Checks a design study (analysis `k` of the study file) against the mechanism; errors are
/// located at the offending field (`analyses[k].parameters[j].from`, …).
pub(crate) fn check(
    src: &Source,
    spec: &StudySpec,
    mech: &Mechanism,
    spin: usize,
    k: usize,
    d: &DesignSpec,
) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    let inner = d.analysis.as_ref();
    match inner {
        AnalysisSpec::HarmonicBalance(h) if h.overlay.is_some() => {
            return Err(src.error(&at("analysis.overlay"), "a design study's cases draw no figure to overlay"));
        }
        AnalysisSpec::HarmonicBalance(_) => {}
        AnalysisSpec::LinearResponse(l) => {
            if !l.variants.is_empty() {
                return Err(src.error(
                    &at("analysis.variants"),
                    "a design study takes no damping variants: vary `JointDamping(…)` as a parameter instead",
                ));
            }
            if spec.lock.is_empty() {
                return Err(src.error(
                    &at("analysis"),
                    "a linear response in a design study needs a locked joint (`lock`): its results are n_t and \
                     ratios to the locked twin",
                ));
            }
        }
        other => {
            return Err(src.error(
                &at("analysis"),
                format!("a design study runs HarmonicBalance or LinearResponse per case, not {}", other.kind()),
            ));
        }
    }
    // The analysis as written must be valid by itself: checked by the study's own rules on a
    // study holding it alone, errors moved to their place inside this entry.
    let alone = StudySpec { analyses: vec![inner.clone()], ..spec.clone() };
    if let Err(e) = super::validate::check(&alone, mech, spin, src) {
        return Err(match e {
            Error::Input { location, message } if location.path.starts_with("analyses[0]") => {
                let rest = &location.path["analyses[0]".len()..];
                src.error(&format!("analyses[{k}].analysis{rest}"), message)
            }
            other => other,
        });
    }
    if d.parameters.is_empty() || d.parameters.len() > MAX_PARAMETERS {
        return Err(src.error(&at("parameters"), format!("give 1 to {MAX_PARAMETERS} parameters")));
    }
    let mut names = std::collections::HashSet::new();
    for (j, p) in d.parameters.iter().enumerate() {
        let pat = |field: &str| format!("analyses[{k}].parameters[{j}].{field}");
        if let Err(m) = check_file_name(&p.name) {
            return Err(src.error(&pat("name"), m));
        }
        if !names.insert(p.name.as_str()) {
            return Err(src.error(&pat("name"), format!("parameter `{}` is named twice", p.name)));
        }
        if d.parameters[..j].iter().any(|q| q.quantity == p.quantity) {
            return Err(src.error(&pat("quantity"), format!("the {} is varied twice", p.quantity.describe())));
        }
        check_quantity(src, &pat("quantity"), mech, spin, inner, &p.quantity)?;
        check_values(src, &pat(""), d.sampling, p, |v| value_ok(&p.quantity, inner, v))?;
    }
    match d.sampling {
        Sampling::Grid => {}
        Sampling::LatinHypercube { n, .. } | Sampling::MonteCarlo { n, .. } => {
            if n == 0 || n > MAX_CASES {
                return Err(src.error(&at("sampling"), format!("give 1 to {MAX_CASES} cases")));
            }
        }
    }
    let n = case_count(d);
    if n > MAX_CASES {
        return Err(src.error(
            &at("parameters"),
            format!("the grid has {n} cases; at most {MAX_CASES} (sample it with LatinHypercube or MonteCarlo)"),
        ));
    }
    Ok(())
}

/// The quantity's name exists and the quantity applies to this mechanism and analysis.
fn check_quantity(
    src: &Source,
    path: &str,
    mech: &Mechanism,
    spin: usize,
    inner: &AnalysisSpec,
    q: &Quantity,
) -> Result<()> {
    if let Some(b) = q.body() {
        let Some(i) = mech.body_index(b) else {
            let names: Vec<&str> = mech.bodies.iter().map(|b| b.name.as_str()).collect();
            return Err(src.error(path, format!("unknown body `{b}` (bodies: {})", names.join(", "))));
        };
        if matches!(q, Quantity::BodyComRadius(_)) && mech.bodies[i].inertia.com.norm() == 0.0 {
            return Err(src.error(
                path,
                format!("body `{b}` has its centre of mass at its origin: no direction to move it along"),
            ));
        }
    }
    if let Some(jn) = q.joint() {
        let Some(j) = mech.joint_index(jn) else {
            let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
            return Err(src.error(path, format!("unknown joint `{jn}` (joints: {})", names.join(", "))));
        };
        let joint = &mech.joints[j];
        if joint.kind == JointKind::Fixed && !matches!(q, Quantity::JointRadius(_)) {
            return Err(src.error(path, format!("joint `{jn}` is Fixed: it has no spring or damper")));
        }
        if matches!(q, Quantity::JointStiffness(_)) && j == spin {
            return Err(src.error(path, format!("`{jn}` is the spin joint: a spinning rotor cannot wind a spring")));
        }
        if matches!(q, Quantity::JointRadius(_)) && joint.at.norm() == 0.0 {
            return Err(
                src.error(path, format!("joint `{jn}` sits at its parent's origin: no direction to move it along"))
            );
        }
    }
    let applies = match (q, inner) {
        (Quantity::Rpm, AnalysisSpec::HarmonicBalance(h)) => !matches!(h.parameter, HbmParameter::Speed { .. }),
        (Quantity::TorqueAmplitude, AnalysisSpec::HarmonicBalance(h)) => {
            !matches!(h.parameter, HbmParameter::Torque { .. })
        }
        (Quantity::Order, AnalysisSpec::HarmonicBalance(h)) => !matches!(h.parameter, HbmParameter::Order),
        (Quantity::Rpm, _) => true,
        (Quantity::TorqueAmplitude | Quantity::Order, _) => false,
        _ => true,
    };
    if !applies {
        return Err(src.error(
            path,
            format!(
                "the {} is not a parameter of this {}: {}",
                q.describe(),
                inner.kind(),
                match q {
                    Quantity::Rpm => "a Speed continuation continues it",
                    Quantity::TorqueAmplitude =>
                        "a linear response is per unit torque, and a Torque continuation \
                                                  continues it",
                    _ => "a linear response and an Order continuation sweep the order themselves",
                }
            ),
        ));
    }
    Ok(())
}

/// Whether `v` is an admissible value of `q` in `inner`, and if not, the admissible range.
fn value_ok(q: &Quantity, inner: &AnalysisSpec, v: f64) -> std::result::Result<(), String> {
    let within = |lo: f64, hi: f64, lo_open: bool| {
        let above = if lo_open { v > lo } else { v >= lo };
        v.is_finite() && above && v <= hi
    };
    let (ok, range) = match q {
        Quantity::BodyMass(_) | Quantity::BodyInertia(_) | Quantity::JointStiffness(_) | Quantity::JointDamping(_) => {
            (within(0.0, MAX_MECHANISM_VALUE, false), format!("0 ≤ value ≤ {MAX_MECHANISM_VALUE:e}"))
        }
        Quantity::BodyComRadius(_) | Quantity::JointRadius(_) => {
            (within(0.0, MAX_MECHANISM_VALUE, true), format!("0 < value ≤ {MAX_MECHANISM_VALUE:e} m"))
        }
        Quantity::Rpm => (within(0.0, MAX_RPM, true), format!("0 < rpm ≤ {MAX_RPM:e}")),
        Quantity::Order => (within(0.0, MAX_ORDER, true), format!("0 < order ≤ {MAX_ORDER}")),
        Quantity::TorqueAmplitude => {
            // Harmonic balance has no periodic response to continue at zero torque.
            let zero_ok = !matches!(inner, AnalysisSpec::HarmonicBalance(_));
            (
                v.is_finite() && v.abs() <= MAX_TORQUE_NM && (zero_ok || v != 0.0),
                format!("0 < |T_n| ≤ {MAX_TORQUE_NM:e} N·m"),
            )
        }
    };
    if ok { Ok(()) } else { Err(format!("{} must satisfy {range}, got {v}", q.describe())) }
}

/// The values of one parameter: a list or a range for a grid, a range for random sampling, every
/// value (for a grid) or both ends admissible. `prefix` ends with a dot.
fn check_values(
    src: &Source,
    prefix: &str,
    sampling: Sampling,
    p: &DesignParameter,
    ok: impl Fn(f64) -> std::result::Result<(), String>,
) -> Result<()> {
    let field = |f: &str| format!("{prefix}{f}");
    let grid = sampling == Sampling::Grid;
    if let Some(values) = &p.values {
        if !grid {
            return Err(src.error(&field("values"), "random sampling draws from `from`..`to`: give those instead"));
        }
        if p.from.is_some() || p.to.is_some() || p.points.is_some() || p.log {
            return Err(src.error(&field("values"), "give either `values` or `from`, `to` and `points`, not both"));
        }
        if values.is_empty() || values.len() > MAX_VALUES {
            return Err(src.error(&field("values"), format!("give 1 to {MAX_VALUES} values")));
        }
        for (i, &v) in values.iter().enumerate() {
            ok(v).map_err(|m| src.error(&field(&format!("values[{i}]")), m))?;
        }
        return Ok(());
    }
    let (Some(a), Some(b)) = (p.from, p.to) else {
        let what = if grid { "`values`, or `from`, `to` and `points`" } else { "`from` and `to`" };
        return Err(src.error(&field(if p.from.is_none() { "from" } else { "to" }), format!("give {what}")));
    };
    ok(a).map_err(|m| src.error(&field("from"), m))?;
    ok(b).map_err(|m| src.error(&field("to"), m))?;
    if a >= b {
        return Err(src.error(&field("to"), format!("need from < to, got {a} and {b}")));
    }
    if p.log && a <= 0.0 {
        return Err(src.error(&field("log"), "log spacing needs from > 0"));
    }
    match (grid, p.points) {
        (true, Some(n)) if (2..=MAX_VALUES).contains(&n) => Ok(()),
        (true, _) => Err(src.error(&field("points"), format!("give 2 to {MAX_VALUES} points from `from` to `to`"))),
        (false, Some(_)) => Err(src.error(&field("points"), "random sampling takes its count from `sampling`'s `n`")),
        (false, None) => Ok(()),
    }
}

// ---------------------------------------------------------------------------------------------
// Plan

/// The estimated work of a design study: the analysis's estimate once per case (its cost does
/// not depend on the varied values: a harmonic-balance branch is bounded by its points, a linear
/// response by its order grid), its memory once per case running at a time, and the table.
pub(crate) fn plan(study: &Study, spec: &DesignSpec, base: AnalysisPlan) -> AnalysisPlan {
    let mut alone = study.clone();
    alone.spec.analyses = vec![spec.analysis.as_ref().clone()];
    let inner = alone.plan().analyses.into_iter().next();
    let n = case_count(spec) as f64;
    let parallel = std::thread::available_parallelism().map_or(1, |p| p.get()) as f64;
    let columns = (1 + spec.parameters.len() + result_columns(study, spec).len()) as f64;
    // A row's cells, plus the status and a message of up to ~200 characters.
    let table_bytes = n * (columns * 22.0 + 200.0);
    match inner {
        Some(a) => AnalysisPlan {
            runs: case_count(spec).saturating_mul(a.runs),
            samples_per_run: a.samples_per_run,
            memory_bytes: a.memory_bytes * n.min(parallel) + table_bytes,
            output_bytes: table_bytes,
            cpu_s: n * a.cpu_s,
            driver: "sampling",
            ..base
        },
        None => base,
    }
}

// ---------------------------------------------------------------------------------------------
// Cases

/// The parameter columns: `<name>_<unit>` (just the name for an order).
pub fn parameter_columns(study: &Study, spec: &DesignSpec) -> Vec<ColumnInfo> {
    spec.parameters
        .iter()
        .map(|p| {
            let slide = p
                .quantity
                .joint()
                .and_then(|j| study.mechanism.joint_index(j))
                .is_some_and(|j| matches!(study.mechanism.joints[j].kind, JointKind::Prismatic { .. }));
            let suffix = p.quantity.suffix(slide);
            let name = if suffix.is_empty() { p.name.clone() } else { format!("{}_{suffix}", p.name) };
            ColumnInfo { name, unit: p.quantity.unit(slide) }
        })
        .collect()
}

/// The result columns of each case, by analysis:
/// - harmonic balance: `peak_accel_<m>x_rad_s2` per reported multiple m (the largest response
///   acceleration amplitude at order m·n over every solved point of every branch, stable or
///   not), `max_relative_angle_rad` (the largest peak relative angle), per reported element
///   `<joint>_peak_rad` (`_m` for a slide; the largest peak of its coordinate) and
///   `<joint>_torque_peak_Nm` (`_N`; its spring-and-damper torque's, NaN without either),
///   `folds` (distinct folds over the branches, merged within [`FOLD_MERGE_TOL`]), `unstable`
///   (1 when some point is unstable, else 0) and `points` (solved points);
/// - linear response: `n_t` (tuning order: the first locked joint's eigen-order, spin held,
///   undamped), `n_r` (the free undamped eigen-order nearest n_t), `min_ratio`,
///   `min_ratio_order`, `max_ratio` (the peak of the response over the locked twin's),
///   `max_ratio_order`, `crossing_order` (first order above n_t with ratio > 1, NaN if none)
///   and `asymptote` (the ratio's high-order limit); orders are absolute.
pub fn result_columns(study: &Study, spec: &DesignSpec) -> Vec<ColumnInfo> {
    let c = |name: String, unit: &'static str| ColumnInfo { name, unit };
    match spec.analysis.as_ref() {
        AnalysisSpec::HarmonicBalance(h) => {
            let mut out: Vec<ColumnInfo> =
                h.multiples.iter().map(|m| c(format!("peak_accel_{}x_rad_s2", fmt_num(*m)), "rad/s²")).collect();
            out.push(c("max_relative_angle_rad".into(), "rad"));
            for &j in &study.elements {
                let joint = &study.mechanism.joints[j];
                let slide = !joint.kind.rotates();
                out.push(c(
                    format!("{}_peak_{}", joint.name, if slide { "m" } else { "rad" }),
                    if slide { "m" } else { "rad" },
                ));
                out.push(c(
                    format!("{}_torque_peak_{}", joint.name, if slide { "N" } else { "Nm" }),
                    if slide { "N" } else { "N·m" },
                ));
            }
            out.push(c("folds".into(), "1"));
            out.push(c("unstable".into(), "1"));
            out.push(c("points".into(), "1"));
            out
        }
        _ => [
            "n_t",
            "n_r",
            "min_ratio",
            "min_ratio_order",
            "max_ratio",
            "max_ratio_order",
            "crossing_order",
            "asymptote",
        ]
        .into_iter()
        .map(|n| c(n.into(), "1"))
        .collect(),
    }
}

/// The mechanism and analysis of one case: `values` substituted.
fn substitute(study: &Study, spec: &DesignSpec, values: &[f64]) -> Result<(Study, AnalysisSpec)> {
    let mut mech = study.mechanism.clone();
    let mut analysis = spec.analysis.as_ref().clone();
    let err = |m: String| Error::Model { mechanism: mech_name(study), message: m };
    for (p, &v) in spec.parameters.iter().zip(values) {
        // Names were resolved when the study was loaded.
        let body = p.quantity.body().and_then(|b| mech.body_index(b));
        let joint = p.quantity.joint().and_then(|j| mech.joint_index(j));
        match (&p.quantity, body, joint) {
            (Quantity::BodyMass(_), Some(b), _) => mech.bodies[b].inertia.mass = v,
            (Quantity::BodyInertia(_), Some(b), _) => mech.bodies[b].inertia.i_com = v,
            (Quantity::BodyComRadius(_), Some(b), _) => {
                let com = mech.bodies[b].inertia.com;
                mech.bodies[b].inertia.com = com * (v / com.norm());
            }
            (Quantity::JointStiffness(_), _, Some(j)) => {
                let free_angle = mech.joints[j].spring.map_or(0.0, |s| s.free_angle);
                mech.joints[j].spring = Some(Spring { stiffness: v, free_angle });
            }
            (Quantity::JointDamping(_), _, Some(j)) => mech.joints[j].damper = v,
            (Quantity::JointRadius(_), _, Some(j)) => {
                let at = mech.joints[j].at;
                mech.joints[j].at = at * (v / at.norm());
            }
            (Quantity::Rpm, ..) => match &mut analysis {
                AnalysisSpec::HarmonicBalance(h) => h.rpm = v,
                AnalysisSpec::LinearResponse(l) => l.rpm = v,
                _ => {}
            },
            (Quantity::TorqueAmplitude, ..) => {
                if let AnalysisSpec::HarmonicBalance(h) = &mut analysis {
                    h.amplitudes = vec![v];
                }
            }
            (Quantity::Order, ..) => {
                if let AnalysisSpec::HarmonicBalance(h) = &mut analysis {
                    match &mut h.parameter {
                        HbmParameter::Speed { order, .. } | HbmParameter::Torque { order, .. } => *order = v,
                        HbmParameter::Order => {}
                    }
                }
            }
            (q, ..) => return Err(err(format!("internal: the {} names nothing in the mechanism", q.describe()))),
        }
    }
    for (i, b) in mech.bodies.iter().enumerate() {
        if b.inertia.mass == 0.0 && b.inertia.i_com == 0.0 {
            return Err(err(format!("body `{}` (bodies[{i}]) has no mass and no inertia in this case", b.name)));
        }
    }
    // The engine's own check of M at q = 0 (positive definite, finite), as at load.
    Kane::new(&mech)?;
    let mut locked = None;
    for j in &study.spec.lock {
        let m = locked.as_ref().unwrap_or(&mech);
        locked = Some(m.lock(j, 0.0)?);
    }
    let locked_body = match &locked {
        Some(m) => Some(
            m.body_index(&study.spec.response_body).ok_or_else(|| err("locking merges the response body".into()))?,
        ),
        None => None,
    };
    if let Some(m) = &locked {
        Kane::new(m)?;
    }
    let spec_alone = StudySpec { analyses: Vec::new(), ..study.spec.clone() };
    let case = Study {
        spec: spec_alone,
        file: study.file.clone(),
        mechanism: mech,
        locked,
        spin: study.spin,
        elements: study.elements.clone(),
        body: study.body,
        locked_body,
        source: study.source.clone(),
    };
    Ok((case, analysis))
}

fn mech_name(study: &Study) -> String {
    study.mechanism.name.clone()
}

/// The largest finite value of `v`, NaN when there is none.
fn finite_max(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().filter(|x| x.is_finite()).fold(f64::NAN, f64::max)
}

/// Runs one case: `values` are its parameter values (a row of [`case_values`]). Never panics
/// into the caller: a panic becomes a failed row.
pub fn run_case(study: &Study, spec: &DesignSpec, index: usize, values: &[f64]) -> CaseRow {
    let n_results = result_columns(study, spec).len();
    let attempt = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| case_results(study, spec, values)));
    let (results, status, error) = match attempt {
        Ok(Ok((results, failures))) if failures.is_empty() => (results, CaseStatus::Ok, String::new()),
        Ok(Ok((results, failures))) => (results, CaseStatus::Partial, failures.join("; ")),
        Ok(Err(e)) => (vec![f64::NAN; n_results], CaseStatus::Failed, e.to_string()),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            (vec![f64::NAN; n_results], CaseStatus::Failed, format!("internal error (please report): {what}"))
        }
    };
    CaseRow { index, values: values.to_vec(), results, status, error }
}

/// The result columns' values of one case and the failures of its runs.
fn case_results(study: &Study, spec: &DesignSpec, values: &[f64]) -> Result<(Vec<f64>, Vec<String>)> {
    let (case, analysis) = substitute(study, spec, values)?;
    match &analysis {
        AnalysisSpec::HarmonicBalance(h) => {
            let (branches, failures) = super::hbm::compute(&case, h);
            if branches.is_empty() {
                return Err(Error::Model {
                    mechanism: mech_name(study),
                    message: format!("no branch solved: {}", failures.join("; ")),
                });
            }
            let mut out: Vec<f64> = (0..h.multiples.len())
                .map(|k| finite_max(branches.iter().flat_map(|b| b.accel[k].iter().copied())))
                .collect();
            out.push(finite_max(branches.iter().flat_map(|b| b.relative_angle.iter().copied())));
            for e in 0..case.elements.len() {
                let points = || branches.iter().flat_map(|b| b.elements.iter().filter_map(move |pt| pt.get(e)));
                out.push(finite_max(points().map(|r| r.peak)));
                out.push(finite_max(points().filter_map(|r| r.torque.as_ref().map(|t| t.peak))));
            }
            let mut folds: Vec<f64> = branches.iter().flat_map(|b| b.folds.iter().copied()).collect();
            folds.sort_by(f64::total_cmp);
            folds.dedup_by(|a, b| (*a - *b).abs() <= FOLD_MERGE_TOL * a.abs().max(b.abs()));
            out.push(folds.len() as f64);
            let stability: Vec<Option<bool>> = branches.iter().flat_map(|b| b.stable.iter().copied()).collect();
            out.push(if stability.iter().all(Option::is_none) {
                f64::NAN
            } else {
                f64::from(u8::from(stability.contains(&Some(false))))
            });
            out.push(branches.iter().map(|b| b.order.len()).sum::<usize>() as f64);
            Ok((out, failures))
        }
        AnalysisSpec::LinearResponse(l) => {
            let (r, failures) = super::linear::compute_response(&case, l)?;
            let nt = r.n_t.unwrap_or(f64::NAN);
            let n_r = r
                .free_orders
                .iter()
                .map(|(o, _)| *o)
                .min_by(|a, b| (a - nt).abs().total_cmp(&(b - nt).abs()))
                .filter(|_| nt.is_finite())
                .unwrap_or(f64::NAN);
            let v = r.variants.first().ok_or_else(|| Error::Model {
                mechanism: mech_name(study),
                message: "internal: a linear response without its variant".into(),
            })?;
            let out = vec![nt, n_r, v.min.1, v.min.0, v.max.1, v.max.0, v.crossing.unwrap_or(f64::NAN), v.asymptote];
            Ok((out, failures))
        }
        other => Err(Error::Model {
            mechanism: mech_name(study),
            message: format!("internal: {} is not run per case (refused at load)", other.kind()),
        }),
    }
}

/// Runs the cases `indices` of the design study (every case when None), in parallel with rayon
/// when `parallel`, and returns their rows in the order asked. `on_case` is called after each
/// case (from the worker threads), for progress.
///
/// # Errors
/// An index beyond the last case.
pub fn run_cases(
    study: &Study,
    spec: &DesignSpec,
    indices: Option<&[usize]>,
    parallel: bool,
    on_case: &(dyn Fn() + Sync),
) -> Result<Vec<CaseRow>> {
    let values = case_values(spec);
    let all: Vec<usize>;
    let indices = match indices {
        Some(i) => i,
        None => {
            all = (0..values.len()).collect();
            &all
        }
    };
    if let Some(&bad) = indices.iter().find(|&&i| i >= values.len()) {
        return Err(Error::Model {
            mechanism: mech_name(study),
            message: format!(
                "design study `{}` has {} cases (0..{}); no case {bad}",
                spec.name,
                values.len(),
                values.len()
            ),
        });
    }
    let one = |&i: &usize| {
        let row = run_case(study, spec, i, &values[i]);
        on_case();
        row
    };
    Ok(if parallel { indices.par_iter().map(one).collect() } else { indices.iter().map(one).collect() })
}

/// The design study named `name` of the study, if there is one.
pub fn find<'a>(study: &'a Study, name: &str) -> Option<&'a DesignSpec> {
    study.spec.analyses.iter().find_map(|a| match a {
        AnalysisSpec::DesignStudy(d) if d.name == name => Some(d),
        _ => None,
    })
}

/// Assembles the result of a design study from its rows (in case order).
pub fn result(study: &Study, spec: &DesignSpec, cases: Vec<CaseRow>) -> DesignResult {
    DesignResult {
        name: spec.name.clone(),
        parameters: parameter_columns(study, spec),
        results: result_columns(study, spec),
        cases,
    }
}

/// Most case failures listed one by one in the study's failures; the rest are counted.
const LISTED_FAILURES: usize = 20;

/// Runs every case in parallel, writes `<name>.csv` and returns the summary section.
pub(crate) fn run(study: &Study, spec: &DesignSpec, dir: &Path, progress: &super::sim::Progress) -> Result<Output> {
    let n = case_count(spec);
    let bar = progress.bar(n as f64 / 1000.0, &format!("{} ({n} cases)", spec.name));
    let rows = run_cases(study, spec, None, true, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let r = result(study, spec, rows);
    let mut failures = Vec::new();
    let bad: Vec<&CaseRow> = r.cases.iter().filter(|c| c.status != CaseStatus::Ok).collect();
    for c in bad.iter().take(LISTED_FAILURES) {
        failures.push(format!("{} case {} ({}): {}", spec.name, c.index, describe_case(&r, c), c.error));
    }
    if bad.len() > LISTED_FAILURES {
        failures.push(format!(
            "{}: {} more cases failed or are partial (see the status and error columns of {}.csv)",
            spec.name,
            bad.len() - LISTED_FAILURES,
            spec.name
        ));
    }
    let svg = dir.join(format!("{}.svg", spec.name));
    crate::plot::write_svg(&svg, &[figure(spec, &r)], 760, 500)?;
    let files = vec![write_csv(&r, dir)?, svg];
    let markdown = summary(study, spec, &r);
    Ok(Output { markdown, files, failures, results: Results::Design(r) })
}

/// Which group of the figure a case falls in.
type Grouping = Box<dyn Fn(&CaseRow) -> usize>;

/// Most groups of cases drawn apart in the figure (the palette's size).
const GROUPS: usize = 8;

/// The figure: the first result (a harmonic balance's peak main-order acceleration, on a log
/// axis; a linear response's n_t) against the first parameter, one colour per value of the second
/// parameter (a grid's values when there are at most eight, else eight equal bins of its range).
/// A grid of at most two parameters is drawn as lines through the first parameter's values;
/// anything else as points, which a line would join in no meaningful order.
fn figure(spec: &DesignSpec, r: &DesignResult) -> crate::plot::Panel {
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
fn describe_case(r: &DesignResult, c: &CaseRow) -> String {
    r.parameters.iter().zip(&c.values).map(|(p, v)| format!("{} = {v}", p.name)).collect::<Vec<_>>().join(", ")
}

/// Writes `<name>.csv`: `case`, the parameters, the results (empty cells for NaN), `status`,
/// `error`.
fn write_csv(r: &DesignResult, dir: &Path) -> Result<PathBuf> {
    let path = dir.join(format!("{}.csv", r.name));
    let io = |e: csv::Error| Error::Io { file: path.clone(), action: "cannot write", source: e.into() };
    let mut w = csv::Writer::from_path(&path).map_err(io)?;
    let mut header = vec!["case".to_string()];
    header.extend(r.parameters.iter().chain(&r.results).map(|c| c.name.clone()));
    header.extend(["status".to_string(), "error".to_string()]);
    w.write_record(&header).map_err(io)?;
    let cell = |v: f64| if v.is_finite() { v.to_string() } else { String::new() };
    for c in &r.cases {
        let mut rec = vec![c.index.to_string()];
        rec.extend(c.values.iter().chain(&c.results).map(|&v| cell(v)));
        rec.push(c.status.as_str().to_string());
        rec.push(c.error.clone());
        w.write_record(&rec).map_err(io)?;
    }
    w.flush().map_err(|e| Error::Io { file: path.clone(), action: "cannot write", source: e })?;
    Ok(path)
}

/// The summary section: what was varied and how, the case counts, and per result column its
/// smallest and largest value with the case.
fn summary(study: &Study, spec: &DesignSpec, r: &DesignResult) -> String {
    let mut md = String::new();
    let sampling = match spec.sampling {
        Sampling::Grid => "full grid".to_string(),
        Sampling::LatinHypercube { n, seed } => format!("Latin hypercube, {n} cases, seed {seed}"),
        Sampling::MonteCarlo { n, seed } => format!("Monte Carlo, {n} cases, seed {seed}"),
    };
    let _ = writeln!(
        md,
        "## Design study `{}`: {} `{}` per case, {sampling}\n",
        spec.name,
        spec.analysis.kind(),
        spec.analysis.name()
    );
    let _ = writeln!(md, "| parameter | quantity | unit | values |\n|---|---|---|---|");
    for (p, c) in spec.parameters.iter().zip(parameter_columns(study, spec)) {
        let values = match (&p.values, p.from, p.to) {
            (Some(v), ..) => v.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "),
            (None, Some(a), Some(b)) => format!(
                "{a} to {b}{}{}",
                p.points.map_or(String::new(), |n| format!(", {n} points")),
                if p.log { ", logarithmic" } else { "" }
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
    let _ = writeln!(md, "| result | unit | smallest | case | largest | case |\n|---|---|---|---|---|---|");
    for (k, col) in r.results.iter().enumerate() {
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
        let _ = writeln!(md, "| `{}` | {} | {lo} | {lo_case} | {hi} | {hi_case} |", col.name, col.unit);
    }
    md.push('\n');
    md
}

/// A number for the summary: six decimals when moderate, exponent form when tiny or huge.
fn num(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:.5e}") } else { format!("{v:.6}") }
}

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

mod analysis;
mod spec;
pub use spec::*;

mod check;
mod report;
mod sampling;
mod substitute;

pub(crate) use check::{check, check_mechanism_quantity, check_parameters};
pub use sampling::{below, case_count, case_values, uniform};
pub use substitute::substitute;
pub(crate) use substitute::{check_masses, set_quantity};

use crate::error::{Error, Result};
use crate::study::table::{Table, fmt_num};
use crate::study::{AnalysisSpec, HbmParameter, Output, Study, StudySpec};
use rayon::prelude::*;
use serde::Serialize;
use std::path::Path;

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

/// The status of one case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
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
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
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
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ColumnInfo {
    /// The CSV header.
    pub name: String,
    /// SI unit, `"1"` when dimensionless.
    pub unit: &'static str,
}

/// The results of a design study.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct DesignResult {
    /// Analysis name.
    pub name: String,
    /// The parameter columns.
    pub parameters: Vec<ColumnInfo>,
    /// The result columns.
    pub results: Vec<ColumnInfo>,
    /// One row per case, in case order.
    pub cases: Vec<CaseRow>,
    /// The operating range counted by `jumps_in_range` and `unison_losses_in_range` (a harmonic
    /// balance's; None otherwise), in its continued parameter's unit.
    pub operating: Option<(f64, f64)>,
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
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct DesignFindings {
    /// Cases run.
    pub cases: usize,
    /// Cases complete.
    pub ok: usize,
    /// Cases with some runs failed.
    pub partial: usize,
    /// Cases without results.
    pub failed: usize,
    /// Each result column's spread over the cases that have a value.
    pub quantiles: Vec<ColumnQuantiles>,
    /// A harmonic balance's: the fraction of the cases with results that jump (have a fold)
    /// inside the operating range (None for a linear response or without results).
    pub jump_fraction: Option<f64>,
    /// The same for a loss of unison (absorbers parting) inside the operating range.
    pub unison_loss_fraction: Option<f64>,
    /// The same for either.
    pub jump_or_unison_loss_fraction: Option<f64>,
}

/// The spread of one result column over the cases: the sample quantiles by linear interpolation
/// between order statistics (Hyndman and Fan's definition 7, numpy's default): with the n
/// values sorted, the p-quantile is at position `(n − 1) p` counted from 0.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct ColumnQuantiles {
    /// The CSV header.
    pub name: String,
    /// SI unit.
    pub unit: &'static str,
    /// Cases with a (finite) value.
    pub values: usize,
    /// Smallest value.
    pub min: f64,
    /// 5 % quantile.
    pub p05: f64,
    /// Median.
    pub p50: f64,
    /// 95 % quantile.
    pub p95: f64,
    /// Largest value.
    pub max: f64,
}

/// The p-quantile (definition 7) of sorted finite values; NaN when there are none.
fn quantile(sorted: &[f64], p: f64) -> f64 {
    let Some(last) = sorted.len().checked_sub(1) else { return f64::NAN };
    let h = last as f64 * p;
    let k = (h.floor() as usize).min(last);
    let above = sorted[(k + 1).min(last)];
    sorted[k] + (h - k as f64) * (above - sorted[k])
}

/// The findings of `r`.
pub fn findings(r: &DesignResult) -> DesignFindings {
    let (ok, partial, failed) = r.counts();
    let quantiles = r
        .results
        .iter()
        .enumerate()
        .map(|(k, col)| {
            let mut v: Vec<f64> = r.cases.iter().map(|c| c.results[k]).filter(|x| x.is_finite()).collect();
            v.sort_by(f64::total_cmp);
            ColumnQuantiles {
                name: col.name.clone(),
                unit: col.unit,
                values: v.len(),
                min: quantile(&v, 0.0),
                p05: quantile(&v, 0.05),
                p50: quantile(&v, 0.5),
                p95: quantile(&v, 0.95),
                max: quantile(&v, 1.0),
            }
        })
        .collect();
    let column = |name: &str| r.results.iter().position(|c| c.name == name);
    let counted: Vec<(f64, f64)> = match (column("jumps_in_range"), column("unison_losses_in_range")) {
        (Some(j), Some(u)) => r
            .cases
            .iter()
            .map(|c| (c.results[j], c.results[u]))
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .collect(),
        _ => Vec::new(),
    };
    let fraction = |hit: &dyn Fn(&(f64, f64)) -> bool| {
        (!counted.is_empty()).then(|| counted.iter().filter(|c| hit(c)).count() as f64 / counted.len() as f64)
    };
    DesignFindings {
        cases: r.cases.len(),
        ok,
        partial,
        failed,
        quantiles,
        jump_fraction: fraction(&|c| c.0 > 0.0),
        unison_loss_fraction: fraction(&|c| c.1 > 0.0),
        jump_or_unison_loss_fraction: fraction(&|c| c.0 > 0.0 || c.1 > 0.0),
    }
}

// ---------------------------------------------------------------------------------------------
// Plan

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
                .is_some_and(|j| study.mechanism.joints[j].kind.slide_axis().is_some());
            let suffix = p.quantity.suffix(slide);
            let name = if suffix.is_empty() { p.name.clone() } else { format!("{}_{suffix}", p.name) };
            ColumnInfo { name, unit: p.quantity.unit(slide) }
        })
        .collect()
}

/// How many folds and how many branch points a harmonic-balance case lists by position.
const EVENTS_LISTED: usize = 2;

/// The localisation index of a case's absorbers: the largest of their peak amplitudes (each the
/// largest over every solved point) over their mean; 1 when they move alike, NaN with fewer
/// than two absorbers among the reported elements.
fn localisation(case: &Study, branches: &[crate::study::HbmBranch]) -> f64 {
    let absorbers: Vec<String> =
        crate::model::absorber::absorbers(&case.mechanism).into_iter().map(|a| a.joint).collect();
    let peaks: Vec<f64> = case
        .elements
        .iter()
        .enumerate()
        .filter(|(_, j)| absorbers.contains(&case.mechanism.joints[**j].name))
        .map(|(e, _)| {
            finite_max(branches.iter().flat_map(|b| b.elements.iter().filter_map(move |pt| pt.get(e)).map(|r| r.peak)))
        })
        .collect();
    if peaks.len() < 2 {
        return f64::NAN;
    }
    let mean = peaks.iter().sum::<f64>() / peaks.len() as f64;
    peaks.iter().copied().fold(f64::NEG_INFINITY, f64::max) / mean
}

/// The result columns of each case, by analysis:
/// - harmonic balance: `peak_accel_<m>x_rad_s2` per reported multiple m (the largest response
///   acceleration amplitude at order m·n over every solved point of every branch, stable or
///   not), `max_relative_angle_rad` (the largest peak relative angle), per reported element
///   `<joint>_peak_rad` (`_m` for a slide; the largest peak of its coordinate) and
///   `<joint>_torque_peak_Nm` (`_N`; its spring-and-damper torque's, NaN without either),
///   `folds` (distinct folds over the branches, merged within [`FOLD_MERGE_TOL`]), `fold_1`,
///   `fold_2` and `branch_point_1`, `branch_point_2` (the lowest distinct folds and branch
///   points, where identical absorbers leave unison, in the continued parameter's unit, NaN
///   where fewer; suffixed `_rpm` or `_Nm` for a speed or torque continuation),
///   `unison_lost_1`, `unison_lost_2` (the lowest distinct values where absorbers leave unison:
///   branch points, and the folds whose critical motion moves them apart, as a mistuned set's
///   do; [`crate::study::parts_absorbers`]), `jumps_in_range` and `unison_losses_in_range`
///   (how many distinct folds, where a sweep jumps, and places where absorbers part, lie inside
///   the [`operating_range`]), `localisation_index` (the
///   absorbers' largest peak over their mean, NaN with fewer than two), `unstable` (1 when some
///   point is unstable, else 0) and `points` (solved points);
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
            let (suffix, unit) = match h.parameter {
                HbmParameter::Order => ("", "1"),
                HbmParameter::Speed { .. } => ("_rpm", "rpm"),
                HbmParameter::Torque { .. } => ("_Nm", "N·m"),
            };
            for what in ["fold", "branch_point", "unison_lost"] {
                for k in 1..=EVENTS_LISTED {
                    out.push(c(format!("{what}_{k}{suffix}"), unit));
                }
            }
            out.push(c("jumps_in_range".into(), "1"));
            out.push(c("unison_losses_in_range".into(), "1"));
            out.push(c("localisation_index".into(), "1"));
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

/// The operating range of a design study's harmonic balance, in its continued parameter's unit:
/// the study's `operating`, else the analysis's whole range.
pub fn operating_range(spec: &DesignSpec, h: &crate::study::HbmSpec) -> (f64, f64) {
    spec.operating.unwrap_or(match h.parameter {
        HbmParameter::Order => (h.order_min, h.order_max),
        HbmParameter::Speed { rpm_min, rpm_max, .. } => (rpm_min, rpm_max),
        HbmParameter::Torque { min, max, .. } => (min, max),
    })
}

pub(super) fn mech_name(study: &Study) -> String {
    study.mechanism.name.clone()
}

/// The values of `v` ascending, those within [`FOLD_MERGE_TOL`] (relative) of the previous kept
/// one dropped: the same event found by the branches from both ends of a range counts once.
fn distinct(v: impl IntoIterator<Item = f64>) -> Vec<f64> {
    let mut v: Vec<f64> = v.into_iter().collect();
    v.sort_by(f64::total_cmp);
    v.dedup_by(|a, b| (*a - *b).abs() <= FOLD_MERGE_TOL * a.abs().max(b.abs()));
    v
}

/// The largest finite value of `v`, NaN when there is none.
fn finite_max(v: impl IntoIterator<Item = f64>) -> f64 {
    v.into_iter().filter(|x| x.is_finite()).fold(f64::NAN, f64::max)
}

/// Runs one case: `values` are its parameter values (a row of [`case_values`]). Never panics
/// into the caller: a panic becomes a failed row.
pub fn run_case(study: &Study, spec: &DesignSpec, index: usize, values: &[f64]) -> CaseRow {
    let n_results = result_columns(study, spec).len();
    // Past the watchdog's deadline the remaining cases are not started.
    if let Some(d) = study.spec.integration.deadline
        && d.passed()
    {
        let error = format!("not run: {} (stopped by the watchdog)", crate::deadline::Deadline::overran(d.budget_s));
        return CaseRow {
            index,
            values: values.to_vec(),
            results: vec![f64::NAN; n_results],
            status: CaseStatus::Failed,
            error,
        };
    }
    let attempt = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| case_results(study, spec, values)));
    let (results, status, error) = match attempt {
        Ok(Ok((results, failures))) if failures.is_empty() => (results, CaseStatus::Ok, String::new()),
        Ok(Ok((results, failures))) => (results, CaseStatus::Partial, failures.join("; ")),
        Ok(Err(e)) => (vec![f64::NAN; n_results], CaseStatus::Failed, e.to_string()),
        Err(panic) => (vec![f64::NAN; n_results], CaseStatus::Failed, crate::error::internal_error(&*panic)),
    };
    CaseRow { index, values: values.to_vec(), results, status, error }
}

/// The result columns' values of one case and the failures of its runs.
fn case_results(study: &Study, spec: &DesignSpec, values: &[f64]) -> Result<(Vec<f64>, Vec<String>)> {
    let (case, analysis) = substitute(study, spec, values)?;
    match &analysis {
        AnalysisSpec::HarmonicBalance(h) => {
            let (branches, failures) = crate::study::hbm::compute(&case, h);
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
            let folds = distinct(branches.iter().flat_map(|b| b.folds.iter().copied()));
            out.push(folds.len() as f64);
            // The first folds and branch points (+1 off a fold: where identical or mistuned
            // absorbers leave unison), distinct, lowest first, NaN where fewer exist.
            let points = distinct(
                branches.iter().flat_map(|b| b.bifurcations.iter().filter(|x| x.1 == "branch point").map(|x| x.0)),
            );
            let lost = distinct(branches.iter().flat_map(|b| b.unison_lost.iter().copied()));
            for list in [&folds, &points, &lost] {
                out.extend((0..EVENTS_LISTED).map(|k| list.get(k).copied().unwrap_or(f64::NAN)));
            }
            // Every fold is a jump of a sweep, whether the absorbers turn together or apart.
            let (lo, hi) = operating_range(spec, h);
            let inside = |v: &&f64| (lo..=hi).contains(*v);
            out.push(folds.iter().filter(inside).count() as f64);
            out.push(lost.iter().filter(inside).count() as f64);
            out.push(localisation(&case, &branches));
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
            let (r, failures) = crate::study::linear::compute_response(&case, l)?;
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

/// The design study named `name` of the study, if there is one, with the study its cases run
/// on (see [`resolve`]).
pub fn find<'a>(study: &'a Study, name: &str) -> Option<(&'a Study, &'a DesignSpec)> {
    study.spec.analyses.iter().find_map(|a| match a {
        AnalysisSpec::DesignStudy(d) if d.name == name => Some(resolve(study, d)),
        _ => None,
    })
}

/// The study a design study's cases run on, and the design study as that study holds it: the
/// study itself, or for a design study with its own `mechanism` the study of that mechanism
/// read at load (`Study::sub_studies`). Falls back to the study itself if none was read.
pub fn resolve<'a>(study: &'a Study, spec: &'a DesignSpec) -> (&'a Study, &'a DesignSpec) {
    if spec.mechanism.is_none() {
        return (study, spec);
    }
    let sub = study
        .sub_studies
        .iter()
        .find(|(k, _)| study.spec.analyses.get(*k).is_some_and(|a| a.name() == spec.name))
        .and_then(|(_, subs)| subs.first())
        .map(|(_, s)| s);
    match sub.and_then(|s| s.spec.analyses.first().map(|a| (s, a))) {
        Some((s, AnalysisSpec::DesignStudy(d))) => (s, d),
        _ => (study, spec),
    }
}

/// Reads the mechanism of each design study that names its own (see
/// [`DesignSpec::mechanism`]) as a study holding that design study alone, checked as the study
/// file is read; its errors are moved to their place in the study file.
pub(crate) fn load_mechanisms(
    spec: &StudySpec,
    src: &crate::io::Source,
    opts: &crate::study::LoadOptions,
) -> Result<Vec<(usize, crate::study::compare::Compared)>> {
    let mut out = Vec::new();
    for (k, a) in spec.analyses.iter().enumerate() {
        let AnalysisSpec::DesignStudy(d) = a else { continue };
        let Some(file) = &d.mechanism else { continue };
        let alone = DesignSpec { mechanism: None, lock: Vec::new(), elements: Vec::new(), ..d.clone() };
        let sub = StudySpec {
            mechanism: file.clone(),
            analyses: vec![AnalysisSpec::DesignStudy(alone)],
            lock: d.lock.clone(),
            elements: d.elements.clone(),
            ..spec.clone()
        };
        let study = Study::from_spec(sub, src.clone(), opts).map_err(|e| {
            // A limit's refusal moved to its place is still a limit's.
            let limit = e.is_limit();
            match e {
                Error::Input { location, message } | Error::Limit { location, message }
                    if location.file == src.file =>
                {
                    let path = &location.path;
                    match path.strip_prefix("analyses[0]") {
                        Some(rest) => src.error(&format!("analyses[{k}]{rest}"), message),
                        // The design study's own `lock` and `elements` were the sub-study's.
                        None if path.starts_with("lock") || path.starts_with("elements") => {
                            src.error(&format!("analyses[{k}].{path}"), message)
                        }
                        None if path == "mechanism" => src.error(&format!("analyses[{k}].mechanism"), message),
                        None => src.error(
                            &format!("analyses[{k}].mechanism"),
                            format!("mechanism `{file}`: {path}: {message}"),
                        ),
                    }
                }
                other => other,
            }
            .limit_if(limit)
        })?;
        out.push((k, vec![(file.clone(), study)]));
    }
    Ok(out)
}

/// Assembles the result of a design study from its rows (in case order).
pub fn result(study: &Study, spec: &DesignSpec, cases: Vec<CaseRow>) -> DesignResult {
    DesignResult {
        name: spec.name.clone(),
        parameters: parameter_columns(study, spec),
        results: result_columns(study, spec),
        cases,
        operating: match spec.analysis.as_ref() {
            AnalysisSpec::HarmonicBalance(h) => Some(operating_range(spec, h)),
            _ => None,
        },
    }
}

/// Most case failures listed one by one in the study's failures; the rest are counted.
const LISTED_FAILURES: usize = 20;

/// Runs every case in parallel, writes `<name>.csv` and returns the summary section.
pub(crate) fn run(
    study: &Study,
    spec: &DesignSpec,
    dir: &Path,
    progress: &crate::study::sim::Progress,
) -> Result<Output> {
    let (study, spec) = resolve(study, spec);
    let n = case_count(spec);
    let bar = progress.bar(n as f64 / 1000.0, &format!("{} ({n} cases)", spec.name));
    let rows = run_cases(study, spec, None, true, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let r = result(study, spec, rows);
    let mut failures = Vec::new();
    let bad: Vec<&CaseRow> = r.cases.iter().filter(|c| c.status != CaseStatus::Ok).collect();
    for c in bad.iter().take(LISTED_FAILURES) {
        failures.push(format!("{} case {} ({}): {}", spec.name, c.index, report::describe_case(&r, c), c.error));
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
    crate::plot::write_svg(&svg, &[report::figure(spec, &r)], 760, 500)?;
    let files = vec![report::write_csv(&r, dir)?, svg];
    let markdown = report::summary(study, spec, &r);
    Ok(Output { markdown, files, failures, results: Box::new(r) })
}

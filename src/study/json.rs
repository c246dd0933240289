//! `results.json`: every number of a study run in one machine-readable file next to
//! `summary.md`, described by the JSON Schema `docs/results.schema.json`.
//!
//! The document holds, per analysis of the study file (in its order):
//! - `result`: the analysis's results as the library returns them ([`SweepRun`],
//!   [`MultiOrderResult`], [`LinearResult`], [`Campbell`], [`HbmBranch`]), serialised field by
//!   field;
//! - `findings`: the numbers the summary reads off those results (minima, intervals, ratios,
//!   counts), computed by the same functions the summary uses;
//! - `tables`: the columns of every CSV file the analysis writes, with their units, in the file's
//!   column order; each value is the same f64 the CSV cell holds.
//!
//! Units: a column carries its SI unit (`"1"` for a dimensionless number such as an order or a
//! ratio); a field's unit is in its name (`wall_s`, `amplitude` in N·m as documented) and in the
//! schema's descriptions.
//!
//! A number that does not exist or does not apply (a ratio to a reference that does not answer,
//! a stability that was not computed) is NaN in memory, an empty cell in a CSV and `null` here:
//! JSON has no NaN or infinity, and a reader must not take a placeholder for data. serde_json
//! writes every non-finite f64 as `null`, so no other value can slip through.
//!
//! The Python package builds its study results from the same [`Document`], so both hold the
//! same data.

use super::hbm::{self, BranchFindings, HbmBranch};
use super::linear::{self, LinearResult};
use super::multi::{self, MultiOrderResult, SpeedFindings};
use super::sweep::{self, SweepFindings, SweepRun};
pub use super::table::{Column, Table};
use super::transient::{self, TransientResult};
use super::{AnalysisSpec, CampbellSpec, Study, StudyReport, StudySpec};
use crate::error::{Error, Result};
use crate::linear::Campbell;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The file name, in the study's output folder.
pub const FILE_NAME: &str = "results.json";

/// The document's `format` field.
pub const FORMAT: &str = "kanedyn-results";

/// The document's `format_version`: raised when a field changes meaning or is removed (adding
/// fields keeps it).
pub const FORMAT_VERSION: u32 = 1;

/// The whole of `results.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Document<'a> {
    /// Always [`FORMAT`].
    pub format: &'static str,
    /// [`FORMAT_VERSION`].
    pub format_version: u32,
    /// The kanedyn version that wrote it.
    pub kanedyn_version: &'static str,
    /// What was run.
    pub study: StudyInfo<'a>,
    /// `complete`, or `partial` when anything failed (see `failures`).
    pub status: &'static str,
    /// Every failure, as in the summary's "Failures" section.
    pub failures: &'a [String],
    /// One entry per analysis of the study file, in its order.
    pub analyses: Vec<AnalysisEntry<'a>>,
}

/// The study as run.
#[derive(Debug, Clone, Serialize)]
pub struct StudyInfo<'a> {
    /// The study's name (its output folder).
    pub name: &'a str,
    /// The study file.
    pub file: String,
    /// The mechanism.
    pub mechanism: MechanismInfo<'a>,
    /// The study file's content, defaults filled in.
    pub spec: &'a StudySpec,
}

/// The study's mechanism, as the summary names it.
#[derive(Debug, Clone, Serialize)]
pub struct MechanismInfo<'a> {
    /// Its name.
    pub name: &'a str,
    /// Its degrees of freedom.
    pub degrees_of_freedom: usize,
    /// The joints owning the coordinates, in coordinate order.
    pub coordinates: Vec<&'a str>,
}

/// One analysis of the study.
#[derive(Debug, Clone, Serialize)]
pub struct AnalysisEntry<'a> {
    /// Its index in the study file's `analyses`.
    pub index: usize,
    /// Its kind as written in the study file (`OrderSweep`, …).
    pub kind: &'static str,
    /// Its name.
    pub name: &'a str,
    /// `complete`; `partial` when some of its runs failed (the others are here); `failed` when
    /// it failed as a whole (no result, no findings, no tables).
    pub status: &'static str,
    /// Its failures (entries of the document's `failures`).
    pub failures: Vec<&'a str>,
    /// Its results (null when it failed as a whole).
    pub result: Option<AnalysisResult<'a>>,
    /// What the summary reads off them (null when it failed as a whole).
    pub findings: Option<AnalysisFindings>,
    /// Its CSV files' columns.
    pub tables: Vec<Table>,
}

impl AnalysisEntry<'_> {
    /// This entry's tables and, for a comparison, those of every compared mechanism's analyses:
    /// one per CSV file the analysis wrote.
    pub fn all_tables(&self) -> Vec<&Table> {
        let mut out: Vec<&Table> = self.tables.iter().collect();
        if let Some(AnalysisResult::Compare { mechanisms }) = &self.result {
            for m in mechanisms {
                for a in &m.analyses {
                    out.extend(a.all_tables());
                }
            }
        }
        out
    }
}

/// The results of one analysis, by kind.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum AnalysisResult<'a> {
    /// An order sweep's runs (the locked twin's included).
    OrderSweep {
        /// The runs, in the order they were run.
        runs: Vec<&'a SweepRun>,
    },
    /// A multi-order analysis.
    MultiOrder(&'a MultiOrderResult),
    /// A linear frequency response.
    LinearResponse(&'a LinearResult),
    /// A Campbell diagram.
    Campbell(&'a Campbell),
    /// A harmonic-balance analysis's branches.
    HarmonicBalance {
        /// The branches, two per amplitude (from each end of the range) unless one failed.
        branches: Vec<&'a HbmBranch>,
    },
    /// A design study's case table: columns, and per case its values, results, status and error.
    DesignStudy(&'a super::design::DesignResult),
    /// A transient or run-up.
    Transient(&'a TransientResult),
    /// A free oscillation's backbone.
    FreeOscillation(&'a super::FreeOscillationResult),
    /// A comparison: per mechanism, its analyses' entries (named `<comparison>_<label>_<analysis>`).
    Compare {
        /// Per mechanism, in the file's order.
        mechanisms: Vec<ComparedEntry<'a>>,
    },
}

/// One mechanism of a comparison in the document.
#[derive(Debug, Clone, Serialize)]
pub struct ComparedEntry<'a> {
    /// Its label.
    pub label: &'a str,
    /// Its mechanism's name.
    pub mechanism: &'a str,
    /// Its analyses, as the document's own entries.
    pub analyses: Vec<AnalysisEntry<'a>>,
}

/// What the summary reads off one analysis's results, by kind.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum AnalysisFindings {
    /// See [`SweepFindings`].
    OrderSweep(SweepFindings),
    /// Per speed.
    MultiOrder {
        /// See [`SpeedFindings`].
        speeds: Vec<SpeedFindings>,
    },
    /// Per damping variant.
    LinearResponse {
        /// See [`VariantFindings`].
        variants: Vec<VariantFindings>,
    },
    /// Per tracked mode.
    Campbell {
        /// See [`ModeFindings`].
        modes: Vec<ModeFindings>,
    },
    /// Per branch.
    HarmonicBalance {
        /// See [`BranchFindings`].
        branches: Vec<BranchFindings>,
    },
    /// See [`super::design::DesignFindings`].
    DesignStudy(super::design::DesignFindings),
    /// The peaks of the order cuts and the elements' largest excursions (as in the result).
    Transient {
        /// Per cut: signal, order, peak and its speed.
        cuts: Vec<CutFindings>,
    },
    /// The backbone read as orders relative to the linear one.
    FreeOscillation {
        /// Each amplitude's order over the linear order (NaN where none was measured).
        order_over_linear: Vec<f64>,
    },
    /// The labels of the compared mechanisms (their findings are in their entries).
    Compare {
        /// The labels, in the file's order.
        labels: Vec<String>,
    },
}

/// The summary's reading of one order cut of a transient.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CutFindings {
    /// The signal cut.
    pub signal: String,
    /// The order, cycles/rev.
    pub order: f64,
    /// The largest amplitude along the cut, in the signal's unit.
    pub peak: f64,
    /// The speed of that block, rpm.
    pub peak_rpm: f64,
}

/// The summary's orders of one linear-response variant in units of the tuning order n_t (None:
/// the study locks no joint, so n_t is not defined, or there is no crossing).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct VariantFindings {
    /// The variant's label.
    pub label: String,
    /// Order of the smallest ratio over n_t.
    pub min_order_over_nt: Option<f64>,
    /// Order of the largest ratio over n_t.
    pub max_order_over_nt: Option<f64>,
    /// First order above n_t with ratio > 1, over n_t.
    pub crossing_over_nt: Option<f64>,
}

/// The summary's reading of one tracked mode of a Campbell diagram.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeFindings {
    /// The mode's label (its dominant joint).
    pub label: String,
    /// Frequency at the lowest speed, Hz.
    pub frequency_at_min_rpm_hz: f64,
    /// Frequency at the highest speed, Hz.
    pub frequency_at_max_rpm_hz: f64,
    /// Frequency over the highest speed's rotation frequency: the mode's order there (NaN, so
    /// `null`, at 0 rpm).
    pub order_at_max_rpm: f64,
    /// Whether the mode's order is the same (to 1e-6 relative) at every non-zero speed: an
    /// order line.
    pub order_line: bool,
}

/// Writes `results.json` for `report`, a run of `study`, into `dir` and returns its path.
///
/// # Errors
/// When the file cannot be written.
pub fn write(study: &Study, report: &StudyReport, dir: &Path) -> Result<PathBuf> {
    let path = dir.join(FILE_NAME);
    let io = |e: std::io::Error| Error::Io { file: path.clone(), action: "cannot write", source: e };
    let file = std::fs::File::create(&path).map_err(io)?;
    let mut w = std::io::BufWriter::new(file);
    serde_json::to_writer(&mut w, &document(study, report)).map_err(|e| io(e.into()))?;
    std::io::Write::flush(&mut w).map_err(io)?;
    Ok(path)
}

/// The document for `report`, a run of `study` (see the module docs).
///
/// [`StudyReport::completed`] tells which analyses ran to the end; the results of each are found
/// by its name (sweeps, multi-order, linear and harmonic-balance results carry it) or, for
/// Campbell diagrams, by their order among the completed ones.
pub fn document<'a>(study: &'a Study, report: &'a StudyReport) -> Document<'a> {
    let mech = &study.mechanism;
    let coordinates = mech.joints.iter().filter(|j| j.coordinate.is_some()).map(|j| j.name.as_str()).collect();
    let analyses = entries(study, report, &report.completed);
    Document {
        format: FORMAT,
        format_version: FORMAT_VERSION,
        kanedyn_version: env!("CARGO_PKG_VERSION"),
        study: StudyInfo {
            name: &study.spec.name,
            file: study.file.display().to_string(),
            mechanism: MechanismInfo { name: &mech.name, degrees_of_freedom: mech.ndof(), coordinates },
            spec: &study.spec,
        },
        status: if report.failures.is_empty() { "complete" } else { "partial" },
        failures: &report.failures,
        analyses,
    }
}

/// The entries of `study`'s analyses, `completed` telling which ran to the end.
fn entries<'a>(study: &'a Study, report: &'a StudyReport, completed: &[bool]) -> Vec<AnalysisEntry<'a>> {
    let mut campbells = report.campbell.iter();
    study
        .spec
        .analyses
        .iter()
        .enumerate()
        .map(|(index, a)| {
            let prefix = format!("{} `{}` ", a.kind(), a.name());
            let inner = format!(": {} `{}`", a.kind(), a.name());
            let failures: Vec<&str> = report
                .failures
                .iter()
                .filter(|f| f.starts_with(&prefix) || f.contains(&inner))
                .map(String::as_str)
                .collect();
            let completed = completed.get(index).copied().unwrap_or(false);
            // The Campbell diagrams carry no name: the k-th completed one is the k-th result.
            let campbell = match a {
                AnalysisSpec::Campbell(_) if completed => campbells.next(),
                _ => None,
            };
            let (result, findings, tables) = if completed {
                parts(study, report, a, campbell).map_or((None, None, Vec::new()), |(r, f, t)| (Some(r), Some(f), t))
            } else {
                (None, None, Vec::new())
            };
            let status = match (&result, failures.is_empty()) {
                (None, _) => "failed",
                (Some(_), true) => "complete",
                (Some(_), false) => "partial",
            };
            AnalysisEntry { index, kind: a.kind(), name: a.name(), status, failures, result, findings, tables }
        })
        .collect()
}

/// The result, findings and tables of a completed analysis (None when its result is missing).
fn parts<'a>(
    study: &'a Study,
    report: &'a StudyReport,
    a: &AnalysisSpec,
    campbell: Option<&'a Campbell>,
) -> Option<(AnalysisResult<'a>, AnalysisFindings, Vec<Table>)> {
    Some(match a {
        AnalysisSpec::OrderSweep(s) => {
            let runs: Vec<&SweepRun> = report.sweeps.iter().filter(|r| r.analysis == s.name).collect();
            let (findings, tables) = (sweep::findings(s, &runs), sweep::tables(s, &runs));
            (AnalysisResult::OrderSweep { runs }, AnalysisFindings::OrderSweep(findings), tables)
        }
        AnalysisSpec::MultiOrder(m) => {
            let r = report.multi.iter().find(|r| r.name == m.name)?;
            let speeds = multi::findings(r);
            (AnalysisResult::MultiOrder(r), AnalysisFindings::MultiOrder { speeds }, vec![multi::table(study, m, r)])
        }
        AnalysisSpec::LinearResponse(l) => {
            let r = report.linear.iter().find(|r| r.name == l.name)?;
            let variants = linear_findings(r);
            (
                AnalysisResult::LinearResponse(r),
                AnalysisFindings::LinearResponse { variants },
                linear::response_tables(study, l, r),
            )
        }
        AnalysisSpec::Campbell(c) => {
            let r = campbell?;
            (
                AnalysisResult::Campbell(r),
                AnalysisFindings::Campbell { modes: campbell_findings(c, r) },
                super::campbell::campbell_tables(c, r),
            )
        }
        AnalysisSpec::HarmonicBalance(h) => {
            let branches: Vec<&HbmBranch> = report.hbm.iter().filter(|b| b.analysis == h.name).collect();
            let findings = hbm::findings(study, h, &branches, &report.sweeps);
            let tables = hbm::tables(&study.mechanism, h, &branches);
            (
                AnalysisResult::HarmonicBalance { branches },
                AnalysisFindings::HarmonicBalance { branches: findings },
                tables,
            )
        }
        AnalysisSpec::DesignStudy(d) => {
            let r = report.designs.iter().find(|r| r.name == d.name)?;
            (AnalysisResult::DesignStudy(r), AnalysisFindings::DesignStudy(super::design::findings(r)), vec![r.table()])
        }
        AnalysisSpec::Transient(t) => {
            let r = report.transient.iter().find(|r| r.name == t.name)?;
            let cuts = r
                .cuts
                .iter()
                .map(|c| CutFindings { signal: c.signal.clone(), order: c.order, peak: c.peak, peak_rpm: c.peak_rpm })
                .collect();
            (AnalysisResult::Transient(r), AnalysisFindings::Transient { cuts }, transient::tables(study, t, r))
        }
        AnalysisSpec::FreeOscillation(f) => {
            let r = report.free.iter().find(|r| r.name == f.name)?;
            let findings = AnalysisFindings::FreeOscillation { order_over_linear: r.order_ratios() };
            (AnalysisResult::FreeOscillation(r), findings, vec![super::backbone::table(r)])
        }
        AnalysisSpec::Compare(c) => {
            let r = report.compares.iter().find(|r| r.name == c.name)?;
            let subs = &study.comparisons.iter().find(|(k, _)| study.spec.analyses[*k].name() == c.name)?.1;
            let mechanisms = subs
                .iter()
                .zip(&r.mechanisms)
                .map(|((label, sub), m)| ComparedEntry {
                    label,
                    mechanism: &sub.mechanism.name,
                    analyses: entries(sub, report, &m.completed),
                })
                .collect();
            let labels = r.mechanisms.iter().map(|m| m.label.clone()).collect();
            (AnalysisResult::Compare { mechanisms }, AnalysisFindings::Compare { labels }, Vec::new())
        }
    })
}

/// The summary's orders in units of n_t, per variant.
fn linear_findings(r: &LinearResult) -> Vec<VariantFindings> {
    let over = |n: f64| r.n_t.map(|nt| n / nt);
    r.variants
        .iter()
        .map(|v| VariantFindings {
            label: v.label.clone(),
            min_order_over_nt: over(v.min.0),
            max_order_over_nt: over(v.max.0),
            crossing_over_nt: v.crossing.and_then(over),
        })
        .collect()
}

/// The summary's reading of each tracked mode (the rule of `study::linear`'s Campbell summary).
fn campbell_findings(spec: &CampbellSpec, c: &Campbell) -> Vec<ModeFindings> {
    let order = |f: f64, rpm: f64| if rpm > 0.0 { f / (rpm / 60.0) } else { f64::NAN };
    c.tracks
        .iter()
        .map(|t| {
            let orders: Vec<f64> =
                c.rpm.iter().zip(&t.frequency_hz).filter(|(r, _)| **r > 0.0).map(|(&r, &f)| order(f, r)).collect();
            let last = t.frequency_hz.last().copied().unwrap_or(f64::NAN);
            ModeFindings {
                label: t.label.clone(),
                frequency_at_min_rpm_hz: t.frequency_hz.first().copied().unwrap_or(f64::NAN),
                frequency_at_max_rpm_hz: last,
                order_at_max_rpm: order(last, spec.rpm_max),
                order_line: orders.iter().all(|o| (o - orders[0]).abs() <= 1e-6 * orders[0].abs()),
            }
        })
        .collect()
}

//! `results.json`: every number of a study run in one machine-readable file next to
//! `summary.md`, described by the JSON Schema `docs/results.schema.json`.
//!
//! The document holds, per analysis of the study file (in its order):
//! - `result`: the analysis's results as the library returns them ([`SweepRun`](super::SweepRun),
//!   [`MultiOrderResult`](super::MultiOrderResult), [`LinearResult`](super::LinearResult), …),
//!   serialised field by field by the analysis itself (`Analysis::json`, in its room);
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

pub use super::table::{Column, Table};
use super::{AnalysisSpec, Study, StudyReport, StudySpec};
use crate::error::{Error, Result};
use serde::Serialize;
use serde_json::value::RawValue;
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
    /// Its results as the library returns them, serialised field by field by the analysis
    /// (null when it failed as a whole).
    pub result: Option<Box<RawValue>>,
    /// What the summary reads off them (null when it failed as a whole).
    pub findings: Option<Box<RawValue>>,
    /// Its CSV files' columns.
    pub tables: Vec<Table>,
    /// The columns of the CSV files the analyses inside it wrote (a comparison's mechanisms'),
    /// which its result holds in their own entries.
    #[serde(skip)]
    pub inner_tables: Vec<Table>,
}

impl AnalysisEntry<'_> {
    /// This entry's tables and, for a comparison, those of every compared mechanism's analyses:
    /// one per CSV file the analysis wrote.
    pub fn all_tables(&self) -> Vec<&Table> {
        self.tables.iter().chain(&self.inner_tables).collect()
    }
}

/// An analysis's part of its entry: its results and what the summary reads off them, each as
/// the JSON it serialises to, and the columns of the CSV files it wrote (see
/// `Analysis::json`).
pub(crate) struct Json {
    /// The results.
    pub result: Box<RawValue>,
    /// What the summary reads off them.
    pub findings: Box<RawValue>,
    /// The columns of its CSV files.
    pub tables: Vec<Table>,
    /// The columns of the CSV files of the analyses inside it.
    pub inner_tables: Vec<Table>,
}

impl Json {
    /// The parts of an entry from the analysis's results and findings (None if they cannot be
    /// serialised, which the types here never refuse).
    pub fn new(result: &impl Serialize, findings: &impl Serialize, tables: Vec<Table>) -> Option<Self> {
        Some(Self {
            result: serde_json::value::to_raw_value(result).ok()?,
            findings: serde_json::value::to_raw_value(findings).ok()?,
            tables,
            inner_tables: Vec::new(),
        })
    }
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
pub(crate) fn entries<'a>(study: &'a Study, report: &'a StudyReport, completed: &[bool]) -> Vec<AnalysisEntry<'a>> {
    let analyses = &study.spec.analyses;
    analyses
        .iter()
        .enumerate()
        .map(|(index, a)| {
            let failures = failures_of(a, &report.failures);
            let completed_here = completed.get(index).copied().unwrap_or(false);
            let nth = nth_of_kind(analyses, completed, index);
            let parts = if completed_here { a.analysis().json(study, report, nth) } else { None };
            let (result, findings, tables, inner_tables) = match parts {
                Some(j) => (Some(j.result), Some(j.findings), j.tables, j.inner_tables),
                None => (None, None, Vec::new(), Vec::new()),
            };
            let status = match (&result, failures.is_empty()) {
                (None, _) => "failed",
                (Some(_), true) => "complete",
                (Some(_), false) => "partial",
            };
            AnalysisEntry {
                index,
                kind: a.kind(),
                name: a.name(),
                status,
                failures,
                result,
                findings,
                tables,
                inner_tables,
            }
        })
        .collect()
}

/// The entries of `failures` that belong to analysis `a`: its own (they start with its kind and
/// name) and those of the analyses a comparison ran inside it (they name it after a colon).
pub(crate) fn failures_of<'a>(a: &AnalysisSpec, failures: &'a [String]) -> Vec<&'a str> {
    let prefix = format!("{} `{}` ", a.kind(), a.name());
    let inner = format!(": {} `{}`", a.kind(), a.name());
    failures.iter().filter(|f| f.starts_with(&prefix) || f.contains(&inner)).map(String::as_str).collect()
}

/// How many analyses of the kind of `analyses[index]` ran to the end before it (`completed`
/// telling which did): a result that carries no name (a Campbell diagram) is found by its place
/// among them.
pub(crate) fn nth_of_kind(analyses: &[AnalysisSpec], completed: &[bool], index: usize) -> usize {
    let kind = analyses[index].kind();
    analyses[..index].iter().zip(completed).filter(|(b, done)| **done && b.kind() == kind).count()
}

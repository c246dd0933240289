//! The analysis interface: what the study driver asks of every kind of analysis, so that the
//! driver (loading, checking, planning, running, reporting) never names a kind.
//!
//! An analysis's life in a study is spec → checks → plan → run → outputs:
//! - its spec is the serde type of its entry in the study file (`study/<analysis>/spec.rs`),
//!   registered once in [`AnalysisSpec`](super::AnalysisSpec);
//! - [`Analysis::check`] refuses what it cannot run, with the file, line and field, before any
//!   work; [`Analysis::files`] names the files it may write, so that two analyses that would
//!   write the same file are refused at load;
//! - [`Analysis::plan`] estimates its work from the file alone, against the limits;
//! - [`Analysis::run`] writes its CSV and SVG files and returns its summary section, its failures
//!   and its results ([`Output`]); [`Kept`] files the results into the
//!   [`StudyReport`].

use super::plan::AnalysisPlan;
use super::sim::Progress;
use super::{Study, StudyReport, StudySpec};
use crate::error::Result;
use crate::io::Source;
use crate::model::mechanism::Mechanism;
use std::path::{Path, PathBuf};

/// One kind of analysis, as the study driver sees it.
pub(crate) trait Analysis {
    /// The analysis's name (its file prefix).
    fn name(&self) -> &str;

    /// Checks its fields against the study and the mechanism; an error names its field under
    /// `analyses[k]`.
    fn check(&self, c: &Checks<'_>) -> Result<()>;

    /// The names of the files it may write into the study's folder: a superset of what a run
    /// writes (see `validate::outputs`). `locked` says whether the study has a locked twin.
    fn files(&self, locked: bool) -> Vec<String>;

    /// Its estimated work; `base` carries its name, kind and index and zeros elsewhere.
    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan;

    /// Runs it, writing its files into `bench.dir`.
    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output>;
}

/// What an analysis's checks see: the study as written, its mechanism and spin joint, the file
/// (to locate errors) and the analysis's index in `analyses`.
#[derive(Clone, Copy)]
pub(crate) struct Checks<'a> {
    /// The study as written.
    pub spec: &'a StudySpec,
    /// The study's mechanism.
    pub mech: &'a Mechanism,
    /// Index of the spin joint.
    pub spin: usize,
    /// The study file.
    pub src: &'a Source,
    /// Index of the analysis in `analyses`.
    pub k: usize,
}

impl Checks<'_> {
    /// The path of one of the analysis's fields, `analyses[k].field`.
    pub fn at(&self, field: &str) -> String {
        format!("analyses[{}].{field}", self.k)
    }
}

/// Where an analysis runs: the output folder, the progress display, and the results of the
/// analyses that ran before it, which a comparison also files its inner analyses' results into.
pub(crate) struct Bench<'a> {
    /// The study's output folder (the temporary one until the run ends).
    pub dir: &'a Path,
    /// Progress bars on a terminal.
    pub progress: &'a Progress,
    /// The results so far.
    pub report: &'a mut StudyReport,
}

/// What one analysis hands back to the study driver: its summary section, the files it wrote,
/// the runs that failed and its results.
pub(crate) struct Output {
    /// Its section of `summary.md`.
    pub markdown: String,
    /// The files it wrote, in order.
    pub files: Vec<PathBuf>,
    /// Its runs that failed, each with the reason.
    pub failures: Vec<String>,
    /// Its results, to be filed into the study report.
    pub results: Box<dyn Kept>,
}

/// Results that know their place in the [`StudyReport`].
pub(crate) trait Kept {
    /// Files the results into `report`.
    fn keep(self: Box<Self>, report: &mut StudyReport);
}

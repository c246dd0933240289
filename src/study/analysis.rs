//! The analysis interface: what the study driver asks of every kind of analysis, so that the
//! driver (loading, checking, planning, running, reporting) never names a kind.
//!
//! An analysis's life in a study is spec → checks → plan → run → outputs:
//! - its spec is the serde type of its entry in the study file (`study/<analysis>/spec.rs`),
//!   with a `name: String` field (its file prefix), registered once in
//!   [`AnalysisSpec`](super::AnalysisSpec);
//! - [`Analysis::check`] refuses what it cannot run, with the file, line and field, before any
//!   work; [`Analysis::files`] names the files it may write, so that two analyses that would
//!   write the same file are refused at load;
//! - [`Analysis::plan`] estimates its work from the file alone, against the limits;
//! - [`Analysis::run`] writes its CSV and SVG files and returns its summary section, its failures
//!   and its results ([`Output`]); [`Kept`] files the results into the [`StudyReport`];
//! - [`Analysis::json`] gives its entry in `results.json` from those results, and
//!   [`Analysis::digest`] its line in the terminal's digest.

use super::json::Json;
use super::plan::AnalysisPlan;
use super::sim::Progress;
use super::{Study, StudyReport, StudySpec};
use crate::combustion::Engine;
use crate::error::{Error, Result};
use crate::io::ReadPolicy;
use crate::io::Source;
use crate::model::mechanism::Mechanism;
use schemars::{Schema, SchemaGenerator};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// One kind of analysis, as the study driver sees it.
pub(crate) trait Analysis {
    /// Renames the earlier analyses it names (a harmonic balance's sweep overlay) by `rename`,
    /// when a comparison runs it under a name per mechanism (its own `name` field is renamed by
    /// the registry); most analyses name none.
    fn rename_references(&mut self, _rename: &dyn Fn(&str) -> String) {}

    /// Whether a comparison may run this kind on several mechanisms (a property of the kind,
    /// so that the registry can list the kinds that may).
    fn comparable() -> bool
    where
        Self: Sized,
    {
        false
    }

    /// Checks its fields against the study and the mechanism; an error names its field under
    /// `analyses[k]`.
    fn check(&self, c: &Checks<'_>) -> Result<()>;

    /// The names of the files it may write into the study's folder: a superset of what a run
    /// writes (see `validate::outputs`). `locked` says whether the study has a locked twin.
    fn files(&self, locked: bool) -> Vec<String>;

    /// Resolves what it reads besides the study file (an engine file), when the study is loaded;
    /// most analyses read nothing else.
    fn prepare(&mut self, _resources: &mut Resources<'_>) -> Result<()> {
        Ok(())
    }

    /// Its estimated work; `base` carries its name, kind and index and zeros elsewhere.
    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan;

    /// Runs it, writing its files into `bench.dir`.
    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output>;

    /// Its entry's parts in `results.json`, from its results in `report` (None when they are
    /// missing). `nth`: how many analyses of its kind ran to the end before it in the same list,
    /// which finds a result that carries no name.
    fn json(&self, study: &Study, report: &StudyReport, nth: usize) -> Option<Json>;

    /// The JSON Schemas of its entry's `result` and `findings`: those of the types
    /// [`Analysis::json`] serialises (a property of the kind, for the registry's schema).
    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema)
    where
        Self: Sized;

    /// Its key findings in one line for the terminal's digest (see `digest`), read off its
    /// results in `report` by the functions its summary section uses; None when they are
    /// missing. `nth` as for [`Analysis::json`].
    fn digest(&self, study: &Study, report: &StudyReport, nth: usize) -> Option<String>;
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

/// What an analysis may read besides the study file when the study is loaded: the engine files
/// it names, each read and prepared once however many analyses name it.
pub(crate) struct Resources<'a> {
    /// The study file, to locate errors.
    pub src: &'a Source,
    /// Where files may be read from.
    policy: &'a ReadPolicy,
    /// The study file's folder, which relative paths start from.
    base: &'a Path,
    /// The engines read so far, by path.
    engines: HashMap<PathBuf, Engine>,
    /// Index of the analysis being prepared in `analyses`.
    pub k: usize,
}

impl<'a> Resources<'a> {
    /// Nothing read yet.
    pub fn new(src: &'a Source, policy: &'a ReadPolicy, base: &'a Path) -> Self {
        Self { src, policy, base, engines: HashMap::new(), k: 0 }
    }

    /// The engine in `file` (relative to the study file), named by the study field `field`;
    /// errors are located in the study file or in the engine file.
    pub fn engine(&mut self, field: &str, file: &str) -> Result<Engine> {
        let src = self.src;
        let path = self.policy.resolve(self.base, file).map_err(|e| src.error(field, e))?;
        if let Some(e) = self.engines.get(&path) {
            return Ok(e.clone());
        }
        let esrc = Source::read_with(&path, self.policy).map_err(|e| match e {
            Error::Io { .. } => src.error(field, format!("cannot read engine file: {e}")),
            other => whole_file_at(other, src, field),
        })?;
        let engine = Engine::new(esrc.parse_as("Engine")?).map_err(|(f, msg)| esrc.error(&f, msg))?;
        self.engines.insert(path, engine.clone());
        Ok(engine)
    }
}

/// An error about a whole file that a study names (a folder, a pipe, a file over the size cap:
/// no line, no field), moved to the study field that named it; other errors unchanged. Such
/// errors used to name the file alone, not where the study asked for it.
pub(crate) fn whole_file_at(e: Error, src: &Source, field: &str) -> Error {
    let limit = e.is_limit();
    match e {
        Error::Input { location, message } | Error::Limit { location, message }
            if location.line_col.is_none() && location.path.is_empty() =>
        {
            src.error(field, format!("{}: {message}", location.file.display())).limit_if(limit)
        }
        other => other,
    }
}

//! The study driver: [`run`] takes a loaded study through its analyses in order, each guarded
//! ([`run_guarded`]: a failure or panic of one analysis becomes its summary section and a listed
//! failure, never the others' loss), and writes the summary, `results.json` and `report.html`
//! around their sections.

use super::analysis;
use super::{AnalysisSpec, Study, StudyReport, finite_text, json, output, report_html, sim, write_file};
use crate::error::Result;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Options of [`run`].
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output root; the study writes into `<out>/<study name>/` (default `out`).
    pub out: Option<PathBuf>,
    /// Show progress bars on stderr (only drawn when stderr is a terminal).
    pub progress: bool,
}

/// Runs every analysis of the study, writes the outputs and returns the summary.
///
/// One failure never costs the others their results: an analysis (or one run of it) that fails
/// or panics is listed under "Failures" in the summary and in [`StudyReport::failures`] with its
/// file:line:column, its partial output is kept, and the remaining analyses still run. The
/// outputs are written into a temporary folder that replaces `<out>/<name>/` only at the end
/// (see `output`), and `summary.md` is always written, with `results.json` (every number of
/// the summary and the CSV files, see [`json`]) next to it.
///
/// # Errors
/// Only when the output folder cannot be prepared or moved into place, or another run holds it.
pub fn run(study: &Study, opts: &RunOptions) -> Result<StudyReport> {
    let root = opts.out.clone().unwrap_or_else(|| PathBuf::from("out"));
    let out = output::OutputDir::begin(&root, &study.spec.name)?;
    let dir = out.dir().to_path_buf();
    let progress = sim::Progress::new(opts.progress);
    let mut report = StudyReport::default();
    let mut md = String::new();
    let _ = writeln!(md, "# Study `{}`\n", study.spec.name);
    let _ = writeln!(
        md,
        "Mechanism `{}` ({} DOF), spin joint `{}` (the steady rotation; the excitation acts there unless an \
         analysis lists its joints in `excite`), response: angular acceleration of `{}`{}.\n",
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
    // The absorbers' properties once, before the analyses (empty without an absorber).
    let absorbers = crate::model::absorber::markdown(&study.mechanism);
    let mut sections = absorbers.clone();
    // Each analysis's section and files, for report.html to put its figures under its section.
    let mut parts = Vec::new();
    let plan = study.plan();
    for (k, a) in study.spec.analyses.iter().enumerate() {
        let where_ = study.source.locate(&format!("analyses[{k}]")).to_string();
        // The watchdog: this analysis's loops stop once it overruns its plan by the set factor.
        let budget_s = study.spec.integration.watchdog.budget_s(plan.analyses[k].cpu_s);
        let timed = study.with_deadline(budget_s);
        let first = report.files.len();
        let (section, completed) = run_guarded(&timed, a, &where_, &dir, &progress, &mut report);
        report.completed.push(completed);
        sections += &section;
        parts.push(report_html::Part {
            spec: a,
            markdown: finite_text(&section),
            files: report.files[first..].to_vec(),
        });
    }
    if report.failures.is_empty() {
        md += "Status: complete.\n\n";
    } else {
        let _ = writeln!(
            md,
            "**Status: partial results** — {} failure(s), listed under Failures at the end; the other \
             results are complete.\n",
            report.failures.len()
        );
    }
    let head = finite_text(&(md.clone() + &absorbers));
    md += &sections;
    for f in &mut report.failures {
        *f = finite_text(f);
    }
    let mut tail = String::new();
    if !report.failures.is_empty() {
        let _ = writeln!(tail, "## Failures\n");
        for f in &report.failures {
            let _ = writeln!(tail, "- {f}");
        }
        tail.push('\n');
    }
    md += &tail;
    let md = finite_text(&md);
    let path = dir.join("summary.md");
    write_file(&path, &md)?;
    report.files.push(path);
    report.files.push(json::write(study, &report, &dir)?);
    let page = report_html::write(
        &dir,
        &study.spec.name,
        (&head, &parts, &finite_text(&tail)),
        &report.failures,
        &report.files,
    )?;
    report.files.push(page);
    report.summary = md;
    let final_dir = out.finish()?;
    for f in &mut report.files {
        if let Ok(rel) = f.strip_prefix(&dir) {
            *f = final_dir.join(rel);
        }
    }
    Ok(report)
}

/// Runs one analysis with its failures named and contained: a failure or panic of the whole
/// analysis becomes its summary section and an entry of [`StudyReport::failures`]; failures of
/// single runs are prefixed with the analysis's kind, name and `where_` (its place in the study
/// file). Returns the summary section and whether the analysis ran to the end.
pub(crate) fn run_guarded(
    study: &Study,
    a: &AnalysisSpec,
    where_: &str,
    dir: &Path,
    progress: &sim::Progress,
    report: &mut StudyReport,
) -> (String, bool) {
    let before = report.failures.len();
    let attempt =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_analysis(study, a, dir, progress, report)));
    for f in &mut report.failures[before..] {
        *f = format!("{} `{}` ({where_}): {f}", a.kind(), a.name());
    }
    let failure = match attempt {
        Ok(Ok(section)) => return (section, true),
        Ok(Err(e)) => e.to_string(),
        Err(panic) => crate::error::internal_error(&*panic),
    };
    report.failures.push(format!("{} `{}` ({where_}): {failure}", a.kind(), a.name()));
    (format!("## {} `{}`\n\nFailed: {failure}\n\n", a.kind(), a.name()), false)
}

/// Runs one analysis, adding its files, failures and results to `report`; returns its section of
/// the summary.
pub(crate) fn run_analysis(
    study: &Study,
    a: &AnalysisSpec,
    dir: &Path,
    progress: &sim::Progress,
    report: &mut StudyReport,
) -> Result<String> {
    let out = a.analysis().run(study, &mut analysis::Bench { dir, progress, report })?;
    report.files.extend(out.files);
    report.failures.extend(out.failures);
    out.results.keep(report);
    Ok(out.markdown)
}

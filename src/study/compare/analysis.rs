//! Compare through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`.

use super::{CompareResult, CompareSpec, run};
use crate::error::Result;
use crate::io::Source;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output};
use crate::study::digest::count;
use crate::study::json::{AnalysisEntry, Json, entries};
use crate::study::plan::AnalysisPlan;
use crate::study::plan::JSON_PER_CSV_BYTE;
use crate::study::validate::{MAX_ANALYSES, check_file_name};
use crate::study::{AnalysisSpec, Study};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// A comparison's `result` in `results.json`.
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "CompareResult")]
struct Mechanisms<'a> {
    /// Per compared mechanism, in the file's order.
    mechanisms: Vec<ComparedEntry<'a>>,
}

/// What the summary reads off a comparison (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "CompareFindings")]
struct Findings {
    /// The mechanisms' labels, in the file's order.
    labels: Vec<String>,
}

impl Analysis for CompareSpec {
    fn check(&self, c: &Checks<'_>) -> Result<()> {
        check_compare(c.src, c.k, self)
    }

    fn files(&self, locked: bool) -> Vec<String> {
        let n = self.name.as_str();
        let mut out = Vec::new();
        let _csv = |stem: String| out.push(format!("{stem}.csv"));
        let c = self;
        // The overlay figure per inner analysis, then every inner analysis's own files under
        // its run name `<comparison>_<label>_<analysis>`.
        out.extend(c.analyses.iter().map(|a| format!("{n}_{}.svg", a.name())));
        for m in &c.mechanisms {
            let locked = m.lock.as_ref().map_or(locked, |l| !l.is_empty());
            for inner in &c.analyses {
                out.extend(super::renamed(n, &m.label, inner).analysis().files(locked));
            }
        }
        out
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, _fs, _n, _locked) = crate::study::plan::basics(study);
        let c = self;
        let subs = study.sub_studies.iter().find(|(k, _)| *k == base.index).map(|(_, s)| s.as_slice());
        let plans: Vec<AnalysisPlan> = subs.unwrap_or(&[]).iter().flat_map(|(_, s)| s.plan().analyses).collect();
        let sum = |f: &dyn Fn(&AnalysisPlan) -> f64| plans.iter().map(f).sum::<f64>();
        AnalysisPlan {
            runs: plans.iter().map(|p| p.runs).sum(),
            samples_per_run: plans.iter().map(|p| p.samples_per_run).fold(0.0, f64::max),
            memory_bytes: sum(&|p| p.memory_bytes),
            // The inner plans count their JSON share already (removed here, as
            // it is added to every analysis below).
            output_bytes: sum(&|p| p.output_bytes) / (1.0 + JSON_PER_CSV_BYTE) + c.analyses.len() as f64 * 1e5,
            cpu_s: sum(&|p| p.cpu_s),
            driver: "analyses",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run(study, self, bench.dir, bench.progress, bench.report)
    }

    fn json(&self, study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let r = report.compares.iter().find(|r| r.name == self.name)?;
        let subs = &study.sub_studies.iter().find(|(k, _)| study.spec.analyses[*k].name() == self.name)?.1;
        let mechanisms: Vec<ComparedEntry> = subs
            .iter()
            .zip(&r.mechanisms)
            .map(|((label, sub), m)| ComparedEntry {
                label,
                mechanism: &sub.mechanism.name,
                analyses: entries(sub, report, &m.completed),
            })
            .collect();
        let labels = r.mechanisms.iter().map(|m| m.label.clone()).collect();
        // The comparison writes no table of its own: its mechanisms' analyses do.
        let inner = mechanisms.iter().flat_map(|m| &m.analyses).flat_map(|a| a.all_tables()).cloned().collect();
        let mut json = Json::new(&Mechanisms { mechanisms }, &Findings { labels }, Vec::new())?;
        json.inner_tables = inner;
        Some(json)
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<Mechanisms<'static>>(), generator.subschema_for::<Findings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let r = report.compares.iter().find(|r| r.name == self.name)?;
        let labels: Vec<&str> = r.mechanisms.iter().map(|m| m.label.as_str()).collect();
        let runs: usize = r.mechanisms.iter().map(|m| m.completed.len()).sum();
        let done: usize = r.mechanisms.iter().map(|m| m.completed.iter().filter(|c| **c).count()).sum();
        Some(format!(
            "{} ({}): {done} of {runs} analyses complete",
            count(labels.len(), "mechanism", "mechanisms"),
            labels.join(", ")
        ))
    }
}

impl Kept for CompareResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.compares.push(*self);
    }
}

/// A comparison: 1 to 8 mechanisms with distinct file-name labels, and analyses of the kinds a
/// comparison runs (each is checked against each mechanism when the mechanisms are read).
pub(super) fn check_compare(src: &Source, k: usize, c: &super::CompareSpec) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    let most = super::MAX_MECHANISMS;
    if c.mechanisms.is_empty() || c.mechanisms.len() > most {
        return Err(src.error(&at("mechanisms"), format!("need 1 to {most} mechanisms")));
    }
    let mut labels = std::collections::HashSet::new();
    for (v, m) in c.mechanisms.iter().enumerate() {
        let field = format!("analyses[{k}].mechanisms[{v}].label");
        check_file_name(&m.label).map_err(|e| src.error(&field, e))?;
        if !labels.insert(m.label.as_str()) {
            return Err(src.error(&field, format!("duplicate label `{}`", m.label)));
        }
    }
    if c.analyses.is_empty() || c.analyses.len() > MAX_ANALYSES {
        return Err(src.error(&at("analyses"), format!("need 1 to {MAX_ANALYSES} analyses")));
    }
    for (i, a) in c.analyses.iter().enumerate() {
        if !a.comparable() {
            return Err(src.error(
                &format!("analyses[{k}].analyses[{i}]"),
                format!("a comparison runs {} analyses, not {}", AnalysisSpec::comparable_kinds().join(", "), a.kind()),
            ));
        }
    }
    Ok(())
}

/// One mechanism of a comparison in `results.json`: its label, its mechanism and the entries of
/// the analyses run on it.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct ComparedEntry<'a> {
    /// Its label.
    pub label: &'a str,
    /// Its mechanism's name.
    pub mechanism: &'a str,
    /// Its analyses, as the document's own entries.
    pub analyses: Vec<AnalysisEntry<'a>>,
}

//! DesignStudy through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`; at load it refuses an engine in
//! the harmonic balance it runs per case.

use super::{AnalysisSpec, DesignResult, DesignSpec, findings, run};
use crate::error::Result;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::StudySpec;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output, Resources};
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{CASE_SETUP_S, LINEAR_SETUP_PER_DOF3_S};
use crate::study::validate::require_steady_spin;
use schemars::{Schema, SchemaGenerator};

impl Analysis for DesignSpec {
    fn prepare(&mut self, r: &mut Resources<'_>) -> Result<()> {
        let (src, k) = (r.src, r.k);
        let at = |f: &str| format!("analyses[{k}].{f}");
        let d = self;
        if let AnalysisSpec::HarmonicBalance(h) = d.analysis.as_ref()
            && h.engine.is_some()
        {
            return Err(src.error(
                &at("analysis.engine"),
                "a design study's harmonic balance takes typed amplitudes, not an engine",
            ));
        }
        Ok(())
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let Checks { spec, mech, spin, src, k } = *c;
        let _at = |field: &str| c.at(field);
        let d = self;
        if d.mechanism.is_some() {
            // Checked as a study of that mechanism when it is read (`load_mechanisms`).
            return Ok(());
        }
        if !d.lock.is_empty() || !d.elements.is_empty() {
            let field = if d.lock.is_empty() { "elements" } else { "lock" };
            return Err(src.error(
                &c.at(field),
                format!("`{field}` here names joints of the design study's own `mechanism`; the study's `{field}` applies otherwise"),
            ));
        }
        require_steady_spin(c, "DesignStudy", &d.name, false)?;
        super::check(src, spec, mech, k, d)?;
        // The analysis a design study runs must be valid by itself: checked by these rules
        // on a study holding it alone, errors moved to their place inside this entry.
        let alone = StudySpec { analyses: vec![d.analysis.as_ref().clone()], ..spec.clone() };
        if let Err(e) = crate::study::validate::check(&alone, mech, spin, src) {
            return Err(match e {
                crate::error::Error::Input { location, message } if location.path.starts_with("analyses[0]") => {
                    let rest = &location.path["analyses[0]".len()..];
                    src.error(&format!("analyses[{k}].analysis{rest}"), message)
                }
                other => other,
            });
        }
        super::check_parameters(src, mech, spin, k, d)?;
        Ok(())
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        let n = self.name.as_str();
        let mut out = Vec::new();
        let mut csv = |stem: String| out.push(format!("{stem}.csv"));
        let _ = self;
        csv(n.to_string());
        out.push(format!("{n}.svg"));
        out
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        design_plan(study, self, base)
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run(study, self, bench.dir, bench.progress)
    }

    fn json(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let r = report.designs.iter().find(|r| r.name == self.name)?;
        Json::new(r, &findings(r), vec![r.table()])
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<DesignResult>(), generator.subschema_for::<super::DesignFindings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let r = report.designs.iter().find(|r| r.name == self.name)?;
        let f = findings(r);
        Some(format!("{} cases: {} complete, {} partial, {} failed", f.cases, f.ok, f.partial, f.failed))
    }
}

impl Kept for DesignResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.designs.push(*self);
    }
}

/// The estimated work of a design study: the analysis's estimate once per case (its cost does
/// not depend on the varied values: a harmonic-balance branch is bounded by its points, a linear
/// response by its order grid), its memory once per case running at a time, and the table.
fn design_plan(study: &Study, spec: &DesignSpec, base: AnalysisPlan) -> AnalysisPlan {
    let (study, spec) = super::resolve(study, spec);
    let mut alone = study.clone();
    alone.spec.analyses = vec![spec.analysis.as_ref().clone()];
    let inner = alone.plan().analyses.into_iter().next();
    let n = super::case_count(spec) as f64;
    let dof = study.mechanism.ndof() as f64;
    let parallel = std::thread::available_parallelism().map_or(1, |p| p.get()) as f64;
    let columns = (1 + spec.parameters.len() + super::result_columns(study, spec).len()) as f64;
    // A row's cells, plus the status and a message of up to ~200 characters.
    let table_bytes = n * (columns * 22.0 + 200.0);
    match inner {
        Some(a) => AnalysisPlan {
            runs: super::case_count(spec).saturating_mul(a.runs),
            samples_per_run: a.samples_per_run,
            memory_bytes: a.memory_bytes * n.min(parallel) + table_bytes,
            output_bytes: table_bytes,
            cpu_s: n * (a.cpu_s + CASE_SETUP_S + LINEAR_SETUP_PER_DOF3_S * dof * dof * dof),
            driver: "sampling",
            ..base
        },
        None => base,
    }
}

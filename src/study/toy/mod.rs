//! A toy analysis that only the unit tests know: the proof that adding a kind of analysis takes
//! its own folder and one registration in [`analyses!`](super::AnalysisSpec), and nothing in
//! the driver, the checks, the plan or `results.json`.
//!
//! `Toy(name: "…", value: v)` writes `<name>.csv` with one column holding `2v`, a summary
//! section, and its entry in `results.json`.

use super::analysis::{Analysis, Bench, Checks, Kept, Output};
use super::json::Json;
use super::plan::AnalysisPlan;
use super::table::Table;
use super::{Study, StudyReport};
use crate::error::Result;
use serde::{Deserialize, Serialize};

/// The toy as written in the study file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToySpec {
    /// Name (file prefix).
    pub name: String,
    /// The number it doubles; must be finite.
    pub value: f64,
}

impl ToySpec {
    /// Its only table: the doubled value.
    fn table(&self) -> Table {
        let mut t = Table::new(self.name.clone());
        t.push("doubled", "1", vec![2.0 * self.value]);
        t
    }
}

/// The toy's result, known from its spec alone, so the report keeps nothing of it.
struct Doubled;

impl Kept for Doubled {
    fn keep(self: Box<Self>, _report: &mut StudyReport) {}
}

/// The toy's `result` in `results.json`.
#[derive(Serialize, schemars::JsonSchema)]
struct Doubling {
    /// Twice the value.
    doubled: f64,
}

impl Analysis for ToySpec {
    fn check(&self, c: &Checks<'_>) -> Result<()> {
        if !self.value.is_finite() {
            return Err(c.src.error(&c.at("value"), "must be finite"));
        }
        Ok(())
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        vec![format!("{}.csv", self.name)]
    }

    fn plan(&self, _study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        AnalysisPlan { runs: 1, samples_per_run: 1.0, output_bytes: 44.0, driver: "value", ..base }
    }

    fn run(&self, _study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        let file = self.table().write_csv(bench.dir)?;
        let markdown = format!("## Toy `{}`\n\nTwice {} is {}.\n\n", self.name, self.value, 2.0 * self.value);
        Ok(Output { markdown, files: vec![file], failures: Vec::new(), results: Box::new(Doubled) })
    }

    fn json(&self, _study: &Study, _report: &StudyReport, _nth: usize) -> Option<Json> {
        Json::new(&Doubling { doubled: 2.0 * self.value }, &(), vec![self.table()])
    }

    fn json_schemas(generator: &mut schemars::SchemaGenerator) -> (schemars::Schema, schemars::Schema) {
        (generator.subschema_for::<Doubling>(), generator.subschema_for::<()>())
    }

    fn digest(&self, _study: &Study, _report: &StudyReport, _nth: usize) -> Option<String> {
        Some(format!("twice {} is {}", self.value, 2.0 * self.value))
    }
}

#[cfg(test)]
mod tests {
    use crate::io::Source;
    use crate::study::{LoadOptions, RunOptions, Study, run};

    fn toy_study(value: &str) -> crate::error::Result<Study> {
        let text = format!(
            r#"Study(name: "toy_study", mechanism: "cpva.ron", analyses: [Toy(name: "twice", value: {value})])"#
        );
        // The mechanism is found next to the study "file", as for a study in examples/.
        Study::from_source(Source::from_text("examples/toy_study.ron", &text), &LoadOptions::default())
    }

    #[test]
    fn a_registered_toy_is_checked_planned_run_and_reported_by_the_driver() {
        let study = toy_study("3.5").expect("the toy study loads");
        let plan = study.plan();
        assert_eq!((plan.analyses[0].kind, plan.analyses[0].runs), ("Toy", 1));

        let tmp = tempfile::Builder::new().prefix("kanedyn-toy-").tempdir().unwrap();
        let out = tmp.path();
        let report = run(&study, &RunOptions { out: Some(out.to_path_buf()), progress: false }).expect("the toy runs");
        assert!(report.failures.is_empty(), "{:?}", report.failures);
        assert!(report.summary.contains("## Toy `twice`\n\nTwice 3.5 is 7.\n"), "{}", report.summary);
        let csv = std::fs::read_to_string(out.join("toy_study/twice.csv")).expect("the toy's CSV");
        assert_eq!(csv, "doubled\n7\n");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("toy_study/results.json")).unwrap()).unwrap();
        let entry = &json["analyses"][0];
        assert_eq!((entry["kind"].as_str(), entry["status"].as_str()), (Some("Toy"), Some("complete")));
        assert_eq!(entry["result"]["doubled"].as_f64(), Some(7.0));
        assert_eq!(entry["tables"][0]["columns"][0]["values"][0].as_f64(), Some(7.0));
    }

    #[test]
    fn the_toys_own_check_is_located_in_the_study_file() {
        let e = toy_study("inf").expect_err("an infinite value is refused").to_string();
        assert!(e.contains("analyses[0].value") && e.contains("must be finite"), "{e}");
    }
}

//! Campbell through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`.

use super::{Campbell, CampbellSpec, campbell_tables, run_campbell};
use crate::error::Result;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output};
use crate::study::digest::{count, num};
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{
    CAMPBELL_PER_DOF3_S, CAMPBELL_POINT_S, CSV_CELL_BYTES, LINEAR_SETUP_PER_DOF3_S, LINEAR_SETUP_S,
};
use crate::study::validate::{MAX_POINTS, modal_fields, order, require_steady_spin, rpm};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// What the summary reads off a Campbell diagram (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "CampbellFindings")]
struct Findings {
    /// One entry per tracked mode, in the order of the result's tracks.
    modes: Vec<ModeFindings>,
}

impl Analysis for CampbellSpec {
    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let Checks { src, k, mech, spin, .. } = *c;
        let at = |field: &str| c.at(field);
        require_steady_spin(c, "Campbell", &self.name, true)?;
        let c = self;
        if !(c.rpm_min.is_finite() && c.rpm_min >= 0.0 && c.rpm_max.is_finite() && c.rpm_max > c.rpm_min) {
            return Err(src.error(&at("rpm_min"), "need 0 ≤ rpm_min < rpm_max"));
        }
        rpm(src, &at("rpm_max"), c.rpm_max)?;
        if c.points < 2 || c.points > MAX_POINTS {
            return Err(src.error(&at("points"), format!("need 2 to {MAX_POINTS} points")));
        }
        if c.orders.len() > 64 {
            return Err(src.error(&at("orders"), "at most 64 order lines"));
        }
        modal_fields(src, &at, c.modal_damping.as_ref(), c.modal_combination)?;
        if let Some(name) = &c.speed_of
            && c.speed_ratio(mech, spin).is_none()
        {
            return Err(src.error(
                &at("speed_of"),
                format!(
                    "joint `{name}` is not a joint of mechanism `{}` that turns with the spin joint (through \
                     gears or meshes), so its speed cannot be the diagram's",
                    mech.name
                ),
            ));
        }
        for (j, &n) in c.orders.iter().enumerate() {
            order(src, &format!("analyses[{k}].orders[{j}]"), n)?;
        }
        Ok(())
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        let n = self.name.as_str();
        let mut out = Vec::new();
        let mut csv = |stem: String| out.push(format!("{stem}.csv"));
        let _ = self;
        csv(n.to_string());
        csv(format!("{n}_crossings"));
        out.push(format!("{n}.svg"));
        out
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, _fs, n, _locked) = crate::study::plan::basics(study);
        let c = self;
        let p = c.points as f64;
        AnalysisPlan {
            runs: 1,
            samples_per_run: p,
            memory_bytes: p * (4.0 * n + c.orders.len() as f64) * 8.0,
            output_bytes: p * (2.0 * n + c.orders.len() as f64 + 1.0) * CSV_CELL_BYTES,
            cpu_s: LINEAR_SETUP_S
                + LINEAR_SETUP_PER_DOF3_S * n * n * n
                + p * (CAMPBELL_POINT_S + CAMPBELL_PER_DOF3_S * n * n * n),
            driver: "points",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run_campbell(study, self, bench.dir)
    }

    fn json(&self, _study: &Study, report: &StudyReport, nth: usize) -> Option<Json> {
        // A Campbell diagram carries no name: the n-th completed one is the n-th result.
        let c = report.campbell.get(nth)?;
        Json::new(c, &Findings { modes: mode_findings(self, c) }, campbell_tables(self, c))
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<Campbell>(), generator.subschema_for::<Findings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, nth: usize) -> Option<String> {
        let c = report.campbell.get(nth)?;
        let (lo, hi) = (c.rpm.first()?, c.rpm.last()?);
        let mut line = format!("{}, {}–{} rpm; ", count(c.tracks.len(), "mode", "modes"), num(*lo), num(*hi));
        match c.crossings.first() {
            None => line += "no order line crosses a mode",
            Some(x) => {
                line += &format!(
                    "{}, first at {} rpm (order {}, mode `{}`, {} Hz)",
                    count(c.crossings.len(), "crossing", "crossings"),
                    num(x.rpm),
                    num(x.order),
                    x.label,
                    num(x.frequency_hz)
                )
            }
        }
        Some(line)
    }
}

impl Kept for crate::linear::Campbell {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.campbell.push(*self);
    }
}

/// The summary's reading of one tracked mode of a Campbell diagram.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
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

/// The summary's reading of each tracked mode (the rule of the Campbell summary).
fn mode_findings(spec: &CampbellSpec, c: &Campbell) -> Vec<ModeFindings> {
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

//! Campbell through the analysis interface: its checks, the files it may write, its plan and its run.

use super::*;
use crate::error::Result;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output};
use crate::study::plan::AnalysisPlan;
use crate::study::plan::*;
use crate::study::validate::*;

impl Analysis for CampbellSpec {
    fn name(&self) -> &str {
        &self.name
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let Checks { src, k, .. } = *c;
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
        if let Some(z) = &c.modal_damping {
            modal_ratios(src, &at("modal_damping"), z)?;
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
}

impl Kept for crate::linear::Campbell {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.campbell.push(*self);
    }
}

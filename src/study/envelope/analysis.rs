//! Envelope through the analysis interface (`study/analysis.rs`): its checks, the files it
//! writes, its plan, its run and its entry in `results.json`.

use super::{EnvelopePlane, EnvelopeResult, EnvelopeSpec, MapPointKind, run};
use crate::error::Result;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Output};
use crate::study::digest::{count, num};
use crate::study::json::Json;
use crate::study::plan::{AnalysisPlan, CSV_CELL_BYTES, hbm_branch_s};
use crate::study::validate::{
    MAX_LIST, MAX_TORQUE_NM, check_excite, order, order_range, pos, require_steady_spin, rpm,
};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// Points a boundary is planned at (the paper's jump boundary over n 2.9–3.3 and 1–500 N·m has
/// about 60).
const PLANNED_POINTS: f64 = 100.0;

/// What the summary reads off an envelope (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "EnvelopeFindings")]
struct Findings {
    /// Number of jump boundaries.
    jump_boundaries: usize,
    /// Number of unison-loss boundaries.
    unison_loss_boundaries: usize,
    /// The least torque of a jump, N·m (the lowest cusp or jump onset; `null` without a jump).
    jump_from_nm: Option<f64>,
    /// The least torque of a loss of unison, N·m (`null` without one).
    unison_lost_from_nm: Option<f64>,
}

fn findings(r: &EnvelopeResult) -> Findings {
    let least = |kinds: &[MapPointKind]| {
        r.points.iter().filter(|p| kinds.contains(&p.kind)).map(|p| p.torque_nm).reduce(f64::min)
    };
    Findings {
        jump_boundaries: r.boundaries.iter().filter(|b| b.kind == super::BoundaryKind::Jump).count(),
        unison_loss_boundaries: r.boundaries.iter().filter(|b| b.kind == super::BoundaryKind::UnisonLoss).count(),
        jump_from_nm: least(&[MapPointKind::Cusp, MapPointKind::JumpOnset]),
        unison_lost_from_nm: least(&[MapPointKind::UnisonLossOnset]),
    }
}

impl Analysis for EnvelopeSpec {
    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let (src, e) = (c.src, self);
        require_steady_spin(c, "Envelope", &e.name, false)?;
        match e.plane {
            EnvelopePlane::Order => {
                rpm(src, &c.at("rpm"), e.rpm)?;
                order_range(src, &c.at("order_min"), e.order_min, e.order_max)?;
            }
            EnvelopePlane::Speed { order: n, rpm_min, rpm_max } => {
                for (field, v) in [("rpm", e.rpm), ("order_min", e.order_min), ("order_max", e.order_max)] {
                    if v != 0.0 {
                        return Err(src.error(
                            &c.at(field),
                            "a `Speed` plane takes its order and speeds in `plane: Speed(order, rpm_min, rpm_max)`",
                        ));
                    }
                }
                order(src, &c.at("plane.order"), n)?;
                rpm(src, &c.at("plane.rpm_min"), rpm_min)?;
                rpm(src, &c.at("plane.rpm_max"), rpm_max)?;
                if rpm_min >= rpm_max {
                    return Err(src.error(
                        &c.at("plane.rpm_min"),
                        format!("need rpm_min < rpm_max, got {rpm_min} and {rpm_max}"),
                    ));
                }
            }
        }
        if !(pos(e.torque_min) && e.torque_min < e.torque_max && e.torque_max <= MAX_TORQUE_NM) {
            return Err(src.error(
                &c.at("torque_min"),
                format!(
                    "need 0 < torque_min < torque_max ≤ {MAX_TORQUE_NM:e} N·m, got {} and {}",
                    e.torque_min, e.torque_max
                ),
            ));
        }
        crate::study::validate::limits::check_harmonics(e.harmonics).map_err(|m| src.error(&c.at("harmonics"), m))?;
        if e.seed_torques.len() > MAX_LIST {
            return Err(src.error(&c.at("seed_torques"), format!("at most {MAX_LIST} torques")));
        }
        for (i, &t) in e.seed_torques.iter().enumerate() {
            if !(t.is_finite() && e.torque_min <= t && t <= e.torque_max) {
                return Err(src.error(
                    &c.at(&format!("seed_torques[{i}]")),
                    format!("{t} N·m lies outside the map's torques {}..{} N·m", e.torque_min, e.torque_max),
                ));
            }
        }
        check_excite(src, c.spec, c.mech, &c.at("excite"), &e.excite, None)
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        vec![format!("{}.csv", self.name), format!("{}.svg", self.name)]
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, _fs, n, _locked) = crate::study::plan::basics(study);
        let seeds = if self.seed_torques.is_empty() { super::SEEDS } else { self.seed_torques.len() } as f64;
        let h = self.harmonics as f64;
        // The seed branches (no Floquet analysis: the Newton part of a branch estimate, a
        // quarter of it) and about two boundaries, each point a few bordered solves.
        let branch = 0.25 * hbm_branch_s(n, h, PLANNED_POINTS);
        let curves = 2.0 * PLANNED_POINTS * 4.0 * (n * (2.0 * h + 1.0)).powi(3) / 3.0 * 1e-9;
        AnalysisPlan {
            runs: seeds as usize,
            samples_per_run: PLANNED_POINTS,
            memory_bytes: 2.0 * PLANNED_POINTS * n * (2.0 * h + 1.0) * 8.0,
            output_bytes: 2.0 * PLANNED_POINTS * 4.0 * CSV_CELL_BYTES,
            cpu_s: seeds * branch + curves,
            driver: "seed torques",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run(study, self, bench.dir)
    }

    fn json(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let r = report.envelopes.iter().find(|r| r.name == self.name)?;
        Json::new(r, &findings(r), vec![r.table()])
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<EnvelopeResult>(), generator.subschema_for::<Findings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let r = report.envelopes.iter().find(|r| r.name == self.name)?;
        let f = findings(r);
        let mut line = format!(
            "{} and {} in {} s",
            count(f.jump_boundaries, "jump boundary", "jump boundaries"),
            count(f.unison_loss_boundaries, "unison-loss boundary", "unison-loss boundaries"),
            num(r.time_s)
        );
        if let Some(t) = f.jump_from_nm {
            line += &format!("; jumps from {} N·m", num(t));
        }
        if let Some(t) = f.unison_lost_from_nm {
            line += &format!("; unison lost from {} N·m", num(t));
        }
        Some(line)
    }
}

//! LinearResponse through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`.

use super::{LinearResponseSpec, LinearResult, response_tables, run_response};
use crate::error::Result;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output};
use crate::study::digest::{count, num};
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{CSV_CELL_BYTES, LINEAR_SETUP_PER_DOF3_S, LINEAR_SETUP_S};
use crate::study::validate::{
    MAX_LIST, MAX_NAME_CHARS, MAX_ORDER, MAX_POINTS, check_excite, modal_fields, pos, require_steady_spin, rpm,
};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// Writing one response point (its CSV row, figure point and results entry), s: the 20,000-point
/// case of `tests/plan_calibration.rs` measured ≈ 10 µs a point in all, of which the solves are
/// about 2 µs, so a plan without the output was 4.5× low.
const LINEAR_OUTPUT_PER_POINT_S: f64 = 5e-6;

/// What the summary reads off a linear response (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "LinearFindings")]
struct Findings {
    /// One entry per variant, in the order of the result's variants.
    variants: Vec<VariantFindings>,
}

impl Analysis for LinearResponseSpec {
    fn comparable() -> bool {
        true
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let Checks { spec, mech, spin: _, src, k } = *c;
        let at = |field: &str| c.at(field);
        let l = self;
        require_steady_spin(c, "LinearResponse", &l.name, true)?;
        check_excite(src, spec, mech, &at("excite"), &l.excite, Some(&[l.rpm]))?;
        rpm(src, &at("rpm"), l.rpm)?;
        if !(pos(l.from) && l.to.is_finite() && l.from < l.to && l.to <= MAX_ORDER) {
            return Err(src.error(&at("from"), format!("need 0 < from < to ≤ {MAX_ORDER}")));
        }
        if l.points < 2 || l.points > MAX_POINTS {
            return Err(src.error(&at("points"), format!("need 2 to {MAX_POINTS} points")));
        }
        modal_fields(src, &at, l.modal_damping.as_ref(), l.modal_combination)?;
        // Replacing modal damping and damper variants would give the damping twice over, one
        // silently discarded; added, each variant's dampers carry the modal ratios on top.
        if let Some((_, crate::linear::ModalCombination::Replace)) = l.modal()
            && l.variants.iter().any(|v| !v.dampers.is_empty())
        {
            return Err(src.error(
                &at("modal_damping"),
                "modal damping replaces the dampers, so variants that set dampers do not apply \
                 (modal_combination: Add puts the ratios on top of each variant's dampers)",
            ));
        }
        if l.relative && spec.lock.is_empty() {
            return Err(src.error(
                &at("relative"),
                "orders relative to n_t need a locked joint (`lock`) to define the tuning order",
            ));
        }
        if l.variants.len() > 32 {
            return Err(src.error(&at("variants"), "at most 32 variants"));
        }
        let mut files = std::collections::HashSet::new();
        for (j, v) in l.variants.iter().enumerate() {
            let vp = format!("analyses[{k}].variants[{j}]");
            if v.label.is_empty() || v.label.chars().count() > MAX_NAME_CHARS {
                return Err(
                    src.error(&format!("{vp}.label"), format!("label must have 1 to {MAX_NAME_CHARS} characters"))
                );
            }
            // The label is a legend and a summary cell: a newline there splits its table row.
            crate::load::check_printable(src, &format!("{vp}.label"), &v.label)?;
            if !files.insert(super::slug(&v.label)) {
                return Err(src.error(
                    &format!("{vp}.label"),
                    format!("label `{}` gives the same file name as an earlier variant's", v.label),
                ));
            }
            if v.dampers.len() > MAX_LIST {
                return Err(src.error(&format!("{vp}.dampers"), format!("at most {MAX_LIST} dampers")));
            }
            for (d, (joint, c)) in v.dampers.iter().enumerate() {
                let dp = format!("{vp}.dampers[{d}]");
                if mech.joint_index(joint).is_none() {
                    return Err(src.error(&dp, format!("unknown joint `{joint}`")));
                }
                if !(c.is_finite() && *c >= 0.0) {
                    return Err(src.error(&dp, format!("damping must be finite and non-negative, got {c}")));
                }
            }
        }
        Ok(())
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        let n = self.name.as_str();
        let mut out = Vec::new();
        let mut csv = |stem: String| out.push(format!("{stem}.csv"));
        let l = self;
        if l.variants.is_empty() {
            csv(format!("{n}_as_built"));
        }
        for v in &l.variants {
            csv(format!("{n}_{}", super::super::linear::slug(&v.label)));
        }
        out.push(format!("{n}.svg"));
        out
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, _fs, n, _locked) = crate::study::plan::basics(study);
        let l = self;
        let runs = l.variants.len().max(1);
        let p = l.points as f64;
        AnalysisPlan {
            runs,
            samples_per_run: p,
            memory_bytes: runs as f64 * p * 8.0 * 8.0,
            output_bytes: runs as f64 * p * 5.0 * CSV_CELL_BYTES,
            cpu_s: runs as f64
                * (LINEAR_SETUP_S
                    + LINEAR_SETUP_PER_DOF3_S * n * n * n
                    + p * (2.0 * (1e-6 + 20e-9 * n * n * n) + LINEAR_OUTPUT_PER_POINT_S)),
            driver: "points",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run_response(study, self, bench.dir)
    }

    fn json(&self, study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let r = report.linear.iter().find(|r| r.name == self.name)?;
        Json::new(r, &Findings { variants: variant_findings(r) }, response_tables(study, self, r))
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<LinearResult>(), generator.subschema_for::<Findings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let r = report.linear.iter().find(|r| r.name == self.name)?;
        let mut line = count(r.variants.len(), "variant", "variants");
        if let Some(nt) = r.n_t {
            line += &format!(", tuning order n_t = {}", num(nt));
        }
        // The deepest notch over the variants: the absorber's best attenuation.
        let best = r.variants.iter().filter(|v| v.min.1.is_finite()).min_by(|a, b| a.min.1.total_cmp(&b.min.1));
        if let Some(v) = best {
            line += &format!("; smallest ratio to locked twin {} at n = {} ({})", num(v.min.1), num(v.min.0), v.label);
        }
        Some(line)
    }
}

impl Kept for LinearResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.linear.push(*self);
    }
}

/// The summary's orders of one linear-response variant in units of the tuning order n_t (None:
/// the study locks no joint, so n_t is not defined, or there is no crossing).
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct VariantFindings {
    /// The variant's label.
    pub label: String,
    /// Order of the smallest ratio over n_t.
    pub min_order_over_nt: Option<f64>,
    /// Order of the largest ratio over n_t.
    pub max_order_over_nt: Option<f64>,
    /// First order above n_t with ratio > 1, over n_t.
    pub crossing_over_nt: Option<f64>,
}

/// The summary's orders in units of n_t, per variant.
fn variant_findings(r: &LinearResult) -> Vec<VariantFindings> {
    let over = |n: f64| r.n_t.map(|nt| n / nt);
    r.variants
        .iter()
        .map(|v| VariantFindings {
            label: v.label.clone(),
            min_order_over_nt: over(v.min.0),
            max_order_over_nt: over(v.max.0),
            crossing_over_nt: v.crossing.and_then(over),
        })
        .collect()
}

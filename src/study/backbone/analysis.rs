//! FreeOscillation through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`.

use super::{FreeOscillationResult, FreeOscillationSpec, FreeSpin, run, table};
use crate::error::Result;
use crate::io::Source;
use crate::model::mechanism::Mechanism;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output};
use crate::study::digest::{count, num};
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{CSV_CELL_BYTES, rhs_s, time_run_s};
use crate::study::validate::{MAX_LIST, g, require_steady_spin, rpm};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// What the summary reads off a free oscillation (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "FreeOscillationFindings")]
struct Findings {
    /// Per release amplitude, the free-oscillation order over the linear order (1 for a
    /// tautochronic path; `null` where the run gave no order).
    order_over_linear: Vec<f64>,
}

impl Analysis for FreeOscillationSpec {
    fn comparable() -> bool {
        true
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        require_steady_spin(c, "FreeOscillation", &self.name, false)?;
        check_free(c.src, c.mech, c.spin, c.k, self)
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        vec![format!("{}.csv", self.name), format!("{}.svg", self.name)]
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, _fs, n, _locked) = crate::study::plan::basics(study);
        let f = self;
        let runs = f.amplitudes.len();
        // The run waits for the slowest oscillation the analysis accepts (a
        // quarter of the linear frequency, assumed below order 10) and samples
        // 128 points per linear period.
        let rev_s = 60.0 / f.rpm.max(1e-9);
        let duration = (f.periods as f64 + 2.0) * 4.0 * rev_s;
        let samples = duration * 128.0 * 10.0 / rev_s;
        AnalysisPlan {
            runs,
            samples_per_run: samples,
            memory_bytes: 64.0 * runs as f64,
            output_bytes: runs as f64 * 4.0 * CSV_CELL_BYTES,
            cpu_s: runs as f64 * (time_run_s(study, duration, 10.0 / rev_s) + samples * rhs_s(n)),
            driver: "amplitudes",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run(study, self, bench.dir)
    }

    fn json(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let r = report.free.iter().find(|r| r.name == self.name)?;
        Json::new(r, &Findings { order_over_linear: r.order_ratios() }, vec![table(r)])
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<FreeOscillationResult>(), generator.subschema_for::<Findings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let r = report.free.iter().find(|r| r.name == self.name)?;
        let ratios: Vec<f64> = r.order_ratios().into_iter().filter(|x| x.is_finite()).collect();
        let lo = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut line = format!(
            "`{}` at {} rpm, linear order {}, {}",
            r.joint,
            num(r.rpm),
            num(r.linear_order),
            count(r.amplitudes.len(), "amplitude", "amplitudes")
        );
        if !ratios.is_empty() {
            line += &format!("; order over linear {} to {}", num(lo), num(hi));
        }
        Some(line)
    }
}

impl Kept for FreeOscillationResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.free.push(*self);
    }
}

/// A free oscillation: a speed, a joint with a coordinate other than the spin joint, and
/// release amplitudes inside the joint's travel.
pub(super) fn check_free(
    src: &Source,
    mech: &Mechanism,
    spin: usize,
    k: usize,
    f: &super::FreeOscillationSpec,
) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    rpm(src, &at("rpm"), f.rpm)?;
    let j = mech.joint_index(&f.joint).ok_or_else(|| {
        let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
        src.error(&at("joint"), format!("unknown joint `{}` (joints: {})", f.joint, names.join(", ")))
    })?;
    if j == spin || mech.coordinate(j).is_none() {
        return Err(src.error(&at("joint"), format!("joint `{}` is the spin joint or has no coordinate", f.joint)));
    }
    if f.amplitudes.is_empty() || f.amplitudes.len() > MAX_LIST {
        return Err(src.error(&at("amplitudes"), format!("need 1 to {MAX_LIST} amplitudes")));
    }
    let kind = mech.joints[j].kind;
    let top = super::top(kind);
    for (i, &a) in f.amplitudes.iter().enumerate() {
        if !(a.is_finite() && a > 0.0 && a < top) {
            return Err(src.error(
                &format!("analyses[{k}].amplitudes[{i}]"),
                format!(
                    "amplitude must be finite, positive and below the top of the joint's swing or its travel \
                     (0 < a < {} {}), got {a}",
                    g(top),
                    kind.coordinate_unit()
                ),
            ));
        }
    }
    crate::study::validate::check_harmonics(f.harmonics).map_err(|m| src.error(&at("harmonics"), m))?;
    if f.spin == FreeSpin::Free {
        // A free rotor conserves its angular momentum only when nothing acts on the mechanism
        // from outside: gravity and world-frame forces are refused above (no steady spin), the
        // dampers and joint torques are removed, a point force would remain.
        if !mech.loads.point_forces.is_empty() {
            return Err(src.error(
                &at("spin"),
                format!(
                    "`spin: Free` needs a rotor free to turn: mechanism `{}` has a point force acting from outside \
                     (use `spin: Held`)",
                    mech.name
                ),
            ));
        }
        let omega = crate::model::excitation::rpm_to_rad_s(f.rpm);
        let spin_name = &mech.joints[spin].name;
        let cpva = super::conservative(mech);
        if let Err(m) = super::linear_mode(&cpva, spin_name, FreeSpin::Free, mech.coordinate(j).unwrap_or(0), omega) {
            return Err(src.error(
                &at("spin"),
                format!("`spin: Free`: joint `{}` and the spin joint `{spin_name}`: {m}", f.joint),
            ));
        }
    }
    if !(1..=1000).contains(&f.periods) {
        return Err(src.error(&at("periods"), "need 1 to 1000 periods"));
    }
    Ok(())
}

//! HarmonicBalance through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`;
//! the engine file it names, read when the study is loaded.

use super::{HbmBranch, HbmParameter, HbmSpec, findings, overlay_of, run, tables};
use crate::error::Result;
use crate::io::Source;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::StudySpec;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output, Resources};
use crate::study::digest::count;
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{CSV_CELL_BYTES, hbm_branch_s};
use crate::study::validate::{
    MAX_RPM, MAX_TORQUE_NM, check_excite, check_harmonics, check_max_step, order, order_range, pos,
    require_steady_spin, rpm, torques,
};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// A harmonic-balance analysis's `result` in `results.json`.
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "HarmonicBalanceResult")]
struct Branches<'a> {
    /// Its branches: per amplitude, one continued from each end of the continued parameter's
    /// range (order, speed or torque; one fewer where a branch failed).
    branches: Vec<&'a HbmBranch>,
}

/// What the summary reads off a harmonic-balance analysis (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "HarmonicBalanceFindings")]
struct BranchesFindings {
    /// One entry per branch, in the order of the result's branches.
    branches: Vec<super::BranchFindings>,
}

impl Analysis for HbmSpec {
    fn rename_references(&mut self, rename: &dyn Fn(&str) -> String) {
        if let Some(o) = &mut self.overlay {
            *o = rename(o);
        }
        if let Some(b) = &mut self.backbone {
            *b = rename(b);
        }
    }

    fn comparable() -> bool {
        true
    }

    fn prepare(&mut self, r: &mut Resources<'_>) -> Result<()> {
        let (src, k) = (r.src, r.k);
        let at = |f: &str| format!("analyses[{k}].{f}");
        let h = self;
        let Some(file) = &h.engine else { return Ok(()) };
        let HbmParameter::Speed { order, .. } = h.parameter else {
            return Err(src.error(
                &at("engine"),
                "an engine's amplitudes follow the speed: only a harmonic balance return Ok(())d in                          `parameter: Speed(…)` takes one",
            ));
        };
        if !h.amplitudes.is_empty() {
            return Err(src.error(&at("amplitudes"), "give either the amplitudes or the engine, not both"));
        }
        if !crate::study::validate::half_multiple(order) {
            return Err(src.error(
                &at("parameter"),
                format!("with an engine the order must be a multiple of ½ (its orders are), got {order}"),
            ));
        }
        // The balance keeps `harmonics` multiples of the order: more from the engine
        // would be dropped, so they are refused rather than lost.
        if !(1..=h.harmonics.clamp(1, 64)).contains(&h.engine_multiples) {
            return Err(src.error(
                &at("engine_multiples"),
                format!("need 1 to harmonics = {} multiples", h.harmonics.clamp(1, 64)),
            ));
        }
        let engine = r.engine(&at("engine"), file)?;
        h.engine_series = engine.oscillating_series(order, order * h.engine_multiples as f64);
        Ok(())
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let Checks { spec, mech, spin, src, k } = *c;
        let at = |field: &str| c.at(field);
        let h = self;
        // A harmonic balance at a fixed order takes gravity and world-frame forces (its base
        // period is then whole revolutions); a spring on the spin joint it cannot.
        if !(h.parameter != HbmParameter::Order && mech.joints[spin].spring.is_none()) {
            require_steady_spin(c, "HarmonicBalance", &h.name, false)?;
        }
        check_excite(src, spec, mech, &at("excite"), &h.excite, None)?;
        check_hbm(src, spec, k, h)?;
        // Each requested value must lie in the continued range, in the parameter's unit.
        let (lo, hi) = match h.parameter {
            HbmParameter::Order => (h.order_min, h.order_max),
            HbmParameter::Speed { rpm_min, rpm_max, .. } => (rpm_min, rpm_max),
            HbmParameter::Torque { min, max, .. } => (min, max),
        };
        if h.orbits_at.len() > crate::study::validate::MAX_LIST {
            return Err(src.error(&at("orbits_at"), format!("at most {} values", crate::study::validate::MAX_LIST)));
        }
        for (i, &v) in h.orbits_at.iter().enumerate() {
            if !(v.is_finite() && lo <= v && v <= hi) {
                return Err(src.error(
                    &at(&format!("orbits_at[{i}]")),
                    format!("{v} lies outside the continued range {lo}..{hi}: no branch can cross it there"),
                ));
            }
        }
        if h.route == super::HbmRoute::Cyclic {
            check_route(c, h)?;
        }
        Ok(())
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        let n = self.name.as_str();
        let mut out = Vec::new();
        let mut csv = |stem: String| out.push(format!("{stem}.csv"));
        let h = self;
        for tag in ["from_above", "from_below"] {
            csv(format!("{n}_{tag}"));
            for &amp in &h.amplitudes {
                csv(format!("{n}_{}Nm_{tag}", crate::study::table::fmt_num(amp)));
            }
        }
        out.extend([format!("{n}.svg"), format!("{n}_elements.svg")]);
        if self.backbone.is_some() {
            out.push(format!("{n}_backbone.svg"));
        }
        out
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, _fs, n, _locked) = crate::study::plan::basics(study);
        let h = self;
        let cases = if matches!(h.parameter, HbmParameter::Torque { .. }) || h.engine.is_some() {
            1
        } else {
            h.amplitudes.len()
        };
        let runs = 2 * cases;
        let points = super::planned_points(h);
        let unknowns = n * (2.0 * h.harmonics as f64 + 1.0);
        AnalysisPlan {
            runs,
            samples_per_run: points,
            memory_bytes: runs as f64 * points * unknowns * 8.0 * 4.0,
            output_bytes: runs as f64 * points * (4.0 + h.multiples.len() as f64) * CSV_CELL_BYTES,
            cpu_s: runs as f64 * hbm_branch_s(n, h.harmonics as f64, points),
            driver: "harmonics",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        // The sweeps it draws over are its one input from the analyses before it.
        let overlay = overlay_of(self, &bench.report.sweeps);
        let backbone = self.backbone.as_ref().and_then(|b| bench.report.free.iter().find(|r| &r.name == b));
        run(study, self, &overlay, backbone, bench.dir, bench.progress)
    }

    fn json(&self, study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let branches: Vec<&HbmBranch> = report.hbm.iter().filter(|b| b.analysis == self.name).collect();
        let findings = findings(study, &branches, &overlay_of(self, &report.sweeps));
        let tables = tables(&study.mechanism, self, &branches);
        Json::new(&Branches { branches }, &BranchesFindings { branches: findings }, tables)
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<Branches<'static>>(), generator.subschema_for::<BranchesFindings>())
    }

    fn digest(&self, study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let branches: Vec<&HbmBranch> = report.hbm.iter().filter(|b| b.analysis == self.name).collect();
        let f = findings(study, &branches, &overlay_of(self, &report.sweeps));
        let points: usize = f.iter().map(|b| b.points).sum();
        let stable: usize = f.iter().map(|b| b.stable).sum();
        let unstable: usize = f.iter().map(|b| b.unstable).sum();
        let folds: usize = branches.iter().map(|b| b.folds.len()).sum();
        let short = branches.iter().filter(|b| b.stopped_short.is_some()).count();
        let mut line = format!(
            "{}, {points} points ({stable} stable, {unstable} unstable), {}",
            count(branches.len(), "branch", "branches"),
            count(folds, "fold", "folds")
        );
        if short > 0 {
            line += &format!("; {short} stopped short of the range");
        }
        Some(line)
    }
}

impl Kept for Vec<HbmBranch> {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.hbm.extend(*self);
    }
}

pub(super) fn check_hbm(src: &Source, spec: &StudySpec, k: usize, h: &super::HbmSpec) -> Result<()> {
    let at = |field: &str| format!("analyses[{k}].{field}");
    let order_range_given = !(h.order_min == 0.0 && h.order_max == 0.0);
    let (needs_rpm, needs_orders, needs_amplitudes) = match h.parameter {
        HbmParameter::Order => (true, true, true),
        HbmParameter::Speed { order: n, rpm_min, rpm_max } => {
            order(src, &at("parameter"), n)?;
            if !(pos(rpm_min) && rpm_min < rpm_max && rpm_max <= MAX_RPM) {
                return Err(src.error(&at("parameter"), format!("Speed needs 0 < rpm_min < rpm_max ≤ {MAX_RPM:e}")));
            }
            (false, false, true)
        }
        HbmParameter::Torque { order: n, min, max } => {
            order(src, &at("parameter"), n)?;
            if !(pos(min) && min < max && max <= MAX_TORQUE_NM) {
                return Err(src.error(&at("parameter"), format!("Torque needs 0 < min < max ≤ {MAX_TORQUE_NM:e} N·m")));
            }
            (true, false, false)
        }
    };
    let what = "a Speed or Torque continuation takes its range from `parameter`";
    if needs_rpm {
        rpm(src, &at("rpm"), h.rpm)?;
    } else if h.rpm != 0.0 {
        return Err(src.error(&at("rpm"), format!("{what}: leave `rpm` out")));
    }
    if needs_orders {
        order_range(src, &at("order_min"), h.order_min, h.order_max)?;
    } else if order_range_given {
        return Err(src.error(&at("order_min"), format!("{what}: leave the order range out")));
    }
    if !needs_orders && h.overlay.is_some() {
        return Err(src.error(&at("overlay"), "sweeps can only be overlaid on order branches"));
    }
    // An engine (resolved at load, where its fields are checked) gives the amplitudes.
    if needs_amplitudes && h.engine.is_none() {
        torques(src, &at("amplitudes"), &h.amplitudes, false)?;
    } else if !h.amplitudes.is_empty() {
        return Err(src.error(&at("amplitudes"), format!("{what}: leave `amplitudes` out")));
    }
    check_harmonics(h.harmonics).map_err(|m| src.error(&at("harmonics"), m))?;
    if let Some(d) = h.max_step {
        check_max_step(d).map_err(|m| src.error(&at("max_step"), m))?;
    }
    if h.multiples.is_empty() || h.multiples.len() > 64 {
        return Err(src.error(&at("multiples"), "give 1 to 64 harmonic multiples"));
    }
    for (j, &m) in h.multiples.iter().enumerate() {
        // A periodic solution holds the harmonics 1..=H of its base order only; a period-doubled
        // one (switched at a period doubling) also the half orders, 0.5, 1.5, ….
        let half = h.switch && (2.0 * m).fract() == 0.0 && m >= 0.5;
        if !((m >= 1.0 && m.fract() == 0.0 || half) && m <= h.harmonics as f64) {
            return Err(src.error(
                &format!("analyses[{k}].multiples[{j}]"),
                format!(
                    "reported multiples must be whole numbers from 1 to harmonics = {} (with `switch: true` also \
                     halves from 0.5, the orders of a period-doubled branch), got {m}",
                    h.harmonics
                ),
            ));
        }
    }
    if let Some(b) = &h.backbone {
        if !needs_orders {
            return Err(src.error(&at("backbone"), "a backbone can only be drawn over order branches"));
        }
        let earlier = spec.analyses[..k]
            .iter()
            .any(|a| matches!(a, crate::study::AnalysisSpec::FreeOscillation(f) if &f.name == b));
        if !earlier {
            return Err(src.error(&at("backbone"), format!("no FreeOscillation named `{b}` before this analysis")));
        }
    }
    if let Some(o) = &h.overlay {
        let earlier =
            spec.analyses[..k].iter().any(|a| matches!(a, crate::study::AnalysisSpec::OrderSweep(s) if &s.name == o));
        if !earlier {
            return Err(src.error(&at("overlay"), format!("no OrderSweep named `{o}` before this analysis")));
        }
    }
    Ok(())
}

/// A declared cyclic route (`route: Cyclic`): the absorbers must form identical sets on this
/// mechanism with this excitation, else a located error with the reason `hbm::cyclic::detect`
/// gives (which member differs, and in what).
fn check_route(c: &Checks<'_>, h: &super::HbmSpec) -> Result<()> {
    let Checks { spec, mech, spin, src, .. } = *c;
    let inputs: Vec<usize> = if h.excite.is_empty() {
        vec![spin]
    } else {
        h.excite.iter().filter_map(|e| mech.joint_index(&e.joint)).collect()
    };
    let kane = crate::kane::Kane::new(mech)?;
    match crate::hbm::route_for(&kane, spin, &inputs) {
        crate::hbm::Route::Cyclic { .. } => Ok(()),
        crate::hbm::Route::General { reason } => Err(src.error(
            &c.at("route"),
            format!(
                "`route: Cyclic` declares the absorbers of mechanism `{}` identical, but they are not ({reason}); \
                 make them identical, or drop `route` to let the solver choose (spin joint `{}`)",
                mech.name, spec.spin_joint
            ),
        )),
    }
}

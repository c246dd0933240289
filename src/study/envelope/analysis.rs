//! Envelope through the analysis interface (`study/analysis.rs`): its checks, the files it
//! writes, its plan, its run and its entry in `results.json`.

use super::{EnvelopePlane, EnvelopeResult, EnvelopeSpec, MapPointKind, run};
use crate::error::Result;
use crate::model::excitation::Harmonic;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Output};
use crate::study::digest::{count, num};
use crate::study::json::Json;
use crate::study::plan::{AnalysisPlan, CSV_CELL_BYTES, hbm_branch_s};
use crate::study::validate::{
    MAX_LIST, MAX_TORQUE_NM, check_excite, order, order_range, pos, require_steady_spin, rpm, torque,
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
    /// Number of period-doubling boundaries.
    period_doubling_boundaries: usize,
    /// The unit of the limits below (the second parameter's: `N·m`, `1 (scale of the set)`, or
    /// a mechanism parameter's SI unit).
    unit: String,
    /// The second parameter at each cusp and jump onset, ascending: on a torque or scale plane
    /// the first is the least torque (scale) at which the response jumps; on a mechanism
    /// parameter's plane each is where a jump region ends as the parameter changes.
    jump_limits: Vec<f64>,
    /// The same at each unison-loss onset.
    unison_loss_limits: Vec<f64>,
    /// The same at each period-doubling onset (a tongue's tip).
    period_doubling_limits: Vec<f64>,
}

fn findings(r: &EnvelopeResult) -> Findings {
    let limits = |kinds: &[MapPointKind]| {
        let mut v: Vec<f64> = r.points.iter().filter(|p| kinds.contains(&p.kind)).map(|p| p.second_value).collect();
        v.sort_by(f64::total_cmp);
        v
    };
    Findings {
        jump_boundaries: r.boundaries.iter().filter(|b| b.kind == super::BoundaryKind::Jump).count(),
        unison_loss_boundaries: r.boundaries.iter().filter(|b| b.kind == super::BoundaryKind::UnisonLoss).count(),
        period_doubling_boundaries: r
            .boundaries
            .iter()
            .filter(|b| b.kind == super::BoundaryKind::PeriodDoubling)
            .count(),
        unit: r.second_unit.clone(),
        jump_limits: limits(&[MapPointKind::Cusp, MapPointKind::JumpOnset]),
        unison_loss_limits: limits(&[MapPointKind::UnisonLossOnset]),
        period_doubling_limits: limits(&[MapPointKind::PeriodDoublingOnset]),
    }
}

/// Largest scale of a multi-order set (dimensionless): far beyond any load.
const MAX_SCALE: f64 = 1e6;

/// The plane's second parameter: exactly one of a single order's torque range, a set's scale
/// range, and a mechanism parameter (with its fixed torque or set), each with its values and
/// seeds in range; the fields of another refused where they are written.
fn check_second(c: &Checks<'_>, e: &EnvelopeSpec) -> Result<()> {
    check_load(c, &e.load)?;
    if let Some(p) = &e.parameter {
        return check_parameter_plane(c, e, p);
    }
    if !e.load.is_empty() {
        return check_scale_plane(c, e);
    }
    check_torque_plane(c, e)
}

/// Whether the field of a second parameter is given (the others must be left out).
fn given(e: &EnvelopeSpec, field: &str) -> bool {
    match field {
        "torque_min" => e.torque_min != 0.0,
        "torque_max" => e.torque_max != 0.0,
        "seed_torques" => !e.seed_torques.is_empty(),
        "scale_min" => e.scale_min != 0.0,
        "scale_max" => e.scale_max != 0.0,
        "torque" => e.torque != 0.0,
        "seeds" => !e.seeds.is_empty(),
        _ => false,
    }
}

/// The first of `fields` that is given, refused with `why`.
fn refuse(c: &Checks<'_>, e: &EnvelopeSpec, fields: &[&str], why: &str) -> Result<()> {
    match fields.iter().find(|f| given(e, f)) {
        Some(f) => Err(c.src.error(&c.at(f), format!("`{f}` does not apply here: {why}"))),
        None => Ok(()),
    }
}

/// At most [`MAX_LIST`] seeds at `field`, each within the map's range `(lo, hi)` (in `unit`).
fn seeds_in(c: &Checks<'_>, field: &str, seeds: &[f64], (lo, hi): (f64, f64), unit: &str) -> Result<()> {
    if seeds.len() > MAX_LIST {
        return Err(c.src.error(&c.at(field), format!("at most {MAX_LIST} values")));
    }
    for (i, &t) in seeds.iter().enumerate() {
        if !(t.is_finite() && lo <= t && t <= hi) {
            return Err(c.src.error(
                &c.at(&format!("{field}[{i}]")),
                format!("{t}{unit} lies outside the map's range {lo}..{hi}{unit}"),
            ));
        }
    }
    Ok(())
}

/// A mechanism parameter's plane (or the speed's, on an `Order` plane): the fixed torque or set,
/// the parameter's name, quantity and range, and its seeds.
fn check_parameter_plane(c: &Checks<'_>, e: &EnvelopeSpec, p: &super::EnvelopeParameter) -> Result<()> {
    let src = c.src;
    refuse(
        c,
        e,
        &["torque_min", "torque_max", "seed_torques", "scale_min", "scale_max"],
        "a mechanism parameter's plane holds the torque fixed (`torque`, or the set `load` as written)",
    )?;
    let torque_plane = matches!(e.plane, EnvelopePlane::Torque { .. });
    match (e.load.is_empty(), e.torque) {
        _ if torque_plane => {
            if !e.load.is_empty() {
                return Err(src.error(&c.at("load"), "a `Torque` plane maps a single order's torque: no `load`"));
            }
            if e.torque != 0.0 {
                return Err(src.error(
                    &c.at("torque"),
                    "a `Torque` plane maps the torque over `plane: Torque(…, torque_min, torque_max)`: drop `torque`",
                ));
            }
        }
        (true, t) if !(pos(t) && t <= MAX_TORQUE_NM) => {
            return Err(src.error(
                &c.at("torque"),
                format!("a mechanism parameter's plane needs the fixed torque 0 < torque ≤ {MAX_TORQUE_NM:e} N·m (or a `load`), got {t}"),
            ));
        }
        (false, t) if t != 0.0 => {
            return Err(src.error(&c.at("torque"), "give the fixed `torque` or a `load`, not both"));
        }
        _ => {}
    }
    if let Err(m) = crate::study::validate::limits::check_file_name(&p.name) {
        return Err(src.error(&c.at("parameter.name"), m));
    }
    if p.quantity == crate::study::design::Quantity::Rpm {
        // The (order, speed) plane at a fixed torque.
        if e.plane != EnvelopePlane::Order {
            return Err(src.error(
                &c.at("parameter.quantity"),
                "a `Speed` plane maps the speed already: map the speed against the order on an `Order` plane",
            ));
        }
        rpm(src, &c.at("parameter.from"), p.from)?;
        rpm(src, &c.at("parameter.to"), p.to)?;
        if p.from >= p.to {
            return Err(src.error(&c.at("parameter.to"), format!("need from < to, got {} and {}", p.from, p.to)));
        }
        return seeds_in(c, "seeds", &e.seeds, (p.from, p.to), " rpm");
    }
    crate::study::design::check_mechanism_quantity(
        src,
        &c.at("parameter.quantity"),
        c.mech,
        c.spin,
        &p.quantity,
        (p.from, p.to),
        (&c.at("parameter.from"), &c.at("parameter.to")),
    )?;
    seeds_in(c, "seeds", &e.seeds, (p.from, p.to), "")
}

/// A multi-order set's plane: its scale's range and seeds.
fn check_scale_plane(c: &Checks<'_>, e: &EnvelopeSpec) -> Result<()> {
    let src = c.src;
    refuse(
        c,
        e,
        &["torque_min", "torque_max", "seed_torques", "torque"],
        "a `load` is mapped over its scale: give `scale_min` and `scale_max` (dimensionless)",
    )?;
    if !(pos(e.scale_min) && e.scale_min < e.scale_max && e.scale_max <= MAX_SCALE) {
        return Err(src.error(
            &c.at(if pos(e.scale_min) { "scale_max" } else { "scale_min" }),
            format!(
                "need 0 < scale_min < scale_max ≤ {MAX_SCALE:e} (scales of the set), got {} and {}",
                e.scale_min, e.scale_max
            ),
        ));
    }
    seeds_in(c, "seeds", &e.seeds, (e.scale_min, e.scale_max), "")
}

/// A single order's plane: its torque range and seed torques.
fn check_torque_plane(c: &Checks<'_>, e: &EnvelopeSpec) -> Result<()> {
    let src = c.src;
    refuse(
        c,
        e,
        &["scale_min", "scale_max", "torque", "seeds"],
        "a single order is mapped over its torque amplitude (`torque_min`, `torque_max`, `seed_torques`); \
         a scale needs a `load`, a fixed torque a `parameter`",
    )?;
    if !(pos(e.torque_min) && e.torque_min < e.torque_max && e.torque_max <= MAX_TORQUE_NM) {
        return Err(src.error(
            &c.at("torque_min"),
            format!(
                "need 0 < torque_min < torque_max ≤ {MAX_TORQUE_NM:e} N·m, got {} and {}",
                e.torque_min, e.torque_max
            ),
        ));
    }
    seeds_in(c, "seed_torques", &e.seed_torques, (e.torque_min, e.torque_max), " N·m")
}

/// A multi-order set: 1 to [`MAX_LIST`] harmonics, each a positive multiple, an admissible
/// amplitude and a finite phase, not all amplitudes zero.
fn check_load(c: &Checks<'_>, load: &[Harmonic]) -> Result<()> {
    let src = c.src;
    if load.len() > MAX_LIST {
        return Err(src.error(&c.at("load"), format!("give 1 to {MAX_LIST} harmonics")));
    }
    for (h, hm) in load.iter().enumerate() {
        let hp = c.at(&format!("load[{h}]"));
        order(src, &format!("{hp}.multiple"), hm.multiple)?;
        torque(src, &format!("{hp}.amplitude"), hm.amplitude)?;
        if !(hm.phase.is_finite() && hm.phase.abs() <= 1e3) {
            return Err(src.error(&format!("{hp}.phase"), "phase must be finite, |α| ≤ 1000 rad"));
        }
    }
    // The harmonic balance's base frequency is the multiples' greatest common divisor.
    let common = |d: f64| load.iter().all(|h| (h.multiple * d - (h.multiple * d).round()).abs() < 1e-9);
    if !(1..=12).any(|d| common(f64::from(d))) {
        return Err(src.error(
            &c.at("load"),
            "the multiples must be fractions with a common denominator ≤ 12 (the set must have a common period)",
        ));
    }
    if !load.is_empty() && load.iter().all(|h| h.amplitude == 0.0) {
        return Err(src.error(&c.at("load"), "every amplitude of the set is zero: nothing excites the response"));
    }
    Ok(())
}

impl Analysis for EnvelopeSpec {
    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let (src, e) = (c.src, self);
        require_steady_spin(c, "Envelope", &e.name, false)?;
        match e.plane {
            EnvelopePlane::Order if e.speed_is_second() => {
                if e.rpm != 0.0 {
                    return Err(src.error(
                        &c.at("rpm"),
                        "the speed is this plane's second parameter (`parameter` with `quantity: Rpm`): drop `rpm`",
                    ));
                }
                order_range(src, &c.at("order_min"), e.order_min, e.order_max)?;
            }
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
            EnvelopePlane::Torque { order: n, torque_min, torque_max } => {
                rpm(src, &c.at("rpm"), e.rpm)?;
                for (field, v) in [("order_min", e.order_min), ("order_max", e.order_max)] {
                    if v != 0.0 {
                        return Err(src.error(
                            &c.at(field),
                            "a `Torque` plane takes its order and torques in `plane: Torque(order, torque_min, torque_max)`",
                        ));
                    }
                }
                order(src, &c.at("plane.order"), n)?;
                if !(pos(torque_min) && torque_min < torque_max && torque_max <= MAX_TORQUE_NM) {
                    return Err(src.error(
                        &c.at("plane.torque_min"),
                        format!(
                            "need 0 < torque_min < torque_max ≤ {MAX_TORQUE_NM:e} N·m, got {torque_min} and {torque_max}"
                        ),
                    ));
                }
                match &e.parameter {
                    None => {
                        return Err(src.error(
                            &c.at("plane"),
                            "a `Torque` plane maps the torque against a mechanism `parameter`: give one \
                             (the order against the torque is an `Order` plane's)",
                        ));
                    }
                    Some(p) if p.quantity == crate::study::design::Quantity::Rpm => {
                        return Err(src.error(
                            &c.at("parameter.quantity"),
                            "the speed against the torque is a `Speed` plane's: `plane: Speed(order, rpm_min, rpm_max)`",
                        ));
                    }
                    Some(_) => {}
                }
            }
        }
        check_second(c, e)?;
        let first = match e.plane {
            EnvelopePlane::Order => (e.order_min, e.order_max),
            EnvelopePlane::Speed { rpm_min, rpm_max, .. } => (rpm_min, rpm_max),
            EnvelopePlane::Torque { torque_min, torque_max, .. } => (torque_min, torque_max),
        };
        if e.sections.len() > MAX_LIST {
            return Err(src.error(&c.at("sections"), format!("at most {MAX_LIST} values")));
        }
        for (i, &v) in e.sections.iter().enumerate() {
            if !(v.is_finite() && first.0 <= v && v <= first.1) {
                return Err(src.error(
                    &c.at(&format!("sections[{i}]")),
                    format!("{v} lies outside the map's first parameter range {}..{}", first.0, first.1),
                ));
            }
        }
        crate::study::validate::limits::check_harmonics(e.harmonics).map_err(|m| src.error(&c.at("harmonics"), m))?;
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
        let mut kinds = vec![
            count(f.jump_boundaries, "jump boundary", "jump boundaries"),
            count(f.unison_loss_boundaries, "unison-loss boundary", "unison-loss boundaries"),
        ];
        if f.period_doubling_boundaries > 0 {
            kinds.push(count(f.period_doubling_boundaries, "period-doubling boundary", "period-doubling boundaries"));
        }
        let last = kinds.pop().unwrap_or_default();
        let mut line = format!("{} and {last} in {} s", kinds.join(", "), num(r.time_s));
        // On a torque or scale plane the least limit is where the jump (the loss) begins; on a
        // mechanism parameter's plane the limits are listed as found.
        let words = |v: &[f64]| v.iter().map(|&t| r.second_words(t, 4)).collect::<Vec<_>>().join(", ");
        let from = !r.on_mechanism();
        match (f.jump_limits.first(), from) {
            (Some(&t), true) => line += &format!("; jumps from {}", r.second_words(t, 4)),
            (Some(_), false) => line += &format!("; jump limits at {}", words(&f.jump_limits)),
            (None, _) => {}
        }
        match (f.unison_loss_limits.first(), from) {
            (Some(&t), true) => line += &format!("; unison lost from {}", r.second_words(t, 4)),
            (Some(_), false) => line += &format!("; unison-loss limits at {}", words(&f.unison_loss_limits)),
            (None, _) => {}
        }
        match (f.period_doubling_limits.first(), from) {
            (Some(&t), true) => line += &format!("; period doubled from {}", r.second_words(t, 4)),
            (Some(_), false) => line += &format!("; period-doubling limits at {}", words(&f.period_doubling_limits)),
            (None, _) => {}
        }
        Some(line)
    }
}

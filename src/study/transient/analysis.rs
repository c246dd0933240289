//! Transient through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`;
//! the engine file it names, read when the study is loaded.

use super::{MAX_ENGINE_ORDER, TransientResult, TransientSpec, run, tables};
use crate::error::Result;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output, Resources};
use crate::study::digest::num;
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{CSV_CELL_BYTES, time_run_s};
use crate::study::validate::{MAX_LIST, MAX_RPM, MAX_TRANSIENT_S, check_excite, g, order, pos, torque};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// What the summary reads off a transient (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "TransientFindings")]
struct Findings {
    /// One entry per order cut, in the order of the result's cuts.
    cuts: Vec<CutFindings>,
}

impl Analysis for TransientSpec {
    fn comparable() -> bool {
        true
    }

    fn prepare(&mut self, r: &mut Resources<'_>) -> Result<()> {
        let (src, k) = (r.src, r.k);
        let at = |f: &str| format!("analyses[{k}].{f}");
        let t = self;
        let Some(e) = &mut t.engine else { return Ok(()) };
        if !crate::study::validate::half_multiple(e.order) {
            return Err(src.error(
                &at("engine.order"),
                format!("the base order must be a multiple of ½ (the engine's orders are), got {}", e.order),
            ));
        }
        if !(e.max_order.is_finite() && e.max_order >= e.order && e.max_order <= MAX_ENGINE_ORDER) {
            return Err(src.error(
                &at("engine.max_order"),
                format!("must lie within order ({}) ≤ max_order ≤ {MAX_ENGINE_ORDER}", e.order),
            ));
        }
        if !(e.ramp_s.is_finite() && (0.0..=crate::study::validate::MAX_TRANSIENT_S).contains(&e.ramp_s)) {
            return Err(src.error(&at("engine.ramp_s"), "the ramp must be finite and non-negative (s)"));
        }
        let engine = r.engine(&at("engine.file"), &e.file)?;
        e.series = engine.oscillating_series(e.order, e.max_order);
        Ok(())
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        check_transient(c, self)
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        let n = self.name.as_str();
        let mut out = Vec::new();
        let mut csv = |stem: String| out.push(format!("{stem}.csv"));
        let t = self;
        if t.write_time_series {
            csv(format!("{n}_series"));
        }
        csv(format!("{n}_map"));
        csv(format!("{n}_cuts"));
        out.extend([format!("{n}_map.svg"), format!("{n}.svg")]);
        out
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, fs, _n, _locked) = crate::study::plan::basics(study);
        let t = self;
        let samples = t.duration_s * fs + 1.0;
        let e = study.elements.len() as f64;
        let (a, b) = t.speed.rpm_range();
        let revs = t.duration_s * a.max(b) / 60.0;
        let blocks = revs / t.map.hop_revs.max(1e-9) + 1.0;
        let columns = t.map.max_order * t.map.revs_per_block as f64;
        let series_cols = if t.write_time_series { 4.0 + 2.0 * e + 3.0 * t.reactions.len() as f64 } else { 0.0 };
        let top =
            t.torques.iter().flat_map(|q| q.harmonics.iter().map(move |h| h.multiple * q.order)).fold(1.0, f64::max);
        AnalysisPlan {
            runs: 1,
            samples_per_run: samples,
            memory_bytes: samples * 8.0 * (4.0 + 2.0 * e) + blocks * columns * 8.0 * 2.0,
            output_bytes: samples * series_cols * CSV_CELL_BYTES + blocks * columns * 4.0 * CSV_CELL_BYTES,
            // The driven equations solve with nalgebra's dense Cholesky: a few
            // times the engine's own right-hand side.
            cpu_s: 4.0 * time_run_s(study, t.duration_s, top * a.max(b) / 60.0),
            driver: "duration_s",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run(study, self, bench.dir, bench.progress)
    }

    fn json(&self, study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let r = report.transient.iter().find(|r| r.name == self.name)?;
        let cuts = r
            .cuts
            .iter()
            .map(|c| CutFindings { signal: c.signal.clone(), order: c.order, peak: c.peak, peak_rpm: c.peak_rpm })
            .collect();
        Json::new(r, &Findings { cuts }, tables(study, self, r))
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<TransientResult>(), generator.subschema_for::<Findings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let r = report.transient.iter().find(|r| r.name == self.name)?;
        let mut line = format!("{}→{} rpm", num(r.rpm_start), num(r.rpm_end));
        // The response's cuts come first; its largest peak is the resonance the run passed.
        let response = r.cuts.iter().filter(|c| c.signal == r.cuts[0].signal);
        match response.filter(|c| c.peak.is_finite()).max_by(|a, b| a.peak.total_cmp(&b.peak)) {
            Some(c) => {
                line += &format!(
                    "; {} peaks at order {}: {} {} at {} rpm",
                    c.signal,
                    num(c.order),
                    num(c.peak),
                    c.unit,
                    num(c.peak_rpm)
                )
            }
            None => line += "; no order–rpm map",
        }
        Some(line)
    }
}

impl Kept for TransientResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.transient.push(*self);
    }
}

/// The transient's fields, each refused where it is written: the speed profile, the initial
/// angles and rates, the reactions, the torques, the engine and the order–rpm map.
pub(super) fn check_transient(c: &Checks<'_>, t: &crate::study::TransientSpec) -> Result<()> {
    if !(pos(t.duration_s) && t.duration_s <= MAX_TRANSIENT_S) {
        return Err(c
            .src
            .error(&c.at("duration_s"), format!("duration must lie in 0 < duration_s ≤ {MAX_TRANSIENT_S} s")));
    }
    check_speed(c, t)?;
    check_initial(c, t)?;
    check_reactions(c, t)?;
    check_torques(c, t)?;
    check_engine(c, t)?;
    check_map(c, t)
}

/// The speed profile: speeds in range, the ramp and the governor's time constant finite and
/// positive.
fn check_speed(c: &Checks<'_>, t: &crate::study::TransientSpec) -> Result<()> {
    use crate::study::SpeedProfile;
    let speed_ok = |v: f64| v.is_finite() && (0.0..=MAX_RPM).contains(&v);
    match t.speed {
        SpeedProfile::Free { rpm } => {
            if !speed_ok(rpm) {
                return Err(c.src.error(&c.at("speed.rpm"), format!("speed must lie in 0 ≤ rpm ≤ {MAX_RPM:e}")));
            }
        }
        SpeedProfile::Torque { rpm_from, rpm_to, ramp_s, .. }
        | SpeedProfile::Prescribed { rpm_from, rpm_to, ramp_s } => {
            if let SpeedProfile::Torque { governor_s: Some(tau), .. } = t.speed
                && !(pos(tau) && tau <= MAX_TRANSIENT_S)
            {
                return Err(c
                    .src
                    .error(&c.at("speed.governor_s"), "the governor's time constant must be finite and positive (s)"));
            }
            for (f, v) in [("rpm_from", rpm_from), ("rpm_to", rpm_to)] {
                if !speed_ok(v) {
                    return Err(c
                        .src
                        .error(&c.at(&format!("speed.{f}")), format!("speed must lie in 0 ≤ rpm ≤ {MAX_RPM:e}")));
                }
            }
            if let Some(r) = ramp_s
                && !(pos(r) && r <= MAX_TRANSIENT_S)
            {
                return Err(c.src.error(&c.at("speed.ramp_s"), "the ramp must be finite and positive (s)"));
            }
        }
    }
    Ok(())
}

/// The joint `name` (at `path`), which must have a coordinate of its own.
fn coordinate_joint(c: &Checks<'_>, path: &str, name: &str) -> Result<usize> {
    let j = c.mech.joint_index(name).ok_or_else(|| {
        let names: Vec<&str> = c.mech.joints.iter().map(|j| j.name.as_str()).collect();
        c.src.error(path, format!("unknown joint `{name}` (joints: {})", names.join(", ")))
    })?;
    if c.mech.coordinate(j).is_none() {
        let why = if c.mech.follow_map()[j].is_some() {
            "is rigidly driven by a gear: its state follows the joint it is geared to (set that one; a \
             transient's crank-locked torques act on joints with a coordinate)"
        } else {
            "is Fixed: it has no coordinate"
        };
        return Err(c.src.error(path, format!("joint `{name}` {why}")));
    }
    Ok(j)
}

/// The initial angles and rates: joints with a coordinate, each once, values finite (the spin
/// joint's rate is the profile's first speed).
fn check_initial(c: &Checks<'_>, t: &crate::study::TransientSpec) -> Result<()> {
    for (field, list) in [("angles", &t.angles), ("rates", &t.rates)] {
        if list.len() > MAX_LIST {
            return Err(c.src.error(&c.at(field), format!("at most {MAX_LIST} entries")));
        }
        let mut seen = Vec::new();
        for (i, (name, v)) in list.iter().enumerate() {
            let path = c.at(&format!("{field}[{i}]"));
            let j = coordinate_joint(c, &path, name)?;
            if field == "rates" && j == c.spin {
                return Err(c.src.error(&path, "the spin joint's initial rate is the speed profile's first speed"));
            }
            if !(v.is_finite() && v.abs() <= 1e6) {
                return Err(c.src.error(&path, format!("must be finite and at most 1e6 in size, got {}", g(*v))));
            }
            if seen.contains(&j) {
                return Err(c.src.error(&path, format!("joint `{name}` is given twice")));
            }
            seen.push(j);
        }
    }
    Ok(())
}

/// The joints whose reactions are recorded: known, each once.
fn check_reactions(c: &Checks<'_>, t: &crate::study::TransientSpec) -> Result<()> {
    if t.reactions.len() > MAX_LIST {
        return Err(c.src.error(&c.at("reactions"), format!("at most {MAX_LIST} joints")));
    }
    for (i, name) in t.reactions.iter().enumerate() {
        let path = c.at(&format!("reactions[{i}]"));
        let j = c.mech.joint_index(name).ok_or_else(|| {
            let names: Vec<&str> = c.mech.joints.iter().map(|j| j.name.as_str()).collect();
            c.src.error(&path, format!("unknown joint `{name}` (joints: {})", names.join(", ")))
        })?;
        if t.reactions[..i].contains(name) {
            return Err(c.src.error(&path, format!("joint `{}` is given twice", c.mech.joints[j].name)));
        }
    }
    Ok(())
}

/// Whether the spin speed is prescribed (its drive then takes whatever torque it needs).
fn prescribed(t: &crate::study::TransientSpec) -> bool {
    matches!(t.speed, crate::study::SpeedProfile::Prescribed { .. })
}

/// The crank-locked torques: joints with a coordinate (not a prescribed spin joint), means,
/// orders, ramps and harmonics in range.
fn check_torques(c: &Checks<'_>, t: &crate::study::TransientSpec) -> Result<()> {
    let prescribed = prescribed(t);
    if t.torques.len() > MAX_LIST {
        return Err(c.src.error(&c.at("torques"), format!("at most {MAX_LIST} torques")));
    }
    for (i, tq) in t.torques.iter().enumerate() {
        let path = |f: &str| c.at(&format!("torques[{i}].{f}"));
        let j = coordinate_joint(c, &path("joint"), &tq.joint)?;
        if prescribed && j == c.spin {
            return Err(c.src.error(
                &path("joint"),
                "the spin joint's speed is prescribed: its drive takes whatever torque it needs (apply the torque at another joint)",
            ));
        }
        torque(c.src, &path("mean"), tq.mean)?;
        order(c.src, &path("order"), tq.order)?;
        if !(tq.ramp_s.is_finite() && tq.ramp_s >= 0.0) {
            return Err(c.src.error(&path("ramp_s"), "ramp must be a finite, non-negative duration (s)"));
        }
        if tq.harmonics.len() > MAX_LIST {
            return Err(c.src.error(&path("harmonics"), format!("at most {MAX_LIST} harmonics")));
        }
        for (h, hm) in tq.harmonics.iter().enumerate() {
            let hp = path(&format!("harmonics[{h}]"));
            order(c.src, &format!("{hp}.multiple"), hm.multiple)?;
            torque(c.src, &format!("{hp}.amplitude"), hm.amplitude)?;
            if !(hm.phase.is_finite() && hm.phase.abs() <= 1e3) {
                return Err(c.src.error(&format!("{hp}.phase"), "phase must be finite, |α| ≤ 1000 rad"));
            }
        }
    }
    Ok(())
}

/// The engine's excited joints (not a prescribed spin joint).
fn check_engine(c: &Checks<'_>, t: &crate::study::TransientSpec) -> Result<()> {
    let prescribed = prescribed(t);
    if let Some(e) = &t.engine {
        // The engine's order, highest order and ramp were checked when it was loaded.
        check_excite(c.src, c.spec, c.mech, &c.at("engine.excite"), &e.excite, None)?;
        let excited: Vec<(String, usize)> = if e.excite.is_empty() {
            vec![(c.at("engine"), c.spin)]
        } else {
            e.excite
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    let path = c.at(&format!("engine.excite[{i}].joint"));
                    let j = coordinate_joint(c, &path, &x.joint)?;
                    Ok((path, j))
                })
                .collect::<Result<_>>()?
        };
        for (path, j) in excited {
            if prescribed && j == c.spin {
                return Err(c.src.error(
                    &path,
                    "the spin joint's speed is prescribed: its drive would take up the engine torque (excite \
                     another joint, or run the speed with `Torque(…)`)",
                ));
            }
        }
    }
    Ok(())
}

/// The order–rpm map: its resolution, its highest order below the block's and the samples'
/// Nyquist limits, its cuts below it.
fn check_map(c: &Checks<'_>, t: &crate::study::TransientSpec) -> Result<()> {
    let m = &t.map;
    if !(8..=1024).contains(&m.samples_per_rev) {
        return Err(c.src.error(&c.at("map.samples_per_rev"), "need 8 to 1024 points per revolution"));
    }
    if !(1..=1024).contains(&m.revs_per_block) {
        return Err(c.src.error(&c.at("map.revs_per_block"), "need 1 to 1024 revolutions per block"));
    }
    if !(pos(m.hop_revs) && m.hop_revs <= 1e6) {
        return Err(c.src.error(&c.at("map.hop_revs"), "hop must be finite, positive and at most 1e6 revolutions"));
    }
    order(c.src, &c.at("map.max_order"), m.max_order)?;
    let half = c.spec.order_tracking.half_width_bins as f64;
    let r = m.revs_per_block as f64;
    // The highest column's band must end below the block's Nyquist bin P·R/2.
    let top = (m.samples_per_rev as f64 * r / 2.0 - 1.0 - half) / r;
    if m.max_order > top {
        return Err(c.src.error(
            &c.at("map.max_order"),
            format!(
                "order {} is beyond what {} points per revolution resolve (at most {top:.3} with {} bins each side); raise samples_per_rev",
                g(m.max_order),
                m.samples_per_rev,
                c.spec.order_tracking.half_width_bins
            ),
        ));
    }
    let (a, b) = t.speed.rpm_range();
    let f_top = m.max_order * a.max(b) / 60.0;
    let fs = c.spec.integration.sample_hz;
    if f_top >= 0.5 * fs {
        return Err(c.src.error(
            &c.at("map.max_order"),
            format!(
                "order {} at {} rpm is {f_top:.1} Hz, at or beyond the Nyquist frequency of integration.sample_hz = {} Hz: raise the sample rate or lower max_order",
                g(m.max_order),
                g(a.max(b)),
                g(fs)
            ),
        ));
    }
    if m.cuts.len() > 64 {
        return Err(c.src.error(&c.at("map.cuts"), "at most 64 order cuts"));
    }
    for (i, &cut) in m.cuts.iter().enumerate() {
        let p = c.at(&format!("map.cuts[{i}]"));
        order(c.src, &p, cut)?;
        if cut > m.max_order {
            return Err(c.src.error(&p, format!("order {} lies above map.max_order = {}", g(cut), g(m.max_order))));
        }
    }
    Ok(())
}

/// The summary's reading of one order cut of a transient.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct CutFindings {
    /// The signal cut.
    pub signal: String,
    /// The order, cycles/rev.
    pub order: f64,
    /// The largest amplitude along the cut, in the signal's unit.
    pub peak: f64,
    /// The speed of that block, rpm.
    pub peak_rpm: f64,
}

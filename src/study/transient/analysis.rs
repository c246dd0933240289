//! Transient through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`;
//! the engine file it names, read when the study is loaded.

use super::{MAX_ENGINE_ORDER, TransientResult, TransientSpec, run, tables};
use crate::error::Result;
use crate::io::Source;
use crate::model::mechanism::Mechanism;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::StudySpec;
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
        check_transient(c.src, c.spec, c.mech, c.spin, c.k, self)
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

pub(super) fn check_transient(
    src: &Source,
    spec: &StudySpec,
    mech: &Mechanism,
    spin: usize,
    k: usize,
    t: &crate::study::TransientSpec,
) -> Result<()> {
    use crate::study::SpeedProfile;
    let at = |field: &str| format!("analyses[{k}].{field}");
    if !(pos(t.duration_s) && t.duration_s <= MAX_TRANSIENT_S) {
        return Err(src.error(&at("duration_s"), format!("duration must lie in 0 < duration_s ≤ {MAX_TRANSIENT_S} s")));
    }
    let speed_ok = |v: f64| v.is_finite() && (0.0..=MAX_RPM).contains(&v);
    let prescribed = matches!(t.speed, SpeedProfile::Prescribed { .. });
    match t.speed {
        SpeedProfile::Free { rpm } => {
            if !speed_ok(rpm) {
                return Err(src.error(&at("speed.rpm"), format!("speed must lie in 0 ≤ rpm ≤ {MAX_RPM:e}")));
            }
        }
        SpeedProfile::Torque { rpm_from, rpm_to, ramp_s, .. }
        | SpeedProfile::Prescribed { rpm_from, rpm_to, ramp_s } => {
            if let SpeedProfile::Torque { governor_s: Some(tau), .. } = t.speed
                && !(pos(tau) && tau <= MAX_TRANSIENT_S)
            {
                return Err(
                    src.error(&at("speed.governor_s"), "the governor's time constant must be finite and positive (s)")
                );
            }
            for (f, v) in [("rpm_from", rpm_from), ("rpm_to", rpm_to)] {
                if !speed_ok(v) {
                    return Err(
                        src.error(&at(&format!("speed.{f}")), format!("speed must lie in 0 ≤ rpm ≤ {MAX_RPM:e}"))
                    );
                }
            }
            if let Some(r) = ramp_s
                && !(pos(r) && r <= MAX_TRANSIENT_S)
            {
                return Err(src.error(&at("speed.ramp_s"), "the ramp must be finite and positive (s)"));
            }
        }
    }
    let joint = |path: &str, name: &str| -> Result<usize> {
        let j = mech.joint_index(name).ok_or_else(|| {
            let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
            src.error(path, format!("unknown joint `{name}` (joints: {})", names.join(", ")))
        })?;
        if mech.coordinate(j).is_none() {
            let why = if mech.follow_map()[j].is_some() {
                "is rigidly driven by a gear: its state follows the joint it is geared to (set that one; a \
                 transient's crank-locked torques act on joints with a coordinate)"
            } else {
                "is Fixed: it has no coordinate"
            };
            return Err(src.error(path, format!("joint `{name}` {why}")));
        }
        Ok(j)
    };
    for (field, list) in [("angles", &t.angles), ("rates", &t.rates)] {
        if list.len() > MAX_LIST {
            return Err(src.error(&at(field), format!("at most {MAX_LIST} entries")));
        }
        let mut seen = Vec::new();
        for (i, (name, v)) in list.iter().enumerate() {
            let path = at(&format!("{field}[{i}]"));
            let j = joint(&path, name)?;
            if field == "rates" && j == spin {
                return Err(src.error(&path, "the spin joint's initial rate is the speed profile's first speed"));
            }
            if !(v.is_finite() && v.abs() <= 1e6) {
                return Err(src.error(&path, format!("must be finite and at most 1e6 in size, got {}", g(*v))));
            }
            if seen.contains(&j) {
                return Err(src.error(&path, format!("joint `{name}` is given twice")));
            }
            seen.push(j);
        }
    }
    if t.reactions.len() > MAX_LIST {
        return Err(src.error(&at("reactions"), format!("at most {MAX_LIST} joints")));
    }
    for (i, name) in t.reactions.iter().enumerate() {
        let path = at(&format!("reactions[{i}]"));
        let j = mech.joint_index(name).ok_or_else(|| {
            let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
            src.error(&path, format!("unknown joint `{name}` (joints: {})", names.join(", ")))
        })?;
        if t.reactions[..i].contains(name) {
            return Err(src.error(&path, format!("joint `{}` is given twice", mech.joints[j].name)));
        }
    }
    if t.torques.len() > MAX_LIST {
        return Err(src.error(&at("torques"), format!("at most {MAX_LIST} torques")));
    }
    for (i, tq) in t.torques.iter().enumerate() {
        let path = |f: &str| at(&format!("torques[{i}].{f}"));
        let j = joint(&path("joint"), &tq.joint)?;
        if prescribed && j == spin {
            return Err(src.error(
                &path("joint"),
                "the spin joint's speed is prescribed: its drive takes whatever torque it needs (apply the torque at another joint)",
            ));
        }
        torque(src, &path("mean"), tq.mean)?;
        order(src, &path("order"), tq.order)?;
        if !(tq.ramp_s.is_finite() && tq.ramp_s >= 0.0) {
            return Err(src.error(&path("ramp_s"), "ramp must be a finite, non-negative duration (s)"));
        }
        if tq.harmonics.len() > MAX_LIST {
            return Err(src.error(&path("harmonics"), format!("at most {MAX_LIST} harmonics")));
        }
        for (h, hm) in tq.harmonics.iter().enumerate() {
            let hp = path(&format!("harmonics[{h}]"));
            order(src, &format!("{hp}.multiple"), hm.multiple)?;
            torque(src, &format!("{hp}.amplitude"), hm.amplitude)?;
            if !(hm.phase.is_finite() && hm.phase.abs() <= 1e3) {
                return Err(src.error(&format!("{hp}.phase"), "phase must be finite, |α| ≤ 1000 rad"));
            }
        }
    }
    if let Some(e) = &t.engine {
        // The engine's order, highest order and ramp were checked when it was loaded.
        check_excite(src, spec, mech, &at("engine.excite"), &e.excite, None)?;
        let excited: Vec<(String, usize)> = if e.excite.is_empty() {
            vec![(at("engine"), spin)]
        } else {
            e.excite
                .iter()
                .enumerate()
                .map(|(i, x)| {
                    let path = at(&format!("engine.excite[{i}].joint"));
                    let j = joint(&path, &x.joint)?;
                    Ok((path, j))
                })
                .collect::<Result<_>>()?
        };
        for (path, j) in excited {
            if prescribed && j == spin {
                return Err(src.error(
                    &path,
                    "the spin joint's speed is prescribed: its drive would take up the engine torque (excite \
                     another joint, or run the speed with `Torque(…)`)",
                ));
            }
        }
    }
    let m = &t.map;
    if !(8..=1024).contains(&m.samples_per_rev) {
        return Err(src.error(&at("map.samples_per_rev"), "need 8 to 1024 points per revolution"));
    }
    if !(1..=1024).contains(&m.revs_per_block) {
        return Err(src.error(&at("map.revs_per_block"), "need 1 to 1024 revolutions per block"));
    }
    if !(pos(m.hop_revs) && m.hop_revs <= 1e6) {
        return Err(src.error(&at("map.hop_revs"), "hop must be finite, positive and at most 1e6 revolutions"));
    }
    order(src, &at("map.max_order"), m.max_order)?;
    let half = spec.order_tracking.half_width_bins as f64;
    let r = m.revs_per_block as f64;
    // The highest column's band must end below the block's Nyquist bin P·R/2.
    let top = (m.samples_per_rev as f64 * r / 2.0 - 1.0 - half) / r;
    if m.max_order > top {
        return Err(src.error(
            &at("map.max_order"),
            format!(
                "order {} is beyond what {} points per revolution resolve (at most {top:.3} with {} bins each side); raise samples_per_rev",
                g(m.max_order),
                m.samples_per_rev,
                spec.order_tracking.half_width_bins
            ),
        ));
    }
    let (a, b) = t.speed.rpm_range();
    let f_top = m.max_order * a.max(b) / 60.0;
    let fs = spec.integration.sample_hz;
    if f_top >= 0.5 * fs {
        return Err(src.error(
            &at("map.max_order"),
            format!(
                "order {} at {} rpm is {f_top:.1} Hz, at or beyond the Nyquist frequency of integration.sample_hz = {} Hz: raise the sample rate or lower max_order",
                g(m.max_order),
                g(a.max(b)),
                g(fs)
            ),
        ));
    }
    if m.cuts.len() > 64 {
        return Err(src.error(&at("map.cuts"), "at most 64 order cuts"));
    }
    for (i, &c) in m.cuts.iter().enumerate() {
        let p = at(&format!("map.cuts[{i}]"));
        order(src, &p, c)?;
        if c > m.max_order {
            return Err(src.error(&p, format!("order {} lies above map.max_order = {}", g(c), g(m.max_order))));
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

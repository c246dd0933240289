//! MultiOrder through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`;
//! the engine file it names, read when the study is loaded.

use super::{MultiOrderResult, MultiOrderSpec, SpeedFindings, findings, run, table};
use crate::error::Result;
use crate::model::excitation::rpm_to_rad_s;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output, Resources};
use crate::study::digest::num;
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{CSV_CELL_BYTES, hbm_branch_s, time_run_s};
use crate::study::validate::{
    MAX_LIST, check_excite, common, modal_fields, order, pos, require_steady_spin, rpm, torque, tracking,
};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// What the summary reads off a multi-order analysis (its `findings` in `results.json`).
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "MultiOrderFindings")]
struct Findings {
    /// One entry per speed, in the order of the result's speeds.
    speeds: Vec<SpeedFindings>,
}

impl Analysis for MultiOrderSpec {
    fn comparable() -> bool {
        true
    }

    fn prepare(&mut self, r: &mut Resources<'_>) -> Result<()> {
        let (src, k) = (r.src, r.k);
        let at = |f: &str| format!("analyses[{k}].{f}");
        let m = self;
        if let Some(range) = m.speed_range.take() {
            let field = at("speed_range");
            if !m.speeds.is_empty() {
                return Err(src.error(&field, "give either `speeds` or `speed_range`, not both"));
            }
            if !(2..=MAX_LIST).contains(&range.points) {
                return Err(src.error(&format!("{field}.points"), format!("give 2 to {MAX_LIST} speeds")));
            }
            let ok = |v: f64| v.is_finite() && v > 0.0 && v <= crate::study::validate::MAX_RPM;
            if !(ok(range.rpm_min) && ok(range.rpm_max) && range.rpm_min < range.rpm_max) {
                return Err(src.error(
                    &field,
                    format!("need 0 < rpm_min < rpm_max ≤ 1e6, got {} and {} rpm", range.rpm_min, range.rpm_max),
                ));
            }
            let step = (range.rpm_max - range.rpm_min) / (range.points - 1) as f64;
            m.speeds = (0..range.points)
                .map(|i| super::spec::SpeedPoint {
                    // Rounded to 12 significant digits: 14.6 rpm, not 14.600000000000001.
                    rpm: if i + 1 == range.points {
                        range.rpm_max
                    } else {
                        format!("{:.11e}", range.rpm_min + step * i as f64).parse().unwrap_or(range.rpm_min)
                    },
                    harmonics: range.harmonics.clone(),
                })
                .collect();
            // Not kept: the spec goes on (results.json, a Dask worker) with the speeds it became.
        }
        let Some(file) = &m.engine else { return Ok(()) };
        let engine = r.engine(&at("engine"), file)?;
        if !(1..=crate::study::validate::MAX_LIST).contains(&m.engine_multiples) {
            return Err(
                src.error(&at("engine_multiples"), format!("need 1 to {} multiples", crate::study::validate::MAX_LIST))
            );
        }
        if !crate::study::validate::half_multiple(m.order) {
            return Err(src.error(
                &at("order"),
                format!("with an engine the base order must be a multiple of ½ (its orders are), got {}", m.order),
            ));
        }
        if m.speeds.len() > crate::study::validate::MAX_LIST {
            return Err(src.error(
                &at("speeds"),
                format!("{} speeds; at most {}", m.speeds.len(), crate::study::validate::MAX_LIST),
            ));
        }
        for (i, p) in m.speeds.iter_mut().enumerate() {
            if !p.harmonics.is_empty() {
                return Err(src.error(
                    &at(&format!("speeds[{i}].harmonics")),
                    "give either the harmonics or the analysis's engine, not both",
                ));
            }
            if !(p.rpm.is_finite() && p.rpm > 0.0 && p.rpm <= crate::study::validate::MAX_RPM) {
                return Err(src.error(&at(&format!("speeds[{i}].rpm")), "speed must be within 0 < rpm ≤ 1e6"));
            }
            let top = m.order * m.engine_multiples as f64;
            let series = engine.orders(crate::model::excitation::rpm_to_rad_s(p.rpm), top);
            p.harmonics = series
                .harmonics
                .iter()
                .filter_map(|h| {
                    let multiple = 0.5 * h.multiple / m.order;
                    ((multiple - multiple.round()).abs() < 1e-9 && multiple >= 1.0).then(|| {
                        crate::model::excitation::Harmonic {
                            multiple: multiple.round(),
                            amplitude: h.amplitude,
                            phase: h.phase,
                        }
                    })
                })
                .collect();
        }
        Ok(())
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let Checks { spec, mech, spin: _, src, k } = *c;
        let at = |field: &str| c.at(field);
        let m = self;
        let name = &m.name;
        if require_steady_spin(c, "MultiOrder", name, true)? {
            // Only the linear part: the steady time runs and the order-continued harmonic
            // balance assume a steady spin.
            let g = mech.loads.gravity;
            let what = if g.x != 0.0 || g.y != 0.0 {
                format!("gravity ({}, {}) m/s²", g.x, g.y)
            } else {
                "a world-frame point force".to_string()
            };
            for (on, field, part) in [
                (m.time_domain, "time_domain", "steady time runs"),
                (m.hbm, "hbm", "harmonic balance continued in order"),
            ] {
                if on {
                    return Err(src.error(
                        &at(field),
                        format!(
                            "MultiOrder `{name}`: mechanism `{}` has {what}, which makes the spinning state \
                             periodic at order 1; the {part} of this analysis need a steady spin. Only its \
                             linear part takes gravity (and reports the order-1 response it forces): set \
                             `{field}: false`, or use a HarmonicBalance continued in Speed or Torque",
                            mech.name
                        ),
                    ));
                }
            }
        }
        let speeds: Vec<f64> = m.speeds.iter().map(|p| p.rpm).collect();
        check_excite(src, spec, mech, &at("excite"), &m.excite, Some(&speeds))?;
        modal_fields(src, &at, m.modal_damping.as_ref(), m.modal_combination)?;
        if m.modal_damping.is_some() && !m.linear {
            return Err(src.error(
                &at("modal_damping"),
                "modal damping acts on the linear part only, and `linear` is false: it would change nothing",
            ));
        }
        order(src, &at("order"), m.order)?;
        if m.speeds.is_empty() || m.speeds.len() > MAX_LIST {
            return Err(src.error(&at("speeds"), format!("give 1 to {MAX_LIST} operating speeds")));
        }
        common(src, &at(""), &m.multiples, m.ramp_s, m.mean_torque)?;
        if !(pos(m.steady_tol) && m.steady_tol <= 1.0) {
            return Err(src.error(&at("steady_tol"), "must be finite, positive and at most 1"));
        }
        if !pos(m.window_s) {
            return Err(src.error(&at("window_s"), "window must be finite and positive (s)"));
        }
        if !(m.min_time_s.is_finite() && m.min_time_s >= 0.0) {
            return Err(src.error(&at("min_time_s"), "must be finite and non-negative (s)"));
        }
        if !(m.max_time_s.is_finite() && m.max_time_s >= m.ramp_s + 2.0 * m.window_s) {
            return Err(src.error(&at("max_time_s"), "must be finite and at least ramp_s + 2·window_s (s)"));
        }
        if m.min_time_s > m.max_time_s {
            return Err(src.error(&at("min_time_s"), "must not exceed max_time_s"));
        }
        for (j, p) in m.speeds.iter().enumerate() {
            let sp = format!("analyses[{k}].speeds[{j}]");
            rpm(src, &format!("{sp}.rpm"), p.rpm)?;
            if p.harmonics.is_empty() || p.harmonics.len() > MAX_LIST {
                return Err(src.error(&format!("{sp}.harmonics"), format!("give 1 to {MAX_LIST} harmonics")));
            }
            for (h, hm) in p.harmonics.iter().enumerate() {
                let hp = format!("{sp}.harmonics[{h}]");
                order(src, &format!("{hp}.multiple"), hm.multiple)?;
                torque(src, &format!("{hp}.amplitude"), hm.amplitude)?;
                if !(hm.phase.is_finite() && hm.phase.abs() <= 1e3) {
                    return Err(src.error(&format!("{hp}.phase"), "phase must be finite, |α| ≤ 1000 rad"));
                }
            }
            if m.time_domain {
                let omega = rpm_to_rad_s(p.rpm);
                tracking(src, &format!("{sp}.rpm"), spec, m.window_s, 2, omega, m.order, &m.multiples)?;
            }
        }
        Ok(())
    }

    fn files(&self, _locked: bool) -> Vec<String> {
        vec![format!("{}.csv", self.name), format!("{}.svg", self.name)]
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (_spec, fs, n, locked) = crate::study::plan::basics(study);
        let m = self;
        let td = usize::from(m.time_domain);
        let runs = m.speeds.len() * td * (1 + locked);
        // Two windows are kept per run (the steadiness test).
        let samples = 2.0 * m.window_s * fs + 1.0;
        let top = m.speeds.iter().flat_map(|p| p.harmonics.iter().map(move |h| h.multiple * p.rpm)).fold(0.0, f64::max);
        let f = m.order * top / 60.0;
        let hbm_s = if m.hbm {
            m.speeds.len() as f64
                * 3.0
                * hbm_branch_s(n, 10.0, crate::hbm::ContinuationOptions::default().max_points as f64)
        } else {
            0.0
        };
        AnalysisPlan {
            runs,
            samples_per_run: samples,
            memory_bytes: runs as f64 * samples * 24.0,
            output_bytes: m.speeds.len() as f64 * CSV_CELL_BYTES * 16.0 * m.multiples.len() as f64,
            cpu_s: runs as f64 * time_run_s(study, m.max_time_s, f) + hbm_s,
            driver: "max_time_s",
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run(study, self, bench.dir, bench.progress)
    }

    fn json(&self, study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let r = report.multi.iter().find(|r| r.name == self.name)?;
        Json::new(r, &Findings { speeds: findings(r) }, vec![table(study, self, r)])
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<MultiOrderResult>(), generator.subschema_for::<Findings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let r = report.multi.iter().find(|r| r.name == self.name)?;
        let (lo, hi) = (r.speeds.first()?.rpm, r.speeds.last()?.rpm);
        let mut line = format!("{} speeds, {}–{} rpm", r.speeds.len(), num(lo), num(hi));
        let f = findings(r);
        // The main order's amplitude over the locked twin's: what the absorber buys, speed by speed.
        let ratios: Vec<(f64, f64)> =
            f.iter().filter_map(|s| Some((s.rpm, *s.ratio.first()?))).filter(|(_, x)| x.is_finite()).collect();
        let best = ratios.iter().min_by(|a, b| a.1.total_cmp(&b.1));
        let worst = ratios.iter().max_by(|a, b| a.1.total_cmp(&b.1));
        if let (Some(b), Some(w), Some(m)) = (best, worst, r.multiples.first()) {
            line += &format!(
                "; {}n over locked twin {} (at {} rpm) to {} (at {} rpm)",
                num(*m),
                num(b.1),
                num(b.0),
                num(w.1),
                num(w.0)
            );
        }
        Some(line)
    }
}

impl Kept for MultiOrderResult {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.multi.push(*self);
    }
}

//! OrderSweep through the analysis interface (`study/analysis.rs`): its checks, the files it may
//! write, its plan, its run and its entry in `results.json`.

use super::{Direction, SweepRun, SweepSpec, findings, fmt_num, run, tables};
use crate::error::Result;
use crate::model::excitation::rpm_to_rad_s;
use crate::study::Study;
use crate::study::StudyReport;
use crate::study::analysis::{Analysis, Bench, Checks, Kept, Output};
use crate::study::digest::{count, num};
use crate::study::json::Json;
use crate::study::plan::AnalysisPlan;
use crate::study::plan::{CSV_CELL_BYTES, stft_s, time_run_s};
use crate::study::validate::{check_excite, common, g, order_range, pos, rpm, torques, tracking};
use schemars::{JsonSchema, Schema, SchemaGenerator};
use serde::Serialize;

/// An order sweep's `result` in `results.json`.
#[derive(Serialize, JsonSchema)]
#[schemars(rename = "OrderSweepResult")]
struct Runs<'a> {
    /// The runs, the locked twin's included, in the order run.
    runs: Vec<&'a SweepRun>,
}

impl Analysis for SweepSpec {
    fn comparable() -> bool {
        true
    }

    fn check(&self, c: &Checks<'_>) -> Result<()> {
        let Checks { spec, mech, spin: _, src, k: _ } = *c;
        let at = |field: &str| c.at(field);
        let o = spec.order_tracking;
        let s = self;
        check_excite(src, spec, mech, &at("excite"), &s.excite, None)?;
        rpm(src, &at("rpm"), s.rpm)?;
        order_range(src, &at("order_min"), s.order_min, s.order_max)?;
        if !pos(s.duration_s) {
            return Err(src.error(&at("duration_s"), "duration must be finite and positive (s)"));
        }
        if s.duration_s < 2.0 * o.window_s {
            return Err(src.error(
                &at("duration_s"),
                format!("a sweep shorter than two tracking windows ({} s) gives no trace", 2.0 * o.window_s),
            ));
        }
        torques(src, &at("amplitudes"), &s.amplitudes, true)?;
        if s.directions.is_empty() || s.directions.len() > 2 || s.directions.first() == s.directions.get(1) {
            return Err(src.error(&at("directions"), "give Up, Down or both, each once"));
        }
        common(src, &at(""), &s.multiples, s.ramp_s, s.mean_torque)?;
        if s.ramp_s > s.duration_s - 2.0 * o.window_s {
            return Err(src.error(
                &at("ramp_s"),
                format!(
                    "the ramp-in ({} s) must end two tracking windows ({} s) before the sweep does ({} s), \
                     or no window sees the full torque",
                    g(s.ramp_s),
                    g(2.0 * o.window_s),
                    g(s.duration_s)
                ),
            ));
        }
        let omega = rpm_to_rad_s(s.rpm);
        tracking(src, &at("multiples"), spec, o.window_s, o.half_width_bins, omega, s.order_min, &s.multiples)?;
        tracking(src, &at("multiples"), spec, o.window_s, o.half_width_bins, omega, s.order_max, &s.multiples)?;
        Ok(())
    }

    fn files(&self, locked: bool) -> Vec<String> {
        let n = self.name.as_str();
        let mut out = Vec::new();
        let mut csv = |stem: String| out.push(format!("{stem}.csv"));
        let s = self;
        for &amp in &s.amplitudes {
            for d in &s.directions {
                let dir = match d {
                    Direction::Up => "up",
                    Direction::Down => "down",
                };
                let label = format!("{n}_{}Nm_{dir}", fmt_num(amp));
                if s.write_time_series {
                    csv(format!("{label}_time_series"));
                    if locked {
                        csv(format!("{label}_locked_time_series"));
                    }
                }
                csv(label);
            }
        }
        out.extend([format!("{n}.svg"), format!("{n}_elements.svg")]);
        out
    }

    fn plan(&self, study: &Study, base: AnalysisPlan) -> AnalysisPlan {
        let (spec, fs, n, locked) = crate::study::plan::basics(study);
        let s = self;
        let runs = s.amplitudes.len() * (s.directions.len() + locked);
        let samples = s.duration_s * fs + 1.0;
        let windows = s.duration_s / spec.order_tracking.hop_s + 1.0;
        let series_cols = if s.write_time_series { 4.0 + n } else { 0.0 };
        let line_hz = |rpm: f64| s.order_max * s.multiples.iter().copied().fold(1.0, f64::max) * rpm / 60.0;
        // A torque that swings the speed far (`plan::swung_rpm`) whirls the absorbers with it;
        // the locked twin has none moving, and its lines stay where the nominal speed puts them.
        let torque = s.amplitudes.iter().fold(0.0, |m: f64, a| m.max(a.abs()));
        let swung = line_hz(crate::study::plan::swung_rpm(study, torque, s.rpm, s.order_min, s.duration_s));
        let (free, twins) = ((s.amplitudes.len() * s.directions.len()) as f64, (s.amplitudes.len() * locked) as f64);
        let r = runs as f64;
        // The analysis streams (`sim::RunStream`): per channel (the response, each element's
        // coordinate and torque) under two tracking windows and its traces; the record itself only
        // when the time series is asked for.
        let channels = 1.0 + 2.0 * study.elements.len() as f64;
        let window = spec.order_tracking.window_s * fs * 8.0;
        let traces = windows * 32.0 * s.multiples.len() as f64;
        AnalysisPlan {
            runs,
            samples_per_run: samples,
            memory_bytes: r * (samples * 8.0 * series_cols + channels * (2.0 * window + traces) + 4.0 * window),
            output_bytes: r * samples * series_cols * CSV_CELL_BYTES
                + r * windows * CSV_CELL_BYTES * (2.0 + 3.0 * s.multiples.len() as f64),
            cpu_s: free * time_run_s(study, s.duration_s, swung)
                + twins * time_run_s(study, s.duration_s, line_hz(s.rpm))
                + r * stft_s(windows, spec.order_tracking.window_s * fs),
            driver: if s.write_time_series { "write_time_series" } else { "duration_s" },
            ..base
        }
    }

    fn run(&self, study: &Study, bench: &mut Bench<'_>) -> Result<Output> {
        run(study, self, bench.dir, bench.progress)
    }

    fn json(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<Json> {
        let runs: Vec<&SweepRun> = report.sweeps.iter().filter(|r| r.analysis == self.name).collect();
        let (findings, tables) = (findings(self, &runs), tables(self, &runs));
        Json::new(&Runs { runs }, &findings, tables)
    }

    fn json_schemas(generator: &mut SchemaGenerator) -> (Schema, Schema) {
        (generator.subschema_for::<Runs<'static>>(), generator.subschema_for::<super::SweepFindings>())
    }

    fn digest(&self, _study: &Study, report: &StudyReport, _nth: usize) -> Option<String> {
        let runs: Vec<&SweepRun> = report.sweeps.iter().filter(|r| r.analysis == self.name).collect();
        let f = findings(self, &runs);
        // The peak the absorber has to live with: the largest main-order amplitude of the free
        // runs after the ramp-in (the locked twin is the reference, not the design).
        let peak = runs
            .iter()
            .filter(|r| !r.locked)
            .filter_map(|r| {
                let t = r.trace(1.0)?;
                let samples = t.time_s.iter().zip(&t.order).zip(&t.amplitude);
                let ((_, n), a) = samples
                    .filter(|((s, _), a)| **s >= f.skip_before_s && a.is_finite())
                    .max_by(|(_, a), (_, b)| a.total_cmp(b))?;
                Some((*a, *n, r.label()))
            })
            .max_by(|a, b| a.0.total_cmp(&b.0));
        let mut line = count(runs.len(), "run", "runs");
        if let Some((a, n, label)) = peak {
            line += &format!("; main-order peak {} rad/s² at n = {} ({label})", num(a), num(n));
        }
        let differ: Vec<String> =
            f.amplitudes.iter().filter(|a| !a.up_down_differ.is_empty()).map(|a| num(a.amplitude)).collect();
        if !differ.is_empty() {
            line += &format!("; up/down sweeps jump apart at T_n = {} N·m", differ.join(", "));
        }
        Some(line)
    }
}

impl Kept for Vec<SweepRun> {
    fn keep(self: Box<Self>, report: &mut StudyReport) {
        report.sweeps.extend(*self);
    }
}

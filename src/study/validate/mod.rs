//! Validation of a study against its mechanism, before any work: every number finite and in
//! range, every name safe as a file name, every count bounded, and every order-tracking band
//! inside the usable spectrum of its window (the check the short-time FFT of `signal` would
//! otherwise make at run time, with no file or line). The estimated work is checked in `plan`.

use super::StudySpec;
use super::analysis::Checks;
use crate::error::Result;
use crate::io::Source;
use crate::model::loads::ForceFrame;
use crate::model::mechanism::Mechanism;
use std::f64::consts::PI;

mod inputs;
pub mod limits;
mod outputs;
pub use inputs::MAX_TRANSIENT_S;
pub(crate) use inputs::check_excite;

pub use limits::*;

/// Why analyses about a steady spin (linear response, Campbell, multi-order, harmonic balance)
/// cannot be run on this mechanism, if they cannot: they need the spin angle to be cyclic. (The
/// linear ones take gravity and world-frame forces as an order-1 forcing all the same; `check`
/// says which.)
pub fn steady_spin_obstacle(mech: &Mechanism, spin: usize) -> Option<String> {
    let g = mech.loads.gravity;
    if g.x != 0.0 || g.y != 0.0 {
        return Some(format!(
            "mechanism `{}` has gravity ({}, {}) m/s²: the spinning state is then periodic at order 1, \
             not steady, which this analysis needs (OrderSweep, Transient, a HarmonicBalance continued in \
             Speed or Torque, LinearResponse, Campbell and MultiOrder's linear part take gravity); \
             set gravity to (0.0, 0.0)",
            mech.name, g.x, g.y
        ));
    }
    if mech.loads.point_forces.iter().any(|f| f.frame == ForceFrame::World) {
        return Some(format!(
            "mechanism `{}` has a world-frame point force: the spinning state is then not steady; \
             give the force in the body frame",
            mech.name
        ));
    }
    if let Some(s) = mech.joints[spin].spring {
        return Some(format!(
            "the spin joint `{}` has a spring ({} N·m/rad): a spinning rotor cannot wind a spring to ground",
            mech.joints[spin].name, s.stiffness
        ));
    }
    None
}

/// A number for a message: plain when moderate, in exponent form when huge or tiny.
pub(crate) fn g(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") }
}

/// A finite, positive value.
pub(crate) fn pos(v: f64) -> bool {
    v.is_finite() && v > 0.0
}

/// Whether `v` is a positive multiple of ½ within [`MAX_ORDER`]: an order an engine has.
pub(crate) fn half_multiple(v: f64) -> bool {
    v.is_finite() && v > 0.0 && v <= MAX_ORDER && (2.0 * v).fract() == 0.0
}

/// Refuses an analysis that needs a steady spin on a mechanism whose spin is not steady (see
/// [`steady_spin_obstacle`]). A `linear` analysis takes gravity and world-frame forces as an
/// order-1 forcing of the steady rotation (`linear::gravity`), so only a spring on the spin joint
/// stops it. Returns whether the spin is unsteady but accepted, for an analysis whose other parts
/// cannot take it (MultiOrder's time runs).
pub(crate) fn require_steady_spin(c: &Checks<'_>, kind: &str, name: &str, linear: bool) -> Result<bool> {
    // Geared or meshed joints must turn with the spin as a whole (no loop of disagreeing ratios,
    // no turning joint held by a spring): else no steady spin exists to expand about.
    if let Err(why) = c.mech.rigid_rotation(c.spin) {
        return Err(c.src.error(&format!("analyses[{}]", c.k), format!("{kind} `{name}`: {why}")));
    }
    let Some(why) = steady_spin_obstacle(c.mech, c.spin) else { return Ok(false) };
    if !linear || c.mech.joints[c.spin].spring.is_some() {
        return Err(c.src.error(&format!("analyses[{}]", c.k), format!("{kind} `{name}`: {why}")));
    }
    Ok(true)
}

/// Checks one study against its mechanism; the first problem found is returned with its file,
/// line:column and field path.
pub(crate) fn check(spec: &StudySpec, mech: &Mechanism, spin: usize, src: &Source) -> Result<()> {
    // The study name was checked before its mechanism was read (`Study::from_source`).
    let i = spec.integration;
    check_rtol(i.rtol).map_err(|m| src.error("integration.rtol", m))?;
    if !(pos(i.atol) && i.atol <= 1.0) {
        return Err(src.error("integration.atol", "absolute tolerance must be finite, positive and at most 1"));
    }
    check_sample_hz(i.sample_hz).map_err(|m| src.error("integration.sample_hz", m))?;
    if i.max_steps == 0 {
        return Err(src.error("integration.max_steps", "must be at least 1"));
    }
    let o = spec.order_tracking;
    if !pos(o.window_s) {
        return Err(src.error("order_tracking.window_s", "window must be finite and positive (s)"));
    }
    if !pos(o.hop_s) {
        return Err(src.error("order_tracking.hop_s", "hop must be finite and positive (s)"));
    }
    if o.hop_s * i.sample_hz < 1.0 {
        return Err(src.error("order_tracking.hop_s", "hop is shorter than one sample (raise hop_s or sample_hz)"));
    }
    if o.half_width_bins > 64 {
        return Err(
            src.error("order_tracking.half_width_bins", "at most 64 bins each side (2 is the 5-bin convention)")
        );
    }
    if spec.analyses.is_empty() {
        return Err(src.error("analyses", "no analyses: nothing to run"));
    }
    if spec.analyses.len() > MAX_ANALYSES {
        return Err(src.error("analyses", format!("{} analyses; at most {MAX_ANALYSES}", spec.analyses.len())));
    }
    if spec.lock.len() > MAX_LIST {
        return Err(src.error("lock", format!("{} locked joints; at most {MAX_LIST}", spec.lock.len())));
    }
    let mut names = std::collections::HashSet::new();
    for (k, a) in spec.analyses.iter().enumerate() {
        let at = |field: &str| format!("analyses[{k}].{field}");
        let name = a.name();
        if let Err(m) = check_file_name(name) {
            return Err(src.error(&at("name"), m));
        }
        if !names.insert(name.to_string()) {
            return Err(src.error(&at("name"), format!("duplicate analysis name `{name}`")));
        }
        a.analysis().check(&Checks { spec, mech, spin, src, k })?;
    }
    outputs::check_unique(spec, src)
}

/// Modal damping ratios: 1 to `MAX_LIST` of them, each finite in 0..=10.
pub(crate) fn modal_ratios(src: &Source, path: &str, z: &crate::linear::ModalDamping) -> Result<()> {
    let ratios = match z {
        crate::linear::ModalDamping::All(v) => std::slice::from_ref(v),
        crate::linear::ModalDamping::PerMode(v) => v.as_slice(),
    };
    if ratios.is_empty() || ratios.len() > MAX_LIST {
        return Err(src.error(path, format!("give 1 to {MAX_LIST} damping ratios")));
    }
    if let Some(bad) = ratios.iter().find(|z| !(z.is_finite() && (0.0..=10.0).contains(*z))) {
        return Err(src.error(path, format!("damping ratio {bad} must lie in 0..=10")));
    }
    Ok(())
}

/// An analysis's `modal_damping` (at `at("modal_damping")`) and `modal_combination`: valid
/// ratios, and no combination without ratios to combine (it would read as damping that is not
/// there).
pub(crate) fn modal_fields(
    src: &Source,
    at: &dyn Fn(&str) -> String,
    z: Option<&crate::linear::ModalDamping>,
    how: Option<crate::linear::ModalCombination>,
) -> Result<()> {
    match (z, how) {
        (Some(z), _) => modal_ratios(src, &at("modal_damping"), z),
        (None, Some(how)) => Err(src.error(
            &at("modal_combination"),
            format!(
                "modal_combination: {how:?} without modal_damping: give the ratios (e.g. All(0.01)) or leave it out"
            ),
        )),
        (None, None) => Ok(()),
    }
}

pub(crate) fn rpm(src: &Source, path: &str, v: f64) -> Result<()> {
    check_rpm(v, false).map_err(|m| src.error(path, m))
}

pub(crate) fn order(src: &Source, path: &str, v: f64) -> Result<()> {
    check_order(v).map_err(|m| src.error(path, m))
}

pub(crate) fn order_range(src: &Source, path: &str, lo: f64, hi: f64) -> Result<()> {
    if pos(lo) && hi.is_finite() && lo < hi && hi <= MAX_ORDER {
        Ok(())
    } else {
        Err(src.error(path, format!("need 0 < order_min < order_max ≤ {MAX_ORDER}")))
    }
}

pub(crate) fn torque(src: &Source, path: &str, v: f64) -> Result<()> {
    check_torque(v).map_err(|m| src.error(path, m))
}

pub(crate) fn torques(src: &Source, path: &str, v: &[f64], allow_zero: bool) -> Result<()> {
    if v.is_empty() || v.len() > MAX_LIST {
        return Err(src.error(path, format!("give 1 to {MAX_LIST} amplitudes (N·m)")));
    }
    for (j, &a) in v.iter().enumerate() {
        torque(src, &format!("{path}[{j}]"), a)?;
        if !allow_zero && a == 0.0 {
            return Err(src.error(&format!("{path}[{j}]"), "a zero amplitude has no periodic response to continue"));
        }
    }
    let mut seen = v.to_vec();
    seen.sort_by(f64::total_cmp);
    if seen.windows(2).any(|w| w[0] == w[1]) {
        return Err(src.error(path, "an amplitude is given twice (its runs would write the same files)"));
    }
    Ok(())
}

/// Checks shared by the time-domain analyses; `prefix` ends with a dot.
pub(crate) fn common(src: &Source, prefix: &str, multiples: &[f64], ramp_s: f64, mean: Option<f64>) -> Result<()> {
    let field = |f: &str| format!("{prefix}{f}");
    if multiples.is_empty() || multiples.len() > 64 {
        return Err(src.error(&field("multiples"), "give 1 to 64 harmonic multiples (1 = main order)"));
    }
    for (j, &m) in multiples.iter().enumerate() {
        order(src, &field(&format!("multiples[{j}]")), m)?;
    }
    if !(ramp_s.is_finite() && ramp_s >= 0.0) {
        return Err(src.error(&field("ramp_s"), "ramp must be a finite, non-negative duration (s)"));
    }
    if let Some(m) = mean {
        torque(src, &field("mean_torque"), m)?;
    }
    Ok(())
}

/// The short-time FFT of a window of `window_s` at the study's sample rate must hold the band of
/// `2·half + 1` bins around each tracked line `m·n·Ω/2π` inside bins 1..N/2 − 1 (no DC, no
/// Nyquist; see `signal`'s calibration). Checked at one order `n` (the band moves linearly with
/// n, so the two ends of a sweep bound it).
#[allow(clippy::too_many_arguments)]
pub(crate) fn tracking(
    src: &Source,
    path: &str,
    spec: &StudySpec,
    window_s: f64,
    half: usize,
    omega: f64,
    n: f64,
    multiples: &[f64],
) -> Result<()> {
    let fs = spec.integration.sample_hz;
    let samples = (window_s * fs).round();
    if samples < MIN_WINDOW_SAMPLES {
        return Err(src.error(
            path,
            format!(
                "a tracking window of {window_s} s at {fs} Hz holds {samples} samples; at least {MIN_WINDOW_SAMPLES} \
                 (lengthen the window or raise integration.sample_hz)"
            ),
        ));
    }
    if samples > MAX_WINDOW_SAMPLES {
        return Err(src.error(
            path,
            format!(
                "a tracking window of {window_s} s at {fs} Hz holds {samples:e} samples; at most {MAX_WINDOW_SAMPLES:e}"
            ),
        ));
    }
    let last = (samples / 2.0).floor() - 1.0;
    for &m in multiples {
        let f = m * n * omega / (2.0 * PI);
        let centre = (f * window_s).round();
        let (lo, hi) = (centre - half as f64, centre + half as f64);
        if lo < 1.0 || hi > last {
            let advice = if lo < 1.0 {
                "lengthen the tracking window or lower half_width_bins"
            } else {
                "raise integration.sample_hz (the line is at or beyond Nyquist) or lower half_width_bins"
            };
            return Err(src.error(
                path,
                format!(
                    "the {m}× line at order {n} ({f:.4} Hz) needs bins {lo}..={hi} of a {window_s} s window at {fs} Hz, \
                     but only bins 1..={last} are usable: {advice}"
                ),
            ));
        }
    }
    Ok(())
}

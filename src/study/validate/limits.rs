//! The limits of a study file's numbers, counts and names, shared by every check.

/// Longest study, analysis or variant name, characters: every output file name is built from
/// one of these plus at most ~40 characters, well under the 255 bytes most file systems allow.
pub const MAX_NAME_CHARS: usize = 64;
/// Most analyses in one study.
pub const MAX_ANALYSES: usize = 100;
/// Most entries in one list of a study (amplitudes, multiples, speeds, harmonics, orders,
/// variants, locked joints): each entry is a run, a trace or a column.
pub const MAX_LIST: usize = 1000;
/// Highest excitation order, multiple or Campbell order line: engine orders stay below ~50;
/// beyond this the order-line arithmetic only produces overflow.
pub const MAX_ORDER: f64 = 1000.0;
/// Highest speed, rpm.
pub const MAX_RPM: f64 = 1e6;
/// Largest torque amplitude or mean torque, N·m (ten times a ship engine's).
pub const MAX_TORQUE_NM: f64 = 1e9;
/// Smallest relative tolerance: below ~500 ε the integrator's error estimate is rounding noise
/// and the step size collapses ("t = inf" failures).
pub const MIN_RTOL: f64 = 1e-13;
/// Fewest samples per order-tracking window.
pub const MIN_WINDOW_SAMPLES: f64 = 16.0;
/// Most samples per order-tracking window (the FFT length; 2²⁶ samples = 512 MB of buffers).
pub const MAX_WINDOW_SAMPLES: f64 = 67_108_864.0;
/// Most points of a linear response or a Campbell diagram.
pub const MAX_POINTS: usize = 1_000_000;

/// A name that can be used as a file or folder name on every platform: 1 to
/// [`MAX_NAME_CHARS`] characters of `A–Z a–z 0–9 _ - .`, not starting with `.` or `-` (so no
/// `.`, `..`, hidden files or option-like names), and no path separator.
pub fn check_file_name(name: &str) -> std::result::Result<(), String> {
    if name.is_empty() {
        return Err("name is empty".into());
    }
    if name.chars().count() > MAX_NAME_CHARS {
        return Err(format!("name is {} characters long; at most {MAX_NAME_CHARS}", name.chars().count()));
    }
    if let Some(c) = name.chars().find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))) {
        return Err(format!(
            "name `{}` contains {c:?}: output file names allow only letters, digits, `_`, `-` and `.`",
            name.escape_debug()
        ));
    }
    if name.starts_with(['.', '-']) {
        return Err(format!("name `{name}` must not start with `.` or `-`"));
    }
    Ok(())
}

// ---- Shared checks: the command line's validation and the Python API call these same
// functions, so a number one refuses the other refuses with the same words (issue 25: the
// Python API let `sample_hz=1e12` abort the interpreter and `rpm=-1` through). Each returns the
// reason without a location; the caller adds the file, line and field, or the argument name.

/// Highest sample rate of a time run, Hz.
pub const MAX_SAMPLE_HZ: f64 = 1e7;
/// Most harmonics of a harmonic balance (its unknowns grow as 2H + 1 per coordinate, its
/// Jacobian as their square).
pub const MAX_HARMONICS: usize = 64;
/// Longest time run, s of simulated time (a day): a transient's duration, a Python run's
/// `t1 − t0`.
pub const MAX_RUN_S: f64 = 86_400.0;
/// Most bytes the samples of one time run may take (8 bytes per value): the command line's
/// default memory limit (`--max-memory-mb 2048`), so a run asked for more is refused instead
/// of aborting the process when the allocation fails.
pub const MAX_SAMPLE_BYTES: f64 = 2048.0 * 1024.0 * 1024.0;

/// A number for a message: plain when moderate, in exponent form when huge or tiny.
fn num(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e6).contains(&v.abs()) { format!("{v:e}") } else { format!("{v}") }
}

/// A spin speed, rpm: finite, at most [`MAX_RPM`], positive (or zero where `allow_zero`: a
/// Campbell diagram's or a linearisation's standstill).
pub fn check_rpm(rpm: f64, allow_zero: bool) -> Result<(), String> {
    let low_ok = if allow_zero { rpm >= 0.0 } else { rpm > 0.0 };
    if rpm.is_finite() && low_ok && rpm <= MAX_RPM {
        Ok(())
    } else {
        let low = if allow_zero { "0 ≤ rpm" } else { "0 < rpm" };
        Err(format!("speed must be within {low} ≤ {MAX_RPM:e}, got {}", num(rpm)))
    }
}

/// A relative tolerance: [`MIN_RTOL`]..=0.1.
pub fn check_rtol(rtol: f64) -> Result<(), String> {
    if rtol.is_finite() && (MIN_RTOL..=0.1).contains(&rtol) {
        Ok(())
    } else {
        Err(format!("relative tolerance must lie in {MIN_RTOL:e}..=0.1, got {}", num(rtol)))
    }
}

/// A sample rate, Hz: 0 < fs ≤ [`MAX_SAMPLE_HZ`].
pub fn check_sample_hz(hz: f64) -> Result<(), String> {
    if hz.is_finite() && hz > 0.0 && hz <= MAX_SAMPLE_HZ {
        Ok(())
    } else {
        Err(format!("sample rate must be finite, positive and at most {MAX_SAMPLE_HZ:e} Hz, got {}", num(hz)))
    }
}

/// The number of harmonics of a harmonic balance: 1..=[`MAX_HARMONICS`].
pub fn check_harmonics(h: usize) -> Result<(), String> {
    if (1..=MAX_HARMONICS).contains(&h) { Ok(()) } else { Err(format!("need 1 to {MAX_HARMONICS} harmonics, got {h}")) }
}

/// A time run from `t0` to `t1`, s: both finite, `t1` after `t0`, at most [`MAX_RUN_S`] long.
pub fn check_run_time(t0: f64, t1: f64) -> Result<(), String> {
    if !(t0.is_finite() && t1.is_finite()) {
        return Err(format!("the start and end times must be finite, got {} and {} s", num(t0), num(t1)));
    }
    if t1 <= t0 {
        return Err(format!("the end time must be after the start, got {} ≤ {} s", num(t1), num(t0)));
    }
    if t1 - t0 > MAX_RUN_S {
        return Err(format!("a run is at most {MAX_RUN_S} s of simulated time (a day), got {} s", num(t1 - t0)));
    }
    Ok(())
}

/// The samples a run of `duration_s` at `sample_hz` keeps, `columns` values each: at most
/// [`MAX_SAMPLE_BYTES`].
pub fn check_samples(duration_s: f64, sample_hz: f64, columns: usize) -> Result<(), String> {
    let bytes = (duration_s * sample_hz + 1.0) * (columns.max(1) as f64) * 8.0;
    if bytes <= MAX_SAMPLE_BYTES {
        Ok(())
    } else {
        Err(format!(
            "{} s at {} Hz with {columns} recorded values per sample is {:.1} MB of samples, over the limit of {:.0} MB; \
             lower the sample rate or shorten the run",
            num(duration_s),
            num(sample_hz),
            bytes / 1048576.0,
            MAX_SAMPLE_BYTES / 1048576.0
        ))
    }
}

/// A harmonic-balance continuation's largest step (arc length in the scaled unknowns):
/// 1e-6..=10.
pub fn check_max_step(ds: f64) -> Result<(), String> {
    if ds.is_finite() && (1e-6..=10.0).contains(&ds) {
        Ok(())
    } else {
        Err(format!("the largest continuation step must be finite and within 1e-6..=10, got {}", num(ds)))
    }
}

/// A count of evaluation points (orders of a response, speeds of a diagram): 1..=[`MAX_POINTS`].
pub fn check_point_count(n: usize) -> Result<(), String> {
    if (1..=MAX_POINTS).contains(&n) { Ok(()) } else { Err(format!("need 1 to {MAX_POINTS} points, got {n}")) }
}

/// An excitation order or multiple: finite, positive, at most [`MAX_ORDER`].
pub fn check_order(v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 && v <= MAX_ORDER {
        Ok(())
    } else {
        Err(format!("must be finite, positive and at most {MAX_ORDER}, got {}", num(v)))
    }
}

/// A torque, N·m: finite, at most [`MAX_TORQUE_NM`] in size.
pub fn check_torque(v: f64) -> Result<(), String> {
    if v.is_finite() && v.abs() <= MAX_TORQUE_NM {
        Ok(())
    } else {
        Err(format!("torque must be finite, |T| ≤ {MAX_TORQUE_NM:e} N·m, got {}", num(v)))
    }
}

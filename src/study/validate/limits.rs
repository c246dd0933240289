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

//! Regression tests of issue 11 (reliability and security of study runs), one or more per class
//! of defect found by feeding hostile study files to `kanedyn run`. Each test names what used to
//! happen; the inputs are the minimal ones that showed it.

use approx::abs_diff_eq;
use kanedyn::study::{RunOptions, Study, run};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use tempfile::TempDir;

/// A scratch copy of `examples/` (with its catalog parts), so studies written here find the
/// example mechanisms by relative path; removed when dropped.
struct Scratch(TempDir);

impl Scratch {
    fn new(tag: &str) -> Self {
        let root = crate::support::scratch(&format!("rel-{tag}"));
        copy_dir(Path::new(env!("CARGO_MANIFEST_DIR")), root.path(), &["examples", "bodies", "joints"]);
        Scratch(root)
    }
    /// Writes a study into the scratch `examples/` folder and returns its path.
    fn study(&self, file: &str, text: &str) -> PathBuf {
        let p = self.0.path().join("examples").join(file);
        std::fs::write(&p, text).unwrap();
        p
    }
    fn out(&self) -> PathBuf {
        self.0.path().join("out")
    }
}

fn copy_dir(from: &Path, to: &Path, only: &[&str]) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let name = e.file_name();
        if !only.is_empty() && !only.iter().any(|o| name == *o) {
            continue;
        }
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(&name), &[]);
        } else {
            std::fs::copy(&p, to.join(&name)).unwrap();
        }
    }
}

use crate::support::cli;
use cli::run as kanedyn;

fn text(o: &Output) -> String {
    format!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr))
}

/// A study around one analysis, on the paper's CPVA with the pendulum locked in the twin.
fn study_with(analysis: &str) -> String {
    format!(
        r#"Study(
    name: "s",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        {analysis},
    ],
)
"#
    )
}

const SWEEP: &str =
    r#"OrderSweep(name: "a", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 20.0, amplitudes: [40.0])"#;

/// The load error of a study text, as printed.
fn load_error(s: &Scratch, text: &str) -> String {
    let p = s.study("bad.ron", text);
    match Study::from_file(&p) {
        Ok(_) => panic!("expected an error for\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Asserts an error names the study file with a line:column and the field.
fn assert_located(e: &str, field: &str) {
    assert!(e.contains("bad.ron:"), "no file in: {e}");
    assert!(e.contains(&format!("(field `{field}`)")), "field `{field}` not named in: {e}");
    let after = e.split("bad.ron:").nth(1).unwrap_or("");
    let lc: Vec<&str> = after.split([' ', '(']).next().unwrap_or("").split(':').collect();
    assert!(lc.len() >= 2 && lc[0].parse::<usize>().is_ok() && lc[1].parse::<usize>().is_ok(), "no line:col in: {e}");
}

// ---- Class 1: panics ----

/// Used to panic: "slice index out of range" in the order tracking, when a tracked line's bin
/// number overflowed (rpm, order_max or a multiple of ~1e19).
#[test]
fn overflowing_tracked_frequencies_are_refused_at_load() {
    let s = Scratch::new("overflow");
    for (sweep, field) in [
        (SWEEP.replace("rpm: 1000.0", "rpm: 1e19"), "analyses[0].rpm"),
        (SWEEP.replace("order_max: 3.3", "order_max: 1e19"), "analyses[0].order_min"),
        (SWEEP.replace("amplitudes: [40.0]", "amplitudes: [40.0], multiples: [1.0, 1e19]"), "analyses[0].multiples[1]"),
    ] {
        let p = s.study("bad.ron", &study_with(&sweep));
        let o = kanedyn(&["run", p.to_str().unwrap(), "--out", s.out().to_str().unwrap()]);
        let t = text(&o);
        assert_eq!(o.status.code(), Some(3), "{t}");
        assert!(!t.contains("panicked"), "{t}");
        assert_located(&t, field);
    }
}

/// Used to panic: "capacity overflow" allocating u64::MAX points.
#[test]
fn point_counts_near_u64_max_are_refused() {
    let s = Scratch::new("points");
    let lin = r#"LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.1, points: 18446744073709551615)"#;
    let camp = r#"Campbell(name: "c", rpm_min: 0.0, rpm_max: 2000.0, points: 18446744073709551614)"#;
    for a in [lin, camp] {
        assert_located(&load_error(&s, &study_with(a)), "analyses[0].points");
    }
}

// ---- Class 2: unbounded work and memory ----

/// Used to hang or exhaust memory; now refused at load with the estimate, the limit and the flag.
#[test]
fn unbounded_work_is_refused_with_the_numbers_and_the_flag() {
    let s = Scratch::new("work");
    let cases = [
        (SWEEP.replace("duration_s: 20.0", "duration_s: 1e9"), "--max-memory-mb", "analyses[0].duration_s"),
        (
            SWEEP.replace("amplitudes: [40.0]", "amplitudes: [40.0], write_time_series: true")
                .replace("duration_s: 20.0", "duration_s: 200000.0"),
            "--max-memory-mb",
            "analyses[0].write_time_series",
        ),
        (
            r#"MultiOrder(name: "m", order: 3.0, speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 100.0)])], max_time_s: 1e12, linear: false)"#.into(),
            "--max-cpu-hours",
            "analyses[0].max_time_s",
        ),
    ];
    for (a, flag, field) in cases {
        let e = load_error(&s, &study_with(&a));
        assert!(e.contains(flag) && e.contains("estimated"), "{e}");
        assert_located(&e, field);
    }
    // Huge sample rates, windows and lists are refused by their own bounds.
    let text = study_with(SWEEP).replace("lock: [\"pivot\"],", "lock: [\"pivot\"], integration: (sample_hz: 1e12),");
    assert_located(&load_error(&s, &text), "integration.sample_hz");
    let text = study_with(SWEEP).replace("lock: [\"pivot\"],", "lock: [\"pivot\"], order_tracking: (window_s: 1e9),");
    assert_located(&load_error(&s, &text), "analyses[0].duration_s");
    let many: Vec<String> = (0..1001).map(|i| format!("{}.0", i + 1)).collect();
    let a = SWEEP.replace("amplitudes: [40.0]", &format!("amplitudes: [{}]", many.join(", ")));
    assert_located(&load_error(&s, &study_with(&a)), "analyses[0].amplitudes");
    let a = SWEEP.replace("order_max: 3.3", "order_max: 1e300");
    assert_located(&load_error(&s, &study_with(&a)), "analyses[0].order_min");
}

/// A limit raised on purpose lets the same study load.
#[test]
fn a_raised_limit_admits_the_study() {
    let s = Scratch::new("raise");
    let a = SWEEP
        .replace("duration_s: 20.0", "duration_s: 4000.0")
        .replace("[40.0]", "[10.0, 20.0, 30.0, 40.0, 50.0, 60.0]");
    let p = s.study("big.ron", &study_with(&a));
    // Streamed, the 18 runs of 4000 s hold their traces only (tens of MB, not the records' GB).
    let low = kanedyn(&["check", p.to_str().unwrap(), "--max-memory-mb", "10"]);
    assert!(!low.status.success() && text(&low).contains("--max-memory-mb"), "{}", text(&low));
    let high = kanedyn(&["check", p.to_str().unwrap(), "--max-memory-mb", "100000"]);
    assert!(high.status.success(), "{}", text(&high));
}

/// Used to try to start 100,000 threads.
#[test]
fn the_thread_count_is_capped() {
    let s = Scratch::new("threads");
    let p =
        s.study("lin.ron", &study_with(r#"LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.1, points: 11)"#));
    let o = kanedyn(&["run", p.to_str().unwrap(), "--out", s.out().to_str().unwrap(), "--threads", "100000"]);
    assert!(o.status.success(), "{}", text(&o));
    assert!(text(&o).contains("--threads 100000 lowered to"), "{}", text(&o));
}

// ---- Class 3: writes outside the output folder, mixed folders ----

/// Used to write outside `--out` (`../x`, absolute paths) or straight into it (`""`, `.`).
#[test]
fn study_and_analysis_names_cannot_leave_the_output_folder() {
    let s = Scratch::new("names");
    let long = "x".repeat(65);
    for name in ["../x", "/tmp/x", "/", "", ".", "..", "a/b", "a\\\\b", ".hidden", "-rf", long.as_str()] {
        let text = study_with(SWEEP).replace("name: \"s\"", &format!("name: \"{name}\""));
        assert_located(&load_error(&s, &text), "name");
        let text = study_with(&SWEEP.replace("name: \"a\"", &format!("name: \"{name}\"")));
        assert_located(&load_error(&s, &text), "analyses[0].name");
    }
    assert!(!s.0.path().join("x").exists() && !Path::new("/tmp/x/summary.md").exists());
    // Used to: an amplitude of 1e-300 made a 300-digit file name, too long to write.
    let p = s.study("tiny.ron", &study_with(&SWEEP.replace("[40.0]", "[1e-300]")));
    let report = run(&Study::from_file(&p).unwrap(), &RunOptions { out: Some(s.out()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    assert!(s.out().join("s/a_1e-300Nm_up.csv").exists(), "{:?}", report.files);
}

/// Used to: two runs into the same folder both wrote into it and left a mix of their files.
/// Now the outputs are written in a temporary folder and moved into place under a lock: the
/// folder holds exactly one run's files, and a run refused by the lock says so.
#[test]
fn concurrent_runs_into_one_folder_never_mix() {
    let s = Scratch::new("concurrent");
    let lin = r#"LinearResponse(name: "first", rpm: 1000.0, from: 0.9, to: 1.1, points: 200001)"#;
    let camp = r#"Campbell(name: "second", rpm_min: 0.0, rpm_max: 2000.0, points: 20001)"#;
    let a = s.study("a.ron", &study_with(lin));
    let b = s.study("b.ron", &study_with(camp));
    let out = s.out();
    let spawn = |p: &Path| {
        Command::new(env!("CARGO_BIN_EXE_kanedyn"))
            .args(["run", p.to_str().unwrap(), "--out", out.to_str().unwrap()])
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (pa, pb) = (spawn(&a), spawn(&b));
    let (oa, ob) = (pa.wait_with_output().unwrap(), pb.wait_with_output().unwrap());
    for o in [&oa, &ob] {
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success() || err.contains("being written by another kanedyn run"), "{err}");
    }
    assert!(oa.status.success() || ob.status.success());
    let mut files: Vec<String> = std::fs::read_dir(out.join("s"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    files.sort();
    let first = ["first.svg", "first_as_built.csv", "report.html", "results.json", "summary.md"];
    let second = ["report.html", "results.json", "second.csv", "second.svg", "second_crossings.csv", "summary.md"];
    assert!(files == first || files == second, "mixed folder: {files:?}");
    // No half-written folder is left posing as a result.
    let hidden: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".partial-"))
        .collect();
    assert!(hidden.is_empty());
}

// ---- Class 4: run-time errors lose the report ----

/// Used to abort the whole study at the first run-time error: no summary, later analyses never
/// run. Now a diverging harmonic balance is one Failures entry, with its location; the analyses
/// before and after it write their files, and the exit code is non-zero.
#[test]
fn a_failing_analysis_costs_the_others_nothing() {
    let s = Scratch::new("isolate");
    let study = r#"Study(
    name: "iso",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        LinearResponse(name: "before", rpm: 1000.0, from: 0.9, to: 1.1, points: 11),
        HarmonicBalance(name: "diverges", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6],
                        harmonics: 1, multiples: [1.0]),
        Campbell(name: "after", rpm_min: 0.0, rpm_max: 2000.0, points: 5),
    ],
)
"#;
    let p = s.study("iso.ron", study);
    let o = kanedyn(&["run", p.to_str().unwrap(), "--out", s.out().to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(6), "{}", text(&o));
    let dir = s.out().join("iso");
    for f in ["before_as_built.csv", "before.svg", "after.csv", "after.svg", "summary.md", "results.json"] {
        assert!(dir.join(f).exists(), "{f} missing");
    }
    let summary = std::fs::read_to_string(dir.join("summary.md")).unwrap();
    assert!(summary.contains("partial results"), "{summary}");
    let failures = summary.split("## Failures").nth(1).expect("a Failures section");
    assert!(failures.contains("HarmonicBalance `diverges` (") && failures.contains("iso.ron:7:9"), "{failures}");
    assert!(!failures.contains("`before`") && !failures.contains("`after`"), "{failures}");
}

/// Used to fail at run time as "mechanism `order tracking`: …" with no file or line, losing the
/// report. Now every band is checked against the window and Nyquist at load.
#[test]
fn order_tracking_settings_are_checked_at_load() {
    let s = Scratch::new("tracking");
    let with =
        |tracking: &str| study_with(SWEEP).replace("lock: [\"pivot\"],", &format!("lock: [\"pivot\"], {tracking}"));
    // 64 bins each side of a line at bin ~110 of a 2 s window reach below bin 1.
    let e = load_error(&s, &with("order_tracking: (half_width_bins: 64, window_s: 0.5),"));
    assert!(!e.contains("order tracking`"), "{e}");
    assert_located(&e, "analyses[0].multiples");
    // A 2n line at 110 Hz is beyond Nyquist at 200 Hz sampling.
    let e = load_error(&s, &with("integration: (sample_hz: 200.0),"));
    assert!(e.contains("Nyquist"), "{e}");
    assert_located(&e, "analyses[0].multiples");
    // Four samples per window.
    let e = load_error(&s, &with("integration: (sample_hz: 2000.0), order_tracking: (window_s: 0.002),"));
    assert_located(&e, "analyses[0].multiples");
}

// ---- Class 5: nonsense accepted ----

/// Used to pass validation and give NaN or inf columns with exit 0, or fail later at "t = inf".
#[test]
fn nonsense_values_are_refused_at_load() {
    let s = Scratch::new("nonsense");
    let multi = |extra: &str| {
        format!(
            r#"MultiOrder(name: "m", order: 3.0, speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 100.0)])]{extra})"#
        )
    };
    let integ =
        |i: &str| study_with(SWEEP).replace("lock: [\"pivot\"],", &format!("lock: [\"pivot\"], integration: ({i}),"));
    let cases: Vec<(String, &str)> = vec![
        (study_with(&SWEEP.replace("[40.0]", "[40.0], ramp_s: 1e300")), "analyses[0].ramp_s"),
        (
            study_with(r#"Campbell(name: "c", rpm_min: 0.0, rpm_max: 2000.0, points: 5, orders: [1.7e308])"#),
            "analyses[0].orders[0]",
        ),
        (study_with(&multi(", min_time_s: NaN")), "analyses[0].min_time_s"),
        (study_with(&multi(", min_time_s: inf")), "analyses[0].min_time_s"),
        (study_with(&multi(", min_time_s: -1.0")), "analyses[0].min_time_s"),
        (integ("rtol: 1e-300"), "integration.rtol"),
        (integ("max_steps: 0"), "integration.max_steps"),
    ];
    for (text, field) in cases {
        assert_located(&load_error(&s, &text), field);
    }
}

/// Used to: a MultiOrder run on a mechanism with gravity wrote NaN everywhere and exited 0. Now
/// the parts of an analysis about a steady spin that cannot take gravity are refused, saying why
/// (a MultiOrder's steady time runs: its linear part takes gravity, tests/it/gravity_linear.rs).
#[test]
fn steady_spin_analyses_under_gravity_are_refused() {
    let s = Scratch::new("gravity");
    let mech = std::fs::read_to_string(s.0.path().join("examples/cpva.ron")).unwrap();
    let with_g = mech.replacen("gravity: (0.0, 0.0)", "gravity: (0.0, -9.81)", 1);
    let with_g = if with_g == mech {
        mech.replacen(
            "speeds: AbsoluteAngularVelocities,",
            "speeds: AbsoluteAngularVelocities, gravity: (0.0, -9.81),",
            1,
        )
    } else {
        with_g
    };
    assert_ne!(with_g, mech, "could not add gravity to the example");
    std::fs::write(s.0.path().join("examples/cpva_g.ron"), with_g).unwrap();
    let m =
        r#"MultiOrder(name: "m", order: 3.0, speeds: [(rpm: 1000.0, harmonics: [(multiple: 1.0, amplitude: 100.0)])])"#;
    let e = load_error(&s, &study_with(m).replace("cpva.ron", "cpva_g.ron"));
    assert!(e.contains("gravity"), "{e}");
    assert_located(&e, "analyses[0].time_domain");
    // The time-domain sweep takes gravity.
    let p = s.study("sweep_g.ron", &study_with(SWEEP).replace("cpva.ron", "cpva_g.ron"));
    assert!(Study::from_file(&p).is_ok());
}

/// Used to print ratios of 682 (and, for an exactly zero reference, 1.3e12) where the locked twin
/// has no response: it is linear, so it answers only at the excitation order and its second-order
/// trace is integration noise. Such ratios are now undefined (empty cells), and the first-order
/// ratio stays the quotient of the two amplitudes.
#[test]
fn ratios_to_a_reference_without_response_are_undefined() {
    let s = Scratch::new("ratio");
    let p = s.study("r.ron", &study_with(SWEEP));
    let study = Study::from_file(&p).unwrap();
    let report = run(&study, &RunOptions { out: Some(s.out()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let csv = std::fs::read_to_string(s.out().join("s/a_40Nm_up.csv")).unwrap();
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let (a1, l1, r1, r2) = (col("amp_1x_rad_s2"), col("locked_1x_rad_s2"), col("ratio_1x"), col("ratio_2x"));
    let mut rows = 0;
    for line in lines {
        let c: Vec<&str> = line.split(',').collect();
        assert_eq!(c[r2], "", "2n ratio to the locked twin's noise: {line}");
        if !c[l1].is_empty() {
            let (a, l, r): (f64, f64, f64) = (c[a1].parse().unwrap(), c[l1].parse().unwrap(), c[r1].parse().unwrap());
            assert!(abs_diff_eq!(r, a / l, epsilon = 1e-12 * r.abs()), "{line}");
            rows += 1;
        }
        assert!(!line.contains("NaN") && !line.contains("inf"), "{line}");
    }
    assert!(rows > 50, "only {rows} rows with a locked reference");
}

/// `kanedyn check STUDY` validates without running and prints the plan; its sample count is the
/// duration times the sample rate, plus the sample at t = 0.
#[test]
fn check_prints_the_plan_of_a_study() {
    let s = Scratch::new("plan");
    let p = s.study("p.ron", &study_with(SWEEP));
    let o = kanedyn(&["check", p.to_str().unwrap()]);
    let t = text(&o);
    assert!(o.status.success(), "{t}");
    // 20 s at the default 2000 Hz: 40,001 samples; 1 amplitude × (2 directions + the locked twin).
    let row = t.lines().find(|l| l.starts_with("| a | OrderSweep |")).unwrap_or_else(|| panic!("{t}"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    assert_eq!(cells[3], "3", "{row}");
    assert_eq!(cells[4].parse::<f64>().unwrap(), 40001.0, "{row}");
    assert!(!s.out().exists(), "check must not write outputs");
}

// ---- Class 6: information leaks through `mechanism:` ----

/// Used to read any absolute path named as the mechanism and echo its first word in the parse
/// error (`… found `root`` for the password file), and to answer differently for paths that do
/// and do not exist. Now a path outside the study's folder tree is refused before it is read, with
/// the same words whether it exists or not; allowed on purpose, a file that is not a mechanism
/// is still not echoed.
#[test]
fn a_mechanism_outside_the_study_tree_is_refused_unread() {
    let s = Scratch::new("leak");
    let named = |m: &str| study_with(SWEEP).replace("\"cpva.ron\"", &format!("\"{m}\""));
    let e_real = load_error(&s, &named("/etc/passwd"));
    let e_none = load_error(&s, &named("/etc/no_such_file_kanedyn"));
    assert_located(&e_real, "mechanism");
    assert!(e_real.contains("--allow-any-path") || e_real.contains("--allow-read"), "{e_real}");
    assert_eq!(e_real.replace("/etc/passwd", "X"), e_none.replace("/etc/no_such_file_kanedyn", "X"));
    let e = load_error(&s, &named("../../../../../../etc/passwd"));
    assert_located(&e, "mechanism");
    // Allowed on purpose: read, but not echoed.
    let p = s.study("bad.ron", &named("/etc/passwd"));
    let opts = kanedyn::study::LoadOptions { allow_any_path: true, ..Default::default() };
    let e = Study::from_file_with(&p, &opts).expect_err("not a mechanism").to_string();
    assert!(!e.contains("root") && !e.contains("bin/"), "echoes the file: {e}");
    // The CLI flag does the same.
    let o = kanedyn(&["check", p.to_str().unwrap(), "--allow-any-path"]);
    assert!(!o.status.success() && !text(&o).contains("root:"), "{}", text(&o));
}

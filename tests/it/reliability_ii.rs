//! Regression tests of issue 25 ("Reliability II"): each test names what used to go wrong, on the
//! smallest input that showed it.

use crate::support::examples;

use examples::copy_dir;
use kanedyn::study::Study;
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// A scratch copy of `examples/`, so a study written into it finds the example mechanisms by
/// relative path; removed when dropped.
struct Scratch(TempDir);

impl Scratch {
    fn new(tag: &str) -> Self {
        let root = crate::support::scratch(&format!("rel2-{tag}"));
        copy_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"), root.path());
        Scratch(root)
    }
    /// Writes `bad.ron` (or another file) into the scratch folder and returns its path.
    fn write(&self, file: &str, text: &str) -> PathBuf {
        let p = self.0.path().join(file);
        std::fs::write(&p, text).unwrap();
        p
    }
    /// The load error of a study text, as printed.
    fn load_error(&self, text: &str) -> String {
        match Study::from_file(&self.write("bad.ron", text)) {
            Ok(_) => panic!("expected an error for\n{text}"),
            Err(e) => e.to_string(),
        }
    }
}

/// Asserts an error names `bad.ron` with a line:column and the field.
fn assert_located(e: &str, field: &str) {
    let after = e.split("bad.ron:").nth(1).unwrap_or_else(|| panic!("no file in: {e}"));
    let lc: Vec<&str> = after.split([' ', '(']).next().unwrap_or("").split(':').collect();
    assert!(lc.len() >= 2 && lc[0].parse::<usize>().is_ok() && lc[1].parse::<usize>().is_ok(), "no line:col in: {e}");
    assert!(e.contains(&format!("(field `{field}`)")), "field `{field}` not named in: {e}");
}

/// A study of `analyses` on the circle-path absorber of examples/paths.
fn circle_study(analyses: &str) -> String {
    format!(
        "Study(\n    name: \"s\",\n    mechanism: \"paths/circle.ron\",\n    analyses: [\n        {analyses}\n    ],\n)\n"
    )
}

const FREE: &str = r#"FreeOscillation(name: "free", rpm: 1000.0, joint: "path", amplitudes: [0.005])"#;

// ---- Item 4: output names unique ----

/// Used to run and exit 0 while two analyses wrote `c_a_free.csv` (and `c_a_free.svg`): the
/// comparison `c`'s analysis `free` on mechanism `a` runs as `c_a_free`, the name of the
/// top-level analysis after it, and the later file replaced the earlier one, listed twice.
#[test]
fn a_comparison_and_an_analysis_writing_one_file_are_refused_naming_both() {
    let s = Scratch::new("names");
    let compare =
        format!(r#"Compare(name: "c", mechanisms: [(label: "a", mechanism: "paths/circle.ron")], analyses: [{FREE}])"#);
    let top = FREE.replace("\"free\"", "\"c_a_free\"");
    let e = s.load_error(&circle_study(&format!("{compare},\n        {top}")));
    assert_located(&e, "analyses[1].name");
    for part in
        ["`c_a_free.csv`", "FreeOscillation `c_a_free` (analyses[1])", "Compare `c` (analyses[0])", "mechanism `a`"]
    {
        assert!(e.contains(part), "{part:?} not in: {e}");
    }
    // The same two in the other order: the error is at the comparison's label.
    let e = s.load_error(&circle_study(&format!("{top},\n        {compare}")));
    assert_located(&e, "analyses[1].mechanisms[0].label");
    assert!(e.contains("FreeOscillation `c_a_free` (analyses[0])"), "{e}");
}

/// A comparison runs the kinds that take one mechanism at a time; the refusal of another kind
/// lists them from the registry (each kind says whether it is comparable), so a new comparable
/// analysis appears in the message without editing the comparison.
#[test]
fn a_comparison_refuses_a_campbell_and_lists_the_kinds_it_runs() {
    let s = Scratch::new("compare_kinds");
    let campbell = r#"Campbell(name: "k", rpm_min: 0.0, rpm_max: 100.0)"#;
    let compare = format!(
        r#"Compare(name: "c", mechanisms: [(label: "a", mechanism: "paths/circle.ron")], analyses: [{campbell}])"#
    );
    let e = s.load_error(&circle_study(&compare));
    assert_located(&e, "analyses[0].analyses[0]");
    let expected = "a comparison runs OrderSweep, MultiOrder, LinearResponse, HarmonicBalance, Transient, \
                    FreeOscillation analyses, not Campbell";
    assert!(e.contains(expected), "{e}");
}

/// A sweep's run files carry its amplitude and direction: a Campbell diagram named like one of
/// them used to overwrite that run's traces. Names that only share a prefix still load.
#[test]
fn a_run_file_of_a_sweep_cannot_be_overwritten_by_another_analysis() {
    let s = Scratch::new("sweepnames");
    let sweep = r#"OrderSweep(name: "sw", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 20.0, amplitudes: [40.0, 1e-4])"#;
    let campbell = |name: &str| format!(r#"Campbell(name: "{name}", rpm_min: 0.0, rpm_max: 2000.0, points: 5)"#);
    let e = s.load_error(&circle_study(&format!("{sweep},\n        {}", campbell("sw_1e-4Nm_down"))));
    assert_located(&e, "analyses[1].name");
    assert!(e.contains("`sw_1e-4Nm_down.csv`") && e.contains("OrderSweep `sw` (analyses[0])"), "{e}");
    for name in ["sw_fine", "sw_40Nm", "sw_40Nm_sideways"] {
        let p = s.write("ok.ron", &circle_study(&format!("{sweep},\n        {}", campbell(name))));
        Study::from_file(&p).unwrap_or_else(|e| panic!("`{name}` should load: {e}"));
    }
    // Two mechanisms of one comparison whose labels make the same run name.
    let e = s.load_error(&circle_study(&format!(
        r#"Compare(name: "c", mechanisms: [(label: "a_b", mechanism: "paths/circle.ron"), (label: "a", mechanism: "paths/circle.ron")],
                   analyses: [{}, {}])"#,
        FREE.replace("\"free\"", "\"x\""),
        FREE.replace("\"free\"", "\"b_x\"")
    )));
    assert_located(&e, "analyses[0].mechanisms[1].label");
    assert!(e.contains("`c_a_b_x.csv`"), "{e}");
}

// ---- Item 1: physical ranges ----

/// A two-body mechanism: a rotor and, on joint `j` (kind and extras given), a second body; and
/// `extra` at the end (gears).
fn mechanism(joint: &str, extra: &str) -> String {
    format!(
        r#"Mechanism(
    name: "m",
    bodies: [
        Body(name: "rotor", mass: 110.0, inertia: 3.4),
        Body(name: "b", mass: 6.0, inertia: 0.0002),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor"),
        Joint(name: "j", parent: "rotor", child: "b", {joint}),
    ],
    {extra}
)
"#
    )
}

/// The error of loading mechanism text `text` as `bad.ron`.
fn mechanism_error(s: &Scratch, text: &str) -> String {
    match kanedyn::model::mechanism::Mechanism::from_file(&s.write("bad.ron", text)) {
        Ok(_) => panic!("expected an error for\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Each used to be accepted: "finite and positive" (or "non-zero") was the only rule, so a gear
/// ratio of 1e-300 passed and a 31-point linear response on it never finished; an epicycloid
/// order of 1e9, a bifilar length of 1e-300, a billion rollers and a friction smoothing of
/// 1e-300 went through without a word, and so did a shaft damper of 1e9 N·m·s/rad (a 2 s
/// transient planned at 0.01 s then ran for minutes). Now each is a located error stating the
/// accepted range (for a stiffness or a damping: the time scale it sets on the inertia it moves);
/// the values just inside each range still load.
#[test]
fn extreme_mechanism_values_are_refused_with_the_range() {
    let s = Scratch::new("ranges");
    let epicycloid = |n: &str| format!("kind: Path(shape: Epicycloid(rho0: 0.185, n_tilde: {n}), mount: 0.0)");
    let bifilar = |l: &str| format!("kind: Path(shape: Bifilar(radius: 0.17, length: {l}), mount: 0.0)");
    let rollers = |n: &str| {
        format!(
            "kind: Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.1), mount: 0.0), rollers: Rollers(count: {n}, \
             mass: 0.08, inertia: 1.44e-6, radius: 0.006, spread: 0.03)"
        )
    };
    let friction = |e: &str| format!("friction: (torque: 6.0, smoothing: {e})");
    let gear = |r: &str| {
        mechanism("", &format!("gears: [Gear(joint: \"j\", follows: \"spin\", ratio: {r})],"))
            .replace("child: \"b\", ", "child: \"b\"")
            .replace("Joint(name: \"j\", parent: \"rotor\"", "Joint(name: \"j\", parent: \"ground\"")
    };
    let cases: Vec<(String, String, &str, &str)> = vec![
        (gear("1e-300"), gear("1e-6"), "gears[0].ratio", "1e-6..=1e6"),
        (gear("-2e6"), gear("-1e6"), "gears[0].ratio", "1e-6..=1e6"),
        (mechanism(&epicycloid("1e9"), ""), mechanism(&epicycloid("1000.0"), ""), "n_tilde", "1e-3..=1e3"),
        (mechanism(&bifilar("1e-300"), ""), mechanism(&bifilar("1e-6"), ""), "length", "1e-6..=1e3"),
        (mechanism(&rollers("1000000000"), ""), mechanism(&rollers("100"), ""), "count", "1 to 100 rollers"),
        (mechanism(&friction("1e-300"), ""), mechanism(&friction("1e-6"), ""), "smoothing", "1e-6..=1e3"),
        // Joint `j` carries body `b` (0.0002 kg·m²) on the rotor: the compliance it meets is
        // ≈ 1/0.0002 = 5000 1/(kg·m²), so a decay rate of 1e8 1/s allows c ≈ 2e4 N·m·s/rad
        // and a natural frequency of 1 MHz allows k ≈ 7.9e9 N·m/rad.
        (mechanism("damper: 1e9", ""), mechanism("damper: 1e3", ""), "joints[1].damper", "up to 1e8 1/s"),
        (
            mechanism("spring: (stiffness: 1e15)", ""),
            mechanism("spring: (stiffness: 1e8)", ""),
            "joints[1].spring.stiffness",
            "up to 1e6 Hz",
        ),
        (
            mechanism("stops: (lower: -1.0, upper: 1.0, stiffness: 1e5, damping: 1e12)", ""),
            mechanism("stops: (lower: -1.0, upper: 1.0, stiffness: 1e5, damping: 1e2)", ""),
            "joints[1].stops.damping",
            "up to 1e8 1/s",
        ),
        (
            gear("2.0, mesh: (stiffness: 1e18, damping: 0.0)"),
            gear("2.0, mesh: (stiffness: 1e6, damping: 0.0)"),
            "gears[0].mesh.stiffness",
            "up to 1e6 Hz",
        ),
        (
            mechanism("", "loads: [GroundDamper(body: \"b\", c: 1e10)],"),
            mechanism("", "loads: [GroundDamper(body: \"b\", c: 1e2)],"),
            "loads[0].c",
            "up to 1e8 1/s",
        ),
    ];
    for (bad, good, field, range) in cases {
        let e = mechanism_error(&s, &bad);
        println!("{e}");
        let after = e.split("bad.ron:").nth(1).unwrap_or_else(|| panic!("no file in: {e}"));
        assert!(after.split(':').next().unwrap().parse::<usize>().is_ok(), "no line in: {e}");
        assert!(e.contains("(field `") && e.contains(field), "field {field} not named in: {e}");
        assert!(e.contains(range), "range {range} not stated in: {e}");
        let p = s.write("good.ron", &good);
        kanedyn::model::mechanism::Mechanism::from_file(&p).unwrap_or_else(|e| panic!("should load: {e}\n{good}"));
    }
}

/// One cylinder's pressure table over 0..720° in steps of 10°: the example engine's pulse
/// (1 bar base, 90 bar peak 12° after TDC, 30° wide), plus a drift that grows evenly to `seam`
/// bar at the last point (a transducer's drift): the step across the seam is then `seam`.
fn pressure_table(seam: f64) -> String {
    let points: Vec<String> = (0..72)
        .map(|i| {
            let a = 10.0 * i as f64;
            let d = if a > 360.0 { a - 720.0 } else { a };
            let p = 1.0 + 89.0 * (-0.5 * ((d - 12.0) / 30.0f64).powi(2)).exp() + seam * a / 710.0;
            format!("({a:.1}, {p:.6})")
        })
        .collect();
    format!(
        "Engine(name: \"e\", bore_m: 0.11, stroke_m: 0.12, rod_m: 0.2, reciprocating_mass_kg: 1.6, firing_order: [1],\n\
         pressure: Table([\n{}\n]))\n",
        points.join(",\n")
    )
}

/// Used to pass silently: a table with an 80-bar step across the 720° → 0° seam, closed by the
/// periodic spline with a swing nobody measured. Now the error names the table's last point and
/// says the table is not periodic; the same table without the step loads.
#[test]
fn a_pressure_table_that_does_not_close_is_refused() {
    let s = Scratch::new("seam");
    std::fs::create_dir_all(s.0.path().join("engines")).unwrap();
    let study = |engine: &str| {
        format!(
            "Study(name: \"s\", mechanism: \"cpva.ron\", analyses: [MultiOrder(name: \"m\", order: 3.0, \
             engine: \"engines/{engine}\", speeds: [(rpm: 1000.0)], time_domain: false, linear: true)])\n"
        )
    };
    s.write("engines/seam.ron", &pressure_table(80.0));
    s.write("engines/closed.ron", &pressure_table(0.0));
    let e = s.load_error(&study("seam.ron"));
    println!("{e}");
    assert!(e.contains("seam.ron:") && e.contains("(field `pressure[71]`)"), "{e}");
    // At the last point's own line (the table has one point a line, from line 3).
    assert!(e.contains("seam.ron:74:"), "{e}");
    assert!(e.contains("not periodic across the 720° → 0° seam"), "{e}");
    let p = s.write("ok.ron", &study("closed.ron"));
    Study::from_file(&p).unwrap_or_else(|e| panic!("the closed table should load: {e}"));
}

// ---- Item 2: the watchdog ----

/// An analysis that runs far past its plan used to run on as long as it liked (a stiff 2 s
/// transient planned at 0.01 s ran past 11 s), holding up the whole study. Now each analysis
/// gets `factor × plan + floor` of wall time: past that its time runs stop with a located
/// Failures entry, and the analyses before and after it keep their results. Here the watchdog
/// is set tight (no multiple of the plan, 0.3 s) so that a transient of 5000 s overruns it.
#[test]
fn the_watchdog_stops_an_overrunning_analysis_and_keeps_the_others() {
    use kanedyn::study::{Limits, Watchdog};
    use kanedyn::study::{LoadOptions, RunOptions, run};
    let s = Scratch::new("watchdog");
    let text = r#"Study(
    name: "w",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        Campbell(name: "before", rpm_min: 0.0, rpm_max: 2000.0, points: 5),
        Transient(name: "long", duration_s: 5000.0, speed: Free(rpm: 1000.0), angles: [("pivot", 0.3)],
                  write_time_series: false),
        LinearResponse(name: "after", rpm: 1000.0, from: 0.9, to: 1.1, points: 11),
    ],
)
"#;
    let path = s.write("w.ron", text);
    let limits = Limits { watchdog: Watchdog { factor: 0.0, floor_s: 0.3 }, ..Limits::default() };
    let study = Study::from_file_with(&path, &LoadOptions { limits, ..LoadOptions::default() }).unwrap();
    let planned = study.plan().analyses[1].cpu_s;
    let start = std::time::Instant::now();
    let report = run(&study, &RunOptions { out: Some(s.0.path().join("out")), progress: false }).unwrap();
    let took = start.elapsed().as_secs_f64();
    println!("transient planned at {planned:.2} s CPU; study stopped after {took:.2} s; {:?}", report.failures);
    // The transient alone is planned at several seconds; stopped at 0.3 s the study ends well
    // before that even on a loaded machine.
    assert!(planned > 3.0, "the transient should be planned long, got {planned} s");
    assert!(took < planned, "the watchdog did not stop the transient: {took} s");
    assert_eq!(report.failures.len(), 1, "{:?}", report.failures);
    let f = &report.failures[0];
    assert!(f.starts_with("Transient `long` (") && f.contains("w.ron:7:9"), "{f}");
    assert!(f.contains("stopped by the watchdog") && f.contains("time budget of 0.3 s"), "{f}");
    let dir = s.0.path().join("out").join("w");
    for file in ["before.csv", "before.svg", "after_as_built.csv", "after.svg", "summary.md"] {
        assert!(dir.join(file).exists(), "{file} missing");
    }
}

/// The watchdog used to reach only time runs: a Campbell diagram of many speeds, a linear
/// response of many orders and a harmonic-balance branch at a tiny step ran to the end
/// whatever their budget. Now each stops at its next speed, chunk of orders or branch point
/// past the deadline, with a Failures entry saying where it got to; the analysis after them
/// still runs. The watchdog is set tight (no multiple of the plan, 0.3 s of wall time), and each
/// of the three is planned at seconds.
#[test]
fn the_watchdog_stops_campbell_linear_response_and_harmonic_balance() {
    use kanedyn::study::{Limits, Watchdog};
    use kanedyn::study::{LoadOptions, RunOptions, run};
    let s = Scratch::new("watchdog_lin");
    let text = r#"Study(
    name: "w",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 400000),
        LinearResponse(name: "lin", rpm: 1000.0, from: 0.5, to: 5.0, points: 1000000),
        HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [500.0],
                        harmonics: 40, max_step: 0.0005),
        LinearResponse(name: "after", rpm: 1000.0, from: 0.9, to: 1.1, points: 11),
    ],
)
"#;
    let path = s.write("w.ron", text);
    let limits = Limits { watchdog: Watchdog { factor: 0.0, floor_s: 0.3 }, ..Limits::default() };
    let study = Study::from_file_with(&path, &LoadOptions { limits, ..LoadOptions::default() }).unwrap();
    let plan = study.plan();
    let planned: Vec<f64> = plan.analyses.iter().map(|a| a.cpu_s).collect();
    let start = std::time::Instant::now();
    let report = run(&study, &RunOptions { out: Some(s.0.path().join("out")), progress: false }).unwrap();
    let took = start.elapsed().as_secs_f64();
    println!("planned {planned:?} s; study took {took:.2} s; {:#?}", report.failures);
    // The linear response of 10⁶ orders takes about 1 s (plan 2.3 s); the others are planned
    // far longer than they take (the harmonic balance bounds a branch by its point cap).
    for (k, p) in planned.iter().enumerate().take(3) {
        assert!(*p > 1.0, "analysis {k} should be planned long, got {p} s");
    }
    // Three stops at 0.3 s each, plus the setup of each and the last small analysis: far below
    // the ~planned total even on a loaded machine.
    assert!(took < 0.5 * planned[..3].iter().sum::<f64>(), "the watchdog did not stop them: {took} s");
    let named = |kind: &str, name: &str, line: usize| {
        report
            .failures
            .iter()
            .find(|f| f.starts_with(&format!("{kind} `{name}` (")))
            .filter(|f| f.contains(&format!("w.ron:{line}:9")) && f.contains("watchdog") && f.contains("0.3 s"))
            .unwrap_or_else(|| panic!("no located watchdog failure for {name}: {:?}", report.failures))
            .clone()
    };
    assert!(named("Campbell", "camp", 6).contains("rpm after"));
    assert!(named("LinearResponse", "lin", 7).contains("order"));
    assert!(named("HarmonicBalance", "hbm", 8).contains("stopped by the watchdog at order"));
    let dir = s.0.path().join("out").join("w");
    for file in ["after_as_built.csv", "after.svg", "summary.md"] {
        assert!(dir.join(file).exists(), "{file} missing");
    }
}

/// A harmonic-balance branch that stops short of its range (here at its 2000-point cap, with a
/// step of 1e-5 over an order range of 0.4) used to be only a note under the summary's table:
/// the run exited 0 although the fold the user asked about may lie beyond. Now it is also a
/// Failures entry naming the analysis, its place in the file, the reason and the order reached;
/// its points are kept. (A branch that stalls at the end of an absorber's path stays a note:
/// that is the mechanism's limit, `cpva_paths::the_path_comparison_example…`.)
#[test]
fn a_branch_stopped_short_of_its_range_is_a_located_failure() {
    use kanedyn::study::{RunOptions, run};
    let s = Scratch::new("stalled");
    let text = r#"Study(
    name: "st",
    mechanism: "cpva.ron",
    lock: ["pivot"],
    analyses: [
        HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0],
                        harmonics: 4, max_step: 0.00001),
    ],
)
"#;
    let study = Study::from_file(&s.write("st.ron", text)).unwrap();
    let report = run(&study, &RunOptions { out: Some(s.0.path().join("out")), progress: false }).unwrap();
    println!("{:#?}", report.failures);
    assert_eq!(report.failures.len(), 2, "{:?}", report.failures);
    for (f, from) in report.failures.iter().zip(["3.3", "2.9"]) {
        assert!(f.starts_with("HarmonicBalance `hbm` (") && f.contains("st.ron:6:9"), "{f}");
        assert!(
            f.contains(&format!("continued from {from}: stopped because it reached the largest number of points")),
            "{f}"
        );
        assert!(f.contains("at order = ") && f.contains("after 2000 points"), "{f}");
    }
    assert_eq!(report.hbm.len(), 2);
    assert!(report.hbm.iter().all(|b| b.order.len() == 2000));
}

// ---- Locations ----

/// A second run into a folder another run holds used to be refused as "mechanism ``: output
/// folder … is being written …", a mechanism error with an empty name. Now the message leads
/// with the folder.
#[test]
fn a_busy_output_folder_is_named() {
    use kanedyn::study::{RunOptions, run};
    let s = Scratch::new("busy");
    let path = s.write("b.ron", &circle_study(FREE).replace("name: \"s\"", "name: \"b\""));
    let study = Study::from_file(&path).unwrap();
    let out = s.0.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    let lock = std::fs::OpenOptions::new().create(true).truncate(false).write(true).open(out.join(".b.lock")).unwrap();
    lock.lock().unwrap();
    let e = match run(&study, &RunOptions { out: Some(out.clone()), progress: false }) {
        Ok(_) => panic!("a run into a locked folder should be refused"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.starts_with(&format!(
            "{}: output folder busy: it is being written by another kanedyn run",
            out.join("b").display()
        )),
        "{e}"
    );
    assert!(!e.contains("mechanism ``"), "{e}");
}

/// A study whose mechanism or engine is a folder, a pipe or a file over the size cap used to be
/// refused naming that file only, not the study field that named it. Now the error is located
/// at the field and still names the file and why.
#[test]
fn a_refused_input_file_is_located_at_the_field_that_names_it() {
    let s = Scratch::new("wholefile");
    std::fs::create_dir_all(s.0.path().join("adir")).unwrap();
    s.write("big.ron", &" ".repeat(2_000_000));
    for (file, why) in [("adir", "not a regular file (a folder)"), ("big.ron", "more than the limit")] {
        let e = s.load_error(&format!(
            "Study(name: \"x\", mechanism: \"{file}\", analyses: [Campbell(name: \"c\", rpm_min: 0.0, rpm_max: 100.0, points: 3)])\n"
        ));
        assert_located(&e, "mechanism");
        assert!(e.contains(&format!("{file}: ")) && e.contains(why), "{e}");
        let e = s.load_error(&format!(
            "Study(name: \"x\", mechanism: \"cpva.ron\", analyses: [MultiOrder(name: \"m\", order: 3.0, engine: \"{file}\", \
             speeds: [(rpm: 1000.0)], time_domain: false, linear: true)])\n"
        ));
        assert_located(&e, "analyses[0].engine");
        assert!(e.contains(why), "{e}");
    }
}

/// A light hub (J₁) driving a heavy rotor (J₂) through a shaft joint: whatever the generalized
/// speeds, the shaft coordinate meets the compliance `1/J₁ + 1/J₂` (the coordinates' mass matrix
/// is `[[J₁ + J₂, J₂], [J₂, J₂]]`, whose inverse has that corner), and the spin coordinate `1/J₁`.
/// With absolute angular velocities the loader's range check and the study's plan used to read
/// the speeds' mass matrix instead, `1/J₂` for the rotor's own rotation: a shaft damper 20 times
/// past the decay-rate limit loaded, and a stiff-shaft transient ran 4.6 times its plan.
#[test]
fn shaft_compliance_does_not_depend_on_the_generalized_speeds() {
    let s = Scratch::new("shaft-compliance");
    let (j1, j2) = (1.0e-3, 10.0);
    let shaft = |speeds: &str, damper: &str| {
        format!(
            r#"Mechanism(
    name: "m",
    speeds: {speeds},
    bodies: [Body(name: "hub", mass: 1.0, inertia: {j1:e}), Body(name: "rotor", mass: 50.0, inertia: {j2:e})],
    joints: [
        Joint(name: "spin", parent: "ground", child: "hub"),
        Joint(name: "shaft", parent: "hub", child: "rotor", spring: (stiffness: 1.0e4), damper: {damper}),
    ],
)
"#
        )
    };
    for speeds in ["JointRates", "AbsoluteAngularVelocities"] {
        let mech =
            kanedyn::model::mechanism::Mechanism::from_file(&s.write("good.ron", &shaft(speeds, "1.0"))).unwrap();
        let mut kane = kanedyn::kane::Kane::new(&mech).unwrap();
        let m = kane.mass_matrix(&[0.0, 0.0]).clone();
        let c = kanedyn::model::time_scales::compliances(&mech, &m).unwrap();
        // A Cholesky solve loses about its condition number in ulps: cond ≈ 4·J₂/J₁ = 4e4 on this
        // matrix, so ~1e-11 relative.
        let rel = |a: f64, b: f64| (a - b).abs() / b;
        assert!(rel(c[0], 1.0 / j1) < 1e-10, "{speeds}: spin compliance {} vs {}", c[0], 1.0 / j1);
        assert!(
            rel(c[1], 1.0 / j1 + 1.0 / j2) < 1e-10,
            "{speeds}: shaft compliance {} vs {}",
            c[1],
            1.0 / j1 + 1.0 / j2
        );
        // 2e6 N·m·s/rad on 1000.1 1/(kg·m²) decays at 2.0e9 1/s, 20 × the 1e8 limit (on 1/J₂ it
        // would have been 2e5 1/s).
        let e = mechanism_error(&s, &shaft(speeds, "2.0e6"));
        assert!(e.contains("joints[1].damper") && e.contains("up to 1e8 1/s"), "{speeds}: {e}");
    }
}

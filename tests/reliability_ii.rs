//! Regression tests of issue 25 ("Reliability II"): each test names what used to go wrong, on the
//! smallest input that showed it.

use kanedyn::study::Study;
use std::path::{Path, PathBuf};

/// A scratch copy of `examples/`, so a study written into it finds the example mechanisms by
/// relative path; removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(tag: &str) -> Self {
        let root = std::env::temp_dir().join(format!("kanedyn_rel2_{tag}_{}", std::process::id()));
        std::fs::remove_dir_all(&root).ok();
        copy_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"), &root);
        Scratch(root)
    }
    /// Writes `bad.ron` (or another file) into the scratch folder and returns its path.
    fn write(&self, file: &str, text: &str) -> PathBuf {
        let p = self.0.join(file);
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

impl Drop for Scratch {
    fn drop(&mut self) {
        std::fs::remove_dir_all(&self.0).ok();
    }
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
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

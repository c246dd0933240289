//! Issue 54, item 6: the exit code tells a script the class of a failure (the table in
//! docs/guide/src/cli.md), and `--quiet` prints nothing on success. Each class is provoked by the
//! smallest input that belongs to it, through the binary as a script would run it.

use crate::support::examples::copy_cpva;
use crate::support::scratch;
use std::path::Path;
use std::process::{Command, Output};

/// Runs `kanedyn args…` in `dir`.
fn kanedyn(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_kanedyn")).args(args).current_dir(dir).output().unwrap()
}

/// Asserts the exit code, that the error line names `words`, and that nothing panicked.
fn assert_exit(out: &Output, code: i32, words: &[&str]) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    for w in words {
        assert!(stderr.contains(w), "stderr should mention {w:?}: {stderr}");
    }
}

/// A study of the paper's CPVA (copied into the scratch folder) with these analyses.
fn study(dir: &Path, analyses: &str) {
    std::fs::write(
        dir.join("s.ron"),
        format!(r#"Study(name: "s", mechanism: "cpva.ron", lock: ["pivot"], analyses: [{analyses}])"#),
    )
    .unwrap();
}

const LINEAR: &str = r#"LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31)"#;

#[test]
fn usage_errors_exit_2() {
    let tmp = scratch("exit-usage");
    copy_cpva(tmp.path());
    // clap's own: an unknown flag.
    assert_exit(&kanedyn(tmp.path(), &["check", "cpva.ron", "--no-such-flag"]), 2, &["--no-such-flag"]);
    // Ours: values that parse but cannot be used (2 degrees of freedom, one value given).
    assert_exit(&kanedyn(tmp.path(), &["eom", "cpva.ron", "--q", "0", "--u", "0,0"]), 2, &["--q needs 2"]);
    assert_exit(&kanedyn(tmp.path(), &["check", "cpva.ron", "--max-memory-mb=0"]), 2, &["--max-memory-mb"]);
}

#[test]
fn input_errors_exit_3() {
    let tmp = scratch("exit-input");
    copy_cpva(tmp.path());
    let text = std::fs::read_to_string(tmp.path().join("cpva.ron")).unwrap();
    std::fs::write(tmp.path().join("bad.ron"), text.replacen("bodies", "bodys", 1)).unwrap();
    assert_exit(&kanedyn(tmp.path(), &["check", "bad.ron"]), 3, &["bad.ron:", "bodys"]);
    // A study's semantic error, located in the study file.
    study(tmp.path(), &LINEAR.replace("points: 31", "points: 1"));
    assert_exit(&kanedyn(tmp.path(), &["run", "s.ron", "--out", "out"]), 3, &["s.ron:", "analyses[0].points"]);
}

#[test]
fn limit_errors_exit_4() {
    let tmp = scratch("exit-limit");
    copy_cpva(tmp.path());
    // The file-size cap: cpva.ron is over 1 kB.
    assert!(std::fs::metadata(tmp.path().join("cpva.ron")).unwrap().len() > 1024);
    assert_exit(&kanedyn(tmp.path(), &["check", "cpva.ron", "--max-file-kb", "1"]), 4, &["--max-file-kb"]);
    // A study's estimated memory.
    study(tmp.path(), LINEAR);
    let out = kanedyn(tmp.path(), &["run", "s.ron", "--out", "out", "--max-memory-mb", "0.0001"]);
    assert_exit(&out, 4, &["s.ron:", "--max-memory-mb"]);
    assert!(!tmp.path().join("out").join("s").exists(), "a refused study writes nothing");
}

#[test]
fn operating_system_errors_exit_5() {
    let tmp = scratch("exit-os");
    copy_cpva(tmp.path());
    assert_exit(&kanedyn(tmp.path(), &["check", "missing.ron"]), 5, &["missing.ron"]);
    // The output root is a regular file: no folder can be made in it.
    study(tmp.path(), LINEAR);
    std::fs::write(tmp.path().join("taken"), "").unwrap();
    assert_exit(&kanedyn(tmp.path(), &["run", "s.ron", "--out", "taken"]), 5, &["taken"]);
}

/// The harmonic balance at 1e6 N·m diverges (tests/it/study_reliability.rs isolates it the same
/// way); the analyses before and after it complete and write their files.
#[test]
fn a_run_with_failed_analyses_exits_6_and_keeps_the_others() {
    let tmp = scratch("exit-failed");
    copy_cpva(tmp.path());
    let hbm = r#"HarmonicBalance(name: "diverges", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6],
                 harmonics: 1, multiples: [1.0])"#;
    study(tmp.path(), &format!("{LINEAR}, {hbm}"));
    let out = kanedyn(tmp.path(), &["run", "s.ron", "--out", "out", "--quiet"]);
    assert_exit(&out, 6, &["failure(s)", "summary.md"]);
    assert!(out.stdout.is_empty(), "{}", String::from_utf8_lossy(&out.stdout));
    assert!(tmp.path().join("out/s/lin_as_built.csv").exists());
}

#[test]
fn quiet_prints_nothing_on_success() {
    let tmp = scratch("exit-quiet");
    copy_cpva(tmp.path());
    study(tmp.path(), LINEAR);
    for args in [
        &["run", "s.ron", "--out", "out", "--quiet", "--threads", "100000"][..],
        &["check", "s.ron", "-q"],
        &["check", "cpva.ron", "--quiet"],
    ] {
        let out = kanedyn(tmp.path(), args);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
        assert!(out.stdout.is_empty() && out.stderr.is_empty(), "{args:?} printed: {out:?}");
    }
    assert!(tmp.path().join("out/s/report.html").exists());
    // Without it, the same run prints its digest, ending with the page's path.
    let out = kanedyn(tmp.path(), &["run", "s.ron", "--out", "out2"]);
    assert!(String::from_utf8_lossy(&out.stdout).trim_end().ends_with("report.html"));
}

//! Issue 49, item 3: a reader that stops early (`kanedyn schema | head -1`, `kanedyn run … |
//! true`) is a normal end of the output, not a crash. Every command used to exit 101 with "failed
//! printing to stdout" and a backtrace. Here each command's standard output is a pipe whose
//! reading end is closed before the command starts, so its first write fails for certain: the
//! command still exits with its own status, says nothing of a panic, and writes its files whole.

use crate::support::examples::copy_cpva;
use crate::support::scratch;
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// Runs `kanedyn args…` in `dir` with its standard output a pipe nobody reads.
fn with_closed_stdout(dir: &Path, args: &[&str]) -> Output {
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    Command::new(env!("CARGO_BIN_EXE_kanedyn"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::from(writer))
        .stderr(Stdio::piped())
        .output()
        .unwrap()
}

fn assert_clean(out: &Output, code: i32, what: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{what}: {stderr}");
    assert!(!stderr.contains("panicked") && !stderr.contains("failed printing"), "{what}: {stderr}");
}

#[test]
fn every_command_ends_normally_when_its_reader_has_gone() {
    let tmp = scratch("broken-pipe");
    let dir = tmp.path();
    copy_cpva(dir);
    std::fs::write(
        dir.join("s.ron"),
        r#"Study(name: "s", mechanism: "cpva.ron", lock: ["pivot"], analyses: [
            LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31)])"#,
    )
    .unwrap();
    std::fs::write(dir.join("t.json"), r#"{"shafts": [{"nl": 0, "nr": 1, "k": 4.0e4}], "disks": [{"node": 0, "inertia": 2.5}, {"node": 1, "inertia": 4.0}]}"#)
        .unwrap();
    assert_clean(&with_closed_stdout(dir, &["schema"]), 0, "schema");
    assert_clean(&with_closed_stdout(dir, &["check", "cpva.ron"]), 0, "check of a mechanism");
    assert_clean(&with_closed_stdout(dir, &["check", "s.ron"]), 0, "check of a study");
    assert_clean(&with_closed_stdout(dir, &["eom", "cpva.ron", "--q", "0,0", "--u", "0,0"]), 0, "eom");
    assert_clean(&with_closed_stdout(dir, &["import", "t.json"]), 0, "import");
    // A command's own failure keeps its status (5: the file cannot be read) and its message.
    let out = with_closed_stdout(dir, &["check", "missing.ron"]);
    assert_clean(&out, 5, "check of a missing file");
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.ron"));

    // A run finishes its work: every file written and whole, as with a reader.
    assert_clean(&with_closed_stdout(dir, &["run", "s.ron", "--out", "out"]), 0, "run");
    let report = std::fs::read_to_string(dir.join("out/s/report.html")).unwrap();
    assert!(report.trim_end().ends_with("</html>"));
    let summary = std::fs::read_to_string(dir.join("out/s/summary.md")).unwrap();
    assert!(summary.contains("lin"), "{summary}");
    let csv = std::fs::read_to_string(dir.join("out/s/lin_as_built.csv")).unwrap();
    assert_eq!(csv.lines().count(), 32, "header and 31 orders");
}

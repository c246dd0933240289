//! `kanedyn run` prints a digest, not the summary's tables: at most 25 lines with the status,
//! one line of findings per analysis, the failures with their place in the study file, and as
//! the last line the path of report.html. `--verbose` also prints the tables.

use crate::support::cli::kanedyn;
use crate::support::examples::copy_cpva;
use crate::support::scratch;
use std::path::{Path, PathBuf};

/// The digest's line budget (issue 31: a screenful, ending with the report's path).
const MAX_LINES: usize = 25;

/// Runs `kanedyn run study --out out extra…`: (success, stdout lines, stderr).
fn run(study: &Path, out: &Path, extra: &[&str]) -> (bool, Vec<String>, String) {
    let mut args = vec!["run", study.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend(extra);
    let (ok, stdout, stderr) = kanedyn(&args);
    (ok, stdout.lines().map(str::to_string).collect(), stderr)
}

#[test]
fn the_paper_study_prints_a_digest_ending_with_the_report_path() {
    let tmp = scratch("digest-paper");
    let out = tmp.path().to_path_buf();
    let (ok, lines, err) = run(Path::new("examples/cpva_paper.ron"), &out, &[]);
    assert!(ok, "{err}");
    assert!(lines.len() <= MAX_LINES, "{} lines:\n{}", lines.len(), lines.join("\n"));
    let page = PathBuf::from(lines.last().unwrap());
    assert_eq!(page, out.join("cpva_paper").join("report.html"));
    assert!(page.is_file(), "{page:?} does not exist");
    assert!(lines[0].starts_with("Study `cpva_paper`") && lines[0].contains("5 analyses, all complete"), "{lines:?}");
    // One line of findings per analysis, read off the results (the numbers of summary.md).
    let summary = std::fs::read_to_string(out.join("cpva_paper/summary.md")).unwrap();
    let line_of = |prefix: &str| lines.iter().find(|l| l.trim_start().starts_with(prefix)).cloned().unwrap_or_default();
    assert!(line_of("OrderSweep `sweep`:").contains("6 runs"), "{lines:?}");
    assert!(line_of("MultiOrder `multi_order`:").contains("7 speeds, 600–1800 rpm"), "{lines:?}");
    let linear = line_of("LinearResponse `figure2`:");
    assert!(linear.contains("n_t = 3.11") && linear.contains("0.01912"), "{linear}");
    assert!(summary.contains("| c_p = 5e-4 | 0.01912 |"), "the digest's smallest ratio is the summary's");
    assert_eq!(
        line_of("Campbell `campbell`:"),
        "  Campbell `campbell`: 1 mode, 0–2000 rpm; no order line crosses a mode"
    );
    assert!(summary.contains("No order line crosses a mode between 0 and 2000 rpm."));
    let hbm = line_of("HarmonicBalance `hbm`:");
    // 59 + 59 + 16 + 21 points, folds 2 + 2 + 0 + 1, as in the summary's branch table.
    assert!(hbm.contains("4 branches, 155 points (114 stable, 41 unstable), 5 folds"), "{hbm}");
    // No table reaches the terminal by default.
    assert!(!lines.iter().any(|l| l.starts_with('|')), "{lines:?}");
}

#[test]
fn verbose_prints_the_summary_tables_before_the_digest() {
    let tmp = scratch("digest-verbose");
    let out = tmp.path().to_path_buf();
    let (ok, lines, err) = run(Path::new("examples/cpva_paper.ron"), &out, &["--verbose"]);
    assert!(ok, "{err}");
    let summary = std::fs::read_to_string(out.join("cpva_paper/summary.md")).unwrap();
    let header = "| run | max abs relative angle (rad) | main-order minimum at n |";
    assert!(summary.contains(header));
    assert!(lines.iter().any(|l| l.starts_with(header)), "no sweep table in --verbose output");
    // Every line of the summary is printed, and the digest still ends the output.
    let printed = lines.join("\n");
    assert!(printed.contains(summary.trim_end()), "the summary is not printed whole");
    assert!(lines.len() > 100, "{} lines", lines.len());
    assert_eq!(PathBuf::from(lines.last().unwrap()), out.join("cpva_paper/report.html"));
}

#[test]
fn a_failing_analysis_is_in_the_digest_with_its_place_in_the_file() {
    let tmp = scratch("digest-failure");
    let dir = tmp.path().to_path_buf();
    copy_cpva(&dir);
    let study = dir.join("iso.ron");
    std::fs::write(
        &study,
        r#"Study(
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
"#,
    )
    .unwrap();
    let out = dir.join("out");
    let (ok, lines, err) = run(&study, &out, &[]);
    assert!(!ok, "a failure must fail the command");
    assert!(err.contains("1 failure(s)"), "{err}");
    assert!(lines.len() <= MAX_LINES, "{lines:?}");
    assert!(lines[0].contains("PARTIAL RESULTS: 1 failure in 1 of 3 analyses"), "{lines:?}");
    // Its branch from below diverges; the one from above is kept, so the analysis is partial.
    let hbm = lines.iter().find(|l| l.starts_with("  HarmonicBalance `diverges`: ")).expect("its line");
    assert!(hbm.ends_with("[partial: 1 failure]"), "{hbm}");
    let failures = lines.iter().position(|l| l == "Failures (1):").expect("a Failures block");
    let failure = &lines[failures + 1];
    assert!(failure.starts_with("  - HarmonicBalance `diverges` (") && failure.contains("iso.ron:7:9"), "{failure}");
    // The analyses around it keep their findings lines.
    assert!(lines.iter().any(|l| l.starts_with("  LinearResponse `before`: 1 variant")), "{lines:?}");
    assert!(lines.iter().any(|l| l.starts_with("  Campbell `after`: 1 mode")), "{lines:?}");
    let page = PathBuf::from(lines.last().unwrap());
    assert!(page.ends_with("iso/report.html") && page.is_file(), "{page:?}");
}

#[test]
fn more_analyses_than_fit_are_folded_into_one_line() {
    let tmp = scratch("digest-fold");
    let dir = tmp.path().to_path_buf();
    copy_cpva(&dir);
    let campbells: Vec<String> = (0..40)
        .map(|k| format!("        Campbell(name: \"c{k}\", rpm_min: 0.0, rpm_max: 2000.0, points: 3),"))
        .collect();
    let study = dir.join("many.ron");
    std::fs::write(
        &study,
        format!(
            "Study(\n    name: \"many\",\n    mechanism: \"cpva.ron\",\n    analyses: [\n{}\n    ],\n)\n",
            campbells.join("\n")
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let (ok, lines, err) = run(&study, &out, &[]);
    assert!(ok, "{err}");
    assert_eq!(lines.len(), MAX_LINES, "{lines:?}");
    assert!(lines[0].contains("40 analyses, all complete"), "{lines:?}");
    // Status, 21 analyses, the fold, the summary's path, the page: 25.
    let shown = lines.iter().filter(|l| l.starts_with("  Campbell `c")).count();
    assert_eq!(shown, 21, "{lines:?}");
    assert!(lines.contains(&"  … and 19 more analyses: see summary.md".to_string()), "{lines:?}");
    assert!(PathBuf::from(lines.last().unwrap()).is_file());
}

#[test]
fn many_failures_are_cut_to_a_few_lines_and_counted() {
    let tmp = scratch("digest-failures");
    let dir = tmp.path().to_path_buf();
    copy_cpva(&dir);
    // Each harmonic balance diverges from its lower end: one failure per analysis.
    let diverging: Vec<String> = (0..8)
        .map(|k| {
            format!(
                "        HarmonicBalance(name: \"d{k}\", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6], \
                 harmonics: 1, multiples: [1.0]),"
            )
        })
        .collect();
    let study = dir.join("many_failures.ron");
    std::fs::write(
        &study,
        format!(
            "Study(\n    name: \"mf\",\n    mechanism: \"cpva.ron\",\n    lock: [\"pivot\"],\n    analyses: [\n{}\n    ],\n)\n",
            diverging.join("\n")
        ),
    )
    .unwrap();
    let out = dir.join("out");
    let (ok, lines, _) = run(&study, &out, &[]);
    assert!(!ok);
    assert!(lines.len() <= MAX_LINES, "{lines:?}");
    assert!(lines[0].contains("PARTIAL RESULTS: 8 failures in 8 of 8 analyses"), "{lines:?}");
    let at = lines.iter().position(|l| l == "Failures (8):").expect("a Failures block");
    // Four listed, each on one line with its place in the file, then the count of the rest.
    for (k, line) in lines[at + 1..at + 5].iter().enumerate() {
        let place = format!("many_failures.ron:{}:", 6 + k);
        assert!(line.starts_with(&format!("  - HarmonicBalance `d{k}` (")) && line.contains(&place), "{line}");
    }
    assert_eq!(lines[at + 5], "  … and 4 more failures: see summary.md");
    assert!(PathBuf::from(lines.last().unwrap()).ends_with("mf/report.html"));
}

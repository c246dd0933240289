//! `report.html`: one self-contained page per study run (issue 13): the summary's tables, every
//! figure inline, links to the data files, failures first. Checked on the page's text against
//! what the run wrote; that a browser renders it is left to a headless-browser check.

use kanedyn::study::{RunOptions, Study, run};
use std::path::{Path, PathBuf};

fn copy_examples(dir: &Path) {
    for sub in ["bodies", "joints"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
        for e in std::fs::read_dir(Path::new("examples").join(sub)).unwrap().flatten() {
            std::fs::copy(e.path(), dir.join(sub).join(e.file_name())).unwrap();
        }
    }
    std::fs::copy("examples/cpva.ron", dir.join("cpva.ron")).unwrap();
}

fn run_study(tag: &str, analyses: &str) -> (kanedyn::study::StudyReport, String, PathBuf) {
    let dir = std::env::temp_dir().join(format!("kanedyn_report_{tag}_{}", std::process::id()));
    copy_examples(&dir);
    let file = dir.join("s.ron");
    std::fs::write(
        &file,
        format!("Study(name: \"s\", mechanism: \"cpva.ron\", lock: [\"pivot\"], analyses: [{analyses}])"),
    )
    .unwrap();
    let study = Study::from_file(&file).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    let page =
        report.files.iter().find(|f| f.file_name().is_some_and(|n| n == "report.html")).expect("report.html written");
    let html = std::fs::read_to_string(page).unwrap();
    (report, html, dir)
}

#[test]
fn the_page_holds_every_table_figure_and_file() {
    let (report, html, dir) = run_study(
        "ok",
        r#"LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31),
           Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 11)"#,
    );
    assert!(report.failures.is_empty());
    assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"));
    // Every Markdown table of the summary is an HTML table.
    let md_tables = report.summary.lines().filter(|l| l.starts_with("|---")).count();
    assert_eq!(html.matches("<table>").count(), md_tables);
    // Every figure inline, every data file linked by its name beside the page.
    for f in &report.files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        match f.extension().and_then(|e| e.to_str()) {
            Some("svg") => assert!(html.contains(&format!("<figcaption>{name}</figcaption>")), "{name}"),
            Some("csv") | Some("json") => assert!(html.contains(&format!("<a href=\"{name}\">")), "{name}"),
            _ => {}
        }
    }
    let svgs = report.files.iter().filter(|f| f.extension().is_some_and(|e| e == "svg")).count();
    assert_eq!(html.matches("<svg").count(), svgs);
    // Self-contained: nothing is fetched (the only URLs are the SVG namespace's).
    assert!(!html.contains(" src=") && !html.contains("<link") && !html.contains("<script"));
    assert!(!html.contains("class=\"failures\""));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn failures_come_first() {
    let (report, html, dir) = run_study(
        "fail",
        r#"LinearResponse(name: "before", rpm: 1000.0, from: 0.9, to: 1.1, points: 11),
           HarmonicBalance(name: "diverges", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [1e6],
                           harmonics: 1, multiples: [1.0])"#,
    );
    assert!(!report.failures.is_empty());
    let failures = html.find("class=\"failures\"").expect("a failures section");
    let summary = html.find("<h1>").expect("the summary's heading");
    assert!(failures < summary, "failures before the summary");
    assert!(html.contains("HarmonicBalance `diverges`") || html.contains("HarmonicBalance <code>diverges</code>"));
    std::fs::remove_dir_all(&dir).ok();
}

//! `report.html`: one self-contained page per study run (issue 13): the summary's tables, every
//! figure inline, links to the data files, failures first. Checked on the page's text against
//! what the run wrote; that a browser renders it is left to a headless-browser check.

use crate::support::examples;

use examples::copy_cpva;
use kanedyn::study::{RunOptions, Study, run};
use std::path::PathBuf;

fn run_study(tag: &str, analyses: &str) -> (kanedyn::study::StudyReport, String, PathBuf) {
    let dir = std::env::temp_dir().join(format!("kanedyn_report_{tag}_{}", std::process::id()));
    copy_cpva(&dir);
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

/// `report.html` in a real browser (headless Chromium, Debian's `chromium`): every figure is laid
/// out at a non-zero size and no script error or console error occurs. A small script appended
/// to a copy of the page records both into the DOM, which `--dump-dom` prints after loading.
/// Without Chromium the test says so and passes, unless `KANEDYN_REQUIRE_BROWSER` is set (as
/// `.ci/run` does after installing it).
#[test]
fn the_page_renders_in_a_headless_browser() {
    let browser = ["chromium", "chromium-browser"]
        .into_iter()
        .find(|b| std::process::Command::new(b).arg("--version").output().is_ok_and(|o| o.status.success()));
    let Some(browser) = browser else {
        assert!(
            std::env::var_os("KANEDYN_REQUIRE_BROWSER").is_none(),
            "KANEDYN_REQUIRE_BROWSER is set but no chromium"
        );
        println!("skipped: no chromium on this machine");
        return;
    };
    let (report, html, dir) = run_study(
        "browser",
        r#"LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31),
           Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 11)"#,
    );
    let probe = r#"<script>
var problems = [];
window.addEventListener('error', function (e) { problems.push('error: ' + e.message); });
var original = console.error;
console.error = function () { problems.push('console: ' + Array.prototype.join.call(arguments, ' ')); original.apply(console, arguments); };
window.addEventListener('load', function () {
  var sizes = Array.prototype.map.call(document.querySelectorAll('figure svg'), function (s) {
    var r = s.getBoundingClientRect(); return [r.width, r.height];
  });
  document.body.setAttribute('data-check', JSON.stringify({ sizes: sizes, problems: problems }));
});
</script></body>"#;
    let page = dir.join("probe.html");
    std::fs::write(&page, html.replace("</body>", probe)).unwrap();
    let out = std::process::Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--window-size=1100,900", "--virtual-time-budget=3000"])
        .arg("--dump-dom")
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&out.stdout);
    let start = dom.find("data-check=\"").expect("the probe ran") + "data-check=\"".len();
    let raw = &dom[start..start + dom[start..].find('"').unwrap()];
    let check: serde_json::Value = serde_json::from_str(&raw.replace("&quot;", "\"")).unwrap();
    let sizes = check["sizes"].as_array().unwrap();
    let svgs = report.files.iter().filter(|f| f.extension().is_some_and(|e| e == "svg")).count();
    println!("figures laid out: {sizes:?}; problems: {}", check["problems"]);
    assert_eq!(sizes.len(), svgs, "every figure is in the page");
    for s in sizes {
        assert!(s[0].as_f64().unwrap() > 100.0 && s[1].as_f64().unwrap() > 100.0, "figure size {s}");
    }
    assert_eq!(check["problems"].as_array().unwrap().len(), 0, "{}", check["problems"]);
    std::fs::remove_dir_all(&dir).ok();
}

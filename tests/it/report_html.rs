//! `report.html`: one self-contained page per study run (issues 13 and 31): the summary's
//! tables, each figure inline under its analysis's section with a caption, links to the data
//! files, failures first, long tables folded, zoom and hover on the figures. Checked on the
//! page's text against what the run wrote, and in headless Chromium (rendering, the zoom and
//! hover layer's scripted self-test, the folds).

use crate::support::examples;

use crate::support::scratch;
use examples::copy_cpva;
use kanedyn::study::{RunOptions, Study, run};
use std::path::{Path, PathBuf};
use tempfile::TempDir;

fn run_study(tag: &str, analyses: &str) -> (kanedyn::study::StudyReport, String, TempDir) {
    let tmp = scratch(&format!("report-{tag}"));
    let dir = tmp.path();
    copy_cpva(dir);
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
    (report, html, tmp)
}

#[test]
fn the_page_holds_every_table_figure_and_file() {
    let (report, html, _folder) = run_study(
        "ok",
        r#"LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31),
           Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 11)"#,
    );
    assert!(report.failures.is_empty());
    assert!(html.starts_with("<!DOCTYPE html>") && html.trim_end().ends_with("</html>"));
    // Every Markdown table of the summary is an HTML table.
    let md_tables = report.summary.lines().filter(|l| l.starts_with("|---")).count();
    assert_eq!(html.matches("<table>").count(), md_tables);
    // Every figure inline with its caption and its file's link, every data file linked by its
    // name beside the page.
    for f in &report.files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        match f.extension().and_then(|e| e.to_str()) {
            Some("svg") => {
                let stem = name.trim_end_matches(".svg");
                assert!(html.contains(&format!("<figure class=\"plot\" id=\"figure-{stem}\">")), "{name}");
                assert!(html.contains(&format!("<a class=\"file\" href=\"{name}\">{name}</a></figcaption>")), "{name}");
            }
            Some("csv") | Some("json") => assert!(html.contains(&format!("<a href=\"{name}\">")), "{name}"),
            _ => {}
        }
    }
    let svgs = report.files.iter().filter(|f| f.extension().is_some_and(|e| e == "svg")).count();
    assert_eq!(html.matches("<svg").count(), svgs);
    assert_eq!(html.matches("<figcaption>").count(), svgs);
    // Self-contained: nothing is fetched. One inline script (the zoom and hover layer), no
    // source attribute, no stylesheet link, and every URL is the SVG namespace's.
    assert_eq!(html.matches("<script").count(), 1);
    assert!(html.contains("<script>\n") && !html.contains(" src=") && !html.contains("<link"));
    for (i, _) in html.match_indices("http") {
        assert!(html[i..].starts_with("http://www.w3.org/2000/svg"), "a URL: {}", &html[i..i + 60]);
    }
    assert!(!html.contains("class=\"failures\""));
}

#[test]
fn failures_come_first() {
    let (report, html, _folder) = run_study(
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
}

/// Each analysis has a section of its own that holds its heading, its figures and their
/// captions in words: the Campbell diagram's caption says what the diagram draws, not only its
/// file's name, and no figure of one analysis sits in another's section.
#[test]
fn every_figure_sits_under_its_analysis_with_a_caption() {
    let (report, html, _folder) = run_study(
        "sections",
        r#"LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31),
           Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 11)"#,
    );
    let svgs: Vec<String> = report
        .files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "svg"))
        .map(|f| f.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(svgs.len(), 2, "{svgs:?}");
    for (name, kind, words) in [
        ("lin", "LinearResponse", "Linear frequency response"),
        ("camp", "Campbell", "Campbell diagram: the eigenfrequencies"),
    ] {
        let open = format!("<section class=\"analysis\" id=\"analysis-{name}\" data-kind=\"{kind}\">");
        let start = html.find(&open).unwrap_or_else(|| panic!("a section for {name}"));
        let section = &html[start..start + html[start..].find("</section>").unwrap()];
        assert!(section.contains(&format!("<code>{name}</code>")) && section.contains("<h2>"), "{name}'s heading");
        let figure = format!("id=\"figure-{name}\"");
        assert!(section.contains(&figure), "{name}'s figure in its section");
        assert_eq!(html.matches(&figure).count(), 1, "{name}'s figure once");
        let caption = &section[section.find("<figcaption>").unwrap()..section.find("</figcaption>").unwrap()];
        assert!(caption.contains(words), "{name}: {caption}");
        assert!(caption.contains(&format!("href=\"{name}.svg\"")), "{name}: {caption}");
        for other in svgs.iter().filter(|f| !f.starts_with(name)) {
            assert!(!section.contains(&format!("href=\"{other}\"")), "{other} in {name}'s section");
        }
    }
}

/// Debian's `chromium` (or `chromium-browser`), or None after saying so; None is refused when
/// `KANEDYN_REQUIRE_BROWSER` is set (as `.ci/run` does after installing it).
fn chromium() -> Option<&'static str> {
    let browser = ["chromium", "chromium-browser"]
        .into_iter()
        .find(|b| std::process::Command::new(b).arg("--version").output().is_ok_and(|o| o.status.success()));
    if browser.is_none() {
        assert!(
            std::env::var_os("KANEDYN_REQUIRE_BROWSER").is_none(),
            "KANEDYN_REQUIRE_BROWSER is set but no chromium"
        );
        println!("skipped: no chromium on this machine");
    }
    browser
}

/// The DOM of `page` (its address ending in `fragment`) after headless Chromium loaded it and
/// ran its scripts.
fn dump_dom(browser: &str, page: &Path, fragment: &str) -> String {
    let out = std::process::Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--window-size=1100,900", "--virtual-time-budget=5000"])
        .arg("--dump-dom")
        .arg(format!("file://{}{fragment}", page.display()))
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The text of the last element that starts with `open` in `dom` (the page's script may quote
/// the tag), entities decoded.
fn text_of(dom: &str, open: &str) -> String {
    let start = dom.rfind(open).unwrap_or_else(|| panic!("no {open} in the page")) + open.len();
    let raw = &dom[start..start + dom[start..].find('<').unwrap()];
    raw.replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"").replace("&amp;", "&")
}

/// `report.html` in a real browser (headless Chromium, Debian's `chromium`): every figure is laid
/// out at a non-zero size and no script error or console error occurs (the zoom and hover layer
/// included). A small script put before the page's own records both into the DOM, which
/// `--dump-dom` prints after loading. Without Chromium the test says so and passes, unless
/// `KANEDYN_REQUIRE_BROWSER` is set.
#[test]
fn the_page_renders_in_a_headless_browser() {
    let Some(browser) = chromium() else { return };
    let (report, html, tmp) = run_study(
        "browser",
        r#"LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31),
           Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 11)"#,
    );
    let dir = tmp.path().to_path_buf();
    let probe = r#"<body>
<script>
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
</script>"#;
    let page = dir.join("probe.html");
    std::fs::write(&page, html.replacen("<body>", probe, 1)).unwrap();
    let dom = dump_dom(browser, &page, "");
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
}

/// Four numbers of a `viewBox`.
fn view_box(v: &serde_json::Value) -> Vec<f64> {
    v.as_str().unwrap().split(' ').map(|t| t.parse().unwrap()).collect()
}

/// The attribute `name`'s numbers on the first `kd-panel` group after `from` in `html`.
fn panel_attr(html: &str, from: usize, name: &str) -> Vec<f64> {
    let key = format!(" {name}=\"");
    let at = from + html[from..].find("class=\"kd-panel\"").expect("a panel group");
    let v = &html[at + html[at..].find(&key).unwrap() + key.len()..];
    v[..v.find('"').unwrap()].split(' ').map(|t| t.parse().unwrap()).collect()
}

/// The zoom and hover layer, driven in headless Chromium through the page's own self-test
/// (`#selftest`: real wheel, mouse-move, drag and double-click events on the first figure with
/// a curve), for `html` written into `dir` with the CSV files `csvs`:
/// - the wheel zooms in by 1.25 about the panel's centre (the viewBox narrows by that factor);
/// - the tooltip at the middle point of a curve names the axes and gives values that are a
///   row of one of the figure's CSV files (x and y each within 1e-3, relative, of two columns
///   of one row): the axes' mapping inverted, not the pixels;
/// - a drag over the middle half of the panel zooms onto exactly that box;
/// - a double-click brings the whole figure back.
fn check_zoom_and_hover(browser: &str, html: &str, dir: &Path, csvs: &[PathBuf]) {
    let page = dir.join("selftest.html");
    std::fs::write(&page, html).unwrap();
    let dom = dump_dom(browser, &page, "#selftest");
    let out: serde_json::Value =
        serde_json::from_str(&text_of(&dom, "<pre id=\"kd-selftest\">")).expect("the self-test's JSON");
    println!("self-test: {out}");
    let figure = out["figure"].as_str().expect("a figure with a curve");
    let from = html.find(&format!("id=\"{figure}\"")).unwrap();
    let (px, py) = (panel_attr(html, from, "data-px"), panel_attr(html, from, "data-py"));
    let (start, wheel, reset, drag) =
        (view_box(&out["start"]), view_box(&out["wheel"]), view_box(&out["reset"]), view_box(&out["drag"]));
    assert!((wheel[2] - start[2] / 1.25).abs() < 0.01 && (wheel[3] - start[3] / 1.25).abs() < 0.01, "wheel: {wheel:?}");
    let centre = ((px[0] + px[1]) / 2.0, (py[0] + py[1]) / 2.0);
    // Zoomed about the pointer: the panel's centre stays where it was in the figure's frame.
    // Synthetic mouse events carry whole client pixels, about 1.2 of the figure's units at this
    // window's width: the pointer lands within `pixel` of where it was aimed.
    let pixel = 1.5;
    assert!((wheel[0] + (centre.0 - start[0]) / 1.25 - centre.0).abs() < 0.2 * pixel, "wheel: {wheel:?}");
    assert_eq!(reset, start, "double-click resets");
    let (w, h) = (px[1] - px[0], py[0] - py[1]);
    let expected = [px[0] + 0.25 * w, py[1] + 0.25 * h, 0.5 * w, 0.5 * h];
    for (d, e) in drag.iter().zip(expected) {
        assert!((d - e).abs() < 2.0 * pixel, "drag box {drag:?}, expected {expected:?}");
    }
    let tip = out["tip"].as_str().expect("a tooltip shown");
    let lines: Vec<&str> = tip.lines().collect();
    assert!(lines.len() >= 2, "{tip}");
    let value = |line: &str, label: &serde_json::Value| -> f64 {
        let (l, v) = line.rsplit_once(" = ").unwrap_or_else(|| panic!("`{line}`"));
        assert_eq!(l, label.as_str().unwrap());
        v.parse().unwrap_or_else(|_| panic!("`{v}`"))
    };
    let x = value(lines[lines.len() - 2], &out["x_label"]);
    let y = value(lines[lines.len() - 1], &out["y_label"]);
    let near = |a: f64, b: f64| (a - b).abs() <= 1e-3 * b.abs().max(1e-12);
    let mut rows = 0;
    for csv in csvs {
        let text = std::fs::read_to_string(csv).unwrap();
        for line in text.lines().skip(1) {
            let row: Vec<f64> = line.split(',').map(|c| c.parse().unwrap_or(f64::NAN)).collect();
            let hit = (0..row.len()).any(|i| near(x, row[i]) && (0..row.len()).any(|j| j != i && near(y, row[j])));
            rows += usize::from(hit);
        }
    }
    assert!(rows > 0, "no row of {csvs:?} holds ({x}, {y})");
}

/// The figure's own CSV files (their names start with its analysis's name) among `files`.
fn csvs_of(files: &[PathBuf], figure: &str) -> Vec<PathBuf> {
    let name = figure.trim_start_matches("figure-");
    files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "csv"))
        .filter(|f| f.file_name().unwrap().to_string_lossy().starts_with(name))
        .cloned()
        .collect()
}

/// Zoom and hover on a small study's page (its first figure: the linear response normalised by
/// the locked twin, a logarithmic y axis): see [`check_zoom_and_hover`].
#[test]
fn zoom_and_hover_work_in_a_headless_browser() {
    let Some(browser) = chromium() else { return };
    let (report, html, tmp) = run_study(
        "zoom",
        r#"LinearResponse(name: "lin", rpm: 1000.0, from: 0.9, to: 1.2, points: 31),
           Campbell(name: "camp", rpm_min: 0.0, rpm_max: 2000.0, points: 11)"#,
    );
    let dir = tmp.path().to_path_buf();
    check_zoom_and_hover(browser, &html, &dir, &csvs_of(&report.files, "figure-lin"));
}

/// The shipped studies' pages: the paper study's and the truck study's `report.html` stay
/// within 2 MB; on the paper's page the zoom and hover layer works on its first figure (the
/// order sweep, read back against the sweep's CSV files); the truck's long tables (more than
/// 40 rows) fold: in the browser the eleventh row is hidden until the fold's `<details>` opens.
#[test]
fn the_example_reports_stay_small_zoom_and_fold() {
    // The folders outlive the loop: the browser checks below open the pages written there.
    let (mut pages, mut folders) = (Vec::new(), Vec::new());
    for (example, tag) in [("examples/cpva_paper.ron", "paper"), ("examples/truck_study.ron", "truck")] {
        let study = Study::from_file(Path::new(example)).unwrap_or_else(|e| panic!("{e}"));
        let tmp = scratch(&format!("report-{tag}"));
        let dir = tmp.path().to_path_buf();
        folders.push(tmp);
        let report = run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
        assert!(report.failures.is_empty(), "{:?}", report.failures);
        let page = report.files.iter().find(|f| f.file_name().is_some_and(|n| n == "report.html")).unwrap().clone();
        let size = std::fs::metadata(&page).unwrap().len();
        println!("{example}: report.html {size} bytes");
        assert!(size <= 2_000_000, "{example}: report.html is {size} bytes");
        pages.push((report, std::fs::read_to_string(&page).unwrap(), dir));
    }
    let (truck, truck_html) = (&pages[1].0, &pages[1].1);
    let long = truck.summary.split("\n\n").filter(|b| b.lines().filter(|l| l.starts_with('|')).count() > 42).count();
    assert!(long > 0, "the truck study has a long table");
    assert_eq!(truck_html.matches("<div class=\"fold\">").count(), long);
    assert_eq!(truck_html.matches("<div class=\"table-box\">").count(), truck.summary.matches("\n|---").count());
    if let Some(browser) = chromium() {
        let (paper, paper_html, paper_dir) = (&pages[0].0, &pages[0].1, &pages[0].2);
        check_zoom_and_hover(browser, paper_html, paper_dir, &csvs_of(&paper.files, "figure-sweep"));
        let probe = r#"<script>
window.addEventListener('load', function () {
  var fold = document.querySelector('.fold'), rows = fold.querySelectorAll('tbody tr');
  var shown = function () { return Array.prototype.filter.call(rows, function (r) { return r.getBoundingClientRect().height > 0; }).length; };
  var closed = shown();
  fold.querySelector('details').open = true;
  document.body.setAttribute('data-fold', JSON.stringify({ rows: rows.length, closed: closed, open: shown() }));
});
</script></body>"#;
        let page = pages[1].2.join("fold.html");
        std::fs::write(&page, truck_html.replacen("</body>", probe, 1)).unwrap();
        let dom = dump_dom(browser, &page, "");
        let start = dom.find("data-fold=\"").expect("the probe ran") + "data-fold=\"".len();
        let raw = &dom[start..start + dom[start..].find('"').unwrap()];
        let fold: serde_json::Value = serde_json::from_str(&raw.replace("&quot;", "\"")).unwrap();
        println!("fold: {fold}");
        assert!(fold["rows"].as_u64().unwrap() > 40);
        assert_eq!(fold["closed"].as_u64().unwrap(), 10, "{fold}");
        assert_eq!(fold["open"], fold["rows"], "{fold}");
    }
}

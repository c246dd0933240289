//! Issue 31's figures (item 1) and issue 29's "mark it on the figure" (item 4): the Campbell
//! diagram used to draw four order lines in one grey style, unnamed, with no crossing marked
//! although the resonance table had them; and every figure was a pixel image in SVG clothing,
//! whole-pixel coordinates with 23–36 % of the points repeating the one before (staircases when
//! zoomed). The SVG text is read back here as a viewer would see it.

use crate::support::scratch;
use kanedyn::study::{AnalysisSpec, RunOptions, Study, run};
use std::path::{Path, PathBuf};
use tempfile::TempDir;

/// The text contents of the SVG's `<text>` elements, trimmed.
fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| Some(t[t.find('>')? + 1..t.find("</text>")?].trim().to_string()))
        .collect()
}

/// Every value of attribute `name` in the SVG (its tags are written one attribute list each).
fn attributes<'a>(svg: &'a str, name: &str) -> Vec<&'a str> {
    let key = format!(" {name}=\"");
    svg.match_indices(&key)
        .map(|(i, _)| {
            let v = &svg[i + key.len()..];
            &v[..v.find('"').unwrap()]
        })
        .collect()
}

/// Every SVG file under `dir`, sorted.
fn svgs(dir: &Path) -> Vec<PathBuf> {
    let mut found = Vec::new();
    for e in std::fs::read_dir(dir).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            found.extend(svgs(&p));
        } else if p.extension().is_some_and(|x| x == "svg") {
            found.push(p);
        }
    }
    found.sort();
    found
}

/// The file `name` under `dir`, wherever the run put it.
fn find(dir: &Path, name: &str) -> PathBuf {
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.file_name().is_some_and(|n| n == name) {
                return p;
            }
        }
    }
    panic!("{name} not written under {}", dir.display())
}

/// Whether a coordinate is written with at least two decimals.
fn two_decimals(v: &str) -> bool {
    v.split_once('.').is_some_and(|(_, d)| d.len() >= 2 && d.chars().all(|c| c.is_ascii_digit()))
}

/// The vector checks on one SVG: no point of a polyline or polygon equal to the one before it,
/// and every coordinate (points, positions, ends, centres) with two decimals. Returns the number
/// of points checked.
fn check_vector(path: &Path) -> usize {
    let svg = std::fs::read_to_string(path).unwrap();
    let name = path.file_name().unwrap().to_string_lossy();
    let mut points = 0;
    for list in attributes(&svg, "points") {
        let pts: Vec<&str> = list.split_whitespace().collect();
        for w in pts.windows(2) {
            assert_ne!(w[0], w[1], "{name}: a point repeats the one before it in `{list}`");
        }
        for p in &pts {
            for c in p.split(',') {
                assert!(two_decimals(c), "{name}: point coordinate `{c}` without two decimals");
            }
        }
        points += pts.len();
    }
    for attr in ["x", "y", "x1", "y1", "x2", "y2", "cx", "cy"] {
        for v in attributes(&svg, attr) {
            assert!(two_decimals(v), "{name}: {attr}=\"{v}\" without two decimals");
        }
    }
    points
}

/// The truck driveline's Campbell diagram (examples/truck_study.ron, its Campbell analysis alone):
/// every crossing of `campbell_crossings.csv` is marked and labelled with its speed, each order
/// line is named at its end ("1.5n" … "6n", as the tables name orders), and each tracked mode
/// appears in the legend under the name its CSV columns give it.
#[test]
fn the_truck_campbell_marks_every_crossing_and_names_every_line() {
    let mut study = Study::from_file(Path::new("examples/truck_study.ron")).unwrap_or_else(|e| panic!("{e}"));
    study.spec.analyses.retain(|a| matches!(a, AnalysisSpec::Campbell(_)));
    let orders = match &study.spec.analyses[..] {
        [AnalysisSpec::Campbell(c)] => c.orders.clone(),
        _ => panic!("one Campbell analysis"),
    };
    let tmp = scratch("figures-truck");
    let dir = tmp.path().to_path_buf();
    let report = run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let svg = std::fs::read_to_string(find(&dir, "campbell.svg")).unwrap();
    let csv = std::fs::read_to_string(find(&dir, "campbell_crossings.csv")).unwrap();
    let table = std::fs::read_to_string(find(&dir, "campbell.csv")).unwrap();
    check_vector(&find(&dir, "campbell.svg"));
    let texts = texts(&svg);

    // Crossings: the speed rounded to whole rpm; two crossings at the same whole rpm need two
    // labels.
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let rpm_col = head.iter().position(|h| *h == "rpm").unwrap();
    let labels: Vec<String> =
        lines.map(|l| format!("{:.0} rpm", l.split(',').nth(rpm_col).unwrap().parse::<f64>().unwrap())).collect();
    println!("{} crossings: {labels:?}", labels.len());
    assert_eq!(labels.len(), 11, "the truck driveline's 11 crossings (issue 29)");
    for l in &labels {
        let want = labels.iter().filter(|m| *m == l).count();
        let got = texts.iter().filter(|t| *t == l).count();
        assert!(got >= want, "crossing `{l}`: {got} label(s) in campbell.svg, {want} in the CSV");
    }
    let markers = svg.matches("<circle").count();
    assert!(markers >= labels.len(), "{markers} markers for {} crossings", labels.len());

    for n in orders {
        let name = if n.fract() == 0.0 { format!("{n:.0}n") } else { format!("{n}n") };
        assert!(texts.contains(&name), "order line `{name}` not named; texts {texts:?}");
    }

    // Modes: the CSV's `mode<k>_<label>_hz` columns, the legend's `mode k (label)`.
    let header = table.lines().next().unwrap();
    let modes: Vec<String> = header
        .split(',')
        .filter_map(|h| {
            h.strip_prefix("mode")?.strip_suffix("_hz")?.split_once('_').map(|(k, l)| format!("mode {k} ({l})"))
        })
        .collect();
    assert_eq!(modes.len(), 4, "{header}");
    for m in &modes {
        assert!(texts.contains(m), "`{m}` not in the legend; texts {texts:?}");
    }
}

/// The paper study's figures (examples/cpva_paper.ron, the whole study: ~3 s) are vector figures:
/// no point repeats the one before it, and every coordinate has two decimals (1/100 pixel).
/// Before, 21.7 % of their 25,176 points repeated the one before (36 % in figure2.svg) and every
/// coordinate was a whole pixel.
#[test]
fn the_paper_study_figures_have_sub_pixel_coordinates_and_no_repeated_points() {
    let study = Study::from_file(Path::new("examples/cpva_paper.ron")).unwrap_or_else(|e| panic!("{e}"));
    let tmp = scratch("figures-paper");
    let dir = tmp.path().to_path_buf();
    run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
    let files = svgs(&dir);
    assert!(files.len() >= 5, "{files:?}");
    for f in &files {
        let n = check_vector(f);
        println!("{}: {n} points", f.file_name().unwrap().to_string_lossy());
        assert!(n > 100, "{}: only {n} points", f.display());
    }
}

/// One panel's axes as the SVG records them for its readers (`g.kd-panel`: the pixel columns
/// and rows of the axis ranges' ends, the ranges in data units, a log y axis, the labels).
#[derive(Debug)]
struct Axes {
    px: (f64, f64),
    py: (f64, f64),
    x: (f64, f64),
    y: (f64, f64),
    log_y: bool,
    y_label: String,
}

impl Axes {
    /// The pixel position of a data point.
    fn pixel(&self, x: f64, y: f64) -> (f64, f64) {
        let f = |v: f64, (a, b): (f64, f64)| (v - a) / (b - a);
        let t = if self.log_y { f(y.ln(), (self.y.0.ln(), self.y.1.ln())) } else { f(y, self.y) };
        (self.px.0 + f(x, self.x) * (self.px.1 - self.px.0), self.py.0 + t * (self.py.1 - self.py.0))
    }
}

impl Axes {
    /// The data value of a pixel row.
    fn value_at_row(&self, row: f64) -> f64 {
        let t = (row - self.py.0) / (self.py.1 - self.py.0);
        if self.log_y {
            (self.y.0.ln() + t * (self.y.1.ln() - self.y.0.ln())).exp()
        } else {
            self.y.0 + t * (self.y.1 - self.y.0)
        }
    }
}

/// The points of the polylines in the series group labelled `label`.
fn series_points(svg: &str, label: &str) -> Vec<(f64, f64)> {
    let open = format!("<g class=\"kd-series\" data-label=\"{label}\">");
    let start = svg.find(&open).unwrap_or_else(|| panic!("no series `{label}`")) + open.len();
    let group = &svg[start..start + svg[start..].find("</g>").unwrap()];
    attributes(group, "points")
        .iter()
        .flat_map(|l| l.split_whitespace())
        .map(|p| {
            let (x, y) = p.split_once(',').unwrap();
            (x.parse().unwrap(), y.parse().unwrap())
        })
        .collect()
}

/// The two numbers of a `data-…` attribute.
fn pair(tag: &str, name: &str) -> (f64, f64) {
    let v = attributes(tag, name)[0];
    let (a, b) = v.split_once(' ').unwrap();
    (a.parse().unwrap(), b.parse().unwrap())
}

/// Every panel of the SVG, in drawing order.
fn panels(svg: &str) -> Vec<Axes> {
    svg.split("<g class=\"kd-panel\"")
        .skip(1)
        .map(|t| {
            let tag = format!(" {}", &t[..t.find('>').unwrap()]);
            Axes {
                px: pair(&tag, "data-px"),
                py: pair(&tag, "data-py"),
                x: pair(&tag, "data-x"),
                y: pair(&tag, "data-y"),
                log_y: attributes(&tag, "data-log-y")[0] == "1",
                y_label: attributes(&tag, "data-y-label")[0].to_string(),
            }
        })
        .collect()
}

/// The centres of the SVG's circles (markers).
fn circles(svg: &str) -> Vec<(f64, f64)> {
    svg.split("<circle")
        .skip(1)
        .map(|t| {
            let tag = format!(" {}", &t[..t.find('>').unwrap()]);
            (attributes(&tag, "cx")[0].parse().unwrap(), attributes(&tag, "cy")[0].parse().unwrap())
        })
        .collect()
}

/// A circle within `tol` pixels of `at`.
fn marked(circles: &[(f64, f64)], at: (f64, f64), tol: f64) -> bool {
    circles.iter().any(|c| (c.0 - at.0).abs() <= tol && (c.1 - at.1).abs() <= tol)
}

/// A CSV file as (header, rows of numbers; an empty cell NaN).
fn csv_columns(path: &Path) -> (Vec<String>, Vec<Vec<f64>>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines.map(|l| l.split(',').map(|c| c.parse().unwrap_or(f64::NAN)).collect()).collect();
    (head, rows)
}

/// The column `name` of a CSV read by [`csv_columns`].
fn column(csv: &(Vec<String>, Vec<Vec<f64>>), name: &str) -> Vec<f64> {
    let k = csv.0.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column `{name}` in {:?}", csv.0));
    csv.1.iter().map(|r| r[k]).collect()
}

/// The paper study (examples/cpva_paper.ron) with only the analyses `keep` says, run into a
/// fresh folder; returns the study's output folder (removed when the guard drops).
fn run_only(file: &str, tag: &str, keep: impl Fn(&AnalysisSpec) -> bool) -> TempDir {
    let mut study = Study::from_file(Path::new(file)).unwrap_or_else(|e| panic!("{e}"));
    study.spec.analyses.retain(keep);
    let dir = scratch(&format!("figures-{tag}"));
    let report = run(&study, &RunOptions { out: Some(dir.path().to_path_buf()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    dir
}

/// The paper's Fig. 5 (the multi-order analysis of examples/cpva_paper.ron): 7 speeds used to be
/// joined by lines without a marker, so the jump at 600 rpm the README explains was invisible.
/// Every sampled speed of every curve of the response panel has a marker at its CSV value, and
/// the jump (harmonic balance's low-amplitude branch folds below the full torques at 600 rpm,
/// not at 800: results.json's `hbm_lower_fold`) is marked and named at 600 rpm on the main order.
#[test]
fn the_multi_order_figure_marks_its_sampled_speeds_and_the_jump() {
    let tmp = run_only("examples/cpva_paper.ron", "multi", |a| matches!(a, AnalysisSpec::MultiOrder(_)));
    let dir = tmp.path().to_path_buf();
    let svg = std::fs::read_to_string(find(&dir, "multi_order.svg")).unwrap();
    let csv = csv_columns(&find(&dir, "multi_order.csv"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(find(&dir, "results.json")).unwrap()).unwrap();
    check_vector(&find(&dir, "multi_order.svg"));
    let (axes, dots) = (panels(&svg), circles(&svg));
    let response = &axes[0];
    assert!(response.y_label.ends_with("rad/s²"), "{response:?}");
    let rpm = column(&csv, "rpm");
    assert_eq!(rpm.len(), 7);
    // plotters rounds positions to 1/100 pixel; 0.05 px is 0.1 rpm here, the speeds 200 rpm apart.
    let mut checked = 0;
    for name in [
        "amp_1x_rad_s2",
        "locked_1x_rad_s2",
        "linear_1x_rad_s2",
        "amp_2x_rad_s2",
        "locked_2x_rad_s2",
        "linear_2x_rad_s2",
    ] {
        for (r, v) in rpm.iter().zip(column(&csv, name)) {
            assert!(marked(&dots, response.pixel(*r, v), 0.05), "{name} at {r} rpm = {v}: no marker");
            checked += 1;
        }
    }
    assert_eq!(checked, 42);

    let speeds =
        json["analyses"].as_array().unwrap().iter().find(|a| a["name"] == "multi_order").unwrap()["result"]["speeds"]
            .as_array()
            .unwrap()
            .clone();
    let folded: Vec<bool> = speeds.iter().map(|s| s["hbm_lower_fold"].is_number()).collect();
    assert_eq!(folded, [true, false, false, false, false, false, false], "the jump the README explains");
    let texts = texts(&svg);
    assert!(texts.iter().any(|t| t == "jump between 600 and 800 rpm"), "{texts:?}");
    let upper = column(&csv, "amp_1x_rad_s2")[0];
    assert!(marked(&dots, response.pixel(600.0, upper), 0.05));
}

/// The truck study's question (examples/truck_study.ron: "what reaches the gearbox input …: the
/// torque in the input shaft (element `clutch`)") is a torque; its figure plotted radians. The
/// elements panel now plots each shaft-like element's transmitted torque on an axis in N·m, the
/// clutch's main and second order at the CSV's time-domain values, a marker at each speed.
#[test]
fn the_truck_multi_order_figure_plots_the_input_shaft_torque_in_newton_metres() {
    let tmp = run_only("examples/truck_study.ron", "truck_orders", |a| matches!(a, AnalysisSpec::MultiOrder(_)));
    let dir = tmp.path().to_path_buf();
    let svg = std::fs::read_to_string(find(&dir, "orders.svg")).unwrap();
    let csv = csv_columns(&find(&dir, "orders.csv"));
    check_vector(&find(&dir, "orders.svg"));
    let summary = std::fs::read_to_string(find(&dir, "summary.md")).unwrap();
    // The linear model overstates the response (friction and the arc spring's stages act in the
    // nonlinear runs only): the summary says so, at the speed of the largest factor in the CSV.
    let (lin, td, rpms) = (column(&csv, "linear_1x_rad_s2"), column(&csv, "amp_1x_rad_s2"), column(&csv, "rpm"));
    let (i, factor) =
        lin.iter().zip(&td).map(|(l, t)| (l / t).max(t / l)).enumerate().max_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert!(factor > 1.5, "{factor}");
    let expected = format!("{factor:.2}× larger than the time-domain one at {} rpm", rpms[i]);
    assert!(summary.contains(&expected), "no '{expected}' in the summary");
    let axes = panels(&svg);
    let torque = axes.iter().find(|a| a.y_label.contains("N·m")).unwrap_or_else(|| panic!("no axis in N·m: {axes:?}"));
    assert!(torque.y_label.contains("torque"), "{torque:?}");
    let labels: Vec<&str> = attributes(&svg, "data-label");
    assert!(labels.contains(&"clutch, main order") && labels.contains(&"clutch, 2nd order"), "{labels:?}");
    let dots = circles(&svg);
    let rpm = column(&csv, "rpm");
    assert_eq!(rpm.len(), 13);
    for name in ["clutch_torque_1x_Nm", "clutch_torque_2x_Nm"] {
        for (r, v) in rpm.iter().zip(column(&csv, name)) {
            assert!(v > 0.0, "{name} at {r} rpm = {v}");
            assert!(marked(&dots, torque.pixel(*r, v), 0.05), "{name} at {r} rpm = {v} N·m: not on the torque axis");
        }
    }
}

/// The paper study's harmonic balance over the sweeps (Figs. 3 and 4 with every periodic state):
/// each fold of results.json is marked on its panel (a circle at the fold's order) and named with
/// its order to five significant digits, and each sweep jump of the summary is marked.
#[test]
fn the_harmonic_balance_figure_marks_and_names_every_fold_and_jump() {
    let tmp = run_only("examples/cpva_paper.ron", "hbm", |a| {
        matches!(a, AnalysisSpec::OrderSweep(_) | AnalysisSpec::HarmonicBalance(_))
    });
    let dir = tmp.path().to_path_buf();
    let svg = std::fs::read_to_string(find(&dir, "hbm.svg")).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(find(&dir, "results.json")).unwrap()).unwrap();
    let (axes, dots, texts) = (panels(&svg), circles(&svg), texts(&svg));
    assert_eq!(axes.len(), 2, "one panel per amplitude, 40 and 500 N·m");
    let branches =
        json["analyses"].as_array().unwrap().iter().find(|a| a["name"] == "hbm").unwrap()["result"]["branches"]
            .as_array()
            .unwrap()
            .clone();
    let named = |prefix: &str, at: f64, digits: f64| {
        texts
            .iter()
            .filter_map(|t| t.strip_prefix(prefix)?.parse::<f64>().ok())
            .any(|v| (v - at).abs() <= 0.5 * 10f64.powf(-digits) * 10.0)
    };
    let mut folds = 0;
    for b in &branches {
        let panel = &axes[if b["amplitude"] == 40.0 { 0 } else { 1 }];
        for f in b["folds"].as_array().unwrap().iter().map(|f| f.as_f64().unwrap()) {
            // Five significant digits of an order near 3: four decimals, half a unit of the last.
            assert!(named("fold ", f, 4.0), "fold at {f} not named; texts {texts:?}");
            let x = panel.pixel(f, 1.0).0;
            assert!(
                dots.iter().any(|c| (c.0 - x).abs() <= 0.05 && (panel.py.1..=panel.py.0).contains(&c.1)),
                "fold at {f}: no marker"
            );
            folds += 1;
        }
    }
    assert_eq!(folds, 5, "the paper study's 5 folds (2 per 40 N·m branch, 1 at 500 N·m)");
    // The sweeps' jumps, as the summary reads them: both directions at 40 N·m, the up-sweep at 500.
    for prefix in ["up-sweep jumps at ", "down-sweep jumps at "] {
        assert!(texts.iter().any(|t| t.starts_with(prefix)), "no `{prefix}…`: {texts:?}");
    }
    assert!(named("up-sweep jumps at ", 3.183, 3.0), "{texts:?}");
}

/// Every legend entry of the paper study's figures that states a value carries its unit: the
/// figure 2 variants used to read "c_p = 5e-4" (the study file's labels, which also name the CSV
/// files and so stay as written).
#[test]
fn legend_entries_with_a_value_carry_its_unit() {
    let tmp = run_only("examples/cpva_paper.ron", "legends", |a| {
        matches!(a, AnalysisSpec::LinearResponse(_) | AnalysisSpec::Campbell(_))
    });
    let dir = tmp.path().to_path_buf();
    let mut valued = 0;
    for f in svgs(&dir) {
        let svg = std::fs::read_to_string(&f).unwrap();
        for label in attributes(&svg, "data-label") {
            let Some((_, value)) = label.split_once(" = ") else { continue };
            let mut words = value.split_whitespace();
            let number = words.next().unwrap_or("");
            assert!(number.parse::<f64>().is_ok(), "{}: `{label}`", f.display());
            assert!(
                words.next().is_some_and(|u| u.contains('/') || u.contains('·') || u.chars().all(char::is_alphabetic)),
                "{}: `{label}` without a unit",
                f.display()
            );
            valued += 1;
        }
    }
    // The three variants in the response panel's legend and again in the elements' ("pivot (c_p = …)").
    assert_eq!(valued, 6, "figure2's three c_p variants, twice");
}

/// The marine gearbox (examples/marine_gearbox.ron, Gunter & Chen's Example 8.1) asks for the
/// propeller-shaft torque under the fifth-order propeller torque; its linear-only multi-order
/// figure showed the propeller's acceleration alone. The elements' linear torques are now drawn
/// on an N·m axis, and the propeller shaft's curve peaks at the CSV's largest torque (4.717e5
/// N·m, the README's number): to 3 %, one pixel of the five-decade log axis, since the dashes
/// only pass through the 901 sampled speeds.
#[test]
fn the_marine_gearbox_figure_plots_the_propeller_shaft_torque() {
    let tmp = run_only("examples/marine_gearbox.ron", "marine", |a| matches!(a, AnalysisSpec::MultiOrder(_)));
    let dir = tmp.path().to_path_buf();
    let svg = std::fs::read_to_string(find(&dir, "propeller_torque.svg")).unwrap();
    let csv = csv_columns(&find(&dir, "propeller_torque.csv"));
    let axes = panels(&svg);
    let torque = axes.iter().find(|a| a.y_label.contains("N·m")).unwrap_or_else(|| panic!("no axis in N·m: {axes:?}"));
    let top =
        series_points(&svg, "propeller_shaft, main order, linear").iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let drawn = torque.value_at_row(top);
    let peak = column(&csv, "linear_propeller_shaft_torque_1x_Nm").into_iter().fold(0.0, f64::max);
    assert!((4.70e5..4.73e5).contains(&peak), "{peak}");
    assert!((drawn / peak - 1.0).abs() < 0.03, "drawn peak {drawn} N·m, CSV {peak} N·m");
}

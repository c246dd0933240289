//! Issue 31's figures (item 1) and issue 29's "mark it on the figure" (item 4): the Campbell
//! diagram used to draw four order lines in one grey style, unnamed, with no crossing marked
//! although the resonance table had them; and every figure was a pixel image in SVG clothing,
//! whole-pixel coordinates with 23–36 % of the points repeating the one before (staircases when
//! zoomed). The SVG text is read back here as a viewer would see it.

use kanedyn::study::{AnalysisSpec, RunOptions, Study, run};
use std::path::{Path, PathBuf};

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
    let dir = std::env::temp_dir().join(format!("kanedyn_figures_truck_{}", std::process::id()));
    let report = run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let svg = std::fs::read_to_string(find(&dir, "campbell.svg")).unwrap();
    let csv = std::fs::read_to_string(find(&dir, "campbell_crossings.csv")).unwrap();
    let table = std::fs::read_to_string(find(&dir, "campbell.csv")).unwrap();
    check_vector(&find(&dir, "campbell.svg"));
    std::fs::remove_dir_all(&dir).ok();
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
    let dir = std::env::temp_dir().join(format!("kanedyn_figures_paper_{}", std::process::id()));
    run(&study, &RunOptions { out: Some(dir.clone()), progress: false }).unwrap();
    let files = svgs(&dir);
    assert!(files.len() >= 5, "{files:?}");
    for f in &files {
        let n = check_vector(f);
        println!("{}: {n} points", f.file_name().unwrap().to_string_lossy());
        assert!(n > 100, "{}: only {n} points", f.display());
    }
    std::fs::remove_dir_all(&dir).ok();
}

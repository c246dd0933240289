//! Issue 49, item 7: where the low-amplitude branch folds before the full torques (the paper's
//! rotor at 600 rpm), no torque-ramp state carries the elements, and the upper state's element
//! peaks used to be in results.json only. Every harmonic-balance state's elements are now in
//! summary.md, the CSV (`hbm_state<k>_<joint>_…`) and results.json, the same numbers.

use crate::support::scratch;
use kanedyn::study::{RunOptions, Study, run};

/// The paper's MultiOrder at 600 rpm alone, harmonic balance only: the summary's element rows
/// (five significant digits, as the summary writes every number), the CSV's columns and
/// results.json's states agree for every state, the upper one included (no torque-ramp state
/// exists at this speed, so the ramp's `hbm_pivot_…` columns cannot carry it).
#[test]
fn every_harmonic_balance_state_reports_its_elements_in_every_output() {
    let tmp = scratch("hbm-states");
    let dir = tmp.path().to_path_buf();
    std::fs::copy("examples/cpva.ron", dir.join("cpva.ron")).unwrap();
    std::fs::write(
        dir.join("s.ron"),
        r#"Study(name: "s", mechanism: "cpva.ron", spin_joint: "spin", response_body: "rotor", elements: ["pivot"],
    analyses: [
        MultiOrder(name: "m", order: 3.0, multiples: [1.0, 2.0], time_domain: false, linear: false, hbm: true,
                   speeds: [(rpm: 600.0, harmonics: [(multiple: 1.0, amplitude: 670.0), (multiple: 2.0, amplitude: 430.0, phase: -0.32)])]),
    ])"#,
    )
    .unwrap();
    let study = Study::from_file(&dir.join("s.ron")).unwrap_or_else(|e| panic!("{e}"));
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let speed = &report.multi[0].speeds[0];
    assert!(speed.hbm_lower_fold.is_some() && speed.hbm_ramp.is_none(), "600 rpm: the low branch folds");
    assert!(!speed.hbm.is_empty());

    let csv = std::fs::read_to_string(dir.join("out/s/m.csv")).unwrap();
    let mut lines = csv.lines();
    let head: Vec<&str> = lines.next().unwrap().split(',').collect();
    let row: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| -> f64 {
        let i = head.iter().position(|h| *h == name).unwrap_or_else(|| panic!("{name}: {head:?}"));
        row[i].parse().unwrap_or_else(|_| panic!("{name} = `{}`", row[i]))
    };
    let summary = std::fs::read_to_string(dir.join("out/s/summary.md")).unwrap();
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("out/s/results.json")).unwrap()).unwrap();
    let states = json["analyses"].as_array().unwrap().iter().find(|a| a["name"] == "m").unwrap()["result"]["speeds"][0]
        ["hbm"]
        .as_array()
        .unwrap()
        .clone();
    assert_eq!(states.len(), speed.hbm.len());
    for (k, (h, js)) in speed.hbm.iter().zip(&states).enumerate() {
        let e = &h.elements[0];
        let je = &js["elements"][0];
        assert_eq!(je["joint"], "pivot");
        let prefix = format!("hbm_state{}_pivot", k + 1);
        // CSV and results.json: the same f64s.
        for (csv_name, json_name, value) in [
            (format!("{prefix}_1x_rad"), None, e.amplitude[0]),
            (format!("{prefix}_2x_rad"), None, e.amplitude[1]),
            (format!("{prefix}_peak_rad"), Some("peak"), e.peak),
            (format!("{prefix}_max_abs_rad"), Some("max_abs"), e.range.max_abs),
        ] {
            assert_eq!(col(&csv_name), value, "{csv_name}");
            if let Some(field) = json_name {
                assert_eq!(je[field].as_f64().unwrap(), value, "{field}");
            }
        }
        assert_eq!(je["amplitude"][0].as_f64().unwrap(), e.amplitude[0]);
        assert_eq!(col(&format!("hbm_state{}_stable", k + 1)), f64::from(h.stable.unwrap()));
        // summary.md: the row of this state names the peak as the summary writes numbers.
        let stable = if h.stable == Some(true) { "stable" } else { "unstable" };
        let label = format!("| 600 (state {}, {stable}) | `pivot` |", k + 1);
        let line = summary.lines().find(|l| l.starts_with(&label)).unwrap_or_else(|| panic!("{label}\n{summary}"));
        let peak = kanedyn::plot::num(e.peak, 5);
        assert!(line.contains(&format!("| {peak} |")), "peak {peak} in {line}");
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let amps: Vec<f64> = cells[3].trim_end_matches("rad").split(',').map(|x| x.trim().parse().unwrap()).collect();
        for (got, want) in amps.iter().zip(&e.amplitude) {
            // Five significant digits.
            assert!((got - want).abs() <= 5e-5 * want.abs(), "{got} vs {want}");
        }
        println!("state {}: pivot peak {:.6} rad ({stable})", k + 1, e.peak);
    }
}

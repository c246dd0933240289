//! The operating envelope (`Envelope` analysis, `src/study/envelope`) of the paper's rotor at
//! 1000 rpm, its pendulum split in two (`examples/cpva_maps.ron`): the jump boundary and the
//! unison-loss boundary against routes that share none of its two-parameter machinery:
//! one-parameter order branches at the boundary's own torques, the general route on the two
//! pendulums, and the single-pendulum rotor (whose response the two pendulums' unison motion
//! is exactly).

use crate::support::cpva_hbm::{cpva_hbm, single};
use crate::support::scratch;
use kanedyn::hbm::{ContinuationOptions, Hbm, HbmOptions};
use kanedyn::study::{EnvelopeResult, LoadOptions, RunOptions, Study, StudyReport, run};
use std::path::Path;

/// Runs the study file `text` (read as if it were `examples/<name>.ron`, so the examples'
/// mechanisms are found) into a fresh folder; returns the report and the output folder's text
/// files that the test reads.
fn run_study(name: &str, text: &str, tag: &str) -> (StudyReport, String, String, serde_json::Value) {
    let src = kanedyn::io::Source::from_text(&format!("examples/{name}.ron"), text);
    let study = Study::from_source(src, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let tmp = scratch(&format!("envelope-{tag}-{name}"));
    let out = tmp.path().to_path_buf();
    let report = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
    let dir = out.join(name);
    let read = |f: &str| std::fs::read_to_string(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    let (csv, svg) = (read("envelope.csv"), read("envelope.svg"));
    let json: serde_json::Value = serde_json::from_str(&read("results.json")).unwrap();
    (report, csv, svg, json)
}

/// `examples/cpva_maps.ron` under the study name `name` (its output folder).
fn maps_study(name: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/cpva_maps.ron"))
        .unwrap()
        .replace("name: \"cpva_maps\"", &format!("name: \"{name}\""))
}

/// The folds of the one-pendulum order branch over `window` at `torque` N·m (an independent
/// one-parameter continuation, no fold curve involved).
fn folds_at(hbm: &mut Hbm, torque: f64, window: (f64, f64), ds_max: f64) -> Vec<f64> {
    hbm.set_torque_scale(torque / 500.0).unwrap();
    let copts = ContinuationOptions { stability: false, ds_max, ds: 0.01_f64.min(ds_max), ..Default::default() };
    hbm.continue_in_order(window.0, window.1, None, &copts).unwrap().folds.iter().map(|f| f.order).collect()
}

#[test]
fn the_envelope_of_two_pendulums_maps_the_jump_and_the_unison_loss() {
    let (report, csv, svg, json) = run_study("maps", &maps_study("maps"), "two");
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let r: &EnvelopeResult = &report.envelopes[0];
    assert!(r.route.starts_with("cyclic"), "{}", r.route);
    let kinds: Vec<_> = r.boundaries.iter().map(|b| format!("{:?}", b.kind)).collect();
    assert_eq!(kinds, ["Jump", "UnisonLoss"]);
    let (jump, unison) = (&r.boundaries[0], &r.boundaries[1]);

    // The jump boundary at 500 N·m: the issue's one-parameter fold (confirmed by independent
    // shooting in `hbm_events`), 1e-6 in n.
    assert_eq!(jump.at_second_max.len(), 1, "{:?}", jump.at_second_max);
    assert!((jump.at_second_max[0] - 3.1015322).abs() <= 1e-6, "{:?}", jump.at_second_max);
    // Points of the CSV are folds of one-parameter branches at their own torques: three of
    // them (at about 40, 10 and 5 N·m), each matched by a fold of the single-pendulum branch
    // to 1e-6 in n (both solved to 1e-10; the branch's folds are refined by bisection).
    let mut one = cpva_hbm(&single(500.0), HbmOptions { stability_samples: 0, ..HbmOptions::default() });
    for target in [40.0, 10.0, 5.0] {
        let i = (0..jump.values.len())
            .min_by(|&a, &b| {
                (jump.second_values[a] / target).ln().abs().total_cmp(&(jump.second_values[b] / target).ln().abs())
            })
            .unwrap();
        let (n, t) = (jump.values[i], jump.second_values[i]);
        let folds = folds_at(&mut one, t, (2.9, 3.3), 0.02);
        let nearest = folds.iter().map(|f| (f - n).abs()).fold(f64::INFINITY, f64::min);
        println!("boundary point n {n:.8} at {t:.4} N·m; branch folds {folds:?}");
        assert!(nearest <= 1e-6, "the boundary point ({n}, {t} N·m) is {nearest} from the branch's folds {folds:?}");
    }
    // Its cusp: just below its torque the one-parameter branch around it has no fold, just above
    // it two (1 % either side; the issue asks 1e-4 against a bisection, done at 1e-5 in
    // `hbm_fold_curve`).
    let cusps: Vec<_> = r.points.iter().filter(|p| format!("{:?}", p.kind) == "Cusp").collect();
    assert_eq!(cusps.len(), 1, "{:?}", r.points);
    let (nc, tc) = (cusps[0].value, cusps[0].second_value);
    println!("cusp n {nc:.8} T {tc:.7} N·m");
    let window = (nc - 0.03, nc + 0.03);
    assert!(folds_at(&mut one, 0.99 * tc, window, 0.001).is_empty());
    assert_eq!(folds_at(&mut one, 1.01 * tc, window, 0.001).len(), 2);

    // The unison-loss boundary at 500 N·m: the general route's +1 points on the two pendulums
    // (located by bisection on the Floquet multipliers, `hbm_cyclic`), 1e-8.
    assert_eq!(unison.at_second_max.len(), 2, "{:?}", unison.at_second_max);
    for (got, want) in unison.at_second_max.iter().zip([3.0813662811512907, 3.0946057552055217]) {
        assert!((got - want).abs() <= 1e-8, "{got} against {want}");
    }
    // Its onset: the general route on both pendulums shows no +1 point off its folds 1 % below
    // it, two at 1.5 times it.
    let onsets: Vec<_> = r.points.iter().filter(|p| format!("{:?}", p.kind) == "UnisonLossOnset").collect();
    assert_eq!(onsets.len(), 1, "{:?}", r.points);
    let onset = onsets[0].second_value;
    for (torque, expected) in [(0.99 * onset, 0), (1.5 * onset, 2)] {
        let (plus, found) = crate::support::two_pendulums::plus_one_points(torque);
        assert_eq!(plus, expected, "{torque} N·m: {found}");
    }

    // The CSV: one row per boundary point, then the two codimension-two points, with their
    // kinds' codes; the chart names its regions and marks the points; results.json carries the
    // least torques.
    let rows: Vec<Vec<f64>> = csv.lines().skip(1).map(|l| l.split(',').map(|c| c.parse().unwrap()).collect()).collect();
    assert_eq!(csv.lines().next(), Some("boundary,kind,order,torque_N_m"));
    assert_eq!(rows.len(), jump.values.len() + unison.values.len() + 2);
    let count = |code: f64| rows.iter().filter(|r| r[1] == code).count();
    assert_eq!((count(1.0), count(2.0), count(10.0), count(12.0)), (jump.values.len(), unison.values.len(), 1, 1));
    let cusp_row = rows.iter().find(|r| r[1] == 10.0).unwrap();
    assert_eq!((cusp_row[2], cusp_row[3]), (nc, tc));
    for text in ["several states: jump possible", "unison lost", "one steady state", "cusp 3.18817", "<polygon"] {
        assert!(svg.contains(text), "the chart lacks `{text}`");
    }
    let findings = &json["analyses"][0]["findings"];
    assert_eq!(findings["jump_limits"][0].as_f64(), Some(tc));
    assert_eq!(findings["unison_loss_limits"][0].as_f64(), Some(onset));
    assert_eq!(findings["unit"].as_str(), Some("N·m"));
}

/// The two pendulums' unison motion is the single pendulum's exactly, so the one-pendulum
/// rotor (general route, every coordinate an unknown) has the same jump boundary: its cusp and
/// its fold at 500 N·m agree to 1e-8 (both solved to 1e-10), and it has no unison-loss boundary.
#[test]
fn one_pendulum_has_the_same_jump_boundary_and_no_unison_loss() {
    let (two, ..) = run_study("maps", &maps_study("maps"), "same");
    // The example's other analyses name the two pendulums' joints: the envelope alone here.
    let text = maps_study("maps1").replace("cpva2.ron", "cpva.ron");
    let envelope = text.lines().find(|l| l.trim_start().starts_with("Envelope(")).unwrap();
    let head = &text[..text.find("analyses: [").unwrap()];
    let one_pendulum = format!("{head}analyses: [\n{envelope}\n    ],\n)\n");
    let (one, ..) = run_study("maps1", &one_pendulum, "same");
    let (a, b) = (&two.envelopes[0], &one.envelopes[0]);
    assert!(b.route.starts_with("general"), "{}", b.route);
    assert_eq!(b.boundaries.len(), 1);
    assert!((a.boundaries[0].at_second_max[0] - b.boundaries[0].at_second_max[0]).abs() <= 1e-8);
    let cusp = |r: &EnvelopeResult| *r.points.iter().find(|p| format!("{:?}", p.kind) == "Cusp").unwrap();
    let (ca, cb) = (cusp(a), cusp(b));
    assert!(
        (ca.value - cb.value).abs() <= 1e-8 && (ca.second_value / cb.second_value - 1.0).abs() <= 1e-8,
        "{ca:?} {cb:?}"
    );
}

#[test]
fn a_bad_envelope_is_refused_with_its_field() {
    let base = maps_study("maps");
    for (from, to, field) in [
        ("torque_min: 1.0", "torque_min: 600.0", "analyses[0].torque_min"),
        ("order_min: 2.9", "order_min: 3.4", "analyses[0].order_min"),
        ("torque_max: 500.0", "torque_max: 500.0, seed_torques: [700.0]", "analyses[0].seed_torques[0]"),
        ("torque_max: 500.0", "torque_max: 500.0, harmonics: 0", "analyses[0].harmonics"),
        ("rpm: 1000.0,", "rpm: 1000.0, plane: Speed(order: 3.0, rpm_min: 300.0, rpm_max: 900.0),", "analyses[0].rpm"),
    ] {
        let text = base.replacen(from, to, 1);
        assert_ne!(text, base);
        let src = kanedyn::io::Source::from_text("examples/bad_maps.ron", &text);
        let e = Study::from_source(src, &LoadOptions::default()).expect_err(to).to_string();
        assert!(e.contains(field) && e.contains("bad_maps.ron:"), "{to}: {e}");
    }
}

/// The (speed, torque) plane at order 3 (below the tuning order 3.11, so the response folds where
/// the torque is large against the centrifugal stiffness ∝ Ω²): three points of the jump
/// boundary are folds of one-parameter speed branches at their own torques, to 1e-7 relative in
/// speed (both solved to 1e-10), and along it the fold torque grows about as Ω² (the
/// undamped problem depends on T/Ω² alone; damping makes it inexact, so ±25 %).
#[test]
fn the_speed_plane_envelope_is_made_of_speed_branch_folds() {
    use kanedyn::hbm::Parameter;
    use kanedyn::model::excitation::rpm_to_rad_s;
    let text = r#"Study(name: "speedmap", mechanism: "cpva.ron", spin_joint: "spin", response_body: "rotor",
        analyses: [Envelope(name: "envelope", plane: Speed(order: 3.0, rpm_min: 300.0, rpm_max: 1500.0),
                            torque_min: 1.0, torque_max: 1000.0)])"#;
    let (report, csv, _svg, _json) = run_study("speedmap", text, "speed");
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    let r = &report.envelopes[0];
    assert_eq!((r.parameter.as_str(), r.boundaries.len()), ("speed_rpm", 1));
    assert_eq!(csv.lines().next(), Some("boundary,kind,speed_rpm,torque_N_m"));
    let b = &r.boundaries[0];
    let mech = kanedyn::cpva::CpvaParams::canonical().mechanism(None).unwrap();
    let kane = kanedyn::kane::Kane::new(&mech).unwrap();
    let opts = HbmOptions { stability_samples: 0, ..HbmOptions::default() };
    let copts = ContinuationOptions { stability: false, ..Default::default() };
    let k = b.values.len();
    for i in [k / 5, k / 2, 4 * k / 5] {
        let (rpm, t) = (b.values[i], b.second_values[i]);
        let mut hbm = Hbm::new(&kane, 0, rpm_to_rad_s(1500.0), &single(t), opts).unwrap();
        let br = hbm
            .continue_in(Parameter::Speed { order: 3.0 }, rpm_to_rad_s(1500.0), rpm_to_rad_s(250.0), None, &copts)
            .unwrap();
        let folds: Vec<f64> = br.folds.iter().map(|f| f.parameter / rpm_to_rad_s(1.0)).collect();
        let nearest = folds.iter().map(|f| (f / rpm - 1.0).abs()).fold(f64::INFINITY, f64::min);
        println!("boundary point {rpm:.6} rpm at {t:.3} N·m; speed branch folds {folds:?}");
        assert!(nearest <= 1e-7, "({rpm} rpm, {t} N·m) is {nearest} from the branch's folds {folds:?}");
    }
    let (first, last) = (0, k - 1);
    let ratio = (b.second_values[last] / b.second_values[first]) / (b.values[last] / b.values[first]).powi(2);
    assert!((ratio - 1.0).abs() < 0.25, "T/Ω² along the fold curve changes by {ratio}");
}

/// Over orders 2.6–3.3 and 1–5000 N·m the unison-loss boundary of the two pendulums reaches
/// the jump boundary: a codimension-two point where the branch point sits on the fold
/// (`UnisonLossMeetsJump`). Checked on one-parameter branches of the general solver (both
/// pendulums unknowns, no two-parameter machinery): at the point's torque the branch's fold is
/// at the point's order (1e-6); 0.5 % below and above it, the branch point next to the fold
/// lies on opposite sides of it along the branch (it passes through the fold there).
#[test]
fn the_unison_loss_boundary_meets_the_jump_boundary() {
    use crate::support::cpva_hbm::omega;
    use kanedyn::cpva::CpvaParams;
    use kanedyn::kane::Kane;
    let text = "Study(name: \"meet\", mechanism: \"cpva2.ron\", spin_joint: \"spin\", response_body: \"rotor\",\n\
                analyses: [Envelope(name: \"envelope\", rpm: 1000.0, order_min: 2.6, order_max: 3.3, torque_min: 1.0, \
                torque_max: 5000.0)])\n";
    let (report, csv, _, _) = run_study("meet", text, "meet");
    let r = &report.envelopes[0];
    // One jump boundary and one unison-loss boundary: the unison-loss curve's two legs near its
    // onset are close in state, and a walk that stepped across to the other leg once walked the
    // first leg again and the map drew a second boundary (the null-vector guard of the walk).
    let kinds: Vec<_> = r.boundaries.iter().map(|b| format!("{:?}", b.kind)).collect();
    assert_eq!(kinds, ["Jump", "UnisonLoss"]);
    let meet = r.points.iter().find(|p| format!("{:?}", p.kind) == "UnisonLossMeetsJump").expect("a meeting point");
    println!("meeting at n {} T {} N·m", meet.value, meet.second_value);
    assert!(csv.lines().any(|l| l.starts_with(&format!("{},14,", meet.boundary + 1))), "CSV kind 14");
    let kane = Kane::new(&CpvaParams::canonical().with_pendulums(2).mechanism(None).unwrap()).unwrap();
    // (fold order, whether the branch point nearest the fold comes before it along the branch)
    let events = |torque: f64| -> (f64, bool) {
        let mut hbm = Hbm::new(&kane, 0, omega(), &single(torque), HbmOptions::default()).unwrap();
        let copts = ContinuationOptions { ds_max: 1e-4, ds: 1e-4, ..Default::default() };
        let b = hbm.continue_in_order(meet.value - 0.01, meet.value + 0.01, None, &copts).unwrap();
        crate::support::two_pendulums::fold_and_side_of_branch_point(&b, &format!("{torque} N·m"))
    };
    let t = meet.second_value;
    let (n_fold, _) = {
        let mut hbm = Hbm::new(&kane, 0, omega(), &single(t), HbmOptions::default()).unwrap();
        let copts = ContinuationOptions { ds_max: 1e-3, stability: false, ..Default::default() };
        let b = hbm.continue_in_order(meet.value - 0.01, meet.value + 0.01, None, &copts).unwrap();
        (b.folds[0].order, ())
    };
    println!("fold at the meeting torque: {n_fold}");
    assert!((n_fold - meet.value).abs() < 1e-6, "{n_fold} vs {}", meet.value);
    let (_, below) = events(t * (1.0 - 5e-3));
    let (_, above) = events(t * (1.0 + 5e-3));
    assert_ne!(below, above, "the branch point does not pass through the fold between the two torques");
}

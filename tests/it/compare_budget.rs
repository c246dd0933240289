//! Issue 49, item 5: one runaway member of a comparison used to spend the whole comparison's
//! watchdog budget (a 1e9 N·m sweep, planned as an ordinary one, ran until the comparison's
//! deadline and the nine other members were stopped unrun, their CSV files header-only). Each
//! inner analysis now has the budget of its own plan, and the plan sees the speed such a torque
//! drives (its CPU time against the measured one is in `tests/plan_calibration.rs`).

use crate::support::examples::copy_dir;
use kanedyn::study::{Limits, LoadOptions, RunOptions, Study, Watchdog, run};
use std::path::Path;

/// Five mechanisms × (a sweep at 1e9 N·m, a linear response): on the paper's rotor the torque
/// swings the speed by ~10⁶ rad/s and the sweep runs away; on the four others (the same rotor
/// 10⁶ times heavier, where the same torque moves the speed by 1 %) everything is ordinary.
#[test]
fn a_runaway_member_leaves_the_other_members_their_budget() {
    let root = crate::support::scratch("compare-budget");
    let dir = root.path();
    copy_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"), dir);
    let cpva = std::fs::read_to_string(dir.join("cpva.ron")).unwrap();
    let rotor = r#"Body(name: "rotor", part: "catalog:bodies/flywheel_rotor.ron")"#;
    assert!(cpva.contains(rotor), "examples/cpva.ron no longer names its rotor part this way");
    let heavy = r#"Body(name: "rotor", mass: 110.0, com: (0.0, 0.0), inertia: 3.4e6)"#;
    std::fs::write(dir.join("heavy.ron"), cpva.replace(rotor, heavy)).unwrap();
    let text = r#"Study(name: "cb", mechanism: "cpva.ron", lock: ["pivot"],
    order_tracking: (window_s: 0.5, hop_s: 0.25),
    analyses: [Compare(name: "c",
        mechanisms: [(label: "a", mechanism: "cpva.ron"), (label: "b", mechanism: "heavy.ron"),
                     (label: "d", mechanism: "heavy.ron"), (label: "e", mechanism: "heavy.ron"),
                     (label: "f", mechanism: "heavy.ron")],
        analyses: [
            OrderSweep(name: "s", rpm: 1000.0, order_min: 2.9, order_max: 3.3, duration_s: 2.0,
                       amplitudes: [1e9], directions: [Up], ramp_s: 0.5),
            LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.2, points: 11),
        ])])
"#;
    let path = dir.join("cb.ron");
    std::fs::write(&path, text).unwrap();
    // No multiple of the plan, five seconds each: the comparison as a whole used to get just
    // that. An ordinary member needs a fraction of a second of CPU; five leave room for a
    // loaded machine (wall time) running other tests beside this one (the process's CPU time),
    // which together pass a one-second budget.
    let limits = Limits { watchdog: Watchdog { factor: 0.0, floor_s: 5.0 }, ..Limits::default() };
    let study = Study::from_file_with(&path, &LoadOptions { limits, ..LoadOptions::default() }).unwrap();

    // The plan sees the runaway: on the light rotor the sweep is planned far above the same sweep
    // on the heavy one (the swing Δω = T/(J n Ω) ≈ 8·10⁵ rad/s against Ω = 105 rad/s; the
    // factor of 100 leaves room for the twin's and the tracking's shares, which do not grow).
    let subs = &study.sub_studies[0].1;
    let planned = |v: usize| subs[v].1.plan().analyses[0].cpu_s;
    assert!(planned(0) > 100.0 * planned(1), "light {} s, heavy {} s", planned(0), planned(1));

    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    println!("{:#?}", report.failures);
    // Only the runaway is stopped, by its own budget (its run, and its locked twin too when
    // the twin starts after the budget is spent).
    assert!(!report.failures.is_empty() && report.failures.len() <= 2, "{:#?}", report.failures);
    for f in &report.failures {
        assert!(f.contains("c_a_s_") && f.contains("stopped by the watchdog") && f.contains("5.0 s"), "{f}");
    }
    // Every other member wrote its CSV files with rows.
    let out = dir.join("out").join("cb");
    let mut checked = 0;
    for entry in std::fs::read_dir(&out).unwrap() {
        let p = entry.unwrap().path();
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        if !name.ends_with(".csv") || name.starts_with("c_a_s") {
            continue;
        }
        let rows = std::fs::read_to_string(&p).unwrap().lines().filter(|l| !l.trim().is_empty()).count();
        assert!(rows >= 2, "{name} has no rows");
        checked += 1;
    }
    // Per heavy mechanism at least a sweep file and a linear response file, and the light
    // mechanism's linear response.
    assert!(checked >= 9, "only {checked} CSV files of the other members");
    // A sweep whose run was stopped still ends (its failure is the run's): every inner analysis
    // of every mechanism ran.
    assert!(report.compares[0].mechanisms.iter().all(|m| m.completed == [true, true]));
}

/// Issue 49, item 4: a comparison whose every free oscillation was stopped has no member result
/// to take the overlay's speed from; its title used to read "NaN rpm". A zero budget stops each
/// member before its first amplitude: the overlay still is written, says so, and no file of the
/// run holds NaN or an infinity as a word.
#[test]
fn a_free_oscillation_overlay_without_members_says_so() {
    let root = crate::support::scratch("compare-none");
    let dir = root.path();
    copy_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"), dir);
    let text = r#"Study(name: "none", mechanism: "cpva.ron", lock: ["pivot"],
    analyses: [Compare(name: "c",
        mechanisms: [(label: "a", mechanism: "cpva.ron"), (label: "b", mechanism: "cpva.ron")],
        analyses: [FreeOscillation(name: "free", rpm: 1000.0, joint: "pivot", amplitudes: [0.1, 0.2])])])
"#;
    let path = dir.join("none.ron");
    std::fs::write(&path, text).unwrap();
    let limits = Limits { watchdog: Watchdog { factor: 0.0, floor_s: 0.0 }, ..Limits::default() };
    let study = Study::from_file_with(&path, &LoadOptions { limits, ..LoadOptions::default() }).unwrap();
    let report = run(&study, &RunOptions { out: Some(dir.join("out")), progress: false }).unwrap();
    assert_eq!(report.failures.len(), 2, "{:#?}", report.failures);
    assert!(report.free.is_empty(), "a member's free oscillation ran");
    let out = dir.join("out").join("none");
    let svg = std::fs::read_to_string(out.join("c_free.svg")).unwrap();
    assert!(svg.contains("no member reached"), "the overlay does not say why it is empty");
    for entry in std::fs::read_dir(&out).unwrap() {
        let p = entry.unwrap().path();
        let body = std::fs::read_to_string(&p).unwrap();
        let bad = body
            .split(|c: char| !(c.is_ascii_alphanumeric() || matches!(c, '-' | '+' | '.')))
            .map(|w| w.trim_start_matches(['-', '+']).to_ascii_lowercase())
            .find(|w| matches!(w.as_str(), "nan" | "inf" | "infinity"));
        assert!(bad.is_none(), "{} holds {bad:?}", p.display());
    }
}

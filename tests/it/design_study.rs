//! Design studies: the cases a grid, a Latin hypercube and Monte Carlo draw (against their
//! definitions), each case's linear results against the paper's closed forms (eqs. 15, 17, 18),
//! one failed case that costs the others nothing, one case run by index equal to the full run,
//! the plan scaled by the cases, and bad input located at file, line:column and field.

use crate::support::scratch;
use approx::{abs_diff_eq, assert_abs_diff_eq};
use kanedyn::cpva::{inertia_ratio, rotor_order, tuning_order};
use kanedyn::error::Error;
use kanedyn::io::Source;
use kanedyn::study::design::{self, CaseStatus, DesignSpec, case_values};
use kanedyn::study::{AnalysisSpec, LoadOptions, RunOptions, Study, run};
use rand_chacha::ChaCha8Rng;
use rand_chacha::rand_core::{RngCore, SeedableRng};
use tempfile::TempDir;

/// A study of `examples/cpva.ron` (the paper's rotor-CPVA) holding the given analyses, as if it
/// were the file `examples/design_test.ron` (never written: its mechanism resolves from there).
fn study_text(analyses: &str) -> String {
    format!(
        "Study(\n    name: \"design_test\",\n    mechanism: \"cpva.ron\",\n    lock: [\"pivot\"],\n    analyses: [\n{analyses}\n    ],\n)\n"
    )
}

fn load(text: &str) -> Result<Study, Error> {
    Study::from_source(Source::from_text("examples/design_test.ron", text), &LoadOptions::default())
}

fn design(study: &Study) -> &DesignSpec {
    match &study.spec.analyses[0] {
        AnalysisSpec::DesignStudy(d) => d,
        other => panic!("not a design study: {}", other.kind()),
    }
}

fn out_dir(tag: &str) -> TempDir {
    scratch(&format!("design-{tag}"))
}

#[test]
fn tuning_and_rotor_orders_follow_eqs_15_and_17_case_by_case() {
    // R (pivot radius), L (pendulum centre-of-mass radius), I_B (its centroidal inertia): with
    // I_B = 0 eq. (15) reduces to n_t = sqrt(R / L).
    let text = study_text(
        r#"        DesignStudy(
            name: "grid",
            parameters: [
                (name: "R", quantity: JointRadius("pivot"), from: 0.12, to: 0.2, points: 3),
                (name: "L", quantity: BodyComRadius("pendulum"), values: [0.01, 0.0152093650768, 0.025]),
                (name: "I_B", quantity: BodyInertia("pendulum"), values: [0.0, 2.16e-4]),
                (name: "m_p", quantity: BodyMass("pendulum"), values: [3.0, 6.0]),
            ],
            analysis: LinearResponse(name: "lin", rpm: 1000.0, from: 0.8, to: 1.3, points: 11),
        ),"#,
    );
    let study = load(&text).unwrap_or_else(|e| panic!("{e}"));
    let spec = design(&study);
    let i_a = study.mechanism.bodies[study.mechanism.body_index("rotor").unwrap()].inertia.i_com;
    let rows = design::run_cases(&study, spec, None, true, &|| {}).unwrap();
    assert_eq!(rows.len(), 36);
    let cols = design::result_columns(&study, spec);
    let col = |name: &str| cols.iter().position(|c| c.name == name).unwrap();
    let (c_nt, c_nr) = (col("n_t"), col("n_r"));
    let mut point_masses = 0;
    for r in &rows {
        assert_eq!(r.status, CaseStatus::Ok, "case {}: {}", r.index, r.error);
        let [rr, l, i_b, m] = r.values[..] else { panic!("four values") };
        let nt = tuning_order(m, rr, l, i_b);
        if i_b == 0.0 {
            // The paper's point-mass form, independent of the library's closed-form helper.
            assert_abs_diff_eq!(nt, (rr / l).sqrt(), epsilon = 1e-15 * nt);
            point_masses += 1;
        }
        // Eigen-orders from the linearisation, solved numerically (tests/it/linear.rs: 2e-14 on the
        // canonical CPVA); 1e-9 relative leaves room for the other geometries.
        assert!(
            abs_diff_eq!(r.results[c_nt], nt, epsilon = 1e-9 * nt),
            "case {}: n_t {} vs {nt}",
            r.index,
            r.results[c_nt]
        );
        let nr = rotor_order(nt, inertia_ratio(i_a, m, rr, i_b, l));
        assert!(
            abs_diff_eq!(r.results[c_nr], nr, epsilon = 1e-9 * nr),
            "case {}: n_r {} vs {nr}",
            r.index,
            r.results[c_nr]
        );
    }
    assert_eq!(point_masses, 18);
}

#[test]
fn a_grid_is_the_nested_loops_of_its_values_in_file_order() {
    let text = study_text(
        r#"        DesignStudy(
            name: "grid",
            parameters: [
                (name: "a", quantity: BodyMass("pendulum"), values: [1.0, 2.0]),
                (name: "b", quantity: JointDamping("pivot"), from: 1e-4, to: 1e-2, points: 3, log: true),
                (name: "c", quantity: Rpm, from: 500.0, to: 1500.0, points: 5),
            ],
            analysis: LinearResponse(name: "lin", rpm: 1000.0, from: 0.8, to: 1.3, points: 11),
        ),"#,
    );
    let study = load(&text).unwrap_or_else(|e| panic!("{e}"));
    let cases = case_values(design(&study));
    let mut expected: Vec<[f64; 3]> = Vec::new();
    for a in [1.0, 2.0] {
        for b in [1e-4, 1e-3, 1e-2] {
            for c in [500.0, 750.0, 1000.0, 1250.0, 1500.0] {
                expected.push([a, b, c]);
            }
        }
    }
    assert_eq!(cases.len(), expected.len());
    for (got, want) in cases.iter().zip(&expected) {
        for (g, w) in got.iter().zip(want) {
            // Log spacing by powf: within a few ulps of the decade values; ends exact.
            assert!(abs_diff_eq!(g, w, epsilon = 4.0 * f64::EPSILON * w.abs()), "{got:?} vs {want:?}");
        }
    }
    assert_eq!(cases.last().unwrap(), &vec![2.0, 1e-2, 1500.0]);
}

fn sampled(sampling: &str) -> Study {
    let text = study_text(&format!(
        r#"        DesignStudy(
            name: "sampled",
            parameters: [
                (name: "T", quantity: TorqueAmplitude, from: 10.0, to: 200.0),
                (name: "c", quantity: JointDamping("pivot"), from: 1e-5, to: 1e-1, log: true),
                (name: "R", quantity: JointRadius("pivot"), from: 0.15, to: 0.19),
            ],
            sampling: {sampling},
            analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),
        ),"#
    ));
    load(&text).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_latin_hypercube_hits_each_stratum_once_per_parameter() {
    for n in [1, 7, 100, 1000] {
        let study = sampled(&format!("LatinHypercube(n: {n}, seed: 42)"));
        let spec = design(&study);
        let cases = case_values(spec);
        assert_eq!(cases.len(), n);
        for (k, p) in spec.parameters.iter().enumerate() {
            let (a, b) = (p.from.unwrap(), p.to.unwrap());
            let mut hits = vec![0usize; n];
            for c in &cases {
                let v = c[k];
                assert!((a..=b).contains(&v), "{} = {v} outside {a}..{b}", p.name);
                // The stratum, measured on the parameter's own scale (logarithmic for c).
                let t = if p.log { (v / a).ln() / (b / a).ln() } else { (v - a) / (b - a) };
                let s = ((t * n as f64).floor() as usize).min(n - 1);
                hits[s] += 1;
            }
            // Rounding can move a value that sits within ~1e-15 of a stratum edge across it;
            // with 53-bit uniforms no draw of this seed comes that close.
            assert!(hits.iter().all(|&h| h == 1), "{}: strata hit {hits:?}", p.name);
        }
    }
}

#[test]
fn monte_carlo_cases_are_the_documented_chacha8_stream() {
    let study = sampled("MonteCarlo(n: 50, seed: 7)");
    let spec = design(&study);
    let cases = case_values(spec);
    // The recipe of the module docs, written out here: ChaCha8 seeded by seed_from_u64, top 53
    // bits of each next_u64 times 2^-53, case by case, parameters in file order; log ranges
    // mapped geometrically.
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for c in &cases {
        for (k, p) in spec.parameters.iter().enumerate() {
            let u = (rng.next_u64() >> 11) as f64 / 9007199254740992.0;
            let (a, b) = (p.from.unwrap(), p.to.unwrap());
            let want = if p.log { a * (b / a).powf(u) } else { a + (b - a) * u };
            assert_eq!(c[k].to_bits(), want.to_bits());
        }
    }
    // Reproducible from the seed; another seed draws other cases.
    assert_eq!(case_values(design(&sampled("MonteCarlo(n: 50, seed: 7)"))), cases);
    assert_ne!(case_values(design(&sampled("MonteCarlo(n: 50, seed: 8)"))), cases);
    let lhs = case_values(design(&sampled("LatinHypercube(n: 50, seed: 7)")));
    assert_eq!(case_values(design(&sampled("LatinHypercube(n: 50, seed: 7)"))), lhs);
    assert_ne!(case_values(design(&sampled("LatinHypercube(n: 50, seed: 9)"))), lhs);
}

#[test]
fn a_failed_case_is_reported_and_the_others_keep_their_results() {
    // Pendulum mass × inertia × torque: with both zero the pendulum is a body with neither mass
    // nor inertia (an invalid mechanism); with no mass but an inertia it has no centrifugal
    // restoring force, so harmonic balance has no isolated solution (a singular Jacobian).
    let text = study_text(
        r#"        DesignStudy(
            name: "forced",
            parameters: [
                (name: "m_p", quantity: BodyMass("pendulum"), values: [0.0, 6.0]),
                (name: "I_B", quantity: BodyInertia("pendulum"), values: [0.0, 2.16e-4]),
                (name: "T_n", quantity: TorqueAmplitude, values: [20.0, 40.0]),
            ],
            analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),
        ),"#,
    );
    let study = load(&text).unwrap_or_else(|e| panic!("{e}"));
    let tmp = out_dir("forced");
    let out = tmp.path().to_path_buf();
    let report = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
    let r = &report.designs[0];
    assert_eq!(r.cases.len(), 8);
    for c in &r.cases {
        let why = match (c.values[0] == 0.0, c.values[1] == 0.0) {
            (true, true) => "no mass and no inertia",
            (true, false) => "singular Jacobian",
            _ => "",
        };
        if why.is_empty() {
            assert_eq!(c.status, CaseStatus::Ok, "case {}: {}", c.index, c.error);
            // Every result is finite but the listed folds, branch points, losses of unison and the localisation
            // index, which are NaN where a case has none (one pendulum; 20 N·m has no fold).
            let optional = |name: &str| {
                name.starts_with("fold_")
                    || name.starts_with("branch_point_")
                    || name.starts_with("unison_lost_")
                    || name == "localisation_index"
            };
            let cols = design::result_columns(&study, design(&study));
            assert!(
                c.results.iter().zip(&cols).all(|(v, col)| v.is_finite() || optional(&col.name)),
                "case {}: {:?}",
                c.index,
                c.results
            );
        } else {
            assert_eq!(c.status, CaseStatus::Failed, "case {}", c.index);
            assert!(c.error.contains(why), "case {}: {}", c.index, c.error);
            assert!(c.results.iter().all(|v| v.is_nan()));
        }
    }
    assert_eq!(r.counts(), (4, 0, 4));
    assert_eq!(report.failures.len(), 4, "{:?}", report.failures);
    assert!(
        report.failures[0].starts_with("DesignStudy `forced` (examples/design_test.ron:"),
        "{}",
        report.failures[0]
    );
    let csv = std::fs::read_to_string(out.join("design_test").join("forced.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert!(lines[0].ends_with(",status,error") && lines[0].starts_with("case,m_p_kg,I_B_kg_m2,T_n_Nm,"));
    assert_eq!(lines.iter().filter(|l| l.contains(",failed,")).count(), 4);
    // The figure: the failed cases' NaN results are left out, the others drawn.
    let svg = std::fs::read_to_string(out.join("design_test").join("forced.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("Design study `forced`: 8 cases"));

    // One case by index, alone and sequentially, equals its row of the parallel run bit for bit.
    let spec = design(&study);
    for i in [1, 3, 6] {
        let alone = design::run_cases(&study, spec, Some(&[i]), false, &|| {}).unwrap();
        let (a, b) = (&alone[0], &r.cases[i]);
        assert_eq!(a.index, i);
        assert_eq!(a.status, b.status);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.results), bits(&b.results));
        assert_eq!(bits(&a.values), bits(&b.values));
    }
    assert!(design::run_cases(&study, spec, Some(&[8]), false, &|| {}).is_err());
}

#[test]
fn the_plan_counts_every_case() {
    let inner = r#"HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0])"#;
    let alone = load(&study_text(&format!("        {inner},"))).unwrap();
    let grid = load(&study_text(&format!(
        r#"        DesignStudy(name: "d", parameters: [(name: "T", quantity: TorqueAmplitude, from: 1.0, to: 100.0, points: 40)], analysis: {inner}),"#
    )))
    .unwrap();
    let (one, many) = (&alone.plan().analyses[0], &grid.plan().analyses[0]);
    assert_eq!(many.runs, 40 * one.runs);
    // Each case costs its analysis plus the setting up of the case (issue 25: a fraction of a
    // millisecond, which dominates only for tiny analyses).
    assert!(
        many.cpu_s >= 40.0 * one.cpu_s && many.cpu_s <= 40.0 * one.cpu_s * 1.001,
        "{} vs {}",
        many.cpu_s,
        one.cpu_s
    );
    // 100 000 such cases exceed the default 12 CPU hours: refused at load, at the sampling.
    let err = load(&study_text(&format!(
        r#"        DesignStudy(name: "d", parameters: [(name: "T", quantity: TorqueAmplitude, from: 1.0, to: 100.0)], sampling: MonteCarlo(n: 100000, seed: 1), analysis: {inner}),"#
    )))
    .unwrap_err()
    .to_string();
    assert!(err.contains("(field `analyses[0].sampling`)") && err.contains("CPU time"), "{err}");
}

/// The error of loading the design study with `parameters` and `tail` (further fields), and
/// the line:column of `needle`'s first occurrence in its text (the value the error must name).
fn located(parameters: &str, tail: &str, needle: &str) -> (String, String) {
    let text = study_text(&format!(
        "        DesignStudy(\n            name: \"bad\",\n            parameters: [\n{parameters}\n            ],\n{tail}\n        ),"
    ));
    let err = load(&text).err().unwrap_or_else(|| panic!("loaded:\n{text}")).to_string();
    let off = text.find(needle).unwrap_or_else(|| panic!("no {needle:?} in\n{text}"));
    let line = text[..off].matches('\n').count() + 1;
    let col = text[..off].rsplit('\n').next().unwrap().chars().count() + 1;
    (err, format!("examples/design_test.ron:{line}:{col} "))
}

#[test]
fn bad_design_input_is_located_at_its_field() {
    let hbm = r#"            analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),"#;
    let lin = r#"            analysis: LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.2, points: 11),"#;
    let p = |q: &str, rest: &str| format!("                (name: \"x\", quantity: {q}, {rest}),");
    let cases: Vec<(String, String, &str, &str, &str)> = vec![
        (p(r#"BodyMass("pendulm")"#, "values: [1.0]"), hbm.into(), r#"BodyMass("pendulm")"#, "parameters[0].quantity", "unknown body `pendulm` (bodies: rotor, pendulum)"),
        (p(r#"JointDamping("pivt")"#, "values: [1.0]"), hbm.into(), r#"JointDamping("pivt")"#, "parameters[0].quantity", "unknown joint `pivt` (joints: spin, pivot)"),
        (p(r#"BodyMass("pendulum")"#, "from: -1.0, to: 2.0, points: 3"), hbm.into(), "-1.0", "parameters[0].from", "must satisfy 0 ≤ value"),
        (p(r#"BodyInertia("pendulum")"#, "values: [1e-4, -2e-4]"), hbm.into(), "-2e-4", "parameters[0].values[1]", "must satisfy 0 ≤ value"),
        (p("Rpm", "from: 900.0, to: 800.0, points: 3"), hbm.into(), "800.0", "parameters[0].to", "need from < to"),
        (p("Rpm", "from: 900.0, to: 1000.0"), hbm.into(), "(name: \"x\"", "parameters[0].points", "give 2 to 1000 points"),
        (p("Order", "values: [3.0]"), hbm.into(), "Order,", "parameters[0].quantity", "sweep the order themselves"),
        (p("TorqueAmplitude", "values: [3.0]"), lin.into(), "TorqueAmplitude", "parameters[0].quantity", "per unit torque"),
        (p("TorqueAmplitude", "values: [0.0]"), hbm.into(), "0.0]", "parameters[0].values[0]", "0 < |T_n|"),
        (p(r#"JointStiffness("spin")"#, "values: [1.0]"), hbm.into(), r#"JointStiffness("spin")"#, "parameters[0].quantity", "spin joint"),
        (p(r#"JointRadius("spin")"#, "values: [1.0]"), hbm.into(), r#"JointRadius("spin")"#, "parameters[0].quantity", "no direction"),
        (p("Rpm", "values: [1e7]"), hbm.into(), "1e7", "parameters[0].values[0]", "0 < rpm ≤ 1e6"),
        (p("Rpm", "values: [500.0]"), format!("            sampling: MonteCarlo(n: 10, seed: 1),\n{hbm}"), "[500.0]", "parameters[0].values", "random sampling draws"),
        (p("Rpm", "from: 500.0, to: 900.0"), format!("            sampling: LatinHypercube(n: 0, seed: 1),\n{hbm}"), "LatinHypercube", "sampling", "give 1 to 100000 cases"),
        (format!("{}\n{}", p("Rpm", "values: [500.0]"), p("TorqueAmplitude", "values: [5.0]")), hbm.into(), "\"x\", quantity: TorqueAmplitude", "parameters[1].name", "named twice"),
        (p("Rpm", "values: [500.0]"), r#"            analysis: HarmonicBalance(name: "h", rpm: -5.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0]),"#.into(), "-5.0", "analysis.rpm", "speed must be within"),
        (p("Rpm", "values: [500.0]"), r#"            analysis: Campbell(name: "c", rpm_min: 0.0, rpm_max: 100.0),"#.into(), "Campbell(", "analysis", "not Campbell"),
        (p("Rpm", "values: [500.0]"), r#"            analysis: LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.2, variants: [(label: "a", dampers: [])]),"#.into(), "[(label", "analysis.variants", "vary `JointDamping"),
        (format!("{}\n{}", p(r#"BodyMass("pendulum")"#, "from: 1.0, to: 2.0, points: 400"), p("Rpm", "from: 500.0, to: 900.0, points: 400").replace("\"x\"", "\"y\"")), hbm.into(), "[\n                (name", "parameters", "160000 cases"),
    ];
    for (params, tail, needle, field, words) in cases {
        let (err, at) = located(&params, &tail, needle);
        assert!(err.starts_with(&at), "expected {at}… for {params}\n{tail}\ngot {err}");
        assert!(err.contains(&format!("(field `analyses[0].{field}`)")), "expected field {field}: {err}");
        assert!(err.contains(words), "expected {words:?}: {err}");
    }
}

#[test]
fn the_example_design_study_runs_complete() {
    let study = Study::from_file(std::path::Path::new("examples/design_study.ron")).unwrap();
    let tmp = out_dir("example");
    let out = tmp.path().to_path_buf();
    let report = run(&study, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
    assert!(report.failures.is_empty(), "{:?}", report.failures);
    assert_eq!(report.designs.len(), 2);
    assert_eq!(report.designs[0].cases.len(), 15);
    assert_eq!(report.designs[1].cases.len(), 24);
}

/// A mechanism like `examples/cpva.ron` with its numbers written in (no catalog parts): the
/// pendulum's mass, inertia and centre-of-mass radius, the pivot's radius, spring and damper.
fn cpva_text(m: f64, i_b: f64, l: f64, r: f64, k: f64, c: f64) -> String {
    format!(
        r#"Mechanism(
    name: "cpva",
    speeds: AbsoluteAngularVelocities,
    bodies: [
        Body(name: "rotor", mass: 110.0, com: (0.0, 0.0), inertia: 3.443504355127701),
        Body(name: "pendulum", mass: {m:?}, com: ({l:?}, 0.0), inertia: {i_b:?}),
    ],
    joints: [
        Joint(name: "spin", parent: "ground", child: "rotor", at: (0.0, 0.0)),
        Joint(name: "pivot", parent: "rotor", child: "pendulum", at: ({r:?}, 0.0), damper: {c:?},
              spring: (stiffness: {k:?}, free_angle: 0.0)),
    ],
    loads: [GroundDamper(body: "rotor", c: 5e-3)],
)
"#
    )
}

#[test]
fn every_quantity_substitutes_as_if_written_in_the_files() {
    // One case of every quantity against the same harmonic balance of a study whose files hold
    // these numbers: the substitution is checked by the loader's independent route.
    let tmp = out_dir("substitution");
    let dir = tmp.path().to_path_buf();
    std::fs::create_dir_all(&dir).unwrap();
    let (m, i_b, l, r, k, c, rpm, t_n) = (5.0, 2.0e-4, 0.016, 0.18, 0.5, 1e-3, 1200.0, 30.0);
    let base = cpva_text(6.0, 2.16e-4, 0.0152093650768, 0.17, 0.0, 5e-4);
    std::fs::write(dir.join("base.ron"), base).unwrap();
    std::fs::write(dir.join("written.ron"), cpva_text(m, i_b, l, r, k, c)).unwrap();
    let hbm = |rpm: f64, t: f64| {
        format!(r#"HarmonicBalance(name: "h", rpm: {rpm:?}, order_min: 2.8, order_max: 3.5, amplitudes: [{t:?}])"#)
    };
    let design = format!(
        r#"Study(name: "sub", mechanism: "base.ron", lock: ["pivot"], analyses: [DesignStudy(name: "d", parameters: [
            (name: "m", quantity: BodyMass("pendulum"), values: [{m:?}]),
            (name: "i", quantity: BodyInertia("pendulum"), values: [{i_b:?}]),
            (name: "l", quantity: BodyComRadius("pendulum"), values: [{l:?}]),
            (name: "r", quantity: JointRadius("pivot"), values: [{r:?}]),
            (name: "k", quantity: JointStiffness("pivot"), values: [{k:?}]),
            (name: "c", quantity: JointDamping("pivot"), values: [{c:?}]),
            (name: "rpm", quantity: Rpm, values: [{rpm:?}]),
            (name: "t", quantity: TorqueAmplitude, values: [{t_n:?}]),
        ], analysis: {})])"#,
        hbm(1000.0, 40.0)
    );
    let plain =
        format!(r#"Study(name: "plain", mechanism: "written.ron", lock: ["pivot"], analyses: [{}])"#, hbm(rpm, t_n));
    std::fs::write(dir.join("design.ron"), design).unwrap();
    std::fs::write(dir.join("plain.ron"), plain).unwrap();
    let opts = RunOptions { out: Some(dir.join("out")), progress: false };
    let d = run(&Study::from_file(&dir.join("design.ron")).unwrap(), &opts).unwrap();
    let p = run(&Study::from_file(&dir.join("plain.ron")).unwrap(), &opts).unwrap();
    assert!(d.failures.is_empty() && p.failures.is_empty(), "{:?} {:?}", d.failures, p.failures);
    let row = &d.designs[0].cases[0];
    let cols = &d.designs[0].results;
    let get = |name: &str| row.results[cols.iter().position(|c| c.name == name).unwrap()];
    let max = |f: &dyn Fn(&kanedyn::study::HbmBranch) -> Vec<f64>| p.hbm.iter().flat_map(f).fold(f64::NAN, f64::max);
    // The substituted centre of mass and joint point are L·(l/L) and R·(r/R): a rounding or two
    // away from the written l and r, so the branches agree to ~1e-13, not bit for bit; 1e-9 relative.
    let close =
        |a: f64, b: f64, what: &str| assert!(abs_diff_eq!(a, b, epsilon = 1e-9 * b.abs()), "{what}: {a} vs {b}");
    close(get("peak_accel_1x_rad_s2"), max(&|b| b.accel[0].clone()), "main order");
    close(get("peak_accel_2x_rad_s2"), max(&|b| b.accel[1].clone()), "second order");
    close(get("max_relative_angle_rad"), max(&|b| b.relative_angle.clone()), "relative angle");
    close(
        get("pivot_torque_peak_Nm"),
        max(&|b| b.elements.iter().filter_map(|e| e[0].torque.as_ref().map(|t| t.peak)).collect()),
        "pivot torque",
    );
    let mut folds: Vec<f64> = p.hbm.iter().flat_map(|b| b.folds.clone()).collect();
    folds.sort_by(f64::total_cmp);
    folds.dedup_by(|a, b| (*a - *b).abs() <= 1e-6 * a.abs());
    assert_eq!(get("folds"), folds.len() as f64);
    assert_eq!(get("points"), p.hbm.iter().map(|b| b.order.len()).sum::<usize>() as f64);
}

#[test]
fn order_and_speed_substitute_into_a_torque_continuation_bit_for_bit() {
    // The analysis's own numbers are assigned, not computed: the case equals the same analysis
    // written with them, bit for bit.
    let torque = |order: f64, rpm: f64| {
        format!(
            r#"HarmonicBalance(name: "h", rpm: {rpm:?}, parameter: Torque(order: {order:?}, min: 1.0, max: 120.0))"#
        )
    };
    let varied = load(&study_text(&format!(
        r#"        DesignStudy(name: "d", parameters: [
            (name: "n", quantity: Order, values: [3.05, 3.2]),
            (name: "rpm", quantity: Rpm, values: [900.0]),
        ], analysis: {}),"#,
        torque(3.0, 1000.0)
    )))
    .unwrap_or_else(|e| panic!("{e}"));
    let rows = design::run_cases(&varied, design(&varied), None, true, &|| {}).unwrap();
    for (row, order) in rows.iter().zip([3.05, 3.2]) {
        assert_eq!(row.status, CaseStatus::Ok, "{}", row.error);
        let plain = load(&study_text(&format!("        {},", torque(order, 900.0)))).unwrap();
        let tmp = out_dir(&format!("torque_{order}"));
        let out = tmp.path().to_path_buf();
        let p = run(&plain, &RunOptions { out: Some(out.clone()), progress: false }).unwrap();
        let peak = p.hbm.iter().flat_map(|b| b.accel[0].iter().copied()).fold(f64::NAN, f64::max);
        assert_eq!(row.results[0].to_bits(), peak.to_bits(), "order {order}");
    }
}

/// A pendulum's tuning order as a design quantity (issue 28, item 5): each case's n_t from the
/// linearisation at held spin (eigen-orders solved numerically, independent of the quadratic
/// in L that sets it) equals the requested order to 1e-10; an order beyond what the pendulum's
/// mass, inertia and pivot radius allow (n_t ≤ √(R / (2√(I/m))): 3.7639 here) fails its case with
/// the reason; the spin joint is refused at load.
#[test]
fn a_tuning_order_is_set_case_by_case() {
    let text = study_text(
        r#"        DesignStudy(
            name: "tuned",
            parameters: [(name: "n_t", quantity: TuningOrder("pivot"), values: [2.9, 3.0, 3.11, 3.3, 3.6, 3.8])],
            analysis: LinearResponse(name: "lin", rpm: 1000.0, from: 0.8, to: 1.3, points: 11),
        ),"#,
    );
    let study = load(&text).unwrap_or_else(|e| panic!("{e}"));
    let spec = design(&study);
    let rows = design::run_cases(&study, spec, None, true, &|| {}).unwrap();
    let cols = design::result_columns(&study, spec);
    let c_nt = cols.iter().position(|c| c.name == "n_t").unwrap();
    for r in &rows[..5] {
        assert_eq!(r.status, CaseStatus::Ok, "case {}: {}", r.index, r.error);
        let want = r.values[0];
        assert!(
            (r.results[c_nt] / want - 1.0).abs() <= 1e-10,
            "case {}: n_t {} against {want}",
            r.index,
            r.results[c_nt]
        );
    }
    assert_ne!(rows[5].status, CaseStatus::Ok);
    assert!(rows[5].error.contains("out of reach") && rows[5].error.contains("at most 3.7639"), "{}", rows[5].error);
    let bad = load(&text.replace("TuningOrder(\"pivot\")", "TuningOrder(\"spin\")")).expect_err("the spin joint");
    assert!(bad.to_string().contains("not a revolute pendulum"), "{bad}");
}

/// Four pendulums (`examples/cpva4.ron`) at 500 N·m, mistuned through their tuning orders:
/// - the zero spread (each at the file's 3.11) is the unmistuned mechanism bit for bit: its row
///   equals that of a case which only re-sets a mass to its own value;
/// - identical pendulums move alike (localisation index exactly 1 on the cyclic route, whose
///   members share the representative's coefficients), a mistuned one does not (> 1), and the
///   folds listed are the case's distinct folds.
#[test]
fn a_mistuned_set_reports_its_localisation_and_folds() {
    let text = |param: &str| {
        format!(
            r#"Study(name: "mistuned", mechanism: "cpva4.ron", spin_joint: "spin", response_body: "rotor",
    analyses: [DesignStudy(name: "d", parameters: [{param}],
        analysis: HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [500.0]))])"#
        )
    };
    let tuned = (1..=4)
        .map(|i| {
            format!(
                r#"(name: "n{i}", quantity: TuningOrder("pivot_{i}"), values: [3.11, {}])"#,
                if i == 1 { 3.08 } else { 3.11 }
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    let study = load(&text(&tuned)).unwrap_or_else(|e| panic!("{e}"));
    let spec = design(&study);
    let rows = design::run_cases(&study, spec, None, true, &|| {}).unwrap();
    let cols = design::result_columns(&study, spec);
    let col = |name: &str| cols.iter().position(|c| c.name == name).unwrap_or_else(|| panic!("{name}"));
    // The grid's first case is all 3.11, its last pivot_1 at 3.08 and the rest at 3.11.
    let (same, mistuned) = (&rows[0], &rows[rows.len() - 1]);
    assert_eq!(mistuned.values, [3.08, 3.11, 3.11, 3.11]);
    for r in [same, mistuned] {
        assert_eq!(r.status, CaseStatus::Ok, "case {}: {}", r.index, r.error);
    }
    let li = col("localisation_index");
    assert_eq!(same.results[li], 1.0);
    assert!(mistuned.results[li] > 1.01, "{}", mistuned.results[li]);
    let folds = same.results[col("folds")] as usize;
    let listed = [col("fold_1"), col("fold_2")].iter().filter(|&&c| same.results[c].is_finite()).count();
    assert_eq!(listed, folds.min(2));

    let mass = r#"(name: "m1", quantity: BodyMass("pendulum_1"), values: [1.5])"#;
    let plain = load(&text(mass)).unwrap_or_else(|e| panic!("{e}"));
    let plain_rows = design::run_cases(&plain, design(&plain), None, true, &|| {}).unwrap();
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&same.results), bits(&plain_rows[0].results));
}

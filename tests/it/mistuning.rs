//! Mistuning and tolerance studies (issue 28, item 5): where a mistuned set of absorbers leaves
//! unison against the identical set's branch points (from shooting, the README's figures), a
//! jump in unison told from a loss of unison by the critical motion, production spreads drawn
//! from a truncated normal (against its closed-form moments), the study's quantiles and
//! fractions, and the same report on one thread and on two.

use kanedyn::error::Error;
use kanedyn::io::Source;
use kanedyn::study::design::{self, CaseRow, CaseStatus, DesignSpec, case_values};
use kanedyn::study::{AnalysisSpec, LoadOptions, Study};
use statrs::distribution::{Continuous, ContinuousCDF, Normal};

/// The +1 points (symmetry breaking) of the two identical pendulums at 500 N·m and 1000 rpm, by
/// independent shooting (issue 26; README).
const PLUS_ONE: [f64; 2] = [3.08137, 3.09461];
/// The one-pendulum fold at 500 N·m (issue 26, shooting): the jump of the pair in unison.
const FOLD_500: f64 = 3.1015322;

fn load(text: &str) -> Result<Study, Error> {
    Study::from_source(Source::from_text("examples/mistuning_test.ron", text), &LoadOptions::default())
}

fn design(study: &Study) -> &DesignSpec {
    match &study.spec.analyses[0] {
        AnalysisSpec::DesignStudy(d) => d,
        other => panic!("not a design study: {}", other.kind()),
    }
}

/// A design study on `mechanism` (next to the examples) with `parameters`, `sampling` and the
/// harmonic balance at `torque` N·m over n 2.9–3.3 at 1000 rpm.
fn study(mechanism: &str, parameters: &str, sampling: &str, torque: f64) -> Study {
    let text = format!(
        r#"Study(name: "mistuning_test", mechanism: "{mechanism}",
    analyses: [DesignStudy(name: "d", parameters: [{parameters}], sampling: {sampling},
        analysis: HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [{torque:?}]))])"#
    );
    load(&text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

/// The rows of every case and a column reader.
fn run(study: &Study) -> (Vec<CaseRow>, impl Fn(&CaseRow, &str) -> f64) {
    let spec = design(study);
    let rows = design::run_cases(study, spec, None, true, &|| {}).unwrap();
    for r in &rows {
        assert_eq!(r.status, CaseStatus::Ok, "case {}: {}", r.index, r.error);
    }
    let cols = design::result_columns(study, spec);
    let col = move |r: &CaseRow, name: &str| {
        r.results[cols.iter().position(|c| c.name == name).unwrap_or_else(|| panic!("no column {name}"))]
    };
    (rows, col)
}

/// Two pendulums at 500 N·m: identical, they leave unison at their two +1 points and jump (in
/// unison) at the one-pendulum fold; with pivot_1's tuning raised by δ the first branch point
/// becomes a fold whose critical motion parts the pair (an imperfect pitchfork), which tends to
/// the +1 point as δ → 0 (like √δ: a hundredfold smaller δ brings it ten times nearer; asserted
/// with a factor 5 of margin).
#[test]
fn a_mistuned_pair_parts_at_a_fold_that_tends_to_the_identical_pairs_branch_point() {
    let n_t = 3.11;
    let values = [n_t, n_t * (1.0 + 1e-6), n_t * (1.0 + 1e-4)];
    let list = values.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(", ");
    let s = study(
        "cpva2.ron",
        &format!(r#"(name: "n1", quantity: TuningOrder("pivot_1"), values: [{list}])"#),
        "Grid",
        500.0,
    );
    let (rows, col) = run(&s);
    let same = &rows[0];
    for (k, at) in PLUS_ONE.iter().enumerate() {
        let v = col(same, &format!("unison_lost_{}", k + 1));
        assert!((v - at).abs() <= 1e-5, "identical pair: unison lost at {v}, shooting {at}");
        assert_eq!(v, col(same, &format!("branch_point_{}", k + 1)));
    }
    assert!((col(same, "fold_1") - FOLD_500).abs() <= 1e-6, "{}", col(same, "fold_1"));
    assert_eq!(col(same, "jumps_in_range"), 1.0);
    assert_eq!(col(same, "unison_losses_in_range"), 2.0);
    let shift: Vec<f64> = rows[1..]
        .iter()
        .map(|r| {
            assert!(col(r, "unison_losses_in_range") >= 1.0, "case {}: no loss of unison", r.index);
            (col(r, "unison_lost_1") - PLUS_ONE[0]).abs()
        })
        .collect();
    assert!(shift[0] < 1e-4 && shift[0] * 5.0 < shift[1], "shifts {shift:?} for δ = 1e-6, 1e-4");
    // At δ = 1e-4 the pair parts at a fold (no exact branch point is left), its only fold: a
    // jump and a loss of unison at once.
    let r = &rows[2];
    assert!(col(r, "branch_point_1").is_nan());
    assert_eq!(col(r, "fold_1"), col(r, "unison_lost_1"));
    assert_eq!((col(r, "jumps_in_range"), col(r, "unison_losses_in_range")), (1.0, 1.0));
}

/// At 40 N·m, well below the identical pair's unison-loss onset (163.2 N·m,
/// `examples/cpva_maps.ron`), a pair mistuned by 0.3 % jumps at two folds in unison and never
/// parts (every fold's critical motion keeps them together); the folds lie near the one pendulum's (2.9403761 and 3.1740911, shooting) moved by
/// about half the mistuning.
#[test]
fn at_40_nm_a_mistuned_pair_jumps_in_unison() {
    let s = study("cpva2.ron", r#"(name: "n1", quantity: TuningOrder("pivot_1"), values: [3.12])"#, "Grid", 40.0);
    let (rows, col) = run(&s);
    let r = &rows[0];
    assert_eq!(col(r, "jumps_in_range"), 2.0);
    assert_eq!(col(r, "unison_losses_in_range"), 0.0);
    assert!(col(r, "unison_lost_1").is_nan());
    for (k, at) in [2.9403761, 3.1740911].iter().enumerate() {
        let f = col(r, &format!("fold_{}", k + 1));
        // The pair's mean tuning is 0.16 % (0.005 in order) above the one pendulum's; 0.01 allows
        // for the fold's own amplitude dependence.
        assert!((f - at).abs() < 0.01, "fold {f} against {at}");
    }
}

/// Quantiles by definition 7 are order statistics when (n − 1)p is whole: with 101 cases the 5 %,
/// 50 % and 95 % quantiles are the 6th, 51st and 96th smallest values; the fractions count the
/// rows; and the whole report is the same on one thread and on two, bit for bit.
#[test]
fn quantiles_fractions_and_threads() {
    let params = (1..=4)
        .map(|i| format!(r#"(name: "n{i}", quantity: TuningOrder("pivot_{i}"), from: 3.0789, to: 3.1411)"#))
        .collect::<Vec<_>>()
        .join(", ");
    let s = study("cpva4.ron", &params, "MonteCarlo(n: 101, seed: 11)", 500.0);
    let spec = design(&s);
    let pool = |n: usize| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
    let one = pool(1).install(|| design::run_cases(&s, spec, None, true, &|| {}).unwrap());
    let two = pool(2).install(|| design::run_cases(&s, spec, None, true, &|| {}).unwrap());
    let bits = |rows: &[CaseRow]| rows.iter().flat_map(|r| r.results.iter().map(|v| v.to_bits())).collect::<Vec<_>>();
    assert_eq!(bits(&one), bits(&two));
    let r = design::result(&s, spec, two);
    let f = design::findings(&r);
    for (k, q) in f.quantiles.iter().enumerate() {
        let mut v: Vec<f64> = r.cases.iter().map(|c| c.results[k]).filter(|x| x.is_finite()).collect();
        v.sort_by(f64::total_cmp);
        assert_eq!(q.values, v.len());
        if v.len() == 101 {
            assert_eq!([q.min, q.p05, q.p50, q.p95, q.max], [v[0], v[5], v[50], v[95], v[100]], "{}", q.name);
        }
    }
    let col = |name: &str| r.results.iter().position(|c| c.name == name).unwrap();
    let share = |k: usize| r.cases.iter().filter(|c| c.results[k] > 0.0).count() as f64 / 101.0;
    assert_eq!(f.jump_fraction, Some(share(col("jumps_in_range"))));
    assert_eq!(f.unison_loss_fraction, Some(share(col("unison_losses_in_range"))));
    // ±1 % at 500 N·m is beyond unison for every draw: the set parts in each case.
    assert_eq!(f.unison_loss_fraction, Some(1.0));
}

/// A truncated normal spread: Monte Carlo draws have the closed-form mean and standard deviation
/// of the truncated distribution (4000 draws: the mean to 4 standard errors, the sd to 5 %), stay
/// inside the limits, and a Latin hypercube puts one draw in each equally probable stratum.
#[test]
fn a_normal_spread_is_drawn_truncated_to_its_limits() {
    let (mean, sd, a, b) = (3.11, 0.0104, 3.0893, 3.1411);
    let text = |sampling: &str| {
        format!(
            r#"Study(name: "spread", mechanism: "cpva.ron", lock: ["pivot"],
    analyses: [DesignStudy(name: "d", sampling: {sampling},
        parameters: [(name: "n", quantity: TuningOrder("pivot"), from: {a:?}, to: {b:?}, distribution: Normal(mean: {mean:?}, sd: {sd:?}))],
        analysis: LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.2, points: 11))])"#
        )
    };
    let n = 4000;
    let s = load(&text(&format!("MonteCarlo(n: {n}, seed: 3)"))).unwrap_or_else(|e| panic!("{e}"));
    let v: Vec<f64> = case_values(design(&s)).into_iter().map(|r| r[0]).collect();
    assert!(v.iter().all(|x| (a..=b).contains(x)));
    let z = Normal::new(0.0, 1.0).unwrap();
    let (al, be) = ((a - mean) / sd, (b - mean) / sd);
    let mass = z.cdf(be) - z.cdf(al);
    let d = (z.pdf(al) - z.pdf(be)) / mass;
    let t_mean = mean + sd * d;
    let t_sd = sd * (1.0 + (al * z.pdf(al) - be * z.pdf(be)) / mass - d * d).sqrt();
    let m = v.iter().sum::<f64>() / n as f64;
    let s_sd = (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
    assert!((m - t_mean).abs() < 4.0 * t_sd / (n as f64).sqrt(), "mean {m} against {t_mean}");
    assert!((s_sd / t_sd - 1.0).abs() < 0.05, "sd {s_sd} against {t_sd}");

    let k = 50;
    let s = load(&text(&format!("LatinHypercube(n: {k}, seed: 5)"))).unwrap_or_else(|e| panic!("{e}"));
    let mut strata: Vec<usize> = case_values(design(&s))
        .into_iter()
        .map(|r| (((z.cdf((r[0] - mean) / sd) - z.cdf(al)) / mass * k as f64) as usize).min(k - 1))
        .collect();
    strata.sort();
    assert_eq!(strata, (0..k).collect::<Vec<_>>());
}

/// Bad spreads and operating ranges are refused at their field.
#[test]
fn bad_spreads_are_located() {
    let hbm =
        r#"analysis: HarmonicBalance(name: "h", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [40.0])"#;
    let lin = r#"analysis: LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.2, points: 11)"#;
    let cases = [
        (
            "from: 3.0, to: 3.2, distribution: Normal(mean: 3.1, sd: 0.01)",
            "Grid",
            hbm,
            "",
            "distribution",
            "a grid takes",
        ),
        (
            "from: 3.0, to: 3.2, distribution: Normal(mean: 3.1, sd: 0.0)",
            "MonteCarlo(n: 5, seed: 1)",
            hbm,
            "",
            "distribution.sd",
            "sd > 0",
        ),
        (
            "from: 3.0, to: 3.2, distribution: Normal(mean: 3.3, sd: 0.01)",
            "MonteCarlo(n: 5, seed: 1)",
            hbm,
            "",
            "distribution.mean",
            "outside",
        ),
        (
            "from: -0.1, to: 3.2, distribution: Normal(mean: 3.1, sd: 0.01)",
            "MonteCarlo(n: 5, seed: 1)",
            hbm,
            "",
            "from",
            "0 < order",
        ),
        ("from: 3.0, to: 3.2", "MonteCarlo(n: 5, seed: 1)", hbm, "operating: (3.2, 3.0), ", "operating", "from < to"),
        (
            "from: 3.0, to: 3.2",
            "MonteCarlo(n: 5, seed: 1)",
            lin,
            "operating: (3.0, 3.2), ",
            "operating",
            "harmonic balance",
        ),
    ];
    for (range, sampling, analysis, extra, field, words) in cases {
        let text = format!(
            r#"Study(name: "bad", mechanism: "cpva.ron", lock: ["pivot"],
    analyses: [DesignStudy(name: "d", sampling: {sampling}, {extra}
        parameters: [(name: "n", quantity: TuningOrder("pivot"), {range})],
        {analysis})])"#
        );
        let err = load(&text).err().unwrap_or_else(|| panic!("loaded:\n{text}")).to_string();
        assert!(err.starts_with("examples/mistuning_test.ron:"), "{err}");
        assert!(
            err.contains(&format!("(field `analyses[0].{field}`)"))
                || err.contains(&format!("parameters[0].{field}`)")),
            "expected {field}: {err}"
        );
        assert!(err.contains(words), "expected {words:?}: {err}");
    }
}

/// A design study of another mechanism than the study's (`mechanism:`) gives the rows the same
/// design study gives in a study of that mechanism, bit for bit; its errors are located in the
/// study file at the design study's fields.
#[test]
fn a_design_study_of_its_own_mechanism_equals_one_in_that_mechanisms_study() {
    let design = |own: &str| {
        format!(
            r#"DesignStudy(name: "d", {own}sampling: MonteCarlo(n: 3, seed: 9),
            parameters: [(name: "n1", quantity: TuningOrder("pivot_1"), from: 3.0789, to: 3.1411)],
            analysis: HarmonicBalance(name: "hbm", rpm: 1000.0, order_min: 2.9, order_max: 3.3, amplitudes: [100.0]))"#
        )
    };
    let study_of = |mech: &str, own: &str| {
        load(&format!(r#"Study(name: "own", mechanism: "{mech}", lock: ["pivot"], analyses: [{}])"#, design(own)))
    };
    let home = load(&format!(r#"Study(name: "home", mechanism: "cpva4.ron", analyses: [{}])"#, design("")))
        .unwrap_or_else(|e| panic!("{e}"));
    let away = study_of("cpva.ron", r#"mechanism: "cpva4.ron", "#).unwrap_or_else(|e| panic!("{e}"));
    let rows = |s: &Study| {
        let (s, d) = design::find(s, "d").unwrap();
        design::run_cases(s, d, None, false, &|| {}).unwrap()
    };
    let bits = |rows: &[CaseRow]| rows.iter().flat_map(|r| r.results.iter().map(|v| v.to_bits())).collect::<Vec<_>>();
    let (a, b) = (rows(&home), rows(&away));
    assert_eq!(a.len(), 3);
    assert_eq!(bits(&a), bits(&b));
    // pivot_1 is not a joint of the study's own mechanism: refused without `mechanism`, and a
    // joint the other mechanism lacks is located at the parameter's field.
    let err = study_of("cpva.ron", "").err().unwrap().to_string();
    assert!(err.contains("analyses[0].parameters[0].quantity") && err.contains("unknown joint `pivot_1`"), "{err}");
    let err = study_of("cpva.ron", r#"mechanism: "cpva2.ron", lock: ["pivot_3"], "#).err().unwrap().to_string();
    assert!(err.contains("(field `analyses[0].lock[0]`)") && err.contains("unknown joint `pivot_3`"), "{err}");
    let err = study_of("cpva.ron", r#"lock: ["pivot"], "#).err().unwrap().to_string();
    assert!(err.contains("(field `analyses[0].lock`)") && err.contains("own `mechanism`"), "{err}");
}

/// At held spin the absorbers do not couple (the rotor cannot move), so each eigen-order of a
/// mistuned set is its own absorber's tuning order: the orders of the held-spin undamped modes
/// equal the requested n_t,i to 1e-10.
#[test]
fn at_held_spin_each_eigen_order_is_its_absorbers_tuning_order() {
    use kanedyn::linear::{Damping, LinearModel, Spin};
    let params = (1..=4)
        .map(|i| format!(r#"(name: "n{i}", quantity: TuningOrder("pivot_{i}"), from: 3.0789, to: 3.1411)"#))
        .collect::<Vec<_>>()
        .join(", ");
    let s = study("cpva4.ron", &params, "MonteCarlo(n: 5, seed: 21)", 500.0);
    let spec = design(&s);
    for values in case_values(spec) {
        let (case, _) = design::substitute(&s, spec, &values).unwrap_or_else(|e| panic!("{e}"));
        let lm = LinearModel::new(&case.mechanism, "spin", 1000.0 * std::f64::consts::PI / 30.0, None).unwrap();
        let mut orders: Vec<f64> = lm
            .modes(Spin::Held, Damping::Undamped)
            .unwrap()
            .modes
            .iter()
            .map(|m| m.order)
            .filter(|o| o.is_finite() && *o > 0.0)
            .collect();
        orders.sort_by(f64::total_cmp);
        let mut want = values.clone();
        want.sort_by(f64::total_cmp);
        assert_eq!(orders.len(), 4, "{orders:?}");
        for (o, n) in orders.iter().zip(&want) {
            assert!((o - n).abs() <= 1e-10, "eigen-order {o} against n_t {n}");
        }
    }
}

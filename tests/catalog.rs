//! Every catalog part and example mechanism loads, and the example files describe the same
//! system as the CPVA builder.

use kanedyn::cpva::CpvaParams;
use kanedyn::io::Source;
use kanedyn::kane::Kane;
use kanedyn::model::body::BodySpec;
use kanedyn::model::joint::JointSpec;
use kanedyn::model::mechanism::Mechanism;
use std::path::Path;

fn ron_files(dir: &str) -> Vec<std::path::PathBuf> {
    let d = Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut v: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    v.sort();
    v
}

#[test]
fn every_catalog_part_parses() {
    let bodies = ron_files("examples/bodies");
    let joints = ron_files("examples/joints");
    assert!(bodies.len() >= 3 && joints.len() >= 2);
    for p in bodies {
        let src = Source::read(&p).unwrap();
        let spec: BodySpec = src.parse().unwrap_or_else(|e| panic!("{e}"));
        // Mass properties given directly or computed from a shape with its density.
        spec.check_numbers(&src, "").unwrap_or_else(|e| panic!("{e}"));
        let props = spec.inertia_props(&src, "").unwrap_or_else(|e| panic!("{e}"));
        assert!(props.mass > 0.0 || props.i_com > 0.0, "{}", p.display());
    }
    for p in joints {
        let _: JointSpec = Source::read(&p).unwrap().parse().unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn every_example_mechanism_loads() {
    let mut n = 0;
    for p in ron_files("examples") {
        let text = std::fs::read_to_string(&p).unwrap();
        if text.trim_start_matches(|c: char| c.is_whitespace()).lines().any(|l| l.starts_with("Mechanism(")) {
            let m = Mechanism::from_file(&p).unwrap_or_else(|e| panic!("{e}"));
            Kane::new(&m).unwrap();
            n += 1;
        }
    }
    assert!(n >= 3, "expected at least the three example mechanisms, found {n}");
}

#[test]
fn example_files_equal_the_builder() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (file, n_pend) in [("examples/cpva.ron", 1), ("examples/cpva4.ron", 4)] {
        let from_file = Mechanism::from_file(&root.join(file)).unwrap();
        let p = CpvaParams::canonical().with_pendulums(n_pend);
        let exc = from_file.loads.joint_torques[0].excitation.clone();
        let built = p.mechanism(Some(exc)).unwrap();
        let (mut a, mut b) = (Kane::new(&from_file).unwrap(), Kane::new(&built).unwrap());
        let n = n_pend + 1;
        let x: Vec<f64> = (0..2 * n).map(|i| if i < n { 0.4 * i as f64 - 0.3 } else { 100.0 + i as f64 }).collect();
        let (mut da, mut db) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
        a.rhs(1.7, &x, &mut da).unwrap();
        b.rhs(1.7, &x, &mut db).unwrap();
        for i in 0..2 * n {
            // The files round the pivot positions' 1e-17 m residues of cos(π/2) to 0.
            assert!((da[i] - db[i]).abs() <= 1e-10 * db[i].abs().max(1.0), "{file}[{i}]: {} vs {}", da[i], db[i]);
        }
    }
}

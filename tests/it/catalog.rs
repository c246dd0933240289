//! Every catalog part and example mechanism loads, and the example files describe the same
//! system as the CPVA builder.

use approx::abs_diff_eq;
use kanedyn::cpva::CpvaParams;
use kanedyn::io::Source;
use kanedyn::kane::Kane;
use kanedyn::model::body::BodySpec;
use kanedyn::model::joint::JointSpec;
use kanedyn::model::mechanism::Mechanism;
use std::path::Path;

use crate::support::scratch;

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
    let bodies = ron_files("bodies");
    let joints = ron_files("joints");
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
            assert!(
                abs_diff_eq!(da[i], db[i], epsilon = 1e-10 * db[i].abs().max(1.0)),
                "{file}[{i}]: {} vs {}",
                da[i],
                db[i]
            );
        }
    }
}

/// The shipped catalog compiled into the library is exactly the top-level `bodies/` and
/// `joints/` folders, file for file and byte for byte.
#[test]
fn the_embedded_catalog_is_the_top_level_folders() {
    use kanedyn::io::catalog::PARTS;
    let mut on_disk: Vec<String> = ["bodies", "joints"]
        .iter()
        .flat_map(|d| {
            ron_files(d).into_iter().map(move |p| format!("{d}/{}", p.file_name().unwrap().to_str().unwrap()))
        })
        .collect();
    on_disk.sort();
    let embedded: Vec<String> = PARTS.iter().map(|(n, _)| n.to_string()).collect();
    assert_eq!(embedded, on_disk, "src/io/catalog.rs's PARTS must list every part of bodies/ and joints/");
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (name, text) in PARTS {
        assert_eq!(*text, std::fs::read_to_string(root.join(name)).unwrap(), "{name}");
    }
    assert!(on_disk.iter().filter(|n| n.starts_with("bodies/")).count() >= 3);
    assert!(on_disk.iter().filter(|n| n.starts_with("joints/")).count() >= 3);
}

/// A mechanism in a folder with no parts of its own builds from `catalog:` names (the parts
/// never touch the disk), equals the example that names the same parts, and a catalog name that
/// does not exist is a located error listing the parts there are.
#[test]
fn catalog_parts_load_from_anywhere_and_unknown_ones_are_located() {
    let tmp = scratch("catalog");
    let dir = tmp.path();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(root.join("examples/cpva.ron")).unwrap();
    assert!(text.contains("part: \"catalog:bodies/flywheel_rotor.ron\""));
    std::fs::write(dir.join("alone.ron"), &text).unwrap();
    let mut alone = Mechanism::from_file(&dir.join("alone.ron")).unwrap();
    let example = Mechanism::from_file(&root.join("examples/cpva.ron")).unwrap();
    alone.file = example.file.clone();
    assert_eq!(alone, example);
    // Unknown part: the error names the mechanism file, line:column, field and the catalog.
    let bad = text.replace("catalog:bodies/cpva_pendulum.ron", "catalog:bodies/cpva_pendulm.ron");
    std::fs::write(dir.join("bad.ron"), &bad).unwrap();
    let e = format!("{:#}", Mechanism::from_file(&dir.join("bad.ron")).unwrap_err());
    assert!(e.contains("bad.ron:9:") && e.contains("bodies[1].part"), "{e}");
    assert!(e.contains("no part `bodies/cpva_pendulm.ron` in the shipped catalog"), "{e}");
    assert!(e.contains("bodies/cpva_pendulum.ron"), "{e}");
}

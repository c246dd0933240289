//! Issue 49, item 2: the OpenTorsion importer never panics or aborts, whatever the file.
//!
//! Seeded random files of both forms kanedyn imports, each drawn whole from its seed (so a
//! failure names the seed and case and replays alone): the node form (`shafts`, `disks`,
//! `gears`) with node indices from small to 2^64 − 1, numbers from 0 to 1e300 of either sign,
//! parents that are and are not there; and TORS files of 1 to 6 components of every element
//! type (and unknown ones), fields present or missing, names with newlines, quotes and dots,
//! connections that chain, loop, repeat or name nothing, and now and then a chain of 2,000
//! components. A quarter of the files then have a span of bytes deleted, repeated or replaced.
//! Each is converted (`convert`), and what converts is loaded as a mechanism; both under
//! `catch_unwind`. An abort (allocation, stack) ends the test process, so a finished run is 0
//! aborts; the panics are counted and must be 0.
//!
//! `importer_fuzz_300` runs 300 files of each form in the normal suite; `importer_fuzz_10000`
//! (ignored: `cargo test --release --test it importer_fuzz_10000 -- --ignored --nocapture`)
//! runs 10,000 of each and prints the counts.

use kanedyn::io::{ReadPolicy, Source};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::opentorsion::convert;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::fmt::Write as _;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

/// A node index: mostly small, sometimes one of the crash values or another extreme.
fn node(rng: &mut StdRng) -> String {
    const HUGE: [&str; 8] = [
        "18446744073709551615",
        "9223372036854775808",
        "1000000000000",
        "4294967296",
        "18446744073709551614",
        "12301",
        "-1",
        "1e12",
    ];
    if rng.random_bool(0.95) {
        rng.random_range(0..3usize).to_string()
    } else {
        HUGE[rng.random_range(0..HUGE.len())].into()
    }
}

/// A number as JSON text: ordinary values, zero, negative, tiny, huge, out of range.
fn number(rng: &mut StdRng) -> String {
    const ODD: [&str; 9] = ["0", "-1.5", "1e300", "-1e300", "5e-324", "1e999", "0.0", "-0", "\"7\""];
    if rng.random_bool(0.93) {
        format!("{:?}", rng.random_range(0.01..1.0e5))
    } else {
        ODD[rng.random_range(0..ODD.len())].into()
    }
}

/// A name: plain, or with a newline, quote, dot, angle bracket or backslash.
fn name(rng: &mut StdRng, plain: &str) -> String {
    const ODD: [&str; 7] = ["\\n", "\\\"", ".", "<x>", "\\\\", "\\u0000", ""];
    if rng.random_bool(0.8) { plain.into() } else { format!("{plain}{}", ODD[rng.random_range(0..ODD.len())]) }
}

/// `"key": value` for each field kept (each is dropped with probability 0.03).
fn fields(rng: &mut StdRng, all: &[(&str, String)]) -> String {
    let kept: Vec<String> =
        all.iter().filter(|_| rng.random_bool(0.97)).map(|(k, v)| format!("\"{k}\": {v}")).collect();
    format!("{{{}}}", kept.join(", "))
}

fn node_form(rng: &mut StdRng) -> String {
    let mut lists = Vec::new();
    let shafts: Vec<String> = (0..rng.random_range(0..4))
        .map(|_| {
            let all =
                [("nl", node(rng)), ("nr", node(rng)), ("k", number(rng)), ("c", number(rng)), ("mass", number(rng))];
            fields(rng, &all)
        })
        .collect();
    lists.push(format!("\"shafts\": [{}]", shafts.join(", ")));
    let disks: Vec<String> = (0..rng.random_range(0..4))
        .map(|_| {
            let all = [("node", node(rng)), ("inertia", number(rng)), ("c", number(rng)), ("k", number(rng))];
            fields(rng, &all)
        })
        .collect();
    lists.push(format!("\"disks\": [{}]", disks.join(", ")));
    let gears: Vec<String> = (0..rng.random_range(0..3))
        .map(|_| {
            let parent = if rng.random_bool(0.5) { node(rng) } else { "null".into() };
            let all = [("node", node(rng)), ("inertia", number(rng)), ("radius", number(rng)), ("parent", parent)];
            fields(rng, &all)
        })
        .collect();
    lists.push(format!("\"gears\": [{}]", gears.join(", ")));
    lists.retain(|_| rng.random_bool(0.9));
    format!("{{{}}}", lists.join(",\n"))
}

fn component_form(rng: &mut StdRng) -> String {
    const KINDS: [&str; 5] = ["Disk", "ShaftDiscrete", "ShaftContinuous", "GearElement", "Spring"];
    // Now and then a long chain: the walk over the connections must not recurse.
    let chain = rng.random_bool(0.02);
    let components = if chain { 2000 } else { rng.random_range(1..7) };
    let mut names: Vec<(String, Vec<String>)> = Vec::new();
    let mut text = String::from("{\"components\": [\n");
    for c in 0..components {
        let comp = name(rng, &format!("c{c}"));
        let mut elements = Vec::new();
        let mut element_names = Vec::new();
        for e in 0..rng.random_range(if chain { 1..3 } else { 0..6 }) {
            let kind = KINDS[rng.random_range(0..if chain { 2 } else { KINDS.len() })];
            let el = name(rng, &format!("e{e}"));
            let mut all = vec![("name", format!("\"{el}\"")), ("type", format!("\"{kind}\""))];
            for field in
                ["inertia", "damping", "stiffness", "length", "outerDiameter", "innerDiameter", "teeth", "diameter"]
            {
                if rng.random_bool(0.5) {
                    all.push((field, number(rng)));
                }
            }
            if rng.random_bool(0.3) && !element_names.is_empty() {
                let p: &String = &element_names[rng.random_range(0..element_names.len())];
                all.push(("parent", format!("\"{p}\"")));
            }
            if rng.random_bool(0.1) {
                all.push(("excitation", "{\"x\": [1, 2]}".into()));
            }
            elements.push(fields(rng, &all));
            element_names.push(el);
        }
        let _ = writeln!(
            text,
            "  {{\"name\": \"{comp}\", \"elements\": [{}]}}{}",
            elements.join(", "),
            if c + 1 < components { "," } else { "" }
        );
        names.push((comp, element_names));
    }
    text += "]";
    let pick = |rng: &mut StdRng, names: &[(String, Vec<String>)]| {
        let (c, els) = &names[rng.random_range(0..names.len())];
        let e = if els.is_empty() || rng.random_bool(0.05) {
            "nope".to_string()
        } else {
            els[rng.random_range(0..els.len())].clone()
        };
        format!("{c}.{e}")
    };
    let links: Vec<String> = if chain {
        (1..components)
            .filter(|&c| !names[c - 1].1.is_empty())
            .map(|c| format!("[\"{}.{}\", \"{}.x\"]", names[c - 1].0, names[c - 1].1[0], names[c].0))
            .collect()
    } else {
        (0..rng.random_range(0..components + 2))
            .map(|_| format!("[\"{}\", \"{}\"]", pick(rng, &names), pick(rng, &names)))
            .collect()
    };
    if !links.is_empty() || rng.random_bool(0.5) {
        let _ = write!(text, ",\n\"structure\": [{}]", links.join(", "));
    }
    text + "}"
}

/// A quarter of the files: a span of bytes deleted, repeated or replaced by random ones (the
/// text may stop being UTF-8 there; it is read back lossily, as a file would be refused or read).
fn mutate(rng: &mut StdRng, text: String) -> String {
    if text.is_empty() || rng.random_bool(0.75) {
        return text;
    }
    let mut bytes = text.into_bytes();
    let a = rng.random_range(0..bytes.len());
    let b = (a + rng.random_range(1..16)).min(bytes.len());
    match rng.random_range(0..3) {
        0 => {
            bytes.drain(a..b);
        }
        1 => {
            let span = bytes[a..b].to_vec();
            for _ in 0..rng.random_range(1..50) {
                bytes.splice(a..a, span.iter().copied());
            }
        }
        _ => bytes[a..b].iter_mut().for_each(|x| *x = rng.random_range(0x20..0x7f)),
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

#[derive(Debug, Default)]
struct Counts {
    files: usize,
    converted: usize,
    loaded: usize,
    panics: Vec<String>,
}

fn fuzz(form: fn(&mut StdRng) -> String, cases: u64, seed: u64) -> Counts {
    let mut counts = Counts::default();
    for case in 0..cases {
        let mut rng = StdRng::seed_from_u64(seed.wrapping_mul(1_000_003).wrapping_add(case));
        let text = form(&mut rng);
        let text = mutate(&mut rng, text);
        counts.files += 1;
        let converted = catch_unwind(AssertUnwindSafe(|| convert(Path::new("fuzz.json"), &text, "fuzz")));
        let ron = match converted {
            Err(_) => {
                counts.panics.push(format!("seed {seed} case {case}: convert panicked on\n{text}"));
                continue;
            }
            Ok(Err(_)) => continue,
            Ok(Ok(ron)) => ron,
        };
        counts.converted += 1;
        let loaded = catch_unwind(AssertUnwindSafe(|| {
            Mechanism::from_source(&Source::from_text("fuzz.ron", &ron), &ReadPolicy::within(Path::new(""))).is_ok()
        }));
        match loaded {
            Err(_) => counts.panics.push(format!("seed {seed} case {case}: loading the RON panicked on\n{ron}")),
            Ok(ok) => counts.loaded += usize::from(ok),
        }
    }
    counts
}

fn check(cases: u64, seed: u64) {
    for (form, what) in [(node_form as fn(&mut StdRng) -> String, "node form"), (component_form, "component form")] {
        let counts = fuzz(form, cases, seed);
        eprintln!(
            "importer fuzz, {what}, seed {seed}: {} files, {} converted, {} of them loaded, {} panics",
            counts.files,
            counts.converted,
            counts.loaded,
            counts.panics.len()
        );
        assert_eq!(counts.files as u64, cases);
        assert!(counts.panics.is_empty(), "{}", counts.panics[0]);
        // The generator reaches the converter's far side too: some files of each form are whole
        // assemblies (a fuzzer whose every file fails to parse tests only the parser).
        assert!(counts.converted > 0 && counts.loaded > 0, "{what}: {counts:?}");
    }
}

#[test]
fn importer_fuzz_300() {
    check(300, 49);
}

#[test]
#[ignore = "10,000 files of each form, about a minute: run with --ignored"]
fn importer_fuzz_10000() {
    check(10_000, 4949);
}

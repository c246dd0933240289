//! Issue 25, item 7 (whole runs): a seeded fuzzer that runs whole studies, not only loads them.
//! Each execution fills a five-analysis study (linear response, Campbell diagram, order sweep,
//! harmonic-balance branch, free oscillation on the paper's CPVA) with numbers drawn from a pool of ordinary and hostile values, loads it
//! and, when it loads, runs it with a tight watchdog (3 × plan + 1 s) and the CPU limit at 60 s (the
//! harmonic-balance plan bounds a branch by its 2000-point cap, so 5 s would refuse nearly all).
//! A sixth analysis compares two mechanisms' free oscillations (`Compare`), whose overlay figure
//! and table draw on every member's result, or on none when all were stopped.
//! Every execution must end in a located load error or a run that returns within the watchdog's
//! budget (3 × its plan, plus 1 s for each analysis the watchdog stopped and 1.5 s for the rest
//! and the files, as CPU time measured in-process: the short and long tests are never run
//! together). Every file in the output folder, whatever its type (CSV, JSON, Markdown, SVG,
//! HTML), is read and must hold no NaN or infinity as a word of its own, and every file the run
//! lists is listed once and is in the folder. A run whose dynamics the plan cannot see is
//! stopped by the watchdog.
//!
//! The short version (40 executions) runs with the normal tests; the long one is
//! `cargo test --release --test fuzz_runs long -- --ignored --nocapture` (2000 executions, or
//! `KANEDYN_FUZZ_EXECUTIONS`). Replay one execution
//! with `KANEDYN_FUZZ_SEED=<seed> KANEDYN_FUZZ_ONLY=<iteration>`.

#[path = "it/support/examples.rs"]
mod examples;

use examples::copy_dir;
use kanedyn::study::{Limits, Watchdog};
use kanedyn::study::{LoadOptions, RunOptions, Study, run};
use std::path::Path;
use std::time::Instant;

/// xorshift64*: a small, seeded, replayable stream.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn pick<'a>(&mut self, v: &[&'a str]) -> &'a str {
        v[(self.next() % v.len() as u64) as usize]
    }
}

/// Values for a float field: mostly sensible, some hostile.
const FLOATS: &[&str] = &[
    "0.0", "-1.0", "1e-300", "1e300", "NaN", "inf", "-inf", "1e-6", "1e6", "0.5", "2.9", "3.3", "1000.0", "20.0", "1e9",
];

/// CPU time of this process so far, s (user + system, from /proc/self/stat; 10 ms ticks): a
/// measure a loaded machine does not inflate the way it does wall time.
fn cpu_s() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap();
    let rest = &stat[stat.rfind(')').unwrap() + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    (f[11].parse::<f64>().unwrap() + f[12].parse::<f64>().unwrap()) / 100.0
}

/// Whether `text` holds NaN or an infinity as a word of its own.
fn non_finite_word(text: &str) -> bool {
    text.split(|c: char| !(c.is_ascii_alphanumeric() || c == '-' || c == '.' || c == '+'))
        .map(|w| w.trim_start_matches(['-', '+']).to_ascii_lowercase())
        .any(|w| w == "nan" || w == "inf" || w == "infinity")
}

/// Every file under `dir`, at any depth (the run's whole output, not only the files it lists).
fn files_under(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for entry in std::fs::read_dir(&d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() { todo.push(p) } else { out.push(p) }
        }
    }
    out
}

/// The study of execution `i`: each number from the pool or its usual value.
fn study_text(rng: &mut Rng) -> String {
    let mut f = |usual: &'static str| if rng.next().is_multiple_of(16) { rng.pick(FLOATS) } else { usual };
    let (rtol, fs, rpm, from, to) = (f("1e-9"), f("2000.0"), f("1000.0"), f("0.9"), f("1.2"));
    let (rpm2, omin, omax, dur, amp) = (f("2000.0"), f("2.9"), f("3.3"), f("20.0"), f("40.0"));
    let points = ["11", "11", "11", "31", "2", "0", "1000000", "11"][(rng.next() % 8) as usize];
    let harmonics = ["10", "10", "10", "5", "1", "0", "64", "65"][(rng.next() % 8) as usize];
    let mut g = |usual: &'static str| if rng.next().is_multiple_of(16) { rng.pick(FLOATS) } else { usual };
    let (swing, hamp) = (g("0.5"), g("40.0"));
    format!(
        "Study(name: \"f\", mechanism: \"cpva.ron\", lock: [\"pivot\"], integration: (rtol: {rtol}, sample_hz: {fs}),\n\
         analyses: [\n\
         LinearResponse(name: \"l\", rpm: {rpm}, from: {from}, to: {to}, points: {points}),\n\
         Campbell(name: \"c\", rpm_min: 0.0, rpm_max: {rpm2}, points: {points}),\n\
         OrderSweep(name: \"s\", rpm: {rpm}, order_min: {omin}, order_max: {omax}, duration_s: {dur}, amplitudes: [{amp}], directions: [Up]),\n\
         HarmonicBalance(name: \"h\", rpm: {rpm}, order_min: {omin}, order_max: {omax}, amplitudes: [{hamp}], harmonics: {harmonics}),\n\
         FreeOscillation(name: \"o\", rpm: {rpm}, joint: \"pivot\", amplitudes: [0.1, {swing}]),\n\
         Compare(name: \"k\", mechanisms: [(label: \"a\", mechanism: \"cpva.ron\"), (label: \"b\", mechanism: \"cpva.ron\")],\n\
           analyses: [FreeOscillation(name: \"o\", rpm: {rpm2}, joint: \"pivot\", amplitudes: [{swing}, 0.2])]),\n\
         ])\n"
    )
}

fn fuzz(seed: u64, executions: usize) {
    let tmp = tempfile::Builder::new().prefix(&format!("kanedyn-fuzz-runs-{seed}-")).tempdir().unwrap();
    let root = tmp.path();
    copy_dir(Path::new("examples"), root);
    let only: Option<usize> = std::env::var("KANEDYN_FUZZ_ONLY").ok().and_then(|v| v.parse().ok());
    let limits = Limits { max_cpu_s: 60.0, watchdog: Watchdog { factor: 3.0, floor_s: 1.0 }, ..Limits::default() };
    let opts = LoadOptions { limits, ..LoadOptions::default() };
    let (mut refused, mut ran, mut watchdog, mut slowest, mut scanned) = (0, 0, 0, 0.0_f64, 0);
    for i in 0..executions {
        let mut rng = Rng(seed.wrapping_add(i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1);
        let text = study_text(&mut rng);
        if only.is_some_and(|o| o != i) {
            continue;
        }
        let path = root.join("f.ron");
        std::fs::write(&path, &text).unwrap();
        let study = match Study::from_file_with(&path, &opts) {
            Ok(s) => s,
            Err(e) => {
                let e = e.to_string();
                assert!(e.contains("f.ron:") && e.contains("(field `"), "execution {i}: unlocated error {e}\n{text}");
                refused += 1;
                continue;
            }
        };
        let planned = study.plan().cpu_s();
        let (start, cpu0) = (Instant::now(), cpu_s());
        let report = run(&study, &RunOptions { out: Some(root.join("out")), progress: false })
            .unwrap_or_else(|e| panic!("execution {i}: the run itself failed: {e}\n{text}"));
        let (took, cpu) = (start.elapsed().as_secs_f64(), cpu_s() - cpu0);
        slowest = slowest.max(took);
        // The watchdog's budget is 3 × plan + 1 s per analysis (per compared mechanism's inner
        // analysis too); an analysis it stops has spent its second, the others need not.
        let stopped = report.failures.iter().filter(|f| f.contains("stopped by the watchdog")).count();
        let bound = 3.0 * planned + stopped as f64 + 1.5;
        assert!(cpu <= bound, "execution {i}: {cpu:.2} s CPU against a plan of {planned:.2} s\n{text}");
        watchdog += stopped;
        let mut seen = std::collections::HashSet::new();
        for f in &report.files {
            assert!(seen.insert(f.clone()), "execution {i}: {} listed twice\n{text}", f.display());
            assert!(f.is_file(), "execution {i}: {} listed but not written\n{text}", f.display());
        }
        for f in files_under(&root.join("out").join("f")) {
            let body = std::fs::read(&f).unwrap();
            let body = String::from_utf8_lossy(&body);
            assert!(!non_finite_word(&body), "execution {i}: {} holds NaN or inf\n{text}", f.display());
            scanned += 1;
        }
        ran += 1;
    }
    println!(
        "seed {seed}: {executions} executions, {refused} refused at load, {ran} runs ({watchdog} analyses stopped by \
         the watchdog), slowest {slowest:.2} s, {scanned} files scanned"
    );
}

#[test]
fn short() {
    let seed = std::env::var("KANEDYN_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(25);
    fuzz(seed, 40);
}

#[test]
#[ignore]
fn long() {
    let seed = std::env::var("KANEDYN_FUZZ_SEED").ok().and_then(|v| v.parse().ok()).unwrap_or(2525);
    let executions = std::env::var("KANEDYN_FUZZ_EXECUTIONS").ok().and_then(|v| v.parse().ok()).unwrap_or(2000);
    fuzz(seed, executions);
}

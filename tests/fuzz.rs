//! A seeded, reproducible, in-process mutation fuzzer over the load-and-validate path of
//! mechanism, study and catalog-part files (issue 11, "Reliability and security of study runs").
//!
//! # What it fuzzes
//!
//! The corpus is every `examples/*.ron` file and every catalog part (`bodies/`, `joints/`). Each
//! execution takes one corpus file, applies 1–4 mutations ([`mutate::MUTATORS`]: byte flips and replacements, token deletion,
//! duplication and swaps, numbers replaced by extremes such as `1e19`, `NaN` or 10^5 digits,
//! strings replaced by 10^5 characters, `".."`, `"/etc/passwd"`, `"/dev/zero"`, …, a value wrapped
//! in 1000–100 000 brackets, a list element repeated up to 1000 times, a splice from another
//! file) and loads the result by the seed file's kind:
//! - a mechanism through [`load_mechanism`] (`Mechanism::from_source` under the read policy), named as its file in
//!   a temporary copy of the example tree so that relative `part:` paths resolve;
//! - a study through [`load_study`] (`Study::from_source` in memory, as a file in that copy: the
//!   study, its mechanism and every check up to the plan);
//! - a body or joint part through a host mechanism that names it as its `part` ([`load_part`]).
//!
//! Those three adapters are the only places the library is called: when the loading API changes
//! (`Mechanism::from_source`, an in-memory `Study::from_source` + `plan`), change them only.
//!
//! Each execution runs under `catch_unwind` with a silent panic hook (panics are recorded with
//! their message, location and backtrace, not printed), is timed, and has its heap use measured
//! by the counting global allocator of this test binary. Inputs are deterministic: execution `i`
//! of base seed `s` draws everything from `StdRng::seed_from_u64(mix(s, i))`, so the parallel
//! (rayon) order does not matter and any execution can be replayed alone.
//!
//! # Modes and what they assert
//! - `short` (a normal test): 20 000 executions of seed 11, ~8 s in `--release` on 2 cores.
//! - `long` (`#[ignore]`; `cargo test --release --test fuzz -- --ignored --nocapture`): 1 000 000
//!   executions of seed 1111; prints the count, wall time, slowest input and the process's peak
//!   memory (`VmHWM`).
//!
//! Both fail on any panic, on any input that takes more than 1 s to load (CPU time of its thread:
//! a loaded machine does not fail an input an idle one loads in time; a hang is still caught by
//! the watchdog below), and on any input whose
//! load uses more than 250 MB of heap (measured per execution by the allocator; two run at once);
//! `long` also fails when the process's peak resident memory exceeds 500 MB. These are the
//! acceptance limits of the issue: ≥ 1 000 000 executions, 0 panics, each input validated in
//! ≤ 1 s, peak memory ≤ 500 MB. A loader must reject bad input with an error, promptly and without allocating for what the
//! input merely claims (a count of 1e19, a path to `/dev/zero`).
//!
//! # Reproducing a failure
//! The failure message prints the seed, the iteration, the mutations and the input (truncated to
//! 4 kB; panics are also shrunk by deleting tokens while the same panic persists). Replay one
//! execution, printing its full input and outcome:
//! `KANEDYN_FUZZ_SEED=11 KANEDYN_FUZZ_ONLY=1234 cargo test --release --test fuzz short -- --nocapture`.
//!
//! Environment: `KANEDYN_FUZZ_ITERS` (execution count), `KANEDYN_FUZZ_SEED` (base seed),
//! `KANEDYN_FUZZ_ONLY` (replay one iteration), `KANEDYN_FUZZ_TRACE=1` (print each iteration before
//! it runs: the last lines name the culprit if the process dies, e.g. of a stack overflow),
//! `KANEDYN_FUZZ_AVOID=/dev/zero,…` (skip inputs containing any of these strings: step over a
//! known defect to look for others; the skipped count is printed).
//!
//! What cannot be caught in-process is bounded instead: a watchdog ends the process with the
//! reproducer after 30 s in one execution (a hang), and the allocator refuses to let the live heap
//! of one thread pass 1 GiB (a refused `try_reserve` becomes an error, e.g. reading `/dev/zero`;
//! a refused plain allocation aborts the process, after printing the iteration).

#[path = "fuzz/mutate.rs"]
mod mutate;

use kanedyn::io::{ReadPolicy, Source};
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{LoadOptions, Study};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::alloc::{GlobalAlloc, Layout, System};
use std::backtrace::Backtrace;
use std::cell::{Cell, RefCell};
use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

// ---------------------------------------------------------------------------------------------
// The adapters: the only calls into the library.

/// Loads and validates mechanism `text` as if it were the file `path` (relative `part:` paths
/// resolve from `path`'s folder).
fn load_mechanism(path: &Path, text: &str) -> Result<(), String> {
    let src = Source::from_text(&path.to_string_lossy(), text);
    let policy = ReadPolicy::within(path.parent().unwrap_or(Path::new("")));
    Mechanism::from_source(&src, &policy).map(drop).map_err(|e| e.to_string())
}

/// Loads, validates and plans study `text` as the file `path` in memory (inside the temporary
/// example tree; its `mechanism:` resolves from there under the default read policy and limits).
fn load_study(path: &Path, text: &str) -> Result<(), String> {
    let src = Source::from_text(&path.to_string_lossy(), text);
    let study = Study::from_source(src, &LoadOptions::default()).map_err(|e| e.to_string())?;
    let plan = study.plan();
    if plan.exceeds(&LoadOptions::default().limits).is_some() {
        return Err("fuzz harness: a study over the limits was accepted".into());
    }
    Ok(())
}

/// Loads catalog part `text` (a body or a joint) as file `path` through a minimal host mechanism
/// in the same folder that names it as its `part`.
fn load_part(path: &Path, kind: Kind, text: &str) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("fuzz harness: cannot write {}: {e}", path.display()))?;
    let file = path.file_name().unwrap_or_default().to_string_lossy();
    let host = match kind {
        Kind::JointPart => format!(
            r#"Mechanism(name: "host", bodies: [Body(name: "b", mass: 1.0, com: (0.1, 0.0), inertia: 0.01)],
               joints: [Joint(name: "j", part: "{file}", parent: "ground", child: "b", at: (0.0, 0.0))])"#
        ),
        _ => format!(
            r#"Mechanism(name: "host", bodies: [Body(name: "b", part: "{file}")],
               joints: [Joint(name: "j", kind: Revolute, parent: "ground", child: "b", at: (0.0, 0.0))])"#
        ),
    };
    let result = load_mechanism(&path.with_file_name("fuzz_host.ron"), &host);
    let _ = std::fs::remove_file(path);
    result
}

/// CPU time (user + system) of the calling thread so far, from `/proc/thread-self/stat` (ticks of
/// 10 ms); `None` where that cannot be read.
fn thread_cpu() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    // Fields after the command name (in parentheses, which may hold spaces): utime, stime.
    let rest = stat.get(stat.rfind(')')? + 2..)?;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks = f.get(11)?.parse::<u64>().ok()? + f.get(12)?.parse::<u64>().ok()?;
    Some(Duration::from_millis(ticks * 10))
}

// ---------------------------------------------------------------------------------------------
// Limits.

/// An input that takes longer than this to load fails the test (the issue's 1 s per input), in
/// CPU time of the thread that loads it (see [`thread_cpu`]).
const SLOW: Duration = Duration::from_secs(1);
/// An execution still running after this is a hang: the watchdog ends the process.
const HANG: Duration = Duration::from_secs(30);
/// Peak resident memory allowed in the long mode (the issue's 500 MB).
const PEAK_LIMIT_BYTES: u64 = 500_000_000;
/// One execution may not use more heap than this (its own peak of live bytes): two run at once
/// on two cores, so this keeps the process within [`PEAK_LIMIT_BYTES`].
const HEAP_LIMIT: i64 = 250_000_000;
/// The live heap of one thread may not pass this (nor that of the process 3×): larger requests
/// are refused (see the module docs).
const HEAP_CAP: usize = 1 << 30;
/// Printed inputs are truncated to this many bytes.
const SHOW: usize = 4096;

// ---------------------------------------------------------------------------------------------
// A counting allocator: process-wide live bytes (capped) and per-thread live bytes and peak, so
// each execution's own peak heap use is known.

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    static T_LIVE: Cell<i64> = const { Cell::new(0) };
    static T_PEAK: Cell<i64> = const { Cell::new(0) };
    static REFUSING: Cell<bool> = const { Cell::new(false) };
    /// The iteration this thread runs (u64::MAX: none), for the refusal message.
    static CURRENT: Cell<u64> = const { Cell::new(u64::MAX) };
    /// True while this thread runs a target (its panics are recorded silently).
    static IN_TARGET: Cell<bool> = const { Cell::new(false) };
    /// The last panic on this thread, recorded by the silent hook.
    static LAST_PANIC: RefCell<Option<PanicRecord>> = const { RefCell::new(None) };
}

fn grow(bytes: usize) -> bool {
    let before = LIVE.fetch_add(bytes, Ordering::Relaxed);
    let thread = T_LIVE.try_with(Cell::get).unwrap_or(0);
    if thread.saturating_add(bytes as i64) > HEAP_CAP as i64 || before.saturating_add(bytes) > 3 * HEAP_CAP {
        LIVE.fetch_sub(bytes, Ordering::Relaxed);
        let _ = REFUSING.try_with(|r| {
            if !r.replace(true) {
                let iter = CURRENT.try_with(Cell::get).unwrap_or(u64::MAX);
                eprintln!(
                    "fuzz: refused an allocation of {bytes} bytes with {thread} bytes live on the thread, {before} \
                     in all (caps {HEAP_CAP} and 3×) in iteration {iter}"
                );
                r.set(false);
            }
        });
        return false;
    }
    let _ = T_LIVE.try_with(|l| {
        let now = l.get() + bytes as i64;
        l.set(now);
        let _ = T_PEAK.try_with(|p| p.set(p.get().max(now)));
    });
    true
}

fn shrink(bytes: usize) {
    LIVE.fetch_sub(bytes, Ordering::Relaxed);
    let _ = T_LIVE.try_with(|l| l.set(l.get() - bytes as i64));
}

// SAFETY: every call forwards to `System` with the same layout; the bookkeeping only decides
// whether to forward an allocation at all (returning null otherwise, as an allocator may).
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if !grow(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded as is.
        let p = unsafe { System.alloc(layout) };
        if p.is_null() {
            shrink(layout.size());
        }
        p
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        if !grow(layout.size()) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded as is.
        let p = unsafe { System.alloc_zeroed(layout) };
        if p.is_null() {
            shrink(layout.size());
        }
        p
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded as is.
        unsafe { System.dealloc(ptr, layout) };
        shrink(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let old = layout.size();
        if new_size > old && !grow(new_size - old) {
            return std::ptr::null_mut();
        }
        // SAFETY: forwarded as is.
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if p.is_null() {
            if new_size > old {
                shrink(new_size - old);
            }
        } else if new_size < old {
            shrink(old - new_size);
        }
        p
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// The process's peak resident set (`VmHWM`), bytes, if `/proc` has it.
fn peak_rss_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

// ---------------------------------------------------------------------------------------------
// The corpus and the temporary example tree.

/// What a corpus file is, which decides the target.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Mechanism,
    Study,
    BodyPart,
    JointPart,
}

struct Seed {
    /// Path relative to the repository root (and to the temporary copy).
    rel: PathBuf,
    kind: Kind,
    bytes: Vec<u8>,
}

/// The folders copied to the temporary tree and searched for corpus files.
const TREE: &[&str] = &["examples", "bodies", "joints"];

fn load_corpus(root: &Path) -> Vec<Seed> {
    let mut seeds = Vec::new();
    for dir in TREE {
        let Ok(entries) = std::fs::read_dir(root.join(dir)) else { continue };
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "ron"))
            .collect();
        files.sort();
        for file in files {
            let text = std::fs::read_to_string(&file).expect("corpus file readable");
            let parent = file.parent().and_then(Path::file_name).unwrap_or_default();
            let kind = if parent == "bodies" {
                Kind::BodyPart
            } else if parent == "joints" {
                Kind::JointPart
            } else {
                // The first token that is not a comment names the top-level struct.
                let first = mutate::tokenize(text.as_bytes()).first().map(|t| &text[t.start..t.end]);
                match first {
                    Some("Study") => Kind::Study,
                    Some("Mechanism") => Kind::Mechanism,
                    other => panic!("{}: neither a Study nor a Mechanism ({other:?})", file.display()),
                }
            };
            let rel = file.strip_prefix(root).expect("under the root").to_path_buf();
            seeds.push(Seed { rel, kind, bytes: text.into_bytes() });
        }
    }
    assert!(seeds.iter().any(|s| s.kind == Kind::Study), "no study in the corpus");
    assert!(seeds.iter().any(|s| s.kind == Kind::Mechanism), "no mechanism in the corpus");
    seeds
}

/// A temporary copy of the example tree, removed on drop (a unique name per tree, so runs in
/// parallel never share one).
struct TempTree {
    dir: tempfile::TempDir,
}

impl TempTree {
    fn new(repo: &Path) -> Self {
        let root = tempfile::Builder::new().prefix("kanedyn-fuzz-").tempdir().expect("create temporary folder");
        for dir in TREE {
            if repo.join(dir).is_dir() {
                copy_dir(&repo.join(dir), &root.path().join(dir));
            }
        }
        Self { dir: root }
    }
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).expect("create temporary folder");
    for entry in std::fs::read_dir(from).expect("read example folder") {
        let path = entry.expect("folder entry").path();
        let dest = to.join(path.file_name().expect("file name"));
        if path.is_dir() {
            copy_dir(&path, &dest);
        } else {
            std::fs::copy(&path, &dest).expect("copy example file");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Inputs and executions.

struct Fuzz {
    seeds: Vec<Seed>,
    corpus: Vec<Vec<u8>>,
    tree: TempTree,
    base_seed: u64,
}

struct Input {
    seed: usize,
    mutations: Vec<&'static str>,
    text: String,
}

/// SplitMix64's finaliser: per-iteration seeds that differ in every bit.
fn mix(base: u64, i: u64) -> u64 {
    let mut z = base.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ i.wrapping_add(0xD1B5_4A32_D192_ED03);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

#[derive(Debug, Clone)]
struct PanicRecord {
    message: String,
    location: String,
    backtrace: Arc<Backtrace>,
}

impl PanicRecord {
    /// Distinct defects: the panic site and the message with its numbers blanked.
    fn key(&self) -> String {
        let mut msg = String::new();
        for c in self.message.chars().take(80) {
            // Each run of digits becomes one `#`.
            if !c.is_ascii_digit() {
                msg.push(c);
            } else if !msg.ends_with('#') {
                msg.push('#');
            }
        }
        format!("{} {msg}", self.location)
    }

    /// The innermost frame in the crate's own sources (`src/…`), from the backtrace.
    fn crate_frame(&self) -> String {
        let text = self.backtrace.to_string();
        text.lines()
            .map(str::trim)
            .find(|l| {
                l.starts_with("at ./src/")
                    || (l.starts_with("at /")
                        && l.contains("/src/")
                        && !l.contains("/rustc/")
                        && !l.contains("/.cargo/"))
            })
            .map_or_else(|| self.location.clone(), |l| l.trim_start_matches("at ").to_string())
    }
}

enum Outcome {
    Ok,
    Rejected,
    Panicked(PanicRecord),
}

struct Exec {
    outcome: Outcome,
    time: Duration,
    heap_peak: i64,
}

impl Fuzz {
    fn new(base_seed: u64) -> Self {
        let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
        let seeds = load_corpus(repo);
        let corpus = seeds.iter().map(|s| s.bytes.clone()).collect();
        Self { seeds, corpus, tree: TempTree::new(repo), base_seed }
    }

    /// Input `i`: a corpus file and 1–4 mutations, all drawn from `mix(base_seed, i)`.
    fn input(&self, i: u64) -> Input {
        let mut rng = StdRng::seed_from_u64(mix(self.base_seed, i));
        let seed = rng.random_range(0..self.seeds.len());
        let mut bytes = self.seeds[seed].bytes.clone();
        let mut mutations = Vec::new();
        let wanted = rng.random_range(1..=4);
        for _ in 0..4 * wanted {
            if mutations.len() == wanted {
                break;
            }
            let which = rng.random_range(0..mutate::MUTATORS.len());
            if mutate::mutate(which, &mut bytes, &mut rng, &self.corpus) {
                mutations.push(mutate::MUTATORS[which]);
            }
        }
        Input { seed, mutations, text: String::from_utf8_lossy(&bytes).into_owned() }
    }

    /// Loads `text` as a file of `seed`'s kind; `tag` makes temporary file names unique.
    fn target(&self, seed: usize, text: &str, tag: &str) -> Result<(), String> {
        let s = &self.seeds[seed];
        let at = self.tree.dir.path().join(&s.rel);
        match s.kind {
            Kind::Mechanism => load_mechanism(&at, text),
            Kind::Study => load_study(&at.with_file_name(format!("fuzz_study_{tag}.ron")), text),
            kind => load_part(&at.with_file_name(format!("fuzz_part_{tag}.ron")), kind, text),
        }
    }

    /// Runs one input under `catch_unwind`, timed, with its heap peak.
    fn execute(&self, seed: usize, text: &str, tag: &str) -> Exec {
        let base = T_LIVE.with(Cell::get);
        T_PEAK.with(|p| p.set(base));
        LAST_PANIC.with(|p| p.borrow_mut().take());
        let (start, cpu0) = (Instant::now(), thread_cpu());
        IN_TARGET.with(|t| t.set(true));
        let result = catch_unwind(AssertUnwindSafe(|| self.target(seed, text, tag)));
        // The thread's own CPU time where it can be read: a loaded machine stretches the wall
        // time of the same work (an input once took 1.39 s of wall time at a load average of 8
        // on 2 cores), not the work. A hang is still caught, by the wall-clock watchdog.
        let time = match (cpu0, thread_cpu()) {
            (Some(a), Some(b)) => b.saturating_sub(a),
            _ => start.elapsed(),
        };
        IN_TARGET.with(|t| t.set(false));
        let heap_peak = T_PEAK.with(Cell::get) - base;
        let outcome = match result {
            Ok(Ok(())) => Outcome::Ok,
            Ok(Err(_)) => Outcome::Rejected,
            Err(payload) => {
                Outcome::Panicked(LAST_PANIC.with(|p| p.borrow_mut().take()).unwrap_or_else(|| PanicRecord {
                    message: payload_text(&*payload),
                    location: "?".into(),
                    backtrace: Arc::new(Backtrace::disabled()),
                }))
            }
        };
        Exec { outcome, time, heap_peak }
    }

    fn reproducer(&self, i: u64) -> String {
        format!(
            "KANEDYN_FUZZ_SEED={} KANEDYN_FUZZ_ONLY={i} cargo test --release --test fuzz -- --nocapture",
            self.base_seed
        )
    }

    fn describe(&self, i: u64) -> String {
        let input = self.input(i);
        let text = &input.text;
        format!(
            "seed {} iteration {i}: {} ({:?}) after {:?}; {} bytes{}:\n{}\n(replay: {})",
            self.base_seed,
            self.seeds[input.seed].rel.display(),
            self.seeds[input.seed].kind,
            input.mutations,
            text.len(),
            if text.len() > SHOW { ", first 4 kB" } else { "" },
            truncate(text, SHOW),
            self.reproducer(i),
        )
    }

    /// Deletes tokens (and halves long tokens) while the input still panics with the same key;
    /// bounded to 2000 attempts or 10 s.
    fn shrink(&self, seed: usize, text: &str, key: &str) -> String {
        let start = Instant::now();
        let mut best = text.as_bytes().to_vec();
        let mut attempts = 0;
        'outer: loop {
            let current = best.clone();
            for candidate in mutate::reductions(&current) {
                attempts += 1;
                if attempts > 2000 || start.elapsed() > Duration::from_secs(10) {
                    break 'outer;
                }
                let Ok(cand) = String::from_utf8(candidate) else { continue };
                if let Outcome::Panicked(p) = self.execute(seed, &cand, "shrink").outcome
                    && p.key() == key
                {
                    best = cand.into_bytes();
                    continue 'outer;
                }
            }
            break;
        }
        String::from_utf8(best).expect("shrunk from UTF-8 candidates")
    }
}

fn payload_text(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "(non-string panic payload)".into())
}

fn truncate(s: &str, max: usize) -> &str {
    if s.len() <= max {
        return s;
    }
    let mut end = max;
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s[..end]
}

/// While alive: a panic hook that records panics of the targets in `LAST_PANIC` silently (and
/// reports the harness's own as usual); the default hook is back on drop. Runs of the fuzzer hold a lock so they do not swap hooks under each other.
struct SilentPanics {
    _lock: std::sync::MutexGuard<'static, ()>,
}

impl SilentPanics {
    fn install() -> Self {
        static LOCK: Mutex<()> = Mutex::new(());
        let lock = LOCK.lock().unwrap_or_else(|e| e.into_inner());
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !IN_TARGET.try_with(Cell::get).unwrap_or(false) {
                // A panic of the harness itself: report it as usual.
                return default(info);
            }
            let message = payload_text(info.payload());
            if message.starts_with("memory allocation of") {
                // Not unwinding: the process aborts next, so say where.
                let iter = CURRENT.try_with(Cell::get).unwrap_or(u64::MAX);
                eprintln!("fuzz: {message} in iteration {iter}: the process aborts");
            }
            let record = PanicRecord {
                message,
                location: info.location().map_or_else(|| "?".into(), |l| l.to_string()),
                backtrace: Arc::new(Backtrace::force_capture()),
            };
            let _ = LAST_PANIC.try_with(|p| *p.borrow_mut() = Some(record));
        }));
        Self { _lock: lock }
    }
}

impl Drop for SilentPanics {
    fn drop(&mut self) {
        let _ = std::panic::take_hook();
    }
}

/// What each worker runs: the iteration and since when (`None`: idle).
type Slot = Mutex<Option<(u64, Instant)>>;

/// Ends the process with a reproducer when one execution runs longer than [`HANG`].
struct Watchdog {
    slots: Arc<Vec<Slot>>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Watchdog {
    fn start(base_seed: u64) -> Self {
        let slots: Arc<Vec<Slot>> = Arc::new((0..rayon::current_num_threads() + 1).map(|_| Mutex::new(None)).collect());
        let stop = Arc::new(AtomicBool::new(false));
        let (s, st) = (slots.clone(), stop.clone());
        let thread = std::thread::spawn(move || {
            while !st.load(Ordering::Relaxed) {
                std::thread::sleep(Duration::from_millis(200));
                for slot in s.iter() {
                    let busy = *slot.lock().unwrap_or_else(|e| e.into_inner());
                    if let Some((i, since)) = busy
                        && since.elapsed() > HANG
                    {
                        eprintln!(
                            "fuzz: iteration {i} of seed {base_seed} has run for {HANG:?}: a hang. Replay: \
                             KANEDYN_FUZZ_SEED={base_seed} KANEDYN_FUZZ_ONLY={i} cargo test --release --test fuzz \
                             -- --nocapture"
                        );
                        std::process::exit(101);
                    }
                }
            }
        });
        Self { slots, stop, thread: Some(thread) }
    }

    fn slot(&self) -> &Slot {
        &self.slots[rayon::current_thread_index().map_or(0, |k| k + 1)]
    }
}

impl Drop for Watchdog {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A run.

/// The first occurrence of one distinct panic.
struct Found {
    iter: u64,
    count: u64,
    record: PanicRecord,
}

#[derive(Default)]
struct Summary {
    execs: u64,
    /// Inputs not run (`KANEDYN_FUZZ_AVOID`).
    skipped: u64,
    ok: u64,
    rejected: u64,
    panics: BTreeMap<String, Found>,
    /// Iterations slower than [`SLOW`], with their times (first 20 by iteration).
    slow: Vec<(u64, Duration)>,
    /// Iterations that used more heap than [`HEAP_LIMIT`], with their peaks (first 20).
    heavy: Vec<(u64, i64)>,
    slowest: (Duration, u64),
    heap_peak: (i64, u64),
}

impl Summary {
    fn add(&mut self, i: u64, e: Exec) {
        self.execs += 1;
        match e.outcome {
            Outcome::Ok => self.ok += 1,
            Outcome::Rejected => self.rejected += 1,
            Outcome::Panicked(record) => {
                let f = self.panics.entry(record.key()).or_insert(Found { iter: i, count: 0, record: record.clone() });
                f.count += 1;
                if i < f.iter {
                    (f.iter, f.record) = (i, record);
                }
            }
        }
        if e.time > SLOW {
            self.slow.push((i, e.time));
        }
        if e.heap_peak > HEAP_LIMIT {
            self.heavy.push((i, e.heap_peak));
        }
        if e.time > self.slowest.0 {
            self.slowest = (e.time, i);
        }
        if e.heap_peak > self.heap_peak.0 {
            self.heap_peak = (e.heap_peak, i);
        }
    }

    fn merge(mut self, other: Summary) -> Summary {
        self.execs += other.execs;
        self.skipped += other.skipped;
        self.ok += other.ok;
        self.rejected += other.rejected;
        for (k, f) in other.panics {
            match self.panics.get_mut(&k) {
                Some(mine) => {
                    mine.count += f.count;
                    if f.iter < mine.iter {
                        (mine.iter, mine.record) = (f.iter, f.record);
                    }
                }
                None => {
                    self.panics.insert(k, f);
                }
            }
        }
        self.slow.extend(other.slow);
        self.slow.sort();
        self.slow.truncate(20);
        self.heavy.extend(other.heavy);
        self.heavy.sort();
        self.heavy.truncate(20);
        if other.slowest.0 > self.slowest.0 {
            self.slowest = other.slowest;
        }
        if other.heap_peak.0 > self.heap_peak.0 {
            self.heap_peak = other.heap_peak;
        }
        self
    }
}

fn env_u64(name: &str) -> Option<u64> {
    std::env::var(name).ok().map(|v| v.trim().parse().unwrap_or_else(|_| panic!("{name}={v}: not an integer")))
}

/// Runs the fuzzer and returns the failure report (empty when nothing failed).
fn run(default_iters: u64, default_seed: u64, check_peak: bool) -> String {
    let base_seed = env_u64("KANEDYN_FUZZ_SEED").unwrap_or(default_seed);
    let iters = env_u64("KANEDYN_FUZZ_ITERS").unwrap_or(default_iters);
    let trace = std::env::var("KANEDYN_FUZZ_TRACE").is_ok_and(|v| v == "1");
    let fuzz = Fuzz::new(base_seed);

    // The adapters must accept the unmutated corpus, or the fuzzer tests nothing.
    for (k, s) in fuzz.seeds.iter().enumerate() {
        let text = std::str::from_utf8(&s.bytes).expect("UTF-8 corpus");
        if let Err(e) = fuzz.target(k, text, "corpus") {
            panic!("corpus file {} ({:?}) does not load through its adapter: {e}", s.rel.display(), s.kind);
        }
    }

    if let Some(i) = env_u64("KANEDYN_FUZZ_ONLY") {
        let input = fuzz.input(i);
        println!("{}", fuzz.describe(i));
        println!("full input:\n{}", input.text);
        let e = fuzz.target(input.seed, &input.text, "only");
        println!("outcome: {e:?}");
        return String::new();
    }

    // Known defects to step over while their fixes land: inputs containing any of these strings
    // are generated but not run.
    let avoid: Vec<String> = std::env::var("KANEDYN_FUZZ_AVOID")
        .map(|v| v.split(',').filter(|s| !s.is_empty()).map(String::from).collect())
        .unwrap_or_default();
    let hooks = SilentPanics::install();
    let watchdog = Watchdog::start(base_seed);
    let wall = Instant::now();
    let summary = (0..iters)
        .into_par_iter()
        .fold(Summary::default, |mut sum, i| {
            let input = fuzz.input(i);
            if avoid.iter().any(|a| input.text.contains(a.as_str())) {
                sum.skipped += 1;
                return sum;
            }
            if trace {
                eprintln!("fuzz: iteration {i}: {} {:?}", fuzz.seeds[input.seed].rel.display(), input.mutations);
            }
            CURRENT.with(|c| c.set(i));
            let slot = watchdog.slot();
            *slot.lock().unwrap_or_else(|e| e.into_inner()) = Some((i, Instant::now()));
            let exec = fuzz.execute(input.seed, &input.text, &i.to_string());
            *slot.lock().unwrap_or_else(|e| e.into_inner()) = None;
            CURRENT.with(|c| c.set(u64::MAX));
            if trace {
                eprintln!("fuzz: iteration {i} done");
            }
            sum.add(i, exec);
            sum
        })
        .reduce(Summary::default, Summary::merge);
    let wall = wall.elapsed();
    drop(watchdog);

    // Shrink and describe each distinct panic (still under the silent hook).
    let mut report = String::new();
    for (key, f) in &summary.panics {
        let input = fuzz.input(f.iter);
        let small = fuzz.shrink(input.seed, &input.text, key);
        let frame = match fuzz.execute(input.seed, &small, "shrunk").outcome {
            Outcome::Panicked(p) => p.crate_frame(),
            _ => f.record.crate_frame(),
        };
        report += &format!(
            "\nPANIC ({} of {} executions) `{}` at {} (crate frame {frame})\n  first: {}\n  shrunk ({} bytes):\n{}\n",
            f.count,
            summary.execs,
            f.record.message.chars().take(300).collect::<String>(),
            f.record.location,
            fuzz.describe(f.iter),
            small.len(),
            truncate(&small, SHOW),
        );
    }
    drop(hooks);
    for &(i, t) in &summary.slow {
        report += &format!("\nSLOW ({:.2} s > {SLOW:?}): {}\n", t.as_secs_f64(), fuzz.describe(i));
    }
    for &(i, bytes) in &summary.heavy {
        report += &format!(
            "\nHEAP ({:.0} MB > {:.0} MB in one execution): {}\n",
            bytes as f64 / 1e6,
            HEAP_LIMIT as f64 / 1e6,
            fuzz.describe(i)
        );
    }
    let peak = peak_rss_bytes();
    if check_peak && let Some(p) = peak.filter(|&p| p > PEAK_LIMIT_BYTES) {
        report += &format!(
            "\nPEAK MEMORY {:.0} MB > {:.0} MB; the largest heap use of one execution was {:.1} MB: {}\n",
            p as f64 / 1e6,
            PEAK_LIMIT_BYTES as f64 / 1e6,
            summary.heap_peak.0 as f64 / 1e6,
            fuzz.describe(summary.heap_peak.1)
        );
    }
    let panics: u64 = summary.panics.values().map(|f| f.count).sum();
    println!(
        "fuzz: seed {base_seed}: {} executions in {:.1} s on {} threads ({} skipped)",
        summary.execs,
        wall.as_secs_f64(),
        rayon::current_num_threads(),
        summary.skipped
    );
    println!(
        "fuzz: {} accepted, {} rejected, {panics} panicked ({} distinct), {} slower than {SLOW:?}, {} over {:.0} MB",
        summary.ok,
        summary.rejected,
        summary.panics.len(),
        summary.slow.len(),
        summary.heavy.len(),
        HEAP_LIMIT as f64 / 1e6
    );
    println!(
        "fuzz: slowest {:.1} ms (iteration {}); largest heap use of one execution {:.1} MB (iteration {}); peak \
         memory (VmHWM) {}",
        summary.slowest.0.as_secs_f64() * 1e3,
        summary.slowest.1,
        summary.heap_peak.0 as f64 / 1e6,
        summary.heap_peak.1,
        peak.map_or_else(|| "unknown".into(), |p| format!("{:.0} MB", p as f64 / 1e6)),
    );
    report
}

/// 20 000 executions of seed 11 (the normal test run).
#[test]
fn short() {
    let report = run(20_000, 11, false);
    assert!(report.is_empty(), "the fuzzer found defects:{report}");
}

/// The issue's acceptance run: 1 000 000 executions of seed 1111, 0 panics, every input in ≤ 1 s,
/// peak memory ≤ 500 MB.
#[test]
#[ignore]
fn long() {
    let report = run(1_000_000, 1111, true);
    assert!(report.is_empty(), "the fuzzer found defects:{report}");
}

//! Peak memory of the time-domain bench studies (issue 30, item 3): each study of
//! `benches/studies` run by the release `kanedyn` binary under `/usr/bin/time -f "%e %M"`, its
//! whole-process peak resident set printed in MiB next to the issue's bound. The analysis streams
//! (`signal::StftStream`), so the peaks must not grow with the sweep's duration × elements.
//!
//! ```text
//! cargo bench --bench memory
//! ```
//!
//! For the heap's breakdown by allocation site, run one study under massif (see BENCHMARKS.md).

use std::path::Path;
use std::process::Command;

/// The studies, each with the issue's bound in MiB.
const STUDIES: [(&str, f64); 3] = [("sweep40_up", 20.0), ("sweep60_p1", 20.0), ("sweep60_p32", 40.0)];

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = env!("CARGO_BIN_EXE_kanedyn");
    let out = std::env::temp_dir().join(format!("kanedyn-memory-bench-{}", std::process::id()));
    println!("study          wall s   peak MiB   bound MiB");
    for (study, bound) in STUDIES {
        let file = root.join("benches/studies").join(format!("{study}.ron"));
        // The bench studies read their mechanisms from examples/ (outside their folder).
        let run = Command::new("/usr/bin/time")
            .args(["-f", "%e %M", exe, "run"])
            .arg(&file)
            .args(["--allow-read"])
            .arg(root.join("examples"))
            .arg("--out")
            .arg(&out)
            .output();
        let Ok(run) = run else {
            println!("{study}: /usr/bin/time is needed (the whole process's peak resident set)");
            return;
        };
        let err = String::from_utf8_lossy(&run.stderr);
        let last = err.lines().last().unwrap_or_default();
        let mut figures = last.split_whitespace().map(|x| x.parse::<f64>().unwrap_or(f64::NAN));
        let (wall, kib) = (figures.next().unwrap_or(f64::NAN), figures.next().unwrap_or(f64::NAN));
        if !run.status.success() {
            println!("{study}: the run failed: {err}");
            continue;
        }
        let mib = kib / 1024.0;
        let verdict = if mib <= bound { "" } else { "  ABOVE THE BOUND" };
        println!("{study:<14} {wall:>6.2}   {mib:>8.1}   {bound:>9.0}{verdict}");
    }
    let _ = std::fs::remove_dir_all(&out);
}

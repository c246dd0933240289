//! The `kanedyn` command-line tool: check a mechanism, evaluate its equations of motion at a
//! state, run a study.
//!
//! Exit codes by class of failure, for scripts (the table is in docs/guide/src/cli.md): see
//! [`exit_code`].

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};
use kanedyn::kane::Kane;
use kanedyn::model::excitation::Excitation;
use kanedyn::model::mechanism::Mechanism;
use kanedyn::study::{Limits, LoadOptions, RunOptions, Study};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "kanedyn", version, about = "Planar multibody dynamics by Kane's method, for torsional vibration")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Validate a mechanism file and print its degrees of freedom, bodies, joints and total mass;
    /// or validate a study file without running it and print its plan (runs, samples, memory,
    /// output size and CPU time per analysis).
    Check {
        /// Mechanism or study file (RON).
        file: PathBuf,
        /// Print nothing when the file is valid: the exit code alone answers.
        #[arg(long, short)]
        quiet: bool,
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// Print M, F, q̇ and u̇ at one state as JSON (numbers round-trip exactly).
    Eom {
        /// Mechanism file (RON).
        file: PathBuf,
        /// Coordinates q (rad), comma-separated, in joint order (see `check`).
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        q: Vec<String>,
        /// Generalized speeds u (rad/s), comma-separated, in the mechanism's speed definition.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        u: Vec<String>,
        /// Time t (s), for time-dependent loads.
        #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
        t: f64,
        /// Replace the applied torque of a joint by a constant, `NAME=VALUE` (N·m); repeatable.
        /// The joint's spring and damper stay.
        #[arg(long = "joint-torque", value_name = "NAME=VALUE")]
        joint_torque: Vec<String>,
    },
    /// Run a study file: every analysis, with CSV, SVG, a Markdown summary, results.json and
    /// report.html in OUT/<study name>/. Prints a digest of at most 25 lines (status, key findings,
    /// failures) ending with the path of report.html.
    Run {
        /// Study file (RON).
        study: PathBuf,
        /// Output root folder.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Number of worker threads (default: all cores; at most 4 per core).
        #[arg(long)]
        threads: Option<usize>,
        /// Also print the full summary (every table of summary.md) and the files written, before
        /// the digest.
        #[arg(long, short, conflicts_with = "quiet")]
        verbose: bool,
        /// Print nothing on success: no progress, notes or digest (errors still go to stderr).
        #[arg(long, short)]
        quiet: bool,
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// Print the JSON Schema of results.json (docs/results.schema.json is this output).
    Schema,
    /// Convert an OpenTorsion model (its TORS JSON assembly, as `Parser.from_tors` reads it) to
    /// a commented mechanism RON to edit or extend; attach absorbers with an overlay (a
    /// mechanism with `base: "FILE.ron"`, see the README). Writes to stdout without `-o`.
    Import {
        /// OpenTorsion TORS JSON file (or the node form that `kanedyn.from_opentorsion` sends).
        file: PathBuf,
        /// Write the RON to this file instead of stdout.
        #[arg(long, short)]
        out: Option<PathBuf>,
        /// The mechanism's name (default: the input file's name without its extension).
        #[arg(long)]
        name: Option<String>,
        /// Largest input file, kB.
        #[arg(long, value_name = "KB", default_value_t = 1024)]
        max_file_kb: u64,
    },
}

/// The limits a study's estimated work is checked against at load (see the README's "Limits
/// and errors"); raise one on purpose when a study really needs more.
#[derive(clap::Args, Debug, Clone)]
struct LimitArgs {
    /// Largest estimated memory of a study, MB.
    #[arg(long, value_name = "MB", default_value_t = 2048.0)]
    max_memory_mb: f64,
    /// Largest estimated size of a study's output files, MB.
    #[arg(long, value_name = "MB", default_value_t = 2048.0)]
    max_output_mb: f64,
    /// Largest estimated CPU time of a study, hours.
    #[arg(long, value_name = "HOURS", default_value_t = 12.0)]
    max_cpu_hours: f64,
    /// Also read mechanisms and parts from this folder (by default only the named file's own
    /// folder tree); repeatable.
    #[arg(long, value_name = "DIR")]
    allow_read: Vec<PathBuf>,
    /// Read mechanisms and parts from any path, absolute or outside the file's folder tree.
    #[arg(long)]
    allow_any_path: bool,
    /// Largest input file (study, mechanism, part), kB.
    #[arg(long, value_name = "KB", default_value_t = 1024)]
    max_file_kb: u64,
    /// Most bodies in a mechanism.
    #[arg(long, value_name = "N", default_value_t = kanedyn::io::ReadPolicy::DEFAULT_MAX_BODIES)]
    max_bodies: usize,
}

impl LimitArgs {
    fn options(&self) -> Result<LoadOptions> {
        for (name, v) in [
            ("--max-memory-mb", self.max_memory_mb),
            ("--max-output-mb", self.max_output_mb),
            ("--max-cpu-hours", self.max_cpu_hours),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(usage(format!("{name} must be a finite, positive number, got {v}")));
            }
        }
        let mb = 1024.0 * 1024.0;
        Ok(LoadOptions {
            limits: Limits {
                max_memory_bytes: self.max_memory_mb * mb,
                max_output_bytes: self.max_output_mb * mb,
                max_cpu_s: self.max_cpu_hours * 3600.0,
                ..Limits::default()
            },
            allow_read: self.allow_read.clone(),
            allow_any_path: self.allow_any_path,
            max_file_bytes: self.max_file_kb.saturating_mul(1024),
            max_bodies: self.max_bodies,
        })
    }
}

/// Most worker threads per core: more only adds memory and scheduling.
const THREADS_PER_CORE: usize = 4;

/// A command line that parses but asks for something impossible (a list of the wrong length, a
/// limit that is not a positive number): a usage error, as clap's own.
#[derive(Debug)]
struct Usage(String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// A usage error with this message.
fn usage(message: String) -> anyhow::Error {
    Usage(message).into()
}

/// A run that completed with some analyses failed: their results are missing, the others are
/// written.
#[derive(Debug)]
struct AnalysesFailed(String);

impl std::fmt::Display for AnalysesFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for AnalysesFailed {}

/// Exit codes by class: a script can tell a mistake in its command line from one in a file, a
/// limit to raise, a machine problem and a partial result. clap exits with 2 on its own.
mod exit {
    /// A bug: anything not classed below (a panic exits with Rust's 101).
    pub const INTERNAL: u8 = 1;
    /// The command line: an unknown flag or subcommand (clap), an impossible value.
    pub const USAGE: u8 = 2;
    /// A file's content: syntax, unknown field, a value out of range, a mechanism that cannot be
    /// evaluated.
    pub const INPUT: u8 = 3;
    /// A limit that can be raised on purpose (`--max-…`).
    pub const LIMIT: u8 = 4;
    /// The operating system: a file that cannot be read or written, standard output closed
    /// with an error.
    pub const OS: u8 = 5;
    /// A run that completed with some analyses failed (the others' results are written).
    pub const ANALYSES_FAILED: u8 = 6;
}

/// The exit code of an error: the class of the first cause that has one (see [`exit`]).
fn exit_code(e: &anyhow::Error) -> u8 {
    use kanedyn::error::Error as Lib;
    for cause in e.chain() {
        if cause.is::<Usage>() {
            return exit::USAGE;
        }
        if cause.is::<AnalysesFailed>() {
            return exit::ANALYSES_FAILED;
        }
        if cause.is::<std::io::Error>() {
            return exit::OS;
        }
        if cause.is::<kanedyn::error::EngineError>() {
            return exit::INPUT;
        }
        if let Some(lib) = cause.downcast_ref::<Lib>() {
            return match lib {
                Lib::Input { .. } | Lib::Model { .. } | Lib::Engine(_) => exit::INPUT,
                Lib::Limit { .. } => exit::LIMIT,
                Lib::Io { .. } => exit::OS,
            };
        }
    }
    exit::INTERNAL
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check { file, quiet, limits } => check_file(&file, quiet, &limits),
        Command::Eom { file, q, u, t, joint_torque } => eom(&file, &q, &u, t, &joint_torque),
        Command::Run { study, out, threads, verbose, quiet, limits } => {
            run(&study, &out, threads, Verbosity::from_flags(verbose, quiet), &limits)
        }
        Command::Schema => serde_json::to_string_pretty(&kanedyn::study::json::schema())
            .map_err(Into::into)
            .and_then(|text| stdout(format_args!("{text}\n"))),
        Command::Import { file, out, name, max_file_kb } => import(&file, out.as_deref(), name.as_deref(), max_file_kb),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Not `eprintln!`, which panics when standard error is closed too.
            let _ = writeln!(std::io::stderr(), "error: {}", without_repeats(&e));
            ExitCode::from(exit_code(&e))
        }
    }
}

/// Writes to standard output. A reader that stops reading early (`kanedyn schema | head -1`,
/// `kanedyn run … | true`) ends the output, not the command: what it no longer wants is dropped
/// and the command finishes its work and exits with its own status (issue 49: `println!`
/// panicked with exit 101 and a backtrace). Any other write error is the command's error.
fn stdout(args: std::fmt::Arguments<'_>) -> Result<()> {
    match std::io::stdout().lock().write_fmt(args) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
            Err(anyhow::Error::new(e).context("cannot write to standard output"))
        }
        _ => Ok(()),
    }
}

/// `print!` through [`stdout`], returning from the function on a write error.
macro_rules! say {
    ($($arg:tt)*) => {
        stdout(format_args!($($arg)*))?
    };
}

/// `println!` through [`stdout`], returning from the function on a write error.
macro_rules! sayln {
    () => {
        stdout(format_args!("\n"))?
    };
    ($($arg:tt)*) => {
        stdout(format_args!("{}\n", format_args!($($arg)*)))?
    };
}

/// `check` on a study (its text begins with `Study(`) prints the plan; on anything else it
/// checks a mechanism.
fn check_file(file: &Path, quiet: bool, limits: &LimitArgs) -> Result<()> {
    let opts = limits.options()?;
    let capped = kanedyn::io::ReadPolicy::unrestricted().with_max_file_bytes(opts.max_file_bytes);
    let src = kanedyn::io::Source::read_with(file, &capped)?;
    if !src.text.lines().any(|l| l.trim_start().starts_with("Study(")) {
        let policy = opts.policy_for(file);
        if quiet {
            return Mechanism::from_file_with(file, &policy).map(|_| ()).map_err(Into::into);
        }
        return check(file, &policy);
    }
    let study = Study::from_source(src, &opts)?;
    if quiet {
        return Ok(());
    }
    let plan = study.plan();
    sayln!("study `{}` ({}): OK", study.spec.name, file.display());
    sayln!(
        "mechanism `{}`: {} degrees of freedom; outputs go to <out>/{}/",
        study.mechanism.name,
        study.mechanism.ndof(),
        study.spec.name
    );
    sayln!("plan (coarse upper-bound estimates):\n{plan}");
    say!("{}", kanedyn::model::absorber::markdown(&study.mechanism));
    Ok(())
}

/// The error and its causes joined by `: `, leaving out a cause whose text is already there.
///
/// NOTE: a library error such as "x.ron: cannot read: Permission denied (os error 13)" prints its
/// OS error and also reports it as its source; anyhow's `{:#}` would print the reason twice.
fn without_repeats(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out += ": ";
        }
        out += &text;
    }
    out
}

fn check(file: &Path, policy: &kanedyn::io::ReadPolicy) -> Result<()> {
    let mech = Mechanism::from_file_with(file, policy)?;
    sayln!("mechanism `{}` ({}): OK", mech.name, file.display());
    sayln!("degrees of freedom: {}", mech.ndof());
    sayln!("generalized speeds: {:?}", mech.speeds);
    sayln!("bodies: {}", mech.bodies.len());
    for b in &mech.bodies {
        let i = b.inertia;
        sayln!(
            "  {:<16} mass {:>10.6} kg   com ({:.6}, {:.6}) m   inertia {:.6e} kg·m²",
            b.name,
            i.mass,
            i.com.x,
            i.com.y,
            i.i_com
        );
    }
    sayln!("joints (tree order): {}", mech.joints.len());
    for (k, j) in mech.joints.iter().enumerate() {
        let parent = j.parent.map_or("ground", |p| mech.bodies[p].name.as_str());
        // Units of the coordinate's spring and damper: per radian for a turn, per metre for a slide.
        let (per, unit) = if j.kind.rotates() { ("N·m", "rad") } else { ("N", "m") };
        let mut extra = String::new();
        if j.damper > 0.0 {
            extra += &format!("   damper {} {per}·s/{unit}", j.damper);
        }
        if let Some(s) = j.spring {
            extra += &format!("   spring {} {per}/{unit} (free at {} {unit})", s.stiffness, s.free_angle);
        }
        extra += &j.couplings.describe(per, unit);
        let q = j.coordinate.map_or_else(|| "    ".to_string(), |c| format!("q[{c}]"));
        sayln!(
            "  {q} {:<12} {:?} {} -> {} at ({}, {}) m{extra}",
            j.name,
            j.kind,
            parent,
            mech.bodies[k].name,
            j.at.x,
            j.at.y
        );
    }
    if mech.is_geared() {
        sayln!("couplings: {}", mech.gears.len());
        for g in &mech.gears {
            let how = g.mesh.map_or_else(
                || "rigid".to_string(),
                |m| format!("compliant mesh {} N·m/rad, {} N·m·s/rad at the driver", m.stiffness, m.damping),
            );
            sayln!(
                "  {} follows {}: ratio {}, offset {} ({how})",
                mech.joints[g.joint].name,
                mech.joints[g.follows].name,
                g.ratio,
                g.offset
            );
        }
    }
    let l = &mech.loads;
    sayln!(
        "loads: gravity ({}, {}) m/s², {} joint torque(s), {} damper(s) to ground, {} point force(s)",
        l.gravity.x,
        l.gravity.y,
        l.joint_torques.len(),
        l.ground_dampers.len(),
        l.point_forces.len()
    );
    sayln!("total mass: {} kg", mech.total_mass());
    say!("{}", kanedyn::model::absorber::markdown(&mech));
    Ok(())
}

fn parse_list(name: &str, values: &[String], n: usize) -> Result<Vec<f64>> {
    if values.len() != n {
        let got = values.len();
        return Err(usage(format!("--{name} needs {n} comma-separated values (one per degree of freedom), got {got}")));
    }
    values
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let v: f64 =
                s.trim().parse().map_err(|_| usage(format!("--{name}: value {} `{s}` is not a number", i + 1)))?;
            if !v.is_finite() {
                return Err(usage(format!("--{name}: value {} is not finite ({s})", i + 1)));
            }
            Ok(v)
        })
        .collect()
}

fn eom(file: &Path, q: &[String], u: &[String], t: f64, torques: &[String]) -> Result<()> {
    let mech = Mechanism::from_file(file)?;
    let n = mech.ndof();
    let q = parse_list("q", q, n)?;
    let u = parse_list("u", u, n)?;
    if !t.is_finite() {
        return Err(usage("--t must be finite".into()));
    }
    let mut kane = Kane::new(&mech)?;
    for spec in torques {
        let (name, value) =
            spec.split_once('=').ok_or_else(|| usage(format!("--joint-torque `{spec}`: expected NAME=VALUE")))?;
        let joint = mech.joint_index(name.trim()).ok_or_else(|| {
            let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
            usage(format!("--joint-torque: unknown joint `{name}` (joints: {})", names.join(", ")))
        })?;
        let v: f64 = value
            .trim()
            .parse()
            .map_err(|e| usage(format!("--joint-torque `{spec}`: `{value}` is not a number: {e}")))?;
        if !v.is_finite() {
            return Err(usage(format!("--joint-torque `{spec}`: value is not finite")));
        }
        kane.set_joint_torque(joint, Excitation::constant(v));
    }
    let x: Vec<f64> = q.iter().chain(&u).copied().collect();
    let mut xdot = vec![0.0; 2 * n];
    kane.rhs(t, &x, &mut xdot).context("evaluating the equations of motion")?;
    let (m, f) = kane.mass_matrix_and_forcing(t, &q, &u);
    let rows: Vec<Vec<f64>> = (0..n).map(|r| (0..n).map(|c| m[(r, c)]).collect()).collect();
    // A struct keeps the documented key order; serde_json prints f64 in the shortest form that
    // parses back to the same bits.
    #[derive(serde::Serialize)]
    struct Eom {
        mass_matrix: Vec<Vec<f64>>,
        forcing: Vec<f64>,
        qdot: Vec<f64>,
        udot: Vec<f64>,
    }
    let out = Eom {
        mass_matrix: rows,
        forcing: f.iter().copied().collect(),
        qdot: xdot[..n].to_vec(),
        udot: xdot[n..].to_vec(),
    };
    // serde_json writes a non-finite number as `null`, which a reader would take for data.
    let first_bad =
        |name: &str, v: &[f64]| v.iter().position(|x| !x.is_finite()).map(|i| format!("{name}[{i}] = {}", v[i]));
    let bad = (out.mass_matrix.iter().enumerate())
        .find_map(|(r, row)| first_bad(&format!("M[{r}]"), row))
        .or_else(|| first_bad("F", &out.forcing))
        .or_else(|| first_bad("q̇", &out.qdot))
        .or_else(|| first_bad("u̇", &out.udot));
    if let Some(what) = bad {
        // The state given on the command line is out of range for this mechanism.
        return Err(usage(format!(
            "the equations of motion overflow at this state: {what} (values too large for f64?)"
        )));
    }
    sayln!("{}", serde_json::to_string(&out)?);
    Ok(())
}

/// How much `run` prints on success.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Verbosity {
    /// Nothing (`--quiet`): the exit code answers, errors go to stderr.
    Quiet,
    /// Progress bars (on a terminal), notes and the digest.
    Digest,
    /// Also the whole summary and the files written (`--verbose`).
    Verbose,
}

impl Verbosity {
    fn from_flags(verbose: bool, quiet: bool) -> Self {
        match (verbose, quiet) {
            (_, true) => Verbosity::Quiet,
            (true, false) => Verbosity::Verbose,
            (false, false) => Verbosity::Digest,
        }
    }
}

fn run(file: &Path, out: &Path, threads: Option<usize>, verbosity: Verbosity, limits: &LimitArgs) -> Result<()> {
    let quiet = verbosity == Verbosity::Quiet;
    if let Some(n) = threads {
        let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
        let cap = THREADS_PER_CORE * cores;
        if n > cap && !quiet {
            eprintln!(
                "note: --threads {n} lowered to {cap} ({THREADS_PER_CORE} per core on this {cores}-core machine)"
            );
        }
        // Only fails when a pool already exists, which cannot happen this early in main.
        rayon::ThreadPoolBuilder::new().num_threads(n.clamp(1, cap)).build_global().ok();
    }
    let study = Study::from_file_with(file, &limits.options()?)?;
    let start = std::time::Instant::now();
    let report = kanedyn::study::run(&study, &RunOptions { out: Some(out.to_path_buf()), progress: !quiet })?;
    if verbosity == Verbosity::Verbose {
        sayln!("{}", report.summary);
        sayln!("files written:");
        for f in &report.files {
            sayln!("  {}", f.display());
        }
        sayln!();
    }
    if !quiet {
        for line in kanedyn::study::digest(&study, &report, start.elapsed().as_secs_f64()) {
            sayln!("{line}");
        }
    }
    if !report.failures.is_empty() {
        let summary = report.files.iter().find(|f| f.ends_with("summary.md"));
        return Err(AnalysesFailed(format!(
            "{} failure(s): the other results are complete; see the Failures section of {}",
            report.failures.len(),
            summary.map_or("summary.md".into(), |p| p.display().to_string())
        ))
        .into());
    }
    Ok(())
}

/// `import`: an OpenTorsion model file to mechanism RON (kanedyn::opentorsion), checked by
/// loading it as `kanedyn check` would, so that what is written is known to load.
fn import(file: &Path, out: Option<&Path>, name: Option<&str>, max_file_kb: u64) -> Result<()> {
    let policy = kanedyn::io::ReadPolicy::unrestricted().with_max_file_bytes(max_file_kb.saturating_mul(1024));
    let src = kanedyn::io::Source::read_with(file, &policy)?;
    let stem = file.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ron = kanedyn::opentorsion::convert(file, &src.text, name.unwrap_or(&stem))?;
    let written = out.map_or_else(|| PathBuf::from("<stdout>"), Path::to_path_buf);
    // Loaded as if it sat where it is written, so a message names that file.
    let loaded = Mechanism::from_source(
        &kanedyn::io::Source::from_text(&written.display().to_string(), &ron),
        &kanedyn::io::ReadPolicy::within(Path::new("")),
    );
    match out {
        Some(path) => std::fs::write(path, &ron).with_context(|| format!("{}: cannot write", path.display()))?,
        None => say!("{ron}"),
    }
    loaded
        .map(|_| ())
        .map_err(|e| anyhow::Error::new(e).context("the converted mechanism was written but does not load as it is"))
}

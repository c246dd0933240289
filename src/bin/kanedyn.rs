//! The `kanedyn` command-line tool: check a mechanism, evaluate its equations of motion at a
//! state, run a study.

use anyhow::{Context, Result, anyhow, bail};
use clap::{Parser, Subcommand};
use kanedyn::excitation::Excitation;
use kanedyn::kane::Kane;
use kanedyn::mechanism::Mechanism;
use kanedyn::study::{RunOptions, Study};
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
    /// Validate a mechanism file and print its degrees of freedom, bodies, joints and total mass.
    Check {
        /// Mechanism file (RON).
        file: PathBuf,
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
    /// Run a study file: every analysis, with CSV, SVG and a Markdown summary in OUT/<study name>/.
    Run {
        /// Study file (RON).
        study: PathBuf,
        /// Output root folder.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// Number of worker threads (default: all cores).
        #[arg(long)]
        threads: Option<usize>,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Check { file } => check(&file),
        Command::Eom { file, q, u, t, joint_torque } => eom(&file, &q, &u, t, &joint_torque),
        Command::Run { study, out, threads } => run(&study, &out, threads),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", without_repeats(&e));
            ExitCode::FAILURE
        }
    }
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

fn check(file: &Path) -> Result<()> {
    let mech = Mechanism::from_file(file)?;
    println!("mechanism `{}` ({}): OK", mech.name, file.display());
    println!("degrees of freedom: {}", mech.ndof());
    println!("generalized speeds: {:?}", mech.speeds);
    println!("bodies: {}", mech.bodies.len());
    for b in &mech.bodies {
        let i = b.inertia;
        println!(
            "  {:<16} mass {:>10.6} kg   com ({:.6}, {:.6}) m   inertia {:.6e} kg·m²",
            b.name, i.mass, i.com.x, i.com.y, i.i_com
        );
    }
    println!("joints (coordinate order): {}", mech.joints.len());
    for (k, j) in mech.joints.iter().enumerate() {
        let parent = j.parent.map_or("ground", |p| mech.bodies[p].name.as_str());
        let mut extra = String::new();
        if j.damper > 0.0 {
            extra += &format!("   damper {} N·m·s/rad", j.damper);
        }
        if let Some(s) = j.spring {
            extra += &format!("   spring {} N·m/rad (free at {} rad)", s.stiffness, s.free_angle);
        }
        println!(
            "  q[{k}] {:<12} {:?} {} -> {} at ({}, {}) m{extra}",
            j.name, j.kind, parent, mech.bodies[k].name, j.at.x, j.at.y
        );
    }
    let l = &mech.loads;
    println!(
        "loads: gravity ({}, {}) m/s², {} joint torque(s), {} damper(s) to ground, {} point force(s)",
        l.gravity.x,
        l.gravity.y,
        l.joint_torques.len(),
        l.ground_dampers.len(),
        l.point_forces.len()
    );
    println!("total mass: {} kg", mech.total_mass());
    Ok(())
}

fn parse_list(name: &str, values: &[String], n: usize) -> Result<Vec<f64>> {
    if values.len() != n {
        bail!("--{name} needs {n} comma-separated values (one per degree of freedom), got {}", values.len());
    }
    values
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let v: f64 = s.trim().parse().map_err(|_| anyhow!("--{name}: value {} `{s}` is not a number", i + 1))?;
            if !v.is_finite() {
                bail!("--{name}: value {} is not finite ({s})", i + 1);
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
        bail!("--t must be finite");
    }
    let mut kane = Kane::new(&mech)?;
    for spec in torques {
        let (name, value) =
            spec.split_once('=').ok_or_else(|| anyhow!("--joint-torque `{spec}`: expected NAME=VALUE"))?;
        let joint = mech.joint_index(name.trim()).ok_or_else(|| {
            let names: Vec<&str> = mech.joints.iter().map(|j| j.name.as_str()).collect();
            anyhow!("--joint-torque: unknown joint `{name}` (joints: {})", names.join(", "))
        })?;
        let v: f64 =
            value.trim().parse().with_context(|| format!("--joint-torque `{spec}`: `{value}` is not a number"))?;
        if !v.is_finite() {
            bail!("--joint-torque `{spec}`: value is not finite");
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
        bail!("the equations of motion overflow at this state: {what} (values too large for f64?)");
    }
    println!("{}", serde_json::to_string(&out)?);
    Ok(())
}

fn run(file: &Path, out: &Path, threads: Option<usize>) -> Result<()> {
    if let Some(n) = threads {
        // Only fails when a pool already exists, which cannot happen this early in main.
        rayon::ThreadPoolBuilder::new().num_threads(n.max(1)).build_global().ok();
    }
    let study = Study::from_file(file)?;
    let start = std::time::Instant::now();
    let report = kanedyn::study::run(&study, &RunOptions { out: Some(out.to_path_buf()), progress: true })?;
    println!("{}", report.summary);
    println!("files written:");
    for f in &report.files {
        println!("  {}", f.display());
    }
    println!("study `{}` finished in {:.2} s", study.spec.name, start.elapsed().as_secs_f64());
    if !report.failures.is_empty() {
        bail!("{} run(s) failed (partial results written): {}", report.failures.len(), report.failures.join("; "));
    }
    Ok(())
}

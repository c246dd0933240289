//! Studies: one RON file in, every trace, table and figure out.
//!
//! A study names a mechanism, the spin joint that carries the excitation torque, the body whose
//! angular acceleration is reported, the joints to lock for the reference twin, and a list of
//! analyses (the paper's load cases). [`run`] executes them (independent runs in parallel with
//! rayon), writes CSV and SVG files into `<out>/<study name>/`, and returns a summary that is also
//! written as Markdown.

mod analysis;
mod backbone;
mod campbell;
pub mod compare;
pub mod design;
mod elements;
pub mod hbm;
pub mod json;
mod linear;
mod multi;
mod output;
pub mod plan;
mod report_html;
mod sim;
pub mod spec;
pub mod sweep;
mod table;
pub mod transient;
pub mod validate;

use crate::error::{Error, Result};
use crate::io::{ReadPolicy, Source};
use crate::kane::Kane;
use crate::model::mechanism::Mechanism;
use analysis::{Analysis, Output};
pub use backbone::FreeOscillationSpec;
pub use campbell::CampbellSpec;
pub use compare::{CompareMechanism, CompareSpec};
pub use design::{DesignParameter, DesignSpec, Quantity, Sampling};
pub use hbm::{HbmParameter, HbmSpec};
pub use linear::{LinearResponseSpec, Variant};
pub use multi::{MultiOrderSpec, SpeedPoint};
pub use plan::{AnalysisPlan, Limits, Plan};
use serde::{Deserialize, Serialize};
pub use spec::*;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
pub use sweep::{Direction, SweepSpec};
pub use transient::{EngineExcitation, JointTorqueSpec, OrderMapSpec, SpeedProfile, TransientSpec};

/// Declares the analysis kinds, one line each: `Kind(Spec)` is both the study file's entry
/// `Kind(…)` (the variant of [`AnalysisSpec`]) and the room whose [`Analysis`] runs it.
macro_rules! analyses {
    ($($(#[$doc:meta])* $kind:ident($spec:ty),)*) => {
        /// One analysis of a study, as written in its `analyses` list.
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        pub enum AnalysisSpec {
            $($(#[$doc])* $kind($spec),)*
        }

        impl AnalysisSpec {
            /// The analysis kind as written in the study file (`OrderSweep`, …).
            pub fn kind(&self) -> &'static str {
                match self {
                    $(AnalysisSpec::$kind(_) => stringify!($kind),)*
                }
            }

            /// The analysis behind the entry, as the study driver calls it.
            pub(crate) fn analysis(&self) -> &dyn Analysis {
                match self {
                    $(AnalysisSpec::$kind(a) => a,)*
                }
            }
        }
    };
}

analyses! {
    /// Single-order excitation swept in order (the paper's load case 1, Figs. 3 and 4).
    OrderSweep(SweepSpec),
    /// Multi-order excitation at steady speeds (the paper's load case 2, Table 1, Fig. 5).
    MultiOrder(MultiOrderSpec),
    /// Linear order-domain frequency response normalised by the locked twin (eq. 22, Fig. 2).
    LinearResponse(LinearResponseSpec),
    /// Natural frequencies against spin speed with engine-order lines.
    Campbell(CampbellSpec),
    /// Periodic steady states by harmonic balance, continued in the excitation order, with
    /// stability: the branches behind the sweeps' jumps.
    HarmonicBalance(HbmSpec),
    /// One analysis run over many cases of varied mechanism and excitation parameters (a grid, a
    /// Latin hypercube or Monte Carlo), collected in one table (see [`design`]).
    DesignStudy(DesignSpec),
    /// A transient from a given state: free, or through a run-up or run-down of the spin speed
    /// (driven by a torque or prescribed), with an order–rpm map of the response.
    Transient(TransientSpec),
    /// The free oscillation of one joint at held spin, undamped, against its release amplitude:
    /// the absorber's backbone curve (see [`backbone`]).
    FreeOscillation(FreeOscillationSpec),
    /// The same analyses run on several mechanisms (e.g. absorber paths), their results overlaid
    /// per analysis in one figure and compared in one table (see [`compare`]).
    Compare(CompareSpec),
}

impl AnalysisSpec {
    /// The analysis name (its file prefix).
    pub fn name(&self) -> &str {
        self.analysis().name()
    }
}

/// A study ready to run: the spec, its mechanism and the locked twin, with names resolved.
#[derive(Debug, Clone)]
pub struct Study {
    /// The spec as read.
    pub spec: StudySpec,
    /// The study file.
    pub file: PathBuf,
    /// The mechanism.
    pub mechanism: Mechanism,
    /// The mechanism with the `lock` joints locked at q = 0, if any are named.
    pub locked: Option<Mechanism>,
    /// Index of the spin joint.
    pub spin: usize,
    /// The joints reported element by element (`elements` of the spec, or every joint with a
    /// coordinate but the spin joint), by index.
    pub elements: Vec<usize>,
    /// Index of the response body.
    pub body: usize,
    /// Index of the response body in the locked twin.
    pub locked_body: Option<usize>,
    /// The study file's text, to name the line of an analysis that fails at run time.
    pub source: Source,
    /// The mechanisms of each `Compare` analysis, by the analysis's index: per mechanism its
    /// label and the study that runs the comparison's analyses on it (see [`compare`]).
    pub comparisons: Vec<(usize, compare::Compared)>,
}

/// How a study is loaded: where its files may come from and the limits its estimated work is
/// checked against.
#[derive(Debug, Clone)]
pub struct LoadOptions {
    /// Limits on memory, output size and CPU time.
    pub limits: Limits,
    /// Folders besides the study's own folder tree that its mechanism and parts may be read
    /// from (`--allow-read DIR`).
    pub allow_read: Vec<PathBuf>,
    /// Read the mechanism and parts from any path (`--allow-any-path`).
    pub allow_any_path: bool,
    /// Largest input file, bytes (`--max-file-kb`).
    pub max_file_bytes: u64,
    /// Most bodies in the mechanism (`--max-bodies`).
    pub max_bodies: usize,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            limits: Limits::default(),
            allow_read: Vec::new(),
            allow_any_path: false,
            max_file_bytes: ReadPolicy::DEFAULT_MAX_FILE_BYTES,
            max_bodies: ReadPolicy::DEFAULT_MAX_BODIES,
        }
    }
}

impl LoadOptions {
    /// The read policy for the files named by the study file `study_file`: its folder tree and
    /// the allowed folders, or anywhere.
    pub fn policy_for(&self, study_file: &Path) -> ReadPolicy {
        let policy = if self.allow_any_path {
            ReadPolicy::unrestricted()
        } else {
            let base = study_file.parent().unwrap_or(Path::new(""));
            self.allow_read.iter().fold(ReadPolicy::within(base), |p, d| p.allow(d))
        };
        policy.with_max_file_bytes(self.max_file_bytes).with_max_bodies(self.max_bodies)
    }
}

/// What a study produced: the Markdown summary and the files written.
#[derive(Debug, Clone, Default)]
pub struct StudyReport {
    /// Markdown summary (also written to `summary.md`).
    pub summary: String,
    /// Files written, in order.
    pub files: Vec<PathBuf>,
    /// Runs that failed (their partial output is still written), with the reason.
    pub failures: Vec<String>,
    /// Sweep results, for tests and further processing.
    pub sweeps: Vec<sweep::SweepRun>,
    /// Multi-order results.
    pub multi: Vec<multi::MultiOrderResult>,
    /// Linear frequency-response results.
    pub linear: Vec<linear::LinearResult>,
    /// Harmonic-balance branches.
    pub hbm: Vec<hbm::HbmBranch>,
    /// Campbell diagrams.
    pub campbell: Vec<crate::linear::Campbell>,
    /// Design studies' case tables.
    pub designs: Vec<design::DesignResult>,
    /// Transients and run-ups.
    pub transient: Vec<transient::TransientResult>,
    /// Free oscillations (backbone curves).
    pub free: Vec<backbone::FreeOscillationResult>,
    /// Comparisons: which of their analyses ran to the end on each mechanism (their results are
    /// in the fields above, under the names `<comparison>_<label>_<analysis>`).
    pub compares: Vec<compare::CompareResult>,
    /// Per analysis of the study file, in its order: whether it ran to the end (its results are
    /// in the fields above; single runs of it may still have failed) rather than failing whole.
    pub completed: Vec<bool>,
}

pub use backbone::FreeOscillationResult;
pub use compare::CompareResult;
pub use linear::{GravityResponse, LinearResult, ResponseVariant};
pub use multi::{MultiOrderResult, SpeedResult};
pub use sweep::SweepRun;

impl Study {
    /// Reads a study file and its mechanism with the default [`LoadOptions`], resolving every
    /// name and checking every field and the estimated work; errors name the file, the
    /// line:column and the field.
    pub fn from_file(path: &Path) -> Result<Self> {
        Self::from_file_with(path, &LoadOptions::default())
    }

    /// [`Study::from_file`] with explicit options.
    pub fn from_file_with(path: &Path, opts: &LoadOptions) -> Result<Self> {
        Self::from_source(
            Source::read_with(path, &ReadPolicy::unrestricted().with_max_file_bytes(opts.max_file_bytes))?,
            opts,
        )
    }

    /// Parses and validates a study from its text; its mechanism is read relative to
    /// `src.file`'s folder.
    pub fn from_source(src: Source, opts: &LoadOptions) -> Result<Self> {
        let spec: StudySpec = src.parse_as("Study")?;
        if let Err(m) = validate::check_file_name(&spec.name) {
            return Err(src.error("name", format!("{m} (the study name is its output folder)")));
        }
        Self::from_spec(spec, src, opts)
    }

    /// A study from its parsed spec (`src` is the study file, for locating errors): reads the
    /// mechanism, resolves every name and checks every field and the estimated work.
    pub(crate) fn from_spec(mut spec: StudySpec, src: Source, opts: &LoadOptions) -> Result<Self> {
        spec.integration.watchdog = opts.limits.watchdog;
        let policy = opts.policy_for(&src.file);
        let base = src.file.parent().map(Path::to_path_buf).unwrap_or_default();
        engine_harmonics(&mut spec, &src, &policy, &base)?;
        let mech_path = policy.resolve(&base, &spec.mechanism).map_err(|m| src.error("mechanism", m))?;
        let mechanism = Mechanism::from_file_with(&mech_path, &policy).map_err(|e| match e {
            Error::Io { .. } => src.error("mechanism", format!("cannot read mechanism file: {e}")),
            other if matches!(&other, Error::Input { location, .. } if location.file == mech_path) => {
                whole_file_at(other, &src, "mechanism")
            }
            other => other,
        })?;
        let joint_names = || mechanism.joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ");
        let spin = mechanism.joint_index(&spec.spin_joint).ok_or_else(|| {
            src.error("spin_joint", format!("unknown joint `{}` (joints: {})", spec.spin_joint, joint_names()))
        })?;
        if mechanism.joints[spin].parent.is_some() {
            return Err(src.error(
                "spin_joint",
                format!("joint `{}` does not connect to ground: the spin joint must", spec.spin_joint),
            ));
        }
        if mechanism.joints[spin].kind != crate::model::joint::JointKind::Revolute {
            return Err(src.error(
                "spin_joint",
                format!("joint `{}` is not revolute: the spin joint turns the rotor", spec.spin_joint),
            ));
        }
        let body = mechanism.body_index(&spec.response_body).ok_or_else(|| {
            let names: Vec<&str> = mechanism.bodies.iter().map(|b| b.name.as_str()).collect();
            src.error("response_body", format!("unknown body `{}` (bodies: {})", spec.response_body, names.join(", ")))
        })?;
        if let Some(j) = mechanism.turning_path_above(body) {
            return Err(src.error(
                "response_body",
                format!(
                    "body `{}` turns with the path joint `{}` (its rotation law), whose turn the \
                     rotor response does not include yet: choose a body above it",
                    spec.response_body, mechanism.joints[j].name
                ),
            ));
        }
        let mut locked = None;
        for (i, j) in spec.lock.iter().enumerate() {
            let m = locked.as_ref().unwrap_or(&mechanism);
            if m.joint_index(j).is_none() {
                return Err(
                    src.error(&format!("lock[{i}]"), format!("unknown joint `{j}` (joints: {})", joint_names()))
                );
            }
            if *j == spec.spin_joint {
                return Err(src.error(&format!("lock[{i}]"), "the spin joint cannot be locked"));
            }
            locked = Some(m.lock(j, 0.0).map_err(|e| src.error(&format!("lock[{i}]"), e.to_string()))?);
        }
        let locked_body = match &locked {
            Some(m) => Some(m.body_index(&spec.response_body).ok_or_else(|| {
                src.error("lock", format!("locking merges the response body `{}` away", spec.response_body))
            })?),
            None => None,
        };
        let elements = if spec.elements.is_empty() {
            (0..mechanism.joints.len()).filter(|&j| j != spin && mechanism.coordinate(j).is_some()).collect()
        } else {
            if spec.elements.len() > validate::MAX_LIST {
                let n = spec.elements.len();
                return Err(src.error("elements", format!("{n} elements; at most {}", validate::MAX_LIST)));
            }
            let mut out = Vec::with_capacity(spec.elements.len());
            for (i, name) in spec.elements.iter().enumerate() {
                let field = format!("elements[{i}]");
                let j = mechanism
                    .joint_index(name)
                    .ok_or_else(|| src.error(&field, format!("unknown joint `{name}` (joints: {})", joint_names())))?;
                // A rigidly driven joint is reported through its gear (factor · the followed
                // coordinate); a Fixed one has nothing to report.
                if mechanism.follow_map()[j].is_none() {
                    return Err(src.error(&field, format!("joint `{name}` is Fixed: it has no motion to report")));
                }
                if out.contains(&j) {
                    return Err(src.error(&field, format!("joint `{name}` is listed twice")));
                }
                out.push(j);
            }
            out
        };
        validate::check(&spec, &mechanism, spin, &src)?;
        let comparisons = compare::load(&spec, &src, opts)?;
        let file = src.file.clone();
        let study =
            Study { spec, file, mechanism, locked, spin, elements, body, locked_body, source: src, comparisons };
        if let Some((k, driver, message)) = study.plan().exceeds(&opts.limits) {
            return Err(study.source.error(&format!("analyses[{k}].{driver}"), message));
        }
        Ok(study)
    }

    /// A copy whose time runs (its comparisons' too) stop `budget_s` of wall time from now.
    fn with_deadline(&self, budget_s: f64) -> Study {
        let mut s = self.clone();
        let at = std::time::Instant::now()
            .checked_add(std::time::Duration::from_secs_f64(budget_s.min(1e9)))
            .unwrap_or_else(|| std::time::Instant::now() + std::time::Duration::from_secs(1 << 30));
        let deadline = Some(spec::Deadline { at, budget_s });
        s.spec.integration.deadline = deadline;
        for (_, subs) in &mut s.comparisons {
            for (_, sub) in subs {
                sub.spec.integration.deadline = deadline;
            }
        }
        s
    }

    /// Mean torque that holds the spin joint's subtree in rigid rotation at `omega` (rad/s): the
    /// viscous losses at the steady rates of [`Mechanism::steady_rates`], by power. A damper whose
    /// rate is `w Ω` (a joint's relative rate, or a ground damper's body rate `Σ w` over the
    /// rotating joints on its path) dissipates `c w² Ω²`, which the spin joint supplies as the
    /// torque `c w² Ω`: on a plain rotor the spinning bodies' ground dampers and the spin joint's
    /// own damper (`Σ c·Ω`; for the CPVA `T_m = c_r·Ω`), and through a gear of factor r a driven
    /// shaft's dampers reflected as `r² c Ω`. In rigid rotation about fixed axes the inertia
    /// forces have no moment about the axes, and joint dampers inside a rigidly turning subtree
    /// see no relative rate. Nonlinear couplings (friction, stops) are not counted.
    pub fn loss_torque(mech: &Mechanism, spin: usize, omega: f64) -> f64 {
        let w = mech.steady_rates(spin);
        let joints: f64 = mech.joints.iter().zip(&w).map(|(j, w)| j.damper * w * w).sum();
        let body_rate = |b: usize| -> f64 {
            mech.path_to(b).into_iter().filter(|&j| mech.joints[j].kind.rotates()).map(|j| w[j]).sum()
        };
        let ground: f64 = mech.loads.ground_dampers.iter().map(|g| g.c * body_rate(g.body).powi(2)).sum();
        (joints + ground) * omega
    }

    /// The initial state of a sweep or steady run (docs/design.md): q = 0, the spin joint turning at
    /// `omega`, every joint geared to it at its steady rate ([`Mechanism::steady_rates`]: a shaft
    /// behind a compliant mesh turns with the train) and every other joint at rest relative to its
    /// parent.
    pub fn initial_state(mech: &Mechanism, spin: usize, omega: f64) -> Vec<f64> {
        let n = mech.ndof();
        let mut qdot = vec![0.0; n];
        for (joint, w) in mech.joints.iter().zip(mech.steady_rates(spin)) {
            if let Some(k) = joint.coordinate {
                qdot[k] = w * omega;
            }
        }
        let mut u = vec![0.0; n];
        mech.speeds.u_from_qdot(&mech.speed_parents(), &qdot, &mut u);
        let mut x = vec![0.0; 2 * n];
        x[n..].copy_from_slice(&u);
        x
    }

    /// The linear analyses' inputs for an analysis's `excite` list: its joints with their shares
    /// and phases, or the spin joint alone.
    pub(crate) fn inputs(&self, excite: &[ExciteAt]) -> Vec<crate::linear::Input> {
        if excite.is_empty() {
            return vec![crate::linear::Input::unit(self.spec.spin_joint.clone())];
        }
        excite.iter().map(|e| crate::linear::Input { joint: e.joint.clone(), scale: e.scale, phase: e.phase }).collect()
    }

    /// An analysis's `excite` list resolved in `mech` (the mechanism or its locked twin) as
    /// `(joint, scale, phase)`; the spin joint alone when the list is empty. The names were
    /// checked at load (and none is locked, see `validate`).
    pub(crate) fn excited_joints(&self, mech: &Mechanism, excite: &[ExciteAt]) -> Vec<(usize, f64, f64)> {
        let spin = mech.joint_index(&self.spec.spin_joint).unwrap_or(self.spin);
        if excite.is_empty() {
            return vec![(spin, 1.0, 0.0)];
        }
        excite.iter().filter_map(|e| mech.joint_index(&e.joint).map(|j| (j, e.scale, e.phase))).collect()
    }

    /// Sets `kane`'s joint torques for an order excitation: `base`'s mean on the spin joint and
    /// its harmonics, scaled and phase-shifted, at each excited joint (see [`ExciteAt`]).
    pub(crate) fn apply_excitation(
        &self,
        kane: &mut Kane,
        mech: &Mechanism,
        excite: &[ExciteAt],
        base: &crate::model::excitation::Excitation,
    ) {
        let spin = mech.joint_index(&self.spec.spin_joint).unwrap_or(self.spin);
        let joints = self.excited_joints(mech, excite);
        if !joints.iter().any(|j| j.0 == spin) {
            kane.set_joint_torque(spin, crate::model::excitation::Excitation { harmonics: Vec::new(), ..base.clone() });
        }
        for (j, scale, phase) in joints {
            let harmonics = base
                .harmonics
                .iter()
                .map(|h| crate::model::excitation::Harmonic {
                    amplitude: scale * h.amplitude,
                    phase: h.phase + phase,
                    ..*h
                })
                .collect();
            // The mean stays the mechanism's own on every joint but the spin joint, as in the
            // linear operating point and the harmonic balance (a preload such as an engine's
            // mean torque on a joint chain must not vanish with the oscillating part).
            let own = mech_mean(kane, j);
            let mean = if j == spin { base.mean } else { own };
            kane.set_joint_torque(j, crate::model::excitation::Excitation { mean, harmonics, ..base.clone() });
        }
    }

    /// Builds the evaluator of the mechanism (or the locked twin).
    pub(crate) fn kane(&self, locked: bool) -> Result<Kane> {
        match (locked, &self.locked) {
            (true, Some(m)) => Kane::new(m),
            _ => Kane::new(&self.mechanism),
        }
    }
}

/// The mean of the torque the mechanism file applies at joint `j` (0 when none).
fn mech_mean(kane: &Kane, j: usize) -> f64 {
    kane.joint_torques().iter().find(|t| t.joint == j).map_or(0.0, |t| t.excitation.mean)
}

/// Highest order of a transient's engine series: engine orders that matter for torsional
/// vibration stay below ~50, and each kept order costs a term in every right-hand side.
pub const MAX_ENGINE_ORDER: f64 = 64.0;

/// Resolves every analysis that names an engine, when the study is loaded: a multi-order
/// analysis gets each speed's harmonics (the orders that are whole multiples of its base order,
/// up to `engine_multiples`), a harmonic balance continued in speed and a transient the engine's
/// [`crate::engine::OscillatingSeries`], whose amplitudes follow the speed as they run. Errors are
/// located in the study file or in the engine file.
fn engine_harmonics(spec: &mut StudySpec, src: &Source, policy: &ReadPolicy, base: &Path) -> Result<()> {
    use crate::engine::Engine;
    // Too many analyses is `validate`'s error; no engine work is spent on such a file.
    if spec.analyses.len() > validate::MAX_ANALYSES {
        return Ok(());
    }
    // Each engine file is read and prepared once, however many analyses name it.
    let mut engines: std::collections::HashMap<PathBuf, Engine> = std::collections::HashMap::new();
    let mut load = |field: &str, file: &str| -> Result<Engine> {
        let path = policy.resolve(base, file).map_err(|e| src.error(field, e))?;
        if let Some(e) = engines.get(&path) {
            return Ok(e.clone());
        }
        let esrc = Source::read_with(&path, policy).map_err(|e| match e {
            Error::Io { .. } => src.error(field, format!("cannot read engine file: {e}")),
            other => whole_file_at(other, src, field),
        })?;
        let engine = Engine::new(esrc.parse_as("Engine")?).map_err(|(f, msg)| esrc.error(&f, msg))?;
        engines.insert(path, engine.clone());
        Ok(engine)
    };
    let half_multiple = |v: f64| v.is_finite() && v > 0.0 && v <= validate::MAX_ORDER && (2.0 * v).fract() == 0.0;
    for (k, a) in spec.analyses.iter_mut().enumerate() {
        let at = |f: &str| format!("analyses[{k}].{f}");
        match a {
            AnalysisSpec::MultiOrder(m) => {
                let Some(file) = &m.engine else { continue };
                let engine = load(&at("engine"), file)?;
                if !(1..=validate::MAX_LIST).contains(&m.engine_multiples) {
                    return Err(
                        src.error(&at("engine_multiples"), format!("need 1 to {} multiples", validate::MAX_LIST))
                    );
                }
                if !half_multiple(m.order) {
                    return Err(src.error(
                        &at("order"),
                        format!(
                            "with an engine the base order must be a multiple of ½ (its orders are), got {}",
                            m.order
                        ),
                    ));
                }
                if m.speeds.len() > validate::MAX_LIST {
                    return Err(
                        src.error(&at("speeds"), format!("{} speeds; at most {}", m.speeds.len(), validate::MAX_LIST))
                    );
                }
                for (i, p) in m.speeds.iter_mut().enumerate() {
                    if !p.harmonics.is_empty() {
                        return Err(src.error(
                            &at(&format!("speeds[{i}].harmonics")),
                            "give either the harmonics or the analysis's engine, not both",
                        ));
                    }
                    if !(p.rpm.is_finite() && p.rpm > 0.0 && p.rpm <= validate::MAX_RPM) {
                        return Err(src.error(&at(&format!("speeds[{i}].rpm")), "speed must be within 0 < rpm ≤ 1e6"));
                    }
                    let top = m.order * m.engine_multiples as f64;
                    let series = engine.orders(crate::model::excitation::rpm_to_rad_s(p.rpm), top);
                    p.harmonics = series
                        .harmonics
                        .iter()
                        .filter_map(|h| {
                            let multiple = 0.5 * h.multiple / m.order;
                            ((multiple - multiple.round()).abs() < 1e-9 && multiple >= 1.0).then(|| {
                                crate::model::excitation::Harmonic {
                                    multiple: multiple.round(),
                                    amplitude: h.amplitude,
                                    phase: h.phase,
                                }
                            })
                        })
                        .collect();
                }
            }
            AnalysisSpec::HarmonicBalance(h) => {
                let Some(file) = &h.engine else { continue };
                let HbmParameter::Speed { order, .. } = h.parameter else {
                    return Err(src.error(
                        &at("engine"),
                        "an engine's amplitudes follow the speed: only a harmonic balance continued in                          `parameter: Speed(…)` takes one",
                    ));
                };
                if !h.amplitudes.is_empty() {
                    return Err(src.error(&at("amplitudes"), "give either the amplitudes or the engine, not both"));
                }
                if !half_multiple(order) {
                    return Err(src.error(
                        &at("parameter"),
                        format!("with an engine the order must be a multiple of ½ (its orders are), got {order}"),
                    ));
                }
                // The balance keeps `harmonics` multiples of the order: more from the engine
                // would be dropped, so they are refused rather than lost.
                if !(1..=h.harmonics.clamp(1, 64)).contains(&h.engine_multiples) {
                    return Err(src.error(
                        &at("engine_multiples"),
                        format!("need 1 to harmonics = {} multiples", h.harmonics.clamp(1, 64)),
                    ));
                }
                let engine = load(&at("engine"), file)?;
                h.engine_series = engine.oscillating_series(order, order * h.engine_multiples as f64);
            }
            AnalysisSpec::Transient(t) => {
                let Some(e) = &mut t.engine else { continue };
                if !half_multiple(e.order) {
                    return Err(src.error(
                        &at("engine.order"),
                        format!("the base order must be a multiple of ½ (the engine's orders are), got {}", e.order),
                    ));
                }
                if !(e.max_order.is_finite() && e.max_order >= e.order && e.max_order <= MAX_ENGINE_ORDER) {
                    return Err(src.error(
                        &at("engine.max_order"),
                        format!("must lie within order ({}) ≤ max_order ≤ {MAX_ENGINE_ORDER}", e.order),
                    ));
                }
                if !(e.ramp_s.is_finite() && (0.0..=validate::MAX_TRANSIENT_S).contains(&e.ramp_s)) {
                    return Err(src.error(&at("engine.ramp_s"), "the ramp must be finite and non-negative (s)"));
                }
                let engine = load(&at("engine.file"), &e.file)?;
                e.series = engine.oscillating_series(e.order, e.max_order);
            }
            AnalysisSpec::DesignStudy(d) => {
                if let AnalysisSpec::HarmonicBalance(h) = d.analysis.as_ref()
                    && h.engine.is_some()
                {
                    return Err(src.error(
                        &at("analysis.engine"),
                        "a design study's harmonic balance takes typed amplitudes, not an engine",
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// Options of [`run`].
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Output root; the study writes into `<out>/<study name>/` (default `out`).
    pub out: Option<PathBuf>,
    /// Show progress bars on stderr (only drawn when stderr is a terminal).
    pub progress: bool,
}

/// Runs every analysis of the study, writes the outputs and returns the summary.
///
/// One failure never costs the others their results: an analysis (or one run of it) that fails
/// or panics is listed under "Failures" in the summary and in [`StudyReport::failures`] with its
/// file:line:column, its partial output is kept, and the remaining analyses still run. The
/// outputs are written into a temporary folder that replaces `<out>/<name>/` only at the end
/// (see `output`), and `summary.md` is always written, with `results.json` (every number of
/// the summary and the CSV files, see [`json`]) next to it.
///
/// # Errors
/// Only when the output folder cannot be prepared or moved into place, or another run holds it.
pub fn run(study: &Study, opts: &RunOptions) -> Result<StudyReport> {
    let root = opts.out.clone().unwrap_or_else(|| PathBuf::from("out"));
    let out = output::OutputDir::begin(&root, &study.spec.name)?;
    let dir = out.dir().to_path_buf();
    let progress = sim::Progress::new(opts.progress);
    let mut report = StudyReport::default();
    let mut md = String::new();
    let _ = writeln!(md, "# Study `{}`\n", study.spec.name);
    let _ = writeln!(
        md,
        "Mechanism `{}` ({} DOF), excitation on joint `{}`, response: angular acceleration of `{}`{}.\n",
        study.mechanism.name,
        study.mechanism.ndof(),
        study.spec.spin_joint,
        study.spec.response_body,
        if study.spec.lock.is_empty() {
            String::new()
        } else {
            format!("; locked twin with {} locked", study.spec.lock.join(", "))
        }
    );
    // The absorbers' properties once, before the analyses (empty without an absorber).
    let mut sections = crate::model::absorber::markdown(&study.mechanism);
    let plan = study.plan();
    for (k, a) in study.spec.analyses.iter().enumerate() {
        let where_ = study.source.locate(&format!("analyses[{k}]")).to_string();
        // The watchdog: this analysis's loops stop once it overruns its plan by the set factor.
        let budget_s = study.spec.integration.watchdog.budget_s(plan.analyses[k].cpu_s);
        let timed = study.with_deadline(budget_s);
        let (section, completed) = run_guarded(&timed, a, &where_, &dir, &progress, &mut report);
        report.completed.push(completed);
        sections += &section;
    }
    if report.failures.is_empty() {
        md += "Status: complete.\n\n";
    } else {
        let _ = writeln!(
            md,
            "**Status: partial results** — {} failure(s), listed under Failures at the end; the other \
             results are complete.\n",
            report.failures.len()
        );
    }
    md += &sections;
    for f in &mut report.failures {
        *f = finite_text(f);
    }
    if !report.failures.is_empty() {
        let _ = writeln!(md, "## Failures\n");
        for f in &report.failures {
            let _ = writeln!(md, "- {f}");
        }
        md.push('\n');
    }
    let md = finite_text(&md);
    let path = dir.join("summary.md");
    write_file(&path, &md)?;
    report.files.push(path);
    report.files.push(json::write(study, &report, &dir)?);
    let page = report_html::write(&dir, &study.spec.name, &md, &report.failures, &report.files)?;
    report.files.push(page);
    report.summary = md;
    let final_dir = out.finish()?;
    for f in &mut report.files {
        if let Ok(rel) = f.strip_prefix(&dir) {
            *f = final_dir.join(rel);
        }
    }
    Ok(report)
}

/// Runs one analysis with its failures named and contained: a failure or panic of the whole
/// analysis becomes its summary section and an entry of [`StudyReport::failures`]; failures of
/// single runs are prefixed with the analysis's kind, name and `where_` (its place in the study
/// file). Returns the summary section and whether the analysis ran to the end.
pub(crate) fn run_guarded(
    study: &Study,
    a: &AnalysisSpec,
    where_: &str,
    dir: &Path,
    progress: &sim::Progress,
    report: &mut StudyReport,
) -> (String, bool) {
    let before = report.failures.len();
    let attempt =
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| run_analysis(study, a, dir, progress, report)));
    for f in &mut report.failures[before..] {
        *f = format!("{} `{}` ({where_}): {f}", a.kind(), a.name());
    }
    let failure = match attempt {
        Ok(Ok(section)) => return (section, true),
        Ok(Err(e)) => e.to_string(),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_default();
            format!("internal error (please report): {what}")
        }
    };
    report.failures.push(format!("{} `{}` ({where_}): {failure}", a.kind(), a.name()));
    (format!("## {} `{}`\n\nFailed: {failure}\n\n", a.kind(), a.name()), false)
}

/// Runs one analysis, adding its files, failures and results to `report`; returns its section of
/// the summary.
pub(crate) fn run_analysis(
    study: &Study,
    a: &AnalysisSpec,
    dir: &Path,
    progress: &sim::Progress,
    report: &mut StudyReport,
) -> Result<String> {
    let out = a.analysis().run(study, &mut analysis::Bench { dir, progress, report })?;
    report.files.extend(out.files);
    report.failures.extend(out.failures);
    out.results.keep(report);
    Ok(out.markdown)
}

/// `a / reference`, or NaN ("undefined", an empty CSV cell) when the reference is zero or below
/// `1e-5 · scale`: a locked (linear) twin answers only at the lines it is excited at, and its
/// other traces are numerical noise of ~1e-6 of its largest, whose ratios would read as huge
/// amplifications.
pub(crate) fn ratio(a: f64, reference: f64, scale: f64) -> f64 {
    if reference.abs() > 1e-5 * scale.abs() && reference != 0.0 { a / reference } else { f64::NAN }
}

/// The last guard of the promise that no output reads `NaN` or `inf`: every such word outside
/// backticks (names are quoted in backticks, so a mechanism called `inf` keeps its name) becomes
/// "undefined". The summaries format their numbers with [`cell`] and friends; this catches a
/// number a formatter missed, e.g. in a solver's error message, before it reaches summary.md,
/// results.json or report.html (issue 25: a multi-order run printed "NaN (locked 1.7e-14)").
/// A word here runs over letters, digits and `-+._/\`, so a path such as `/tmp/nan/s.ron` is
/// one word and left alone.
pub(crate) fn finite_text(text: &str) -> String {
    let word_char = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '+' | '.' | '_' | '/' | '\\');
    let mut out = String::with_capacity(text.len());
    let mut quoted = false;
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        if !word_char(c) {
            quoted ^= c == '`';
            out.push(c);
            rest = &rest[c.len_utf8()..];
            continue;
        }
        let end = rest.find(|c: char| !word_char(c)).unwrap_or(rest.len());
        let word = &rest[..end];
        let bare = word.trim_start_matches(['-', '+']).to_ascii_lowercase();
        if !quoted && matches!(bare.as_str(), "nan" | "inf" | "infinity") {
            out.push_str("undefined");
        } else {
            out.push_str(word);
        }
        rest = &rest[end..];
    }
    out
}

/// An error about a whole file that a study names (a folder, a pipe, a file over the size cap:
/// no line, no field), moved to the study field that named it; other errors unchanged. Such
/// errors used to name the file alone, not where the study asked for it.
fn whole_file_at(e: Error, src: &Source, field: &str) -> Error {
    match e {
        Error::Input { location, message } if location.line_col.is_none() && location.path.is_empty() => {
            src.error(field, format!("{}: {message}", location.file.display()))
        }
        other => other,
    }
}

/// A number for a summary table, or `undefined` when it is not finite.
pub(crate) fn cell(v: f64, precision: usize) -> String {
    if v.is_finite() { format!("{v:.precision$}") } else { "undefined".into() }
}

/// Writes a text file, naming it on failure.
pub(crate) fn write_file(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e })
}

/// Writes a CSV file with a header row and columns of equal length; non-finite values are written
/// as empty cells.
pub(crate) fn write_csv(path: &Path, header: &[&str], columns: &[&[f64]]) -> Result<()> {
    let io = |e: csv::Error| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e.into() };
    let mut w = csv::Writer::from_path(path).map_err(io)?;
    w.write_record(header).map_err(io)?;
    let rows = columns.iter().map(|c| c.len()).min().unwrap_or(0);
    let mut rec = Vec::with_capacity(columns.len());
    for r in 0..rows {
        rec.clear();
        // A value that does not exist or apply (a ratio to a zero reference, a trace that does
        // not reach this order) is NaN in memory and an empty cell on disk, never `NaN`/`inf`.
        rec.extend(columns.iter().map(|c| if c[r].is_finite() { c[r].to_string() } else { String::new() }));
        w.write_record(&rec).map_err(io)?;
    }
    w.flush().map_err(|e| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e })
}

#[cfg(test)]
mod finite_text_tests {
    use super::finite_text;

    #[test]
    fn non_finite_words_become_undefined_but_names_and_paths_stay() {
        assert_eq!(finite_text("| NaN (locked 1.7e-14) |"), "| undefined (locked 1.7e-14) |");
        assert_eq!(finite_text("t = -inf, x = Infinity"), "t = undefined, x = undefined");
        assert_eq!(finite_text("mechanism `inf` at /tmp/nan/s.ron:3:4"), "mechanism `inf` at /tmp/nan/s.ron:3:4");
        assert_eq!(finite_text("information, finite, 1e-300, inflow"), "information, finite, 1e-300, inflow");
    }
}

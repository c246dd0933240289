//! A design problem and its evaluation: the mechanism at a design x, each operating speed's
//! torque branch from rest to past the operating torques, the jump (the branch's first fold in
//! torque) located exactly, the operating states polished on the branch, and every value's
//! gradient in x by the sensitivity room (one factorisation per state, one back-solve per
//! variable; the fold's by its left null vector).

use crate::hbm::{
    ContinuationOptions, DesignPoint, Direction, FoldPlane, Hbm, HbmError, HbmOptions, HbmSolution, MechanismFamily,
    Parameter,
};
use crate::kane::Kane;
use crate::model::excitation::Harmonic;
use crate::model::mechanism::Mechanism;

/// What sets one design variable's value (its unit) in a mechanism; an error says why the value
/// cannot be had (a tuning order out of reach).
pub type Setter = dyn Fn(&mut Mechanism, f64) -> Result<(), String> + Send + Sync;

/// One continuous design variable and its bounds.
pub struct Variable {
    /// Its name, as the outputs write it.
    pub name: String,
    /// Lower bound, in the variable's unit.
    pub lower: f64,
    /// Upper bound, in the variable's unit (> lower).
    pub upper: f64,
    /// Sets the value in a mechanism.
    pub set: Box<Setter>,
}

impl std::fmt::Debug for Variable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Variable")
            .field("name", &self.name)
            .field("lower", &self.lower)
            .field("upper", &self.upper)
            .finish()
    }
}

/// An absorber design problem on a rotor excited at one order: minimise the largest rotor
/// response over an operating set (speeds × torque amplitudes) subject to an absorber travel
/// and a margin against the jump.
#[derive(Debug)]
pub struct Problem {
    /// The base mechanism; each design sets its variables in a copy.
    pub mechanism: Mechanism,
    /// Index of the spin joint (the rotor whose response is minimised).
    pub spin: usize,
    /// Indices of the absorber joints whose peak swing the travel bounds.
    pub absorbers: Vec<usize>,
    /// Excitation order n.
    pub order: f64,
    /// Operating mean speeds Ω, rad/s.
    pub speeds: Vec<f64>,
    /// Operating torque amplitudes T_n of the order, N·m (> 0).
    pub torques: Vec<f64>,
    /// Largest absorber swing allowed, rad (None: unbounded).
    pub travel: Option<f64>,
    /// The jump torque must be at least this multiple of the largest operating torque (None:
    /// no jump constraint; the operating states must still lie before the jump).
    pub jump_margin: Option<f64>,
    /// Harmonics kept in the balance.
    pub harmonics: usize,
    /// The design variables.
    pub variables: Vec<Variable>,
}

/// The response at one operating point of a design, with its gradient in the variables.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct OperatingValue {
    /// Mean speed, rpm.
    pub rpm: f64,
    /// Torque amplitude T_n, N·m.
    pub torque_nm: f64,
    /// The rotor's acceleration amplitude at the order, rad/s².
    pub rotor_accel: f64,
    /// Its gradient in the variables (per unit of each).
    pub rotor_accel_gradient: Vec<f64>,
    /// The largest absorber peak swing, rad.
    pub absorber_peak: f64,
    /// Its gradient in the variables.
    pub absorber_peak_gradient: Vec<f64>,
    /// Whether the torque lies past the jump: the values are then the jump state's (the branch
    /// a rising torque follows ends there), with zero gradients.
    pub beyond_jump: bool,
}

/// The jump at one operating speed: the torque at which the branch from rest first folds.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct JumpValue {
    /// Mean speed, rpm.
    pub rpm: f64,
    /// The jump torque, N·m; None when the branch does not fold below the searched torque.
    pub torque_nm: Option<f64>,
    /// Its gradient in the variables (zeros without a jump).
    pub gradient: Vec<f64>,
}

/// A design's values and gradients over the operating set.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Evaluation {
    /// The design, in the variables' units.
    pub x: Vec<f64>,
    /// Per speed, per torque (speed-major).
    pub points: Vec<OperatingValue>,
    /// Per speed.
    pub jumps: Vec<JumpValue>,
    /// Harmonic-balance solves spent: continuation points, polishes and fold solves.
    pub solves: usize,
}

impl Evaluation {
    /// The largest rotor response over the set, rad/s².
    pub fn worst_response(&self) -> f64 {
        self.points.iter().map(|p| p.rotor_accel).fold(0.0, f64::max)
    }
}

/// Why a design could not be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum SynthesisError {
    /// The mechanism at the design is invalid (a variable out of reach, a mass matrix that is
    /// not positive definite).
    #[error("design {x:?}: {message}")]
    Design {
        /// The design.
        x: Vec<f64>,
        /// Why.
        message: String,
    },
    /// The harmonic balance failed at the design.
    #[error("design {x:?} at {rpm} rpm: {source}")]
    Balance {
        /// The design.
        x: Vec<f64>,
        /// The speed, rpm.
        rpm: f64,
        /// The failure.
        source: HbmError,
    },
    /// The problem is ill-posed (named).
    #[error("{0}")]
    Invalid(String),
}

/// The torque scale the branch is followed to, in units of the largest operating torque: past
/// the jump margin so that a jump just above it is located, not cut off.
pub(super) fn search_scale(margin: Option<f64>) -> f64 {
    1.25 * margin.unwrap_or(1.0).max(1.0)
}

impl Problem {
    /// The mechanism at design `x`.
    ///
    /// # Errors
    /// A variable that cannot take its value, or a mechanism the engine refuses.
    pub fn mechanism_at(&self, x: &[f64]) -> Result<Mechanism, SynthesisError> {
        let mut mech = self.mechanism.clone();
        for (v, &value) in self.variables.iter().zip(x) {
            (v.set)(&mut mech, value).map_err(|message| SynthesisError::Design { x: x.to_vec(), message })?;
        }
        Ok(mech)
    }

    /// The balance at design `x` and speed Ω (rad/s), its torque T_ref = the largest operating
    /// torque at scale 1.
    fn balance(&self, x: &[f64], omega: f64) -> Result<Hbm, HbmError> {
        let mech = self.mechanism_at(x).map_err(|e| HbmError::Invalid(e.to_string()))?;
        let kane = Kane::new(&mech).map_err(|e| HbmError::Invalid(e.to_string()))?;
        let t_ref = self.torques.iter().copied().fold(0.0, f64::max);
        let harmonic = [Harmonic { multiple: 1.0, amplitude: t_ref, phase: 0.0 }];
        let opts = HbmOptions { harmonics: self.harmonics, ..HbmOptions::default() };
        Hbm::new(&kane, self.spin, omega, &harmonic, opts)
    }

    /// Checks what can be checked before any solve.
    ///
    /// # Errors
    /// An empty operating set or variable list, a bound pair out of order, a non-positive
    /// torque, speed, travel or margin.
    pub fn check(&self) -> Result<(), SynthesisError> {
        let bad = |m: String| Err(SynthesisError::Invalid(m));
        if self.variables.is_empty() {
            return bad("a synthesis needs at least one design variable".into());
        }
        for v in &self.variables {
            if !(v.lower.is_finite() && v.upper.is_finite() && v.lower < v.upper) {
                return bad(format!(
                    "variable `{}`: bounds [{}, {}] must be finite and increasing",
                    v.name, v.lower, v.upper
                ));
            }
        }
        if self.speeds.is_empty() || self.torques.is_empty() {
            return bad("the operating set needs at least one speed and one torque".into());
        }
        if self.speeds.iter().chain(&self.torques).any(|v| !(v.is_finite() && *v > 0.0)) {
            return bad("operating speeds and torques must be finite and positive".into());
        }
        if self.travel.is_some_and(|t| !(t.is_finite() && t > 0.0))
            || self.jump_margin.is_some_and(|m| !(m.is_finite() && m > 0.0))
        {
            return bad("the travel and the jump margin must be finite and positive".into());
        }
        if !(self.order.is_finite() && self.order > 0.0) {
            return bad(format!("the order must be finite and positive, got {}", self.order));
        }
        Ok(())
    }

    /// The design's values and gradients over the operating set.
    ///
    /// # Errors
    /// A design the mechanism cannot take, a balance that fails (no branch from rest, a jump
    /// that cannot be located or differentiated).
    pub fn evaluate(&self, x: &[f64]) -> Result<Evaluation, SynthesisError> {
        let mut out = Evaluation { x: x.to_vec(), points: Vec::new(), jumps: Vec::new(), solves: 0 };
        for &omega in &self.speeds {
            let rpm = omega * 30.0 / std::f64::consts::PI;
            let fail = |source| SynthesisError::Balance { x: x.to_vec(), rpm, source };
            let (points, jump, solves) = self.at_speed(x, omega).map_err(fail)?;
            out.points.extend(points);
            out.jumps.push(jump);
            out.solves += solves;
        }
        Ok(out)
    }

    /// One speed's operating values, its jump and the solves spent.
    fn at_speed(&self, x: &[f64], omega: f64) -> Result<(Vec<OperatingValue>, JumpValue, usize), HbmError> {
        let rpm = omega * 30.0 / std::f64::consts::PI;
        let n = self.order;
        let t_ref = self.torques.iter().copied().fold(0.0, f64::max);
        let mut hbm = self.balance(x, omega)?;
        let copts = ContinuationOptions { stability: false, ..ContinuationOptions::default() };
        let to = search_scale(self.jump_margin);
        let branch = hbm.continue_in(Parameter::TorqueScale { order: n }, 0.0, to, None, &copts)?;
        let mut solves = branch.points.len();
        // The design points of every variable at this speed, built once for all its states.
        let designs = self.design_points(x, omega)?;
        let dirs: Vec<Direction<'_>> = designs.iter().map(Direction::Design).collect();
        let first_fold = branch.folds.first();
        let (jump, jump_state) = match first_fold {
            Some(fold) => {
                let guess = &branch.points[fold.after].solution;
                let point = hbm.fold_at_value(FoldPlane::Order, n, guess)?;
                solves += 1;
                let ds = hbm.fold_sensitivities(FoldPlane::Torque { order: n }, &point, &dirs)?;
                let gradient = ds.iter().map(|d| d * t_ref).collect();
                (JumpValue { rpm, torque_nm: Some(point.scale * t_ref), gradient }, Some(point.solution))
            }
            None => (JumpValue { rpm, torque_nm: None, gradient: vec![0.0; x.len()] }, None),
        };
        let last_before = first_fold.map_or(branch.points.len() - 1, |f| f.after);
        let mut values = Vec::with_capacity(self.torques.len());
        for &torque in &self.torques {
            let s = torque / t_ref;
            let past = jump.torque_nm.is_some_and(|tj| torque >= tj);
            let value = if past {
                let sol = jump_state.as_ref().expect("a jump torque comes with its state");
                self.read(sol, rpm, torque, None)
            } else {
                let i = branch.points[..=last_before]
                    .iter()
                    .rposition(|p| p.parameter <= s)
                    .unwrap_or(0)
                    .min(last_before.saturating_sub(1));
                let (a, b) = (branch.points[i].parameter, branch.points[i + 1].parameter);
                let sigma = if b > a { ((s - a) / (b - a)).clamp(0.0, 1.0) } else { 0.0 };
                let guess = branch.interpolate(i, sigma).unwrap_or_else(|| branch.points[i].solution.clone());
                hbm.set_torque_scale(s)?;
                let sol = hbm.solve(n, Some(&guess))?;
                solves += 1;
                let sens = hbm.state_sensitivities(&sol, &dirs)?;
                self.read(&sol, rpm, torque, Some(&sens))
            };
            values.push(value);
        }
        Ok((values, jump, solves))
    }

    /// Each variable's design point at x and Ω: the problems at x_i ± h.
    fn design_points(&self, x: &[f64], omega: f64) -> Result<Vec<DesignPoint>, HbmError> {
        (0..x.len())
            .map(|i| {
                let build = |p: f64| {
                    let mut y = x.to_vec();
                    y[i] = p;
                    self.balance(&y, omega)
                };
                let v = &self.variables[i];
                let reference = x[i].abs().max(v.upper - v.lower);
                let family = MechanismFamily { build: &build, scale: 1.0, reference, speed: false };
                DesignPoint::new(&family, x[i])
            })
            .collect()
    }

    /// The values read from a state, with their gradients from its sensitivities (zeros
    /// without).
    fn read(
        &self,
        sol: &HbmSolution,
        rpm: f64,
        torque: f64,
        sens: Option<&[crate::hbm::StateSensitivity]>,
    ) -> OperatingValue {
        let nvar = self.variables.len();
        let rotor_accel = sol.order_acceleration(sol.spin, 1.0);
        let grad = |f: &dyn Fn(&crate::hbm::StateSensitivity) -> f64| {
            sens.map_or(vec![0.0; nvar], |s| s.iter().map(f).collect())
        };
        let rotor_accel_gradient = grad(&|s| s.order_acceleration(sol, sol.spin, 1.0));
        let coords: Vec<usize> = self.absorbers.iter().filter_map(|&j| self.mechanism.coordinate(j)).collect();
        let worst = coords.iter().copied().max_by(|&a, &b| sol.peak_amplitude(a).total_cmp(&sol.peak_amplitude(b)));
        let (absorber_peak, absorber_peak_gradient) = match worst {
            Some(k) => (sol.peak_amplitude(k), grad(&|s| s.peak_amplitude(sol, k))),
            None => (0.0, vec![0.0; nvar]),
        };
        OperatingValue {
            rpm,
            torque_nm: torque,
            rotor_accel,
            rotor_accel_gradient,
            absorber_peak,
            absorber_peak_gradient,
            beyond_jump: sens.is_none(),
        }
    }
}

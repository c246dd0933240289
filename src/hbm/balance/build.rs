//! The construction of a harmonic-balance problem ([`Hbm::new`] and its variants): the spin
//! joint and inputs checked, the base frequency ω₀ found from the excitation's multiples, the
//! excitation's generalized forces tabulated at the N_t samples, and the work buffers of the
//! assembly planned once, so that no residual allocates.

use super::options::{HbmError, HbmOptions};
use super::problem::Hbm;
use super::sample::{Evaluator, SampleLin};
use crate::hbm::series::{Aft, Upsampler};
use crate::kane::Kane;
use crate::model::excitation::{Excitation, Harmonic};
use crate::model::gears::Follow;
use crate::model::loads::JointTorque;
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};
use realfft::num_complex::Complex;
use std::f64::consts::PI;

/// One excitation term in normalised time: `amplitude · sin(index·τ + phase)` (tabulated at the
/// samples in [`Hbm::new`]).
#[derive(Debug, Clone, Copy)]
struct Term {
    index: f64,
    amplitude: f64,
    phase: f64,
}

impl Hbm {
    /// Sets up the problem for `kane`'s mechanism (cloned), spin joint index `spin_joint`, mean
    /// speed `omega` (rad/s) and the excitation terms `T_k sin(m_k n Ω t + α_k)` of `harmonics`
    /// (multiple m_k, amplitude T_k in N·m, phase α_k in rad).
    ///
    /// Errors when the spin joint is not a root joint with a cyclic angle (gravity or a
    /// world-frame force, or a spring on it), when another joint carries an oscillating torque,
    /// when a multiple is not a positive rational with denominator ≤ 12, or when the options are
    /// inconsistent.
    pub fn new(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        harmonics: &[Harmonic],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        Self::with_inputs(kane, spin_joint, omega, harmonics, &[(spin_joint, 1.0, 0.0)], options)
    }

    /// [`Hbm::new`] with the oscillating torque acting at several joints: joint `j` of each
    /// `(j, scale, phase)` of `inputs` carries `scale · T_k sin(m_k n Ω t + α_k + phase)` (child
    /// against parent; the mean torque stays on the spin joint). Each joint's torque enters the
    /// residual through its own generalized force `∂q̇_j/∂u`. The joints' own oscillating
    /// torques, if any, are replaced.
    pub fn with_inputs(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        harmonics: &[Harmonic],
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        Self::with_speed_forcing(kane, spin_joint, omega, harmonics, &[], inputs, options)
    }

    /// [`Hbm::with_inputs`] with a forcing that follows the mean speed, as an engine's does:
    /// `Σ T_k sin(m_k n Ω t + α_k) + Ω² Σ T'_k sin(m'_k n Ω t + α'_k)`, the terms T'_k of
    /// `per_omega2` in N·m·s²/rad² (an engine's reciprocating-inertia torque per Ω², its gas
    /// torque in `harmonics`, see [`crate::combustion::OscillatingSeries::split_harmonics`]). A
    /// continuation in [`Parameter::Speed`](crate::hbm::Parameter::Speed) then carries the forcing along, and its ∂R̂/∂Ω holds
    /// the forcing's derivative `2Ω Σ T'_k sin(…)`.
    pub fn with_speed_forcing(
        kane: &Kane,
        spin_joint: usize,
        omega: f64,
        harmonics: &[Harmonic],
        per_omega2: &[Harmonic],
        inputs: &[(usize, f64, f64)],
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        let mech = kane.mechanism();
        let n = kane.ndof();
        let (spin, cyclic, rotation) = spin_coordinate(mech, spin_joint)?;
        if !(omega.is_finite() && omega > 0.0) {
            return Err(HbmError::Invalid(format!("mean speed must be positive and finite, got {omega} rad/s")));
        }
        // A rigidly driven joint is excited through its gear: its torque reaches the coordinate it
        // follows times the factor (Tᵀ, docs/design/model.md "Gears").
        let follow = mech.follow_map();
        check_inputs(mech, &follow, inputs)?;
        let torques = replaced_torques(kane, spin_joint, inputs)?;
        let opts = options;
        let nt = time_samples(&opts)?;
        let (ratio, terms, terms2) = base_terms(harmonics, per_omega2)?;
        let t_scale = (harmonics.iter().map(|h| h.amplitude.abs()).sum::<f64>()
            + omega * omega * per_omega2.iter().map(|h| h.amplitude.abs()).sum::<f64>())
        .max(1.0);
        let mut kane = kane.clone();
        for &(j, _, _) in inputs {
            let mean = torques.iter().find(|t| t.joint == j).map_or(0.0, |t| t.excitation.mean);
            kane.set_joint_torque(j, Excitation::constant(mean));
        }
        kane.set_joint_torque(spin_joint, Excitation::constant(0.0));
        let parents = mech.speed_parents();
        let speeds = mech.speeds;
        let w = speeds.w_matrix(&parents);
        let g = spin_force(speeds, &parents, n, spin);
        let forcing = Forcing { speeds, parents: &parents, n, nt, spin };
        let (exc, exc2) = forcing.tables(inputs, &follow, &terms, &terms2);
        let nb = 2 * opts.harmonics + 1;
        let couplings = mech
            .joints
            .iter()
            .filter_map(|j| j.coordinate.filter(|_| !j.couplings.is_empty()).map(|k| (k, j.couplings.clone())))
            .collect();
        let ev = Evaluator::new(kane, speeds, parents, (0..n * n).map(|i| w[(i / n, i % n)]).collect(), g);
        let tree_rate = tree_rate(mech, spin_joint, omega, n);
        Ok(Self {
            couplings,
            non_unison: Vec::new(),
            on_point: None,
            pair_senses: Vec::new(),
            ev,
            n,
            spin,
            spin_column_zero: cyclic && rotation.iter().enumerate().all(|(k, &z)| k == spin || z == 0.0),
            rotation,
            cyclic,
            omega,
            scale: 1.0,
            ratio,
            t_scale,
            opts,
            nb,
            aft: Aft::new(nt, opts.harmonics),
            exc,
            exc2,
            qt: vec![0.0; n * nt],
            qdt: vec![0.0; n * nt],
            qddt: vec![0.0; n * nt],
            rt: vec![0.0; n * nt],
            dpt: vec![0.0; n * nt],
            series: vec![0.0; nt],
            spectra: vec![Complex::default(); 3 * n * n * (nt / 2 + 1)],
            unfolded: vec![(0.0, 0.0); 3 * n * n * (4 * opts.harmonics + 1)],
            zero_series: vec![false; 3 * n * n],
            zero_blocks: vec![false; n * n],
            q: vec![0.0; n],
            qd: vec![0.0; n],
            qdd: vec![0.0; n],
            lin: SampleLin::new(n),
            samples: vec![0.0; nt * 3 * n * n],
            samples_at: None,
            rhat_at: None,
            upsampler: Upsampler::new(opts.stability_samples.max(2)),
            tree_upsampler: None,
            tree_rate,
            tree_buffers: Default::default(),
            rhat: DVector::zeros(n * nb),
            jac: DMatrix::zeros(n * nb, n * nb),
            gp: DVector::zeros(n * nb),
        })
    }

    /// Like [`Hbm::new`], taking Ω (from `rpm`) and the terms from an [`Excitation`]; its mean
    /// (solved instead), order (the free parameter) and ramp (steady state) are not used.
    pub fn from_excitation(
        kane: &Kane,
        spin_joint: usize,
        excitation: &Excitation,
        options: HbmOptions,
    ) -> Result<Self, HbmError> {
        Self::new(kane, spin_joint, excitation.omega(), &excitation.harmonics, options)
    }
}

/// The spin joint's coordinate, whether its angle is cyclic (no gravity, no world-frame force)
/// and every coordinate's share of the mean rotation; an error where the spin joint cannot
/// spin freely about ground.
fn spin_coordinate(mech: &Mechanism, spin_joint: usize) -> Result<(usize, bool, Vec<f64>), HbmError> {
    let bad = |m: String| Err(HbmError::Invalid(m));
    if spin_joint >= mech.joints.len() {
        return bad(format!("spin joint index {spin_joint} out of range (mechanism has {} joints)", mech.joints.len()));
    }
    let sj = &mech.joints[spin_joint];
    if sj.parent.is_some() {
        return bad(format!("spin joint `{}` must connect a body to ground", sj.name));
    }
    // The unknowns are per coordinate: the spin's is its joint's (a welded joint has none).
    let Some(spin) = sj.coordinate.filter(|_| sj.kind.rotates()) else {
        return bad(format!("spin joint `{}` does not rotate: it cannot spin", sj.name));
    };
    if sj.spring.is_some_and(|s| s.stiffness != 0.0) {
        return bad(format!("spin joint `{}` has a spring: its angle is not cyclic", sj.name));
    }
    if sj.couplings.stages.is_some() || sj.couplings.stops.is_some() {
        return bad(format!("spin joint `{}` has a staged spring or end stops: its angle is not cyclic", sj.name));
    }
    // Gravity or a world-frame force: the spin angle is not cyclic, the forces depend on it
    // with period 2π, and a periodic solution needs a base period that is a whole number of
    // revolutions (checked per solve, see `check_base`).
    let cyclic = !mech.loads.needs_world_orientation();
    // The mean rotation of every coordinate (1 at the spin, the ratios through meshes): a
    // geared train turns as a whole (issue 29, item 1).
    let rotation = mech.rigid_rotation(spin_joint).map_err(HbmError::Invalid)?;
    if !cyclic && rotation.iter().enumerate().any(|(k, &z)| k != spin && z != 0.0) {
        return bad("gravity or a world-frame force with joints meshed to the spin joint: they turn at other \
                    rates, so the forcing has no common period"
            .into());
    }
    Ok((spin, cyclic, rotation))
}

/// Every excitation input at a joint with a coordinate (its own or the one it follows through
/// a gear), with a finite scale and phase.
fn check_inputs(mech: &Mechanism, follow: &[Option<Follow>], inputs: &[(usize, f64, f64)]) -> Result<(), HbmError> {
    for &(j, scale, phase) in inputs {
        if follow.get(j).copied().flatten().is_none() {
            return Err(HbmError::Invalid(format!(
                "excitation input: joint #{j} has no coordinate (Fixed or out of range)"
            )));
        }
        if !(scale.is_finite() && phase.is_finite()) {
            return Err(HbmError::Invalid(format!(
                "excitation input at joint `{}`: scale and phase must be finite",
                mech.joints[j].name
            )));
        }
    }
    Ok(())
}

/// The engine's joint torques, of which the spin joint's and the inputs' are replaced by the
/// balance's own; an error where another joint carries an oscillating torque.
fn replaced_torques(
    kane: &Kane,
    spin_joint: usize,
    inputs: &[(usize, f64, f64)],
) -> Result<Vec<JointTorque>, HbmError> {
    let mech = kane.mechanism();
    // A geared engine's unconstrained tree holds every joint torque, the driven joints' too.
    let torques = kane.unconstrained().map_or(kane.joint_torques(), |u| u.joint_torques()).to_vec();
    for jt in &torques {
        let replaced = jt.joint == spin_joint || inputs.iter().any(|i| i.0 == jt.joint);
        if !replaced && jt.excitation.harmonics.iter().any(|h| h.amplitude != 0.0) {
            return Err(HbmError::Invalid(format!(
                "joint `{}` carries an oscillating torque; only the spin joint may be excited",
                mech.joints[jt.joint].name
            )));
        }
    }
    Ok(torques)
}

/// The time samples per period N_t of `opts` (4(H + 1) when automatic), after checking the
/// harmonic count and the stability samples.
fn time_samples(opts: &HbmOptions) -> Result<usize, HbmError> {
    let bad = |m: String| Err(HbmError::Invalid(m));
    if opts.harmonics == 0 {
        return bad("at least one harmonic is needed".into());
    }
    let nt = if opts.time_samples == 0 { 4 * (opts.harmonics + 1) } else { opts.time_samples };
    if nt < 2 * opts.harmonics + 1 {
        return bad(format!("{nt} time samples cannot resolve {} harmonics (need ≥ 2H + 1)", opts.harmonics));
    }
    if opts.stability_samples != 0 && (opts.stability_samples < 8 || !opts.stability_samples.is_multiple_of(4)) {
        return bad(format!(
            "stability_samples must be a multiple of 4 and ≥ 8 (or 0), got {}",
            opts.stability_samples
        ));
    }
    Ok(nt)
}

/// The base frequency's ratio ω₀/(nΩ) and the terms of `harmonics` and of `per_omega2` in
/// normalised time: the multiples as fractions k_i/d with a common denominator d ≤ 12, ω₀ their
/// greatest common divisor.
fn base_terms(harmonics: &[Harmonic], per_omega2: &[Harmonic]) -> Result<(f64, Vec<Term>, Vec<Term>), HbmError> {
    let mut ratio = 1.0;
    let mut terms = Vec::new();
    let all: Vec<Harmonic> = harmonics.iter().chain(per_omega2).copied().collect();
    if !all.is_empty() {
        let harmonics = &all;
        for h in harmonics {
            if !(h.multiple.is_finite() && h.multiple > 0.0 && h.amplitude.is_finite() && h.phase.is_finite()) {
                return Err(HbmError::Invalid(format!(
                    "excitation term {h:?}: multiple must be positive, all numbers finite"
                )));
            }
        }
        let d = (1..=12u64)
            .find(|&d| harmonics.iter().all(|h| (h.multiple * d as f64 - (h.multiple * d as f64).round()).abs() < 1e-9))
            .ok_or_else(|| HbmError::Invalid("excitation multiples must be rationals with denominator ≤ 12".into()))?;
        let ints: Vec<u64> = harmonics.iter().map(|h| (h.multiple * d as f64).round() as u64).collect();
        let g = ints.iter().fold(0, |a, &b| gcd(a, b));
        ratio = g as f64 / d as f64;
        terms = harmonics
            .iter()
            .zip(&ints)
            .map(|(h, &k)| Term { index: (k / g) as f64, amplitude: h.amplitude, phase: h.phase })
            .collect();
    }
    // The terms of `per_omega2` follow those of `harmonics` in `terms`.
    let terms2 = terms.split_off(terms.len().min(harmonics.len()));
    Ok((ratio, terms, terms2))
}

/// g_r = ∂q̇_s/∂u_r: a spin torque τ does τ q̇_s of power.
fn spin_force(speeds: Speeds, parents: &[Option<usize>], n: usize, spin: usize) -> Vec<f64> {
    let mut g = vec![0.0; n];
    let (mut e, mut qd) = (vec![0.0; n], vec![0.0; n]);
    for r in 0..n {
        e.iter_mut().for_each(|x| *x = 0.0);
        e[r] = 1.0;
        speeds.qdot(parents, &e, &mut qd);
        g[r] = qd[spin];
    }
    g
}

/// What the excitation's generalized forces are tabulated with: the speeds and their parents,
/// n coordinates, N_t samples and the spin coordinate (where an input without a gear acts).
struct Forcing<'a> {
    speeds: Speeds,
    parents: &'a [Option<usize>],
    n: usize,
    nt: usize,
    spin: usize,
}

impl Forcing<'_> {
    /// The oscillating torque's generalized force at every sample: Σ_inputs g_j · T_j(τ), with
    /// `g_j[r] = ∂q̇_j/∂u_r` (a torque τ at joint j does τ q̇_j of power); the same for the forcing
    /// per Ω² (empty without one).
    fn tables(
        &self,
        inputs: &[(usize, f64, f64)],
        follow: &[Option<Follow>],
        terms: &[Term],
        terms2: &[Term],
    ) -> (Vec<f64>, Vec<f64>) {
        let (n, nt, spin) = (self.n, self.nt, self.spin);
        let (mut e, mut qd) = (vec![0.0; n], vec![0.0; n]);
        let mut exc = vec![0.0; n * nt];
        let mut exc2 = vec![0.0; if terms2.is_empty() { 0 } else { n * nt }];
        for &(joint, scale, phase) in inputs {
            let (c, factor) = follow[joint].map_or((spin, 1.0), |f| (f.coordinate, f.factor));
            let mut gj = vec![0.0; n];
            for (r, g) in gj.iter_mut().enumerate() {
                e.iter_mut().for_each(|x| *x = 0.0);
                e[r] = 1.0;
                self.speeds.qdot(self.parents, &e, &mut qd);
                *g = factor * qd[c];
            }
            for j in 0..nt {
                let tau = 2.0 * PI * j as f64 / nt as f64;
                let t: f64 = terms.iter().map(|t| t.amplitude * (t.index * tau + t.phase + phase).sin()).sum();
                let t2: f64 = terms2.iter().map(|t| t.amplitude * (t.index * tau + t.phase + phase).sin()).sum();
                for (r, g) in gj.iter().enumerate() {
                    exc[r * nt + j] += scale * g * t;
                    if !exc2.is_empty() {
                        exc2[r * nt + j] += scale * g * t2;
                    }
                }
            }
        }
        (exc, exc2)
    }
}

/// The largest eigenvalue modulus (1/s) of the mechanism linearised about its steady spin at Ω
/// and that Ω, for the tree route's monodromy; None below seven coordinates or where the
/// linearisation fails.
fn tree_rate(mech: &Mechanism, spin_joint: usize, omega: f64, n: usize) -> Option<(f64, f64)> {
    if 2 * n > 12 {
        use crate::linear::{Damping, LinearModel, Spin};
        LinearModel::new(mech, &mech.joints[spin_joint].name, omega, None)
            .and_then(|m| m.fastest_rate(Spin::Free, Damping::Damped))
            .ok()
            .filter(|r| r.is_finite())
            .map(|r| (r, omega))
    } else {
        None
    }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// The canonical CPVA at 1000 rpm under one order of amplitude `amplitude` (N·m), with
/// `time_samples` (0: automatic) and the speeds `speeds`: the problem of the unit tests.
#[cfg(test)]
pub(in crate::hbm) fn test_problem(amplitude: f64, time_samples: usize, speeds: crate::model::speeds::Speeds) -> Hbm {
    let mut mech = crate::cpva::CpvaParams::canonical().mechanism(None).unwrap();
    mech.speeds = speeds;
    let kane = Kane::new(&mech).unwrap();
    let h = [Harmonic { multiple: 1.0, amplitude, phase: 0.0 }];
    let omega = crate::model::excitation::rpm_to_rad_s(1000.0);
    Hbm::new(&kane, 0, omega, &h, HbmOptions { time_samples, ..HbmOptions::default() }).unwrap()
}

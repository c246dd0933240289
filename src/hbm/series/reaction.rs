//! Joint reactions of a harmonic-balance solution as order harmonics: the Newton–Euler pass of
//! [`crate::kane::reactions`] on the solution's own q, q̇, q̈ (its Fourier series differentiated
//! term by term) at equally spaced times over one period, then a real FFT. With N samples per
//! period the harmonics up to N/2 − 1 are exact for a band-limited signal; the reaction is a
//! smooth function of a state whose series stops at H, so 8(H + 1) samples leave the aliasing of
//! its products far below the series' own truncation.
//!
//! On a geared mechanism the pass runs on the unconstrained tree at the expanded state (see
//! [`crate::kane::reactions`]), and the torque each gear mesh transmits has its harmonics too
//! ([`HbmSolution::mesh_torque_harmonics`], from [`crate::kane::Kane::gear_torques`] at the same
//! samples).

use super::solution::HbmSolution;
use crate::kane::Kane;
use crate::model::mechanism::Mechanism;
use realfft::RealFftPlanner;

/// One joint's reaction on a periodic solution, by harmonic of the solution's base frequency.
#[derive(Debug, Clone, PartialEq)]
pub struct ReactionHarmonics {
    /// Mean radial force, tangential force (N) and moment (N·m).
    pub mean: [f64; 3],
    /// Amplitude of harmonic h (index h − 1) of the radial force, tangential force (N) and
    /// moment (N·m).
    pub amplitudes: Vec<[f64; 3]>,
}

/// One gear mesh's torque on its driven joint over a periodic solution, by harmonic.
#[derive(Debug, Clone, PartialEq)]
pub struct MeshTorqueHarmonics {
    /// Mean torque, N·m (N on a prismatic driven joint).
    pub mean: f64,
    /// Amplitude of harmonic h (index h − 1) of the base frequency, N·m (N).
    pub amplitudes: Vec<f64>,
}

/// Mean and amplitudes of harmonics 1..=h of one period of samples, by a real FFT.
fn harmonics_of(series: &mut [f64], h: usize) -> (f64, Vec<f64>) {
    let samples = series.len();
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(samples);
    let mut spec = fft.make_output_vec();
    // The lengths match the plan, so the transform cannot fail.
    if fft.process(series, &mut spec).is_err() {
        return (f64::NAN, vec![f64::NAN; h]);
    }
    let mean = spec[0].re / samples as f64;
    (mean, (1..=h).map(|k| 2.0 * spec[k].norm() / samples as f64).collect())
}

impl HbmSolution {
    /// The torque the mesh of coupling `gear` (index into `mech.gears`) exerts on its driven
    /// joint over one period, as its mean and harmonics 1..=H of the base frequency:
    /// [`Kane::gear_torques`] on the solution's q, q̇ = u, q̈ = u̇ (couplings need joint rates) at
    /// 8(H + 1) times of the period, then a real FFT (see the module docs). `kane` is an engine
    /// of the solution's mechanism; only the joint torques it applies at driven joints enter (a
    /// rigid coupling's balance there), so `Kane::new(mech)` serves unless a driven joint is
    /// excited: then give it that excitation with `ramp_s: 0` and the solution's torque scale,
    /// its time origin being the solution's. `None` when `gear` is out of range.
    pub fn mesh_torque_harmonics(&self, kane: &mut Kane, gear: usize) -> Option<MeshTorqueHarmonics> {
        if gear >= kane.mechanism().gears.len() {
            return None;
        }
        let n = self.ndof();
        let samples = 8 * (self.harmonics + 1);
        let period = 2.0 * std::f64::consts::PI / self.base_frequency;
        let mut series = vec![0.0; samples];
        let mut qdd = vec![0.0; n];
        for (i, v) in series.iter_mut().enumerate() {
            let t = period * i as f64 / samples as f64;
            let (q, qd) = self.coordinates_at(t);
            for (k, a) in qdd.iter_mut().enumerate() {
                *a = self.periodic_part(k, t).2;
            }
            *v = kane.gear_torques(t, &q, &qd, &qdd).get(gear).copied().unwrap_or(f64::NAN);
        }
        let (mean, amplitudes) = harmonics_of(&mut series, self.harmonics);
        Some(MeshTorqueHarmonics { mean, amplitudes })
    }

    /// The reaction at joint `joint` of `mech` (the mechanism the solution was computed on) over
    /// one period, as its mean and harmonics 1..=H of the base frequency (see the module docs).
    /// On a geared mechanism a driven joint's moment holds its mesh torque.
    pub fn reaction_harmonics(&self, mech: &Mechanism, joint: usize) -> ReactionHarmonics {
        let n = self.ndof();
        let samples = 8 * (self.harmonics + 1);
        let period = 2.0 * std::f64::consts::PI / self.base_frequency;
        let mut series = [vec![0.0; samples], vec![0.0; samples], vec![0.0; samples]];
        let mut qdd = vec![0.0; n];
        for i in 0..samples {
            let t = period * i as f64 / samples as f64;
            let (q, qd) = self.coordinates_at(t);
            for (k, a) in qdd.iter_mut().enumerate() {
                *a = self.periodic_part(k, t).2;
            }
            let r = crate::kane::reactions::joint_reactions(mech, &q, &qd, &qdd)[joint];
            series[0][i] = r.radial;
            series[1][i] = r.tangential;
            series[2][i] = r.moment;
        }
        let mut mean = [0.0; 3];
        let mut amplitudes = vec![[0.0; 3]; self.harmonics];
        for (c, s) in series.iter_mut().enumerate() {
            let (m, a) = harmonics_of(s, self.harmonics);
            mean[c] = m;
            for (out, v) in amplitudes.iter_mut().zip(a) {
                out[c] = v;
            }
        }
        ReactionHarmonics { mean, amplitudes }
    }
}

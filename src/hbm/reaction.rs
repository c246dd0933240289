//! Joint reactions of a harmonic-balance solution as order harmonics: the Newton–Euler pass of
//! [`crate::kane::reactions`] on the solution's own q, q̇, q̈ (its Fourier series differentiated
//! term by term) at equally spaced times over one period, then a real FFT. With N samples per
//! period the harmonics up to N/2 − 1 are exact for a band-limited signal; the reaction is a
//! smooth function of a state whose series stops at H, so 8(H + 1) samples leave the aliasing of
//! its products far below the series' own truncation.

use super::HbmSolution;
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

impl HbmSolution {
    /// The reaction at joint `joint` of `mech` (the mechanism the solution was computed on) over
    /// one period, as its mean and harmonics 1..=H of the base frequency (see the module docs).
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
        let fft = RealFftPlanner::<f64>::new().plan_fft_forward(samples);
        let mut mean = [0.0; 3];
        let mut amplitudes = vec![[0.0; 3]; self.harmonics];
        for (c, s) in series.iter_mut().enumerate() {
            let mut spec = fft.make_output_vec();
            // The lengths match the plan, so the transform cannot fail.
            if fft.process(s, &mut spec).is_err() {
                return ReactionHarmonics { mean: [f64::NAN; 3], amplitudes: vec![[f64::NAN; 3]; self.harmonics] };
            }
            mean[c] = spec[0].re / samples as f64;
            for (h, a) in amplitudes.iter_mut().enumerate() {
                a[c] = 2.0 * spec[h + 1].norm() / samples as f64;
            }
        }
        ReactionHarmonics { mean, amplitudes }
    }
}

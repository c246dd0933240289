//! One periodic steady state of the harmonic balance ([`HbmSolution`]): the truncated Fourier
//! series `p_k = a_k0 + Σ_{h=1..H} a_kh cos hω₀t + b_kh sin hω₀t` of every coordinate (the spin
//! one about Ωt) with the solved mean torque T_m, and its read-outs: harmonic amplitudes,
//! accelerations `(hω₀)²·|c_h|` at an order, the synthesis of q(t) and q̇(t), the peak amplitude
//! over a period (Clenshaw's recurrence), and the top-harmonic share of the acceleration spectrum
//! that says whether H suffices (section "Harmonic count" of the balance room's docs).

use super::floquet::Stability;
use std::f64::consts::PI;

/// One periodic steady state.
#[derive(Debug, Clone, PartialEq)]
pub struct HbmSolution {
    /// Excitation order n.
    pub order: f64,
    /// Mean speed Ω, rad/s.
    pub omega: f64,
    /// Torque scale s: the oscillating excitation amplitudes are s·T_k (1: as given).
    pub torque_scale: f64,
    /// Base frequency ω₀ of the Fourier series, rad/s (nΩ for a single order).
    pub base_frequency: f64,
    /// Number of harmonics H.
    pub harmonics: usize,
    /// Index of the spin coordinate.
    pub spin: usize,
    /// Each coordinate's share of the mean rotation: `q_k(t) = rotation_k Ω t + p_k(t)`, 1 at
    /// the spin coordinate, the gear ratios at joints meshed to it, 0 elsewhere
    /// ([`crate::model::mechanism::Mechanism::rigid_rotation`]).
    pub rotation: Vec<f64>,
    /// Fourier coefficients of the periodic parts p_k, row-major per coordinate k:
    /// `[a_k0, a_k1, b_k1, …, a_kH, b_kH]` (rad), `p_k(t) = a_k0 + Σ a_kh cos hω₀t + b_kh sin hω₀t`.
    /// The spin coordinate's `a_s0` is the gauge 0.
    pub coefficients: Vec<f64>,
    /// The mean spin torque T_m that holds the mean speed at Ω, N·m.
    pub mean_torque: f64,
    /// Newton iterations used.
    pub iterations: usize,
    /// Max norm of the projected residual at the solution, N·m.
    pub residual: f64,
    /// Largest share of the top harmonic in a coordinate's acceleration spectrum.
    pub top_harmonic_ratio: f64,
    /// Largest share of a joint coupling's force in the harmonics above H (0 without
    /// couplings; section "Harmonic count" of the harmonic balance's formulation).
    pub coupling_tail: f64,
    /// True when `top_harmonic_ratio` exceeds [`HbmOptions::harmonic_tol`](crate::hbm::HbmOptions::harmonic_tol)
    /// or `coupling_tail` exceeds [`HbmOptions::coupling_tol`](crate::hbm::HbmOptions::coupling_tol): raise H.
    pub needs_more_harmonics: bool,
    /// Floquet stability, when computed.
    pub stability: Option<Stability>,
}

impl HbmSolution {
    /// Fourier coefficients per coordinate, 2H + 1.
    pub(in crate::hbm) fn nb(&self) -> usize {
        2 * self.harmonics + 1
    }

    /// Number of coordinates.
    pub fn ndof(&self) -> usize {
        self.coefficients.len() / self.nb()
    }

    /// The coefficients `(a_kh, b_kh)` of harmonic h ≥ 1 of coordinate k (rad); (a_k0, 0) for h = 0;
    /// zero above H.
    pub fn coefficient(&self, k: usize, h: usize) -> (f64, f64) {
        let c = &self.coefficients[k * self.nb()..(k + 1) * self.nb()];
        match h {
            0 => (c[0], 0.0),
            h if h <= self.harmonics => (c[2 * h - 1], c[2 * h]),
            _ => (0.0, 0.0),
        }
    }

    /// Amplitude of harmonic h (frequency hω₀) of coordinate k, rad.
    pub fn amplitude(&self, k: usize, h: usize) -> f64 {
        let (a, b) = self.coefficient(k, h);
        if h == 0 { a.abs() } else { a.hypot(b) }
    }

    /// Amplitude of the angular acceleration of coordinate k at harmonic h, rad/s².
    pub fn acceleration_amplitude(&self, k: usize, h: usize) -> f64 {
        let w = h as f64 * self.base_frequency;
        w * w * self.amplitude(k, h)
    }

    /// Harmonic index of order `multiple·n`, if it is a harmonic of ω₀.
    pub fn harmonic_of(&self, multiple: f64) -> Option<usize> {
        let h = multiple * self.order * self.omega / self.base_frequency;
        let r = h.round();
        ((h - r).abs() < 1e-9 * h.abs().max(1.0) && r >= 1.0).then_some(r as usize)
    }

    /// Amplitude of the angular acceleration of coordinate k at the order `multiple·n` (rad/s²);
    /// 0 when that order is not a harmonic of ω₀ or lies above H. For the spin coordinate this is
    /// the rotor acceleration `u̇1` of the paper's figures (multiple 1: main order, 2: second).
    pub fn order_acceleration(&self, k: usize, multiple: f64) -> f64 {
        self.harmonic_of(multiple).map_or(0.0, |h| self.acceleration_amplitude(k, h))
    }

    /// The periodic part p_k and its first two time derivatives at time t (rad, rad/s, rad/s²).
    pub fn periodic_part(&self, k: usize, t: f64) -> (f64, f64, f64) {
        let w = self.base_frequency;
        let c = &self.coefficients[k * self.nb()..(k + 1) * self.nb()];
        let (mut p, mut pd, mut pdd) = (c[0], 0.0, 0.0);
        for h in 1..=self.harmonics {
            let hw = h as f64 * w;
            let (s, co) = (hw * t).sin_cos();
            let (a, b) = (c[2 * h - 1], c[2 * h]);
            p += a * co + b * s;
            pd += hw * (b * co - a * s);
            pdd -= hw * hw * (a * co + b * s);
        }
        (p, pd, pdd)
    }

    /// Coordinates q(t) and rates q̇(t) (rad, rad/s), the spin one including Ωt.
    pub fn coordinates_at(&self, t: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.ndof();
        let (mut q, mut qd) = (vec![0.0; n], vec![0.0; n]);
        for k in 0..n {
            let (p, pd, _) = self.periodic_part(k, t);
            q[k] = p;
            qd[k] = pd;
        }
        for (k, z) in self.rotation.iter().enumerate() {
            q[k] += z * self.omega * t;
            qd[k] += z * self.omega;
        }
        (q, qd)
    }

    /// Peak amplitude `max_t |p_k(t) − a_k0|` of coordinate k over one period (rad): the true
    /// maximum of the Fourier series, not a sample of it.
    ///
    /// The series is first sampled at 16(H + 1) points by Clenshaw's recurrence; every local
    /// maximum of |p| among the samples then brackets a stationary point of p between its two
    /// neighbours (p has at most 2H of them, and the sampling is 8 times finer than the top
    /// harmonic's half-period), which Newton's method on p′(τ) = 0 (with p″) locates to rounding,
    /// kept inside the bracket. The largest refined value is the peak; sampling alone
    /// underestimates it by up to ~2 % of the top harmonic's share.
    pub fn peak_amplitude(&self, k: usize) -> f64 {
        self.series_peak(&self.coefficients[k * self.nb()..(k + 1) * self.nb()])
    }

    /// The Fourier coefficients (same layout as one coordinate's) of the torque an element of
    /// stiffness `k` (N·m/rad or N/m) and viscous damping `c` (N·m·s/rad or N·s/m) on coordinate
    /// `j` transmits, `T = k (q_j − free) + c q̇_j`, without the spring's preload `−k·free`:
    /// harmonic h is `(k a_h + c hω₀ b_h) cos + (k b_h − c hω₀ a_h) sin`, the mean `k a_0`.
    pub fn element_torque_series(&self, j: usize, k: f64, c: f64) -> Vec<f64> {
        let q = &self.coefficients[j * self.nb()..(j + 1) * self.nb()];
        let mut out = vec![k * q[0]; self.nb()];
        for h in 1..=self.harmonics {
            let w = h as f64 * self.base_frequency;
            let (a, b) = (q[2 * h - 1], q[2 * h]);
            out[2 * h - 1] = k * a + c * w * b;
            out[2 * h] = k * b - c * w * a;
        }
        out
    }

    /// The Fourier coefficients (same layout as one coordinate's, harmonics 0..=H) of a force
    /// law `f(q_j, q̇_j)` along the periodic motion of coordinate `j`: `f` sampled at 16(H + 1)
    /// points of one period and projected on the harmonics by the discrete Fourier sums. For a
    /// smooth law the sums are exact up to aliasing from harmonics above 16(H + 1) − H − 1; a
    /// kinked one (a stage spring, a stop) converges as its own Fourier series does. Used for the
    /// nonlinear couplings' torques ([`crate::model::coupling`]), which have no closed form in
    /// the coefficients.
    pub fn force_series(&self, j: usize, f: &dyn Fn(f64, f64) -> f64) -> Vec<f64> {
        let nb = self.nb();
        let ns = 16 * (self.harmonics + 1);
        let period = 2.0 * PI / self.base_frequency;
        let mut out = vec![0.0; nb];
        for i in 0..ns {
            let t = period * i as f64 / ns as f64;
            let (q, qd, _) = self.periodic_part(j, t);
            let v = f(q, qd);
            out[0] += v / ns as f64;
            for h in 1..=self.harmonics {
                let (s, c) = (h as f64 * self.base_frequency * t).sin_cos();
                out[2 * h - 1] += 2.0 * v * c / ns as f64;
                out[2 * h] += 2.0 * v * s / ns as f64;
            }
        }
        out
    }

    /// Like [`HbmSolution::element_torques`] for any torque series laid out as one
    /// coordinate's (e.g. [`HbmSolution::force_series`]): the amplitude at each order
    /// `multiples·n` and the peak of the oscillating part.
    pub fn series_torques(&self, series: &[f64], multiples: &[f64]) -> (Vec<f64>, f64) {
        let amps = multiples
            .iter()
            .map(|&m| {
                self.harmonic_of(m)
                    .filter(|&h| h <= self.harmonics)
                    .map_or(0.0, |h| series[2 * h - 1].hypot(series[2 * h]))
            })
            .collect();
        (amps, self.series_peak(series))
    }

    /// The vibratory torque of an element (see [`HbmSolution::element_torque_series`]): the
    /// amplitude at the order `multiple·n` (0 when that order is not a harmonic of ω₀) and the
    /// true peak of its oscillating part over a period, N·m (N for a slide).
    pub fn element_torque(&self, j: usize, k: f64, c: f64, multiple: f64) -> (f64, f64) {
        let (amps, peak) = self.element_torques(j, k, c, &[multiple]);
        (amps[0], peak)
    }

    /// [`HbmSolution::element_torque`] at several orders `multiples·n` from one series: the
    /// amplitude at each, and the peak once.
    pub fn element_torques(&self, j: usize, k: f64, c: f64, multiples: &[f64]) -> (Vec<f64>, f64) {
        self.series_torques(&self.element_torque_series(j, k, c), multiples)
    }

    /// `max_τ |Σ_{h≥1} c_{2h−1} cos hτ + c_{2h} sin hτ|` of a series laid out like one
    /// coordinate's coefficients (see [`HbmSolution::peak_amplitude`]).
    fn series_peak(&self, c: &[f64]) -> f64 {
        self.series_peak_at(c).0
    }

    /// The peak of [`HbmSolution::peak_amplitude`] for coordinate k and the normalised time
    /// τ = ω₀t ∈ [0, 2π) where the series reaches it (a sensitivity of the peak is the series'
    /// sensitivity at that instant, since p′ vanishes there).
    pub(in crate::hbm) fn peak_at(&self, k: usize) -> (f64, f64) {
        self.series_peak_at(&self.coefficients[k * self.nb()..(k + 1) * self.nb()])
    }

    /// [`HbmSolution::peak_at`] of a series laid out like one coordinate's coefficients.
    fn series_peak_at(&self, c: &[f64]) -> (f64, f64) {
        let ns = 16 * (self.harmonics + 1);
        let dtau = 2.0 * PI / ns as f64;
        let (ds, dc) = dtau.sin_cos();
        let (mut s1, mut c1) = (0.0f64, 1.0f64);
        let mut samples = Vec::with_capacity(ns);
        for _ in 0..ns {
            // Clenshaw's recurrence for Σ a_h cos hτ + b_h sin hτ: two multiply-adds per
            // harmonic and series, against a rotation of (cos hτ, sin hτ) per harmonic.
            let two_c = 2.0 * c1;
            let (mut ya, mut ya1, mut yb, mut yb1) = (0.0, 0.0, 0.0, 0.0);
            for h in (1..=self.harmonics).rev() {
                (ya, ya1) = (c[2 * h - 1] + two_c * ya - ya1, ya);
                (yb, yb1) = (c[2 * h] + two_c * yb - yb1, yb);
            }
            // Σ_{h≥1} a_h cos hτ = ya cos τ − ya1, Σ b_h sin hτ = yb sin τ.
            samples.push((ya * c1 - ya1 + yb * s1).abs());
            // The sample angle by rotation (one sin_cos per call instead of per sample).
            (c1, s1) = (c1 * dc - s1 * ds, s1 * dc + c1 * ds);
        }
        let mut peak = (0.0f64, 0.0f64);
        for (j, &v) in samples.iter().enumerate() {
            if v > peak.0 {
                peak = (v, j as f64 * dtau);
            }
        }
        for j in 0..ns {
            let (before, after) = (samples[(j + ns - 1) % ns], samples[(j + 1) % ns]);
            if samples[j] > 0.0 && samples[j] >= before && samples[j] >= after {
                let refined = self.refine_extremum(c, j as f64 * dtau, dtau);
                if refined.0 > peak.0 {
                    peak = refined;
                }
            }
        }
        peak
    }

    /// The signed extremes `(min, max)` of the oscillating part of coordinate k over a period,
    /// rad (m): `p_k(t) − a_k0` at its true lowest and highest points (sampled as for
    /// [`HbmSolution::peak_amplitude`] and refined by Newton's method on p′ at every local
    /// extreme of the samples). A wound-up spring's clearance is its mean `a_k0` plus these.
    pub fn oscillation_range(&self, k: usize) -> (f64, f64) {
        self.series_range(&self.coefficients[k * self.nb()..(k + 1) * self.nb()])
    }

    /// [`HbmSolution::oscillation_range`] of any series laid out like one coordinate's (an
    /// element's torque, [`HbmSolution::element_torque_series`]).
    pub fn series_range(&self, c: &[f64]) -> (f64, f64) {
        let ns = 16 * (self.harmonics + 1);
        let dtau = 2.0 * PI / ns as f64;
        let value = |tau: f64| -> f64 {
            (1..=self.harmonics)
                .map(|h| {
                    let (s, co) = (h as f64 * tau).sin_cos();
                    c[2 * h - 1] * co + c[2 * h] * s
                })
                .sum()
        };
        let samples: Vec<f64> = (0..ns).map(|j| value(j as f64 * dtau)).collect();
        let (mut lo, mut hi) =
            samples.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
        for j in 0..ns {
            let (before, after) = (samples[(j + ns - 1) % ns], samples[(j + 1) % ns]);
            let (p, top) = (samples[j], samples[j] >= before && samples[j] >= after);
            if top || (p <= before && p <= after) {
                let v = self.refine_signed(c, j as f64 * dtau, dtau, top);
                (lo, hi) = (lo.min(v), hi.max(v));
            }
        }
        (lo, hi)
    }

    /// The largest (`top`) or smallest value of the series `c` met by Newton's method on p′
    /// from τ0, each step clamped to `τ0 ± half`.
    fn refine_signed(&self, c: &[f64], tau0: f64, half: f64, top: bool) -> f64 {
        if top { self.refine_by(c, tau0, half, |p| p).0 } else { -self.refine_by(c, tau0, half, |p| -p).0 }
    }

    /// |p(τ*)| at the stationary point τ* of the series `c` within `τ0 ± half` (see
    /// [`HbmSolution::peak_amplitude`]), by Newton's method on p′ with p″, each step clamped to
    /// the bracket.
    fn refine_extremum(&self, c: &[f64], tau0: f64, half: f64) -> (f64, f64) {
        self.refine_by(c, tau0, half, f64::abs)
    }

    /// The largest `score(p)` over the points Newton's method on p′ visits from τ0 (each step
    /// clamped to `τ0 ± half`), the start included: |p| for a peak, ±p for a signed extreme;
    /// with the τ where it was met.
    fn refine_by(&self, c: &[f64], tau0: f64, half: f64, score: impl Fn(f64) -> f64) -> (f64, f64) {
        let series = |tau: f64| {
            let (mut p, mut pd, mut pdd) = (0.0, 0.0, 0.0);
            for h in 1..=self.harmonics {
                let hf = h as f64;
                let (s, co) = (hf * tau).sin_cos();
                let (a, b) = (c[2 * h - 1], c[2 * h]);
                p += a * co + b * s;
                pd += hf * (b * co - a * s);
                pdd -= hf * hf * (a * co + b * s);
            }
            (p, pd, pdd)
        };
        let (lo, hi) = (tau0 - half, tau0 + half);
        let mut tau = tau0;
        let (mut p, mut pd, mut pdd) = series(tau);
        let mut best = (score(p), tau);
        for _ in 0..20 {
            if pdd == 0.0 {
                break;
            }
            let next = (tau - pd / pdd).clamp(lo, hi);
            if (next - tau).abs() <= 4.0 * f64::EPSILON * (1.0 + tau.abs()) {
                break;
            }
            tau = next;
            (p, pd, pdd) = series(tau);
            if score(p) > best.0 {
                best = (score(p), tau);
            }
        }
        best
    }

    /// Largest peak amplitude over the coordinates other than the spin (the pendulums), rad.
    pub fn max_peak_amplitude(&self) -> f64 {
        (0..self.ndof()).filter(|&k| k != self.spin).map(|k| self.peak_amplitude(k)).fold(0.0, f64::max)
    }

    /// The share of the top harmonic (section "Harmonic count" of the balance room's docs).
    pub(in crate::hbm) fn harmonic_ratio(&self) -> f64 {
        let mut worst = 0.0f64;
        for k in 0..self.ndof() {
            let mut sum = 0.0;
            for h in 1..=self.harmonics {
                let c = (h * h) as f64 * self.amplitude(k, h);
                sum += c * c;
            }
            // A coordinate that barely moves (below 1e-9 rad/s² at the base frequency) says
            // nothing about convergence.
            if sum.sqrt() * self.base_frequency.powi(2) < 1e-9 {
                continue;
            }
            let top = (self.harmonics * self.harmonics) as f64 * self.amplitude(k, self.harmonics);
            worst = worst.max(top / sum.sqrt());
        }
        worst
    }
}

#[cfg(test)]
mod tests {
    use crate::hbm::balance::test_problem;
    use approx::{abs_diff_eq, assert_abs_diff_eq};
    use std::f64::consts::PI;

    /// The peak amplitude is the true maximum of the series: it equals a dense synthesis of the
    /// same solution at 10⁵ instants per period to 1e-9, and never lies below it. The dense
    /// synthesis can only fall short, by at most ½(π/10⁵)²·H_eff² ≈ 4.9e-10·H_eff² relative for a
    /// peak dominated by harmonic H_eff (its nearest instant is at most half a step away);
    /// measured 7e-12 to 4.9e-10 here. The former 16(H + 1)-point sample fell short by up to
    /// ~1e-4 (issue 13: 0.161824 against 0.161834).
    #[test]
    fn peak_amplitude_is_the_true_maximum() {
        for (torque, order) in [(500.0, 3.05), (40.0, 3.10), (500.0, 2.95)] {
            let mut hbm = test_problem(torque, 0, crate::model::speeds::Speeds::AbsoluteAngularVelocities);
            let sol = hbm.solve(order, None).unwrap();
            let period = 2.0 * PI / sol.base_frequency;
            for k in 0..sol.ndof() {
                let a0 = sol.coefficient(k, 0).0;
                let ns = 100_000;
                let dense = (0..ns)
                    .map(|j| (sol.periodic_part(k, period * j as f64 / ns as f64).0 - a0).abs())
                    .fold(0.0, f64::max);
                let peak = sol.peak_amplitude(k);
                let e = (peak - dense) / dense;
                println!("{torque} N·m, n = {order}, coordinate {k}: peak {peak:.12e}, peak − dense {e:.1e} relative");
                assert!(
                    dense > 0.0 && abs_diff_eq!(e, 0.0, epsilon = 1e-9),
                    "coordinate {k}: {peak} vs dense {dense} ({e:e})"
                );
                assert!(peak >= dense * (1.0 - 1e-14), "the true maximum cannot lie below a sample");
            }
        }
    }
    /// The sampled force series reproduces the closed forms it stands in for: a linear law
    /// `k q + c q̇` gives [`HbmSolution::element_torque_series`] (coefficient by coefficient, to
    /// rounding: the discrete sums of a band-limited product are exact), and Coulomb friction
    /// `T_f tanh(q̇/ε)` on a pure sine `q = A sin ω₀t` has the fundamental `4T_f/π` of a square
    /// wave, to within the smoothing's share: at ε/(Aω₀) = 1e-4 the tanh differs from sign(q̇)
    /// only over a phase width ~ε/(Aω₀), which changes the fundamental by O((ε/Aω₀)²) ≈ 1e-8, and
    /// the 16(H + 1) samples see the jump at its exact place (it falls between samples), so the
    /// sampled sums carry the square wave's own aliasing, below 1e-3 at H = 10 (checked here
    /// against 1e-3).
    #[test]
    fn force_series_matches_closed_forms() {
        let mut hbm = test_problem(500.0, 0, crate::model::speeds::Speeds::AbsoluteAngularVelocities);
        let sol = hbm.solve(3.05, None).unwrap();
        let (k, c) = (1.5e3, 0.8);
        for j in 0..sol.ndof() {
            let closed = sol.element_torque_series(j, k, c);
            let sampled = sol.force_series(j, &|q, qd| k * q + c * qd);
            let scale = closed.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            for (a, b) in closed.iter().zip(&sampled) {
                assert_abs_diff_eq!(a, b, epsilon = 1e-12 * scale);
            }
        }
        // A pure sine on coordinate 0 of an otherwise zero solution.
        let mut pure = sol.clone();
        pure.coefficients.iter_mut().for_each(|v| *v = 0.0);
        let amp = 0.02;
        pure.coefficients[2] = amp; // b_1: A sin ω₀t
        let (tf, eps) = (20.0, 1e-4 * amp * pure.base_frequency);
        let series = pure.force_series(0, &|_, qd| tf * (qd / eps).tanh());
        let fundamental = series[1].hypot(series[2]);
        let expect = 4.0 * tf / PI;
        let e = (fundamental - expect).abs() / expect;
        println!("friction fundamental {fundamental:.9} vs 4T_f/π {expect:.9}: {e:.1e}");
        assert!(e <= 1e-3, "{fundamental} vs {expect}");
    }

    /// An element's transmitted torque: its amplitude at each order equals `|k + i hω₀ c|·|q̂_h|`
    /// (the complex stiffness times the coordinate's amplitude) to rounding, and its peak equals
    /// a dense synthesis of `k (p(t) − a_0) + c ṗ(t)` from `periodic_part` to 1e-9 (the dense
    /// grid's own shortfall, as for the coordinate peak).
    #[test]
    fn element_torque_is_stiffness_and_damping_on_the_coordinate() {
        let mut hbm = test_problem(500.0, 0, crate::model::speeds::Speeds::AbsoluteAngularVelocities);
        let sol = hbm.solve(3.05, None).unwrap();
        let (k, c): (f64, f64) = (1.5e3, 0.8);
        let period = 2.0 * PI / sol.base_frequency;
        for j in 0..sol.ndof() {
            for m in [1.0, 2.0, 3.0] {
                let h = sol.harmonic_of(m).unwrap();
                let w = h as f64 * sol.base_frequency;
                let expect = k.hypot(c * w) * sol.amplitude(j, h);
                let (amp, _) = sol.element_torque(j, k, c, m);
                assert_abs_diff_eq!(amp, expect, epsilon = 1e-12 * expect.max(1e-300));
            }
            let a0 = sol.coefficient(j, 0).0;
            let ns = 100_000;
            let dense = (0..ns)
                .map(|i| {
                    let (p, pd, _) = sol.periodic_part(j, period * i as f64 / ns as f64);
                    (k * (p - a0) + c * pd).abs()
                })
                .fold(0.0, f64::max);
            let (_, peak) = sol.element_torque(j, k, c, 1.0);
            let e = (peak - dense) / dense;
            println!("coordinate {j}: torque peak {peak:.9e} N·m, peak − dense {e:.1e}");
            assert_abs_diff_eq!(e, 0.0, epsilon = 1e-9);
            assert!(peak >= dense * (1.0 - 1e-14));
        }
    }
}

//! Harmonic balance (HBM) for periodic steady states under order excitation, with pseudo-arclength
//! continuation in the excitation order, the mean speed or the torque amplitude, and Floquet
//! stability: the faster route to the steady responses that the paper obtains by long time
//! integration (sections 4 and 5; its conclusion names harmonic balance as the method to come).
//!
//! # Formulation
//!
//! A mechanism (any revolute tree) has a *spin joint* s: a root joint whose angle is cyclic (no
//! gravity, no world-frame force, no spring on it), driven by the order excitation
//! `T(t) = T_m + Σ_k T_k sin(m_k n Ω t + α_k)` at mean speed Ω. A periodic steady state is sought as
//!
//! - `q_s(t) = Ω t + p_s(t)` for the spin coordinate and `q_k(t) = p_k(t)` for every other one,
//! - each `p_k` a truncated Fourier series in the normalised time `τ = ω₀ t ∈ [0, 2π)`:
//!   `p_k = a_k0 + Σ_{h=1..H} a_kh cos hτ + b_kh sin hτ`,
//!
//! where the base frequency `ω₀ = n Ω g / d` is the greatest common divisor of the excited
//! frequencies `m_k n Ω` (the multiples m_k are rational with denominator d ≤ 12, and g is the
//! greatest common divisor of the integers `m_k d`): for a single order n, and for orders n and
//! 2n, ω₀ = nΩ.
//!
//! The constant `a_s0` of the spin angle is a gauge (the angle is cyclic, so shifting it changes
//! nothing) and is fixed at 0. Its slot is taken by the mean torque `T_m`, which is *solved*: the
//! mean speed is Ω by construction, and T_m is whatever torque sustains it. The mean of the
//! excitation given by the user is therefore not used. For the CPVA the balance of angular
//! momentum over one period gives `T_m = c_r Ω` exactly (the pendulum damper is internal), which
//! the tests check. Other applied torques of the mechanism must be constant in time (an
//! oscillating torque elsewhere is rejected), the spin joint's own torque is replaced by T.
//!
//! # Residual (alternating frequency/time)
//!
//! With speeds `u = W q̇` (W constant for both speed choices of kanedyn) Kane's equations read
//! `R(t) = M(q) W q̈ − F(q, W q̇, t) − g·T(t) = 0`, with g the generalized force of a unit torque in
//! the spin joint. `R` is evaluated by the engine at `N_t` equally spaced samples of one period
//! and projected on the Fourier basis (mean, cos hτ, sin hτ for h ≤ H): `n_dof (2H + 1)` equations
//! for as many unknowns. Both transforms are real FFTs (realfft, planned once in [`Hbm::new`],
//! buffers preallocated, no allocation per residual): the coordinates and their two derivatives
//! by 3 n_dof inverse transforms of the (derivative-weighted) half spectra, the residual by n_dof
//! forward transforms. `N_t ≥ 2H + 1` makes the projection exact for a band-limited residual; the
//! default `4(H + 1)` (44 for H = 10, an even length, 4·11: realfft halves it to a complex FFT of
//! 22) keeps the aliasing of the nonlinear terms (sin φ, u² sin φ) below the truncation error.
//! Any N_t is allowed (realfft handles odd lengths too; no power-of-two padding).
//!
//! # Jacobian
//!
//! Per sample, the derivatives `A = ∂R/∂q`, `B = ∂R/∂q̇` are formed by central differences of the
//! engine (4 n_dof − 2 evaluations; the spin angle is cyclic so its column of A is zero), and
//! `C = ∂R/∂q̈ = M W` is exact. The Fourier-domain Jacobian projects `A e + ω₀ B e' + ω₀² C e''`
//! for every basis function e (1, cos lτ, sin lτ): about 4·N_t·n_dof engine calls instead of the
//! `2·N_t·n_dof·(2H + 1)` of central differences of the whole residual (for the CPVA with
//! H = 10: 308 instead of 3696), and each difference sees one time sample only. The projections
//! are not summed over the samples: each entry A_ik(τ)·cos lτ projected on cos hτ is
//! `C_{h−l} + C_{h+l}` of the discrete Fourier coefficients of A_ik (and likewise for the other
//! products), so one forward FFT per coefficient series (3 n_dof²) and O(1) work per entry give
//! the same matrix, aliasing included, up to rounding.
//!
//! NOTE (measured on the canonical CPVA, H = 10, N_t = 44, one call on this 2-core machine):
//! a residual costs 3.7–5.3 µs with realfft against 6.8 µs with the former explicit DFT tables;
//! a Jacobian assembly (residual, 308 engine calls, projection) 33–38 µs spectrally against
//! 48 µs with per-sample tables (the tables cost N_t·(2H + 1)² multiply-adds per block, the
//! spectral form (2H + 1)² lookups plus 3 n_dof² FFTs), so the tables were not kept.
//!
//! A unit test checks the assembled Jacobian and ∂R̂/∂n against central differences of the
//! whole residual (agreement to 1e-6 of the largest entry). The derivative with respect to the
//! order n, needed by the continuation, follows exactly from the same B and C, because in
//! normalised time n enters only through `d/dt = ω₀ d/dτ`. Likewise for the mean speed
//! (`∂R/∂Ω = B (q̇_per/Ω + e_s) + 2 C q̈/Ω`: Ω also sets the mean spin rate, while the spin angle
//! Ωt = τ/(ratio·n) is cyclic) and the torque scale s (`∂R/∂s = −g T_osc(τ)`, the torque enters
//! linearly); the unit test checks all three against differences of the residual.
//!
//! # Harmonic count
//!
//! [`HbmSolution::top_harmonic_ratio`] is the share of the top harmonic in the acceleration
//! spectrum of each coordinate, `H² |c_H| / (Σ_h h⁴ |c_h|²)^½`, maximised over the coordinates;
//! when it exceeds [`HbmOptions::harmonic_tol`], more harmonics are needed
//! ([`HbmSolution::needs_more_harmonics`]).

mod aft;
mod continuation;
mod stability;

pub use continuation::{
    Bifurcation, BifurcationKind, Branch, BranchEnd, BranchPoint, ContinuationOptions, Fold, FoldKind, Parameter,
    continue_in_order,
};
pub use stability::Stability;

use crate::kane::Kane;
use crate::model::excitation::{Excitation, Harmonic};
use crate::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};
use realfft::num_complex::Complex;
use std::f64::consts::PI;

/// Failures of the harmonic balance.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum HbmError {
    /// The problem is not set up correctly (names the problem).
    #[error("harmonic balance: {0}")]
    Invalid(String),
    /// Newton's method did not converge.
    #[error(
        "harmonic balance at order {order}: Newton did not converge in {iterations} iterations (last step {step:e})"
    )]
    NoConvergence {
        /// Excitation order n.
        order: f64,
        /// Iterations done.
        iterations: usize,
        /// Size of the last Newton step (max norm of the unknowns).
        step: f64,
    },
    /// The Jacobian could not be factorised (a fold at fixed order, or a free coordinate).
    #[error(
        "harmonic balance at order {order}: singular Jacobian (at a fold, or a coordinate without restoring force?)"
    )]
    Singular {
        /// Excitation order n.
        order: f64,
    },
    /// The iteration produced a non-finite number.
    #[error("harmonic balance at order {order}: non-finite value (diverged)")]
    NonFinite {
        /// Excitation order n.
        order: f64,
    },
}

/// Numerical settings of the harmonic balance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HbmOptions {
    /// Number of harmonics H of the base frequency ω₀ kept in every coordinate.
    pub harmonics: usize,
    /// Time samples per period N_t for the residual (0: automatic, 4(H + 1)); at least 2H + 1.
    pub time_samples: usize,
    /// Newton tolerance on the step: max norm over the Fourier coefficients (rad) and the scaled
    /// mean torque `T_m / T_scale` (T_scale = max(Σ|T_k|, 1 N·m)).
    pub tol: f64,
    /// Maximum Newton iterations for a solve at fixed order.
    pub max_iter: usize,
    /// Largest acceptable share of the top harmonic (see [`HbmSolution::top_harmonic_ratio`]).
    pub harmonic_tol: f64,
    /// Central-difference step for the per-sample derivatives: rad for angles, and relative
    /// (times max(1, |q̇|)) for rates.
    pub fd_step: f64,
    /// Samples per period N_s for the Floquet monodromy (a multiple of 4, ≥ 8; 0 disables
    /// stability): RK4 with steps 2T/N_s and 4T/N_s (T = 2π/ω₀), Richardson-extrapolated, on the
    /// variational equations, whose coefficients are interpolated from the N_t samples of the
    /// harmonic balance.
    pub stability_samples: usize,
}

impl Default for HbmOptions {
    fn default() -> Self {
        Self {
            harmonics: 10,
            time_samples: 0,
            tol: 1e-10,
            max_iter: 30,
            harmonic_tol: 1e-5,
            fd_step: 1e-6,
            stability_samples: 256,
        }
    }
}

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
    /// True when `top_harmonic_ratio` exceeds [`HbmOptions::harmonic_tol`]: raise H.
    pub needs_more_harmonics: bool,
    /// Floquet stability, when computed.
    pub stability: Option<Stability>,
}

impl HbmSolution {
    fn nb(&self) -> usize {
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
        q[self.spin] += self.omega * t;
        qd[self.spin] += self.omega;
        (q, qd)
    }

    /// Peak amplitude `max_t |p_k(t) − a_k0|` of coordinate k over one period (rad), sampled at
    /// 16(H + 1) points.
    pub fn peak_amplitude(&self, k: usize) -> f64 {
        let ns = 16 * (self.harmonics + 1);
        let c = &self.coefficients[k * self.nb()..(k + 1) * self.nb()];
        let (ds, dc) = (2.0 * PI / ns as f64).sin_cos();
        let (mut s1, mut c1) = (0.0f64, 1.0f64);
        let mut peak = 0.0f64;
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
            let p = ya * c1 - ya1 + yb * s1;
            peak = peak.max(p.abs());
            // The sample angle by rotation (one sin_cos per call instead of per sample).
            (c1, s1) = (c1 * dc - s1 * ds, s1 * dc + c1 * ds);
        }
        peak
    }

    /// Largest peak amplitude over the coordinates other than the spin (the pendulums), rad.
    pub fn max_peak_amplitude(&self) -> f64 {
        (0..self.ndof()).filter(|&k| k != self.spin).map(|k| self.peak_amplitude(k)).fold(0.0, f64::max)
    }

    /// The share of the top harmonic (see the module docs).
    fn harmonic_ratio(&self) -> f64 {
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

/// Where the residual is evaluated: excitation order n, mean speed Ω (rad/s), torque scale s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct At {
    pub order: f64,
    pub omega: f64,
    pub scale: f64,
}

/// The parameter whose derivative ∂R̂/∂p the Jacobian assembly also forms.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Free {
    Order,
    Speed,
    Scale,
}

/// One excitation term in normalised time: `amplitude · sin(index·τ + phase)` (tabulated at the
/// samples in [`Hbm::new`]).
#[derive(Debug, Clone, Copy)]
struct Term {
    index: f64,
    amplitude: f64,
    phase: f64,
}

/// The engine wrapped to evaluate `R = M W q̈ − F(q, W q̇) − g T` and its per-sample derivatives.
#[derive(Debug, Clone)]
struct Evaluator {
    kane: Kane,
    n: usize,
    speeds: Speeds,
    parents: Vec<Option<usize>>,
    /// W, row-major.
    w: Vec<f64>,
    /// Generalized force (in speeds) of a unit torque in the spin joint.
    g: Vec<f64>,
    u: Vec<f64>,
    ud: Vec<f64>,
    rp: Vec<f64>,
    rm: Vec<f64>,
    /// ∂R/∂u and M (row-major) from the engine's closed-form derivatives.
    dr_du: Vec<f64>,
    mass: Vec<f64>,
}

/// Per-sample linearisation: R, and row-major `A = ∂R/∂q`, `B = ∂R/∂q̇`, `C = ∂R/∂q̈`.
#[derive(Debug, Clone)]
struct SampleLin {
    r: Vec<f64>,
    a: Vec<f64>,
    b: Vec<f64>,
    c: Vec<f64>,
}

impl SampleLin {
    fn new(n: usize) -> Self {
        Self { r: vec![0.0; n], a: vec![0.0; n * n], b: vec![0.0; n * n], c: vec![0.0; n * n] }
    }
}

impl Evaluator {
    /// R at one sample; writes `M W` into `mw` when given.
    #[allow(clippy::too_many_arguments)]
    fn residual(
        &mut self,
        t: f64,
        q: &[f64],
        qd: &[f64],
        qdd: &[f64],
        torque: f64,
        r: &mut [f64],
        mw: Option<&mut [f64]>,
    ) {
        let n = self.n;
        self.speeds.u_from_qdot(&self.parents, qd, &mut self.u);
        self.speeds.u_from_qdot(&self.parents, qdd, &mut self.ud);
        let (m, f) = self.kane.mass_matrix_and_forcing_rows(t, q, &self.u);
        for i in 0..n {
            let mut s = -f[i] - self.g[i] * torque;
            for j in 0..n {
                s += m[i * n + j] * self.ud[j];
            }
            r[i] = s;
        }
        if let Some(mw) = mw {
            for i in 0..n {
                for k in 0..n {
                    let mut s = 0.0;
                    for j in 0..n {
                        s += m[i * n + j] * self.w[j * n + k];
                    }
                    mw[i * n + k] = s;
                }
            }
        }
    }

    /// R, A, B, C at one sample by central differences (q and q̇ are restored on return). The
    /// spin angle is cyclic, so its column of A is zero and not differenced.
    #[allow(clippy::too_many_arguments)]
    fn linearize(
        &mut self,
        t: f64,
        q: &mut [f64],
        qd: &mut [f64],
        qdd: &[f64],
        torque: f64,
        spin: usize,
        h: f64,
        lin: &mut SampleLin,
    ) {
        let n = self.n;
        // Closed-form derivatives where the engine has them (absolute speeds, no gravity or
        // point forces): one evaluation instead of 1 + 2(n − 1) + 2n (measured: −20 % of the
        // instructions of a CPVA branch).
        if self.kane.has_residual_jacobian() {
            self.speeds.u_from_qdot(&self.parents, qd, &mut self.u);
            self.speeds.u_from_qdot(&self.parents, qdd, &mut self.ud);
            let (du, m) = (&mut self.dr_du, &mut self.mass);
            self.kane.residual_jacobian(t, q, &self.u, &self.ud, &mut lin.r, &mut lin.a, du, m);
            for i in 0..n {
                lin.r[i] -= self.g[i] * torque;
                lin.a[i * n + spin] = 0.0;
                for k in 0..n {
                    let (mut b, mut c) = (0.0, 0.0);
                    for j in 0..n {
                        b += du[i * n + j] * self.w[j * n + k];
                        c += m[i * n + j] * self.w[j * n + k];
                    }
                    lin.b[i * n + k] = b;
                    lin.c[i * n + k] = c;
                }
            }
            return;
        }
        let (mut rp, mut rm) = (std::mem::take(&mut self.rp), std::mem::take(&mut self.rm));
        self.residual(t, q, qd, qdd, torque, &mut lin.r, Some(&mut lin.c));
        for k in 0..n {
            if k == spin {
                for i in 0..n {
                    lin.a[i * n + k] = 0.0;
                }
                continue;
            }
            let q0 = q[k];
            q[k] = q0 + h;
            self.residual(t, q, qd, qdd, torque, &mut rp, None);
            q[k] = q0 - h;
            self.residual(t, q, qd, qdd, torque, &mut rm, None);
            q[k] = q0;
            for i in 0..n {
                lin.a[i * n + k] = (rp[i] - rm[i]) / (2.0 * h);
            }
        }
        for k in 0..n {
            let v0 = qd[k];
            let hv = h * v0.abs().max(1.0);
            qd[k] = v0 + hv;
            self.residual(t, q, qd, qdd, torque, &mut rp, None);
            qd[k] = v0 - hv;
            self.residual(t, q, qd, qdd, torque, &mut rm, None);
            qd[k] = v0;
            for i in 0..n {
                lin.b[i * n + k] = (rp[i] - rm[i]) / (2.0 * hv);
            }
        }
        self.rp = rp;
        self.rm = rm;
    }
}

/// A harmonic-balance problem: one mechanism, its spin joint, the mean speed Ω and the order
/// excitation terms; the excitation order n is the free parameter of every solve.
///
/// Build once, then [`Hbm::solve`] at fixed orders or [`continue_in_order`] along a branch.
/// `Clone` it to work on several threads.
#[derive(Debug, Clone)]
pub struct Hbm {
    ev: Evaluator,
    n: usize,
    spin: usize,
    omega: f64,
    /// Torque scale s of the fixed-parameter solves.
    scale: f64,
    /// ω₀ = ratio · n · Ω.
    ratio: f64,
    t_scale: f64,
    opts: HbmOptions,
    nb: usize,
    aft: aft::Aft,
    /// The oscillating excitation torque at the N_t samples, N·m.
    exc: Vec<f64>,
    // Work buffers: p, ṗ, p̈ per coordinate, R and ∂R/∂n per equation, each N_t samples.
    qt: Vec<f64>,
    qdt: Vec<f64>,
    qddt: Vec<f64>,
    rt: Vec<f64>,
    dpt: Vec<f64>,
    /// One coefficient series (N_t) and the half spectra of the 3n² series of `samples`.
    series: Vec<f64>,
    spectra: Vec<Complex<f64>>,
    /// `(C_m, S_m)`, m = −2H..=2H, of each of those series.
    unfolded: Vec<(f64, f64)>,
    q: Vec<f64>,
    qd: Vec<f64>,
    qdd: Vec<f64>,
    lin: SampleLin,
    /// Per-sample `[A | B | C]` (3n² each, row-major blocks) of the last Jacobian assembly, and
    /// the point (unknowns, order) it belongs to: the stability analysis reuses them.
    samples: Vec<f64>,
    samples_at: Option<(Vec<f64>, At)>,
    /// The point (unknowns, parameters) of the residual in `rhat`.
    rhat_at: Option<(Vec<f64>, At)>,
    /// Trigonometric interpolation from the N_t residual samples to the N_s stability samples.
    upsampler: aft::Upsampler,
    rhat: DVector<f64>,
    jac: DMatrix<f64>,
    /// ∂R̂/∂p of the last Jacobian assembly, for the parameter it was asked for.
    gp: DVector<f64>,
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
        let bad = |m: String| Err(HbmError::Invalid(m));
        let mech = kane.mechanism();
        let n = kane.ndof();
        if spin_joint >= n {
            return bad(format!("spin joint index {spin_joint} out of range (mechanism has {n} joints)"));
        }
        let sj = &mech.joints[spin_joint];
        if sj.parent.is_some() {
            return bad(format!("spin joint `{}` must connect a body to ground", sj.name));
        }
        if sj.spring.is_some_and(|s| s.stiffness != 0.0) {
            return bad(format!("spin joint `{}` has a spring: its angle is not cyclic", sj.name));
        }
        if mech.loads.needs_world_orientation() {
            return bad("gravity or a world-frame force makes the spin angle non-cyclic".into());
        }
        if !(omega.is_finite() && omega > 0.0) {
            return bad(format!("mean speed must be positive and finite, got {omega} rad/s"));
        }
        for jt in kane.joint_torques() {
            if jt.joint != spin_joint && jt.excitation.harmonics.iter().any(|h| h.amplitude != 0.0) {
                return bad(format!(
                    "joint `{}` carries an oscillating torque; only the spin joint may be excited",
                    mech.joints[jt.joint].name
                ));
            }
        }
        let opts = options;
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
        // Base frequency: the multiples as fractions k_i/d with a common denominator d ≤ 12.
        let mut ratio = 1.0;
        let mut terms = Vec::new();
        if !harmonics.is_empty() {
            for h in harmonics {
                if !(h.multiple.is_finite() && h.multiple > 0.0 && h.amplitude.is_finite() && h.phase.is_finite()) {
                    return bad(format!("excitation term {h:?}: multiple must be positive, all numbers finite"));
                }
            }
            let d = (1..=12u64)
                .find(|&d| {
                    harmonics.iter().all(|h| (h.multiple * d as f64 - (h.multiple * d as f64).round()).abs() < 1e-9)
                })
                .ok_or_else(|| {
                    HbmError::Invalid("excitation multiples must be rationals with denominator ≤ 12".into())
                })?;
            let ints: Vec<u64> = harmonics.iter().map(|h| (h.multiple * d as f64).round() as u64).collect();
            let g = ints.iter().fold(0, |a, &b| gcd(a, b));
            ratio = g as f64 / d as f64;
            terms = harmonics
                .iter()
                .zip(&ints)
                .map(|(h, &k)| Term { index: (k / g) as f64, amplitude: h.amplitude, phase: h.phase })
                .collect();
        }
        let t_scale = harmonics.iter().map(|h| h.amplitude.abs()).sum::<f64>().max(1.0);
        let mut kane = kane.clone();
        kane.set_joint_torque(spin_joint, Excitation::constant(0.0));
        let parents = mech.parents();
        let speeds = mech.speeds;
        let w = speeds.w_matrix(&parents);
        // g_r = ∂q̇_s/∂u_r: a spin torque τ does τ q̇_s of power.
        let mut g = vec![0.0; n];
        let (mut e, mut qd) = (vec![0.0; n], vec![0.0; n]);
        for r in 0..n {
            e.iter_mut().for_each(|x| *x = 0.0);
            e[r] = 1.0;
            speeds.qdot(&parents, &e, &mut qd);
            g[r] = qd[spin_joint];
        }
        let nb = 2 * opts.harmonics + 1;
        let ev = Evaluator {
            kane,
            n,
            speeds,
            parents,
            w: (0..n * n).map(|i| w[(i / n, i % n)]).collect(),
            g,
            u: vec![0.0; n],
            ud: vec![0.0; n],
            rp: vec![0.0; n],
            rm: vec![0.0; n],
            dr_du: vec![0.0; n * n],
            mass: vec![0.0; n * n],
        };
        let exc = (0..nt)
            .map(|j| {
                let tau = 2.0 * PI * j as f64 / nt as f64;
                terms.iter().map(|t| t.amplitude * (t.index * tau + t.phase).sin()).sum()
            })
            .collect();
        Ok(Self {
            ev,
            n,
            spin: spin_joint,
            omega,
            scale: 1.0,
            ratio,
            t_scale,
            opts,
            nb,
            aft: aft::Aft::new(nt, opts.harmonics),
            exc,
            qt: vec![0.0; n * nt],
            qdt: vec![0.0; n * nt],
            qddt: vec![0.0; n * nt],
            rt: vec![0.0; n * nt],
            dpt: vec![0.0; n * nt],
            series: vec![0.0; nt],
            spectra: vec![Complex::default(); 3 * n * n * (nt / 2 + 1)],
            unfolded: vec![(0.0, 0.0); 3 * n * n * (4 * opts.harmonics + 1)],
            q: vec![0.0; n],
            qd: vec![0.0; n],
            qdd: vec![0.0; n],
            lin: SampleLin::new(n),
            samples: vec![0.0; nt * 3 * n * n],
            samples_at: None,
            rhat_at: None,
            upsampler: aft::Upsampler::new(opts.stability_samples.max(2)),
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

    /// The options in use.
    pub fn options(&self) -> &HbmOptions {
        &self.opts
    }

    /// Time samples per period used for the residual.
    pub fn time_samples(&self) -> usize {
        self.aft.nt
    }

    /// Number of unknowns n_dof (2H + 1).
    pub fn unknowns(&self) -> usize {
        self.n * self.nb
    }

    /// Base frequency ω₀ at order n and the current mean speed, rad/s.
    pub fn base_frequency(&self, order: f64) -> f64 {
        self.ratio * order * self.omega
    }

    /// Mean speed Ω of the fixed-parameter solves, rad/s.
    pub fn omega(&self) -> f64 {
        self.omega
    }

    /// Sets the mean speed Ω (rad/s) of the fixed-parameter solves ([`Hbm::solve`]).
    pub fn set_speed(&mut self, omega: f64) -> Result<(), HbmError> {
        if !(omega.is_finite() && omega > 0.0) {
            return Err(HbmError::Invalid(format!("mean speed must be positive and finite, got {omega} rad/s")));
        }
        self.omega = omega;
        Ok(())
    }

    /// Torque scale s of the fixed-parameter solves (the excitation amplitudes are s·T_k).
    pub fn torque_scale(&self) -> f64 {
        self.scale
    }

    /// Sets the torque scale s (dimensionless, finite) of the fixed-parameter solves.
    pub fn set_torque_scale(&mut self, scale: f64) -> Result<(), HbmError> {
        if !scale.is_finite() {
            return Err(HbmError::Invalid(format!("torque scale must be finite, got {scale}")));
        }
        self.scale = scale;
        Ok(())
    }

    /// The current fixed parameters at order n.
    fn at(&self, order: f64) -> At {
        At { order, omega: self.omega, scale: self.scale }
    }

    /// Residual R̂ (and with `jacobian` = Some(p), its Jacobian and ∂R̂/∂p) at unknowns x and
    /// parameters `at`, into the work buffers.
    fn assemble(&mut self, x: &[f64], at: &At, jacobian: Option<Free>) {
        let (n, nb, nt, spin) = (self.n, self.nb, self.aft.nt, self.spin);
        let At { order, omega, scale } = *at;
        match &mut self.rhat_at {
            Some((xs, a)) => {
                xs.copy_from_slice(x);
                *a = *at;
            }
            None => self.rhat_at = Some((x.to_vec(), *at)),
        }
        let w0 = self.ratio * order * omega;
        let tm = x[spin * nb] * self.t_scale;
        self.rhat.fill(0.0);
        if jacobian.is_some() {
            self.jac.fill(0.0);
        }
        // Synthesis of p, ṗ, p̈ at every sample by inverse real FFTs.
        for k in 0..n {
            let c = &x[k * nb..(k + 1) * nb];
            let rows = k * nt..(k + 1) * nt;
            self.aft.synthesize(c, k == spin, 0, w0, &mut self.qt[rows.clone()]);
            self.aft.synthesize(c, k == spin, 1, w0, &mut self.qdt[rows.clone()]);
            self.aft.synthesize(c, k == spin, 2, w0, &mut self.qddt[rows]);
        }
        for j in 0..nt {
            let tau = 2.0 * PI * j as f64 / nt as f64;
            let t = tau / w0;
            for k in 0..n {
                self.q[k] = self.qt[k * nt + j];
                self.qd[k] = self.qdt[k * nt + j];
                self.qdd[k] = self.qddt[k * nt + j];
            }
            self.q[spin] += omega * t;
            self.qd[spin] += omega;
            let torque = tm + scale * self.exc[j];
            if jacobian.is_some() {
                self.ev.linearize(
                    t,
                    &mut self.q,
                    &mut self.qd,
                    &self.qdd,
                    torque,
                    spin,
                    self.opts.fd_step,
                    &mut self.lin,
                );
            } else {
                self.ev.residual(t, &self.q, &self.qd, &self.qdd, torque, &mut self.lin.r, None);
            }
            for i in 0..n {
                self.rt[i * nt + j] = self.lin.r[i];
            }
            let Some(free) = jacobian else { continue };
            let lin = &self.lin;
            let nn = n * n;
            let store = &mut self.samples[j * 3 * nn..(j + 1) * 3 * nn];
            store[..nn].copy_from_slice(&lin.a);
            store[nn..2 * nn].copy_from_slice(&lin.b);
            store[2 * nn..].copy_from_slice(&lin.c);
            // ∂R/∂p at fixed unknowns. In normalised time the periodic part of q̇ is ∝ ω₀ and q̈
            // ∝ ω₀², ω₀ ∝ nΩ; Ω also sets the mean spin rate; the spin angle Ωt = τ/(ratio·n) is
            // cyclic (its column of A is zero); s multiplies the oscillating torque only.
            for i in 0..n {
                let dr = match free {
                    Free::Scale => -self.ev.g[i] * self.exc[j],
                    Free::Order | Free::Speed => {
                        let mut s = 0.0;
                        for k in 0..n {
                            let qd_per = if k == spin { self.qd[k] - omega } else { self.qd[k] };
                            s += lin.b[i * n + k] * qd_per + 2.0 * lin.c[i * n + k] * self.qdd[k];
                        }
                        if free == Free::Order { s / order } else { s / omega + lin.b[i * n + spin] }
                    }
                };
                self.dpt[i * nt + j] = dr;
            }
        }
        // Projection of the residual samples by forward real FFTs.
        for i in 0..n {
            let rows = i * nt..(i + 1) * nt;
            self.aft.project(&self.rt[rows.clone()], &mut self.rhat.as_mut_slice()[i * nb..(i + 1) * nb]);
            if jacobian.is_some() {
                self.aft.project(&self.dpt[rows], &mut self.gp.as_mut_slice()[i * nb..(i + 1) * nb]);
            }
        }
        if jacobian.is_some() {
            self.spectral_jacobian(w0);
            self.samples_at = Some((x.to_vec(), *at));
            // The mean-torque unknown enters the spin torque only: mean row, −g_i T_scale.
            for i in 0..n {
                self.jac[(i * nb, spin * nb)] = -self.ev.g[i] * self.t_scale;
            }
        }
    }

    /// The Fourier-domain Jacobian from the per-sample `A, B, C` in `samples` (see the module
    /// docs): each block (i, k) projects `A_ik e + ω₀ B_ik e' + ω₀² C_ik e''` for every basis
    /// function e, which for products of a sampled coefficient with cos lτ or sin lτ reduces to
    /// sums and differences of the coefficient's discrete Fourier coefficients at h ± l. One FFT
    /// per coefficient series and O(1) work per entry; identical, up to rounding, to summing
    /// the products over the samples.
    fn spectral_jacobian(&mut self, w0: f64) {
        let (n, nb, nt, spin, hh) = (self.n, self.nb, self.aft.nt, self.spin, self.opts.harmonics);
        let (nn, half) = (n * n, self.aft.half_len());
        for sidx in 0..3 * nn {
            for j in 0..nt {
                self.series[j] = self.samples[j * 3 * nn + sidx];
            }
            self.aft.spectrum(&self.series, &mut self.spectra[sidx * half..(sidx + 1) * half]);
        }
        // (C_m, S_m) for m = −2H..=2H per series, unfolded once so that the entries below are
        // plain lookups.
        let width = 4 * hh + 1;
        for sidx in 0..3 * nn {
            let spec = &self.spectra[sidx * half..(sidx + 1) * half];
            for (u, v) in self.unfolded[sidx * width..(sidx + 1) * width].iter_mut().enumerate() {
                *v = aft::cos_sin(spec, nt, u as isize - 2 * hh as isize);
            }
        }
        let dim = n * nb;
        let w2 = w0 * w0;
        let unfolded = &self.unfolded;
        let jac = self.jac.as_mut_slice();
        let cs = |s: usize, m: isize| unfolded[s * width + (m + 2 * hh as isize) as usize];
        for i in 0..n {
            for k in 0..n {
                let (alpha, beta, gamma) = (i * n + k, nn + i * n + k, 2 * nn + i * n + k);
                // Column-major storage: the rows (i, ·) of column (k, b) start at base(b).
                let base = |b: usize| (k * nb + b) * dim + i * nb;
                if k != spin {
                    let c = base(0);
                    jac[c] = cs(alpha, 0).0;
                    for h in 1..=hh {
                        let (ch, sh) = cs(alpha, h as isize);
                        jac[c + 2 * h - 1] = 2.0 * ch;
                        jac[c + 2 * h] = 2.0 * sh;
                    }
                }
                for l in 1..=hh {
                    let lf = l as f64;
                    let (l2, lw) = (lf * lf * w2, lf * w0);
                    // cos lτ column: (α − l²ω₀²γ) cos lτ + (−lω₀β) sin lτ; sin lτ column:
                    // (α − l²ω₀²γ) sin lτ + (lω₀β) cos lτ. f1, f2: (C_m, S_m) of the two factors.
                    let f1 = |m: isize| {
                        let ((ca, sa), (cg, sg)) = (cs(alpha, m), cs(gamma, m));
                        (ca - l2 * cg, sa - l2 * sg)
                    };
                    let f2 = |m: isize| {
                        let (cb, sb) = cs(beta, m);
                        (-lw * cb, -lw * sb)
                    };
                    let (cc, sc) = (base(2 * l - 1), base(2 * l));
                    let li = l as isize;
                    let ((c1l, s1l), (c2l, s2l)) = (f1(li), f2(li));
                    jac[cc] = c1l + s2l;
                    jac[sc] = s1l - c2l;
                    for h in 1..=hh {
                        let (p, m) = (h as isize + li, h as isize - li);
                        let ((c1p, s1p), (c1m, s1m)) = (f1(p), f1(m));
                        let ((c2p, s2p), (c2m, s2m)) = (f2(p), f2(m));
                        jac[cc + 2 * h - 1] = c1m + c1p + s2p - s2m;
                        jac[cc + 2 * h] = s1p + s1m + c2m - c2p;
                        jac[sc + 2 * h - 1] = s1p - s1m - c2m - c2p;
                        jac[sc + 2 * h] = c1m - c1p - s2p - s2m;
                    }
                }
            }
        }
    }

    /// Unknowns vector from a solution (resampled to this problem's H), or zero.
    fn unknowns_from(&self, guess: Option<&HbmSolution>) -> Vec<f64> {
        let (n, nb) = (self.n, self.nb);
        let mut x = vec![0.0; n * nb];
        if let Some(g) = guess.filter(|g| g.ndof() == n) {
            for k in 0..n {
                let src = &g.coefficients[k * g.nb()..(k + 1) * g.nb()];
                let m = src.len().min(nb);
                x[k * nb..k * nb + m].copy_from_slice(&src[..m]);
            }
            x[self.spin * nb] = g.mean_torque / self.t_scale;
        }
        x
    }

    /// The solution record for unknowns x at `at` (fills the residual norm and the harmonic
    /// check; no stability).
    fn solution_from(&mut self, x: &[f64], at: &At, iterations: usize) -> HbmSolution {
        let order = at.order;
        // The residual is already in the buffer when the last assembly was at this very point
        // (as after the continuation's Jacobian at an accepted point).
        if !self.rhat_at.as_ref().is_some_and(|(xs, a)| a == at && xs.as_slice() == x) {
            self.assemble(x, at, None);
        }
        let residual = self.rhat.amax();
        let mut coefficients = x.to_vec();
        coefficients[self.spin * self.nb] = 0.0;
        let mut sol = HbmSolution {
            order,
            omega: at.omega,
            torque_scale: at.scale,
            base_frequency: self.ratio * order * at.omega,
            harmonics: self.opts.harmonics,
            spin: self.spin,
            coefficients,
            mean_torque: x[self.spin * self.nb] * self.t_scale,
            iterations,
            residual,
            top_harmonic_ratio: 0.0,
            needs_more_harmonics: false,
            stability: None,
        };
        sol.top_harmonic_ratio = sol.harmonic_ratio();
        sol.needs_more_harmonics = sol.top_harmonic_ratio > self.opts.harmonic_tol;
        sol
    }

    /// Solves for the periodic steady state at excitation order `order` by Newton's method from
    /// `guess` (a nearby solution; zero coefficients, i.e. the rigid rotation, when None: the
    /// first step is then the linear response). Stability is not computed (see
    /// [`Hbm::stability`]).
    pub fn solve(&mut self, order: f64, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        if !(order.is_finite() && order > 0.0) {
            return Err(HbmError::Invalid(format!("excitation order must be positive and finite, got {order}")));
        }
        self.solve_at(&self.at(order), guess)
    }

    /// Newton's method at fixed parameters.
    fn solve_at(&mut self, at: &At, guess: Option<&HbmSolution>) -> Result<HbmSolution, HbmError> {
        let order = at.order;
        let mut x = self.unknowns_from(guess);
        let mut step = f64::INFINITY;
        for it in 1..=self.opts.max_iter {
            self.assemble(&x, at, Some(Free::Order));
            let dx = self.jac.clone().lu().solve(&self.rhat).ok_or(HbmError::Singular { order })?;
            step = dx.amax();
            if !step.is_finite() {
                return Err(HbmError::NonFinite { order });
            }
            for (xi, d) in x.iter_mut().zip(dx.iter()) {
                *xi -= d;
            }
            if step <= self.opts.tol {
                return Ok(self.solution_from(&x, at, it));
            }
        }
        Err(HbmError::NoConvergence { order, iterations: self.opts.max_iter, step })
    }

    /// The state `x = [q; u]` of the mechanism at time t on a solution (for starting a time
    /// integration on the orbit).
    pub fn state_at(&self, sol: &HbmSolution, t: f64) -> Vec<f64> {
        let n = self.n;
        let (q, qd) = sol.coordinates_at(t);
        let mut u = vec![0.0; n];
        self.ev.speeds.u_from_qdot(&self.ev.parents, &qd, &mut u);
        let mut x = q;
        x.extend_from_slice(&u);
        x
    }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

/// One-call convenience: the periodic steady state of `kane`'s mechanism at order `order` (see
/// [`Hbm::new`] for the arguments), with its Floquet stability when
/// `options.stability_samples > 0`.
pub fn solve_periodic(
    kane: &Kane,
    spin_joint: usize,
    omega: f64,
    harmonics: &[Harmonic],
    order: f64,
    guess: Option<&HbmSolution>,
    options: HbmOptions,
) -> Result<HbmSolution, HbmError> {
    let mut hbm = Hbm::new(kane, spin_joint, omega, harmonics, options)?;
    let mut sol = hbm.solve(order, guess)?;
    if options.stability_samples > 0 {
        sol.stability = Some(hbm.stability(&sol)?);
    }
    Ok(sol)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpva::CpvaParams;
    use crate::model::excitation::rpm_to_rad_s;

    fn problem(amplitude: f64, time_samples: usize, speeds: crate::model::speeds::Speeds) -> Hbm {
        let mut mech = CpvaParams::canonical().mechanism(None).unwrap();
        mech.speeds = speeds;
        let kane = Kane::new(&mech).unwrap();
        let h = [Harmonic { multiple: 1.0, amplitude, phase: 0.0 }];
        Hbm::new(&kane, 0, rpm_to_rad_s(1000.0), &h, HbmOptions { time_samples, ..HbmOptions::default() }).unwrap()
    }

    /// The peak amplitude (Clenshaw sums at 16(H + 1) samples) equals the direct synthesis of
    /// the series at the same instants.
    #[test]
    fn peak_amplitude_equals_direct_synthesis() {
        let mut hbm = problem(500.0, 0, crate::model::speeds::Speeds::AbsoluteAngularVelocities);
        let sol = hbm.solve(3.05, None).unwrap();
        let period = 2.0 * PI / sol.base_frequency;
        for k in 0..sol.ndof() {
            let ns = 16 * (sol.harmonics + 1);
            let a0 = sol.coefficient(k, 0).0;
            let direct =
                (0..ns).map(|j| (sol.periodic_part(k, period * j as f64 / ns as f64).0 - a0).abs()).fold(0.0, f64::max);
            let e = (sol.peak_amplitude(k) - direct).abs();
            assert!(
                direct > 0.0 && e <= 1e-12 * direct,
                "coordinate {k}: {} vs {direct} ({e:e})",
                sol.peak_amplitude(k)
            );
        }
    }

    /// The assembled Jacobian and ∂R̂/∂n against central differences of the whole residual, for
    /// the default even N_t = 44 and an odd one (45) and the minimum 2H + 1 = 21, where the
    /// products' frequencies h ± l wrap around the spectrum; with absolute speeds (the engine's
    /// closed-form per-sample derivatives) and with joint rates (per-sample central differences).
    #[test]
    fn jacobian_matches_differenced_residual() {
        for speeds in
            [crate::model::speeds::Speeds::AbsoluteAngularVelocities, crate::model::speeds::Speeds::JointRates]
        {
            for nt in [0, 45, 21] {
                jacobian_check(nt, speeds);
            }
        }
    }

    fn jacobian_check(time_samples: usize, speeds: crate::model::speeds::Speeds) {
        let mut hbm = problem(40.0, time_samples, speeds);
        let sol = hbm.solve(3.05, None).unwrap();
        let mut x = hbm.unknowns_from(Some(&sol));
        // Move off the solution so that the residual is not zero.
        for (i, v) in x.iter_mut().enumerate() {
            *v += 1e-3 * ((i as f64) * 0.7).sin();
        }
        // Off the defaults (Ω = 1000 rpm, s = 1) so that every term of ∂R/∂p is exercised.
        let at = At { order: 3.05, omega: 0.9 * hbm.omega(), scale: 1.3 };
        hbm.assemble(&x, &at, Some(Free::Order));
        let jac = hbm.jac.clone();
        let m = x.len();
        let mut worst = 0.0f64;
        let scale = jac.amax();
        for c in 0..m {
            let h = 1e-6;
            let mut xp = x.clone();
            xp[c] += h;
            hbm.assemble(&xp, &at, None);
            let rp = hbm.rhat.clone();
            xp[c] -= 2.0 * h;
            hbm.assemble(&xp, &at, None);
            let col = (rp - &hbm.rhat) / (2.0 * h);
            worst = worst.max((col - jac.column(c)).amax() / scale);
        }
        assert!(worst < 1e-6, "Jacobian columns differ by {worst:e} (relative to max entry)");
        // ∂R̂/∂p for the order, the mean speed (rad/s) and the torque scale, each against a
        // central difference with a relative step of 1e-6.
        type Shift = fn(&mut At, f64);
        let cases: [(Free, Shift, f64); 3] = [
            (Free::Order, |a, d| a.order += d, at.order),
            (Free::Speed, |a, d| a.omega += d, at.omega),
            (Free::Scale, |a, d| a.scale += d, at.scale),
        ];
        for (free, shift, value) in cases {
            hbm.assemble(&x, &at, Some(free));
            let gp = hbm.gp.clone();
            let h = 1e-6 * value;
            let (mut ap, mut am) = (at, at);
            shift(&mut ap, h);
            shift(&mut am, -h);
            hbm.assemble(&x, &ap, None);
            let rp = hbm.rhat.clone();
            hbm.assemble(&x, &am, None);
            let dp = (rp - &hbm.rhat) / (2.0 * h);
            let err = (&dp - &gp).amax() / dp.amax();
            assert!(err < 1e-6, "∂R/∂p for {free:?} (N_t = {time_samples}) differs by {err:e}");
        }
    }
}

//! Alternating frequency/time by real FFTs (realfft), planned once per problem.
//!
//! Conventions (normalised time τ = 2πj/N_t, j = 0..N_t): a coordinate's Fourier coefficients
//! `[a_0, a_1, b_1, …, a_H, b_H]` stand for `a_0 + Σ a_h cos hτ + b_h sin hτ`; the projection of
//! samples r_j is `a_0 = (1/N)Σ r_j`, `a_h = (2/N)Σ r_j cos hτ_j`, `b_h = (2/N)Σ r_j sin hτ_j`
//! (exact for a residual band-limited below N_t/2, the discrete Galerkin projection otherwise).
//! The unnormalised inverse real FFT maps the half spectrum `X_0 = a_0`, `X_h = (a_h − i b_h)/2`
//! to the samples; a τ-derivative multiplies `X_h` by `ih`.

use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::sync::Arc;

/// Forward and inverse real FFTs of one length with their preallocated buffers.
#[derive(Clone)]
pub(in crate::hbm) struct Aft {
    pub nt: usize,
    harmonics: usize,
    fwd: Arc<dyn RealToComplex<f64>>,
    inv: Arc<dyn ComplexToReal<f64>>,
    spec: Vec<Complex<f64>>,
    buf: Vec<f64>,
    scratch: Vec<Complex<f64>>,
}

impl std::fmt::Debug for Aft {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Aft").field("nt", &self.nt).field("harmonics", &self.harmonics).finish()
    }
}

impl Aft {
    /// Plans for `nt` samples per period and `harmonics` < nt/2 harmonics.
    pub fn new(nt: usize, harmonics: usize) -> Self {
        let mut planner = RealFftPlanner::<f64>::new();
        let fwd = planner.plan_fft_forward(nt);
        let inv = planner.plan_fft_inverse(nt);
        let scratch = vec![Complex::default(); fwd.get_scratch_len().max(inv.get_scratch_len())];
        Self { nt, harmonics, fwd, inv, spec: vec![Complex::default(); nt / 2 + 1], buf: vec![0.0; nt], scratch }
    }

    /// Length of a half spectrum (N_t/2 + 1).
    pub fn half_len(&self) -> usize {
        self.nt / 2 + 1
    }

    /// Samples of the `deriv`-th derivative (0, 1 or 2) in time of the series with coefficients
    /// `c` at base frequency `w` (rad/s), into `out` (N_t values). With `skip_mean` the constant
    /// `c[0]` is left out (the spin coordinate's slot holds the mean torque).
    pub fn synthesize(&mut self, c: &[f64], skip_mean: bool, deriv: u32, w: f64, out: &mut [f64]) {
        self.spec.fill(Complex::default());
        if deriv == 0 && !skip_mean {
            self.spec[0] = Complex::new(c[0], 0.0);
        }
        for h in 1..=self.harmonics {
            let z = Complex::new(0.5 * c[2 * h - 1], -0.5 * c[2 * h]);
            let hw = h as f64 * w;
            self.spec[h] = match deriv {
                0 => z,
                1 => Complex::new(-z.im * hw, z.re * hw),
                _ => z * (-hw * hw),
            };
        }
        // Lengths are fixed at planning and the DC/Nyquist bins are real (H < N_t/2), so the
        // transform cannot fail.
        let r = self.inv.process_with_scratch(&mut self.spec, out, &mut self.scratch);
        debug_assert!(r.is_ok(), "inverse FFT: {r:?}");
    }

    /// Projection of the samples `series` on `[1, cos hτ, sin hτ]_{h ≤ H}` into `out` (2H + 1).
    pub fn project(&mut self, series: &[f64], out: &mut [f64]) {
        self.transform(series);
        let s = 1.0 / self.nt as f64;
        out[0] = self.spec[0].re * s;
        for h in 1..=self.harmonics {
            out[2 * h - 1] = 2.0 * s * self.spec[h].re;
            out[2 * h] = -2.0 * s * self.spec[h].im;
        }
    }

    /// The normalised half spectrum `F_m = (1/N) Σ_j r_j e^{−imτ_j}`, m = 0..=N_t/2, into `out`.
    pub fn spectrum(&mut self, series: &[f64], out: &mut [Complex<f64>]) {
        self.transform(series);
        let s = 1.0 / self.nt as f64;
        for (o, z) in out.iter_mut().zip(&self.spec) {
            *o = z * s;
        }
    }

    fn transform(&mut self, series: &[f64]) {
        self.buf.copy_from_slice(series);
        let r = self.fwd.process_with_scratch(&mut self.buf, &mut self.spec, &mut self.scratch);
        debug_assert!(r.is_ok(), "forward FFT: {r:?}");
    }
}

/// `(C_m, S_m) = ((1/N)Σ r_j cos mτ_j, (1/N)Σ r_j sin mτ_j)` for any integer m, from the
/// normalised half spectrum of `nt` real samples.
#[inline]
pub(in crate::hbm) fn cos_sin(spec: &[Complex<f64>], nt: usize, m: isize) -> (f64, f64) {
    let m = m.rem_euclid(nt as isize) as usize;
    if m <= nt / 2 {
        (spec[m].re, -spec[m].im)
    } else {
        let z = spec[nt - m];
        (z.re, z.im)
    }
}

/// Trigonometric interpolation by FFT: the band-limited periodic function through N_t samples
/// (given by their normalised half spectrum; for even N_t the Nyquist term is a pure cosine)
/// evaluated at N_s equally spaced instants by one inverse real FFT of length N_s (components
/// above N_s/2, when N_s < N_t, fold onto the bins they alias to).
#[derive(Clone)]
pub(in crate::hbm) struct Upsampler {
    ns: usize,
    inv: Arc<dyn ComplexToReal<f64>>,
    spec: Vec<Complex<f64>>,
    scratch: Vec<Complex<f64>>,
}

impl std::fmt::Debug for Upsampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Upsampler").field("ns", &self.ns).finish()
    }
}

impl Upsampler {
    /// Plans for `ns` output samples (even, ≥ 2).
    pub fn new(ns: usize) -> Self {
        let inv = RealFftPlanner::<f64>::new().plan_fft_inverse(ns);
        let scratch = vec![Complex::default(); inv.get_scratch_len()];
        Self { ns, inv, spec: vec![Complex::default(); ns / 2 + 1], scratch }
    }

    /// The number of output samples N_s.
    pub fn samples(&self) -> usize {
        self.ns
    }

    /// Values at the N_s instants of the interpolant of `nt` samples with normalised half
    /// spectrum `f` (as from [`Aft::spectrum`]), into `out`.
    pub fn run(&mut self, f: &[Complex<f64>], nt: usize, out: &mut [f64]) {
        let ns = self.ns;
        self.spec.fill(Complex::default());
        for (h, &fh) in f.iter().enumerate().take(nt / 2 + 1) {
            if h == 0 {
                self.spec[0] += fh.re;
                continue;
            }
            // The real term 2 Re(c e^{ihτ}); the Nyquist term of an even N_t is F cos(hτ).
            let c = if 2 * h == nt { fh * 0.5 } else { fh };
            let r = h % ns;
            if r == 0 {
                self.spec[0] += 2.0 * c.re;
            } else if 2 * r == ns {
                self.spec[r] += 2.0 * c.re;
            } else if 2 * r < ns {
                self.spec[r] += c;
            } else {
                self.spec[ns - r] += c.conj();
            }
        }
        let r = self.inv.process_with_scratch(&mut self.spec, out, &mut self.scratch);
        debug_assert!(r.is_ok(), "inverse FFT: {r:?}");
    }
}

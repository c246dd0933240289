//! The alternating frequency/time (AFT) assembly of the harmonic balance (sections "Residual" and
//! "Jacobian" of the room's docs): the Fourier unknowns synthesised at the N_t
//! samples by inverse real FFTs, Kane's residual and its per-sample derivatives evaluated there
//! and projected back by forward real FFTs into R̂; the Fourier-domain Jacobian ∂R̂/∂x (each
//! product of a sampled coefficient with cos lτ or sin lτ taken from the coefficient's discrete
//! Fourier coefficients at h ± l), and ∂R̂/∂p for the continued parameter.

use super::parameter::{At, Parameter};
use super::problem::Hbm;
use crate::hbm::series::cos_sin;
use std::f64::consts::PI;

impl Hbm {
    /// Residual R̂ (and with `jacobian` = Some(p), its Jacobian and ∂R̂/∂p) at unknowns x and
    /// parameters `at`, into the work buffers. Only the kind of p is read: the order a variant
    /// holds fixed is `at.order` here.
    pub(in crate::hbm) fn assemble(&mut self, x: &[f64], at: &At, jacobian: Option<Parameter>) {
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
            for (k, z) in self.rotation.iter().enumerate() {
                if *z != 0.0 {
                    self.q[k] += z * omega * t;
                    self.qd[k] += z * omega;
                }
            }
            // The mean torque acts at the spin joint (through the evaluator's g); the oscillating
            // torques at their joints are subtracted below.
            let torque = tm;
            if jacobian.is_some() {
                self.ev.linearize(
                    t,
                    &mut self.q,
                    &mut self.qd,
                    &self.qdd,
                    torque,
                    spin,
                    self.spin_column_zero,
                    self.opts.fd_step,
                    &mut self.lin,
                );
            } else {
                self.ev.residual(t, &self.q, &self.qd, &self.qdd, torque, &mut self.lin.r, None);
            }
            let w2 = omega * omega;
            for i in 0..n {
                let forcing = self.exc[i * nt + j] + self.exc2.get(i * nt + j).map_or(0.0, |e| w2 * e);
                self.rt[i * nt + j] = self.lin.r[i] - scale * forcing;
            }
            let Some(param) = jacobian else { continue };
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
                let per_w2 = self.exc2.get(i * nt + j).copied().unwrap_or(0.0);
                let dr = match param {
                    Parameter::TorqueScale { .. } => -(self.exc[i * nt + j] + w2 * per_w2),
                    Parameter::Order | Parameter::Speed { .. } => {
                        let mut s = 0.0;
                        for k in 0..n {
                            let qd_per = self.qd[k] - self.rotation[k] * omega;
                            s += lin.b[i * n + k] * qd_per + 2.0 * lin.c[i * n + k] * self.qdd[k];
                        }
                        // A speed-following forcing (an engine's inertia torque, ∝ Ω²) adds
                        // −s·2Ω·exc2 to ∂R/∂Ω.
                        if param == Parameter::Order {
                            s / order
                        } else {
                            let mean_rate: f64 = (0..n).map(|k| lin.b[i * n + k] * self.rotation[k]).sum();
                            s / omega + mean_rate - scale * 2.0 * omega * per_w2
                        }
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

    /// The Fourier-domain Jacobian from the per-sample `A, B, C` in `samples` (see the room's
    /// docs): each block (i, k) projects `A_ik e + ω₀ B_ik e' + ω₀² C_ik e''` for every basis
    /// function e, which for products of a sampled coefficient with cos lτ or sin lτ reduces to
    /// sums and differences of the coefficient's discrete Fourier coefficients at h ± l. One FFT
    /// per coefficient series and O(1) work per entry; identical, up to rounding, to summing
    /// the products over the samples.
    fn spectral_jacobian(&mut self, w0: f64) {
        let (n, nb, nt, spin, hh) = (self.n, self.nb, self.aft.nt, self.spin, self.opts.harmonics);
        let (nn, half) = (n * n, self.aft.half_len());
        let width = 4 * hh + 1;
        // A series that is zero at every sample (a pair of coordinates the tree does not couple:
        // most of them for a rotor with many absorbers) has a zero spectrum and leaves its block
        // zero: no FFT, and the block is skipped below (cleared if the last assembly wrote it).
        let mut zero = std::mem::take(&mut self.zero_series);
        // The Jacobian is not cleared as a whole (a memset of 357² entries on 16 absorbers, most
        // of them in blocks that stay zero): every block written here is written whole, and a
        // block not written now is cleared unless `zero_blocks` marks it zero already.
        let mut zero_blocks = std::mem::take(&mut self.zero_blocks);
        zero_blocks.resize(nn, false);
        zero.resize(3 * nn, false);
        for sidx in 0..3 * nn {
            let mut any = false;
            for j in 0..nt {
                let v = self.samples[j * 3 * nn + sidx];
                self.series[j] = v;
                any |= v != 0.0;
            }
            zero[sidx] = !any;
            let unfolded = &mut self.unfolded[sidx * width..(sidx + 1) * width];
            if !any {
                unfolded.fill((0.0, 0.0));
                continue;
            }
            let spec = &mut self.spectra[sidx * half..(sidx + 1) * half];
            self.aft.spectrum(&self.series, spec);
            // (C_m, S_m) for m = −2H..=2H, unfolded once so that the entries below are plain
            // lookups.
            for (u, v) in unfolded.iter_mut().enumerate() {
                *v = cos_sin(spec, nt, u as isize - 2 * hh as isize);
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
                if zero[alpha] && zero[beta] && zero[gamma] {
                    if !zero_blocks[alpha] {
                        for b in 0..nb {
                            let c = (k * nb + b) * dim + i * nb;
                            jac[c..c + nb].fill(0.0);
                        }
                    }
                    // The spin column's blocks get the mean torque's entry below.
                    zero_blocks[alpha] = k != spin;
                    continue;
                }
                zero_blocks[alpha] = false;
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
        self.zero_series = zero;
        self.zero_blocks = zero_blocks;
    }
}

#[cfg(test)]
mod tests {
    use super::super::build::test_problem;
    use super::*;
    use crate::model::excitation::Harmonic;

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

    /// The same with a forcing that follows the speed (an engine's inertia torque ∝ Ω²), whose
    /// derivative enters ∂R̂/∂Ω and ∂R̂/∂s.
    #[test]
    fn jacobian_matches_with_a_speed_following_forcing() {
        let mech = crate::cpva::CpvaParams::canonical().mechanism(None).unwrap();
        let kane = crate::kane::Kane::new(&mech).unwrap();
        let gas = [Harmonic { multiple: 1.0, amplitude: 30.0, phase: 0.3 }];
        // 40 N·m of order 2n at 1000 rpm: 40 / (104.7 rad/s)².
        let per_w2 = [Harmonic { multiple: 2.0, amplitude: 40.0 / 104.72f64.powi(2), phase: -0.5 }];
        let omega = crate::model::excitation::rpm_to_rad_s(1000.0);
        let hbm =
            Hbm::with_speed_forcing(&kane, 0, omega, &gas, &per_w2, &[(0, 1.0, 0.0)], Default::default()).unwrap();
        jacobian_check_of(hbm, 0);
    }

    fn jacobian_check(time_samples: usize, speeds: crate::model::speeds::Speeds) {
        jacobian_check_of(test_problem(40.0, time_samples, speeds), time_samples);
    }

    fn jacobian_check_of(mut hbm: Hbm, time_samples: usize) {
        let sol = hbm.solve(3.05, None).unwrap();
        let mut x = hbm.unknowns_from(Some(&sol));
        // Move off the solution so that the residual is not zero.
        for (i, v) in x.iter_mut().enumerate() {
            *v += 1e-3 * ((i as f64) * 0.7).sin();
        }
        // Off the defaults (Ω = 1000 rpm, s = 1) so that every term of ∂R/∂p is exercised.
        let at = At { order: 3.05, omega: 0.9 * hbm.omega(), scale: 1.3 };
        hbm.assemble(&x, &at, Some(Parameter::Order));
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
        let cases: [(Parameter, Shift, f64); 3] = [
            (Parameter::Order, |a, d| a.order += d, at.order),
            (Parameter::Speed { order: at.order }, |a, d| a.omega += d, at.omega),
            (Parameter::TorqueScale { order: at.order }, |a, d| a.scale += d, at.scale),
        ];
        for (param, shift, value) in cases {
            hbm.assemble(&x, &at, Some(param));
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
            assert!(err < 1e-6, "∂R/∂p for {param:?} (N_t = {time_samples}) differs by {err:e}");
        }
    }
}

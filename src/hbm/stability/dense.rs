//! The dense route's monodromy: `ż = 𝒜 z`, `𝒜 = [[0, I], [−K, −L]]` with `[K | L] = C⁻¹[A | B]`
//! at the N_s instants, by RK4 at two steps and Richardson's extrapolation, through fixed-size
//! arrays for small systems; and the row kernels the tree route shares.

/// Φ(T), row-major 2n × 2n, of `ż = 𝒜 z`, `𝒜 = [[0, I], [−K, −L]]`, by RK4 with steps
/// 2T/N_s and 4T/N_s, Richardson-extrapolated (which removes RK4's h⁴ error term); `sys` holds
/// `[K | L]` (n rows of 2n, row-major) at the N_s instants, and the stages use every (or every
/// other) instant. Small systems go through fixed-size arrays, padded with
/// decoupled states up to the next supported size: the generic slice loop spends most of its
/// time on loop and bounds overhead at 4 × 4 (instruction counts of the single-pendulum CPVA's
/// stability analysis before and after: `BENCHMARKS.md`).
pub(super) fn monodromy(sys: &[f64], n: usize, ns: usize, period: f64) -> Vec<f64> {
    let (fine, coarse) = match 2 * n {
        d if d <= 4 => monodromy_fixed::<4>(sys, n, ns, period),
        d if d <= 6 => monodromy_fixed::<6>(sys, n, ns, period),
        d if d <= 8 => monodromy_fixed::<8>(sys, n, ns, period),
        d if d <= 12 => monodromy_fixed::<12>(sys, n, ns, period),
        _ => (monodromy_slices(sys, n, ns, 1, period), monodromy_slices(sys, n, ns, 2, period)),
    };
    richardson(&fine, &coarse)
}

/// `(16 Φ_h − Φ_2h)/15`: RK4's h⁴ error term removed.
pub(super) fn richardson(fine: &[f64], coarse: &[f64]) -> Vec<f64> {
    fine.iter().zip(coarse).map(|(f, c)| (16.0 * f - c) / 15.0).collect()
}

/// [`monodromy`] with D × D arrays (D ≥ 2n, even): coordinate k < n of the system is state k,
/// its rate state D/2 + k; the other states have zero coefficients and do not couple. Returns
/// Φ for the steps 2T/N_s and 4T/N_s.
fn monodromy_fixed<const D: usize>(sys: &[f64], n: usize, ns: usize, period: f64) -> (Vec<f64>, Vec<f64>) {
    let (nh, d) = (D / 2, 2 * n);
    let map = |k: usize| if k < n { k } else { nh + k - n };
    // Padded [K | L]: nh rows of D per instant.
    let mut kl = vec![[0.0f64; D]; ns * nh];
    for j in 0..ns {
        for i in 0..n {
            for k in 0..d {
                kl[j * nh + i][map(k)] = sys[j * n * d + i * d + k];
            }
        }
    }
    let deriv = |kl: &[[f64; D]], phi: &[[f64; D]; D], out: &mut [[f64; D]; D]| fixed_deriv(kl, phi, out);
    let at = |j: usize| {
        let j = if j >= ns { j - ns } else { j };
        &kl[j * nh..(j + 1) * nh]
    };
    let rk4 = |stride: usize| {
        let mut phi = [[0.0; D]; D];
        for (i, row) in phi.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        let phi = rk4_period(phi, ns, stride, period, at, deriv);
        let mut out = vec![0.0; d * d];
        for r in 0..d {
            for c in 0..d {
                out[r * d + c] = phi[map(r)][map(c)];
            }
        }
        out
    };
    (rk4(1), rk4(2))
}

/// `out = 𝒜Φ` for [`monodromy_fixed`]: the D/2 rows of `[K | L]` in `kl`.
///
/// NOTE: a function marked to be inlined, not the closure's own body, because the compiler
/// stopped inlining that closure into the RK4 loop when the module around it grew: a call per
/// derivative on the paper's rotor, measured by callgrind (`BENCHMARKS.md`).
#[inline(always)]
fn fixed_deriv<const D: usize>(kl: &[[f64; D]], phi: &[[f64; D]; D], out: &mut [[f64; D]; D]) {
    let nh = D / 2;
    for i in 0..nh {
        out[i] = phi[nh + i];
        let mut o = [0.0; D];
        for (r, p) in kl[i].iter().zip(phi) {
            for c in 0..D {
                o[c] -= r * p[c];
            }
        }
        out[nh + i] = o;
    }
}

/// [`monodromy`] on row-major slices, any size.
fn monodromy_slices(sys: &[f64], n: usize, ns: usize, stride: usize, period: f64) -> Vec<f64> {
    let (d, m2) = (2 * n, 2 * n * n);
    let dd = d * d;
    // The top half of 𝒜Φ is Φ's bottom half, the bottom half −[K | L]Φ, accumulated row by row
    // of Φ so the inner loop runs over contiguous memory.
    let deriv = |kl: &[f64], phi: &Vec<f64>, out: &mut Vec<f64>| {
        let (top, bottom) = out.split_at_mut(n * d);
        top.copy_from_slice(&phi[n * d..]);
        for (row, o) in kl.chunks_exact(d).zip(bottom.chunks_exact_mut(d)) {
            o.fill(0.0);
            for (&r, p) in row.iter().zip(phi.chunks_exact(d)) {
                for (oc, &pc) in o.iter_mut().zip(p) {
                    *oc -= r * pc;
                }
            }
        }
    };
    let mut phi = vec![0.0; dd];
    for i in 0..d {
        phi[i * d + i] = 1.0;
    }
    let at = |j: usize| {
        let j = if j >= ns { j - ns } else { j };
        &sys[j * m2..(j + 1) * m2]
    };
    rk4_period(phi, ns, stride, period, at, deriv)
}

/// A monodromy matrix in one of the two storages: fixed-size rows or a flat row-major vector.
pub(super) trait Phi: Clone {
    /// `out = x + s y`.
    fn axpy(x: &Self, y: &Self, s: f64, out: &mut Self);
    /// `self += h/6 (k1 + 2 k2 + 2 k3 + k4)`.
    fn rk4_update(&mut self, k: [&Self; 4], h: f64);
}

impl<const D: usize> Phi for [[f64; D]; D] {
    fn axpy(x: &Self, y: &Self, s: f64, out: &mut Self) {
        for r in 0..D {
            for c in 0..D {
                out[r][c] = x[r][c] + s * y[r][c];
            }
        }
    }
    fn rk4_update(&mut self, [k1, k2, k3, k4]: [&Self; 4], h: f64) {
        for r in 0..D {
            for c in 0..D {
                self[r][c] += h / 6.0 * (k1[r][c] + 2.0 * k2[r][c] + 2.0 * k3[r][c] + k4[r][c]);
            }
        }
    }
}

impl Phi for Vec<f64> {
    #[inline(always)]
    fn axpy(x: &Self, y: &Self, s: f64, out: &mut Self) {
        axpy(x, y, s, out);
    }
    #[inline(always)]
    fn rk4_update(&mut self, [k1, k2, k3, k4]: [&Self; 4], h: f64) {
        for ((((p, &a), &b), &c), &e) in self.iter_mut().zip(k1).zip(k2).zip(k3).zip(k4) {
            *p += h / 6.0 * (a + 2.0 * b + 2.0 * c + e);
        }
    }
}

/// RK4 for `Φ' = 𝒜(t) Φ` over one period T from `phi`, with step 2T·stride/N_s: the stages of a
/// step from instant j read the coefficients `at(j)`, `at(j + stride)` (twice) and
/// `at(j + 2 stride)`; `deriv(coefficients, Φ, out)` writes 𝒜Φ. Inlined, so that it takes the
/// target features of its caller (`TreeSystem::monodromy_avx2`).
#[inline(always)]
pub(super) fn rk4_period<'a, T: Phi, C: ?Sized + 'a>(
    mut phi: T,
    ns: usize,
    stride: usize,
    period: f64,
    at: impl Fn(usize) -> &'a C,
    deriv: impl Fn(&C, &T, &mut T),
) -> T {
    let h = 2.0 * stride as f64 * period / ns as f64;
    let (mut k1, mut k2, mut k3, mut k4, mut tmp) = (phi.clone(), phi.clone(), phi.clone(), phi.clone(), phi.clone());
    for step in 0..ns / (2 * stride) {
        let j = 2 * stride * step;
        let (a0, a1, a2) = (at(j), at(j + stride), at(j + 2 * stride));
        deriv(a0, &phi, &mut k1);
        T::axpy(&phi, &k1, 0.5 * h, &mut tmp);
        deriv(a1, &tmp, &mut k2);
        T::axpy(&phi, &k2, 0.5 * h, &mut tmp);
        deriv(a1, &tmp, &mut k3);
        T::axpy(&phi, &k3, h, &mut tmp);
        deriv(a2, &tmp, &mut k4);
        phi.rk4_update([&k1, &k2, &k3, &k4], h);
    }
    phi
}

/// `x += f y`.
#[inline(always)]
pub(super) fn row(x: &mut [f64], y: &[f64], f: f64) {
    for (a, &b) in x.iter_mut().zip(y) {
        *a += f * b;
    }
}

/// `out = x + s y`.
#[inline(always)]
fn axpy(x: &[f64], y: &[f64], s: f64, out: &mut [f64]) {
    for ((o, &a), &b) in out.iter_mut().zip(x).zip(y) {
        *o = a + s * b;
    }
}

/// Solves `C X = R` in place (C n×n, R n×m, both row-major; R becomes X) by Gaussian elimination
/// with partial pivoting. False when C is singular.
pub(super) fn solve_in_place(c: &mut [f64], r: &mut [f64], n: usize, m: usize) -> bool {
    for col in 0..n {
        let piv = (col..n).max_by(|&a, &b| c[a * n + col].abs().total_cmp(&c[b * n + col].abs())).unwrap_or(col);
        if c[piv * n + col] == 0.0 || !c[piv * n + col].is_finite() {
            return false;
        }
        if piv != col {
            for k in 0..n {
                c.swap(piv * n + k, col * n + k);
            }
            for k in 0..m {
                r.swap(piv * m + k, col * m + k);
            }
        }
        let p = c[col * n + col];
        for row in col + 1..n {
            let f = c[row * n + col] / p;
            if f == 0.0 {
                continue;
            }
            for k in col..n {
                c[row * n + k] -= f * c[col * n + k];
            }
            for k in 0..m {
                r[row * m + k] -= f * r[col * m + k];
            }
        }
    }
    for col in (0..n).rev() {
        let p = c[col * n + col];
        for k in 0..m {
            let mut v = r[col * m + k];
            for j in col + 1..n {
                v -= c[col * n + j] * r[j * m + k];
            }
            r[col * m + k] = v / p;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixed-size (and padded) monodromy equals the slice version on arbitrary coefficients.
    #[test]
    fn fixed_size_monodromy_equals_the_slice_version() {
        for n in 1..=6 {
            let (ns, d) = (16, 2 * n);
            // A deterministic, non-symmetric, time-varying [K | L].
            let sys: Vec<f64> =
                (0..ns * n * d).map(|i| ((i * 7919 % 97) as f64 / 97.0 - 0.5) * (1.0 + (i % 5) as f64)).collect();
            let a = monodromy(&sys, n, ns, 0.7);
            let b = richardson(&monodromy_slices(&sys, n, ns, 1, 0.7), &monodromy_slices(&sys, n, ns, 2, 0.7));
            let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let e = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(e <= 1e-13 * scale, "n = {n}: {e:e} of {scale:e}");
        }
    }
}

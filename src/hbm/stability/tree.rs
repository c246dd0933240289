//! The tree route's monodromy (`Hbm::tree_monodromy`): the variational equations of a whole
//! large mechanism in the states (δq, δu), kept as sparse as its tree (A, B W⁻¹ and W⁻¹ by
//! their non-zeros, M through its LDLᵀ factors in a fill-free order), integrated by Butcher's
//! sixth-order method or by RK4 with Richardson's extrapolation, compiled a second time for
//! AVX2.

use super::butcher::{BUTCHER6_C, rk6_period};
use super::dense::{richardson, rk4_period, row};
use crate::hbm::balance::Hbm;
use crate::hbm::series::{Aft, Upsampler};
use nalgebra::DMatrix;

impl Hbm {
    /// Φ(T) of the whole mechanism, row-major, in the states `(δq, δu)` with `δu = W δq̇` (W is
    /// constant, so Φ is similar to the one in `(δq, δq̇)` and has the same multipliers; a
    /// Runge–Kutta method commutes with the constant change of variables), integrated by
    /// `scheme`:
    ///
    /// `δq̇ = W⁻¹ δu`, `M δu̇ = −A δq − B W⁻¹ δu`, with `M = C W⁻¹` the mass matrix.
    ///
    /// NOTE: the dense route forms `[K | L] = C⁻¹[A | B]`, which is full even on a tree (M⁻¹
    /// couples every absorber through the rotor), so each RK4 stage costs 2n²·2n. Here A, B W⁻¹
    /// and W⁻¹ keep the tree's zeros (an absorber's rows touch itself and its ancestors only) and
    /// M is applied through its LDLᵀ factors in a fill-free order (greedy minimum degree on its
    /// pattern: the leaves first, which for a tree adds no entry), so a stage costs
    /// O(nnz·2n): on 16 pendulums (n = 17) ≈ 200 row operations of length 34 per stage against
    /// 17 · 34 · 34 multiply-adds (`BENCHMARKS.md`). The interpolated series are the non-zeros
    /// of A, B W⁻¹ and M (≈ 6n instead of 2n²). None when W is singular or M has a
    /// non-positive pivot (the caller then takes the dense route).
    pub(super) fn tree_monodromy(&mut self, period: f64, scheme: TreeScheme) -> Option<Vec<f64>> {
        let (n, nt) = (self.n, self.aft.nt);
        let ns = self.tree_grid(scheme);
        let nn = n * n;
        let winv = DMatrix::from_row_slice(n, n, &self.ev.w).try_inverse()?;
        let winv_nz: Vec<(usize, usize, f64)> = (0..n)
            .flat_map(|i| (0..n).map(move |k| (i, k)))
            .filter_map(|(i, k)| {
                let v = winv[(i, k)];
                (v != 0.0).then_some((i, k, v))
            })
            .collect();
        // W⁻¹'s non-zeros row by row (in the order of `winv_nz`).
        let mut winv_rows: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
        for &(l, k, v) in &winv_nz {
            winv_rows[l].push((k, v));
        }
        // The work arrays are kept between calls (`Hbm::tree_buffers`): fresh ones of this size
        // are mapped anew by the allocator at every call, and their pages faulted in and zeroed.
        let [mut m, mut bw, mut raw, mut inst] = std::mem::take(&mut self.tree_buffers);
        let sized = |v: &mut Vec<f64>, len: usize| {
            v.clear();
            v.resize(len, 0.0);
        };
        sized(&mut m, nt * nn);
        sized(&mut bw, nt * nn);
        let (a_pat, b_pat, m_pat) = self.mass_and_damping(&winv_rows, &mut m, &mut bw);
        let sym = |i: usize, k: usize| m_pat[i * n + k] || m_pat[k * n + i];
        let (perm, pinv, below) = symbolic_ldlt(n, &sym)?;
        let l_count: usize = below.iter().map(Vec::len).sum();
        // The series to interpolate: A's and B W⁻¹'s non-zeros, and M's lower triangle (in
        // elimination positions) on the filled pattern.
        let a_nz: Vec<(usize, usize)> = (0..nn).filter(|&e| a_pat[e]).map(|e| (e / n, e % n)).collect();
        let b_nz: Vec<(usize, usize)> = (0..nn).filter(|&e| b_pat[e]).map(|e| (e / n, e % n)).collect();
        let m_nz: Vec<(usize, usize)> = (0..n)
            .flat_map(|p| std::iter::once((p, p)).chain(below[p].iter().map(move |&i| (i, p))))
            .filter(|&(i, p)| i == p || sym(perm[i], perm[p]))
            .collect();
        let (na, nbz) = (a_nz.len(), b_nz.len());
        let width = na + nbz + m_nz.len();
        let entry = |j: usize, e: usize| {
            if e < na {
                let (i, k) = a_nz[e];
                self.samples[j * 3 * nn + i * n + k]
            } else if e < na + nbz {
                let (i, k) = b_nz[e - na];
                bw[j * nn + i * n + k]
            } else {
                let (i, p) = m_nz[e - na - nbz];
                m[j * nn + perm[i] * n + perm[p]]
            }
        };
        let up = match scheme {
            TreeScheme::Butcher6 { .. } => self.tree_upsampler.as_mut()?,
            TreeScheme::Rk4Richardson => &mut self.upsampler,
        };
        interpolate(&mut self.aft, up, (width, ns), entry, &mut raw);
        let pattern = LdltPattern { n, na, nbz, l_count, m_nz: &m_nz, below: &below };
        let stride = pattern.factor_instants(scheme, &raw, width, ns, &mut inst)?;
        let system = TreeSystem { n, winv_nz, a_nz, b_nz, pinv, perm, below, na, nbz, l_count };
        let instants = Instants { values: &inst, stride, ns };
        #[cfg(target_arch = "x86_64")]
        let phi = if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the processor has AVX2 (detected just above).
            unsafe { system.monodromy_avx2(&instants, period, scheme) }
        } else {
            system.monodromy(&instants, period, scheme)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let phi = system.monodromy(&instants, period, scheme);
        self.tree_buffers = [m, bw, raw, inst];
        Some(phi)
    }

    /// The number N of instants the coefficients are interpolated to for `scheme`: Butcher's
    /// stages sit at multiples of a sixth of a step (`BUTCHER6_C`), RK4's at the N_s samples;
    /// the interpolation to Butcher's grid is planned on its first use.
    fn tree_grid(&mut self, scheme: TreeScheme) -> usize {
        match scheme {
            TreeScheme::Butcher6 { steps } => {
                if self.tree_upsampler.as_ref().is_none_or(|u| u.samples() != 6 * steps) {
                    self.tree_upsampler = Some(Upsampler::new(6 * steps));
                }
                6 * steps
            }
            TreeScheme::Rk4Richardson => self.opts.stability_samples,
        }
    }

    /// M = C W⁻¹ and B W⁻¹ at the N_t samples (row-major n × n each, into `m` and `bw`, zeroed),
    /// and the union of their and A's non-zero patterns over the samples.
    #[allow(clippy::type_complexity)]
    fn mass_and_damping(
        &self,
        winv_rows: &[Vec<(usize, f64)>],
        m: &mut [f64],
        bw: &mut [f64],
    ) -> (Vec<bool>, Vec<bool>, Vec<bool>) {
        let (n, nt) = (self.n, self.aft.nt);
        let nn = n * n;
        let (mut a_pat, mut b_pat, mut m_pat) = (vec![false; nn], vec![false; nn], vec![false; nn]);
        for j in 0..nt {
            let abc = &self.samples[j * 3 * nn..(j + 1) * 3 * nn];
            let (mj, bj) = (&mut m[j * nn..(j + 1) * nn], &mut bw[j * nn..(j + 1) * nn]);
            for i in 0..n {
                for l in 0..n {
                    let (b, c) = (abc[nn + i * n + l], abc[2 * nn + i * n + l]);
                    if b == 0.0 && c == 0.0 {
                        continue;
                    }
                    for &(k, v) in &winv_rows[l] {
                        bj[i * n + k] += b * v;
                        mj[i * n + k] += c * v;
                    }
                }
            }
            for e in 0..nn {
                a_pat[e] |= abc[e] != 0.0;
                b_pat[e] |= bj[e] != 0.0;
                m_pat[e] |= mj[e] != 0.0;
            }
        }
        (a_pat, b_pat, m_pat)
    }
}

/// Symbolic LDLᵀ of a symmetric pattern `sym` of n × n: greedy minimum degree with the fill it
/// makes, `perm[p]` the coordinate eliminated p-th, `pinv` its inverse, `below[p]` the rows (in
/// elimination positions) of L's column p.
#[allow(clippy::type_complexity)]
fn symbolic_ldlt(n: usize, sym: &dyn Fn(usize, usize) -> bool) -> Option<(Vec<usize>, Vec<usize>, Vec<Vec<usize>>)> {
    let mut adj: Vec<Vec<bool>> = (0..n).map(|i| (0..n).map(|k| i != k && sym(i, k)).collect()).collect();
    let mut alive = vec![true; n];
    let mut perm = Vec::with_capacity(n);
    for _ in 0..n {
        let k = (0..n).filter(|&b| alive[b]).min_by_key(|&b| (0..n).filter(|&o| alive[o] && adj[b][o]).count())?;
        let nbrs: Vec<usize> = (0..n).filter(|&o| alive[o] && adj[k][o]).collect();
        for &a in &nbrs {
            for &b in &nbrs {
                if a != b {
                    adj[a][b] = true;
                }
            }
        }
        alive[k] = false;
        perm.push(k);
    }
    let mut pinv = vec![0; n];
    for (p, &k) in perm.iter().enumerate() {
        pinv[k] = p;
    }
    // The filled pattern, in elimination positions: L's column p holds the neighbours
    // eliminated after p (adj holds the fill now).
    let below: Vec<Vec<usize>> = (0..n)
        .map(|p| {
            let mut rows: Vec<usize> = (0..n).filter(|&o| adj[perm[p]][o] && pinv[o] > p).map(|o| pinv[o]).collect();
            rows.sort_unstable();
            rows
        })
        .collect();
    Some((perm, pinv, below))
}

/// Each of `width` coefficient series (`entry(j, e)`: series e at sample j of the N_t) carried
/// to the N instants of `up` by trigonometric interpolation, into `raw` (instant-major, `width`
/// values per instant).
fn interpolate(
    aft: &mut Aft,
    up: &mut Upsampler,
    (width, ns): (usize, usize),
    entry: impl Fn(usize, usize) -> f64,
    raw: &mut Vec<f64>,
) {
    let nt = aft.nt;
    let mut series = vec![0.0; nt];
    let mut spec = vec![Default::default(); aft.half_len()];
    let mut values = vec![0.0; ns];
    // Every entry of `raw` is written below; `inst` only where an instant is read.
    raw.resize(ns * width, 0.0);
    for e in 0..width {
        for (j, v) in series.iter_mut().enumerate() {
            *v = entry(j, e);
        }
        aft.spectrum(&series, &mut spec);
        up.run(&spec, nt, &mut values);
        for (j, &v) in values.iter().enumerate() {
            raw[j * width + e] = v;
        }
    }
}

/// Where M's LDLᵀ factors go in an instant's values: n coordinates after `na` values of A and
/// `nbz` of B W⁻¹, L's `l_count` entries column by column as `below`, M's interpolated lower
/// triangle at `m_nz` (elimination positions).
struct LdltPattern<'a> {
    n: usize,
    na: usize,
    nbz: usize,
    l_count: usize,
    m_nz: &'a [(usize, usize)],
    below: &'a [Vec<usize>],
}

impl LdltPattern<'_> {
    /// Per instant of `raw` that `scheme` reads, `[A values | B W⁻¹ values | L | D⁻¹]` into
    /// `inst`; the stride per instant, or None where M has a non-positive pivot.
    ///
    /// D's reciprocals, because the division of a stage's rows by D was a sixth of the
    /// integration's samples (`vdivpd`), its product a few percent. Butcher's stages never read
    /// two grid instants of the six per step (`BUTCHER6_C`: 1 and 5): those are not factorised.
    fn factor_instants(
        &self,
        scheme: TreeScheme,
        raw: &[f64],
        width: usize,
        ns: usize,
        inst: &mut Vec<f64>,
    ) -> Option<usize> {
        let LdltPattern { n, na, nbz, l_count, m_nz, below } = *self;
        let nn = n * n;
        let stride = na + nbz + l_count + n;
        inst.resize(ns * stride, 0.0);
        let mut s = vec![0.0; nn];
        let read = |j: usize| match scheme {
            TreeScheme::Butcher6 { .. } => BUTCHER6_C.contains(&(j % 6)),
            TreeScheme::Rk4Richardson => true,
        };
        for j in (0..ns).filter(|&j| read(j)) {
            let r = &raw[j * width..(j + 1) * width];
            let out = &mut inst[j * stride..(j + 1) * stride];
            out[..na + nbz].copy_from_slice(&r[..na + nbz]);
            s.fill(0.0);
            for (e, &(i, p)) in m_nz.iter().enumerate() {
                s[i * n + p] = r[na + nbz + e];
            }
            let mut l = na + nbz;
            for p in 0..n {
                let d = s[p * n + p];
                if !(d > 0.0 && d.is_finite()) {
                    return None;
                }
                for (x, &i) in below[p].iter().enumerate() {
                    for &i2 in &below[p][..=x] {
                        s[i * n + i2] -= s[i * n + p] * s[i2 * n + p] / d;
                    }
                }
                for &i in &below[p] {
                    out[l] = s[i * n + p] / d;
                    l += 1;
                }
                out[na + nbz + l_count + p] = 1.0 / d;
            }
        }
        Some(stride)
    }
}

/// How the tree route integrates the period (`Hbm::tree_monodromy`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum TreeScheme {
    /// Butcher's sixth-order method in `steps` steps of T/steps.
    Butcher6 { steps: usize },
    /// RK4 at steps 2T/N_s and 4T/N_s with Richardson's extrapolation, on the N_s samples.
    Rk4Richardson,
}

/// The variational equations of the whole mechanism in the states `(δq, δu)` as the tree keeps
/// them sparse (`Hbm::tree_monodromy`): the non-zeros of W⁻¹, A and B W⁻¹, and the LDLᵀ
/// factors of M in a fill-free elimination order.
struct TreeSystem {
    n: usize,
    /// W⁻¹'s non-zeros (row, column, value).
    winv_nz: Vec<(usize, usize, f64)>,
    /// A's and B W⁻¹'s non-zero positions; their values at an instant lead the instant's slice.
    a_nz: Vec<(usize, usize)>,
    b_nz: Vec<(usize, usize)>,
    /// Elimination position of each coordinate, and the coordinate eliminated at each position.
    pinv: Vec<usize>,
    perm: Vec<usize>,
    /// Rows (elimination positions) of L's column p.
    below: Vec<Vec<usize>>,
    na: usize,
    nbz: usize,
    l_count: usize,
}

impl TreeSystem {
    /// `out = 𝒜Φ` with the instant's values `c` (`[A | B W⁻¹ | L | D]`), Φ row-major 2n × 2n;
    /// `g` is scratch of n × 2n.
    #[inline(always)]
    fn deriv(&self, c: &[f64], phi: &[f64], out: &mut [f64], g: &mut [f64]) {
        let (n, d2) = (self.n, 2 * self.n);
        let (na, nbz) = (self.na, self.nbz);
        let (top, bottom) = out.split_at_mut(n * d2);
        let (pq, pu) = phi.split_at(n * d2);
        top.fill(0.0);
        for &(i, k, v) in &self.winv_nz {
            row(&mut top[i * d2..(i + 1) * d2], &pu[k * d2..(k + 1) * d2], v);
        }
        g.fill(0.0);
        for (e, &(i, k)) in self.a_nz.iter().enumerate() {
            let p = self.pinv[i];
            row(&mut g[p * d2..(p + 1) * d2], &pq[k * d2..(k + 1) * d2], c[e]);
        }
        for (e, &(i, k)) in self.b_nz.iter().enumerate() {
            let p = self.pinv[i];
            row(&mut g[p * d2..(p + 1) * d2], &pu[k * d2..(k + 1) * d2], c[na + e]);
        }
        // M⁻¹ = L⁻ᵀ D⁻¹ L⁻¹ in elimination positions.
        let (lv, dv) = c[na + nbz..].split_at(self.l_count);
        let mut l = 0;
        for (p, rows) in self.below.iter().enumerate() {
            for &i in rows {
                let (head, tail) = g.split_at_mut(i * d2);
                row(&mut tail[..d2], &head[p * d2..(p + 1) * d2], -lv[l]);
                l += 1;
            }
        }
        for (p, &d) in dv.iter().enumerate() {
            g[p * d2..(p + 1) * d2].iter_mut().for_each(|v| *v *= d);
        }
        for (p, rows) in self.below.iter().enumerate().rev() {
            l -= rows.len();
            for (x, &i) in rows.iter().enumerate() {
                let (head, tail) = g.split_at_mut(i * d2);
                row(&mut head[p * d2..(p + 1) * d2], &tail[..d2], -lv[l + x]);
            }
        }
        for (p, &k) in self.perm.iter().enumerate() {
            for (o, &v) in bottom[k * d2..(k + 1) * d2].iter_mut().zip(&g[p * d2..(p + 1) * d2]) {
                *o = -v;
            }
        }
    }

    /// Φ(T) from the identity by `scheme` on the instants' grid.
    fn monodromy(&self, inst: &Instants, period: f64, scheme: TreeScheme) -> Vec<f64> {
        let scratch = std::cell::RefCell::new(vec![0.0; 2 * self.n * self.n]);
        self.integrate(inst, period, scheme, |c: &[f64], phi: &Vec<f64>, out: &mut Vec<f64>| {
            self.deriv(c, phi, out, &mut scratch.borrow_mut())
        })
    }

    /// [`TreeSystem::monodromy`] compiled for AVX2: the same operations element by element (no
    /// fused multiply-adds, no reordered sums), so the same results to the bit, on four doubles
    /// at a time instead of SSE2's two (the row operations have length 2n). The derivative's
    /// closure is written here, not taken from `monodromy`, because a closure takes the target
    /// features of the function it is written in.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn monodromy_avx2(&self, inst: &Instants, period: f64, scheme: TreeScheme) -> Vec<f64> {
        let scratch = std::cell::RefCell::new(vec![0.0; 2 * self.n * self.n]);
        self.integrate(inst, period, scheme, |c: &[f64], phi: &Vec<f64>, out: &mut Vec<f64>| {
            self.deriv(c, phi, out, &mut scratch.borrow_mut())
        })
    }

    /// One period from the identity with the derivative `deriv`: Butcher's method, or RK4 at
    /// steps 2T/N_s and 4T/N_s with Richardson's extrapolation.
    #[inline(always)]
    fn integrate(
        &self,
        inst: &Instants,
        period: f64,
        scheme: TreeScheme,
        deriv: impl Fn(&[f64], &Vec<f64>, &mut Vec<f64>) + Copy,
    ) -> Vec<f64> {
        let d2 = 2 * self.n;
        let at = |j: usize| inst.at(j);
        let mut phi = vec![0.0; d2 * d2];
        for i in 0..d2 {
            phi[i * d2 + i] = 1.0;
        }
        match scheme {
            TreeScheme::Butcher6 { steps } => rk6_period(phi, steps, period, at, deriv),
            TreeScheme::Rk4Richardson => {
                let fine = rk4_period(phi.clone(), inst.ns, 1, period, at, deriv);
                richardson(&fine, &rk4_period(phi, inst.ns, 2, period, at, deriv))
            }
        }
    }
}

/// The tree system's values at the N_s instants: instant j's `[A | B W⁻¹ | L | D]` is
/// `values[j·stride..(j + 1)·stride]`; instants past the period wrap around.
struct Instants<'a> {
    values: &'a [f64],
    stride: usize,
    ns: usize,
}

impl Instants<'_> {
    #[inline(always)]
    fn at(&self, j: usize) -> &[f64] {
        let j = if j >= self.ns { j - self.ns } else { j };
        &self.values[j * self.stride..(j + 1) * self.stride]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The AVX2 build of the tree monodromy gives the plain build's results to the bit (the same
    /// operations element by element), on an arrow of 4 leaves and a root with arbitrary
    /// values: the multipliers do not depend on the processor they are computed on.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_avx2_monodromy_is_the_plain_one_to_the_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let n = 5;
        let arrow: Vec<(usize, usize)> =
            (0..n).flat_map(|i| (0..n).map(move |k| (i, k))).filter(|&(i, k)| i == k || i == 4 || k == 4).collect();
        let system = TreeSystem {
            n,
            winv_nz: (0..n).map(|i| (i, i, 1.0 + 0.1 * i as f64)).chain([(1, 4, -0.3)]).collect(),
            a_nz: arrow.clone(),
            b_nz: arrow.clone(),
            pinv: (0..n).collect(),
            perm: (0..n).collect(),
            below: (0..n).map(|p| if p < 4 { vec![4] } else { Vec::new() }).collect(),
            na: arrow.len(),
            nbz: arrow.len(),
            l_count: 4,
        };
        let value = |i: usize| ((i * 7919 % 101) as f64 / 101.0 - 0.5) * 1.7;
        // Twelve instants of [A | B W⁻¹ | L | D⁻¹], D positive.
        let (ns, stride) = (12, 2 * arrow.len() + 4 + n);
        let values: Vec<f64> =
            (0..ns * stride).map(|e| if e % stride >= stride - n { 1.0 + value(e).abs() } else { value(e) }).collect();
        let inst = Instants { values: &values, stride, ns };
        // Both schemes: Butcher's in two steps, RK4 with Richardson on the twelve instants.
        for scheme in [TreeScheme::Butcher6 { steps: 2 }, TreeScheme::Rk4Richardson] {
            let plain = system.monodromy(&inst, 0.9, scheme);
            // SAFETY: the processor has AVX2 (checked above).
            let wide = unsafe { system.monodromy_avx2(&inst, 0.9, scheme) };
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&plain), bits(&wide), "{scheme:?}");
            assert!(plain.iter().any(|v| *v != 0.0 && *v != 1.0));
        }
    }
}

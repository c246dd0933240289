//! The general path `ρ² = ρ₀² − ñ²s² + x₄s⁴ + …` with the rotation law `α = α₁s + α₃s³ + …`:
//! its polar angle θ(s) from `θ' = √(1 − ρ'²)/ρ`, tabulated once per distinct path as a Chebyshev
//! series in u (`s = s_end sin u`) and evaluated by Clenshaw's recurrence (docs/design/paths.md, "The
//! general path").

use super::{MAX_COEFFICIENTS, PathPoint, PolarPoint};
use crate::model::math::{Vec2, perp};
use std::sync::{Mutex, OnceLock};

/// A general path's data and its tabulated curve: `ρ² = P(z)`, `z = s²`, with
/// `P(z) = ρ₀² − ñ²z + x₄z² + x₆z³ + …`, and `α(s) = s A(z)`, `A(z) = α₁ + α₃z + …`.
///
/// **The curve** (docs/design/paths.md, "The general path"): `θ' = √(1 − ρ'²)/ρ = √g(z)/P(z)` with
/// `g(z) = P(z) − z P'(z)²` (P' = dP/dz); the path ends at the first positive root `z_end` of g,
/// `s_end = √z_end`, where |dρ/ds| reaches 1 (a cusp; ρ reaching 0 makes g negative first). With
/// `g = (z_end − z) h(z)` and `s = s_end sin u`, `dθ/du = s_end² cos²u √h(z) / P(z)`: analytic in
/// u up to the end. That function (even in u) is expanded in Chebyshev polynomials of
/// `x = 2u/π` until its coefficients reach the rounding plateau (the last ones below 1e-14 of the
/// largest; 64 points for the paths tried), and integrated term by term;
/// θ(s) is then an odd Chebyshev series in x evaluated by Clenshaw's recurrence (one `asin` and
/// about as many multiply-adds as terms). Its error is the rounding of the sums, ≈ 1e-15 of θ.
///
/// Built with [`GeneralPath::intern`]; invalid parameters are kept (with [`GeneralPath::problem`]
/// saying which field is wrong) so that loading can report them where they are written.
#[derive(Clone, PartialEq)]
pub struct GeneralPath {
    /// Distance ρ₀ of the vertex (s = 0) from the rotor axis, m.
    pub rho0: f64,
    /// The path's order ñ (ρ² = ρ₀² − ñ²s² + …), dimensionless.
    pub n_tilde: f64,
    /// The coefficients x₄, x₆, … of s⁴, s⁶, … in ρ² (m⁻², m⁻⁴, …).
    pub x: Vec<f64>,
    /// The rotation law's coefficients α₁, α₃, … of s, s³, … (rad/m, rad/m³, …).
    pub alpha: Vec<f64>,
    /// P(z) by increasing power of z = s².
    p: Vec<f64>,
    /// h(z) = g(z)/(z_end − z) by increasing power.
    h: Vec<f64>,
    /// z_end = s_end², m².
    z_end: f64,
    /// The end of the path s_end, m (NaN for invalid parameters).
    pub(super) s_end: f64,
    /// θ(s) = Σ_j b_j T_{2j+1}(2u/π), u = asin(s/s_end).
    theta: Vec<f64>,
    /// Why the parameters are invalid: the field (below the shape) and the message.
    pub(super) problem: Option<(&'static str, String)>,
}

impl std::fmt::Debug for GeneralPath {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // The table is derived from the coefficients: printing it would only bury them.
        f.debug_struct("General")
            .field("rho0", &self.rho0)
            .field("n_tilde", &self.n_tilde)
            .field("x", &self.x)
            .field("alpha", &self.alpha)
            .finish()
    }
}

/// `Σ c_k z^k` and its first two derivatives in z.
#[inline]
fn poly3(c: &[f64], z: f64) -> (f64, f64, f64) {
    let (mut v, mut d1, mut d2) = (0.0, 0.0, 0.0);
    for &a in c.iter().rev() {
        d2 = d2 * z + 2.0 * d1;
        d1 = d1 * z + v;
        v = v * z + a;
    }
    (v, d1, d2)
}

/// `d/dz Σ c_k z^k`.
#[inline]
fn poly_d(c: &[f64], z: f64) -> f64 {
    c.iter().enumerate().skip(1).rev().fold(0.0, |v, (k, &a)| v * z + k as f64 * a)
}

/// `Σ c_k z^k`.
#[inline]
fn poly(c: &[f64], z: f64) -> f64 {
    c.iter().rev().fold(0.0, |v, &a| v * z + a)
}

/// The tables of every general path built so far, shared by equal paths (see
/// [`GeneralPath::intern`]).
static INTERNED: OnceLock<Mutex<Vec<&'static GeneralPath>>> = OnceLock::new();

impl GeneralPath {
    /// The tabulated path of these coefficients: built the first time, then shared.
    ///
    /// NOTE: the table is leaked on purpose: [`PathShape`](super::PathShape) (and so the `Copy` joint kind) holds a
    /// `&'static` to it. Equal coefficients share one table, so the memory kept is one table
    /// (a few hundred bytes) per distinct path a process loads.
    pub fn intern(rho0: f64, n_tilde: f64, x: &[f64], alpha: &[f64]) -> &'static GeneralPath {
        let same = |g: &GeneralPath| {
            let bits =
                |a: &[f64], b: &[f64]| a.len() == b.len() && a.iter().zip(b).all(|(p, q)| p.to_bits() == q.to_bits());
            g.rho0.to_bits() == rho0.to_bits()
                && g.n_tilde.to_bits() == n_tilde.to_bits()
                && bits(&g.x, x)
                && bits(&g.alpha, alpha)
        };
        let mut tables = INTERNED.get_or_init(|| Mutex::new(Vec::new())).lock().unwrap_or_else(|e| e.into_inner());
        if let Some(g) = tables.iter().find(|g| same(g)) {
            return g;
        }
        let g: &'static GeneralPath = Box::leak(Box::new(GeneralPath::build(rho0, n_tilde, x, alpha)));
        tables.push(g);
        g
    }

    /// Why the parameters are invalid, if they are: the field below the shape (`rho0`,
    /// `n_tilde`, `x`, `alpha`) and what is wrong.
    pub fn problem(&self) -> Option<&(&'static str, String)> {
        self.problem.as_ref()
    }

    /// The end of the path s_end (m): where |dρ/ds| reaches 1.
    pub fn end(&self) -> f64 {
        self.s_end
    }

    /// Number of terms of the θ table.
    pub fn table_terms(&self) -> usize {
        self.theta.len()
    }

    fn build(rho0: f64, n_tilde: f64, x: &[f64], alpha: &[f64]) -> GeneralPath {
        let mut out = GeneralPath {
            rho0,
            n_tilde,
            x: x.to_vec(),
            alpha: alpha.to_vec(),
            p: Vec::new(),
            h: Vec::new(),
            z_end: f64::NAN,
            s_end: f64::NAN,
            theta: Vec::new(),
            problem: None,
        };
        if let Err(p) = out.tabulate() {
            out.problem = Some(p);
            out.s_end = f64::NAN;
        }
        out
    }

    fn tabulate(&mut self) -> Result<(), (&'static str, String)> {
        let (rho0, n_tilde) = (self.rho0, self.n_tilde);
        use crate::model::ranges::{PATH_LENGTH_M, PATH_ORDER, show, within};
        if !within(rho0, &PATH_LENGTH_M) {
            return Err((
                "rho0",
                format!("the vertex radius ρ₀ (m) must lie in {}, got {rho0:e}", show(&PATH_LENGTH_M)),
            ));
        }
        if !within(n_tilde, &PATH_ORDER) {
            return Err(("n_tilde", format!("the path order ñ must lie in {}, got {n_tilde:e}", show(&PATH_ORDER))));
        }
        for (field, list, what) in [("x", &self.x, "x₄, x₆, …"), ("alpha", &self.alpha, "α₁, α₃, …")] {
            if list.len() > MAX_COEFFICIENTS {
                return Err((field, format!("at most {MAX_COEFFICIENTS} coefficients ({what}), got {}", list.len())));
            }
            if let Some(k) = list.iter().position(|v| !v.is_finite()) {
                return Err((field, format!("coefficient {k} ({what}) must be finite, got {}", list[k])));
            }
        }
        let mut p = vec![rho0 * rho0, -n_tilde * n_tilde];
        p.extend_from_slice(&self.x);
        while p.len() > 2 && p.last() == Some(&0.0) {
            p.pop();
        }
        // g = P − z P'²: every coefficient by convolution.
        let dp: Vec<f64> = (1..p.len()).map(|k| k as f64 * p[k]).collect();
        let mut g = p.clone();
        g.resize(p.len().max(2 * dp.len()), 0.0);
        for (i, a) in dp.iter().enumerate() {
            for (j, b) in dp.iter().enumerate() {
                g[i + j + 1] -= a * b;
            }
        }
        let z_end = first_positive_root(&g, rho0 * rho0 / (n_tilde * n_tilde * (1.0 + n_tilde * n_tilde)))
            .ok_or(("x", "the path's end (where |dρ/ds| reaches 1) could not be found".to_string()))?;
        // h = g / (z_end − z): the quotient of synthetic division, sign turned (g(z_end) = 0).
        let mut h = vec![0.0; g.len() - 1];
        let mut carry = 0.0;
        for k in (1..g.len()).rev() {
            carry = carry * z_end + g[k];
            h[k - 1] = -carry;
        }
        self.p = p;
        self.h = h;
        self.z_end = z_end;
        self.s_end = z_end.sqrt();
        self.theta = self.theta_series()?;
        Ok(())
    }

    /// dθ/du at u (see the type's doc).
    fn dtheta_du(&self, u: f64) -> f64 {
        let (su, cu) = u.sin_cos();
        let z = self.z_end * su * su;
        self.z_end * cu * cu * poly(&self.h, z).max(0.0).sqrt() / poly(&self.p, z)
    }

    /// The odd Chebyshev coefficients of θ in x = 2u/π (see the type's doc).
    fn theta_series(&self) -> Result<Vec<f64>, (&'static str, String)> {
        let half_pi = std::f64::consts::FRAC_PI_2;
        let mut n = 32;
        loop {
            // f(x) = dθ/du at the Chebyshev points of the first kind; c_k by the discrete cosine sum.
            let nodes: Vec<f64> = (0..n).map(|i| (std::f64::consts::PI * (i as f64 + 0.5) / n as f64).cos()).collect();
            let f: Vec<f64> = nodes.iter().map(|&x| self.dtheta_du(half_pi * x)).collect();
            if f.iter().any(|v| !v.is_finite()) {
                return Err(("x", "the path's angle is not finite inside its travel (ρ² reaches 0?)".to_string()));
            }
            let c: Vec<f64> = (0..n)
                .map(|k| {
                    // The angle πk(2i+1)/(2n) reduced modulo 2π in integers, so that it is exact.
                    let sum: f64 = (0..n)
                        .map(|i| {
                            let m = (k * (2 * i + 1)) % (4 * n);
                            f[i] * (std::f64::consts::PI * m as f64 / (2 * n) as f64).cos()
                        })
                        .sum();
                    sum * if k == 0 { 1.0 } else { 2.0 } / n as f64
                })
                .collect();
            // Converged when the last even coefficients (the odd ones are zero: f is even) have
            // reached the rounding plateau of the sums (a few 1e-16 of the largest).
            let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let tail = c[n - 8..].iter().step_by(2).fold(0.0f64, |m, v| m.max(v.abs()));
            if tail <= 1e-14 * scale {
                // ∫ Σ c_k T_k dx = Σ C_k T_k with C_k = (c_{k−1} − c_{k+1}) / (2k), c₀ counted twice
                // in C₁ (here c₀ holds the mean); the odd C_k only (f is even), times π/2 for du.
                let at = |k: usize| if k < n { c[k] } else { 0.0 };
                let mut b: Vec<f64> = (0..n / 2)
                    .map(|j| {
                        let k = 2 * j + 1;
                        let lower = if k == 1 { 2.0 * c[0] } else { at(k - 1) };
                        half_pi * (lower - at(k + 1)) / (2.0 * k as f64)
                    })
                    .collect();
                let big = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
                while b.len() > 1 && b.last().is_some_and(|v| v.abs() < 1e-18 * big) {
                    b.pop();
                }
                return Ok(b);
            }
            if n >= 1024 {
                return Err((
                    "x",
                    "the path's angle could not be tabulated to 1e-13 (the path turns too sharply near its end)"
                        .to_string(),
                ));
            }
            n *= 2;
        }
    }

    /// θ at arc length s, |s| < s_end.
    #[inline]
    fn theta_at(&self, s: f64) -> f64 {
        let x = (s / self.s_end).asin() * std::f64::consts::FRAC_2_PI;
        // Clenshaw for Σ b_j T_{2j+1}(x): T_{k+2} = 2T₂ T_k − T_{k−2}, T_{−1} = T₁.
        let a = 2.0 * (2.0 * x * x - 1.0);
        let (mut b1, mut b2) = (0.0, 0.0);
        for &c in self.theta[1..].iter().rev() {
            (b1, b2) = (c + a * b1 - b2, b1);
        }
        // Σ = b₀ T₁ + b1 T₃ − b2 T₁ with T₃ = x (a − 1).
        x * (self.theta[0] + b1 * (a - 1.0) - b2)
    }

    /// The rotation law α(s), α'(s), α''(s).
    #[inline]
    pub(super) fn rotation(&self, s: f64) -> (f64, f64, f64) {
        if self.alpha.is_empty() {
            return (0.0, 0.0, 0.0);
        }
        // α = s A(z): α' = A + 2z A', α'' = 2s (3A' + 2z A'').
        let z = s * s;
        let (a, da, dda) = poly3(&self.alpha, z);
        (s * a, a + 2.0 * z * da, 2.0 * s * (3.0 * da + 2.0 * z * dda))
    }

    /// The path at arc length s (NaN beyond its end or for invalid parameters).
    pub(super) fn at(&self, s: f64) -> PathPoint {
        let on_path = s.abs() < self.s_end;
        if !on_path {
            return PathPoint::nan();
        }
        let z = s * s;
        let (pz, dpz, ddpz) = poly3(&self.p, z);
        let rho = pz.sqrt();
        // ρ' = s P'/ρ; ρ'' = (P' + 2z P'' − ρ'²)/ρ; w = ρθ' = √(1 − ρ'²) = √((z_end − z) h / P).
        let d_rho = s * dpz / rho;
        let dd_rho = (dpz + 2.0 * z * ddpz - d_rho * d_rho) / rho;
        let w = ((self.z_end - z) * poly(&self.h, z) / pz).sqrt();
        let dw = -d_rho * dd_rho / w;
        let (st, ct) = self.theta_at(s).sin_cos();
        let e_rho = Vec2::new(ct, st);
        let e_theta = perp(e_rho);
        let (alpha, dalpha, ddalpha) = self.rotation(s);
        PathPoint {
            position: rho * e_rho,
            tangent: d_rho * e_rho + w * e_theta,
            curvature: (dd_rho - w * w / rho) * e_rho + (d_rho * w / rho + dw) * e_theta,
            alpha,
            dalpha,
            ddalpha,
        }
    }

    /// The rotation-invariant quantities at s ([`PolarPoint`]; NaN beyond the end): no θ table.
    #[inline]
    pub(super) fn polar(&self, s: f64) -> PolarPoint {
        let on_path = s.abs() < self.s_end;
        if !on_path {
            return PolarPoint::nan();
        }
        // ρ² = P(z), ρρ' = s P'(z), ρw = √g with g = (z_end − z) h(z) = P − zP'², and
        // d√g/ds = s g'(z)/√g with g' = (z_end − z) h' − h.
        let z = s * s;
        let (pz, dpz) = (poly(&self.p, z), poly_d(&self.p, z));
        let (hz, dhz, _) = poly3(&self.h, z);
        let gap = self.z_end - z;
        let root = (gap * hz).sqrt();
        let (_, dalpha, ddalpha) = self.rotation(s);
        PolarPoint {
            rho_sq: pz,
            r_dot_t: s * dpz,
            r_cross_t: root,
            r_cross_k: s * (gap * dhz - hz) / root,
            dalpha,
            ddalpha,
        }
    }

    /// The Taylor coefficients of ρ² (by powers of s², from s⁰) and of α (by odd powers).
    pub fn coefficients(&self) -> (&[f64], &[f64]) {
        (&self.p, &self.alpha)
    }
}

/// The first positive root of the polynomial `g` (by increasing power; g(0) > 0, leading
/// coefficient negative), found by a scan on a grid scaled by `hint` (a typical root) and
/// bisection to the last bit.
fn first_positive_root(g: &[f64], hint: f64) -> Option<f64> {
    if g[0].is_nan() || g[0] <= 0.0 || !hint.is_finite() || hint <= 0.0 {
        return None;
    }
    // Cauchy's bound on the roots' size: the scan's far end.
    let lead = *g.iter().rev().find(|v| **v != 0.0)?;
    let bound = 1.0 + g.iter().map(|v| (v / lead).abs()).fold(0.0, f64::max);
    // Steps of hint/256 up to 4·hint, then growing by 1 % up to the bound: fine near the
    // epicycloid's end (the usual place) and never more than a few thousand evaluations.
    let mut z = 0.0;
    let (mut lo, mut hi) = loop {
        let step = if z < 4.0 * hint { hint / 256.0 } else { 0.01 * z };
        let next = (z + step).min(bound);
        if poly(g, next) <= 0.0 {
            break (z, next);
        }
        if next >= bound {
            return None;
        }
        z = next;
    };
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if poly(g, mid) > 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // The last point where g is still positive: s_end is then on the path's side.
    Some(lo)
}

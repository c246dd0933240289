//! Absorber paths: the curves a path joint's child frame origin follows in its parent's frame,
//! parameterised by arc length, with the child body's rotation law (docs/design.md, "The path
//! joint").
//!
//! A path is described in polar form about a centre c (the rotor axis): the squared distance
//! `ρ²(s)` from c as a function of the arc length s, its polar angle `θ(s)` fixed by
//! `|dr/ds| = 1`, i.e. `θ' = √(1 − ρ'²) / ρ`, and the body's rotation relative to the parent
//! `α(s)`. Every kind here has that angle in closed form, so no quadrature is needed:
//!
//! - `Circle` and `Bifilar`: a circle of radius L whose centre sits at R from c (the pivot of a
//!   compound pendulum); `ρ² = R² + L² + 2RL cos(s/L)`. The compound pendulum turns with its arm,
//!   `α = s/L` (the revolute CPVA after the change of coordinate s = Lφ); the bifilar absorber
//!   translates, `α = 0`.
//! - `Epicycloid`: `ρ² = ρ₀² − ñ²s²`, the tautochronic path (its small-amplitude order is ñ at
//!   every amplitude for a point mass or a translating body), ending in a cusp at
//!   `s_max = ρ₀ / (ñ √(1 + ñ²))`; `α = α₁ s` (α₁ = 0 by default: a translating body).
//!
//! - `General`: `ρ² = ρ₀² − ñ²s² + x₄s⁴ + x₆s⁶ + …` with `α = α₁s + α₃s³ + …`; its angle has no
//!   closed form, so it is tabulated once per distinct path ([`GeneralPath`]): a Chebyshev series
//!   of θ in the variable u of `s = s_end sin u`, which takes the square-root end of the path
//!   into an analytic function (accuracy ≈ 1e-15 relative, checked against the epicycloid's
//!   closed form in `tests/path_general.rs`).
//!
//! The vertex (s = 0) lies on the +x axis of the path's own frame; the joint turns that frame by
//! its mounting angle.

use crate::model::math::{Vec2, perp};
use serde::{Deserialize, Serialize};
use std::sync::{Mutex, OnceLock};

/// The shape of an absorber path and the rotation law of the body on it. All lengths in m.
///
/// In RON: `Circle(radius: 0.17, length: 0.0152)`, `Bifilar(radius: 0.17, length: 0.0152)`,
/// `Epicycloid(rho0: 0.185, n_tilde: 3.11)` (optionally `alpha1: …`, rad/m),
/// `General(rho0: 0.185, n_tilde: 3.11, x: [x₄, x₆, …], alpha: [α₁, α₃, …])`.
///
/// The type stays `Copy` (see [`crate::model::joint::JointKind`]): a general path is a
/// reference to its tabulated curve, built once per distinct path and kept for the process's
/// life ([`GeneralPath::intern`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(from = "ShapeSpec", into = "ShapeSpec")]
pub enum PathShape {
    /// Circle of radius `length` (L) about a pivot at `radius` (R) from the centre; the body turns
    /// with its arm, α = s/L: the compound pendulum of the paper (eq. 15: n_t² = R L m / J_B with
    /// J_B = I + m L²).
    Circle {
        /// Pivot radius R (distance of the circle's centre from the rotor axis), m, > 0.
        radius: f64,
        /// Radius L of the circle the centre of mass follows, m, > 0.
        length: f64,
    },
    /// The same circle traversed without rotation (a parallel bifilar absorber), α = 0; its
    /// linear order is √(R/L) whatever the body's inertia.
    Bifilar {
        /// Distance R of the circle's centre from the rotor axis, m, > 0.
        radius: f64,
        /// Radius L of the circle (the effective bifilar length), m, > 0.
        length: f64,
    },
    /// The epicycloid `ρ² = ρ₀² − ñ² s²` (tautochronic for a translating body), with the rotation
    /// law α = α₁ s.
    Epicycloid {
        /// Distance of the vertex (s = 0) from the rotor axis, m, > 0.
        rho0: f64,
        /// The path's order ñ (dimensionless, > 0): the linear tuning order of a point mass.
        n_tilde: f64,
        /// Rotation of the body per unit arc length, rad/m (default 0: the body translates).
        alpha1: f64,
    },
    /// The polynomial path `ρ² = ρ₀² − ñ²s² + x₄s⁴ + x₆s⁶ + …` with the rotation law
    /// `α = α₁s + α₃s³ + …`, its curve tabulated once ([`GeneralPath`]).
    General(&'static GeneralPath),
}

/// The most coefficients `x` (x₄, x₆, …) or `alpha` (α₁, α₃, …) a general path may have: ρ² up
/// to s¹⁸ and α up to s¹⁵ (a designer's path uses two or three).
pub const MAX_COEFFICIENTS: usize = 8;

/// A path shape as written in RON (the form [`PathShape`] reads and writes).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "PathShape")]
enum ShapeSpec {
    Circle {
        radius: f64,
        length: f64,
    },
    Bifilar {
        radius: f64,
        length: f64,
    },
    Epicycloid {
        rho0: f64,
        n_tilde: f64,
        #[serde(default)]
        alpha1: f64,
    },
    General {
        rho0: f64,
        n_tilde: f64,
        #[serde(default)]
        x: Vec<f64>,
        #[serde(default)]
        alpha: Vec<f64>,
    },
}

impl From<ShapeSpec> for PathShape {
    fn from(spec: ShapeSpec) -> PathShape {
        match spec {
            ShapeSpec::Circle { radius, length } => PathShape::Circle { radius, length },
            ShapeSpec::Bifilar { radius, length } => PathShape::Bifilar { radius, length },
            ShapeSpec::Epicycloid { rho0, n_tilde, alpha1 } => PathShape::Epicycloid { rho0, n_tilde, alpha1 },
            ShapeSpec::General { rho0, n_tilde, x, alpha } => PathShape::general(rho0, n_tilde, &x, &alpha),
        }
    }
}

impl From<PathShape> for ShapeSpec {
    fn from(shape: PathShape) -> ShapeSpec {
        match shape {
            PathShape::Circle { radius, length } => ShapeSpec::Circle { radius, length },
            PathShape::Bifilar { radius, length } => ShapeSpec::Bifilar { radius, length },
            PathShape::Epicycloid { rho0, n_tilde, alpha1 } => ShapeSpec::Epicycloid { rho0, n_tilde, alpha1 },
            PathShape::General(g) => {
                ShapeSpec::General { rho0: g.rho0, n_tilde: g.n_tilde, x: g.x.clone(), alpha: g.alpha.clone() }
            }
        }
    }
}

/// A general path's data and its tabulated curve: `ρ² = P(z)`, `z = s²`, with
/// `P(z) = ρ₀² − ñ²z + x₄z² + x₆z³ + …`, and `α(s) = s A(z)`, `A(z) = α₁ + α₃z + …`.
///
/// **The curve** (docs/design.md, "The general path"): `θ' = √(1 − ρ'²)/ρ = √g(z)/P(z)` with
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
    s_end: f64,
    /// θ(s) = Σ_j b_j T_{2j+1}(2u/π), u = asin(s/s_end).
    theta: Vec<f64>,
    /// Why the parameters are invalid: the field (below the shape) and the message.
    problem: Option<(&'static str, String)>,
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
    /// NOTE: the table is leaked on purpose: [`PathShape`] (and so the `Copy` joint kind) holds a
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
        if !(rho0.is_finite() && rho0 > 0.0) {
            return Err(("rho0", format!("the vertex radius ρ₀ (m) must be finite and positive, got {rho0}")));
        }
        if !(n_tilde.is_finite() && n_tilde > 0.0) {
            return Err(("n_tilde", format!("the path order ñ must be finite and positive, got {n_tilde}")));
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
    fn rotation(&self, s: f64) -> (f64, f64, f64) {
        if self.alpha.is_empty() {
            return (0.0, 0.0, 0.0);
        }
        // α = s A(z): α' = A + 2z A', α'' = 2s (3A' + 2z A'').
        let z = s * s;
        let (a, da, dda) = poly3(&self.alpha, z);
        (s * a, a + 2.0 * z * da, 2.0 * s * (3.0 * da + 2.0 * z * dda))
    }

    /// The path at arc length s (NaN beyond its end or for invalid parameters).
    fn at(&self, s: f64) -> PathPoint {
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
    fn polar(&self, s: f64) -> PolarPoint {
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

/// Where a path puts its point at one arc length s, in the path's own frame (centre at the
/// origin, vertex on +x), with the body's rotation law.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    /// Position r(s), m.
    pub position: Vec2,
    /// Unit tangent dr/ds.
    pub tangent: Vec2,
    /// Curvature vector d²r/ds², 1/m.
    pub curvature: Vec2,
    /// Rotation α(s) of the body relative to the parent, rad.
    pub alpha: f64,
    /// dα/ds, rad/m.
    pub dalpha: f64,
    /// d²α/ds², rad/m².
    pub ddalpha: f64,
}

impl PathPoint {
    /// Every field NaN: a point off the path.
    fn nan() -> PathPoint {
        let nan = Vec2::repeat(f64::NAN);
        PathPoint { position: nan, tangent: nan, curvature: nan, alpha: f64::NAN, dalpha: f64::NAN, ddalpha: f64::NAN }
    }
}

/// The rotation-invariant quantities of a path at one arc length s: what the dynamics of a body
/// whose centre of mass follows the path about the rotor axis need when the rotor's own frame is
/// the basis (docs/design.md, "Fast path for path joints"). With r the point, t = r' the unit
/// tangent and κ = r'' the curvature vector, all about the path's centre:
/// `|r|² = ρ²`, `r·t = ρρ' = ½ dρ²/ds`, `r × t = ρ w` (w = ρθ'), `r × κ = d(r × t)/ds`.
/// None of them depends on the polar angle θ(s), so none needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PolarPoint {
    /// `|r|² = ρ²`, m².
    pub rho_sq: f64,
    /// `r·t = ρ ρ'`, m.
    pub r_dot_t: f64,
    /// `r × t = ρ w = ρ² θ'`, m.
    pub r_cross_t: f64,
    /// `r × κ = d(r × t)/ds`, dimensionless.
    pub r_cross_k: f64,
    /// dα/ds, rad/m.
    pub dalpha: f64,
    /// d²α/ds², rad/m².
    pub ddalpha: f64,
}

impl PolarPoint {
    /// Every field NaN: a point off the path.
    fn nan() -> PolarPoint {
        let nan = f64::NAN;
        PolarPoint { rho_sq: nan, r_dot_t: nan, r_cross_t: nan, r_cross_k: nan, dalpha: nan, ddalpha: nan }
    }
}

/// A path prepared for [`PolarPath::at`]: its constants (travel, squares, the scale of the
/// epicycloid's parameter) computed once per joint, so that an evaluation's dependency chain
/// holds no division or square root of constants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PolarPath {
    /// `Circle` (`turns`: α = s/L) or `Bifilar` (α = 0).
    Circle {
        /// 1/L, 1/m.
        inv_length: f64,
        /// R² + L², m².
        sum_sq: f64,
        /// 2RL, m².
        two_rl: f64,
        /// R, m.
        radius: f64,
        /// L, m.
        length: f64,
        /// R/L.
        ratio: f64,
        /// α' (1/L for `Circle`, 0 for `Bifilar`), rad/m.
        dalpha: f64,
    },
    /// `Epicycloid`.
    Epicycloid {
        /// The end of travel s_max, m.
        travel: f64,
        /// ρ₀², m².
        rho0_sq: f64,
        /// ñ².
        n2: f64,
        /// ρ₀, m.
        rho0: f64,
        /// `c = ñ√(1+ñ²)/ρ₀` of σ = sin u = c s, 1/m.
        c_sigma: f64,
        /// −ρ₀ c, dimensionless.
        minus_rho0_c: f64,
        /// α₁, rad/m.
        alpha1: f64,
    },
    /// `General`: its polynomials are already stored.
    General(&'static GeneralPath),
}

impl PolarPath {
    /// The rotation-invariant quantities at arc length `s` (m); NaN in every field at |s| ≥ the
    /// travel (or a NaN s), as [`PathShape::at`].
    #[inline(always)]
    pub fn at(self, s: f64) -> PolarPoint {
        match self {
            PolarPath::Circle { inv_length, sum_sq, two_rl, radius, length, ratio, dalpha } => {
                // r = (R, 0) + L(cos φ, sin φ), t = (−sin φ, cos φ), κ = −(cos φ, sin φ)/L.
                let (sn, cs) = (s * inv_length).sin_cos();
                PolarPoint {
                    rho_sq: sum_sq + two_rl * cs,
                    r_dot_t: -radius * sn,
                    r_cross_t: length + radius * cs,
                    r_cross_k: -ratio * sn,
                    dalpha,
                    ddalpha: 0.0,
                }
            }
            PolarPath::Epicycloid { travel, rho0_sq, n2, rho0, c_sigma, minus_rho0_c, alpha1 } => {
                // Written so that a NaN s also counts as off the path.
                let on_path = s.abs() < travel;
                if !on_path {
                    return PolarPoint::nan();
                }
                // ρ² = ρ₀² − ñ²s² and ρρ' = −ñ²s exactly; with σ = sin u = c s, ρw = ρ₀ cos u
                // (cos u > 0 inside the travel), whose derivative is −ρ₀ c σ / cos u.
                let sigma = c_sigma * s;
                let cos_u = ((1.0 - sigma) * (1.0 + sigma)).sqrt();
                PolarPoint {
                    rho_sq: rho0_sq - n2 * (s * s),
                    r_dot_t: -n2 * s,
                    r_cross_t: rho0 * cos_u,
                    r_cross_k: minus_rho0_c * sigma / cos_u,
                    dalpha: alpha1,
                    ddalpha: 0.0,
                }
            }
            PolarPath::General(g) => g.polar(s),
        }
    }
}

impl PathShape {
    /// The general path `ρ² = ρ₀² − ñ²s² + x₄s⁴ + …`, `α = α₁s + α₃s³ + …` (`x` = [x₄, x₆, …],
    /// `alpha` = [α₁, α₃, …]), tabulated once ([`GeneralPath::intern`]). Invalid parameters give
    /// a shape whose [`PathShape::check`] names the field.
    pub fn general(rho0: f64, n_tilde: f64, x: &[f64], alpha: &[f64]) -> PathShape {
        PathShape::General(GeneralPath::intern(rho0, n_tilde, x, alpha))
    }

    /// The end of travel: |s| must stay below it (m); infinite for a circle. For a general path,
    /// where |dρ/ds| reaches 1 (NaN when its parameters are invalid).
    pub fn travel(self) -> f64 {
        match self {
            PathShape::Circle { .. } | PathShape::Bifilar { .. } => f64::INFINITY,
            PathShape::Epicycloid { rho0, n_tilde, .. } => rho0 / (n_tilde * (1.0 + n_tilde * n_tilde).sqrt()),
            PathShape::General(g) => g.s_end,
        }
    }

    /// The Taylor coefficients of the path about its vertex, `(ρ₀², ñ², x₄, [α₁, α₃])`:
    /// `ρ² = ρ₀² − ñ²s² + x₄s⁴ + O(s⁶)`, `α = α₁s + α₃s³ + O(s⁵)` (closed forms for the named
    /// shapes; the circle's from the series of cos(s/L)). The absorber properties are made of these.
    pub fn taylor(self) -> (f64, f64, f64, [f64; 2]) {
        match self {
            PathShape::Circle { radius: r, length: l } | PathShape::Bifilar { radius: r, length: l } => {
                // ρ² = R² + L² + 2RL cos(s/L) = (R+L)² − (R/L)s² + (R/(12L³))s⁴ − …
                let turn = if matches!(self, PathShape::Circle { .. }) { 1.0 / l } else { 0.0 };
                ((r + l) * (r + l), r / l, r / (12.0 * l * l * l), [turn, 0.0])
            }
            PathShape::Epicycloid { rho0, n_tilde, alpha1 } => (rho0 * rho0, n_tilde * n_tilde, 0.0, [alpha1, 0.0]),
            PathShape::General(g) => {
                let at = |v: &[f64], k: usize| v.get(k).copied().unwrap_or(0.0);
                (g.rho0 * g.rho0, g.n_tilde * g.n_tilde, at(&g.x, 0), [at(&g.alpha, 0), at(&g.alpha, 1)])
            }
        }
    }

    /// True when the path is exactly an epicycloid with a linear rotation law (a general path
    /// without x or higher α terms counts): then, at held spin, the reduced equation is exactly
    /// linear (see docs/design.md).
    pub fn is_epicycloid(self) -> bool {
        match self {
            PathShape::Epicycloid { .. } => true,
            PathShape::General(g) => g.x.iter().all(|v| *v == 0.0) && g.alpha.iter().skip(1).all(|v| *v == 0.0),
            _ => false,
        }
    }

    /// A length typical of the path's curvature (m): the finite-difference steps of the linear
    /// analysis are taken relative to it, so they stay inside the travel and resolve the path.
    /// L for a circle (a step of 0.05·L is the 0.05 rad the revolute pendulum gets), a fifth of
    /// the travel for an epicycloid.
    pub fn length_scale(self) -> f64 {
        match self {
            PathShape::Circle { length, .. } | PathShape::Bifilar { length, .. } => length,
            PathShape::Epicycloid { .. } | PathShape::General(_) => 0.2 * self.travel(),
        }
    }

    /// Whether the carried body turns relative to the parent as it moves (α not identically 0).
    pub fn turns(self) -> bool {
        match self {
            PathShape::Circle { .. } => true,
            PathShape::Bifilar { .. } => false,
            PathShape::Epicycloid { alpha1, .. } => alpha1 != 0.0,
            PathShape::General(g) => g.alpha.iter().any(|a| *a != 0.0),
        }
    }

    /// The body's rotation α(s) relative to the parent, rad (exact, not wrapped).
    pub fn alpha(self, s: f64) -> f64 {
        match self {
            PathShape::Circle { length, .. } => s / length,
            PathShape::Bifilar { .. } => 0.0,
            PathShape::Epicycloid { alpha1, .. } => alpha1 * s,
            PathShape::General(g) => g.rotation(s).0,
        }
    }

    /// The path at arc length `s` (m). Outside the travel (|s| ≥ s_max, or s not finite) every
    /// field is NaN: the engine reports that as the joint leaving its path (see
    /// `Mechanism::path_out_of_travel`), and nothing downstream can mistake it for a state.
    #[inline]
    pub fn at(self, s: f64) -> PathPoint {
        match self {
            PathShape::Circle { radius, length } | PathShape::Bifilar { radius, length } => {
                let (sn, cs) = (s / length).sin_cos();
                let arm = Vec2::new(cs, sn);
                let turns = matches!(self, PathShape::Circle { .. });
                PathPoint {
                    position: Vec2::new(radius, 0.0) + length * arm,
                    tangent: perp(arm),
                    curvature: -arm / length,
                    alpha: self.alpha(s),
                    dalpha: if turns { 1.0 / length } else { 0.0 },
                    ddalpha: 0.0,
                }
            }
            PathShape::Epicycloid { rho0, n_tilde, alpha1 } => {
                // Written so that a NaN s also counts as off the path.
                let on_path = s.abs() < self.travel();
                if !on_path {
                    let nan = Vec2::repeat(f64::NAN);
                    return PathPoint {
                        position: nan,
                        tangent: nan,
                        curvature: nan,
                        alpha: f64::NAN,
                        dalpha: f64::NAN,
                        ddalpha: f64::NAN,
                    };
                }
                let n2 = n_tilde * n_tilde;
                let k1 = (1.0 + n2).sqrt();
                let rho = (rho0 * rho0 - n2 * s * s).sqrt();
                // σ = sin u with s = ρ₀ sin u / (ñ √(1+ñ²)); cos u = √(1 − σ²) > 0 inside the travel.
                // (ñ s / ρ₀) first: the division runs beside the square root, not after it.
                let sigma = n_tilde * s / rho0 * k1;
                let cos_u = ((1.0 - sigma) * (1.0 + sigma)).sqrt();
                // ρ' = −ñ²s/ρ and w = ρθ' = √(1 − ρ'²) = ρ₀ cos u / ρ.
                let d_rho = -n2 * s / rho;
                let w = rho0 * cos_u / rho;
                // θ(s) = A u − β with A = √(1+ñ²)/ñ and β = atan2(ñ sin u, √(1+ñ²) cos u), whose
                // cosine and sine are w and −ρ' (docs/design.md): so e_ρ is the direction of
                // A u turned back by β, and the tangent ρ' e_ρ + w e_θ is the direction of
                // A u + π/2: the tangent turns linearly in u. Its derivative, with
                // du/ds = ñ√(1+ñ²) / (ρ₀ cos u), is the curvature vector, of length
                // (1+ñ²) / (ρ₀ cos u), towards −(cos Au, sin Au). One `asin` and one `sin_cos`
                // (not also an `atan2` and a second `sin_cos` for θ).
                let (sa, ca) = (k1 / n_tilde * sigma.asin()).sin_cos();
                let e_rho = Vec2::new(ca * w - sa * d_rho, sa * w + ca * d_rho);
                let kappa = (1.0 + n2) / (rho0 * cos_u);
                PathPoint {
                    position: rho * e_rho,
                    tangent: Vec2::new(-sa, ca),
                    curvature: Vec2::new(-kappa * ca, -kappa * sa),
                    alpha: alpha1 * s,
                    dalpha: alpha1,
                    ddalpha: 0.0,
                }
            }
            PathShape::General(g) => g.at(s),
        }
    }

    /// The path prepared for [`PolarPath::at`], its constants computed once.
    pub fn polar_path(self) -> PolarPath {
        match self {
            PathShape::Circle { radius, length } | PathShape::Bifilar { radius, length } => PolarPath::Circle {
                inv_length: 1.0 / length,
                sum_sq: radius * radius + length * length,
                two_rl: 2.0 * radius * length,
                radius,
                length,
                ratio: radius / length,
                dalpha: if matches!(self, PathShape::Circle { .. }) { 1.0 / length } else { 0.0 },
            },
            PathShape::Epicycloid { rho0, n_tilde, alpha1 } => {
                let c_sigma = n_tilde * (1.0 + n_tilde * n_tilde).sqrt() / rho0;
                PolarPath::Epicycloid {
                    travel: self.travel(),
                    rho0_sq: rho0 * rho0,
                    n2: n_tilde * n_tilde,
                    rho0,
                    c_sigma,
                    minus_rho0_c: -rho0 * c_sigma,
                    alpha1,
                }
            }
            PathShape::General(g) => PolarPath::General(g),
        }
    }

    /// The rotation-invariant quantities at arc length `s` (m) ([`PolarPoint`]): `self.polar_path().at(s)`.
    pub fn polar(self, s: f64) -> PolarPoint {
        self.polar_path().at(s)
    }

    /// Checks the parameters: the field that is wrong and why.
    pub fn check(self) -> Result<(), (&'static str, String)> {
        let positive = |field: &'static str, v: f64, what: &str| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err((field, format!("{what} must be finite and positive, got {v}")))
            }
        };
        match self {
            PathShape::Circle { radius, length } | PathShape::Bifilar { radius, length } => {
                positive("radius", radius, "the pivot radius R (m)")?;
                positive("length", length, "the path radius L (m)")
            }
            PathShape::Epicycloid { rho0, n_tilde, alpha1 } => {
                positive("rho0", rho0, "the vertex radius ρ₀ (m)")?;
                positive("n_tilde", n_tilde, "the path order ñ")?;
                if alpha1.is_finite() {
                    Ok(())
                } else {
                    Err(("alpha1", format!("the rotation law α₁ (rad/m) must be finite, got {alpha1}")))
                }
            }
            PathShape::General(g) => g.problem.clone().map_or(Ok(()), Err),
        }
    }
}

/// Rollers that carry a translating absorber on its path (a roller-type or bifilar absorber):
/// `count` rollers of `mass` (kg), centroidal `inertia` (kg·m²) and `radius` (m) rolling without
/// slip between a track of the parent (rotor) and a track of the absorber (docs/design.md,
/// "Rollers").
///
/// Their kinematics need nothing about the tracks' shapes: each roller centre moves, relative to
/// the parent, by half the absorber's displacement (velocity ½ṡ t(s)) and turns relative to the
/// parent by ψ = −s/(2 r_r) (the parent's contact on the roller's outer side, where the
/// centrifugal load puts it). Their centroid sits halfway between the path's point and the
/// vertex's centre of curvature, `c̄(s) = ½(P + r(s))`, and each roller keeps its offset from it
/// (fixed in the parent), so their spread about it adds the constant `count · mass · spread²`
/// to the parent's moment of inertia.
///
/// In RON, on a path joint: `rollers: Rollers(count: 2, mass: 0.08, inertia: 1.44e-6,
/// radius: 0.006, spread: 0.03)`.
///
/// # Common mistake
/// The derivation holds for a translating absorber only (α = 0: `Bifilar`, an `Epicycloid`
/// without `alpha1`, a `General` path without `alpha`); a path with a rotation law is refused.
/// `mass` and `inertia` are per roller, not for the set.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rollers {
    /// Number N of rollers (≥ 1).
    pub count: u32,
    /// Mass m_r of one roller, kg (≥ 0).
    pub mass: f64,
    /// Centroidal moment of inertia I_r of one roller, kg·m² (≥ 0; a uniform disc: ½ m_r r_r²).
    pub inertia: f64,
    /// Rolling radius r_r of a roller, m (> 0).
    pub radius: f64,
    /// Root-mean-square distance of the roller centres from their centroid, m (≥ 0, default 0):
    /// the rollers' spread, which adds `count · mass · spread²` to the parent's inertia (two
    /// rollers a distance d apart: d/2).
    #[serde(default)]
    pub spread: f64,
}

impl Rollers {
    /// Total mass N m_r of the rollers, kg.
    pub fn total_mass(&self) -> f64 {
        f64::from(self.count) * self.mass
    }

    /// Sum N I_r of the rollers' own centroidal inertias, kg·m² (the inertia that turns with ψ).
    pub fn total_inertia(&self) -> f64 {
        f64::from(self.count) * self.inertia
    }

    /// The rollers' spread about their centroid, `N m_r spread²` (kg·m²): a constant inertia of
    /// the parent.
    pub fn spread_inertia(&self) -> f64 {
        self.total_mass() * self.spread * self.spread
    }

    /// The rollers' rotation relative to the parent per unit arc length of the absorber,
    /// `dψ/ds = −1/(2 r_r)`, rad/m.
    pub fn turn_rate(&self) -> f64 {
        -0.5 / self.radius
    }

    /// Checks the numbers: the field that is wrong and why.
    pub fn check(&self) -> Result<(), (&'static str, String)> {
        if self.count == 0 {
            return Err(("count", "a roller set needs at least one roller, got count 0".into()));
        }
        for (field, v, what) in [
            ("mass", self.mass, "the roller mass (kg)"),
            ("inertia", self.inertia, "the roller inertia (kg·m²)"),
            ("spread", self.spread, "the rollers' spread (m)"),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err((field, format!("{what} must be finite and non-negative, got {v}")));
            }
        }
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(("radius", format!("the roller radius (m) must be finite and positive, got {}", self.radius)));
        }
        Ok(())
    }

    /// Checks that the rollers' derivation holds on `shape`: the absorber translates (α ≡ 0).
    pub fn check_on(&self, shape: PathShape) -> Result<(), (&'static str, String)> {
        let turns = match shape {
            PathShape::Circle { .. } => true,
            PathShape::Bifilar { .. } => false,
            PathShape::Epicycloid { alpha1, .. } => alpha1 != 0.0,
            PathShape::General(g) => g.alpha.iter().any(|a| *a != 0.0),
        };
        if turns {
            return Err((
                "rollers",
                "rollers are modelled for a translating absorber only (rotation law α = 0: a `Bifilar`, an \
                 `Epicycloid` without `alpha1`, a `General` path without `alpha`); this path turns its body"
                    .into(),
            ));
        }
        Ok(())
    }

    /// The vertex's centre of curvature P in the path's own frame, `r(0) + r''(0)/|r''(0)|²`, m:
    /// the rollers' centroid is `c̄(s) = ½(P + r(s))` (docs/design.md, "Rollers").
    pub fn vertex_centre(shape: PathShape) -> Vec2 {
        let vertex = shape.at(0.0);
        vertex.position + vertex.curvature / vertex.curvature.norm_squared()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Position, tangent and curvature are consistent (central differences of r, step 1e-6 m:
    /// truncation ~h²|r'''| ≈ 1e-10, rounding ~1e-16/1e-6): the tangent is a unit vector (the
    /// arc-length meaning of s) and is dr/ds, and the curvature is dt/ds.
    #[test]
    fn tangent_and_curvature_are_derivatives_of_the_position() {
        let shapes = [
            PathShape::Circle { radius: 0.17, length: 0.015 },
            PathShape::Bifilar { radius: 0.1, length: 0.03 },
            PathShape::Epicycloid { rho0: 0.185, n_tilde: 3.11, alpha1: 0.0 },
            PathShape::Epicycloid { rho0: 0.5, n_tilde: 0.7, alpha1: 2.0 },
        ];
        for shape in shapes {
            let scale = shape.length_scale();
            for f in [-0.9, -0.4, 0.0, 0.3, 0.95] {
                let s = f * 4.5 * scale.min(shape.travel() / 4.5);
                let p = shape.at(s);
                let h = 1e-6;
                let (a, b) = (shape.at(s + h), shape.at(s - h));
                let t_fd = (a.position - b.position) / (2.0 * h);
                let k_fd = (a.tangent - b.tangent) / (2.0 * h);
                assert!((p.tangent.norm() - 1.0).abs() < 1e-14, "{shape:?} at {s}: |t| = {}", p.tangent.norm());
                assert!((t_fd - p.tangent).norm() < 1e-8, "{shape:?} at {s}: t {:?} vs {:?}", p.tangent, t_fd);
                assert!(
                    (k_fd - p.curvature).norm() < 1e-7 * p.curvature.norm().max(1.0),
                    "{shape:?} at {s}: κ {:?} vs {:?}",
                    p.curvature,
                    k_fd
                );
            }
        }
    }

    /// The rotation-invariant quantities of [`PolarPath::at`] equal the products of
    /// [`PathShape::at`]'s vectors (|r|², r·t, r × t, r × κ) and its rotation law, for every kind
    /// and mount-free path, to 1e-13 of the size of the products' terms (|r|², |r|, |r||κ|: both
    /// sides are a few roundings of these), and are NaN off the path as `at` is.
    #[test]
    fn polar_quantities_are_the_products_of_the_vectors() {
        let shapes = [
            PathShape::Circle { radius: 0.17, length: 0.015 },
            PathShape::Bifilar { radius: 0.1, length: 0.03 },
            PathShape::Epicycloid { rho0: 0.185, n_tilde: 3.11, alpha1: 0.0 },
            PathShape::Epicycloid { rho0: 0.5, n_tilde: 0.7, alpha1: 2.0 },
            PathShape::general(0.3, 1.7, &[4.0], &[0.8, -3.0]),
        ];
        for shape in shapes {
            let reach = if shape.travel().is_finite() { shape.travel() } else { 3.0 * shape.length_scale() };
            for f in [-0.99, -0.6, -0.1, 0.0, 0.25, 0.7, 0.95, 0.999] {
                let s = f * reach;
                let (p, q) = (shape.at(s), shape.polar(s));
                let (r, t, k) = (p.position, p.tangent, p.curvature);
                let cross = |a: Vec2, b: Vec2| a.x * b.y - a.y * b.x;
                let pairs = [
                    (q.rho_sq, r.norm_squared(), r.norm_squared()),
                    (q.r_dot_t, r.dot(&t), r.norm()),
                    (q.r_cross_t, cross(r, t), r.norm()),
                    (q.r_cross_k, cross(r, k), r.norm() * k.norm()),
                ];
                for (i, (polar, vectors, size)) in pairs.into_iter().enumerate() {
                    assert!(
                        (polar - vectors).abs() <= 1e-13 * size,
                        "{shape:?} at {s}: quantity {i}: {polar} vs {vectors}"
                    );
                }
                assert_eq!((q.dalpha, q.ddalpha), (p.dalpha, p.ddalpha), "{shape:?} at {s}");
            }
            if shape.travel().is_finite() {
                assert!(
                    shape.polar(shape.travel()).rho_sq.is_nan()
                        && shape.polar(-1.5 * shape.travel()).r_cross_k.is_nan()
                );
            }
            assert!(shape.polar(f64::NAN).r_cross_t.is_nan());
        }
    }

    /// The epicycloid's distance from the centre is the declared one, ρ² = ρ₀² − ñ²s², and it
    /// ends at s_max = ρ₀/(ñ√(1+ñ²)) (NaN beyond).
    #[test]
    fn epicycloid_radius_and_travel() {
        let (rho0, n) = (0.185, 3.11);
        let shape = PathShape::Epicycloid { rho0, n_tilde: n, alpha1: 0.0 };
        let s_max = shape.travel();
        assert!((s_max - rho0 / (n * (1.0 + n * n).sqrt())).abs() < 1e-18);
        for f in [0.0, 0.2, -0.5, 0.99] {
            let s = f * s_max;
            let r2 = shape.at(s).position.norm_squared();
            assert!((r2 - (rho0 * rho0 - n * n * s * s)).abs() < 1e-15, "ρ² at {s}");
        }
        assert!(shape.at(1.0001 * s_max).position.x.is_nan());
        assert!(shape.at(f64::NAN).tangent.x.is_nan());
    }
}

//! Absorber paths: the curves a path joint's child frame origin follows in its parent's frame,
//! parameterised by arc length, with the child body's rotation law (docs/design/paths.md, "The path
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
//!   closed form in `tests/it/path_general.rs`).
//!
//! The vertex (s = 0) lies on the +x axis of the path's own frame; the joint turns that frame by
//! its mounting angle.

//!
//! The general path's table is in `general.rs`, the rotation-invariant form the fast path reads
//! in `polar.rs` and the rollers of a roller-type absorber in `rollers.rs`.

mod general;
mod polar;
mod rollers;

pub use general::GeneralPath;
pub use polar::PolarPath;
pub use rollers::Rollers;

use crate::model::math::{Vec2, perp};
use serde::{Deserialize, Serialize};

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
/// the basis (docs/design/paths.md, "Fast path for path joints"). With r the point, t = r' the unit
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
    /// linear (see docs/design/paths.md).
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
                // cosine and sine are w and −ρ' (docs/design/paths.md): so e_ρ is the direction of
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
        use crate::model::ranges::{PATH_LENGTH_M, PATH_ORDER, show, within};
        let inside = |field: &'static str, v: f64, what: &str, range| {
            if within(v, range) {
                Ok(())
            } else {
                Err((field, format!("{what} must lie in {}, got {v:e}", show(range))))
            }
        };
        match self {
            PathShape::Circle { radius, length } | PathShape::Bifilar { radius, length } => {
                inside("radius", radius, "the pivot radius R (m)", &PATH_LENGTH_M)?;
                inside("length", length, "the path radius L (m)", &PATH_LENGTH_M)
            }
            PathShape::Epicycloid { rho0, n_tilde, alpha1 } => {
                inside("rho0", rho0, "the vertex radius ρ₀ (m)", &PATH_LENGTH_M)?;
                inside("n_tilde", n_tilde, "the path order ñ", &PATH_ORDER)?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use approx::{abs_diff_eq, assert_abs_diff_eq};

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
                assert!(
                    abs_diff_eq!(p.tangent.norm(), 1.0, epsilon = 1e-14),
                    "{shape:?} at {s}: |t| = {}",
                    p.tangent.norm()
                );
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
                        abs_diff_eq!(polar, vectors, epsilon = 1e-13 * size),
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
        assert_abs_diff_eq!(s_max, rho0 / (n * (1.0 + n * n).sqrt()), epsilon = 1e-18);
        for f in [0.0, 0.2, -0.5, 0.99] {
            let s = f * s_max;
            let r2 = shape.at(s).position.norm_squared();
            assert!(abs_diff_eq!(r2, rho0 * rho0 - n * n * s * s, epsilon = 1e-15), "ρ² at {s}");
        }
        assert!(shape.at(1.0001 * s_max).position.x.is_nan());
        assert!(shape.at(f64::NAN).tangent.x.is_nan());
    }
}

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
//! The vertex (s = 0) lies on the +x axis of the path's own frame; the joint turns that frame by
//! its mounting angle.

use crate::model::math::{Vec2, perp};
use serde::{Deserialize, Serialize};

/// The shape of an absorber path and the rotation law of the body on it. All lengths in m.
///
/// In RON: `Circle(radius: 0.17, length: 0.0152)`, `Bifilar(radius: 0.17, length: 0.0152)`,
/// `Epicycloid(rho0: 0.185, n_tilde: 3.11)` (optionally `alpha1: …`, rad/m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
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
        #[serde(default)]
        alpha1: f64,
    },
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

impl PathShape {
    /// The end of travel: |s| must stay below it (m); infinite for a circle.
    pub fn travel(self) -> f64 {
        match self {
            PathShape::Circle { .. } | PathShape::Bifilar { .. } => f64::INFINITY,
            PathShape::Epicycloid { rho0, n_tilde, .. } => rho0 / (n_tilde * (1.0 + n_tilde * n_tilde).sqrt()),
        }
    }

    /// A length typical of the path's curvature (m): the finite-difference steps of the linear
    /// analysis are taken relative to it, so they stay inside the travel and resolve the path.
    /// L for a circle (a step of 0.05·L is the 0.05 rad the revolute pendulum gets), a fifth of
    /// the travel for an epicycloid.
    pub fn length_scale(self) -> f64 {
        match self {
            PathShape::Circle { length, .. } | PathShape::Bifilar { length, .. } => length,
            PathShape::Epicycloid { .. } => 0.2 * self.travel(),
        }
    }

    /// The body's rotation α(s) relative to the parent, rad (exact, not wrapped).
    pub fn alpha(self, s: f64) -> f64 {
        match self {
            PathShape::Circle { length, .. } => s / length,
            PathShape::Bifilar { .. } => 0.0,
            PathShape::Epicycloid { alpha1, .. } => alpha1 * s,
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
        }
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
        }
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

//! The rotation-invariant form of a path (|r|², r·t, r×t, r×κ about the rotor axis), which the
//! fixed-size pair form of a rotor with one path absorber reads instead of the curve's polar angle
//! (docs/design/kane.md, "Fast path for path joints").

use super::{GeneralPath, PolarPoint};

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
    /// travel (or a NaN s), as [`PathShape::at`](super::PathShape::at).
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

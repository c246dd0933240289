//! Rollers of a roller-type absorber: N rollers rolling without slip between the rotor's track
//! and the absorber's, their centroid halfway between the vertex's centre of curvature and the
//! absorber's point, turning at dψ/ds = −1/(2 r_r) (docs/design/paths.md, "Rollers").

use super::PathShape;
use crate::model::math::Vec2;
use serde::{Deserialize, Serialize};

/// Rollers that carry a translating absorber on its path (a roller-type or bifilar absorber):
/// `count` rollers of `mass` (kg), centroidal `inertia` (kg·m²) and `radius` (m) rolling without
/// slip between a track of the parent (rotor) and a track of the absorber (docs/design/paths.md,
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
        let most = crate::model::ranges::MAX_ROLLERS;
        if self.count == 0 || self.count > most {
            return Err((
                "count",
                format!(
                    "a roller set has 1 to {most} rollers (at least one carries the absorber), got count {}",
                    self.count
                ),
            ));
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
        if shape.turns() {
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
    /// the rollers' centroid is `c̄(s) = ½(P + r(s))` (docs/design/paths.md, "Rollers").
    pub fn vertex_centre(shape: PathShape) -> Vec2 {
        let vertex = shape.at(0.0);
        vertex.position + vertex.curvature / vertex.curvature.norm_squared()
    }
}

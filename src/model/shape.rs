//! Plane shapes with a density → mass properties, through parry2d-f64.
//!
//! A body may take its mass, centre of mass and centroidal inertia from a shape instead of
//! listing them (see [`crate::model::body::BodySpec`]). The shapes are a disc, an annulus, a rectangle,
//! a convex polygon and a compound of placed shapes, some of which may be holes. Each primitive's
//! area, centroid and polar second moment of area come from parry2d-f64's `MassProperties` (this
//! module is the one place in kanedyn that sees parry's glam types); placing and combining them is
//! done with [`PlanarInertia`]'s `placed`, `+` and `-`.
//!
//! # RON form
//! ```ron
//! shape: Disc(radius: 0.2)                                  // m, centred on the body origin
//! shape: Annulus(inner_radius: 0.05, outer_radius: 0.2)     // m
//! shape: Rectangle(width: 0.5, height: 0.04)                // m, along x and y, centred
//! shape: ConvexPolygon(points: [(0.0, 0.0), (0.3, 0.0), (0.0, 0.1)])   // m, in order
//! shape: Compound(parts: [
//!     Placed(shape: Rectangle(width: 0.3, height: 0.02), at: (0.15, 0.0)),
//!     Placed(shape: Disc(radius: 0.04), at: (0.3, 0.0)),
//!     Placed(shape: Disc(radius: 0.01), at: (0.3, 0.0), hole: true),
//! ])
//! ```
//! `at` (m) and `angle` (rad, counter-clockwise) place a part's own frame in the enclosing frame
//! (both default to 0); `hole: true` removes the part's area instead of adding it.
//!
//! # Common mistakes
//! - Radii, not diameters.
//! - A 2-D density is per unit **area** (kg/m²): a plate of density ρ (kg/m³) and thickness t (m)
//!   has ρ·t. The body spec accepts either form.
//! - A hole must lie inside the solid parts. Only the totals are checked (the area left must be
//!   positive), not the geometry of the overlap.

use crate::model::inertia::PlanarInertia;
use crate::model::math::Vec2;
use parry2d_f64::mass_properties::MassProperties;
use parry2d_f64::math::Vector as ParryVec;
use serde::{Deserialize, Serialize};

/// A plane shape, in its own frame. Lengths in m.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum ShapeSpec {
    /// A full disc centred on the origin: area πr², polar second moment πr⁴/2 about its centre.
    Disc {
        /// Radius, m (> 0).
        radius: f64,
    },
    /// A ring centred on the origin: the disc of `outer_radius` minus the disc of `inner_radius`.
    Annulus {
        /// Radius of the hole, m (0 ≤ inner < outer; 0 gives a full disc).
        inner_radius: f64,
        /// Outer radius, m.
        outer_radius: f64,
    },
    /// A rectangle centred on the origin, `width` along x and `height` along y (full sizes, not
    /// half sizes).
    Rectangle {
        /// Size along x, m (> 0).
        width: f64,
        /// Size along y, m (> 0).
        height: f64,
    },
    /// A convex polygon through `points` (m, in the shape's frame, not re-centred), taken in order
    /// around the boundary, either way round; every vertex must turn the same way.
    ConvexPolygon {
        /// Vertices, at least 3.
        points: Vec<(f64, f64)>,
    },
    /// Several placed shapes forming one rigid body; holes subtract.
    Compound {
        /// The parts.
        parts: Vec<PlacedShape>,
    },
}

/// A part of a [`ShapeSpec::Compound`]: a shape placed in the compound's frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Placed", deny_unknown_fields)]
pub struct PlacedShape {
    /// The part's shape, in its own frame.
    pub shape: ShapeSpec,
    /// Where the part's origin sits in the compound's frame, m (default the origin).
    #[serde(default)]
    pub at: (f64, f64),
    /// Rotation of the part's frame relative to the compound's, rad, counter-clockwise (default 0).
    #[serde(default)]
    pub angle: f64,
    /// `true` to remove this part's area (a bore, a lightening hole) instead of adding it.
    #[serde(default)]
    pub hole: bool,
}

/// A shape that cannot give mass properties: the offending field, relative to the shape
/// (`.parts[1].shape.radius`; empty for the shape as a whole), and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("shape{field}: {message}")]
pub struct ShapeError {
    /// Field path below the shape, in serde_path_to_error's form (`.points[2]`), or empty.
    pub field: String,
    /// What is wrong, in words.
    pub message: String,
}

fn err(field: impl Into<String>, message: impl Into<String>) -> ShapeError {
    ShapeError { field: field.into(), message: message.into() }
}

fn positive(field: &str, what: &str, v: f64) -> Result<(), ShapeError> {
    if !v.is_finite() {
        return Err(err(format!(".{field}"), format!("{what} must be a finite number, got {v}")));
    }
    if v <= 0.0 {
        return Err(err(format!(".{field}"), format!("{what} must be positive, got {v} m")));
    }
    not_huge(&format!(".{field}"), what, v)
}

/// Refuses a length whose fourth power (the scale of a second moment of area) overflows.
///
/// NOTE: parry stores the inverse of mass and inertia, so an infinite area comes back as a
/// zero one: a disc of radius 1e200 would silently weigh nothing.
fn not_huge(field: &str, what: &str, v: f64) -> Result<(), ShapeError> {
    if !v.powi(4).is_finite() {
        return Err(err(field, format!("{what} {v:e} m is too large: its second moment of area (∝ size⁴) overflows")));
    }
    Ok(())
}

impl ShapeSpec {
    /// Checks the geometry: finite positive sizes, `inner_radius < outer_radius`, a convex,
    /// non-degenerate polygon given in order, finite placements, and a compound whose holes leave
    /// a positive area.
    pub fn validate(&self) -> Result<(), ShapeError> {
        self.unit_properties().map(|_| ())
    }

    /// Mass properties for an areal density (kg/m²): mass (kg), centre of mass (m, in the
    /// shape's frame) and moment of inertia about the centre of mass (kg·m²). Validates first.
    ///
    /// A negative or non-finite density is an error; zero gives zero mass and inertia.
    pub fn mass_properties(&self, areal_density: f64) -> Result<PlanarInertia, ShapeError> {
        if !(areal_density.is_finite() && areal_density >= 0.0) {
            return Err(err("", format!("areal density must be finite and non-negative, got {areal_density} kg/m²")));
        }
        let unit = self.unit_properties()?;
        // Mass and inertia are linear in a uniform density; the centroid does not depend on it.
        Ok(PlanarInertia::new(unit.mass * areal_density, unit.com, unit.i_com * areal_density))
    }

    /// Area (m²), centroid (m) and polar second moment of area about the centroid (m⁴), as the
    /// mass properties of a unit areal density. Validates on the way.
    pub fn unit_properties(&self) -> Result<PlanarInertia, ShapeError> {
        match self {
            ShapeSpec::Disc { radius } => {
                positive("radius", "radius", *radius)?;
                Ok(from_parry(&MassProperties::from_ball(1.0, *radius)))
            }
            ShapeSpec::Annulus { inner_radius: ri, outer_radius: ro } => {
                positive("outer_radius", "outer radius", *ro)?;
                if !ri.is_finite() {
                    return Err(err(".inner_radius", format!("inner radius must be a finite number, got {ri}")));
                }
                if *ri < 0.0 {
                    return Err(err(".inner_radius", format!("inner radius must not be negative, got {ri} m")));
                }
                if ri >= ro {
                    return Err(err(
                        ".inner_radius",
                        format!("inner radius {ri} m must be smaller than the outer radius {ro} m"),
                    ));
                }
                let outer = from_parry(&MassProperties::from_ball(1.0, *ro));
                if *ri == 0.0 {
                    return Ok(outer);
                }
                Ok(outer - from_parry(&MassProperties::from_ball(1.0, *ri)))
            }
            ShapeSpec::Rectangle { width, height } => {
                positive("width", "width", *width)?;
                positive("height", "height", *height)?;
                // NOTE: parry's cuboid takes HALF extents.
                let half = ParryVec::new(0.5 * width, 0.5 * height);
                Ok(from_parry(&MassProperties::from_cuboid(1.0, half)))
            }
            ShapeSpec::ConvexPolygon { points } => {
                check_convex(points)?;
                let v: Vec<ParryVec> = points.iter().map(|&(x, y)| ParryVec::new(x, y)).collect();
                Ok(from_parry(&MassProperties::from_convex_polygon(1.0, &v)))
            }
            ShapeSpec::Compound { parts } => compound(parts),
        }
    }
}

/// Sums the solid parts and removes the holes, each placed in the compound's frame.
fn compound(parts: &[PlacedShape]) -> Result<PlanarInertia, ShapeError> {
    if parts.is_empty() {
        return Err(err(".parts", "a compound needs at least one part"));
    }
    // Options rather than a zero start, so that a single part passes through unchanged.
    let (mut solid, mut holes): (Option<PlanarInertia>, Option<PlanarInertia>) = (None, None);
    for (k, p) in parts.iter().enumerate() {
        let here = |e: ShapeError| err(format!(".parts[{k}].shape{}", e.field), e.message);
        let unit = p.shape.unit_properties().map_err(here)?;
        let (x, y) = p.at;
        if !(x.is_finite() && y.is_finite()) {
            return Err(err(format!(".parts[{k}].at"), "placement must be finite"));
        }
        if !p.angle.is_finite() {
            return Err(err(format!(".parts[{k}].angle"), format!("angle must be a finite number, got {}", p.angle)));
        }
        let placed = unit.placed(Vec2::new(x, y), p.angle);
        let sum = if p.hole { &mut holes } else { &mut solid };
        *sum = Some(sum.map_or(placed, |s| s + placed));
    }
    let Some(solid) = solid else {
        return Err(err(".parts", "a compound of holes only has no area"));
    };
    let Some(holes) = holes else {
        return Ok(solid);
    };
    // Relative to the solid area: a hole the size of the solid leaves only rounding behind.
    if solid.mass - holes.mass <= 1e-12 * solid.mass {
        return Err(err(
            "",
            format!("the holes ({:e} m²) leave no area of the solid parts ({:e} m²)", holes.mass, solid.mass),
        ));
    }
    let net = solid - holes;
    if net.i_com < 0.0 {
        return Err(err("", "the holes give a negative moment of inertia: do they lie inside the solid parts?"));
    }
    Ok(net)
}

/// A convex polygon, given in order: at least 3 finite points, every vertex turning the same way
/// (no repeated or collinear consecutive points), and going round exactly once (which rules out
/// self-intersecting stars such as the pentagram, whose vertices all turn the same way too).
fn check_convex(points: &[(f64, f64)]) -> Result<(), ShapeError> {
    let n = points.len();
    if n < 3 {
        return Err(err(".points", format!("a polygon needs at least 3 points, got {n}")));
    }
    for (k, &(x, y)) in points.iter().enumerate() {
        if !(x.is_finite() && y.is_finite()) {
            return Err(err(format!(".points[{k}]"), "point must be finite"));
        }
        not_huge(&format!(".points[{k}]"), "coordinate", x.abs().max(y.abs()))?;
    }
    let p = |k: usize| Vec2::new(points[k % n].0, points[k % n].1);
    let mut sign = 0.0;
    let mut turning = 0.0;
    for k in 0..n {
        let (a, b, c) = (p(k + n - 1), p(k), p(k + 1));
        let (e1, e2) = (b - a, c - b);
        let cross = crate::model::math::cross2(e1, e2);
        // Relative test: rounding of exactly collinear input leaves |cross| ~ 1e-16·|e1||e2|.
        if cross.abs() <= 1e-12 * e1.norm() * e2.norm() {
            return Err(err(
                format!(".points[{k}]"),
                format!("point {k} is repeated or collinear with its neighbours (zero turn); remove it"),
            ));
        }
        if sign == 0.0 {
            sign = cross.signum();
        } else if cross.signum() != sign {
            return Err(err(
                format!(".points[{k}]"),
                format!(
                    "the polygon is not convex (or its points are out of order): it turns the other way at point {k}"
                ),
            ));
        }
        turning += cross.atan2(e1.dot(&e2));
    }
    // A simple convex polygon turns through exactly ±2π; a star polygon through a multiple of it.
    if (turning.abs() - std::f64::consts::TAU).abs() > 1e-6 {
        return Err(err(
            ".points",
            format!(
                "the polygon winds {:.0} times around: it crosses itself (points out of order?)",
                turning.abs() / std::f64::consts::TAU
            ),
        ));
    }
    Ok(())
}

/// The one conversion from parry's (glam) mass properties.
fn from_parry(mp: &MassProperties) -> PlanarInertia {
    PlanarInertia::new(mp.mass(), Vec2::new(mp.local_com.x, mp.local_com.y), mp.principal_inertia())
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use std::f64::consts::PI;

    #[test]
    fn parry_disc_has_the_textbook_moment() {
        // Area πr², polar moment πr⁴/2 about the centre; 1e-14 covers parry storing 1/m.
        let u = ShapeSpec::Disc { radius: 0.3 }.unit_properties().unwrap();
        assert_abs_diff_eq!(u.mass, PI * 0.09, epsilon = 1e-14);
        assert_abs_diff_eq!(u.i_com, PI * 0.3f64.powi(4) / 2.0, epsilon = 1e-14);
    }

    #[test]
    fn pentagram_is_rejected_as_self_intersecting() {
        let pts: Vec<(f64, f64)> = (0..5)
            .map(|k| {
                let a = 2.0 * PI * (2 * k) as f64 / 5.0;
                (a.cos(), a.sin())
            })
            .collect();
        let e = ShapeSpec::ConvexPolygon { points: pts }.validate().unwrap_err();
        assert_eq!(e.field, ".points");
        assert!(e.message.contains("crosses itself"), "{e}");
    }
}

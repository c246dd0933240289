//! Body specifications (the RON form) and resolved bodies.

use crate::error::Result;
use crate::io::Source;
use crate::model::inertia::PlanarInertia;
use crate::model::math::Vec2;
use crate::model::shape::ShapeSpec;
use serde::{Deserialize, Serialize};

/// A body as written in a mechanism or catalog file.
///
/// A body's frame has its origin at its inboard joint point. Its mass properties come from
/// exactly one of two sources:
/// - **directly**: `mass` in kg, `com` in m in the body frame, `inertia` the centroidal moment in
///   kg·m² (`inertia` may be left out for a point mass, `com` for a centre of mass on the joint);
/// - **from a shape** ([`ShapeSpec`], placed with its origin on the body origin) and a density,
///   either `areal_density` (kg/m²) or `density` (kg/m³) with `thickness` (m).
///
/// Mixing the two (say `shape` with `mass` or `com`) is an error rather than an override, so that
/// a number never silently disagrees with the geometry it sits next to. To put a shape off the
/// joint, place it inside a `Compound`:
/// ```ron
/// Body(name: "bob", shape: Compound(parts: [Placed(shape: Disc(radius: 0.05), at: (0.3, 0.0))]),
///      density: 7850.0, thickness: 0.02)
/// ```
/// With `part`, the fields of the catalog file are taken first and the fields given here override
/// them one by one (a use can change the `density` of a shaped part, but not add a `mass` to it).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Body", deny_unknown_fields)]
pub struct BodySpec {
    /// Unique name (required once catalog parts are merged).
    pub name: Option<String>,
    /// Catalog file to start from, relative to the file that names it.
    pub part: Option<String>,
    /// Mass, kg.
    pub mass: Option<f64>,
    /// Centre of mass in the body frame, m (default at the origin, i.e. on the inboard joint).
    pub com: Option<(f64, f64)>,
    /// Centroidal moment of inertia about z, kg·m² (default 0: a point mass).
    pub inertia: Option<f64>,
    /// Shape in the body frame, for mass properties from a density instead of the three above.
    pub shape: Option<ShapeSpec>,
    /// Mass per unit area of the shape, kg/m² (instead of `density` and `thickness`).
    pub areal_density: Option<f64>,
    /// Mass per unit volume of the shape's material, kg/m³ (with `thickness`; steel ≈ 7850).
    pub density: Option<f64>,
    /// Uniform thickness of the shape out of the plane, m (with `density`).
    pub thickness: Option<f64>,
}

/// Names of the fields that give mass properties directly, with whether each is set.
fn direct_fields(b: &BodySpec) -> [(&'static str, bool); 3] {
    [("mass", b.mass.is_some()), ("com", b.com.is_some()), ("inertia", b.inertia.is_some())]
}

impl BodySpec {
    /// Fields of `over` replace those of `self` (catalog part ← per-use overrides).
    pub fn merged(&self, over: &BodySpec) -> BodySpec {
        BodySpec {
            name: over.name.clone().or_else(|| self.name.clone()),
            part: None,
            mass: over.mass.or(self.mass),
            com: over.com.or(self.com),
            inertia: over.inertia.or(self.inertia),
            shape: over.shape.clone().or_else(|| self.shape.clone()),
            areal_density: over.areal_density.or(self.areal_density),
            density: over.density.or(self.density),
            thickness: over.thickness.or(self.thickness),
        }
    }

    /// Checks the numbers given in this spec (before merging), naming the field at `path`.
    pub fn check_numbers(&self, src: &Source, path: &str) -> Result<()> {
        if let Some(m) = self.mass {
            if !m.is_finite() {
                return Err(src.error(&format!("{path}.mass"), format!("mass must be a finite number, got {m}")));
            }
            if m < 0.0 {
                return Err(src.error(&format!("{path}.mass"), format!("negative mass {m} kg")));
            }
        }
        if let Some(i) = self.inertia {
            if !i.is_finite() {
                return Err(src.error(&format!("{path}.inertia"), format!("inertia must be a finite number, got {i}")));
            }
            if i < 0.0 {
                return Err(src.error(&format!("{path}.inertia"), format!("negative moment of inertia {i} kg·m²")));
            }
        }
        if let Some((x, y)) = self.com
            && !(x.is_finite() && y.is_finite())
        {
            return Err(src.error(&format!("{path}.com"), "centre of mass must be finite"));
        }
        for (field, value, what) in [
            ("areal_density", self.areal_density, "areal density (kg/m²)"),
            ("density", self.density, "density (kg/m³)"),
        ] {
            if let Some(v) = value
                && !(v.is_finite() && v >= 0.0)
            {
                return Err(
                    src.error(&format!("{path}.{field}"), format!("{what} must be finite and non-negative, got {v}"))
                );
            }
        }
        if let Some(t) = self.thickness
            && !(t.is_finite() && t > 0.0)
        {
            return Err(
                src.error(&format!("{path}.thickness"), format!("thickness must be a positive number of m, got {t}"))
            );
        }
        if let Some(shape) = &self.shape {
            shape.validate().map_err(|e| src.error(&format!("{path}.shape{}", e.field), e.message))?;
        }
        self.check_conflicts(src, path)
    }

    /// Fields that can never go together, whatever a merge adds: a shape with direct mass
    /// properties, and the two density forms.
    fn check_conflicts(&self, src: &Source, path: &str) -> Result<()> {
        if self.shape.is_some() {
            for (field, set) in direct_fields(self) {
                if set {
                    return Err(src.error(
                        &format!("{path}.{field}"),
                        format!(
                            "`{field}` cannot be given with `shape`: a body takes its mass properties either \
                             directly (mass, com, inertia) or from a shape with a density"
                        ),
                    ));
                }
            }
        }
        if self.areal_density.is_some() {
            for (field, set) in [("density", self.density.is_some()), ("thickness", self.thickness.is_some())] {
                if set {
                    return Err(src.error(
                        &format!("{path}.{field}"),
                        format!(
                            "`{field}` cannot be given with `areal_density`: give kg/m², or kg/m³ with a thickness"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The mass properties of a merged spec, checking that the source of mass properties is
    /// complete and unambiguous (`src` and `path` locate the body for messages).
    pub fn inertia_props(&self, src: &Source, path: &str) -> Result<PlanarInertia> {
        self.check_conflicts(src, path)?;
        let Some(shape) = &self.shape else {
            for (field, value) in
                [("areal_density", self.areal_density), ("density", self.density), ("thickness", self.thickness)]
            {
                if value.is_some() {
                    return Err(
                        src.error(&format!("{path}.{field}"), format!("`{field}` is given but there is no `shape`"))
                    );
                }
            }
            let com = self.com.map_or(Vec2::zeros(), |(x, y)| Vec2::new(x, y));
            let props = PlanarInertia::new(self.mass.unwrap_or(0.0), com, self.inertia.unwrap_or(0.0));
            if !finite_props(&props) {
                return Err(src.error(
                    &format!("{path}.com"),
                    format!(
                        "the moment of inertia about the joint, inertia + mass·|com|² = {:e} + {:e}·{:e} kg·m², \
                         overflows; are the units kg and m?",
                        props.i_com,
                        props.mass,
                        com.norm_squared()
                    ),
                ));
            }
            return Ok(props);
        };
        let areal_density = match (self.areal_density, self.density, self.thickness) {
            (Some(a), None, None) => a,
            (None, Some(rho), Some(t)) if !(rho * t).is_finite() => {
                return Err(src.error(
                    &format!("{path}.density"),
                    format!("density × thickness = {rho:e} kg/m³ × {t:e} m overflows; are the units kg/m³ and m?"),
                ));
            }
            (None, Some(rho), Some(t)) => rho * t,
            (None, Some(_), None) => {
                return Err(src.error(&format!("{path}.density"), "`density` (kg/m³) needs a `thickness` (m)"));
            }
            (None, None, Some(_)) => {
                return Err(src.error(&format!("{path}.thickness"), "`thickness` (m) needs a `density` (kg/m³)"));
            }
            (None, None, None) => {
                return Err(src.error(
                    &format!("{path}.shape"),
                    "a shape needs a density: `areal_density` (kg/m²), or `density` (kg/m³) and `thickness` (m)",
                ));
            }
            // check_conflicts has ruled out areal_density with either of the others.
            _ => return Err(src.error(path, "internal: density forms not exclusive")),
        };
        let props = shape
            .mass_properties(areal_density)
            .map_err(|e| src.error(&format!("{path}.shape{}", e.field), e.message))?;
        if !finite_props(&props) {
            // Each size and the density is finite on its own (checked above); their product is
            // not. Name the shape when its own area or moment overflows, else the density.
            let unit_finite = shape.unit_properties().is_ok_and(|u| finite_props(&u));
            let field = match (unit_finite, self.areal_density.is_some()) {
                (false, _) => "shape",
                (true, true) => "areal_density",
                (true, false) => "density",
            };
            return Err(src.error(
                &format!("{path}.{field}"),
                format!(
                    "mass properties overflow: mass {:e} kg, centre of mass ({:e}, {:e}) m, centroidal inertia {:e} \
                     kg·m² (areal density {areal_density:e} kg/m²); are the sizes in m and the density in kg/m² or kg/m³?",
                    props.mass, props.com.x, props.com.y, props.i_com
                ),
            ));
        }
        Ok(props)
    }
}

/// Whether mass, centre of mass, centroidal inertia and the inertia about the body origin (the
/// inboard joint, which is what enters the mass matrix) are all finite.
fn finite_props(p: &PlanarInertia) -> bool {
    [p.mass, p.com.x, p.com.y, p.i_com, p.about(Vec2::zeros())].iter().all(|v| v.is_finite())
}

/// A resolved body of a mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Unique name.
    pub name: String,
    /// Mass properties in the body frame.
    pub inertia: PlanarInertia,
}

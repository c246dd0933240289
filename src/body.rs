//! Body specifications (the RON form) and resolved bodies.

use crate::error::Result;
use crate::inertia::PlanarInertia;
use crate::io::Source;
use crate::math::Vec2;
use serde::{Deserialize, Serialize};

/// A body as written in a mechanism or catalog file.
///
/// Give the mass properties directly (`mass` in kg, `com` in m in the body frame, `inertia` the
/// centroidal moment in kg·m²; `inertia` may be left out for a point mass). A body's frame has its
/// origin at its inboard joint point. With `part`, the fields of the catalog file are taken first
/// and the fields given here override them.
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
        Ok(())
    }

    /// The mass properties of a merged spec.
    pub fn inertia_props(&self) -> PlanarInertia {
        let com = self.com.map_or(Vec2::zeros(), |(x, y)| Vec2::new(x, y));
        PlanarInertia::new(self.mass.unwrap_or(0.0), com, self.inertia.unwrap_or(0.0))
    }
}

/// A resolved body of a mechanism.
#[derive(Debug, Clone, PartialEq)]
pub struct Body {
    /// Unique name.
    pub name: String,
    /// Mass properties in the body frame.
    pub inertia: PlanarInertia,
}

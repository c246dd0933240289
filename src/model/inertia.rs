//! Planar rigid-body inertia as a value type that names its reference point.

use crate::model::math::Vec2;
use std::ops::{Add, Sub};

/// Mass properties of a planar body: mass (kg), centre of mass `com` (m, in the body's frame) and
/// the moment of inertia about the centre of mass `i_com` (kg·m², about the z axis).
///
/// # Common mistake
/// `i_com` is about the centre of mass, not about the body's origin: use [`PlanarInertia::about`]
/// for the moment about another point (parallel-axis theorem).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlanarInertia {
    /// Mass in kg.
    pub mass: f64,
    /// Centre of mass in the body frame, m.
    pub com: Vec2,
    /// Centroidal moment of inertia about z, kg·m².
    pub i_com: f64,
}

impl PlanarInertia {
    /// Mass properties from mass (kg), centre of mass (m) and centroidal inertia (kg·m²).
    pub fn new(mass: f64, com: Vec2, i_com: f64) -> Self {
        Self { mass, com, i_com }
    }

    /// A point mass (zero centroidal inertia) at `com`.
    pub fn point(mass: f64, com: Vec2) -> Self {
        Self::new(mass, com, 0.0)
    }

    /// The zero inertia (neutral element of `+`).
    pub fn zero() -> Self {
        Self::new(0.0, Vec2::zeros(), 0.0)
    }

    /// Moment of inertia about `point` (body frame), kg·m²: `i_com + m·|com − point|²`.
    pub fn about(&self, point: Vec2) -> f64 {
        self.i_com + self.mass * (self.com - point).norm_squared()
    }

    /// The same body with its frame moved so that the old frame's `offset` becomes the origin and
    /// rotated by `angle` (rad): used when a part is placed inside a compound body.
    pub fn placed(&self, offset: Vec2, angle: f64) -> Self {
        Self::new(self.mass, offset + crate::model::math::rot2(angle) * self.com, self.i_com)
    }
}

impl Add for PlanarInertia {
    type Output = PlanarInertia;
    /// Combines two bodies rigidly joined (both given in the same frame).
    fn add(self, o: PlanarInertia) -> PlanarInertia {
        let mass = self.mass + o.mass;
        if mass == 0.0 {
            return PlanarInertia::new(0.0, Vec2::zeros(), self.i_com + o.i_com);
        }
        let com = (self.com * self.mass + o.com * o.mass) / mass;
        let i_com = self.about(com) + o.about(com);
        PlanarInertia::new(mass, com, i_com)
    }
}

impl Sub for PlanarInertia {
    type Output = PlanarInertia;
    /// Removes `o` from `self` (a hole: an annulus is a disc minus a disc).
    fn sub(self, o: PlanarInertia) -> PlanarInertia {
        let mass = self.mass - o.mass;
        if mass == 0.0 {
            return PlanarInertia::new(0.0, Vec2::zeros(), self.i_com - o.i_com);
        }
        let com = (self.com * self.mass - o.com * o.mass) / mass;
        // Moments about a common point subtract; then shift back to the new centre of mass.
        let i_o = self.about(Vec2::zeros()) - o.about(Vec2::zeros());
        let i_com = i_o - mass * com.norm_squared();
        PlanarInertia::new(mass, com, i_com)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn add_is_commutative_and_sub_inverts_add() {
        let a = PlanarInertia::new(2.0, Vec2::new(0.1, 0.2), 0.03);
        let b = PlanarInertia::new(0.5, Vec2::new(-0.4, 0.0), 0.001);
        let ab = a + b;
        let ba = b + a;
        assert_abs_diff_eq!(ab.mass, ba.mass, epsilon = 1e-15);
        assert!((ab.com - ba.com).norm() < 1e-15);
        assert_abs_diff_eq!(ab.i_com, ba.i_com, epsilon = 1e-15);
        let back = ab - b;
        assert_abs_diff_eq!(back.mass, a.mass, epsilon = 1e-14);
        assert!((back.com - a.com).norm() < 1e-14);
        assert_abs_diff_eq!(back.i_com, a.i_com, epsilon = 1e-14);
    }

    #[test]
    fn two_point_masses_give_dumbbell_inertia() {
        // Two 1 kg points 2 m apart: i_com = 2 · 1 · 1² = 2 kg·m² about the midpoint.
        let s = PlanarInertia::point(1.0, Vec2::new(-1.0, 0.0)) + PlanarInertia::point(1.0, Vec2::new(1.0, 0.0));
        assert_eq!(s.com, Vec2::zeros());
        assert_abs_diff_eq!(s.i_com, 2.0, epsilon = 1e-15);
    }
}

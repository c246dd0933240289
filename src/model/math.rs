//! Planar vector aliases and the four helpers the kinematic formulas of kanedyn use: `rot2`,
//! `perp`, `cross2` and `rotate_cs`.
//!
//! Convention: z points out of the plane, angles are counter-clockwise positive, in rad.

/// A planar vector (m, m/s, N, … as the context says).
pub type Vec2 = nalgebra::Vector2<f64>;
/// A 2×2 matrix (rotations).
pub type Mat2 = nalgebra::Matrix2<f64>;

/// Rotation matrix of angle `theta` (rad): maps body-frame components to parent-frame components.
#[inline]
pub fn rot2(theta: f64) -> Mat2 {
    let (s, c) = theta.sin_cos();
    Mat2::new(c, -s, s, c)
}

/// `ẑ × v`: the vector `v` turned by +90°. The velocity of a point at offset `v` from a pivot on a
/// body spinning at ω is `ω · perp(v)`.
#[inline]
pub fn perp(v: Vec2) -> Vec2 {
    Vec2::new(-v.y, v.x)
}

/// The z component of `a × b` (a scalar in the plane): the moment of force `b` at lever arm `a`.
#[inline]
pub fn cross2(a: Vec2, b: Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Rotates `v` by the angle whose cosine and sine are `c`, `s` (avoids re-evaluating trig when a
/// pose is composed from already known sines and cosines).
#[inline]
pub fn rotate_cs(c: f64, s: f64, v: Vec2) -> Vec2 {
    Vec2::new(c * v.x - s * v.y, s * v.x + c * v.y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perp_is_quarter_turn() {
        let v = Vec2::new(0.3, -1.2);
        let r = rot2(std::f64::consts::FRAC_PI_2) * v;
        assert!((perp(v) - r).norm() < 1e-15);
        assert_eq!(cross2(Vec2::x(), Vec2::y()), 1.0);
        let (s, c) = 0.7f64.sin_cos();
        assert!((rotate_cs(c, s, v) - rot2(0.7) * v).norm() < 1e-15);
    }
}

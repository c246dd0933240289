//! The rotor with centrifugal pendulum vibration absorbers (paper, Fig. 1): parameters, the
//! closed-form equations of motion (eq. 7, generalized to N synchronous pendulums), the tuning
//! order n_t (eq. 15), the inertia ratio Ĩ (eq. 18), the rotor eigen-order n_r (eq. 17), and a
//! builder that makes the same system a generic [`Mechanism`].
//!
//! Geometry (docs/design/conventions.md): the rotor spins about ground point O (coordinate θ); pendulum i pivots at
//! Q_i on the rotor at radius R and angle ψ_i = 2πi/N; its centre of mass lies at distance L from
//! Q_i on the radial line when φ_i = 0. With N pendulums the mass, inertia and damping of the
//! single pendulum of the paper are split evenly, so N synchronous pendulums act as one.

use crate::error::Result;
use crate::model::body::BodySpec;
use crate::model::excitation::Excitation;
use crate::model::joint::{JointKind, JointSpec};
use crate::model::loads::LoadSpec;
use crate::model::mechanism::{GROUND, Mechanism, MechanismSpec};
use crate::model::speeds::Speeds;
use nalgebra::{DMatrix, DVector};
use std::f64::consts::PI;

/// Tuning order of a compound pendulum, eq. (15): `n_t² = m R L / (I_B + m L²)`.
pub fn tuning_order(mass: f64, r: f64, l: f64, i_b: f64) -> f64 {
    (mass * r * l / (i_b + mass * l * l)).sqrt()
}

/// Inertia ratio, eq. (18): `Ĩ = (I_A + m R²) / (I_B + m L²)`.
pub fn inertia_ratio(i_a: f64, mass: f64, r: f64, i_b: f64, l: f64) -> f64 {
    (i_a + mass * r * r) / (i_b + mass * l * l)
}

/// Rotor eigen-order, eq. (17): `n_r² = n_t² (Ĩ + 2n_t² + 1) / (Ĩ − n_t⁴)`.
pub fn rotor_order(n_t: f64, i_tilde: f64) -> f64 {
    let nt2 = n_t * n_t;
    (nt2 * (i_tilde + 2.0 * nt2 + 1.0) / (i_tilde - nt2 * nt2)).sqrt()
}

/// Parameters of a rotor-CPVA. Ĩ and n_t are the design inputs (Table 2 of the paper); the
/// geometry follows from R and k (see [`CpvaParams::l`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CpvaParams {
    /// Pivot radius R, m.
    pub pivot_radius: f64,
    /// Pendulum radius of gyration k (I_B = m_p k²), m.
    pub gyration_radius: f64,
    /// Total pendulum mass m_p, kg (split over the pendulums).
    pub pendulum_mass: f64,
    /// Inertia ratio Ĩ, eq. (18).
    pub i_tilde: f64,
    /// Linear tuning order n_t, eq. (15).
    pub n_t: f64,
    /// Total pendulum pivot damping c_p, N·m·s/rad (split over the pendulums).
    pub c_p: f64,
    /// Rotor viscous loss c_r to ground, N·m·s/rad.
    pub c_r: f64,
    /// Number of pendulums N ≥ 1, at angles 2πi/N.
    pub n_pendulums: usize,
    /// Rotor mass, kg (irrelevant to the dynamics without gravity: its centre is on the axis).
    pub rotor_mass: f64,
}

impl CpvaParams {
    /// kanedyn's canonical parameters (docs/design/conventions.md): Table 2 of the paper plus R = 0.17 m and
    /// k = 6 mm, one pendulum.
    pub fn canonical() -> Self {
        Self {
            pivot_radius: 0.17,
            gyration_radius: 0.006,
            pendulum_mass: 6.0,
            i_tilde: 2255.0,
            n_t: 3.11,
            c_p: 5e-4,
            c_r: 5e-3,
            n_pendulums: 1,
            rotor_mass: 110.0,
        }
    }

    /// The same with N pendulums.
    pub fn with_pendulums(self, n: usize) -> Self {
        Self { n_pendulums: n, ..self }
    }

    /// Pivot-to-centre-of-mass distance L, m: the larger root of `n_t² L² − R L + n_t² k² = 0`,
    /// which is eq. (15) with I_B = m k² solved for L.
    pub fn l(&self) -> f64 {
        let (r, k, nt2) = (self.pivot_radius, self.gyration_radius, self.n_t * self.n_t);
        (r + (r * r - 4.0 * nt2 * nt2 * k * k).sqrt()) / (2.0 * nt2)
    }

    /// Total pendulum centroidal inertia I_B = m_p k², kg·m².
    pub fn i_b(&self) -> f64 {
        self.pendulum_mass * self.gyration_radius * self.gyration_radius
    }

    /// Pendulum inertia about its pivot J_B = I_B + m_p L², kg·m².
    pub fn j_b(&self) -> f64 {
        self.i_b() + self.pendulum_mass * self.l().powi(2)
    }

    /// Rotor centroidal inertia I_A = Ĩ J_B − m_p R², kg·m².
    pub fn i_a(&self) -> f64 {
        self.i_tilde * self.j_b() - self.pendulum_mass * self.pivot_radius.powi(2)
    }

    /// Inertia of the rotor with its pendulums locked at φ = 0, `I_A + I_B + m_p (R + L)²`, kg·m².
    pub fn locked_inertia(&self) -> f64 {
        self.i_a() + self.i_b() + self.pendulum_mass * (self.pivot_radius + self.l()).powi(2)
    }

    /// Rotor eigen-order n_r, eq. (17).
    pub fn n_r(&self) -> f64 {
        rotor_order(self.n_t, self.i_tilde)
    }

    /// Angle ψ_i of pendulum i's pivot in the rotor frame, rad.
    pub fn pivot_angle(&self, i: usize) -> f64 {
        2.0 * PI * i as f64 / self.n_pendulums as f64
    }

    /// Pendulum body name: `pendulum` for one, `pendulum_1`… otherwise.
    pub fn pendulum_name(&self, i: usize) -> String {
        if self.n_pendulums == 1 { "pendulum".into() } else { format!("pendulum_{}", i + 1) }
    }

    /// Pivot joint name: `pivot` for one, `pivot_1`… otherwise.
    pub fn pivot_name(&self, i: usize) -> String {
        if self.n_pendulums == 1 { "pivot".into() } else { format!("pivot_{}", i + 1) }
    }

    /// The generic mechanism spec (absolute angular velocities as speeds, as in the paper),
    /// with the rotor torque `excitation` on joint `spin` if given.
    pub fn spec(&self, excitation: Option<Excitation>) -> MechanismSpec {
        let n = self.n_pendulums as f64;
        let (r, l) = (self.pivot_radius, self.l());
        let mut bodies = vec![BodySpec {
            name: Some("rotor".into()),
            mass: Some(self.rotor_mass),
            inertia: Some(self.i_a()),
            ..BodySpec::default()
        }];
        let mut joints = vec![JointSpec {
            name: Some("spin".into()),
            kind: Some(JointKind::Revolute),
            parent: Some(GROUND.into()),
            child: Some("rotor".into()),
            ..JointSpec::default()
        }];
        for i in 0..self.n_pendulums {
            let (s, c) = self.pivot_angle(i).sin_cos();
            bodies.push(BodySpec {
                name: Some(self.pendulum_name(i)),
                mass: Some(self.pendulum_mass / n),
                com: Some((l * c, l * s)),
                inertia: Some(self.i_b() / n),
                ..BodySpec::default()
            });
            joints.push(JointSpec {
                name: Some(self.pivot_name(i)),
                kind: Some(JointKind::Revolute),
                parent: Some("rotor".into()),
                child: Some(self.pendulum_name(i)),
                at: Some((r * c, r * s)),
                damper: Some(self.c_p / n),
                ..JointSpec::default()
            });
        }
        let mut loads = vec![LoadSpec::GroundDamper { body: "rotor".into(), c: self.c_r }];
        if let Some(excitation) = excitation {
            loads.push(LoadSpec::JointTorque { joint: "spin".into(), excitation });
        }
        MechanismSpec {
            base: None,
            name: format!("cpva{}", if self.n_pendulums == 1 { String::new() } else { self.n_pendulums.to_string() }),
            speeds: Speeds::AbsoluteAngularVelocities,
            gravity: (0.0, 0.0),
            bodies,
            joints,
            loads,
            gears: Vec::new(),
        }
    }

    /// The generic mechanism (validated like a file).
    pub fn mechanism(&self, excitation: Option<Excitation>) -> Result<Mechanism> {
        Mechanism::from_spec(&self.spec(excitation))
    }

    /// The closed-form model of these parameters.
    pub fn closed_form(&self) -> ClosedForm {
        let n = self.n_pendulums as f64;
        let m = self.pendulum_mass / n;
        ClosedForm {
            n: self.n_pendulums,
            a: self.i_a() + self.pendulum_mass * self.pivot_radius.powi(2),
            b: m * self.pivot_radius * self.l(),
            c: self.i_b() / n + m * self.l().powi(2),
            c_p: self.c_p / n,
            c_r: self.c_r,
        }
    }
}

/// Eq. (7) for N pendulums, with speeds `u = [u1, u2…]` (rotor and absolute pendulum angular
/// velocities) and coordinates `q = [θ, φ_1…]`:
///
/// `a u̇1 + Σ b cos φ_i u̇_i − Σ b u_i² sin φ_i = Σ c_p(u_i − u1) + T_o − c_r u1`,
/// `c u̇_i + b cos φ_i u̇1 + b u1² sin φ_i = −c_p(u_i − u1)`,
///
/// with `a = I_A + m_p R²`, and per pendulum `b = m R L`, `c = I_B/N + m L²`, m = m_p/N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClosedForm {
    /// Number of pendulums.
    pub n: usize,
    /// `I_A + m_p R²`, kg·m².
    pub a: f64,
    /// `m R L` per pendulum, kg·m².
    pub b: f64,
    /// `I_B/N + m L²` per pendulum, kg·m².
    pub c: f64,
    /// Pivot damping per pendulum, N·m·s/rad.
    pub c_p: f64,
    /// Rotor damping, N·m·s/rad.
    pub c_r: f64,
}

impl ClosedForm {
    /// M and F of eq. (7) at coordinates q, speeds u and rotor torque `torque` (N·m). Allocates.
    pub fn mass_matrix_and_forcing(&self, q: &[f64], u: &[f64], torque: f64) -> (DMatrix<f64>, DVector<f64>) {
        let dim = self.n + 1;
        let mut m = DMatrix::zeros(dim, dim);
        let mut f = DVector::zeros(dim);
        m[(0, 0)] = self.a;
        f[0] = torque - self.c_r * u[0];
        for i in 1..dim {
            let (s, c) = q[i].sin_cos();
            m[(0, i)] = self.b * c;
            m[(i, 0)] = self.b * c;
            m[(i, i)] = self.c;
            let damp = self.c_p * (u[i] - u[0]);
            f[0] += self.b * u[i] * u[i] * s + damp;
            f[i] = -self.b * u[0] * u[0] * s - damp;
        }
        (m, f)
    }

    /// Hand-written right-hand side for one pendulum, `x = [θ, φ, u1, u2]`, by Cramer's rule on
    /// the 2×2 system: the baseline the generic engine is benchmarked against. No allocation.
    #[inline]
    pub fn rhs1(&self, torque: f64, x: &[f64], xdot: &mut [f64]) {
        let (s, c) = x[1].sin_cos();
        let (u1, u2) = (x[2], x[3]);
        let damp = self.c_p * (u2 - u1);
        let f1 = self.b * u2 * u2 * s + damp + torque - self.c_r * u1;
        let f2 = -self.b * u1 * u1 * s - damp;
        let m12 = self.b * c;
        let det = self.a * self.c - m12 * m12;
        xdot[0] = u1;
        xdot[1] = u2 - u1;
        xdot[2] = (self.c * f1 - m12 * f2) / det;
        xdot[3] = (self.a * f2 - m12 * f1) / det;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;

    #[test]
    fn canonical_values_match_design_table() {
        let p = CpvaParams::canonical();
        assert_abs_diff_eq!(p.l(), 0.0152093650768, epsilon = 1e-12);
        assert_abs_diff_eq!(p.i_b(), 2.16e-4, epsilon = 1e-15);
        assert_abs_diff_eq!(p.i_a(), 3.44350435513, epsilon = 1e-10);
        assert_abs_diff_eq!(p.j_b(), 1.60394871624e-3, epsilon = 1e-14);
        assert_abs_diff_eq!(p.locked_inertia(), 3.6495354086, epsilon = 1e-9);
        assert_abs_diff_eq!(p.n_r(), 3.19088605122, epsilon = 1e-10);
    }
}

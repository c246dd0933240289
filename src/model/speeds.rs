//! Generalized speeds `u = W(q) q̇`.
//!
//! Both choices offered have a constant, lower-triangular W (so `q̈ = W⁻¹ u̇` and the bias
//! accelerations need no `d(W⁻¹)/dt` term):
//! - `JointRates`: u = q̇ (W = I);
//! - `AbsoluteAngularVelocities`: u_i is the absolute angular velocity of joint i's child body,
//!   `u_i = u_parent(i) + q̇_i` — the paper's choice `u1 = θ̇, u2 = θ̇ + φ̇` (eqs. 8 and 26).

use serde::{Deserialize, Serialize};

/// The choice of generalized speeds of a mechanism.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Speeds {
    /// u = q̇: the joint rates.
    #[default]
    JointRates,
    /// u_i = absolute angular velocity of body i (rad/s).
    AbsoluteAngularVelocities,
}

impl Speeds {
    /// `q̇ = W⁻¹ u` for a revolute tree with `parent[i] < i` (None = ground).
    #[inline]
    pub fn qdot(self, parent: &[Option<usize>], u: &[f64], qdot: &mut [f64]) {
        match self {
            Speeds::JointRates => qdot.copy_from_slice(u),
            Speeds::AbsoluteAngularVelocities => {
                for i in 0..u.len() {
                    qdot[i] = u[i] - parent[i].map_or(0.0, |p| u[p]);
                }
            }
        }
    }

    /// `u = W q̇`.
    pub fn u_from_qdot(self, parent: &[Option<usize>], qdot: &[f64], u: &mut [f64]) {
        match self {
            Speeds::JointRates => u.copy_from_slice(qdot),
            Speeds::AbsoluteAngularVelocities => {
                // Parents come first, so their absolute rates are ready.
                for i in 0..qdot.len() {
                    u[i] = qdot[i] + parent[i].map_or(0.0, |p| u[p]);
                }
            }
        }
    }

    /// The matrix `W⁻¹` (n×n) of `q̇ = W⁻¹ u`, exact: the identity for joint rates; for absolute
    /// angular velocities ones on the diagonal and `−1` at (k, p) for each speed parent p of k.
    pub fn w_inverse_matrix(self, parent: &[Option<usize>]) -> nalgebra::DMatrix<f64> {
        let n = parent.len();
        let mut b = nalgebra::DMatrix::identity(n, n);
        if self == Speeds::AbsoluteAngularVelocities {
            for (k, p) in parent.iter().enumerate() {
                if let Some(p) = *p {
                    b[(k, p)] = -1.0;
                }
            }
        }
        b
    }

    /// The matrix W (n×n), for tests and reports.
    pub fn w_matrix(self, parent: &[Option<usize>]) -> nalgebra::DMatrix<f64> {
        let n = parent.len();
        let mut w = nalgebra::DMatrix::zeros(n, n);
        let mut e = vec![0.0; n];
        let mut col = vec![0.0; n];
        for k in 0..n {
            e.iter_mut().for_each(|x| *x = 0.0);
            e[k] = 1.0;
            self.u_from_qdot(parent, &e, &mut col);
            w.set_column(k, &nalgebra::DVector::from_column_slice(&col));
        }
        w
    }
}

//! The pair form of a rotor carrying one path absorber about its axis, in fixed size: the
//! commonest tree of issue 14 (the paper's rotor with one absorber on an epicycloid or a circle).
//!
//! The equations of motion are written directly in the rotor frame from the path's
//! rotation-invariant quantities (|r|², r·t, r × t, r × κ; [`PolarPath`]): a pair form with
//! s-dependent coefficients that needs neither the path's polar angle (the epicycloid's `asin` and
//! `sin_cos`) nor the LDLᵀ's two serial divisions ([`Model::rhs_path_pair`]). It equals the
//! fixed-size composite-body form of [`super::small_rates`] to rounding
//! (`tests/it/path_pair_form.rs`), hands every failure to it, and is chosen only after
//! reproducing it at probe states ([`pair_agrees`]).

use super::small_rates::{Install, Packed, PathPair};
use super::{Kane, Model, NONE, PIVOT_TOL, SmallRhs};
use crate::error::EngineError;
use crate::model::joint::PathJoint;
use crate::model::math::Vec2;
use std::sync::Arc;

/// The pair form's constants when `kane` is a rotor carrying one path absorber (see [`PathPair`]).
pub(super) fn path_pair(kane: &Model, p: &Packed) -> Option<PathPair> {
    let nodes = &kane.nodes;
    // No speed is mapped (`speed_parent`), so the same equations serve absolute speeds and joint
    // rates.
    if kane.n != 2 || nodes.len() != 2 || !p.basis[0] || p.parent[1] != 0 || kane.gravity != Vec2::zeros() {
        return None;
    }
    let (r, a) = (&nodes[0], &nodes[1]);
    let PathJoint { shape, travel, .. } = a.kind.path()?;
    // The path must be drawn about the rotor axis and carry the centre of mass: then every
    // quantity is rotation-invariant (the mount angle drops out with θ(s)).
    if a.at != Vec2::zeros() || a.com_local != Vec2::zeros() || p.speed_parent[..2] != [NONE, NONE] {
        return None;
    }
    Some(PathPair {
        path: shape.polar_path(),
        limit: travel.unwrap_or(f64::INFINITY),
        j_sum: r.j_own + a.i_com,
        mass: a.mass,
        i_com: a.i_com,
        k_spring: [r.k_spring, a.k_spring],
        q_free: [r.q_free, a.q_free],
        c_joint: [r.c_joint, a.c_joint],
        c_ground: [r.c_ground, a.c_ground],
    })
}

/// True when the pair form and the composite-body instance `rates` give the same ẋ at three
/// probe states spread over the path, with both speeds and the time non-zero: u̇₁ and ρ u̇₀ to
/// 1e-10 of the absorber's largest acceleration term (ω²ρ + 2|ωṡ| + ṡ²|κ|, or u̇ itself), far
/// above both forms' rounding (the general form's F₁ sums terms of that size, so a state whose
/// u̇ is nearly zero carries its rounding) and far below any physical term either could lack.
pub(super) fn pair_agrees(kane: &Model, packed: &Packed, rates: SmallRhs, install: &Install) -> bool {
    let Some(pair) = &packed.pair else { return false };
    let Some(PathJoint { shape, .. }) = kane.nodes[1].kind.path() else { return false };
    let reach = shape.length_scale().min(0.5 * shape.travel()).min(0.5 * pair.limit);
    let mut model = kane.clone();
    install(&mut model, rates, packed.clone());
    let mut probe = Kane::with_model(Arc::new(model));
    [(0.0, 0.37), (0.6, -0.9), (-0.95, 0.5)].iter().all(|&(f, g)| {
        let x = [0.3, f * reach, 20.0 + 40.0 * f, 20.0 * g * reach];
        let (mut general, mut fast) = ([0.0; 4], [0.0; 4]);
        let t = 0.123 + f;
        let ok = probe.rhs(t, &x, &mut general).is_ok() && probe.model.rhs_path_pair(t, &x, &mut fast).is_ok();
        let at = shape.at(x[1]);
        let (rho, kappa) = (at.position.norm(), at.curvature.norm());
        let accel = x[2] * x[2] * rho + 2.0 * (x[2] * x[3]).abs() + x[3] * x[3] * kappa;
        let scale = accel.max((rho * general[2]).abs()).max(general[3].abs());
        let off = (rho * (general[2] - fast[2])).abs().max((general[3] - fast[3]).abs());
        ok && general[..2] == fast[..2] && off <= 1e-10 * scale && fast[2].is_finite() && fast[3].is_finite()
    })
}

impl Model {
    /// [`Kane::rhs`](super::Kane::rhs) for a rotor carrying one path absorber ([`PathPair`]): the equations of
    /// motion written directly in the rotor's frame, a pair form with s-dependent coefficients.
    ///
    /// With ω the rotor's speed, ṡ the absorber's, r the absorber's centre from the axis, t the
    /// unit tangent, κ the curvature vector and α(s) the rotation law, the partial velocities are
    /// (1, ẑ × r) for ω and (α', t) for ṡ, and the velocity-product acceleration of the centre is
    /// `−ω² r + 2ωṡ ẑ × t + ṡ² κ`. Dotting (t ⊥ κ, t ⊥ ẑ × t, r ⊥ ẑ × r):
    ///
    /// ```text
    /// M₀₀ = J₀ + I + m ρ²     M₀₁ = I α' + m (r × t)     M₁₁ = I α'² + m
    /// F₀ = τ₀ − c₀ ω − c₁ Ω − I α'' ṡ² − m (2ωṡ (r·t) + ṡ² (r × κ))
    /// F₁ = τ₁ − α' (c₁ Ω + I α'' ṡ²) + m ω² (r·t),     Ω = ω + α' ṡ
    /// ```
    ///
    /// (c₀, c₁ the ground dampers, τ the joints' springs, dampers and torques.) Only the
    /// rotation-invariant |r|², r·t, r × t and r × κ enter ([`PolarPath::at`]), so the path's
    /// polar angle θ(s), the `asin` and `sin_cos` of the epicycloid, is never needed; the 2 × 2
    /// system is solved by Cramer's rule (one division, the LDLᵀ's two are serial). The results
    /// equal the composite-body form's to rounding (`tests/it/path_pair_form.rs`), not to the bit.
    /// Whenever the LDLᵀ's pivots (M₀₀ and det/M₀₀) would not both pass `factor_solve`'s test,
    /// or a result is not finite (beyond the end of the path), the call is handed to the
    /// composite-body form, which gives the error (or the result) it always gave.
    #[inline(never)]
    pub(super) fn rhs_path_pair(&self, t: f64, x: &[f64], xdot: &mut [f64]) -> Result<(), EngineError> {
        let packed = &self.small.as_ref().expect("the fixed-size path is chosen with its data").rates;
        let c = packed.pair.as_ref().expect("the pair form is chosen with its constants");
        let (theta, s, w, sd) = (x[0], x[1], x[2], x[3]);
        // The excitation's `sin` first: its chain (phase, `sin`, F, solve) is the longest here.
        let mut exc = [0.0; 2];
        for (j, exc) in exc.iter_mut().enumerate() {
            if packed.torque[j] != NONE {
                *exc = self.torques[packed.torque[j]].excitation.torque(t);
            }
        }
        let p = c.path.at(if s.abs() < c.limit { s } else { f64::NAN });
        let (m, i) = (c.mass, c.i_com);
        let (da, dda) = (p.dalpha, p.ddalpha);
        let spin = w + da * sd;
        let tau0 = -c.k_spring[0] * (theta - c.q_free[0]) - c.c_joint[0] * w + exc[0];
        let tau1 = -c.k_spring[1] * (s - c.q_free[1]) - c.c_joint[1] * sd + exc[1];
        let turn = i * dda * (sd * sd) + c.c_ground[1] * spin;
        let f0 = tau0 - c.c_ground[0] * w - turn - m * (2.0 * w * sd * p.r_dot_t + sd * sd * p.r_cross_k);
        let f1 = tau1 - da * turn + m * (w * w) * p.r_dot_t;
        let m00 = c.j_sum + m * p.rho_sq;
        let m01 = i * da + m * p.r_cross_t;
        let m11 = i * (da * da) + m;
        let det = m00 * m11 - m01 * m01;
        let inv = 1.0 / det;
        let ud0 = (m11 * f0 - m01 * f1) * inv;
        let ud1 = (m00 * f1 - m01 * f0) * inv;
        // `factor_solve`'s pivots are M₀₀ and det/M₀₀, against 1e-12 of the largest diagonal entry.
        let pivot_min = PIVOT_TOL * m00.abs().max(m11.abs());
        if !(m00 > pivot_min && det > pivot_min * m00 && ud0.is_finite() && ud1.is_finite()) {
            return self.rhs_small_rates::<2>(t, x, xdot);
        }
        xdot[..4].copy_from_slice(&[w, sd, ud0, ud1]);
        Ok(())
    }
}

/// The fixed-size joint-rates form of `kane`: the pair form where `kane` is a rotor carrying one
/// path absorber and the form reproduces the general one at probe states (a term the general
/// engine gains, and this form does not know, keeps the general form); else, unless
/// `pair_only` (joint rates as speeds, where only the pair form applies), the composite-body form
/// of [`super::small_rates`].
pub(super) fn choose(kane: &Model, pair_only: bool, install: &Install) -> Option<(SmallRhs, Packed)> {
    let (rhs, p) = super::small_rates::small(kane)?;
    if let Some(pair) = path_pair(kane, &p) {
        let mut with_pair = p.clone();
        with_pair.pair = Some(pair);
        if pair_agrees(kane, &with_pair, rhs, install) {
            return Some((Model::rhs_path_pair, with_pair));
        }
    }
    (!pair_only).then_some((rhs, p))
}

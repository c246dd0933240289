//! Driven runs: joint torques whose orders are locked to a crank joint's angle, and a joint whose
//! speed is prescribed, on top of Kane's equations `M(q) u̇ = F(q, u, t)`.
//!
//! An engine's excitation is periodic in crank angle, not in time: through a run-up its order
//! lines stay orders. A torque at joint j is therefore
//! `τ_j = T_m(t) + r(t) · Σ_k T_k sin(m_k · n · q_c + α_k)`, with `q_c` the crank joint's
//! coordinate (rad, unwrapped), n the base order, `m_k` the multiples, `T_m(t) = T_0 + Ṫ·t` a
//! mean torque that may ramp linearly (the feed-forward of a torque-driven run-up) and r the
//! cubic ramp-in of [`crate::model::excitation::Excitation::ramp`]. A torque on joint j's
//! coordinate c adds `τ_j · ∂q̇_c/∂u = τ_j · (W⁻¹)_{c,:}ᵀ` to F (Kane's generalized active force
//! for the speeds `u = W q̇`).
//!
//! A prescribed joint s follows `q̈_s = α` while `t < t_ramp` and `q̈_s = 0` afterwards (a linear
//! speed ramp, then a constant speed). W is constant, so in the joint rates the equations read
//! `A q̈ = G` with `A = WᵀMW` and `G = WᵀF`; row s is replaced by the prescribed `q̈_s` and the
//! remaining rows give `A_rr q̈_r = G_r − A_rs q̈_s` (the partitioned form of a rheonomic
//! constraint on one coordinate). The torque the drive exerts is `(A q̈ − G)_s`.
//!
//! An engine torque ([`EngineTorque`]) is crank-locked too, but its amplitudes and phases follow
//! the crank's rate q̇_c at each instant (the inertia part of the engine series scales with q̇_c²).

use crate::combustion::OscillatingSeries;
use crate::error::{EngineError, Result};
use crate::kane::Kane;
use crate::model::excitation::{Harmonic, ramp_in};
use crate::model::mechanism::Mechanism;
use nalgebra::{DMatrix, DVector};

/// A joint torque with orders locked to the crank's angle (see the module docs), N·m.
#[derive(Debug, Clone, PartialEq)]
pub struct LockedTorque {
    /// The joint it acts at (index in the mechanism), child against parent.
    pub joint: usize,
    /// Mean torque at t = 0, N·m.
    pub mean_nm: f64,
    /// Rate of change of the mean torque, N·m/s (0 for a constant mean).
    pub mean_slope_nm_s: f64,
    /// Time after which the mean torque stops changing, s.
    pub mean_until_s: f64,
    /// Base order n, cycles per crank revolution.
    pub order: f64,
    /// Harmonics of n: multiple m, amplitude T (N·m), phase α (rad).
    pub harmonics: Vec<Harmonic>,
    /// Ramp-in of the oscillating part, s (0: none).
    pub ramp_s: f64,
}

impl LockedTorque {
    /// The torque at time `t` with the crank at `crank_rad`, N·m.
    pub fn torque(&self, t: f64, crank_rad: f64) -> f64 {
        let mean = self.mean_nm + self.mean_slope_nm_s * t.clamp(0.0, self.mean_until_s.max(0.0));
        if self.harmonics.is_empty() {
            return mean;
        }
        let ramp = ramp_in(t, self.ramp_s);
        let phase = self.order * crank_rad;
        mean + ramp * self.harmonics.iter().map(|h| h.amplitude * (h.multiple * phase + h.phase).sin()).sum::<f64>()
    }
}

/// An engine's oscillating torque at a joint, `τ = scale · r(t) · T̃(q_c, q̇_c)`: the engine's
/// order series ([`OscillatingSeries`]) at the crank's angle and rate at that instant, every
/// harmonic led by `phase`, ramped in by r over `ramp_s`. Through a run-up its inertia part grows
/// with the square of the crank's speed as it does on a real engine.
#[derive(Debug, Clone, PartialEq)]
pub struct EngineTorque {
    /// The joint it acts at (index in the mechanism), child against parent.
    pub joint: usize,
    /// Share of the engine torque at this joint.
    pub scale: f64,
    /// Phase lead of every harmonic, rad.
    pub phase: f64,
    /// Ramp-in, s (0: none).
    pub ramp_s: f64,
    /// The engine's series.
    pub series: OscillatingSeries,
}

impl EngineTorque {
    /// The torque at time `t` with the crank at `crank_rad` turning at `crank_rate` (rad/s), N·m.
    pub fn torque(&self, t: f64, crank_rad: f64, crank_rate: f64) -> f64 {
        self.scale * ramp_in(t, self.ramp_s) * self.series.torque(crank_rad, crank_rate, self.phase)
    }
}

/// A joint whose rate is prescribed: `q̇ = ω_0 + α·min(t, t_ramp)` (a run-up or run-down of a
/// test-bench drive), its coordinate integrated from the initial state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prescribed {
    /// The joint (index in the mechanism).
    pub joint: usize,
    /// Its acceleration during the ramp, rad/s² (m/s² for a slide).
    pub accel: f64,
    /// End of the ramp, s.
    pub until_s: f64,
}

impl Prescribed {
    fn accel_at(&self, t: f64) -> f64 {
        if t < self.until_s { self.accel } else { 0.0 }
    }
}

/// A proportional speed governor on a joint: `τ = K·(ω_ref(t) − q̇)` with the reference
/// `ω_ref = ω_0 + α·min(t, t_ramp)`, added to the joint's torques.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Governor {
    /// The joint (index in the mechanism).
    pub joint: usize,
    /// Gain K, N·m·s/rad.
    pub gain: f64,
    /// Reference rate at t = 0, rad/s.
    pub rate0: f64,
    /// Reference acceleration during the ramp, rad/s².
    pub accel: f64,
    /// End of the ramp, s.
    pub until_s: f64,
}

impl Governor {
    fn torque(&self, t: f64, rate: f64) -> f64 {
        self.gain * (self.rate0 + self.accel * t.clamp(0.0, self.until_s.max(0.0)) - rate)
    }
}

/// Kane's equations with crank-locked joint torques and at most one prescribed joint: the
/// right-hand side of a driven run (see the module docs).
pub struct Drive {
    kane: Kane,
    n: usize,
    winv: DMatrix<f64>,
    w: DMatrix<f64>,
    crank: usize,
    torques: Vec<(usize, LockedTorque)>,
    engines: Vec<(usize, EngineTorque)>,
    prescribed: Option<(usize, Prescribed)>,
    governor: Option<(usize, Governor)>,
    m: DMatrix<f64>,
    f: DVector<f64>,
}

impl Drive {
    /// The driven equations of `kane`'s mechanism: `crank` is the joint whose coordinate phases
    /// the torques. Every torque's joint, the crank and the prescribed joint must have a
    /// coordinate. The engine's own joint torques stay in effect (clear them with
    /// [`Kane::set_joint_torque`] first to replace them).
    pub fn new(kane: Kane, crank: usize, torques: Vec<LockedTorque>, prescribed: Option<Prescribed>) -> Result<Self> {
        let mech = kane.mechanism().clone();
        let coord = |j: usize, what: &str| {
            mech.joints.get(j).and_then(|_| mech.coordinate(j)).ok_or_else(|| crate::error::Error::Model {
                mechanism: mech.name.clone(),
                message: format!("{what}: joint #{j} has no coordinate (Fixed or out of range)"),
            })
        };
        let crank = coord(crank, "crank")?;
        let torques =
            torques.into_iter().map(|t| Ok((coord(t.joint, "joint torque")?, t))).collect::<Result<Vec<_>>>()?;
        let prescribed = match prescribed {
            Some(p) => Some((coord(p.joint, "prescribed joint")?, p)),
            None => None,
        };
        let parents = mech.speed_parents();
        let n = kane.ndof();
        Ok(Self {
            n,
            winv: mech.speeds.w_inverse_matrix(&parents),
            w: mech.speeds.w_matrix(&parents),
            crank,
            torques,
            engines: Vec::new(),
            prescribed,
            governor: None,
            m: DMatrix::zeros(n, n),
            f: DVector::zeros(n),
            kane,
        })
    }

    /// The coordinate of joint `joint`, or an error saying which input (`what`) named a joint
    /// without one (Fixed, or out of range).
    fn coordinate_of(&self, joint: usize, what: &str) -> Result<usize> {
        let mech = self.kane.mechanism();
        mech.joints.get(joint).and_then(|_| mech.coordinate(joint)).ok_or_else(|| crate::error::Error::Model {
            mechanism: mech.name.clone(),
            message: format!("{what}: joint #{joint} has no coordinate (Fixed or out of range)"),
        })
    }

    /// Adds a speed governor (replacing any earlier one); its joint must have a coordinate.
    pub fn with_governor(mut self, g: Governor) -> Result<Self> {
        let c = self.coordinate_of(g.joint, "governor")?;
        self.governor = Some((c, g));
        Ok(self)
    }

    /// Adds engine torques (to any added before); each joint must have a coordinate.
    pub fn with_engine_torques(mut self, torques: Vec<EngineTorque>) -> Result<Self> {
        for t in torques {
            let c = self.coordinate_of(t.joint, "engine torque")?;
            self.engines.push((c, t));
        }
        Ok(self)
    }

    /// The mechanism.
    pub fn mechanism(&self) -> &Mechanism {
        self.kane.mechanism()
    }

    /// Degrees of freedom n (the state is `[q; u]`, 2n long).
    pub fn ndof(&self) -> usize {
        self.n
    }

    /// The crank angle in state `x`, rad.
    pub fn crank_angle(&self, x: &[f64]) -> f64 {
        x[self.crank]
    }

    /// Torque `k` of the list given to [`Drive::new`] at `t` and state `x`, N·m.
    pub fn torque(&self, k: usize, t: f64, x: &[f64]) -> f64 {
        self.torques[k].1.torque(t, x[self.crank])
    }

    /// M and F at `(t, x)` with the locked torques added to F.
    fn assemble(&mut self, t: f64, x: &[f64]) -> std::result::Result<(), EngineError> {
        let n = self.n;
        let (q, u) = x.split_at(n);
        // A path joint beyond its end of travel is named, not left to surface as a NaN.
        if let Some(e) = self.kane.mechanism().path_out_of_travel(q) {
            return Err(e);
        }
        let (m, f) = self.kane.mass_matrix_and_forcing(t, q, u);
        self.m.copy_from(m);
        self.f.copy_from(f);
        let crank = x[self.crank];
        for (c, lt) in &self.torques {
            let tau = lt.torque(t, crank);
            for r in 0..n {
                self.f[r] += tau * self.winv[(*c, r)];
            }
        }
        if !self.engines.is_empty() {
            // q̇_crank = (W⁻¹u)_crank: the engine's speed at this instant.
            let rate: f64 = (0..n).map(|r| self.winv[(self.crank, r)] * u[r]).sum();
            for (c, e) in &self.engines {
                let tau = e.torque(t, crank, rate);
                for r in 0..n {
                    self.f[r] += tau * self.winv[(*c, r)];
                }
            }
        }
        if let Some((c, g)) = self.governor {
            // q̇_c = (W⁻¹u)_c.
            let rate: f64 = (0..n).map(|r| self.winv[(c, r)] * u[r]).sum();
            let tau = g.torque(t, rate);
            for r in 0..n {
                self.f[r] += tau * self.winv[(c, r)];
            }
        }
        if let Some(i) = self.f.iter().position(|v| !v.is_finite()) {
            return Err(EngineError::NonFinite { what: "forcing F with the drive's torques", index: i });
        }
        Ok(())
    }

    /// `ẋ = [W⁻¹u; u̇]` of the driven equations. Allocates a little per call (nalgebra's
    /// factorisations): a transient is one run, not the inner loop of a sweep.
    pub fn rhs(&mut self, t: f64, x: &[f64], xdot: &mut [f64]) -> std::result::Result<(), EngineError> {
        let n = self.n;
        if x.len() != 2 * n || xdot.len() != 2 * n {
            let (what, got) = if x.len() != 2 * n { ("state x", x.len()) } else { ("derivative ẋ", xdot.len()) };
            return Err(EngineError::Dimension { what, got, expected: 2 * n });
        }
        self.assemble(t, x)?;
        let u = DVector::from_column_slice(&x[n..]);
        let qd = &self.winv * &u;
        xdot[..n].copy_from_slice(qd.as_slice());
        let ud = match self.prescribed {
            None => self.solve(&self.m, &self.f)?,
            Some((s, p)) => {
                let a = self.w.transpose() * &self.m * &self.w;
                let g = self.w.transpose() * &self.f;
                let qdd = self.partitioned(&a, &g, s, p.accel_at(t))?;
                &self.w * qdd
            }
        };
        xdot[n..].copy_from_slice(ud.as_slice());
        Ok(())
    }

    /// The torque the prescribed joint's drive exerts at `(t, x)`, N·m (N for a slide); `None`
    /// without a prescribed joint.
    pub fn drive_torque(&mut self, t: f64, x: &[f64]) -> Option<f64> {
        let (s, p) = self.prescribed?;
        self.assemble(t, x).ok()?;
        let a = self.w.transpose() * &self.m * &self.w;
        let g = self.w.transpose() * &self.f;
        let qdd = self.partitioned(&a, &g, s, p.accel_at(t)).ok()?;
        Some((a.row(s) * &qdd)[0] - g[s])
    }

    /// `q̈` of `A q̈ = G` with `q̈_s = accel` imposed.
    fn partitioned(
        &self,
        a: &DMatrix<f64>,
        g: &DVector<f64>,
        s: usize,
        accel: f64,
    ) -> std::result::Result<DVector<f64>, EngineError> {
        let n = self.n;
        let rest: Vec<usize> = (0..n).filter(|&k| k != s).collect();
        let arr = a.select_rows(&rest).select_columns(&rest);
        let rhs = DVector::from_iterator(rest.len(), rest.iter().map(|&r| g[r] - a[(r, s)] * accel));
        let sol = if rest.is_empty() { DVector::zeros(0) } else { self.solve(&arr, &rhs)? };
        let mut qdd = DVector::zeros(n);
        qdd[s] = accel;
        for (i, &r) in rest.iter().enumerate() {
            qdd[r] = sol[i];
        }
        Ok(qdd)
    }

    fn solve(&self, a: &DMatrix<f64>, b: &DVector<f64>) -> std::result::Result<DVector<f64>, EngineError> {
        let chol = a.clone().cholesky().ok_or_else(|| {
            let dof = (0..a.nrows()).find(|&k| a[(k, k)] <= 0.0).unwrap_or(0);
            EngineError::NotPositiveDefinite { dof, joint: String::from("(driven equations)"), pivot: a[(dof, dof)] }
        })?;
        let x = chol.solve(b);
        match x.iter().position(|v| !v.is_finite()) {
            Some(index) => Err(EngineError::NonFinite { what: "accelerations of the driven equations", index }),
            None => Ok(x),
        }
    }
}

/// The polar moment of inertia of everything joint `joint` carries, turning rigidly about it at
/// the configuration `q`: `uᵀ M u` for the speeds of `q̇ = e_c` (c the joint's coordinate), kg·m²
/// (kg for a slide); `None` for a joint without coordinate.
pub fn rigid_inertia(kane: &mut Kane, joint: usize, q: &[f64]) -> Option<f64> {
    let mech = kane.mechanism();
    let c = mech.coordinate(joint)?;
    let mut qdot = vec![0.0; mech.ndof()];
    qdot[c] = 1.0;
    let mut u = vec![0.0; qdot.len()];
    mech.speeds.u_from_qdot(&mech.speed_parents(), &qdot, &mut u);
    let u = DVector::from_vec(u);
    Some((u.transpose() * kane.mass_matrix(q) * &u)[0])
}

//! The order-domain frequency response (eq. 22): for a unit torque `e^{iΩnt}` in a joint, the
//! steady amplitude `x̂ = (iΩnM + A)⁻¹ â` of the first-order form (eq. 19, spin free), read out as
//! the angular acceleration `α̂ = iΩn c·û` of a body ([`LinearModel::acceleration_response`]); and
//! the same for the twin with chosen joints locked, whose ratio is the normalised response of
//! Fig. 2 ([`OrderResponse`]), with its high-order asymptote, first amplification order and
//! extremes over an order range.

use super::{C64, LinResult, LinearError, LinearModel, Spin, body_of, joint_of};
use crate::model::mechanism::Mechanism;
use nalgebra::{DMatrix, DVector};

impl LinearModel {
    /// Complex amplitude of body `body`'s angular acceleration (rad/s² per N·m) for a unit torque
    /// `e^{iΩnt}` in joint `joint`, spin free: eq. (22) on the full 2n state,
    /// `α̂ = iΩn · c·û` with c the body's angular-velocity row.
    pub fn acceleration_response(&self, body: usize, joint: usize, order: f64) -> LinResult<C64> {
        let n = self.ndof();
        let w = self.op.omega * order;
        let x = self.state_response(joint, order)?;
        let c = self.angular_velocity_row(body);
        let mut om = C64::new(0.0, 0.0);
        for r in 0..n {
            om += x[n + r] * c[r];
        }
        Ok(C64::new(0.0, w) * om)
    }

    /// The complex amplitudes `x̂ = [q̂; û]` of the whole first-order state (rad and rad/s per
    /// N·m; m and m/s for slides) for a unit torque `e^{iΩnt}` in joint `joint`, spin free
    /// (eq. 22).
    pub fn state_response(&self, joint: usize, order: f64) -> LinResult<DVector<C64>> {
        let g = self.generalized_torque(joint).map(|v| C64::new(v, 0.0));
        self.forced_state(Spin::Free, order, &g)
    }

    /// Eq. (22) for a generalized force `force·e^{iΩnt}` in the rows of the speeds (n entries):
    /// the steady `x̂ = [q̂; û]` (2n). With the spin held, the spin angle and speed are removed
    /// (their entries are 0, the spin speed's row is the reaction).
    pub(super) fn forced_state(&self, spin: Spin, order: f64, force: &DVector<C64>) -> LinResult<DVector<C64>> {
        let n = self.ndof();
        let w = self.op.omega * order;
        let iw = C64::new(0.0, w);
        let s = self.op.spin_coordinate;
        let kept: Vec<usize> = (0..n).filter(|&j| spin == Spin::Free || j != s).collect();
        let m = kept.len();
        let mut k = DMatrix::from_element(2 * m, 2 * m, C64::new(0.0, 0.0));
        for (a, &i) in kept.iter().enumerate() {
            k[(a, a)] = iw;
            for (b, &j) in kept.iter().enumerate() {
                k[(a, m + b)] = C64::new(-self.w_inv[(i, j)], 0.0);
                k[(m + a, b)] = C64::new(-self.f_q[(i, j)], 0.0);
                k[(m + a, m + b)] = iw * self.mass[(i, j)] - self.f_u[(i, j)];
            }
        }
        let rhs = DVector::from_fn(2 * m, |a, _| if a >= m { force[kept[a - m]] } else { C64::new(0.0, 0.0) });
        let xr = k.lu().solve(&rhs).ok_or(LinearError::Singular { order })?;
        if xr.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
            return Err(LinearError::Singular { order });
        }
        let mut x = DVector::from_element(2 * n, C64::new(0.0, 0.0));
        for (a, &i) in kept.iter().enumerate() {
            x[i] = xr[a];
            x[n + i] = xr[m + a];
        }
        Ok(x)
    }

    /// The high-order limit of the acceleration response: `c·M⁰⁻¹·g`, rad/s² per N·m (inertia
    /// only: stiffness and damping vanish against ω²M and ωM as ω → ∞).
    pub fn acceleration_limit(&self, body: usize, joint: usize) -> LinResult<f64> {
        let chol = self
            .mass
            .clone()
            .cholesky()
            .ok_or_else(|| LinearError::MassMatrix { mechanism: self.mech.name.clone() })?;
        Ok(self.angular_velocity_row(body).dot(&chol.solve(&self.generalized_torque(joint))))
    }
}

/// One joint of the excitation: it carries `scale·e^{i·phase}` times the unit torque.
#[derive(Debug, Clone, PartialEq)]
pub struct Input {
    /// The joint (child against parent).
    pub joint: String,
    /// Its share of the torque (1 for the whole).
    pub scale: f64,
    /// Its phase lead, rad.
    pub phase: f64,
}

impl Input {
    /// The whole unit torque at `joint`.
    pub fn unit(joint: impl Into<String>) -> Self {
        Self { joint: joint.into(), scale: 1.0, phase: 0.0 }
    }

    fn weight(&self) -> C64 {
        C64::from_polar(self.scale, self.phase)
    }
}

/// Which joints excite, which body is watched, and which joints are locked for the reference.
#[derive(Debug, Clone, PartialEq)]
pub struct ResponseSpec {
    /// The spin joint (root joint turning at Ω).
    pub spin_joint: String,
    /// The joints carrying the torque, each with its share and phase (e.g. the spin joint alone
    /// for the engine torque, or a propeller's joint as well): the response is the sum of each
    /// joint's response times its weight `scale·e^{i·phase}`.
    pub inputs: Vec<Input>,
    /// The body whose angular acceleration is the response (e.g. `rotor`).
    pub body: String,
    /// Joints locked (at their operating-point angles) to build the reference mechanism, e.g. the
    /// pendulum pivots. A locked child merges into its parent; if `body` is merged away, the
    /// response is that of the body that absorbed it.
    pub lock: Vec<String>,
}

/// One point of an order sweep of the frequency response.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrfPoint {
    /// Excitation order n.
    pub order: f64,
    /// |α̂| of the body, rad/s² per N·m.
    pub response: f64,
    /// |α̂| of the locked mechanism's body, rad/s² per N·m.
    pub locked: f64,
    /// `response / locked` (Fig. 2).
    pub ratio: f64,
}

/// The extremes of the normalised response over an order range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremes {
    /// Order of the smallest ratio.
    pub min_order: f64,
    /// The smallest ratio.
    pub min_ratio: f64,
    /// Order of the largest ratio.
    pub max_order: f64,
    /// The largest ratio (very large near an undamped resonance).
    pub max_ratio: f64,
}

/// The frequency response of a mechanism and of its locked twin at one spin speed (Fig. 2).
#[derive(Debug, Clone)]
pub struct OrderResponse {
    /// The mechanism.
    pub model: LinearModel,
    /// The locked mechanism.
    pub locked: LinearModel,
    body: usize,
    input: Vec<(usize, C64)>,
    body_locked: usize,
    input_locked: Vec<(usize, C64)>,
}

/// `Σ w_j · f(joint_j)`.
fn weighted(inputs: &[(usize, C64)], mut f: impl FnMut(usize) -> LinResult<C64>) -> LinResult<C64> {
    let mut sum = C64::new(0.0, 0.0);
    for &(j, w) in inputs {
        sum += w * f(j)?;
    }
    Ok(sum)
}

impl OrderResponse {
    /// Linearises `mech` and its locked twin at `omega_rad_s` (spin free).
    pub fn new(mech: &Mechanism, spec: &ResponseSpec, omega_rad_s: f64, guess: Option<&[f64]>) -> LinResult<Self> {
        let model = LinearModel::new(mech, &spec.spin_joint, omega_rad_s, guess)?;
        let body = body_of(mech, &spec.body)?;
        let input =
            spec.inputs.iter().map(|i| Ok((joint_of(mech, &i.joint)?, i.weight()))).collect::<LinResult<Vec<_>>>()?;
        let mut lm = mech.clone();
        let mut watched = spec.body.clone();
        for name in &spec.lock {
            if spec.inputs.iter().any(|i| i.joint == *name) {
                return Err(LinearError::LockedInput { joint: name.clone() });
            }
            let c = joint_of(&lm, name)?;
            joint_of(mech, name)?;
            // A welded joint has no coordinate: it is locked at its own pose already.
            let q_lock = mech.coordinate_index(name).map_or(0.0, |k| model.op.q[k]);
            if lm.bodies[c].name == watched
                && let Some(p) = lm.joints[c].parent
            {
                watched = lm.bodies[p].name.clone();
            }
            lm = lm.lock(name, q_lock)?;
        }
        // The twin's coordinates start where the mechanism's equilibrium has them, matched by name.
        let guess_l: Vec<f64> = (0..lm.ndof())
            .map(|k| mech.coordinate_index(&lm.joints[lm.joint_of(k)].name).map_or(0.0, |c| model.op.q[c]))
            .collect();
        let locked = LinearModel::new(&lm, &spec.spin_joint, omega_rad_s, Some(&guess_l))?;
        let body_locked = body_of(&lm, &watched)?;
        let input_locked =
            spec.inputs.iter().map(|i| Ok((joint_of(&lm, &i.joint)?, i.weight()))).collect::<LinResult<Vec<_>>>()?;
        Ok(Self { model, locked, body, input, body_locked, input_locked })
    }

    /// Complex α̂ of the body per N·m at order n.
    pub fn response(&self, order: f64) -> LinResult<C64> {
        weighted(&self.input, |j| self.model.acceleration_response(self.body, j, order))
    }

    /// Complex amplitudes q̂ of every coordinate of the mechanism (rad per N·m, m per N·m for a
    /// slide) at order n, under the weighted inputs: one solve per input for all coordinates.
    pub fn coordinate_responses(&self, order: f64) -> LinResult<DVector<C64>> {
        let n = self.model.ndof();
        let mut q = DVector::from_element(n, C64::new(0.0, 0.0));
        for &(j, w) in &self.input {
            let x = self.model.state_response(j, order)?;
            for k in 0..n {
                q[k] += w * x[k];
            }
        }
        Ok(q)
    }

    /// Complex α̂ of the body at order 1 under gravity (rad/s², absolute, not per N·m), spin
    /// free, `α(t) = Re(α̂ e^{iΩt})`: the gravity-forced response (see `gravity`'s module docs);
    /// zero without gravity.
    pub fn gravity_response(&self) -> LinResult<C64> {
        self.model.gravity_acceleration(self.body)
    }

    /// The same for the locked mechanism's body (its own weight distribution, e.g. the
    /// unbalance of one locked absorber), rad/s².
    pub fn gravity_locked_response(&self) -> LinResult<C64> {
        self.locked.gravity_acceleration(self.body_locked)
    }

    /// Complex amplitudes q̂ of every coordinate at order 1 under gravity (rad, m for a slide),
    /// spin free.
    pub fn gravity_coordinates(&self) -> LinResult<DVector<C64>> {
        let n = self.model.ndof();
        Ok(self.model.gravity_state_response(Spin::Free)?.rows(0, n).into_owned())
    }

    /// Complex α̂ of the locked mechanism's body per N·m at order n.
    pub fn locked_response(&self, order: f64) -> LinResult<C64> {
        weighted(&self.input_locked, |j| self.locked.acceleration_response(self.body_locked, j, order))
    }

    /// Both magnitudes and their ratio at order n.
    pub fn point(&self, order: f64) -> LinResult<FrfPoint> {
        let response = self.response(order)?.norm();
        let locked = self.locked_response(order)?.norm();
        Ok(FrfPoint { order, response, locked, ratio: response / locked })
    }

    /// [`OrderResponse::point`] over a list of orders.
    pub fn sweep(&self, orders: &[f64]) -> LinResult<Vec<FrfPoint>> {
        orders.iter().map(|&n| self.point(n)).collect()
    }

    /// The normalised response as n → ∞: the ratio of the inertia-only responses
    /// ([`LinearModel::acceleration_limit`]); for the CPVA `(Ĩ + 1 + 2n_t²)/(Ĩ − n_t⁴)`.
    pub fn asymptote(&self) -> LinResult<f64> {
        let limit = |m: &LinearModel, body: usize, inputs: &[(usize, C64)]| {
            weighted(inputs, |j| Ok(C64::new(m.acceleration_limit(body, j)?, 0.0))).map(|v| v.norm())
        };
        Ok(limit(&self.model, self.body, &self.input)? / limit(&self.locked, self.body_locked, &self.input_locked)?)
    }

    fn ratio(&self, n: f64) -> f64 {
        // An exact hit of an undamped pole counts as an infinite response.
        self.point(n).map_or(f64::INFINITY, |p| p.ratio)
    }

    /// The first order in `[n_from, n_to]` where the normalised response rises through 1 (from
    /// below): located on a grid of `steps` intervals, then bisected to 1e-13 relative.
    /// `None` when it does not happen in the range.
    pub fn first_amplification(&self, n_from: f64, n_to: f64, steps: usize) -> LinResult<Option<f64>> {
        if !(n_to > n_from && steps > 0) {
            return Err(LinearError::Invalid(format!("order range [{n_from}, {n_to}] with {steps} steps")));
        }
        let at = |i: usize| n_from + (n_to - n_from) * i as f64 / steps as f64;
        let mut prev = self.ratio(n_from);
        for i in 1..=steps {
            let cur = self.ratio(at(i));
            if prev <= 1.0 && cur > 1.0 {
                let (mut lo, mut hi) = (at(i - 1), at(i));
                while hi - lo > 1e-13 * hi.abs().max(1.0) {
                    let mid = 0.5 * (lo + hi);
                    if self.ratio(mid) > 1.0 {
                        hi = mid;
                    } else {
                        lo = mid;
                    }
                }
                return Ok(Some(0.5 * (lo + hi)));
            }
            prev = cur;
        }
        Ok(None)
    }

    /// Smallest and largest normalised response over `[n_from, n_to]`: a grid of `steps`
    /// intervals, then golden-section search in the two intervals around the best grid point
    /// (to 1e-10 relative in n).
    pub fn extremes(&self, n_from: f64, n_to: f64, steps: usize) -> LinResult<Extremes> {
        if !(n_to > n_from && steps >= 2) {
            return Err(LinearError::Invalid(format!("order range [{n_from}, {n_to}] with {steps} steps")));
        }
        let grid: Vec<f64> = (0..=steps).map(|i| n_from + (n_to - n_from) * i as f64 / steps as f64).collect();
        let vals: Vec<f64> = grid.iter().map(|&n| self.ratio(n)).collect();
        let refine = |sign: f64| -> (f64, f64) {
            let i = (0..vals.len()).max_by(|&a, &b| (sign * vals[a]).total_cmp(&(sign * vals[b]))).unwrap_or(0);
            let (a, b) = (grid[i.saturating_sub(1)], grid[(i + 1).min(steps)]);
            let (n, v) = golden(|n| -sign * self.ratio(n), a, b);
            if -v * sign >= vals[i] * sign { (n, -sign * v) } else { (grid[i], vals[i]) }
        };
        let (max_order, max_ratio) = refine(1.0);
        let (min_order, min_ratio) = refine(-1.0);
        Ok(Extremes { min_order, min_ratio, max_order, max_ratio })
    }
}

/// Golden-section minimisation of `f` on `[a, b]`; returns (argmin, min).
fn golden(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64) -> (f64, f64) {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    while (b - a) > 1e-10 * b.abs().max(1.0) {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d);
        }
    }
    if fc < fd { (c, fc) } else { (d, fd) }
}

//! Nonlinear joint couplings: state-dependent generalized forces τ(q, q̇) inside one joint, acting
//! +τ on the child and −τ on the parent like a joint spring or damper (a torque for a revolute
//! joint, a force along the slide or the path for a prismatic or path joint).
//!
//! Three laws, each optional and summed (docs/design/model.md, "Joint couplings"):
//!
//! - **Staged spring** ([`StageSpring`]), the arc springs of a dual-mass flywheel or the spring
//!   sets of a clutch damper: piecewise-linear in the deflection δ = q − q₀, with a table of
//!   stages per side. The *drive* side is δ < 0: the parent leads the child and drives it through
//!   the spring (the engine side pulling the load, when the tree runs from the engine outwards);
//!   the *coast* side is δ > 0, the child leading. Stage i of a side starts at |δ| = `from_i` and
//!   has stiffness k_i, so `τ(δ) = −sign(δ) Σ_i k_i · clamp(|δ| − from_i, 0, from_{i+1} − from_i)`:
//!   continuous, with a kink (a jump of the local stiffness) at every breakpoint.
//! - **Friction** ([`Friction`]), a regularised Coulomb law `τ = −T_f tanh(q̇/ε)`: for
//!   |q̇| ≫ ε it is Coulomb's ±T_f, at q̇ = 0 it is zero with slope −T_f/ε (a viscous damper
//!   T_f/ε; that is what a linear analysis sees). Under slow harmonic motion q = A sin ωt the
//!   torque–angle loop is a rectangle of height 2T_f and width 2A, dissipating 4 T_f A per cycle
//!   less the fraction π²ε²/(24 A²ω²) lost in the two smoothed reversals.
//! - **End stops** ([`EndStops`]), a compliant contact against `lower` and `upper`: with the
//!   penetration p (q − upper above, lower − q below) and its rate ṗ, the contact pushes back
//!   with `N = max(k p + c ṗ, 0)` while p > 0 and nothing otherwise. The damping may not pull:
//!   the contact ends when N reaches 0 (before p does), so a rebound never sticks to the stop;
//!   a mass m meeting the stop then leaves it with the velocity ratio
//!   `e = exp(−ζ (π − 2 arcsin ζ)/√(1 − ζ²))`, ζ = c/(2√(k m)) (docs/design/model.md derives it).
//!
//! tanh, not `q̇/√(q̇² + ε²)`: both have slope 1/ε at zero, but tanh reaches ±1 exponentially
//! (1 − tanh x ≈ 2e^{−2x}) where the algebraic form creeps up as 1/(2x²), so the same ε gives a
//! loop much closer to Coulomb's; and tanh is analytic in a strip of half-width πε/2 around the
//! real q̇ axis (the algebraic form only ε), so the harmonics of the friction torque under
//! periodic motion decay faster, which the harmonic balance's AFT needs.

use serde::{Deserialize, Serialize};

/// One stage of a [`StageSpring`] side: from deflection `from` on (rad or m, measured from the
/// free position, ≥ 0) the local stiffness is `stiffness`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stage {
    /// Deflection where the stage begins, rad (m for a prismatic or path joint), ≥ 0; the first
    /// stage of a side begins at 0.
    pub from: f64,
    /// Stiffness of the stage: N·m/rad for a revolute joint, N/m for a prismatic or path one.
    pub stiffness: f64,
}

/// A multi-stage (piecewise-linear) spring: `drive` for deflections q − `free_angle` < 0 (the
/// parent ahead of the child, driving it), `coast` (default: the drive table mirrored) for
/// deflections above.
///
/// In RON: `stages: (free_angle: 0.0, drive: [(from: 0.0, stiffness: 300.0),
/// (from: 0.45, stiffness: 1800.0)], coast: [(from: 0.0, stiffness: 300.0)])`.
///
/// # Common mistake
/// `from` is a deflection from `free_angle`, measured outwards on both sides: a drive stage at
/// `from: 0.2` begins at q = free_angle − 0.2 (q is the child's coordinate relative to the
/// parent, negative when the parent leads), a coast stage at `from: 0.2` at q = free_angle + 0.2.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StageSpring {
    /// Coordinate where the spring is relaxed, rad (m).
    #[serde(default)]
    pub free_angle: f64,
    /// Stages for negative deflection q − free_angle < 0 (drive side), deflection counted
    /// positive, `from` strictly increasing from 0.
    pub drive: Vec<Stage>,
    /// Stages for positive deflection (coast side); `None`: the drive table.
    #[serde(default)]
    pub coast: Option<Vec<Stage>>,
}

/// Regularised Coulomb friction `τ = −torque · tanh(q̇ / smoothing)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Friction {
    /// Coulomb level T_f: N·m for a revolute joint, N for a prismatic or path one, ≥ 0.
    pub torque: f64,
    /// Smoothing rate ε > 0: rad/s (m/s). Below it the law is viscous (T_f/ε); well above it,
    /// Coulomb's. Small ε is closer to Coulomb but stiffer for the integrator and needs more
    /// harmonics in a harmonic balance.
    pub smoothing: f64,
}

/// Compliant end stops at `lower` < `upper` (rad or m), a spring-dashpot contact that acts only
/// while engaged and never pulls (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EndStops {
    /// Lower limit of the coordinate, rad (m).
    pub lower: f64,
    /// Upper limit of the coordinate, rad (m).
    pub upper: f64,
    /// Contact stiffness, N·m/rad (N/m), > 0.
    pub stiffness: f64,
    /// Contact damping, N·m·s/rad (N·s/m), ≥ 0.
    #[serde(default)]
    pub damping: f64,
}

/// The couplings of one joint, as the engine evaluates them ([`Couplings::torque`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Couplings {
    /// Staged spring.
    pub stages: Option<StageSpring>,
    /// Friction.
    pub friction: Option<Friction>,
    /// End stops.
    pub stops: Option<EndStops>,
}

/// The stage table `coast` or, when absent, `drive`.
fn coast_of(s: &StageSpring) -> &[Stage] {
    s.coast.as_deref().unwrap_or(&s.drive)
}

/// `(∫₀^x k, k(x))` of one side's table at deflection x ≥ 0: the restoring torque's magnitude
/// and the local stiffness (the stage starting at or before x).
#[inline]
fn side(stages: &[Stage], x: f64) -> (f64, f64) {
    let (mut t, mut k) = (0.0, 0.0);
    for (i, s) in stages.iter().enumerate() {
        if x < s.from {
            break;
        }
        let end = stages.get(i + 1).map_or(f64::INFINITY, |n| n.from);
        t += s.stiffness * (x.min(end) - s.from);
        k = s.stiffness;
    }
    (t, k)
}

impl StageSpring {
    /// The spring's torque τ(q) (N·m or N) and its derivative ∂τ/∂q (minus the local stiffness).
    #[inline]
    pub fn torque(&self, q: f64) -> (f64, f64) {
        let d = q - self.free_angle;
        if d <= 0.0 {
            let (t, k) = side(&self.drive, -d);
            (t, -k)
        } else {
            let (t, k) = side(coast_of(self), d);
            (-t, -k)
        }
    }

    /// The coordinates of the breakpoints (rad or m), where the local stiffness jumps.
    pub fn breakpoints(&self) -> Vec<f64> {
        let down = self.drive.iter().skip(1).map(|s| self.free_angle - s.from);
        let up = coast_of(self).iter().skip(1).map(|s| self.free_angle + s.from);
        up.chain(down).collect()
    }

    /// Checks the tables, naming the field below `stages` and what is wrong.
    pub fn check(&self) -> Result<(), (String, String)> {
        if !self.free_angle.is_finite() {
            return Err(("free_angle".into(), format!("the free position must be finite, got {}", self.free_angle)));
        }
        let sides: [(&str, Option<&[Stage]>); 2] = [("drive", Some(&self.drive)), ("coast", self.coast.as_deref())];
        for (name, table) in sides {
            let Some(table) = table else { continue };
            if table.is_empty() {
                return Err((name.into(), "a stage table needs at least one stage".into()));
            }
            for (i, s) in table.iter().enumerate() {
                if !(s.stiffness.is_finite() && s.stiffness >= 0.0) {
                    return Err((
                        format!("{name}[{i}].stiffness"),
                        format!(
                            "stage stiffness must be finite and non-negative (N·m/rad or N/m), got {}",
                            s.stiffness
                        ),
                    ));
                }
                if !s.from.is_finite() {
                    return Err((format!("{name}[{i}].from"), format!("stage start must be finite, got {}", s.from)));
                }
                if i == 0 && s.from != 0.0 {
                    return Err((
                        format!("{name}[0].from"),
                        format!("the first stage begins at the free position: `from: 0.0`, got {}", s.from),
                    ));
                }
                if i > 0 && s.from <= table[i - 1].from {
                    return Err((
                        format!("{name}[{i}].from"),
                        format!(
                            "stage starts must increase: {} after {} (deflections from the free position, both sides \
                             counted positive)",
                            s.from,
                            table[i - 1].from
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

impl Friction {
    /// Checks the parameters, naming the field and what is wrong.
    pub fn check(&self) -> Result<(), (String, String)> {
        if !(self.torque.is_finite() && self.torque >= 0.0) {
            return Err((
                "torque".into(),
                format!("friction level must be finite and non-negative (N·m or N), got {}", self.torque),
            ));
        }
        let range = &super::ranges::FRICTION_SMOOTHING;
        if !super::ranges::within(self.smoothing, range) {
            return Err((
                "smoothing".into(),
                format!(
                    "smoothing rate ε must lie in {} (rad/s or m/s), got {:e}",
                    super::ranges::show(range),
                    self.smoothing
                ),
            ));
        }
        Ok(())
    }
}

impl EndStops {
    /// The contact torque τ(q, q̇) with `(∂τ/∂q, ∂τ/∂q̇)`.
    #[inline]
    pub fn torque(&self, q: f64, qd: f64) -> (f64, f64, f64) {
        // Penetration and its rate, and the direction the contact pushes.
        let (p, pd, sign) = if q > self.upper {
            (q - self.upper, qd, -1.0)
        } else if q < self.lower {
            (self.lower - q, -qd, 1.0)
        } else {
            return (0.0, 0.0, 0.0);
        };
        let n = self.stiffness * p + self.damping * pd;
        if n <= 0.0 {
            // Separating faster than the spring relaxes: the dashpot would pull; contact lost.
            return (0.0, 0.0, 0.0);
        }
        (sign * n, -self.stiffness, -self.damping)
    }

    /// Checks the parameters, naming the field and what is wrong.
    pub fn check(&self) -> Result<(), (String, String)> {
        for (field, v) in [("lower", self.lower), ("upper", self.upper)] {
            if !v.is_finite() {
                return Err((field.into(), format!("stop limit must be finite (rad or m), got {v}")));
            }
        }
        if self.lower >= self.upper {
            return Err((
                "upper".into(),
                format!("stop limits inverted: upper {} must exceed lower {}", self.upper, self.lower),
            ));
        }
        if !(self.stiffness.is_finite() && self.stiffness > 0.0) {
            return Err((
                "stiffness".into(),
                format!("contact stiffness must be finite and positive (N·m/rad or N/m), got {}", self.stiffness),
            ));
        }
        if !(self.damping.is_finite() && self.damping >= 0.0) {
            return Err((
                "damping".into(),
                format!("contact damping must be finite and non-negative (N·m·s/rad or N·s/m), got {}", self.damping),
            ));
        }
        Ok(())
    }
}

impl Couplings {
    /// True when the joint has no coupling.
    pub fn is_empty(&self) -> bool {
        self.stages.is_none() && self.friction.is_none() && self.stops.is_none()
    }

    /// The generalized force τ(q, q̇) on the child (N·m or N; the reverse on the parent).
    #[inline]
    pub fn torque(&self, q: f64, qd: f64) -> f64 {
        self.torque_and_slopes(q, qd).0
    }

    /// τ(q, q̇) with its exact local derivatives `(τ, ∂τ/∂q, ∂τ/∂q̇)`; at a breakpoint the
    /// stiffness of the stage that begins there.
    #[inline]
    pub fn torque_and_slopes(&self, q: f64, qd: f64) -> (f64, f64, f64) {
        let (mut t, mut dq, mut dv) = (0.0, 0.0, 0.0);
        if let Some(s) = &self.stages {
            let (ts, k) = s.torque(q);
            t += ts;
            dq += k;
        }
        if let Some(f) = &self.friction {
            let th = (qd / f.smoothing).tanh();
            t -= f.torque * th;
            dv -= f.torque / f.smoothing * (1.0 - th * th);
        }
        if let Some(s) = &self.stops {
            let (ts, kq, kv) = s.torque(q, qd);
            t += ts;
            dq += kq;
            dv += kv;
        }
        (t, dq, dv)
    }

    /// The couplings in words for `check`, with the force unit `per` (N·m or N) and the
    /// coordinate's `unit` (rad or m); empty without couplings.
    pub fn describe(&self, per: &str, unit: &str) -> String {
        let mut out = String::new();
        if let Some(s) = &self.stages {
            let table = |t: &[Stage]| {
                t.iter().map(|st| format!("{} from {}", st.stiffness, st.from)).collect::<Vec<_>>().join(", ")
            };
            out += &format!(
                "   stages (free at {} {unit}; {per}/{unit} from deflection {unit}) drive [{}] coast [{}]",
                s.free_angle,
                table(&s.drive),
                table(coast_of(s))
            );
        }
        if let Some(f) = &self.friction {
            out += &format!("   friction {} {per} (ε = {} {unit}/s)", f.torque, f.smoothing);
        }
        if let Some(s) = &self.stops {
            out += &format!(
                "   stops [{}, {}] {unit} ({} {per}/{unit}, {} {per}·s/{unit})",
                s.lower, s.upper, s.stiffness, s.damping
            );
        }
        out
    }

    /// Coordinates (rad or m) where τ has a kink in q: the stage breakpoints and the stop limits.
    pub fn kinks(&self) -> Vec<f64> {
        let mut out = self.stages.as_ref().map(StageSpring::breakpoints).unwrap_or_default();
        if let Some(s) = &self.stops {
            out.extend([s.lower, s.upper]);
        }
        out
    }
}

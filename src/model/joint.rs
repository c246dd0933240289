//! Joint specifications (the RON form), joint kinds and resolved joints.

use crate::error::Result;
use crate::io::Source;
use crate::model::coupling::{Couplings, EndStops, Friction, StageSpring};
use crate::model::math::{Vec2, rotate_cs};
use crate::model::path::{PathShape, Rollers};
use serde::{Deserialize, Serialize};

/// The joint vocabulary: how a child body's frame may move relative to its parent's.
///
/// Every kind has at most one coordinate (a joint of several coordinates is a chain of these with
/// massless bodies between them) and answers three questions through [`JointKind::motion`]: where
/// the child frame is (its transform), how it moves per unit rate of the coordinate (its motion
/// columns) and what its motion adds at zero coordinate acceleration (its velocity-product or
/// bias terms). The engine's general forms ([`crate::kane`]'s reference and joint-rate forms) use
/// nothing else about a joint.
///
/// In RON: `Revolute`, `Prismatic(axis: (1.0, 0.0))`, `Fixed`,
/// `Path(shape: Epicycloid(rho0: 0.185, n_tilde: 3.11), mount: 0.0)`.
///
/// The enum stays `Copy`: a path kind carries only the few numbers of its closed form
/// ([`PathShape`]), or for a general path a `&'static` reference to its table built once at load,
/// so passing a kind by value into the engine's per-body records costs nothing new and no caller
/// had to change.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub enum JointKind {
    /// Rotation about z through the joint point; one coordinate, the relative angle (rad).
    #[default]
    Revolute,
    /// Translation along `axis` (in the parent frame; normalised when the mechanism is loaded)
    /// from the joint point, without rotation; one coordinate, the displacement (m).
    Prismatic {
        /// Direction of the slide in the parent frame (any non-zero length).
        axis: (f64, f64),
    },
    /// Welded: the child frame sits at the joint point, parallel to the parent's; no coordinate.
    Fixed,
    /// An absorber path: the child frame's origin follows the curve `shape` drawn about the
    /// joint point `at` (the rotor axis, in the parent frame) and turned by `mount`, and the
    /// child turns by the shape's rotation law α(s); one coordinate, the arc length s of the
    /// origin along the path (m). The child's centre of mass must sit at its frame origin
    /// (`com: (0.0, 0.0)`) for s to be the centre of mass's arc length, as the absorber formulas
    /// assume; another `com` is carried along, turning with α.
    ///
    /// # Common mistake
    /// `at` is the centre the path is drawn about (the rotor axis), not the path's vertex: at
    /// s = 0 the child's origin is at `at + ρ₀ (cos mount, sin mount)`.
    Path {
        /// The curve and rotation law.
        shape: PathShape,
        /// Mounting angle: direction of the vertex (s = 0) from `at` in the parent frame, rad.
        #[serde(default)]
        mount: f64,
        /// The absorber's travel limit, m (> 0, below the path's own end): a state with
        /// |s| ≥ travel stops the engine with [`crate::error::EngineError::OutOfTravel`] naming the
        /// joint. `None` (default): the path's own end (the cusp; infinite for a circle).
        #[serde(default)]
        travel: Option<f64>,
    },
}

/// A joint's kinematics at one value `q` of its coordinate, in the parent frame.
///
/// The child frame's origin is `origin(q)` and its rotation relative to the parent is
/// `angle(q)`; with `q̇` the coordinate's rate, the child moves relative to the parent with angular
/// velocity `omega · q̇` and origin velocity `velocity · q̇`, and at `q̈ = 0` with angular
/// acceleration `bias_alpha · q̇²` and origin acceleration `bias_acc · q̇²` (the velocity-product
/// terms, `∂(columns)/∂q`). For a joint without coordinate the columns are zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointMotion {
    /// Cosine and sine of the child frame's rotation relative to the parent frame.
    pub cos: f64,
    /// See `cos`.
    pub sin: f64,
    /// The child frame's origin in the parent frame, m.
    pub origin: Vec2,
    /// Partial angular velocity of the child frame per unit rate (rad/s per unit of q̇).
    pub omega: f64,
    /// Partial velocity of the child origin relative to the parent frame, per unit rate, in the
    /// parent frame (m/s per unit of q̇).
    pub velocity: Vec2,
    /// Relative angular acceleration per q̇² at q̈ = 0 (rad/s² per unit² of q̇).
    pub bias_alpha: f64,
    /// Relative acceleration of the child origin per q̇² at q̈ = 0, parent frame.
    pub bias_acc: Vec2,
}

impl JointMotion {
    /// The motion of a joint that does not move its child: the child's frame at `at`, parallel
    /// to the parent's, with zero columns and bias terms.
    #[inline]
    pub fn still(at: Vec2) -> JointMotion {
        JointMotion {
            cos: 1.0,
            sin: 0.0,
            origin: at,
            omega: 0.0,
            velocity: Vec2::zeros(),
            bias_alpha: 0.0,
            bias_acc: Vec2::zeros(),
        }
    }
}

/// A path joint's parameters ([`JointKind::Path`]'s fields), for callers that need the path itself
/// rather than one of [`JointKind`]'s answers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathJoint {
    /// The curve and rotation law.
    pub shape: PathShape,
    /// Mounting angle of the vertex direction in the parent frame, rad.
    pub mount: f64,
    /// The user's travel limit, m, when one is given.
    pub travel: Option<f64>,
}

impl JointKind {
    /// The kind's name as written in RON and shown in reports and the Python package:
    /// `Revolute`, `Prismatic`, `Fixed` or `Path`.
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Revolute => "Revolute",
            JointKind::Prismatic { .. } => "Prismatic",
            JointKind::Fixed => "Fixed",
            JointKind::Path { .. } => "Path",
        }
    }

    /// The path's parameters for a path joint, `None` for the other kinds.
    #[inline]
    pub fn path(self) -> Option<PathJoint> {
        match self {
            JointKind::Path { shape, mount, travel } => Some(PathJoint { shape, mount, travel }),
            JointKind::Revolute | JointKind::Prismatic { .. } | JointKind::Fixed => None,
        }
    }

    /// The unit slide axis of a prismatic joint (in the parent frame, once loaded), `None` for the
    /// other kinds.
    pub fn slide_axis(self) -> Option<Vec2> {
        match self {
            JointKind::Prismatic { axis } => Some(Vec2::new(axis.0, axis.1)),
            JointKind::Revolute | JointKind::Fixed | JointKind::Path { .. } => None,
        }
    }

    /// The direction the kind fixes in its parent's frame, which turns with the parent: a slide
    /// axis, or a path's vertex direction (its mount); `None` for a revolute or fixed joint, whose
    /// only geometry is the joint point.
    pub fn direction(self) -> Option<Vec2> {
        match self {
            JointKind::Prismatic { axis } => Some(Vec2::new(axis.0, axis.1)),
            JointKind::Path { mount, .. } => Some(Vec2::new(mount.cos(), mount.sin())),
            JointKind::Revolute | JointKind::Fixed => None,
        }
    }

    /// True when the child's origin stays at the joint point whatever the coordinate (revolute
    /// and fixed joints).
    pub fn keeps_origin(self) -> bool {
        match self {
            JointKind::Revolute | JointKind::Fixed => true,
            JointKind::Prismatic { .. } | JointKind::Path { .. } => false,
        }
    }

    /// True when the child turns relative to the parent as the coordinate moves: a revolute
    /// joint, or a path whose rotation law α(s) is not zero.
    pub fn turns_child(self) -> bool {
        match self {
            JointKind::Revolute => true,
            JointKind::Path { shape, .. } => shape.turns(),
            JointKind::Prismatic { .. } | JointKind::Fixed => false,
        }
    }

    /// Why a coupling (a gear, a mesh) cannot join this joint, as the rest of a sentence that
    /// starts with the joint's name, or `None` when it can: couplings relate the rates of
    /// one-coordinate joints whose coordinate is a rotation or a slide.
    pub fn uncouplable(self) -> Option<&'static str> {
        match self {
            JointKind::Revolute | JointKind::Prismatic { .. } => None,
            JointKind::Fixed => Some("is Fixed: it has no coordinate to couple"),
            JointKind::Path { .. } => Some(
                "is a path joint: couplings join revolute and prismatic joints (a gear does not drive an absorber \
                 along its path)",
            ),
        }
    }

    /// Number of coordinates (and generalized speeds) the joint owns: 1, or 0 for `Fixed`.
    pub fn dof(self) -> usize {
        match self {
            JointKind::Revolute | JointKind::Prismatic { .. } | JointKind::Path { .. } => 1,
            JointKind::Fixed => 0,
        }
    }

    /// True when the coordinate is an angle that adds to the child's absolute rotation.
    pub fn rotates(self) -> bool {
        matches!(self, JointKind::Revolute)
    }

    /// The child's rotation relative to the parent at coordinate `q`, rad, not wrapped: q for a
    /// revolute joint, α(s) for a path, 0 otherwise.
    pub fn turn(self, q: f64) -> f64 {
        match self {
            JointKind::Revolute => q,
            JointKind::Path { shape, .. } => shape.alpha(q),
            JointKind::Prismatic { .. } | JointKind::Fixed => 0.0,
        }
    }

    /// The end of travel of the coordinate: |q| must stay below it (m for a path: its travel
    /// limit when given, else the path's own end; infinite for the other kinds).
    pub fn travel(self) -> f64 {
        match self {
            JointKind::Path { shape, travel, .. } => travel.map_or(shape.travel(), |t| t.min(shape.travel())),
            _ => f64::INFINITY,
        }
    }

    /// A typical size of the coordinate (1 rad, 1 m; a path's [`PathShape::length_scale`]), for
    /// finite-difference steps taken in it.
    pub fn coordinate_scale(self) -> f64 {
        match self {
            JointKind::Path { shape, travel, .. } => {
                travel.map_or(shape.length_scale(), |t| shape.length_scale().min(0.2 * t))
            }
            _ => 1.0,
        }
    }

    /// The coordinate to evaluate a path at: `q` inside the joint's travel limit, NaN at or beyond
    /// it (or when `q` is NaN), so that the path's point is NaN there as beyond the path's own
    /// end, which the engine reports as `OutOfTravel` naming the joint. Every evaluation of a
    /// path joint's shape (`PathShape::at`) must take its coordinate through this; `q` itself for
    /// the other kinds.
    #[inline(always)]
    pub fn limited(self, q: f64) -> f64 {
        match self {
            JointKind::Path { travel: Some(t), .. } => {
                let within = q.abs() < t;
                if within { q } else { f64::NAN }
            }
            _ => q,
        }
    }

    /// The joint's transform, motion columns and bias terms at coordinate `q` (ignored without a
    /// coordinate), for a joint at point `at` of the parent frame (m).
    #[inline]
    pub fn motion(self, at: Vec2, q: f64) -> JointMotion {
        let still = JointMotion::still(at);
        match self {
            JointKind::Revolute => {
                let (sin, cos) = q.sin_cos();
                JointMotion { cos, sin, omega: 1.0, ..still }
            }
            JointKind::Prismatic { axis } => {
                let axis = Vec2::new(axis.0, axis.1);
                JointMotion { origin: at + q * axis, velocity: axis, ..still }
            }
            JointKind::Fixed => still,
            JointKind::Path { mount, .. } => {
                let (ms, mc) = mount.sin_cos();
                self.motion_mounted(at, q, Some((mc, ms)))
            }
        }
    }

    /// [`JointKind::motion`] with a path's mounting rotation given as its cosine and sine (`None`:
    /// no rotation, for a mount of zero), so that a caller evaluating the same joint many times
    /// (the engine's fixed-size forms) takes the mount's `sin_cos` once; the same numbers up to
    /// the sign of a zero. Kinds other than `Path` ignore `mount`.
    #[inline(always)]
    pub fn motion_mounted(self, at: Vec2, q: f64, mount: Option<(f64, f64)>) -> JointMotion {
        let JointKind::Path { shape, .. } = self else { return self.motion(at, q) };
        // The path's own frame (vertex on +x) turned by the mounting angle.
        let turn = |v: Vec2| match mount {
            Some((mc, ms)) => rotate_cs(mc, ms, v),
            None => v,
        };
        let p = shape.at(self.limited(q));
        // A translating absorber (α ≡ 0) skips the sine and cosine.
        let (sin, cos) = if p.alpha == 0.0 { (p.alpha, 1.0) } else { p.alpha.sin_cos() };
        JointMotion {
            cos,
            sin,
            origin: at + turn(p.position),
            omega: p.dalpha,
            velocity: turn(p.tangent),
            bias_alpha: p.ddalpha,
            bias_acc: turn(p.curvature),
        }
    }

    /// The motion of a path joint's rollers ([`Rollers`]) relative to the parent at the path's
    /// coordinate `q`, as a joint's (docs/design/paths.md, "Rollers"): the rollers' centroid
    /// `at + R(γ) ½(P + r(s))` (`centre` = P, the vertex's centre of curvature in the path's
    /// frame), turned by ψ = `turn_rate` · s; columns ω = `turn_rate` (= −1/(2 r_r)) and
    /// v = ½ R(γ) t(s); bias 0 and ½ R(γ) r''(s) per ṡ². Beyond the travel every field is NaN,
    /// as the path's own. For a kind other than `Path` the rollers stand still at `at`.
    #[inline]
    pub fn roller_motion(self, at: Vec2, q: f64, centre: Vec2, turn_rate: f64) -> JointMotion {
        if let JointKind::Path { shape, mount, .. } = self {
            let (ms, mc) = mount.sin_cos();
            let s = self.limited(q);
            let p = shape.at(s);
            let (sin, cos) = (turn_rate * s).sin_cos();
            return JointMotion {
                cos,
                sin,
                origin: at + rotate_cs(mc, ms, 0.5 * (centre + p.position)),
                omega: turn_rate,
                velocity: rotate_cs(mc, ms, 0.5 * p.tangent),
                bias_alpha: 0.0,
                bias_acc: rotate_cs(mc, ms, 0.5 * p.curvature),
            };
        }
        JointMotion::still(at)
    }

    /// The kind with its parameters checked and normalised (a prismatic axis to unit length), or
    /// the field below the kind and what is wrong.
    pub fn normalised(self) -> std::result::Result<JointKind, (&'static str, String)> {
        match self {
            JointKind::Prismatic { axis: (x, y) } => {
                let len = x.hypot(y);
                if !(x.is_finite() && y.is_finite() && len > 1e-12) {
                    return Err((
                        "axis",
                        format!("a prismatic joint needs a finite, non-zero slide axis, got ({x}, {y})"),
                    ));
                }
                Ok(JointKind::Prismatic { axis: (x / len, y / len) })
            }
            JointKind::Path { shape, mount, travel } => {
                if !mount.is_finite() {
                    return Err(("mount", format!("the mounting angle must be finite (rad), got {mount}")));
                }
                shape.check().map_err(|(field, msg)| {
                    // The field sits below the shape's variant: `shape.rho0`.
                    let field: &'static str = match field {
                        "radius" => "shape.radius",
                        "length" => "shape.length",
                        "rho0" => "shape.rho0",
                        "n_tilde" => "shape.n_tilde",
                        "alpha1" => "shape.alpha1",
                        "x" => "shape.x",
                        "alpha" => "shape.alpha",
                        _ => "shape",
                    };
                    (field, msg)
                })?;
                if let Some(t) = travel {
                    if !(t.is_finite() && t > 0.0) {
                        return Err(("travel", format!("the travel limit must be finite and positive (m), got {t}")));
                    }
                    let end = shape.travel();
                    if t >= end {
                        let why = match shape {
                            PathShape::General(_) => "where |dρ/ds| reaches 1 (the path turns back on itself)",
                            _ => "at its cusp",
                        };
                        return Err((
                            "travel",
                            format!(
                                "the travel limit {t} m reaches beyond the path's end at ±{end:.6e} m, {why}: \
                                 give a limit below it, or none to use the whole path"
                            ),
                        ));
                    }
                }
                Ok(self)
            }
            other => Ok(other),
        }
    }

    /// The unit of the coordinate, for messages and reports.
    pub fn coordinate_unit(self) -> &'static str {
        match self {
            JointKind::Revolute => "rad",
            JointKind::Prismatic { .. } | JointKind::Path { .. } => "m",
            JointKind::Fixed => "",
        }
    }
}

/// A linear spring inside a joint: generalized force `−stiffness·(q − free_angle)` on the child
/// (a torque for a revolute joint, a force along the axis for a prismatic one, along the path for
/// a path joint).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Spring {
    /// Stiffness: N·m/rad for a revolute joint, N/m for a prismatic or path one.
    pub stiffness: f64,
    /// Coordinate at which the spring is relaxed: rad for a revolute joint, m for a prismatic or
    /// path one.
    #[serde(default)]
    pub free_angle: f64,
}

/// A joint as written in a mechanism or catalog file.
///
/// `at` is the joint point in the parent's frame (m; in the world frame when the parent is
/// `ground`). The child's frame has its origin at that point and is parallel to the parent's at
/// q = 0. With `part`, the catalog file's fields come first and the ones given here override them.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Joint", deny_unknown_fields)]
pub struct JointSpec {
    /// Unique name (required once parts are merged).
    pub name: Option<String>,
    /// Catalog file to start from, relative to the file that names it.
    pub part: Option<String>,
    /// Joint kind (default `Revolute`).
    pub kind: Option<JointKind>,
    /// Parent body name, or `ground`.
    pub parent: Option<String>,
    /// Child body name.
    pub child: Option<String>,
    /// Joint point in the parent frame, m (default the parent's origin).
    pub at: Option<(f64, f64)>,
    /// Internal torsional spring.
    pub spring: Option<Spring>,
    /// Internal viscous damper, N·m·s/rad (N·s/m for a prismatic or path joint): generalized force
    /// `−damper·q̇` on the child, the reverse on the parent.
    pub damper: Option<f64>,
    /// Multi-stage (piecewise-linear) spring, added to `spring` ([`StageSpring`]).
    #[serde(default)]
    pub stages: Option<StageSpring>,
    /// Regularised Coulomb friction ([`Friction`]).
    #[serde(default)]
    pub friction: Option<Friction>,
    /// Compliant end stops ([`EndStops`]).
    #[serde(default)]
    pub stops: Option<EndStops>,
    /// The rollers that carry a translating path absorber ([`Rollers`]; path joints with α = 0
    /// only).
    #[serde(default)]
    pub rollers: Option<Rollers>,
}

impl JointSpec {
    /// Fields of `over` replace those of `self`.
    pub fn merged(&self, over: &JointSpec) -> JointSpec {
        JointSpec {
            name: over.name.clone().or_else(|| self.name.clone()),
            part: None,
            kind: over.kind.or(self.kind),
            parent: over.parent.clone().or_else(|| self.parent.clone()),
            child: over.child.clone().or_else(|| self.child.clone()),
            at: over.at.or(self.at),
            spring: over.spring.or(self.spring),
            damper: over.damper.or(self.damper),
            stages: over.stages.clone().or_else(|| self.stages.clone()),
            friction: over.friction.or(self.friction),
            stops: over.stops.or(self.stops),
            rollers: over.rollers.or(self.rollers),
        }
    }

    /// Checks the numbers given in this spec (before merging), naming the field at `path`.
    pub fn check_numbers(&self, src: &Source, path: &str) -> Result<()> {
        if let Some((x, y)) = self.at
            && !(x.is_finite() && y.is_finite())
        {
            return Err(src.error(&format!("{path}.at"), "joint point must be finite"));
        }
        if let Some(c) = self.damper
            && !(c.is_finite() && c >= 0.0)
        {
            return Err(src.error(
                &format!("{path}.damper"),
                format!("damping must be finite and non-negative (N·m·s/rad), got {c}"),
            ));
        }
        if let Some(s) = self.spring {
            if !(s.stiffness.is_finite() && s.stiffness >= 0.0) {
                return Err(src.error(
                    &format!("{path}.spring.stiffness"),
                    format!("stiffness must be finite and non-negative (N·m/rad), got {}", s.stiffness),
                ));
            }
            if !s.free_angle.is_finite() {
                return Err(src.error(&format!("{path}.spring.free_angle"), "free angle must be finite"));
            }
        }
        let located = |what: &str, (field, msg): (String, String)| src.error(&format!("{path}.{what}.{field}"), msg);
        if let Some(s) = &self.stages {
            s.check().map_err(|e| located("stages", e))?;
        }
        if let Some(f) = &self.friction {
            f.check().map_err(|e| located("friction", e))?;
        }
        if let Some(s) = &self.stops {
            s.check().map_err(|e| located("stops", e))?;
        }
        if let Some(r) = &self.rollers {
            r.check().map_err(|(field, msg)| located("rollers", (field.to_string(), msg)))?;
        }
        Ok(())
    }
}

/// A resolved joint. In a [`crate::model::mechanism::Mechanism`], joint `i` is the inboard joint of
/// body `i`; it owns coordinate `q[coordinate]` when its kind has one.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Unique name.
    pub name: String,
    /// Kind.
    pub kind: JointKind,
    /// Parent body index, `None` for ground.
    pub parent: Option<usize>,
    /// Joint point in the parent frame (world frame for ground), m.
    pub at: Vec2,
    /// Index of its coordinate in q (and of its speed in u), `None` for a joint without one.
    pub coordinate: Option<usize>,
    /// Internal spring.
    pub spring: Option<Spring>,
    /// Internal viscous damping, N·m·s/rad (0 when none).
    pub damper: f64,
    /// Nonlinear couplings: staged spring, friction, end stops (empty when none).
    pub couplings: Couplings,
    /// The rollers carrying a path joint's translating absorber (`None` for most joints).
    pub rollers: Option<Rollers>,
}

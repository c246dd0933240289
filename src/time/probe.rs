//! Named signals of a simulation (probes), the one recorder that turns sampled states into
//! columns, and [`simulate`]: integrate a [`Kane`] engine into a [`Recorder`], with one
//! [`Outcome`] per run. Studies and library users go through these three.
//!
//! A probe is resolved once against a [`Mechanism`] by body or joint name; recording is then
//! index arithmetic on the state `x = [q; u]` (and `ẋ` for accelerations):
//! - body angle `β_b = Σ q_k` over the rotating joints k on the path root → b
//!   ([`Mechanism::rotation_coordinates`]: angles add along the tree, slides and welds turn nothing);
//! - body rate `ω_b`: `u_b` itself for absolute angular velocities as speeds on a revolute body,
//!   else `Σ q̇_k` over the same joints with `q̇ = W⁻¹u`;
//! - body acceleration `ω̇_b`: the same with `u̇` (W is constant for both speed choices, so no
//!   `Ẇ` term); it needs `ẋ` at the sample state, one extra right-hand-side call per sample;
//! - joint coordinate `q_j` (the pendulum's φ in rad; m for a slide) and its rate `q̇_j`;
//! - the largest `|q_k|` over every coordinate except one joint's (for a rotor with absorbers,
//!   the largest absorber excursion when the spin joint is excepted);
//! - a joint's reaction, the force (radial and tangential components) and moment its parent
//!   exerts on its child ([`crate::kane::reactions`], a Newton–Euler pass over `q, q̇, q̈`; it
//!   needs `ẋ` like an acceleration);
//! - the torque a gear mesh exerts on its driven joint ([`Kane::gear_torques`]: a rigid
//!   coupling's constraint torque λ, a compliant mesh's spring and damper torque; it needs `ẋ`
//!   and the joint torques acting at driven joints, which [`simulate`] hands over).
//!
//! On a geared mechanism (docs/design/model.md, "Gears") a rigidly driven joint has no state entry:
//! its coordinate, rate and acceleration are `factor · (the followed coordinate's)` plus its
//! offset ([`Mechanism::follow_map`]), and a body's angle is `Σ factor · q_k` plus the offsets
//! over the rotating joints on its path ([`Mechanism::rotation_rates`]); reactions run on the
//! unconstrained tree at the expanded state.
//!
//! The rotor response of the paper (Figs. 3–6) is `BodyAccel(rotor)`, i.e. u̇1 in rad/s².

use crate::error::{Error, Result};
use crate::kane::Kane;
use crate::model::mechanism::Mechanism;
use crate::model::speeds::Speeds;
use crate::time::integrate::{IntegrateError, IntegrateOptions, IntegrateStats, integrate};
use serde::{Deserialize, Serialize};

/// What a probe measures (the serialisable half of a probe; see [`Probe::resolve`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ProbeKind {
    /// Absolute angle of a body, rad.
    BodyAngle,
    /// Absolute angular velocity of a body, rad/s.
    BodyRate,
    /// Absolute angular acceleration of a body, rad/s².
    BodyAccel,
    /// Coordinate q of a joint (child relative to parent), rad or m.
    JointAngle,
    /// Rate q̇ of a joint's coordinate, rad/s or m/s.
    JointRate,
    /// Largest |q| over the coordinates of every joint except the named one, rad (m for slides).
    LargestJointAngle,
    /// Radial component of the force the parent exerts on the child through a joint, N (see
    /// [`crate::kane::reactions::Reaction`]).
    JointForceRadial,
    /// Tangential component of that force, N.
    JointForceTangential,
    /// Moment about the joint point the parent exerts on the child, N·m.
    JointMoment,
    /// Torque the gear mesh driving the named joint exerts on it, as a joint torque (positive on
    /// the child, negative on the parent; N·m, N on a prismatic joint): a rigid coupling's
    /// constraint torque, a compliant mesh's spring and damper torque. The driving joint receives
    /// `−ratio` times it.
    GearMeshTorque,
}

/// A signal to record, with its body or joint index resolved in a mechanism.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Probe {
    /// Absolute angle of body `b`, rad.
    BodyAngle(usize),
    /// Absolute angular velocity of body `b`, rad/s.
    BodyRate(usize),
    /// Absolute angular acceleration of body `b`, rad/s².
    BodyAccel(usize),
    /// Coordinate q of joint `j`, rad (m for a slide).
    JointAngle(usize),
    /// Rate q̇ of joint `j`'s coordinate, rad/s (m/s for a slide).
    JointRate(usize),
    /// Largest |q_k| over every coordinate except joint `j`'s.
    LargestJointAngle(usize),
    /// Radial reaction force at joint `j`, N.
    JointForceRadial(usize),
    /// Tangential reaction force at joint `j`, N.
    JointForceTangential(usize),
    /// Reaction moment at joint `j`, N·m.
    JointMoment(usize),
    /// Torque of the gear mesh on its driven joint `j`, N·m (N for a slide).
    GearMeshTorque(usize),
}

impl Probe {
    /// Resolves `kind` on the body or joint called `name` in `mech`; an unknown name is an error
    /// that lists the known ones.
    pub fn resolve(mech: &Mechanism, kind: ProbeKind, name: &str) -> Result<Probe> {
        let unknown = |what: &str, known: Vec<&str>| Error::Model {
            mechanism: mech.name.clone(),
            message: format!("probe {kind:?}: unknown {what} `{name}` (known {what}s: {})", known.join(", ")),
        };
        if matches!(
            kind,
            ProbeKind::JointAngle
                | ProbeKind::JointRate
                | ProbeKind::LargestJointAngle
                | ProbeKind::JointForceRadial
                | ProbeKind::JointForceTangential
                | ProbeKind::JointMoment
                | ProbeKind::GearMeshTorque
        ) {
            let j = mech
                .joint_index(name)
                .ok_or_else(|| unknown("joint", mech.joints.iter().map(|j| j.name.as_str()).collect()))?;
            match kind {
                ProbeKind::GearMeshTorque => {
                    return match mech.gear_driving(j) {
                        Ok(Some(_)) => Ok(Probe::GearMeshTorque(j)),
                        Ok(None) => {
                            let driven: Vec<&str> =
                                mech.gears.iter().map(|g| mech.joints[g.joint].name.as_str()).collect();
                            Err(Error::Model {
                                mechanism: mech.name.clone(),
                                message: format!(
                                    "probe {kind:?}: no gear drives joint `{name}` (name the driven joint of a \
                                     coupling, its `joint`; driven joints: {})",
                                    if driven.is_empty() { "none".to_string() } else { driven.join(", ") }
                                ),
                            })
                        }
                        Err(several) => Err(Error::Model {
                            mechanism: mech.name.clone(),
                            message: format!(
                                "probe {kind:?}: joint `{name}` is driven by {} compliant meshes (gears {:?}): the \
                                 probe names one mesh by its driven joint",
                                several.len(),
                                several
                            ),
                        }),
                    };
                }
                ProbeKind::LargestJointAngle => return Ok(Probe::LargestJointAngle(j)),
                ProbeKind::JointForceRadial => return Ok(Probe::JointForceRadial(j)),
                ProbeKind::JointForceTangential => return Ok(Probe::JointForceTangential(j)),
                ProbeKind::JointMoment => return Ok(Probe::JointMoment(j)),
                _ => {}
            }
            if mech.follow_map()[j].is_none() {
                return Err(Error::Model {
                    mechanism: mech.name.clone(),
                    message: format!("probe {kind:?}: joint `{name}` is Fixed and has no coordinate"),
                });
            }
            return Ok(if kind == ProbeKind::JointAngle { Probe::JointAngle(j) } else { Probe::JointRate(j) });
        }
        let b = mech
            .body_index(name)
            .ok_or_else(|| unknown("body", mech.bodies.iter().map(|b| b.name.as_str()).collect()))?;
        Ok(match kind {
            ProbeKind::BodyAngle => Probe::BodyAngle(b),
            ProbeKind::BodyRate => Probe::BodyRate(b),
            _ => Probe::BodyAccel(b),
        })
    }

    /// What the probe measures.
    pub fn kind(&self) -> ProbeKind {
        match self {
            Probe::BodyAngle(_) => ProbeKind::BodyAngle,
            Probe::BodyRate(_) => ProbeKind::BodyRate,
            Probe::BodyAccel(_) => ProbeKind::BodyAccel,
            Probe::JointAngle(_) => ProbeKind::JointAngle,
            Probe::JointRate(_) => ProbeKind::JointRate,
            Probe::LargestJointAngle(_) => ProbeKind::LargestJointAngle,
            Probe::JointForceRadial(_) => ProbeKind::JointForceRadial,
            Probe::JointForceTangential(_) => ProbeKind::JointForceTangential,
            Probe::JointMoment(_) => ProbeKind::JointMoment,
            Probe::GearMeshTorque(_) => ProbeKind::GearMeshTorque,
        }
    }

    /// The body or joint index.
    pub fn index(&self) -> usize {
        match *self {
            Probe::BodyAngle(i)
            | Probe::BodyRate(i)
            | Probe::BodyAccel(i)
            | Probe::JointAngle(i)
            | Probe::JointRate(i)
            | Probe::LargestJointAngle(i)
            | Probe::JointForceRadial(i)
            | Probe::JointForceTangential(i)
            | Probe::JointMoment(i)
            | Probe::GearMeshTorque(i) => i,
        }
    }

    /// Whether the probe is a joint reaction.
    pub fn is_reaction(&self) -> bool {
        matches!(self, Probe::JointForceRadial(_) | Probe::JointForceTangential(_) | Probe::JointMoment(_))
    }

    /// Whether recording needs `ẋ` (an extra right-hand-side call per sample).
    pub fn needs_derivative(&self) -> bool {
        matches!(
            self,
            Probe::BodyAccel(_)
                | Probe::JointForceRadial(_)
                | Probe::JointForceTangential(_)
                | Probe::JointMoment(_)
                | Probe::GearMeshTorque(_)
        )
    }

    /// SI unit of the recorded values in `mech` (a slide's coordinate is in m).
    pub fn unit(&self, mech: &Mechanism) -> &'static str {
        let slides = |j: usize| mech.joints.get(j).is_some_and(|j| !j.kind.rotates());
        match *self {
            Probe::BodyAngle(_) | Probe::LargestJointAngle(_) => "rad",
            Probe::BodyRate(_) => "rad/s",
            Probe::BodyAccel(_) => "rad/s²",
            Probe::JointAngle(j) if slides(j) => "m",
            Probe::JointAngle(_) => "rad",
            Probe::JointRate(j) if slides(j) => "m/s",
            Probe::JointRate(_) => "rad/s",
            Probe::JointForceRadial(_) | Probe::JointForceTangential(_) => "N",
            Probe::JointMoment(_) => "N·m",
            Probe::GearMeshTorque(j) if slides(j) => "N",
            Probe::GearMeshTorque(_) => "N·m",
        }
    }

    /// Column name `<body>.angle`, `<body>.rate`, `<body>.accel`, `<joint>.q`, `<joint>.qdot` or
    /// `max_abs_q_except_<joint>`, `<joint>.force_radial`, `.force_tangential`, `.moment` or
    /// `.mesh_torque` (names not checked: use on the mechanism the probe was
    /// resolved in).
    pub fn label(&self, mech: &Mechanism) -> String {
        let body = |b: usize| mech.bodies.get(b).map_or("?", |b| b.name.as_str()).to_string();
        let joint = |j: usize| mech.joints.get(j).map_or("?", |j| j.name.as_str()).to_string();
        match *self {
            Probe::BodyAngle(b) => format!("{}.angle", body(b)),
            Probe::BodyRate(b) => format!("{}.rate", body(b)),
            Probe::BodyAccel(b) => format!("{}.accel", body(b)),
            Probe::JointAngle(j) => format!("{}.q", joint(j)),
            Probe::JointRate(j) => format!("{}.qdot", joint(j)),
            Probe::LargestJointAngle(j) => format!("max_abs_q_except_{}", joint(j)),
            Probe::JointForceRadial(j) => format!("{}.force_radial", joint(j)),
            Probe::JointForceTangential(j) => format!("{}.force_tangential", joint(j)),
            Probe::JointMoment(j) => format!("{}.moment", joint(j)),
            Probe::GearMeshTorque(j) => format!("{}.mesh_torque", joint(j)),
        }
    }
}

/// Turns sampled states into one row of values per sample, one per probe, kept in memory as
/// columns (plus the time column), or only handed on as the run goes ([`simulate_streamed`]):
/// [`Recorder::store_only`] names the columns kept, so a long run analysed as it goes does not
/// grow with its duration.
///
/// Times strictly increase: a sample closer than half a sample period to the last one is the
/// boundary of consecutive runs (see [`simulate`]) and is dropped, so a run continued in chunks
/// records the same columns as one run.
#[derive(Debug, Clone)]
pub struct Recorder {
    n: usize,
    absolute: bool,
    parents: Vec<Option<usize>>,
    probes: Vec<Probe>,
    /// Per probe: the (coordinate, factor) pairs whose weighted sum is its body's rotation
    /// ([`Mechanism::rotation_rates`]), its joint's one coordinate and factor for a joint probe
    /// (a rigidly driven joint's followed coordinate and gear factor), or the coordinates
    /// compared by [`Probe::LargestJointAngle`] (factor 1).
    paths: Vec<Vec<(usize, f64)>>,
    /// Per probe: the constant added to an angle (a driven joint's or its body's gear offsets).
    offsets: Vec<f64>,
    names: Vec<String>,
    units: Vec<&'static str>,
    /// The tree the reaction probes' Newton–Euler pass runs on (the unconstrained tree of a
    /// geared mechanism), kept only when a probe is a reaction.
    reactions: Option<Box<Mechanism>>,
    /// A geared mechanism's map to the expanded state ([`Mechanism::expansion`]).
    expansion: Vec<(usize, f64, f64)>,
    /// The engine whose constraint residual gives the mesh torques (only with a
    /// [`Probe::GearMeshTorque`]), and per probe the coupling it reads.
    mesh: Option<Box<Kane>>,
    mesh_gear: Vec<usize>,
    min_gap_s: f64,
    last_t: f64,
    /// Per probe: whether its column is kept (all by default, see [`Recorder::store_only`]).
    stored: Vec<bool>,
    /// Whether any column is kept (then the time column is).
    any_stored: bool,
    /// The last sample's values, one per probe.
    row: Vec<f64>,
    /// Sample times, s (empty when no column is kept).
    pub time: Vec<f64>,
    /// One column per probe, in the order given (empty for a column not kept).
    pub columns: Vec<Vec<f64>>,
}

impl Recorder {
    /// A recorder for `probes` on `mech`; refuses indices outside the mechanism.
    pub fn new(mech: &Mechanism, probes: &[Probe]) -> Result<Self> {
        let (n, nb) = (mech.ndof(), mech.bodies.len());
        let follow = mech.follow_map();
        let mut paths = Vec::with_capacity(probes.len());
        let mut offsets = Vec::with_capacity(probes.len());
        let mut mesh_gear = vec![usize::MAX; probes.len()];
        for (i, p) in probes.iter().enumerate() {
            let out_of_range = |what: &str| Error::Model {
                mechanism: mech.name.clone(),
                message: format!("probe {p:?}: {what} ({nb} bodies and joints)"),
            };
            if p.index() >= nb {
                return Err(out_of_range("index out of range"));
            }
            let mut offset = 0.0;
            paths.push(match *p {
                Probe::JointAngle(j) | Probe::JointRate(j) => {
                    let f = follow[j].ok_or_else(|| out_of_range("joint has no coordinate"))?;
                    offset = f.offset;
                    vec![(f.coordinate, f.factor)]
                }
                Probe::LargestJointAngle(j) => {
                    let own = mech.coordinate(j);
                    (0..n).filter(|&k| Some(k) != own).map(|k| (k, 1.0)).collect()
                }
                Probe::GearMeshTorque(j) => {
                    mesh_gear[i] = match mech.gear_driving(j) {
                        Ok(Some(g)) => g,
                        _ => return Err(out_of_range("no single gear drives this joint")),
                    };
                    Vec::new()
                }
                Probe::JointForceRadial(_) | Probe::JointForceTangential(_) | Probe::JointMoment(_) => Vec::new(),
                Probe::BodyAngle(b) | Probe::BodyRate(b) | Probe::BodyAccel(b) => {
                    if let Some(j) = mech.turning_path_above(b) {
                        let name = &mech.joints[j].name;
                        return Err(Error::Model {
                            mechanism: mech.name.clone(),
                            message: format!(
                                "probe {p:?}: the body turns with the path joint `{name}`, whose rotation law \
                                 body probes do not include yet"
                            ),
                        });
                    }
                    offset = mech.rotation_offset(b);
                    mech.rotation_rates(b)
                }
            });
            offsets.push(offset);
        }
        let geared = mech.is_geared();
        let reactions = probes
            .iter()
            .any(Probe::is_reaction)
            .then(|| Box::new(if geared { mech.expanded() } else { mech.clone() }));
        let mesh = match probes.iter().any(|p| matches!(p, Probe::GearMeshTorque(_))) {
            true => Some(Box::new(Kane::new(mech)?)),
            false => None,
        };
        Ok(Self {
            n,
            absolute: mech.speeds == Speeds::AbsoluteAngularVelocities,
            parents: mech.speed_parents(),
            probes: probes.to_vec(),
            paths,
            offsets,
            names: probes.iter().map(|p| p.label(mech)).collect(),
            units: probes.iter().map(|p| p.unit(mech)).collect(),
            reactions,
            expansion: if geared { mech.expansion() } else { Vec::new() },
            mesh,
            mesh_gear,
            min_gap_s: 0.0,
            last_t: f64::NEG_INFINITY,
            stored: vec![true; probes.len()],
            any_stored: true,
            row: vec![0.0; probes.len()],
            time: Vec::new(),
            columns: vec![Vec::new(); probes.len()],
        })
    }

    /// Keeps only the columns `keep` says (by column index; the time column is kept when any
    /// is): the others are computed at every sample and handed to [`simulate_streamed`]'s sink,
    /// but their columns stay empty. All columns are kept by default.
    pub fn store_only(&mut self, keep: impl Fn(usize) -> bool) {
        for (i, s) in self.stored.iter_mut().enumerate() {
            *s = keep(i);
            if !*s {
                self.columns[i] = Vec::new();
            }
        }
        self.any_stored = self.stored.iter().any(|&s| s);
        if !self.any_stored {
            self.time = Vec::new();
        }
    }

    /// Takes the joint torques of `kane` (an engine of the recorder's mechanism, as the run
    /// evaluates it) for the mesh-torque probes: a torque applied at a driven joint enters the
    /// constraint's balance there. [`simulate`] calls it with the engine it integrates; a run
    /// through another right-hand side (a [`crate::time::drive_laws::Drive`]) calls it with the
    /// engine's torques as that run applies them. No effect without a mesh-torque probe.
    pub fn use_torques_of(&mut self, kane: &Kane) {
        let Some(mesh) = self.mesh.as_deref_mut() else { return };
        let full = |k: &Kane| k.unconstrained().map(|u| u.joint_torques().to_vec()).unwrap_or_default();
        // A geared engine forwards every joint torque to its unconstrained tree: that list is
        // the whole set (the reduced one lacks the driven joints').
        for t in full(mesh) {
            mesh.set_joint_torque(t.joint, crate::model::excitation::Excitation::constant(0.0));
        }
        for t in full(kane) {
            mesh.set_joint_torque(t.joint, t.excitation);
        }
    }

    /// The probes, in column order.
    pub fn probes(&self) -> &[Probe] {
        &self.probes
    }

    /// Column names ([`Probe::label`]), in column order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Units of the columns ([`Probe::unit`]).
    pub fn units(&self) -> &[&'static str] {
        &self.units
    }

    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|i| self.columns[i].as_slice())
    }

    /// Whether any probe needs `ẋ`.
    pub fn needs_derivatives(&self) -> bool {
        self.probes.iter().any(Probe::needs_derivative)
    }

    /// Reserves room for `samples` more samples (a 240 s run at 2 kHz: 480,001).
    pub fn reserve(&mut self, samples: usize) {
        if self.any_stored {
            self.time.reserve(samples);
        }
        self.columns.iter_mut().zip(&self.stored).filter(|(_, s)| **s).for_each(|(c, _)| c.reserve(samples));
    }

    /// The value of probe `i` at time `t` and state `x` (and `xdot`; accelerations, reactions
    /// and mesh torques are NaN without it).
    pub fn value(&mut self, i: usize, t: f64, x: &[f64], xdot: Option<&[f64]>) -> f64 {
        let n = self.n;
        let path = &self.paths[i];
        // Absolute rate (or acceleration) of the probe's body from speeds (or their rates) `v`.
        // With absolute angular velocities the last rotating joint's speed is the body's own
        // (no couplings then: every factor is 1).
        let absolute = |v: &[f64]| {
            if self.absolute {
                path.last().map_or(0.0, |&(k, _)| v[k])
            } else {
                path.iter().map(|&(k, a)| a * v[k]).sum()
            }
        };
        match self.probes[i] {
            Probe::BodyAngle(_) => path.iter().map(|&(k, a)| a * x[k]).sum::<f64>() + self.offsets[i],
            Probe::BodyRate(_) => absolute(&x[n..2 * n]),
            Probe::BodyAccel(_) => xdot.map_or(f64::NAN, |d| absolute(&d[n..2 * n])),
            Probe::JointAngle(_) => path[0].1 * x[path[0].0] + self.offsets[i],
            Probe::JointRate(_) => {
                // q̇_k = (W⁻¹u)_k, row k of Speeds::qdot; a driven joint's is factor · q̇_k.
                let (k, a) = path[0];
                let parent = if self.absolute { self.parents[k] } else { None };
                a * (x[n + k] - parent.map_or(0.0, |p| x[n + p]))
            }
            Probe::LargestJointAngle(_) => path.iter().map(|&(k, _)| x[k].abs()).fold(0.0, f64::max),
            Probe::JointForceRadial(j) | Probe::JointForceTangential(j) | Probe::JointMoment(j) => {
                let (Some(mech), Some(d)) = (&self.reactions, xdot) else { return f64::NAN };
                let mut qdot = vec![0.0; n];
                let mut qddot = vec![0.0; n];
                // W is constant for both speed choices: q̈ = W⁻¹u̇.
                if self.absolute {
                    crate::model::speeds::Speeds::AbsoluteAngularVelocities.qdot(
                        &self.parents,
                        &x[n..2 * n],
                        &mut qdot,
                    );
                    crate::model::speeds::Speeds::AbsoluteAngularVelocities.qdot(
                        &self.parents,
                        &d[n..2 * n],
                        &mut qddot,
                    );
                } else {
                    qdot.copy_from_slice(&x[n..2 * n]);
                    qddot.copy_from_slice(&d[n..2 * n]);
                }
                let r = if self.expansion.is_empty() {
                    crate::kane::reactions::tree_reactions(mech, &x[..n], &qdot, &qddot)[j]
                } else {
                    // Couplings need joint rates, so q̇ = u and q̈ = u̇ here.
                    let e = &self.expansion;
                    let qf: Vec<f64> = e.iter().map(|&(k, a, o)| a * x[k] + o).collect();
                    let qdf: Vec<f64> = e.iter().map(|&(k, a, _)| a * qdot[k]).collect();
                    let qddf: Vec<f64> = e.iter().map(|&(k, a, _)| a * qddot[k]).collect();
                    crate::kane::reactions::tree_reactions(mech, &qf, &qdf, &qddf)[j]
                };
                match self.probes[i] {
                    Probe::JointForceRadial(_) => r.radial,
                    Probe::JointForceTangential(_) => r.tangential,
                    _ => r.moment,
                }
            }
            Probe::GearMeshTorque(_) => {
                let (Some(kane), Some(d)) = (self.mesh.as_deref_mut(), xdot) else { return f64::NAN };
                kane.gear_torques(t, &x[..n], &x[n..2 * n], &d[n..2 * n])
                    .get(self.mesh_gear[i])
                    .copied()
                    .unwrap_or(f64::NAN)
            }
        }
    }

    /// Appends one sample to the kept columns and returns its values, one per probe (`None`
    /// when the sample repeats the last one and is dropped, see the type's doc).
    pub fn record(&mut self, t: f64, x: &[f64], xdot: Option<&[f64]>) -> Option<&[f64]> {
        if t <= self.last_t + self.min_gap_s {
            return None;
        }
        self.last_t = t;
        if !self.any_stored {
            for i in 0..self.probes.len() {
                self.row[i] = self.value(i, t, x, xdot);
            }
            return Some(&self.row);
        }
        self.time.push(t);
        for i in 0..self.probes.len() {
            let v = self.value(i, t, x, xdot);
            self.row[i] = v;
            if self.stored[i] {
                self.columns[i].push(v);
            }
        }
        Some(&self.row)
    }

    /// Drops all but the last `keep` samples (a long run analysed window by window stays
    /// bounded in memory).
    pub fn keep_last(&mut self, keep: usize) {
        for v in std::iter::once(&mut self.time).chain(self.columns.iter_mut()) {
            if v.len() > keep {
                v.drain(..v.len() - keep);
            }
        }
    }
}

/// How one run ended, with its counters (or the sum over consecutive chunks, see
/// [`Outcome::absorb`]). Serialised (study results) with the error as its message.
#[derive(Debug, Clone, Default, Serialize, schemars::JsonSchema)]
pub struct Outcome {
    /// Integration counters (also on failure).
    pub stats: IntegrateStats,
    /// Wall-clock time, s.
    pub wall_s: f64,
    /// Time reached, s (the end time when the run completed).
    pub t_end: f64,
    /// State at the end time when the run completed.
    pub x_end: Option<Vec<f64>>,
    /// Why the run ended early, if it did (its message); the samples recorded up to there are
    /// kept.
    #[serde(serialize_with = "message_or_none")]
    #[schemars(with = "Option<String>")]
    pub error: Option<IntegrateError>,
    /// Which integrator ran and why, when a study chose it (`None` outside studies).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrator: Option<crate::time::integrate::IntegratorChoice>,
}

/// An optional error as its message (`None` stays `None`).
fn message_or_none<S: serde::Serializer>(e: &Option<IntegrateError>, s: S) -> std::result::Result<S::Ok, S::Error> {
    match e {
        Some(e) => s.serialize_some(&e.to_string()),
        None => s.serialize_none(),
    }
}

impl Outcome {
    /// Right-hand-side evaluations by the integrator plus those at the samples.
    pub fn rhs_evals(&self) -> usize {
        self.stats.rhs_evals + self.stats.sample_rhs_evals
    }

    /// Adds a later chunk's counters and takes its end state and outcome.
    pub fn absorb(&mut self, later: &Outcome) {
        let (s, c) = (&mut self.stats, &later.stats);
        s.accepted += c.accepted;
        s.rejected += c.rejected;
        s.rhs_evals += c.rhs_evals;
        s.sample_rhs_evals += c.sample_rhs_evals;
        s.samples += c.samples;
        s.method = c.method;
        self.wall_s += later.wall_s;
        self.t_end = later.t_end;
        self.x_end.clone_from(&later.x_end);
        if later.error.is_some() {
            self.error.clone_from(&later.error);
        }
    }
}

/// Integrates `kane` from `x0 = [q; u]` at `t0` to `t1` with DOP853 (see
/// [`crate::time::integrate::integrate`]) and records the probes of `rec` at
/// `opts.sample_rate_hz` (2 kHz by default; `ẋ` is evaluated at the samples when a probe needs
/// it, whatever `opts.sample_derivatives` says). `progress` is told the simulated time about ten
/// times per simulated second. Never fails: a failed run keeps the samples recorded before the
/// failure and names it in [`Outcome::error`]; a wrong `x0` records nothing and gives an
/// `InvalidInput` error. A run continued from the end of another into the same recorder adds
/// the new samples only.
pub fn simulate(
    kane: &mut Kane,
    x0: &[f64],
    t0: f64,
    t1: f64,
    opts: &IntegrateOptions,
    rec: &mut Recorder,
    progress: &mut dyn FnMut(f64),
) -> Outcome {
    simulate_streamed(kane, x0, t0, t1, opts, rec, &mut |_, _| {}, progress)
}

/// [`simulate`] that also hands every recorded sample to `sink` as it is taken: its time and
/// its values, one per probe (kept in `rec`'s columns or not, see [`Recorder::store_only`]). A
/// caller that analyses the samples in `sink` keeps no column and its memory does not grow with
/// the run's length.
#[allow(clippy::too_many_arguments)]
pub fn simulate_streamed(
    kane: &mut Kane,
    x0: &[f64],
    t0: f64,
    t1: f64,
    opts: &IntegrateOptions,
    rec: &mut Recorder,
    sink: &mut dyn FnMut(f64, &[f64]),
    progress: &mut dyn FnMut(f64),
) -> Outcome {
    let n = kane.ndof();
    rec.use_torques_of(kane);
    simulate_rhs_streamed(|t, x, dx| kane.rhs(t, x, dx), n, x0, t0, t1, opts, rec, sink, progress)
}

/// [`simulate`] for any right-hand side of a mechanism with `n` degrees of freedom, such as a
/// [`crate::time::drive_laws::Drive`]'s.
#[allow(clippy::too_many_arguments)]
pub fn simulate_rhs(
    rhs: impl FnMut(f64, &[f64], &mut [f64]) -> std::result::Result<(), crate::error::EngineError>,
    n: usize,
    x0: &[f64],
    t0: f64,
    t1: f64,
    opts: &IntegrateOptions,
    rec: &mut Recorder,
    progress: &mut dyn FnMut(f64),
) -> Outcome {
    simulate_rhs_streamed(rhs, n, x0, t0, t1, opts, rec, &mut |_, _| {}, progress)
}

/// [`simulate_rhs`] with a sink for every recorded sample, as [`simulate_streamed`].
#[allow(clippy::too_many_arguments)]
pub fn simulate_rhs_streamed(
    mut rhs: impl FnMut(f64, &[f64], &mut [f64]) -> std::result::Result<(), crate::error::EngineError>,
    n: usize,
    x0: &[f64],
    t0: f64,
    t1: f64,
    opts: &IntegrateOptions,
    rec: &mut Recorder,
    sink: &mut dyn FnMut(f64, &[f64]),
    progress: &mut dyn FnMut(f64),
) -> Outcome {
    let start = std::time::Instant::now();
    if x0.len() != 2 * n {
        let message = format!("x0 has length {}, the mechanism needs 2n = {}", x0.len(), 2 * n);
        return Outcome { t_end: t0, error: Some(IntegrateError::InvalidInput { message }), ..Outcome::default() };
    }
    let mut opts = opts.clone();
    opts.sample_derivatives |= rec.needs_derivatives();
    let mut tick = usize::MAX;
    if let Some(fs) = opts.sample_rate_hz
        && fs.is_finite()
        && fs > 0.0
    {
        rec.min_gap_s = 0.5 / fs;
        tick = (fs as usize / 10).max(1);
        if t1 > t0 {
            rec.reserve(((t1 - t0) * fs) as usize + 2);
        }
    }
    let run = integrate(&mut rhs, x0, t0, t1, &opts, |s| {
        if let Some(row) = rec.record(s.t, s.x, s.xdot) {
            sink(s.t, row);
        }
        if s.k.is_multiple_of(tick) {
            progress(s.t);
        }
    });
    let wall_s = start.elapsed().as_secs_f64();
    match run {
        Ok(done) => Outcome {
            stats: done.stats,
            wall_s,
            t_end: done.t_end,
            x_end: Some(done.x_end),
            error: None,
            integrator: None,
        },
        Err(e) => {
            Outcome { stats: e.stats(), wall_s, t_end: e.t_reached(), x_end: None, error: Some(e), integrator: None }
        }
    }
}

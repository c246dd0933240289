//! Named signals of a simulation (probes), a recorder that turns sampled states into columns,
//! and [`simulate`]: integrate a [`Kane`] engine and record its probes at the sample rate.
//!
//! A probe is resolved once against a [`Mechanism`] by body or joint name; recording is then
//! index arithmetic on the state `x = [q; u]` (and `ẋ` for accelerations):
//! - body angle `β_b = Σ q_k` over the rotating joints k on the path root → b
//!   ([`Mechanism::rotation_coordinates`]: angles add along the tree, slides and welds turn nothing);
//! - body rate `ω_b`: `u_b` itself for absolute angular velocities as speeds on a revolute body,
//!   else `Σ q̇_k` over the same joints with `q̇ = W⁻¹u`;
//! - body acceleration `ω̇_b`: the same with `u̇` (W is constant for both speed choices, so no
//!   `Ẇ` term); it needs `ẋ` at the sample state, one extra right-hand-side call per sample;
//! - joint angle: the joint's own coordinate `q_j` (the pendulum's φ; m for a slide).
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
    /// Relative angle q of a joint (child relative to parent), rad.
    JointAngle,
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
    /// Relative angle q of joint `j`, rad.
    JointAngle(usize),
}

impl Probe {
    /// Resolves `kind` on the body or joint called `name` in `mech`; an unknown name is an error
    /// that lists the known ones.
    pub fn resolve(mech: &Mechanism, kind: ProbeKind, name: &str) -> Result<Probe> {
        let unknown = |what: &str, known: Vec<&str>| Error::Model {
            mechanism: mech.name.clone(),
            message: format!("probe {kind:?}: unknown {what} `{name}` (known {what}s: {})", known.join(", ")),
        };
        if kind == ProbeKind::JointAngle {
            let j = mech
                .joint_index(name)
                .ok_or_else(|| unknown("joint", mech.joints.iter().map(|j| j.name.as_str()).collect()))?;
            if mech.coordinate(j).is_none() {
                return Err(Error::Model {
                    mechanism: mech.name.clone(),
                    message: format!("probe {kind:?}: joint `{name}` is Fixed and has no coordinate"),
                });
            }
            return Ok(Probe::JointAngle(j));
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
        }
    }

    /// The body or joint index.
    pub fn index(&self) -> usize {
        match *self {
            Probe::BodyAngle(i) | Probe::BodyRate(i) | Probe::BodyAccel(i) | Probe::JointAngle(i) => i,
        }
    }

    /// Whether recording needs `ẋ` (an extra right-hand-side call per sample).
    pub fn needs_derivative(&self) -> bool {
        matches!(self, Probe::BodyAccel(_))
    }

    /// SI unit of the recorded values.
    pub fn unit(&self) -> &'static str {
        match self {
            Probe::BodyAngle(_) | Probe::JointAngle(_) => "rad",
            Probe::BodyRate(_) => "rad/s",
            Probe::BodyAccel(_) => "rad/s²",
        }
    }

    /// Column name `<body>.angle`, `<body>.rate`, `<body>.accel` or `<joint>.q` (names not
    /// checked: use on the mechanism the probe was resolved in).
    pub fn label(&self, mech: &Mechanism) -> String {
        let body = |b: usize| mech.bodies.get(b).map_or("?", |b| b.name.as_str()).to_string();
        match *self {
            Probe::BodyAngle(b) => format!("{}.angle", body(b)),
            Probe::BodyRate(b) => format!("{}.rate", body(b)),
            Probe::BodyAccel(b) => format!("{}.accel", body(b)),
            Probe::JointAngle(j) => format!("{}.q", mech.joints.get(j).map_or("?", |j| j.name.as_str())),
        }
    }
}

/// Turns sampled states into one column per probe (plus the time column), kept in memory.
#[derive(Debug, Clone)]
pub struct Recorder {
    n: usize,
    absolute: bool,
    probes: Vec<Probe>,
    /// Per probe: the coordinates whose sum is its body's rotation
    /// ([`Mechanism::rotation_coordinates`]), or its joint's one coordinate for a joint probe.
    paths: Vec<Vec<usize>>,
    /// Sample times, s.
    pub time: Vec<f64>,
    /// One column per probe, in the order given.
    pub columns: Vec<Vec<f64>>,
}

impl Recorder {
    /// A recorder for `probes` on `mech`; refuses indices outside the mechanism.
    pub fn new(mech: &Mechanism, probes: &[Probe]) -> Result<Self> {
        let (n, nb) = (mech.ndof(), mech.bodies.len());
        let mut paths = Vec::with_capacity(probes.len());
        for p in probes {
            let out_of_range = |what: &str| Error::Model {
                mechanism: mech.name.clone(),
                message: format!("probe {p:?}: {what} ({nb} bodies and joints)"),
            };
            if p.index() >= nb {
                return Err(out_of_range("index out of range"));
            }
            paths.push(match p {
                Probe::JointAngle(j) => {
                    vec![mech.coordinate(*j).ok_or_else(|| out_of_range("joint has no coordinate"))?]
                }
                _ => mech.rotation_coordinates(p.index()),
            });
        }
        Ok(Self {
            n,
            absolute: mech.speeds == Speeds::AbsoluteAngularVelocities,
            probes: probes.to_vec(),
            paths,
            time: Vec::new(),
            columns: vec![Vec::new(); probes.len()],
        })
    }

    /// Whether any probe needs `ẋ`.
    pub fn needs_derivatives(&self) -> bool {
        self.probes.iter().any(Probe::needs_derivative)
    }

    /// Reserves room for `samples` more samples (a 240 s run at 2 kHz: 480,001).
    pub fn reserve(&mut self, samples: usize) {
        self.time.reserve(samples);
        self.columns.iter_mut().for_each(|c| c.reserve(samples));
    }

    /// The value of probe `i` at state `x` (and `xdot`; accelerations are NaN without it).
    pub fn value(&self, i: usize, x: &[f64], xdot: Option<&[f64]>) -> f64 {
        let n = self.n;
        // Absolute rate (or acceleration) of the probe's body from speeds (or their rates) `v`.
        // With absolute angular velocities the last rotating joint's speed is the body's own.
        let absolute = |v: &[f64]| {
            let path = &self.paths[i];
            if self.absolute { path.last().map_or(0.0, |&k| v[k]) } else { path.iter().map(|&k| v[k]).sum() }
        };
        match self.probes[i] {
            Probe::BodyAngle(_) => self.paths[i].iter().map(|&k| x[k]).sum(),
            Probe::BodyRate(_) => absolute(&x[n..2 * n]),
            Probe::BodyAccel(_) => xdot.map_or(f64::NAN, |d| absolute(&d[n..2 * n])),
            Probe::JointAngle(_) => x[self.paths[i][0]],
        }
    }

    /// Appends one sample.
    pub fn record(&mut self, t: f64, x: &[f64], xdot: Option<&[f64]>) {
        self.time.push(t);
        for i in 0..self.probes.len() {
            let v = self.value(i, x, xdot);
            self.columns[i].push(v);
        }
    }
}

/// The recorded signals of one run; partial (up to the failure) when `error` is set.
#[derive(Debug, Clone)]
pub struct SimResult {
    /// Sample times, s.
    pub time: Vec<f64>,
    /// One column per probe, same length as `time`.
    pub columns: Vec<Vec<f64>>,
    /// Column names ([`Probe::label`]), same order as `columns`.
    pub names: Vec<String>,
    /// Units of the columns ([`Probe::unit`]).
    pub units: Vec<&'static str>,
    /// Integration counters (also on failure).
    pub stats: IntegrateStats,
    /// State at the end time t1 when the run completed.
    pub x_end: Option<Vec<f64>>,
    /// Why the run ended early, if it did.
    pub error: Option<IntegrateError>,
}

impl SimResult {
    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.names.iter().position(|n| n == name).map(|i| self.columns[i].as_slice())
    }
}

/// Integrates `kane` from `x0 = [q; u]` at `t0` to `t1` with DOP853 (see
/// [`crate::time::integrate::integrate`]) and records `probes` at `opts.sample_rate_hz` (2 kHz by
/// default; `ẋ` is evaluated at the samples when a probe needs it, whatever
/// `opts.sample_derivatives` says). A failed run keeps the samples recorded before the failure
/// and names it in [`SimResult::error`]; probes that do not fit the mechanism, or a wrong `x0`,
/// give an empty result with an `InvalidInput` error.
pub fn simulate(kane: &mut Kane, x0: &[f64], t0: f64, t1: f64, opts: &IntegrateOptions, probes: &[Probe]) -> SimResult {
    let mech = kane.mechanism();
    let names = probes.iter().map(|p| p.label(mech)).collect();
    let units = probes.iter().map(Probe::unit).collect();
    let mut out = SimResult {
        time: Vec::new(),
        columns: vec![Vec::new(); probes.len()],
        names,
        units,
        stats: IntegrateStats::default(),
        x_end: None,
        error: None,
    };
    let invalid = |message: String| Some(IntegrateError::InvalidInput { message });
    let mut rec = match Recorder::new(mech, probes) {
        Ok(r) => r,
        Err(e) => {
            out.error = invalid(e.to_string());
            return out;
        }
    };
    if x0.len() != 2 * kane.ndof() {
        out.error = invalid(format!("x0 has length {}, the mechanism needs 2n = {}", x0.len(), 2 * kane.ndof()));
        return out;
    }
    let mut opts = opts.clone();
    opts.sample_derivatives |= rec.needs_derivatives();
    if let Some(fs) = opts.sample_rate_hz
        && fs.is_finite()
        && t1 > t0
    {
        rec.reserve(((t1 - t0) * fs) as usize + 2);
    }
    let run = integrate(|t, x, dx| kane.rhs(t, x, dx), x0, t0, t1, &opts, |s| rec.record(s.t, s.x, s.xdot));
    match run {
        Ok(done) => {
            out.stats = done.stats;
            out.x_end = Some(done.x_end);
        }
        Err(e) => {
            out.stats = e.stats();
            out.error = Some(e);
        }
    }
    out.time = rec.time;
    out.columns = rec.columns;
    out
}

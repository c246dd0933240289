//! The physical ranges a mechanism's numbers must lie in, beyond "finite and positive": each is
//! generous for any real driveline or absorber, and excludes values that only make the solvers
//! loop without end or divide by nothing (issue 25: a gear ratio of 1e-300 passed and a linear
//! response then never finished; an epicycloid order ñ of 1e9, a bifilar length of 1e-300 and a
//! roller count of 1e9 were accepted without a word). Every check that uses one states the range
//! in its error; the user guide's "Limits and errors" (`docs/guide/src/limits.md`) lists them.

use std::ops::RangeInclusive;

/// Magnitude of a gear or fixed-ratio coupling's ratio `q̇_joint / q̇_follows`: a real gear
/// stage lies within 1/100..100; beyond 1e6 the geared inertias differ by more than 1e12, past
/// what the mass matrix's 16 digits can hold.
pub const GEAR_RATIO: RangeInclusive<f64> = 1e-6..=1e6;

/// Lengths of a path's geometry (pivot radius R, path radius L, vertex radius ρ₀), m: a micron to
/// a kilometre.
pub const PATH_LENGTH_M: RangeInclusive<f64> = 1e-6..=1e3;

/// A path's order ñ: tuning orders of absorbers lie near the engine orders (½ to ~20); the upper
/// end is the highest excitation order a study accepts (`study::validate::MAX_ORDER`).
pub const PATH_ORDER: RangeInclusive<f64> = 1e-3..=1e3;

/// Most rollers of one roller set: an absorber runs on one to four; the count only scales the
/// rollers' mass and inertia, so a thousand rollers is a data error, not a design.
pub const MAX_ROLLERS: u32 = 100;

/// The smoothing rate ε of a friction element, rad/s or m/s: `tanh(q̇/ε)` turns a slip of ε into
/// full friction, so ε sets a damping of `T/ε`; below 1e-6 the equations become so stiff that
/// an explicit integrator needs a step per nanosecond.
pub const FRICTION_SMOOTHING: RangeInclusive<f64> = 1e-6..=1e3;

/// Largest jump of a pressure table across its 720° → 0° seam, as a multiple of the steepest
/// step between neighbouring points inside the table (bar per degree, times the seam's angular
/// gap): the periodic spline closes any gap, so a table that does not join would be closed by a
/// made-up swing.
pub const PRESSURE_SEAM_FACTOR: f64 = 2.0;

/// Whether `v` is finite and inside `range`.
pub fn within(v: f64, range: &RangeInclusive<f64>) -> bool {
    v.is_finite() && range.contains(&v)
}

/// A range for a message: `1e-6..=1e6`.
pub fn show(range: &RangeInclusive<f64>) -> String {
    format!("{:e}..={:e}", range.start(), range.end())
}

/// Highest natural frequency `√(k/J)/2π` of one spring, stage, end stop or mesh on the inertia it
/// moves, Hz: the stiffest contacts and meshes of real drivelines and absorbers ring at tens of
/// kHz; a megahertz means a stiffness or an inertia in the wrong units, and would hold an
/// explicit integrator to sub-microsecond steps.
pub const MAX_NATURAL_HZ: f64 = 1e6;

/// Highest decay rate `c/J` of one damper on the inertia it moves, 1/s (a time constant of
/// 10 ns): a shaft damper of 1e9 N·m·s/rad on a flywheel decays in well under a nanosecond, which
/// no driveline does, and made a 2 s transient planned at 0.01 s run for minutes.
pub const MAX_DECAY_RATE: f64 = 1e8;

/// One stiffness or damping of a mechanism and the time scale it sets on the inertia it acts on.
#[derive(Debug, Clone, PartialEq)]
pub struct TimeScale {
    /// Which element, as the mechanism file names its field (`joints[2].damper`, …), with the
    /// joint index in tree order (the loader maps it to the file's).
    pub element: Element,
    /// The stiffness (N·m/rad or N/m) or damping (N·m·s/rad or N·s/m) as given.
    pub coefficient: f64,
    /// The compliance it meets, `aᵀM⁻¹a` at q = 0 (1/(kg·m²) or 1/kg).
    pub compliance: f64,
}

/// The element behind a [`TimeScale`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Element {
    /// A joint's linear spring (tree index).
    Spring(usize),
    /// A staged spring's stage: joint, `coast` side, stage index.
    Stage(usize, bool, usize),
    /// A joint's end-stop contact stiffness.
    StopStiffness(usize),
    /// A joint's end-stop contact damping.
    StopDamping(usize),
    /// A joint's friction, as the damping `torque / smoothing` it has near zero slip.
    Friction(usize),
    /// A joint's viscous damper.
    Damper(usize),
    /// A compliant mesh's stiffness (gear index).
    MeshStiffness(usize),
    /// A compliant mesh's damping (gear index).
    MeshDamping(usize),
    /// A ground damper (its index among the mechanism's ground dampers).
    GroundDamper(usize),
}

impl TimeScale {
    /// Whether the element is a stiffness (its scale a natural frequency) rather than a damping
    /// (a decay rate).
    pub fn is_stiffness(&self) -> bool {
        matches!(
            self.element,
            Element::Spring(_) | Element::Stage(..) | Element::StopStiffness(_) | Element::MeshStiffness(_)
        )
    }

    /// The natural frequency, Hz, of a stiffness; the decay rate, 1/s, of a damping.
    pub fn rate(&self) -> f64 {
        let c = (self.coefficient * self.compliance).max(0.0);
        if self.is_stiffness() { c.sqrt() / (2.0 * std::f64::consts::PI) } else { c }
    }

    /// The largest rate this kind of element may reach ([`MAX_NATURAL_HZ`] or [`MAX_DECAY_RATE`]).
    pub fn limit(&self) -> f64 {
        if self.is_stiffness() { MAX_NATURAL_HZ } else { MAX_DECAY_RATE }
    }

    /// The largest coefficient that keeps this element within [`TimeScale::limit`] on the same
    /// inertia.
    pub fn largest_coefficient(&self) -> f64 {
        let l = self.limit();
        let c = if self.is_stiffness() { (2.0 * std::f64::consts::PI * l).powi(2) } else { l };
        c / self.compliance
    }
}

/// The diagonal of M⁻¹ at a mass matrix `m` (symmetric positive definite), by Cholesky: the
/// compliance a force on each coordinate meets. `None` when `m` is not positive definite or has
/// more than 1000 coordinates (the O(n³) inverse would outweigh what it checks).
pub fn compliances(m: &nalgebra::DMatrix<f64>) -> Option<Vec<f64>> {
    let n = m.nrows();
    if n > 1000 {
        return None;
    }
    let chol = m.clone().cholesky()?;
    let mut e = nalgebra::DVector::zeros(n);
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        e.fill(0.0);
        e[k] = 1.0;
        out.push(chol.solve(&e)[k].max(0.0));
    }
    Some(out)
}

/// Every stiffness and damping of `mech` with the compliance it meets (`diag`: the diagonal of
/// M⁻¹ at q = 0, [`compliances`]). A coarse bound, not an eigen-analysis: a mesh between two
/// coordinates meets `(√c₁ + |r|√c₂)²`, an upper bound of `aᵀM⁻¹a`.
pub fn time_scales(mech: &super::mechanism::Mechanism, diag: &[f64]) -> Vec<TimeScale> {
    let mut out = Vec::new();
    let c = |k: Option<usize>| k.and_then(|k| diag.get(k).copied()).unwrap_or(0.0);
    for (j, joint) in mech.joints.iter().enumerate() {
        let compliance = c(joint.coordinate);
        if compliance == 0.0 {
            continue;
        }
        let mut push = |element, coefficient: f64| {
            if coefficient > 0.0 {
                out.push(TimeScale { element, coefficient, compliance });
            }
        };
        if let Some(s) = joint.spring {
            push(Element::Spring(j), s.stiffness);
        }
        push(Element::Damper(j), joint.damper);
        let cp = &joint.couplings;
        if let Some(st) = &cp.stages {
            for (i, s) in st.drive.iter().enumerate() {
                push(Element::Stage(j, false, i), s.stiffness);
            }
            for (i, s) in st.coast.iter().flatten().enumerate() {
                push(Element::Stage(j, true, i), s.stiffness);
            }
        }
        if let Some(s) = &cp.stops {
            push(Element::StopStiffness(j), s.stiffness);
            push(Element::StopDamping(j), s.damping);
        }
        if let Some(f) = &cp.friction {
            push(Element::Friction(j), f.torque / f.smoothing);
        }
    }
    for (g, gear) in mech.gears.iter().enumerate() {
        let Some(mesh) = gear.mesh else { continue };
        let (a, b) = (c(mech.joints[gear.joint].coordinate), c(mech.joints[gear.follows].coordinate));
        let compliance = (a.sqrt() + gear.ratio.abs() * b.sqrt()).powi(2);
        for (element, coefficient) in
            [(Element::MeshStiffness(g), mesh.stiffness), (Element::MeshDamping(g), mesh.damping)]
        {
            if coefficient > 0.0 && compliance > 0.0 {
                out.push(TimeScale { element, coefficient, compliance });
            }
        }
    }
    for (i, gd) in mech.loads.ground_dampers.iter().enumerate() {
        let compliance = c(mech.joints.get(gd.body).and_then(|j| j.coordinate));
        if gd.c > 0.0 && compliance > 0.0 {
            out.push(TimeScale { element: Element::GroundDamper(i), coefficient: gd.c, compliance });
        }
    }
    out
}

//! The time scale each stiffness and damping of a mechanism sets on the inertia it moves: a
//! natural frequency `√(k·c)/2π` or a decay rate `d·c`, with `c = aᵀM⁻¹a` the compliance at
//! q = 0 along the element's coordinate (M from the engine at rest). The loader refuses a scale
//! outside [`super::ranges::MAX_NATURAL_HZ`] / [`super::ranges::MAX_DECAY_RATE`], and the study's
//! plan reads the fastest ones to see a stiff model.

use super::ranges::{MAX_DECAY_RATE, MAX_NATURAL_HZ};

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

/// The diagonal of the inverse joint-coordinate mass matrix at `m`, the mass matrix of `mech` in
/// its speeds (symmetric positive definite), by Cholesky: the compliance a torque (or force) on
/// each joint coordinate meets. With absolute angular velocities as speeds (`u = W q̇`) the
/// coordinates' mass matrix is `Wᵀ M W`; reading `M⁻¹` directly would give the compliance of a
/// body's absolute rotation, which misses the light body on the other side of a shaft (a stiff
/// shaft damper after a 0.5 kg·m² hub was planned at a fifth of the steps it took). `None` when
/// the matrix is not positive definite or has more than 1000 coordinates (the O(n³) inverse would
/// outweigh what it checks).
pub fn compliances(mech: &super::mechanism::Mechanism, m: &nalgebra::DMatrix<f64>) -> Option<Vec<f64>> {
    let n = m.nrows();
    if n > 1000 {
        return None;
    }
    let chol = if mech.speeds == super::speeds::Speeds::AbsoluteAngularVelocities {
        let w = mech.speeds.w_matrix(&mech.speed_parents());
        (w.transpose() * m * &w).cholesky()?
    } else {
        m.clone().cholesky()?
    };
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

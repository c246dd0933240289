//! The linear torque an element transmits, as a combination of the independent coordinates and
//! their rates: a joint's own spring and damper, and the compliant mesh that drives it, if any.
//! A shaft written as a mesh of ratio 1 between two gears (examples/marine_driveline.ron) has no
//! spring on its joint: its torque is the mesh's, and without the mesh term it would read zero.

use crate::model::mechanism::Mechanism;

/// `T = Σ (k_i q_i + c_i q̇_i) + constant` over independent coordinates `q_i`: the torque joint
/// `j`'s spring and damper transmit (`k (q_j − q_free) + c q̇_j`, N·m; N for a slide), plus, when
/// a compliant mesh drives `j`, the torque the mesh transmits to it, `−(k_m δ + c_m δ̇)/r` with
/// `δ = q_follows − (q_j − offset)/r` (the mesh's generalized force on `q_j` reversed, as for a
/// spring: a mesh of ratio 1 from shaft A to shaft B reads `k_m (q_B − q_A)`, a joint spring's
/// sign with A as the parent).
#[derive(Debug, Clone, PartialEq)]
pub struct ElementLaw {
    /// `(coordinate, k, c)`: stiffness N·m/rad (N/m) and damping N·m·s/rad (N·s/m) on that
    /// independent coordinate, one entry per coordinate.
    pub terms: Vec<(usize, f64, f64)>,
    /// The constant part (a preload), N·m (N).
    pub constant: f64,
}

impl ElementLaw {
    /// The torque at the independent coordinates `q` and rates `qd`, N·m (N).
    pub fn at(&self, q: &[f64], qd: &[f64]) -> f64 {
        self.terms.iter().map(|&(i, k, c)| k * q[i] + c * qd[i]).sum::<f64>() + self.constant
    }

    /// The complex amplitude at circular frequency `w` (rad/s) of the oscillation whose
    /// coordinates' complex amplitudes are `q`: `Σ (k_i + i w c_i) q̂_i`.
    pub fn phasor(&self, q: &[super::C64], w: f64) -> super::C64 {
        self.terms.iter().map(|&(i, k, c)| super::C64::new(k, w * c) * q[i]).sum()
    }

    fn add(&mut self, coordinate: usize, k: f64, c: f64) {
        match self.terms.iter_mut().find(|t| t.0 == coordinate) {
            Some(t) => {
                t.1 += k;
                t.2 += c;
            }
            None => self.terms.push((coordinate, k, c)),
        }
    }
}

/// Joint `j`'s [`ElementLaw`] in mechanism `mech` (its dampers and the mesh's left out when
/// `dampers` is false: modal damping replaces them); None when the joint has neither a spring,
/// a damper nor a driving compliant mesh, or is Fixed. Nonlinear couplings (staged springs,
/// friction, stops) are not part of it.
pub fn element_law(mech: &Mechanism, j: usize, dampers: bool) -> Option<ElementLaw> {
    let map = mech.follow_map();
    let fj = map[j]?;
    let joint = &mech.joints[j];
    let (k, free) = joint.spring.map_or((0.0, 0.0), |s| (s.stiffness, s.free_angle));
    let c = if dampers { joint.damper } else { 0.0 };
    let mut law = ElementLaw { terms: Vec::new(), constant: 0.0 };
    if k != 0.0 || c != 0.0 {
        // q_j = a q_i + offset.
        law.add(fj.coordinate, fj.factor * k, fj.factor * c);
        law.constant += k * (fj.offset - free);
    }
    for g in mech.gears.iter().filter(|g| g.joint == j) {
        let (Some(mesh), Some(ff)) = (g.mesh, map[g.follows]) else { continue };
        let (km, cm, r) = (mesh.stiffness, if dampers { mesh.damping } else { 0.0 }, g.ratio);
        // T = −(k_m δ + c_m δ̇)/r, δ = (a_f q_f + o_f) − (a_j q_j + o_j − offset)/r.
        law.add(ff.coordinate, -km * ff.factor / r, -cm * ff.factor / r);
        law.add(fj.coordinate, km * fj.factor / (r * r), cm * fj.factor / (r * r));
        law.constant -= km / r * (ff.offset - (fj.offset - g.offset) / r);
    }
    (!law.terms.is_empty()).then_some(law)
}

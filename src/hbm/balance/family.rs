//! A mechanism parameter p as a parameter of the balance ([`MechanismFamily`]): a fold curve's
//! second parameter, a sensitivity's direction. The problem is built at any p, the last few
//! kept, since the engine builds the mechanism once and offers no derivative in p.

use super::options::HbmError;
use super::parameter::At;
use super::problem::Hbm;

/// A family of problems along a mechanism parameter p (a pivot's damping, an absorber's
/// tuning), the plane's second parameter in place of the torque scale.
///
/// The residual depends on p through the mechanism, which the engine builds once (its mass
/// matrix, the joints' laws): there is no ∂R̂/∂p in closed form, and no way to change p in place.
/// So `build(p)` makes the whole problem at p, and ∂R̂/∂p and `∂g/∂p = −wᵀ (∂J/∂p) v` are
/// differences of problems built at p and p ± h, h = 1e-5 · `reference`: central (O(h²) of the
/// third derivatives) for tangents at turning points, one-sided in Newton's iterates (the
/// residual is linear in a damping, so both are exact there up to rounding).
pub struct MechanismFamily<'a> {
    /// The problem at p: the same mechanism and route at every p, so the same unknowns.
    pub build: &'a dyn Fn(f64) -> Result<Hbm, HbmError>,
    /// The torque scale s held fixed.
    pub scale: f64,
    /// The size of p, its unit (> 0): the arclength weighs p / reference like the order and the
    /// coefficients in rad, and the difference step is relative to it.
    pub reference: f64,
    /// Whether p is the mean speed Ω itself (rad/s), on an order plane: the (n, Ω) plane at a
    /// fixed torque. Each state is then evaluated at Ω = p (the problems are built there too),
    /// and ∂R̂/∂Ω, ∂g/∂Ω are differences between Ω = p and p ± h like any other p's.
    pub speed: bool,
}

impl std::fmt::Debug for MechanismFamily<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("MechanismFamily")
            .field("scale", &self.scale)
            .field("reference", &self.reference)
            .field("speed", &self.speed)
            .finish()
    }
}

/// Problems built at recent values of p, the last few kept (a corrector needs p and p ± h at
/// each iterate, and the tangent the same again at the converged point).
#[derive(Default)]
pub(in crate::hbm) struct Built {
    problems: Vec<(f64, Hbm)>,
}

impl Built {
    const KEPT: usize = 6;

    /// The problem at p, built unless kept.
    pub(in crate::hbm) fn at(&mut self, family: &MechanismFamily<'_>, p: f64) -> Result<&mut Hbm, HbmError> {
        let k = match self.problems.iter().position(|(q, _)| q.to_bits() == p.to_bits()) {
            Some(k) => k,
            None => {
                if !p.is_finite() {
                    return Err(HbmError::NonFinite { order: f64::NAN });
                }
                let hbm = (family.build)(p)?;
                if self.problems.len() >= Self::KEPT {
                    self.problems.remove(0);
                }
                self.problems.push((p, hbm));
                self.problems.len() - 1
            }
        };
        Ok(&mut self.problems[k].1)
    }
}

/// `at` with the family's p where p is a parameter of the evaluation (a speed family's Ω).
pub(in crate::hbm) fn on_family(at: At, family: &MechanismFamily<'_>, p: f64) -> At {
    if family.speed { At { omega: p, ..at } } else { at }
}

/// The problem at p: `base` on a torque-scale plane (p None), else the family's, built if need be.
pub(in crate::hbm) fn problem<'h>(
    base: &'h mut Hbm,
    built: &'h mut Built,
    family: Option<&MechanismFamily<'_>>,
    p: Option<f64>,
) -> Result<&'h mut Hbm, HbmError> {
    match (family, p) {
        (Some(f), Some(p)) => built.at(f, p),
        _ => Ok(base),
    }
}

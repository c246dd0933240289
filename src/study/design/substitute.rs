//! One case's mechanism and analysis: the case's values substituted into the typed mechanism
//! (a mass, an inertia, a spring, a damper, a radius, or a pendulum's tuning order n_t, set by
//! the distance L of its centre of mass from the pivot, the root of `n_t² m L² − m R L + n_t² I = 0`)
//! and into the analysis (its speed, torque or order), checked as at load.

use super::{DesignSpec, Quantity, mech_name};
use crate::error::{Error, Result};
use crate::kane::Kane;
use crate::model::joint::Spring;
use crate::model::mechanism::Mechanism;
use crate::study::{AnalysisSpec, HbmParameter, Study, StudySpec};

/// The distance L of a revolute pendulum's centre of mass from its pivot that gives it the
/// tuning order `n_t` (mass m, centroidal inertia I, pivot radius R): the root of
/// `n_t² m L² − m R L + n_t² I = 0` on the side of `√(I/m)` (where n_t is largest) that the
/// current distance `l_now` is on.
fn tuned_com_distance(m: f64, i: f64, r: f64, l_now: f64, n_t: f64) -> std::result::Result<f64, String> {
    let n2 = n_t * n_t;
    let disc = (m * r).powi(2) - 4.0 * n2 * n2 * m * i;
    if !(disc >= 0.0 && m > 0.0) {
        let most = crate::plot::num((r / (2.0 * (i / m).sqrt())).sqrt(), 5);
        return Err(format!(
            "a tuning order of {n_t} is out of reach with this mass, inertia and pivot radius (at most {most})"
        ));
    }
    let sq = disc.sqrt();
    let (near, far) = ((m * r - sq) / (2.0 * n2 * m), (m * r + sq) / (2.0 * n2 * m));
    Ok(if l_now * l_now >= i / m { far } else { near })
}

/// Sets the mechanism quantity `q` of `mech` to `v` (its unit); Ok(false) for an analysis's
/// quantity (speed, torque, order), which the mechanism does not hold. Names were resolved when
/// the study was loaded.
///
/// # Errors
/// A tuning order out of reach, or a name not in the mechanism (an internal error).
pub(crate) fn set_quantity(mech: &mut Mechanism, q: &Quantity, v: f64) -> std::result::Result<bool, String> {
    let body = q.body().and_then(|b| mech.body_index(b));
    let joint = q.joint().and_then(|j| mech.joint_index(j));
    match (q, body, joint) {
        (Quantity::BodyMass(_), Some(b), _) => mech.bodies[b].inertia.mass = v,
        (Quantity::BodyInertia(_), Some(b), _) => mech.bodies[b].inertia.i_com = v,
        (Quantity::BodyComRadius(_), Some(b), _) => {
            let com = mech.bodies[b].inertia.com;
            mech.bodies[b].inertia.com = com * (v / com.norm());
        }
        (Quantity::JointStiffness(_), _, Some(j)) => {
            let free_angle = mech.joints[j].spring.map_or(0.0, |s| s.free_angle);
            mech.joints[j].spring = Some(Spring { stiffness: v, free_angle });
        }
        (Quantity::JointDamping(_), _, Some(j)) => mech.joints[j].damper = v,
        (Quantity::JointRadius(_), _, Some(j)) => {
            let at = mech.joints[j].at;
            mech.joints[j].at = at * (v / at.norm());
        }
        (Quantity::TuningOrder(name), _, Some(j)) => {
            let b = j;
            let inertia = mech.bodies[b].inertia;
            let (m, i, r, com) = (inertia.mass, inertia.i_com, mech.joints[j].at.norm(), inertia.com);
            let l = tuned_com_distance(m, i, r, com.norm(), v).map_err(|why| format!("`{name}`: {why}"))?;
            // A request equal to the file's own tuning (to rounding) keeps the file's
            // distance, so that a zero spread is the unmistuned mechanism bit for bit.
            if (l / com.norm() - 1.0).abs() > 1e-13 {
                mech.bodies[b].inertia.com = com * (l / com.norm());
            }
        }
        (Quantity::Rpm | Quantity::TorqueAmplitude | Quantity::Order, ..) => return Ok(false),
        (q, ..) => return Err(format!("internal: the {} names nothing in the mechanism", q.describe())),
    }
    Ok(true)
}

/// Every body keeps some mass or inertia (a varied mass or inertia may have taken both away).
pub(crate) fn check_masses(mech: &Mechanism) -> std::result::Result<(), String> {
    for (i, b) in mech.bodies.iter().enumerate() {
        if b.inertia.mass == 0.0 && b.inertia.i_com == 0.0 {
            return Err(format!("body `{}` (bodies[{i}]) has no mass and no inertia in this case", b.name));
        }
    }
    Ok(())
}

/// The study and analysis of one case: `values` (a row of [`case_values`](super::case_values))
/// substituted into the mechanism (its locked twin rebuilt and checked) and the analysis.
///
/// # Errors
/// A case whose mechanism is invalid (a tuning order out of reach, a body left with neither
/// mass nor inertia, a mass matrix that is not positive definite).
pub fn substitute(study: &Study, spec: &DesignSpec, values: &[f64]) -> Result<(Study, AnalysisSpec)> {
    let mut mech = study.mechanism.clone();
    let mut analysis = spec.analysis.as_ref().clone();
    let err = |m: String| Error::Model { mechanism: mech_name(study), message: m };
    for (p, &v) in spec.parameters.iter().zip(values) {
        if set_quantity(&mut mech, &p.quantity, v).map_err(err)? {
            continue;
        }
        match &p.quantity {
            Quantity::Rpm => match &mut analysis {
                AnalysisSpec::HarmonicBalance(h) => h.rpm = v,
                AnalysisSpec::LinearResponse(l) => l.rpm = v,
                _ => {}
            },
            Quantity::TorqueAmplitude => {
                if let AnalysisSpec::HarmonicBalance(h) = &mut analysis {
                    h.amplitudes = vec![v];
                }
            }
            Quantity::Order => {
                if let AnalysisSpec::HarmonicBalance(h) = &mut analysis {
                    match &mut h.parameter {
                        HbmParameter::Speed { order, .. } | HbmParameter::Torque { order, .. } => *order = v,
                        HbmParameter::Order => {}
                    }
                }
            }
            q => return Err(err(format!("internal: the {} names nothing in the mechanism", q.describe()))),
        }
    }
    check_masses(&mech).map_err(err)?;
    // The engine's own check of M at q = 0 (positive definite, finite), as at load.
    Kane::new(&mech)?;
    let mut locked = None;
    for j in &study.spec.lock {
        let m = locked.as_ref().unwrap_or(&mech);
        locked = Some(m.lock(j, 0.0)?);
    }
    let locked_body = match &locked {
        Some(m) => Some(
            m.body_index(&study.spec.response_body).ok_or_else(|| err("locking merges the response body".into()))?,
        ),
        None => None,
    };
    if let Some(m) = &locked {
        Kane::new(m)?;
    }
    let spec_alone = StudySpec { analyses: Vec::new(), ..study.spec.clone() };
    let case = Study {
        spec: spec_alone,
        file: study.file.clone(),
        mechanism: mech,
        locked,
        spin: study.spin,
        elements: study.elements.clone(),
        body: study.body,
        locked_body,
        source: study.source.clone(),
        sub_studies: Vec::new(),
    };
    Ok((case, analysis))
}

//! Absorber properties of a mechanism's absorber joints, in closed form from the path's Taylor
//! coefficients about its vertex (docs/design/paths.md, "Absorber properties").
//!
//! At held spin Ω, a body of mass m and centroidal inertia I whose centre of mass follows a path
//! (arc length s) and turns by α(s) has the reduced equation
//! `(m + I α'²) s̈ + I α'α'' ṡ² = ½ m Ω² dρ²/ds`. With `ρ² = ρ₀² − ñ²s² + x₄s⁴ + …` and
//! `α = α₁s + α₃s³ + …`, the linear tuning order is `n_t² = m ñ² / (m + I α₁²)` and, to leading
//! order in the amplitude A (m of arc length), the free oscillation's order is
//! `n(A) = n_t (1 + κ A²)` with the path's nonlinear coefficient
//! `κ = −(3/4) x₄/ñ² − (3/2) I α₁ α₃ / (m + I α₁²)` (single-harmonic balance, exact to O(A²)).
//! A circle gives κ = −1/(16 L²), the compound pendulum's n/n_t = 1 − φ₀²/16.
//!
//! A translating absorber on rollers (docs/design/paths.md, "Rollers") keeps a constant s-inertia
//! `M₀ = m + N(m_r + I_r/r_r²)/4` and gains the rollers' centrifugal potential
//! `−½ Ω² N m_r |c̄(s)|²`, `c̄ = ½(P + r(s))`; with the path's x coordinate
//! `r_x = ρ₀ − (κ_v/2)s² + c₄s⁴ + …` (κ_v = (1+ñ²)/ρ₀ the vertex curvature,
//! `c₄ = x₄/(2ρ₀) + (1+ñ²)²/(24ρ₀³)`) and `P_x = ρ₀ − 1/κ_v`, the potential `½K₀s² + ¼K₂s⁴` has
//! `K₀ = ñ²(m + N m_r/2)` and `K₂ = −2m x₄ − (N m_r/2)(2P_x c₄ + x₄)`, so
//! `n_t² = K₀/M₀` and `κ = (3/8) K₂/K₀`.
//!
//! A revolute joint whose parent is a spinning root body (a rotor hung from ground by a revolute
//! joint) and whose child's centre of mass is off the pivot is the paper's compound pendulum: a
//! circle path with R the pivot's distance from the rotor axis and L the centre of mass's from
//! the pivot (eq. 15).

use crate::model::inertia::PlanarInertia;
use crate::model::joint::PathJoint;
use crate::model::math::{Vec2, rotate_cs};
use crate::model::mechanism::Mechanism;
use crate::model::path::{PathShape, Rollers};

/// Whether an absorber's free oscillation at held spin keeps its period at every amplitude.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tautochronism {
    /// Exactly: the reduced equation is linear (an epicycloid with a linear rotation law).
    Exact,
    /// To leading order only: κ = 0 but higher terms are not zero.
    LeadingOrder,
    /// No: the order changes with the amplitude (κ ≠ 0).
    No,
}

/// The absorber properties of one joint.
#[derive(Debug, Clone, PartialEq)]
pub struct Absorber {
    /// The joint's name.
    pub joint: String,
    /// What the joint is: `Circle`, `Bifilar`, `Epicycloid`, `General` or `Revolute pendulum`.
    pub kind: &'static str,
    /// Mass m of everything the joint carries (its child's subtree, other joints at zero), kg.
    pub mass: f64,
    /// Centroidal inertia I of that subtree, kg·m².
    pub inertia: f64,
    /// Distance of the subtree's centre of mass from the child frame's origin, m: the formulas
    /// assume 0 for a path joint (s is then the centre of mass's arc length).
    pub com_offset: f64,
    /// The linear tuning order squared, n_t².
    pub tuning_order_squared: f64,
    /// The path's nonlinear coefficient κ, 1/m²: `n(A) ≈ n_t (1 + κ A²)`, A the amplitude of the
    /// centre of mass's arc length.
    pub nonlinear: f64,
    /// The end of travel, m of arc length (infinite for a circle).
    pub travel: f64,
    /// The joint's own travel limit, m, if given.
    pub travel_limit: Option<f64>,
    /// Whether the period is independent of the amplitude at held spin.
    pub tautochronic: Tautochronism,
    /// The rollers that carry the absorber, when it has them: `tuning_order_squared`,
    /// `nonlinear` and `tautochronic` include them.
    pub rollers: Option<Rollers>,
    /// n_t² of the same absorber without its rollers (equal to `tuning_order_squared` without).
    pub plain_tuning_order_squared: f64,
}

impl Absorber {
    /// The linear tuning order n_t.
    pub fn tuning_order(&self) -> f64 {
        self.tuning_order_squared.sqrt()
    }
}

/// The mass properties of the subtree hanging from joint `j` (its child and every body below),
/// in the child's frame with every coordinate of the subtree at zero.
pub fn carried_inertia(mech: &Mechanism, j: usize) -> PlanarInertia {
    // Pose (cos, sin, origin) of each subtree body's frame in the child's frame.
    let mut pose: Vec<Option<(f64, f64, Vec2)>> = vec![None; mech.bodies.len()];
    pose[j] = Some((1.0, 0.0, Vec2::zeros()));
    let mut total = PlanarInertia::zero();
    for b in j..mech.bodies.len() {
        if b > j {
            let Some(p) = mech.joints[b].parent else { continue };
            let Some((pc, ps, po)) = pose[p] else { continue };
            let mo = mech.joints[b].kind.motion(mech.joints[b].at, 0.0);
            pose[b] = Some((pc * mo.cos - ps * mo.sin, ps * mo.cos + pc * mo.sin, po + rotate_cs(pc, ps, mo.origin)));
        }
        if let Some((c, s, o)) = pose[b] {
            let i = mech.bodies[b].inertia;
            total = total + PlanarInertia::new(i.mass, o + rotate_cs(c, s, i.com), i.i_com);
        }
    }
    total
}

/// `(n_t², κ)` of a body (m, I) on a path with these Taylor coefficients (see the module doc).
pub fn path_orders(m: f64, i: f64, n2: f64, x4: f64, alpha: [f64; 2]) -> (f64, f64) {
    let inertia = m + i * alpha[0] * alpha[0];
    // `+ 0.0` turns the −0 of a path without x₄, α₃ into 0 for the reports.
    (m * n2 / inertia, -0.75 * x4 / n2 - 1.5 * i * alpha[0] * alpha[1] / inertia + 0.0)
}

/// n_t² of a translating absorber (mass m, path order ñ, `n2` = ñ²) carried by `count` rollers
/// of mass `m_r` (kg), centroidal inertia `i_r` (kg·m²) and radius `r_r` (m) rolling without slip
/// between a rotor track and an absorber track, with the rollers' centroid halfway between the
/// path's vertex and its centre of curvature (docs/design/paths.md, "Rollers"):
/// `n_t² = ñ² (m + N m_r/2) / (m + N (m_r + I_r/r_r²)/4)`.
///
/// The same number as [`roller_orders`]'s first, for a designer without a mechanism; a loaded
/// mechanism's path joint with `rollers` reports it in [`absorbers`].
pub fn roller_tuning_order_squared(m: f64, n2: f64, count: f64, m_r: f64, i_r: f64, r_r: f64) -> f64 {
    n2 * (m + 0.5 * count * m_r) / (m + 0.25 * count * (m_r + i_r / (r_r * r_r)))
}

/// `(n_t², κ)` of a translating absorber of mass `m` (kg) carried by `rollers` on a path with
/// these Taylor coefficients (`rho0_2` = ρ₀², `n2` = ñ², `x4`; see the module doc).
pub fn roller_orders(m: f64, rho0_2: f64, n2: f64, x4: f64, rollers: &Rollers) -> (f64, f64) {
    let (count, m_r) = (f64::from(rollers.count), rollers.mass);
    let nt2 = roller_tuning_order_squared(m, n2, count, m_r, rollers.inertia, rollers.radius);
    let rho0 = rho0_2.sqrt();
    let p_x = rho0 - rho0 / (1.0 + n2);
    let c4 = x4 / (2.0 * rho0) + (1.0 + n2) * (1.0 + n2) / (24.0 * rho0 * rho0_2);
    let k0 = n2 * (m + 0.5 * count * m_r);
    let k2 = -2.0 * m * x4 - 0.5 * count * m_r * (2.0 * p_x * c4 + x4);
    // `+ 0.0`: a −0 reads as 0 in the reports.
    (nt2, 0.375 * k2 / k0 + 0.0)
}

/// The absorber properties of every path joint, and of every revolute pendulum on a spinning
/// root body, in tree order.
pub fn absorbers(mech: &Mechanism) -> Vec<Absorber> {
    let mut out = Vec::new();
    for (j, joint) in mech.joints.iter().enumerate() {
        let carried = carried_inertia(mech, j);
        let (m, i) = (carried.mass, carried.i_com);
        if m.is_nan() || m <= 0.0 {
            continue;
        }
        if let Some(PathJoint { shape, travel, .. }) = joint.kind.path() {
            let (rho0_2, n2, x4, alpha) = shape.taylor();
            let (plain, plain_kappa) = path_orders(m, i, n2, x4, alpha);
            // Rollers are accepted only on a translating absorber (α = 0, checked at load).
            let (nt2, kappa) = match joint.rollers {
                Some(r) => roller_orders(m, rho0_2, n2, x4, &r),
                None => (plain, plain_kappa),
            };
            // Massive rollers add |c̄(s)|², never exactly quadratic, to the potential.
            let heavy_rollers = joint.rollers.is_some_and(|r| r.total_mass() > 0.0);
            let kind = match shape {
                PathShape::Circle { .. } => "Circle",
                PathShape::Bifilar { .. } => "Bifilar",
                PathShape::Epicycloid { .. } => "Epicycloid",
                PathShape::General(_) => "General",
            };
            // Constant (m + I α'²) and exactly quadratic ρ²: the reduced equation is linear.
            let tautochronic = if !heavy_rollers && (shape.is_epicycloid() || (i == 0.0 && is_quadratic(shape))) {
                Tautochronism::Exact
            } else if kappa == 0.0 {
                Tautochronism::LeadingOrder
            } else {
                Tautochronism::No
            };
            out.push(Absorber {
                joint: joint.name.clone(),
                kind,
                mass: m,
                inertia: i,
                com_offset: carried.com.norm(),
                tuning_order_squared: nt2,
                nonlinear: kappa,
                travel: shape.travel(),
                travel_limit: travel,
                tautochronic,
                rollers: joint.rollers,
                plain_tuning_order_squared: plain,
            });
        } else if joint.kind.rotates() {
            // A pendulum on a rotor: the parent is a root body spinning about its own origin.
            let Some(p) = joint.parent else { continue };
            let rotor = mech.joints[p].parent.is_none() && mech.joints[p].kind.rotates();
            let (r, l) = (joint.at.norm(), carried.com.norm());
            if !(rotor && r > 0.0 && l > 0.0) {
                continue;
            }
            let (_, n2, x4, alpha) = PathShape::Circle { radius: r, length: l }.taylor();
            let (nt2, kappa) = path_orders(m, i, n2, x4, alpha);
            out.push(Absorber {
                joint: joint.name.clone(),
                kind: "Revolute pendulum",
                mass: m,
                inertia: i,
                com_offset: 0.0,
                tuning_order_squared: nt2,
                nonlinear: kappa,
                travel: f64::INFINITY,
                travel_limit: None,
                tautochronic: Tautochronism::No,
                rollers: None,
                plain_tuning_order_squared: nt2,
            });
        }
    }
    out
}

/// A general path whose ρ² is exactly quadratic (every x zero).
fn is_quadratic(shape: PathShape) -> bool {
    match shape {
        PathShape::General(g) => g.x.iter().all(|v| *v == 0.0),
        PathShape::Epicycloid { .. } => true,
        _ => false,
    }
}

/// The properties as a Markdown section (`## Absorbers` with one table row per absorber), or an
/// empty string when the mechanism has none. Shared by `kanedyn check` and study summaries.
pub fn markdown(mech: &Mechanism) -> String {
    let list = absorbers(mech);
    if list.is_empty() {
        return String::new();
    }
    let mut md = String::from(
        "## Absorbers\n\nAt held spin, from the path's Taylor coefficients (docs/design/paths.md, \"Absorber properties\"): \
         linear tuning order n_t, nonlinear coefficient κ of the free oscillation's order n(A) ≈ n_t (1 + κ A²) \
         (A: the centre of mass's arc-length amplitude), end of travel.\n\n\
         | joint | kind | m (kg) | I (kg·m²) | n_t | κ (1/m²) | travel (m) | tautochronic |\n\
         |---|---|---|---|---|---|---|---|\n",
    );
    for a in &list {
        let travel = match a.travel_limit {
            Some(t) => format!("{t:.4e} (limit; path ends at {:.4e})", a.travel),
            None if a.travel.is_finite() => format!("{:.4e} (end of path)", a.travel),
            None => "unlimited".to_string(),
        };
        let tauto = match a.tautochronic {
            Tautochronism::Exact => "yes",
            Tautochronism::LeadingOrder => "to leading order",
            Tautochronism::No => "no",
        };
        let kind = match a.rollers {
            Some(r) => format!("{} on {} roller{}", a.kind, r.count, if r.count == 1 { "" } else { "s" }),
            None => a.kind.to_string(),
        };
        md += &format!(
            "| `{}` | {} | {:.6} | {:.6e} | {:.6} | {:.6e} | {travel} | {tauto} |\n",
            a.joint,
            kind,
            a.mass,
            a.inertia,
            a.tuning_order(),
            a.nonlinear
        );
    }
    for a in list.iter().filter(|a| a.rollers.is_some()) {
        let Some(r) = a.rollers else { continue };
        md += &format!(
            "\nRollers included for `{}`: {} × (m_r {:.6e} kg, I_r {:.6e} kg·m², r_r {:.6e} m) rolling without slip \
             (docs/design/paths.md, \"Rollers\"): n_t = {:.6} with them, {:.6} without \
             (n_t² = ñ² (m + N m_r/2) / (m + N (m_r + I_r/r_r²)/4)); κ includes their centrifugal potential.\n",
            a.joint,
            r.count,
            r.mass,
            r.inertia,
            r.radius,
            a.tuning_order(),
            a.plain_tuning_order_squared.sqrt()
        );
    }
    if list.iter().any(|a| a.com_offset > 1e-9) {
        md += "\nNOTE: a path joint's carried centre of mass is off its frame origin; the formulas assume it at the origin.\n";
    }
    md.push('\n');
    md
}

//! Loading a mechanism: file → [`MechanismSpec`] → catalog parts merged → names, tree and
//! numbers validated → [`Mechanism`] → the engine's check that M is positive definite and finite
//! at q = 0, with every error located at the offending field (file:line:col).
//!
//! This stage sits above both the model and the engine, so the mechanism type never depends on
//! the engine that evaluates it.

use crate::error::{EngineError, Error, Result};
use crate::io::known_list;
use crate::io::{ReadPolicy, Source, catalog};
use crate::model::body::{Body, BodySpec};
use crate::model::coupling::Couplings;
use crate::model::joint::{Joint, JointSpec};
use crate::model::loads::{GroundDamper, JointTorque, LoadSpec, Loads, PointForce};
use crate::model::math::Vec2;
use crate::model::mechanism::{GROUND, Mechanism, MechanismSpec};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// How deep catalog parts may refer to further parts (guards against a part naming itself).
const MAX_PART_DEPTH: usize = 8;

impl Mechanism {
    /// Reads and validates a mechanism file; catalog parts may only come from the file's own
    /// folder tree (see [`ReadPolicy::within`]).
    pub fn from_file(path: &Path) -> Result<Self> {
        Self::from_file_with(path, &ReadPolicy::within(&folder_of(path)))
    }

    /// Reads and validates a mechanism file under `policy` (allowed folders, size and body caps).
    pub fn from_file_with(path: &Path, policy: &ReadPolicy) -> Result<Self> {
        let src = Source::read_with(path, policy)?;
        Self::from_source(&src, policy)
    }

    /// Parses and validates mechanism text; catalog parts are resolved relative to `src.file`'s
    /// folder under `policy`, each part file size-capped too.
    pub fn from_source(src: &Source, policy: &ReadPolicy) -> Result<Self> {
        let spec: MechanismSpec = src.parse_as("Mechanism")?;
        Self::from_spec_with(&spec, src, policy)
    }

    /// Validates a spec built in code (no file): errors name the field path under
    /// `<spec: NAME>`, and catalog parts resolve relative to the current folder.
    pub fn from_spec(spec: &MechanismSpec) -> Result<Self> {
        let src = Source::from_text(&format!("<spec: {}>", spec.name), "");
        Self::from_spec_with(spec, &src, &ReadPolicy::within(Path::new("")))
    }

    /// Validates a parsed spec, reading catalog parts under `policy`; an overlay (a spec with a
    /// `base`) is merged with its base first (see [`MechanismSpec::base`]).
    pub fn from_spec_with(spec: &MechanismSpec, src: &Source, policy: &ReadPolicy) -> Result<Self> {
        if let Some(base) = &spec.base {
            return overlay(spec, base, src, policy);
        }
        // Counts first: everything below is at least linear in them, the tree ordering quadratic.
        let max = policy.max_bodies;
        for (field, count, limit) in [
            ("bodies", spec.bodies.len(), max),
            ("joints", spec.joints.len(), max),
            ("loads", spec.loads.len(), max.saturating_mul(10)),
        ] {
            if count > limit {
                return Err(src.error(
                    field,
                    format!(
                        "{count} {field}, more than the limit of {limit} (the body cap is {max}, loads may be ten \
                         times as many); raise it with `--max-bodies N` if the mechanism is genuine"
                    ),
                ));
            }
        }
        if spec.bodies.is_empty() {
            return Err(src.error("bodies", "no bodies: nothing to simulate"));
        }
        let base = folder_of(&src.file);

        // Bodies: merge parts, check numbers and names.
        let mut body_specs = Vec::with_capacity(spec.bodies.len());
        let mut massless = Vec::new();
        let mut body_index: HashMap<String, usize> = HashMap::new();
        for (i, b) in spec.bodies.iter().enumerate() {
            let path = format!("bodies[{i}]");
            b.check_numbers(src, &path)?;
            let merged = match &b.part {
                Some(part) => resolve_part::<BodySpec>(&base, part, src, &path, policy, 0)?.merged(b),
                None => b.clone(),
            };
            let Some(name) = merged.name.clone() else {
                return Err(src.error(&path, "body has no `name`"));
            };
            check_name(src, &format!("{path}.name"), &name)?;
            if name == GROUND {
                return Err(src.error(&format!("{path}.name"), "`ground` is the implicit root and cannot be a body"));
            }
            if let Some(prev) = body_index.insert(name.clone(), i) {
                return Err(
                    src.error(&format!("{path}.name"), format!("duplicate body name `{name}` (also bodies[{prev}])"))
                );
            }
            let props = merged.inertia_props(src, &path)?;
            // Checked once the couplings are known: a massless body is harmless on a joint
            // without a coordinate of its own (a pinion whose inertia its gear carries).
            if props.mass == 0.0 && props.i_com == 0.0 {
                massless.push(i);
            }
            body_specs.push((name, props));
        }

        // Joints: merge parts, check names and the tree shape.
        let mut joint_specs = Vec::with_capacity(spec.joints.len());
        let mut joint_names: HashMap<String, usize> = HashMap::new();
        let mut joint_of_child: Vec<Option<usize>> = vec![None; body_specs.len()];
        for (k, j) in spec.joints.iter().enumerate() {
            let path = format!("joints[{k}]");
            j.check_numbers(src, &path)?;
            let merged = match &j.part {
                Some(part) => resolve_part::<JointSpec>(&base, part, src, &path, policy, 0)?.merged(j),
                None => j.clone(),
            };
            let Some(name) = merged.name.clone() else {
                return Err(src.error(&path, "joint has no `name`"));
            };
            check_name(src, &format!("{path}.name"), &name)?;
            if let Some(prev) = joint_names.insert(name.clone(), k) {
                return Err(
                    src.error(&format!("{path}.name"), format!("duplicate joint name `{name}` (also joints[{prev}])"))
                );
            }
            let known = || known_list(body_specs.iter().map(|(n, _)| n.as_str()));
            let Some(parent) = merged.parent.clone() else {
                return Err(src.error(&path, format!("joint `{name}` has no `parent` (a body name or `ground`)")));
            };
            let Some(child) = merged.child.clone() else {
                return Err(src.error(&path, format!("joint `{name}` has no `child` body")));
            };
            let parent_idx = if parent == GROUND {
                None
            } else {
                match body_index.get(&parent) {
                    Some(&p) => Some(p),
                    None => {
                        return Err(src.error(
                            &format!("{path}.parent"),
                            format!("joint `{name}`: unknown parent body `{parent}` (bodies: ground, {})", known()),
                        ));
                    }
                }
            };
            let child_idx = match body_index.get(&child) {
                Some(&c) => c,
                None if child == GROUND => {
                    return Err(
                        src.error(&format!("{path}.child"), format!("joint `{name}`: `ground` cannot be a child"))
                    );
                }
                None => {
                    return Err(src.error(
                        &format!("{path}.child"),
                        format!("joint `{name}`: unknown child body `{child}` (bodies: {})", known()),
                    ));
                }
            };
            if parent_idx == Some(child_idx) {
                return Err(
                    src.error(&format!("{path}.parent"), format!("joint `{name}` joins body `{child}` to itself"))
                );
            }
            if let Some(prev) = joint_of_child[child_idx] {
                return Err(src.error(
                    &format!("{path}.child"),
                    format!(
                        "body `{child}` has two parents: joints `{}` and `{name}`",
                        spec.joints[prev].name.as_deref().unwrap_or("?")
                    ),
                ));
            }
            joint_of_child[child_idx] = Some(k);
            joint_specs.push((name, merged, parent_idx, child_idx));
        }
        for (i, j) in joint_of_child.iter().enumerate() {
            if j.is_none() {
                return Err(src.error(
                    &format!("bodies[{i}]"),
                    format!("body `{}` is not attached: no joint has it as `child`", body_specs[i].0),
                ));
            }
        }

        // Tree order: repeatedly take, in file order, a joint whose parent is already placed.
        // Keeps the file's order when it is already parents-first, so q follows the file.
        let nb = body_specs.len();
        let mut new_index: Vec<Option<usize>> = vec![None; nb];
        let mut order = Vec::with_capacity(nb);
        let mut placed_any = true;
        while order.len() < nb && placed_any {
            placed_any = false;
            for (k, (_, _, parent, child)) in joint_specs.iter().enumerate() {
                if new_index[*child].is_none() && parent.is_none_or(|p| new_index[p].is_some()) {
                    new_index[*child] = Some(order.len());
                    order.push(k);
                    placed_any = true;
                }
            }
        }
        if order.len() < nb {
            let stuck: Vec<&str> =
                (0..nb).filter(|&b| new_index[b].is_none()).map(|b| body_specs[b].0.as_str()).collect();
            let k = joint_of_child[(0..nb).find(|&b| new_index[b].is_none()).unwrap_or(0)].unwrap_or(0);
            return Err(src.error(
                &format!("joints[{k}]"),
                format!("the joints form a cycle: bodies {} are not connected to ground", stuck.join(", ")),
            ));
        }

        let mut bodies = Vec::with_capacity(nb);
        let mut joints = Vec::with_capacity(nb);
        let mut ncoord = 0;
        for &k in &order {
            let (name, js, parent, child) = &joint_specs[k];
            let (bname, props) = &body_specs[*child];
            let path = format!("joints[{k}]");
            let kind =
                js.kind.unwrap_or_default().normalised().map_err(|(field, msg)| {
                    src.error(&format!("{path}.kind.{field}"), format!("joint `{name}`: {msg}"))
                })?;
            if let Some(rollers) = js.rollers {
                let on = match kind.path() {
                    Some(p) => rollers.check_on(p.shape),
                    None => Err(("rollers", format!("rollers carry a path absorber, but this joint is {kind:?}"))),
                };
                on.map_err(|(field, msg)| src.error(&format!("{path}.{field}"), format!("joint `{name}`: {msg}")))?;
            }
            if kind.dof() == 0 {
                for (field, given) in [
                    ("spring", js.spring.is_some()),
                    ("damper", js.damper.is_some_and(|c| c != 0.0)),
                    ("stages", js.stages.is_some()),
                    ("friction", js.friction.is_some()),
                    ("stops", js.stops.is_some()),
                ] {
                    if given {
                        return Err(src.error(
                            &format!("{path}.{field}"),
                            format!("joint `{name}` is Fixed (welded, no coordinate): it cannot have a {field}"),
                        ));
                    }
                }
            }
            let coordinate = (kind.dof() == 1).then(|| {
                ncoord += 1;
                ncoord - 1
            });
            bodies.push(Body { name: bname.clone(), inertia: *props });
            joints.push(Joint {
                name: name.clone(),
                kind,
                parent: parent.map(|p| new_index[p].unwrap_or(usize::MAX)),
                at: js.at.map_or(Vec2::zeros(), |(x, y)| Vec2::new(x, y)),
                coordinate,
                spring: js.spring,
                damper: js.damper.unwrap_or(0.0),
                couplings: Couplings { stages: js.stages.clone(), friction: js.friction, stops: js.stops },
                rollers: js.rollers,
            });
        }
        if ncoord == 0 {
            return Err(src.error("joints", "every joint is Fixed: the mechanism has no coordinate to move"));
        }
        // Couplings: a rigidly driven joint loses its coordinate (numbered again over the rest).
        let index_of = |name: &str| joint_names.get(name).and_then(|&k| new_index[joint_specs[k].3]);
        let gears = crate::model::gears::resolve(&spec.gears, &mut joints, spec.speeds, &index_of, src)?;
        // A massless body on a joint with its own coordinate leaves that coordinate without
        // inertia (the mass matrix singular); welded or rigidly geared, it adds nothing.
        for &i in &massless {
            let t = new_index[i].unwrap_or(usize::MAX);
            if joints.get(t).is_none_or(|j| j.coordinate.is_some()) {
                return Err(src.error(
                    &format!("bodies[{i}]"),
                    format!(
                        "body `{}` has no mass and no inertia (a massless body is accepted only on a welded or \
                         rigidly geared joint, whose motion it cannot leave without inertia)",
                        body_specs[i].0
                    ),
                ));
            }
        }

        // Loads.
        let (gx, gy) = spec.gravity;
        if !(gx.is_finite() && gy.is_finite()) {
            return Err(src.error("gravity", "gravity must be finite (m/s²)"));
        }
        let mut loads = Loads { gravity: Vec2::new(gx, gy), ..Loads::default() };
        // The file index (`loads[l]`) of each ground damper, for the time-scale check's messages.
        let mut ground_damper_at = Vec::new();
        let body_of = |name: &str, path: &str| -> Result<usize> {
            body_index.get(name).and_then(|&b| new_index[b]).ok_or_else(|| {
                src.error(
                    path,
                    format!(
                        "unknown body `{name}` (bodies: {})",
                        known_list(body_specs.iter().map(|(n, _)| n.as_str()))
                    ),
                )
            })
        };
        for (l, load) in spec.loads.iter().enumerate() {
            let path = format!("loads[{l}]");
            match load {
                LoadSpec::JointTorque { joint, excitation } => {
                    let Some(&k) = joint_names.get(joint) else {
                        return Err(src.error(
                            &format!("{path}.joint"),
                            format!(
                                "unknown joint `{joint}` (joints: {})",
                                known_list(joint_specs.iter().map(|j| j.0.as_str()))
                            ),
                        ));
                    };
                    if let Err((field, msg)) = excitation.validate() {
                        return Err(src.error(&format!("{path}.excitation.{field}"), msg));
                    }
                    if joint_specs[k].1.kind.is_some_and(|kind| kind.dof() == 0) {
                        return Err(src.error(
                            &format!("{path}.joint"),
                            format!("joint `{joint}` is Fixed: it has no coordinate for a torque to drive"),
                        ));
                    }
                    let joint = new_index[joint_specs[k].3].unwrap_or(usize::MAX);
                    loads.joint_torques.push(JointTorque { joint, excitation: excitation.clone() });
                }
                LoadSpec::GroundDamper { body, c } => {
                    let b = body_of(body, &format!("{path}.body"))?;
                    if !(c.is_finite() && *c >= 0.0) {
                        return Err(src
                            .error(&format!("{path}.c"), format!("damping must be finite and non-negative, got {c}")));
                    }
                    loads.ground_dampers.push(GroundDamper { body: b, c: *c });
                    ground_damper_at.push(l);
                }
                LoadSpec::PointForce { body, at, force, frame } => {
                    let b = body_of(body, &format!("{path}.body"))?;
                    if ![at.0, at.1, force.0, force.1].iter().all(|v| v.is_finite()) {
                        return Err(src.error(&path, "point and force must be finite"));
                    }
                    loads.point_forces.push(PointForce {
                        body: b,
                        at: Vec2::new(at.0, at.1),
                        force: Vec2::new(force.0, force.1),
                        frame: *frame,
                    });
                }
            }
        }

        let mech = Mechanism {
            name: spec.name.clone(),
            file: Some(src.file.clone()),
            speeds: spec.speeds,
            bodies,
            joints,
            loads,
            gears,
        };
        // A tree whose mass matrix is singular or not finite at q = 0 cannot be simulated: say
        // which joint (in the file's numbering: coordinate i belongs to tree joint j = joint_of(i),
        // which is the file's `order[j]`).
        let at_coordinate = |i: usize| {
            let j = mech.joint_of(i);
            order.get(j).map_or_else(String::new, |k| format!("joints[{k}]"))
        };
        let mut kane = match crate::kane::Kane::new(&mech) {
            Ok(kane) => kane,
            Err(e) => {
                let path = match &e {
                    Error::Engine(EngineError::NotPositiveDefinite { dof, .. }) => at_coordinate(*dof),
                    Error::Engine(EngineError::NonFinite { index, .. }) => at_coordinate(*index),
                    _ => String::new(),
                };
                let message = match &e {
                    // inf ≤ tolerance·inf: an overflow, not a missing inertia.
                    Error::Engine(EngineError::NotPositiveDefinite { pivot, joint, .. }) if !pivot.is_finite() => {
                        format!(
                            "mass matrix at q = 0 is not finite (pivot {pivot} at joint `{joint}`); a body too heavy \
                             or too far from its joint for f64 (units kg and m?)"
                        )
                    }
                    _ => e.to_string(),
                };
                return Err(src.error(&path, message));
            }
        };
        // The factorisation lets an infinite pivot through (inf > 0), so look at M itself.
        let n = mech.ndof();
        let m = kane.mass_matrix(&vec![0.0; n]);
        if let Some((r, c)) = (0..n).flat_map(|r| (0..n).map(move |c| (r, c))).find(|&(r, c)| !m[(r, c)].is_finite()) {
            return Err(src.error(
                &at_coordinate(r.max(c)),
                format!(
                    "mass matrix at q = 0 is not finite: M[{r}][{c}] = {}; a body too heavy or too far from \
                     its joint for f64 (units kg and m?)",
                    m[(r, c)]
                ),
            ));
        }
        check_time_scales(
            &mech,
            m,
            src,
            &|j| order.get(j).map_or_else(String::new, |k| format!("joints[{k}]")),
            &ground_damper_at,
        )?;
        Ok(mech)
    }
}

/// Refuses a stiffness or damping whose time scale on the inertia it moves lies outside
/// [`crate::model::ranges::MAX_NATURAL_HZ`] / [`crate::model::ranges::MAX_DECAY_RATE`], naming the
/// field, the rate it sets and the largest coefficient that inertia accepts. `joint_path` maps a
/// tree joint to its `joints[k]`; `ground_damper_at` the ground dampers to their `loads[l]`.
fn check_time_scales(
    mech: &Mechanism,
    m: &nalgebra::DMatrix<f64>,
    src: &Source,
    joint_path: &dyn Fn(usize) -> String,
    ground_damper_at: &[usize],
) -> Result<()> {
    use crate::model::time_scales::{Element, compliances, time_scales};
    let Some(diag) = compliances(m) else { return Ok(()) };
    for ts in time_scales(mech, &diag) {
        // A friction's smoothing has its own range (`ranges::FRICTION_SMOOTHING`): a near-Coulomb
        // law is stiff by choice, which the plan counts and the watchdog bounds.
        if ts.rate() <= ts.limit() || matches!(ts.element, Element::Friction(_)) {
            continue;
        }
        let joint = |j: usize| (joint_path(j), format!("joint `{}`", mech.joints[j].name));
        let gear = |g: usize| {
            let gr = &mech.gears[g];
            (
                format!("gears[{g}]"),
                format!("the mesh of `{}` on `{}`", mech.joints[gr.joint].name, mech.joints[gr.follows].name),
            )
        };
        let ((base, owner), field, what) = match ts.element {
            Element::Spring(j) => (joint(j), "spring.stiffness".to_string(), "spring stiffness"),
            Element::Stage(j, coast, i) => (
                joint(j),
                format!("stages.{}[{i}].stiffness", if coast { "coast" } else { "drive" }),
                "stage stiffness",
            ),
            Element::StopStiffness(j) => (joint(j), "stops.stiffness".to_string(), "end-stop stiffness"),
            Element::StopDamping(j) => (joint(j), "stops.damping".to_string(), "end-stop damping"),
            Element::Friction(_) => continue,
            Element::Damper(j) => (joint(j), "damper".to_string(), "damper"),
            Element::MeshStiffness(g) => (gear(g), "mesh.stiffness".to_string(), "mesh stiffness"),
            Element::MeshDamping(g) => (gear(g), "mesh.damping".to_string(), "mesh damping"),
            Element::GroundDamper(i) => (
                (
                    ground_damper_at.get(i).map_or_else(String::new, |l| format!("loads[{l}]")),
                    "a ground damper".to_string(),
                ),
                "c".to_string(),
                "ground damping",
            ),
        };
        let scale = if ts.is_stiffness() {
            format!(
                "rings at {:.3e} Hz on the inertia it moves (√(k/J)/2π with 1/J = {:.3e} from M⁻¹ at q = 0); the accepted \
                 range is up to {:.0e} Hz, here a stiffness up to {:.3e}",
                ts.rate(),
                ts.compliance,
                ts.limit(),
                ts.largest_coefficient()
            )
        } else {
            format!(
                "decays at {:.3e} 1/s on the inertia it moves (c/J with 1/J = {:.3e} from M⁻¹ at q = 0); the accepted \
                 range is up to {:.0e} 1/s (a time constant of 10 ns or more), here a damping up to {:.3e}",
                ts.rate(),
                ts.compliance,
                ts.limit(),
                ts.largest_coefficient()
            )
        };
        return Err(src.error(
            &format!("{base}.{field}"),
            format!("{owner}: {what} {:e} {scale}; a value in the wrong units?", ts.coefficient),
        ));
    }
    Ok(())
}

/// A body's or joint's name: not blank, and no control character (C0, DEL, C1). A name is
/// quoted into summaries, CSV headers, figures and messages; a newline or tab in one splits a
/// table row or a comment line there (issue 49), and it is never what the engineer meant.
fn check_name(src: &Source, path: &str, name: &str) -> Result<()> {
    if name.trim().is_empty() {
        return Err(src.error(path, "name is empty"));
    }
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Err(src.error(
            path,
            format!(
                "name `{}` holds the control character {:?} (U+{:04X}): names take printable characters only",
                name.escape_debug(),
                c,
                u32::from(c)
            ),
        ));
    }
    Ok(())
}

/// A catalog part type: body or joint specs that can refer to further parts.
trait Part: serde::de::DeserializeOwned + Clone {
    /// The RON struct name a part file of this kind begins with.
    const KIND: &'static str;
    fn part(&self) -> Option<&str>;
    fn merged(&self, over: &Self) -> Self;
    fn check_numbers(&self, src: &Source, path: &str) -> Result<()>;
}

impl Part for BodySpec {
    const KIND: &'static str = "Body";
    fn part(&self) -> Option<&str> {
        self.part.as_deref()
    }
    fn merged(&self, over: &Self) -> Self {
        BodySpec::merged(self, over)
    }
    fn check_numbers(&self, src: &Source, path: &str) -> Result<()> {
        BodySpec::check_numbers(self, src, path)
    }
}

impl Part for JointSpec {
    const KIND: &'static str = "Joint";
    fn part(&self) -> Option<&str> {
        self.part.as_deref()
    }
    fn merged(&self, over: &Self) -> Self {
        JointSpec::merged(self, over)
    }
    fn check_numbers(&self, src: &Source, path: &str) -> Result<()> {
        JointSpec::check_numbers(self, src, path)
    }
}

/// The folder of `file`, for resolving the names it writes (empty for a bare file name: the
/// current folder).
/// An overlay: `spec` names a `base` mechanism file whose bodies, joints, loads and gears come
/// first and `spec`'s are added after them.
///
/// The base is validated on its own first, so that its errors point into its own file; its
/// file parts are resolved from its own folder. Then the overlay's names are checked against the
/// base's (a clash is an error at the overlay's name), the two are merged and the merged spec is
/// validated; an error there is moved back to the file and item it came from (`bodies[N]` of
/// the merged spec is the overlay's `bodies[N − n_base]`). The base's `speeds` and `gravity`
/// apply: an overlay that sets others is refused rather than silently overridden.
fn overlay(spec: &MechanismSpec, base: &str, src: &Source, policy: &ReadPolicy) -> Result<Mechanism> {
    let folder = folder_of(&src.file);
    let file = policy.resolve(&folder, base).map_err(|m| src.error("base", format!("base mechanism: {m}")))?;
    let base_src = Source::read_with(&file, policy).map_err(|e| src.error("base", format!("base mechanism: {e}")))?;
    let mut base_spec: MechanismSpec = base_src.parse_as("Mechanism")?;
    if base_spec.base.is_some() {
        return Err(base_src.error(
            "base",
            format!(
                "`{base}` is itself an overlay; an overlay's base must be a complete mechanism (overlays do not nest)"
            ),
        ));
    }
    Mechanism::from_spec_with(&base_spec, &base_src, policy)?;
    let base_folder = folder_of(&base_src.file);
    for (i, b) in base_spec.bodies.iter_mut().enumerate() {
        if let Some(part) = &b.part {
            *b = resolve_part::<BodySpec>(&base_folder, part, &base_src, &format!("bodies[{i}]"), policy, 0)?.merged(b);
        }
    }
    for (k, j) in base_spec.joints.iter_mut().enumerate() {
        if let Some(part) = &j.part {
            *j =
                resolve_part::<JointSpec>(&base_folder, part, &base_src, &format!("joints[{k}]"), policy, 0)?.merged(j);
        }
    }
    if spec.speeds != base_spec.speeds && spec.speeds != crate::model::speeds::Speeds::default() {
        return Err(src
            .error("speeds", format!("an overlay keeps its base's speeds ({:?}); remove `speeds`", base_spec.speeds)));
    }
    if spec.gravity != base_spec.gravity && spec.gravity != (0.0, 0.0) {
        return Err(src.error(
            "gravity",
            format!("an overlay keeps its base's gravity ({:?}); remove `gravity`", base_spec.gravity),
        ));
    }
    let clash = |list: &str, name: Option<&String>, base_names: &[Option<&String>]| {
        let n = name?;
        let k = base_names.iter().position(|b| *b == Some(n))?;
        Some(format!("`{n}` is already a name in the base `{base}` ({list}[{k}] there); choose another name"))
    };
    let base_bodies: Vec<Option<&String>> = base_spec.bodies.iter().map(|x| x.name.as_ref()).collect();
    for (i, b) in spec.bodies.iter().enumerate() {
        if let Some(msg) = clash("bodies", b.name.as_ref(), &base_bodies) {
            return Err(src.error(&format!("bodies[{i}].name"), msg));
        }
    }
    let base_joints: Vec<Option<&String>> = base_spec.joints.iter().map(|x| x.name.as_ref()).collect();
    for (k, j) in spec.joints.iter().enumerate() {
        if let Some(msg) = clash("joints", j.name.as_ref(), &base_joints) {
            return Err(src.error(&format!("joints[{k}].name"), msg));
        }
    }
    let counts = [
        ("bodies", base_spec.bodies.len()),
        ("joints", base_spec.joints.len()),
        ("loads", base_spec.loads.len()),
        ("gears", base_spec.gears.len()),
    ];
    let merged = MechanismSpec {
        name: spec.name.clone(),
        base: None,
        speeds: base_spec.speeds,
        gravity: base_spec.gravity,
        bodies: base_spec.bodies.into_iter().chain(spec.bodies.iter().cloned()).collect(),
        joints: base_spec.joints.into_iter().chain(spec.joints.iter().cloned()).collect(),
        loads: base_spec.loads.into_iter().chain(spec.loads.iter().cloned()).collect(),
        gears: base_spec.gears.into_iter().chain(spec.gears.iter().cloned()).collect(),
    };
    Mechanism::from_spec_with(&merged, src, policy).map_err(|e| match e {
        // Errors inside a part file are already where they belong.
        Error::Input { location, message } if location.file == src.file => {
            let relocated = counts.iter().find_map(|&(list, n)| {
                let rest = location.path.strip_prefix(list)?.strip_prefix('[')?;
                let (index, tail) = rest.split_once(']')?;
                let index: usize = index.parse().ok()?;
                Some(if index < n {
                    base_src.locate(&location.path)
                } else {
                    src.locate(&format!("{list}[{}]{tail}", index - n))
                })
            });
            Error::Input { location: relocated.unwrap_or_else(|| src.locate(&location.path)), message }
        }
        other => other,
    })
}

fn folder_of(file: &Path) -> PathBuf {
    file.parent().map(Path::to_path_buf).unwrap_or_default()
}

/// Loads a catalog part named `part` in `referrer` (whose folder is `base`) under `policy`,
/// following its own `part` references.
fn resolve_part<T: Part>(
    base: &Path,
    part: &str,
    referrer: &Source,
    path: &str,
    policy: &ReadPolicy,
    depth: usize,
) -> Result<T> {
    if depth >= MAX_PART_DEPTH {
        return Err(referrer.error(
            &format!("{path}.part"),
            format!("parts nest deeper than {MAX_PART_DEPTH} levels (a part naming itself?)"),
        ));
    }
    let here = format!("{path}.part");
    // A catalog part's own `part` names another catalog part, with or without the prefix: the
    // catalog is its folder.
    let in_catalog = referrer.file.to_str().is_some_and(|f| f.starts_with(catalog::PREFIX));
    let (src, folder) = match catalog::name_of(part).or(in_catalog.then_some(part)) {
        Some(name) => {
            let text = catalog::text(name).map_err(|msg| referrer.error(&here, msg))?;
            (Source::from_text(&format!("{}{name}", catalog::PREFIX), text), None)
        }
        None => {
            let file = policy.resolve(base, part).map_err(|msg| referrer.error(&here, msg))?;
            let src = Source::read_with(&file, policy).map_err(|e| referrer.error(&here, e.to_string()))?;
            (src, Some(folder_of(&file)))
        }
    };
    let spec: T = src.parse_as(T::KIND)?;
    spec.check_numbers(&src, "")?;
    match spec.part() {
        Some(inner) => {
            let folder = folder.unwrap_or_default();
            Ok(resolve_part::<T>(&folder, inner, &src, "", policy, depth + 1)?.merged(&spec))
        }
        None => Ok(spec),
    }
}

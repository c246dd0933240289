//! A mechanism: bodies, joints (a tree rooted at `ground`), generalized speeds and loads, read
//! from RON and validated once, as plain vectors with `parent(i) < i`.

use crate::body::{Body, BodySpec};
use crate::error::{Error, Result};
use crate::io::{ReadPolicy, Source};
use crate::joint::{Joint, JointKind, JointSpec};
use crate::loads::{GroundDamper, JointTorque, LoadSpec, Loads, PointForce};
use crate::math::Vec2;
use crate::speeds::Speeds;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The implicit root body's name.
pub const GROUND: &str = "ground";

/// How deep catalog parts may refer to further parts (guards against a part naming itself).
const MAX_PART_DEPTH: usize = 8;

/// A mechanism file as written (see the README for an annotated example).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Mechanism", deny_unknown_fields)]
pub struct MechanismSpec {
    /// Name used in reports and output folders.
    pub name: String,
    /// Choice of generalized speeds (default `JointRates`).
    #[serde(default)]
    pub speeds: Speeds,
    /// Gravitational acceleration in the world frame, m/s² (default off: `(0.0, 0.0)`).
    #[serde(default)]
    pub gravity: (f64, f64),
    /// The bodies.
    pub bodies: Vec<BodySpec>,
    /// The joints, one per body (each body has exactly one parent).
    pub joints: Vec<JointSpec>,
    /// External loads.
    #[serde(default)]
    pub loads: Vec<LoadSpec>,
}

/// A validated mechanism. Body `i` hangs from joint `i`, which owns coordinate `q[i]`; parents
/// come before children (`joints[i].parent < Some(i)`).
#[derive(Debug, Clone, PartialEq)]
pub struct Mechanism {
    /// Name.
    pub name: String,
    /// File it was read from, if any.
    pub file: Option<PathBuf>,
    /// Choice of generalized speeds.
    pub speeds: Speeds,
    /// Bodies in tree order.
    pub bodies: Vec<Body>,
    /// Joints; `joints[i]` is the inboard joint of `bodies[i]`.
    pub joints: Vec<Joint>,
    /// External loads.
    pub loads: Loads,
}

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

    /// Validates a parsed spec; `src` is the text it came from (for error locations and for
    /// resolving catalog parts relative to its file, within its folder tree).
    pub fn from_spec(spec: &MechanismSpec, src: &Source) -> Result<Self> {
        Self::from_spec_with(spec, src, &ReadPolicy::within(&folder_of(&src.file)))
    }

    /// Validates a parsed spec, reading catalog parts under `policy`.
    pub fn from_spec_with(spec: &MechanismSpec, src: &Source, policy: &ReadPolicy) -> Result<Self> {
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
            if props.mass == 0.0 && props.i_com == 0.0 {
                return Err(src.error(&path, format!("body `{name}` has no mass and no inertia")));
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
        for &k in &order {
            let (name, js, parent, child) = &joint_specs[k];
            let (bname, props) = &body_specs[*child];
            bodies.push(Body { name: bname.clone(), inertia: *props });
            joints.push(Joint {
                name: name.clone(),
                kind: js.kind.unwrap_or(JointKind::Revolute),
                parent: parent.map(|p| new_index[p].unwrap_or(usize::MAX)),
                at: js.at.map_or(Vec2::zeros(), |(x, y)| Vec2::new(x, y)),
                spring: js.spring,
                damper: js.damper.unwrap_or(0.0),
            });
        }

        // Loads.
        let (gx, gy) = spec.gravity;
        if !(gx.is_finite() && gy.is_finite()) {
            return Err(src.error("gravity", "gravity must be finite (m/s²)"));
        }
        let mut loads = Loads { gravity: Vec2::new(gx, gy), ..Loads::default() };
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
        };
        // A tree whose mass matrix is singular or not finite at q = 0 cannot be simulated: say
        // which joint (in the file's numbering: coordinate i is joint `order[i]`).
        let at_coordinate = |i: usize| order.get(i).map_or_else(String::new, |k| format!("joints[{k}]"));
        let mut kane = match crate::kane::Kane::new(&mech) {
            Ok(kane) => kane,
            Err(e) => {
                let path = match &e {
                    Error::Engine(crate::error::EngineError::NotPositiveDefinite { dof, .. }) => at_coordinate(*dof),
                    Error::Engine(crate::error::EngineError::NonFinite { index, .. }) => at_coordinate(*index),
                    _ => String::new(),
                };
                let message = match &e {
                    // inf ≤ tolerance·inf: an overflow, not a missing inertia.
                    Error::Engine(crate::error::EngineError::NotPositiveDefinite { pivot, joint, .. })
                        if !pivot.is_finite() =>
                    {
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
        let m = kane.mass_matrix(&vec![0.0; nb]);
        if let Some((r, c)) = (0..nb).flat_map(|r| (0..nb).map(move |c| (r, c))).find(|&(r, c)| !m[(r, c)].is_finite())
        {
            return Err(src.error(
                &at_coordinate(r.max(c)),
                format!(
                    "mass matrix at q = 0 is not finite: M[{r}][{c}] = {}; a body too heavy or too far from \
                     its joint for f64 (units kg and m?)",
                    m[(r, c)]
                ),
            ));
        }
        Ok(mech)
    }

    /// Number of degrees of freedom (= coordinates = speeds).
    pub fn ndof(&self) -> usize {
        self.joints.len()
    }

    /// Parent indices (None = ground), one per body.
    pub fn parents(&self) -> Vec<Option<usize>> {
        self.joints.iter().map(|j| j.parent).collect()
    }

    /// Index of a body by name.
    pub fn body_index(&self, name: &str) -> Option<usize> {
        self.bodies.iter().position(|b| b.name == name)
    }

    /// Index of a joint (= its coordinate) by name.
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joints.iter().position(|j| j.name == name)
    }

    /// Total mass, kg.
    pub fn total_mass(&self) -> f64 {
        self.bodies.iter().map(|b| b.inertia.mass).sum()
    }

    /// The mechanism with joint `name` locked at angle `q_lock` (rad): its child body is merged
    /// rigidly into the parent (parallel-axis inertia), the child's children hang from the parent
    /// at their transformed joint points, the locked joint's spring, damper and applied torque
    /// disappear, and loads on the child move to the parent. Used for the "locked pendulum"
    /// reference of the paper (Fig. 2 and 5). Locking a joint to ground is refused: it would weld
    /// the whole subtree to ground.
    pub fn lock(&self, name: &str, q_lock: f64) -> Result<Mechanism> {
        let model = |message: String| Error::Model { mechanism: self.name.clone(), message };
        let c = self.joint_index(name).ok_or_else(|| {
            model(format!(
                "cannot lock unknown joint `{name}` (joints: {})",
                known_list(self.joints.iter().map(|j| j.name.as_str()))
            ))
        })?;
        let Some(p) = self.joints[c].parent else {
            return Err(model(format!(
                "joint `{name}` connects to ground; locking it would weld its subtree to ground"
            )));
        };
        let rot = crate::math::rot2(q_lock);
        let at_c = self.joints[c].at;
        // Child-frame vectors expressed in the parent frame.
        let to_parent = |v: Vec2| at_c + rot * v;
        let mut out = self.clone();
        out.name = format!("{}_locked", self.name);
        let child = &self.bodies[c].inertia;
        let moved = crate::inertia::PlanarInertia::new(child.mass, to_parent(child.com), child.i_com);
        out.bodies[p].inertia = out.bodies[p].inertia + moved;
        for (j, joint) in out.joints.iter_mut().enumerate() {
            if joint.parent == Some(c) {
                joint.parent = Some(p);
                joint.at = to_parent(self.joints[j].at);
            }
        }
        for g in &mut out.loads.ground_dampers {
            if g.body == c {
                g.body = p;
            }
        }
        for f in &mut out.loads.point_forces {
            if f.body == c {
                f.body = p;
                f.at = to_parent(f.at);
                if f.frame == crate::loads::ForceFrame::Body {
                    f.force = rot * f.force;
                }
            }
        }
        out.loads.joint_torques.retain(|t| t.joint != c);
        // Remove body/joint c and shift the later indices down (order stays parents-first).
        out.bodies.remove(c);
        out.joints.remove(c);
        let shift = |i: usize| if i > c { i - 1 } else { i };
        for joint in &mut out.joints {
            joint.parent = joint.parent.map(shift);
        }
        for g in &mut out.loads.ground_dampers {
            g.body = shift(g.body);
        }
        for f in &mut out.loads.point_forces {
            f.body = shift(f.body);
        }
        for t in &mut out.loads.joint_torques {
            t.joint = shift(t.joint);
        }
        Ok(out)
    }

    /// Joint indices from the root to body `j` (inclusive).
    pub fn path_to(&self, j: usize) -> Vec<usize> {
        let mut path = vec![j];
        let mut b = j;
        while let Some(p) = self.joints[b].parent {
            path.push(p);
            b = p;
        }
        path.reverse();
        path
    }
}

fn check_name(src: &Source, path: &str, name: &str) -> Result<()> {
    if name.trim().is_empty() {
        return Err(src.error(path, "name is empty"));
    }
    Ok(())
}

fn known_list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names.collect::<Vec<_>>().join(", ")
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
    let file = policy.resolve(base, part).map_err(|msg| referrer.error(&here, msg))?;
    let src = Source::read_with(&file, policy).map_err(|e| referrer.error(&here, e.to_string()))?;
    let spec: T = src.parse_as(T::KIND)?;
    spec.check_numbers(&src, "")?;
    match spec.part() {
        Some(inner) => Ok(resolve_part::<T>(&folder_of(&file), inner, &src, "", policy, depth + 1)?.merged(&spec)),
        None => Ok(spec),
    }
}

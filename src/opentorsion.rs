//! OpenTorsion models as kanedyn mechanisms (issue 31, item 6): an OpenTorsion assembly, read
//! from its TORS JSON file or handed over node by node from Python, written as a commented
//! mechanism RON that the user can edit and extend (an overlay adds absorbers, see
//! [`crate::model::mechanism::MechanismSpec::base`]).
//!
//! OpenTorsion (Aalto-Arotor) models a shaft line by nodes, one rotation angle each:
//! - a shaft joins nodes `nl` and `nr` with a spring k and a damper c, and carries the mass
//!   matrix `m·[[2, 1], [1, 2]]` (m = ρ·J·L/6 for a shaft given by its geometry, the given `I`
//!   for one given by its stiffness; 0 for every discrete shaft of a TORS file);
//! - a disk adds an inertia I, a damper c to ground and a stiffness k to ground at its node;
//! - a gear adds its inertia I at its node and, when it has a parent gear, the rigid constraint
//!   `R_parent·θ_parent + R·θ = 0` (R a radius or a tooth count).
//!
//! The conversion is exact for everything but the shafts' own inertia:
//! - every node is a body whose inertia is the sum of its disks and gears;
//! - a node that takes part in a gear stage, or has a stiffness to ground, turns on a bearing of
//!   its own (a revolute joint on ground: its coordinate is its absolute angle, which is what
//!   the gear constraint and the ground spring act on); so does the lowest node of a shaft line
//!   without any such node. These are the *anchored* nodes;
//! - the nodes and shafts on the paths between anchored nodes (the *core*) turn on bearings too,
//!   and those shafts become compliant couplings of ratio 1 between the two nodes' joints
//!   (`Gear(…, ratio: 1.0, mesh: …)`), which act on the difference of the absolute angles
//!   exactly as the shaft does;
//! - every other shaft hangs its far node from the near one by a joint spring and damper (the
//!   shaft's twist is the joint's coordinate);
//! - a gear with a parent is `Gear(joint: child, follows: parent, ratio: −R_parent/R)`, the
//!   disks' dampers are `GroundDamper`s and their ground stiffness the anchored joint's spring;
//! - a shaft's mass matrix cannot be written as bodies (its off-diagonal term couples two
//!   bodies' accelerations), so its total inertia 6m is lumped, 3m to each end node, and the
//!   RON says so; a discrete shaft (m = 0), OpenTorsion's usual one, is exact.
//!
//! The TORS file is read as OpenTorsion's own parser reads it: components whose elements
//! (`Disk`, `ShaftDiscrete`, `ShaftContinuous`, `GearElement`) are laid on consecutive nodes
//! (a shaft advances one node; a gear with a parent in the same component starts a new node), a
//! `structure` of connections `["A.element", "B.…"]` that continues component B's numbering
//! after A's element, starting from the one component that no connection leads into. Continuous
//! shafts use OpenTorsion's defaults (lengths and diameters in mm, G = 80 GPa, ρ = 8000 kg/m³
//! unless given). Excitations are not converted (the RON says which elements had one).
//!
//! Both routes give the same node description ([`Assembly`]), so the same RON: body names are
//! `node_N`, joints `node_N` (a bearing) or `shaft_S` (a shaft's twist), and comments cite
//! OpenTorsion's element lists (shaft S, disk D, gear G, in the order the assembly holds them).

use crate::error::{Error, Location, Result};
use crate::io::line_col;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap, HashSet};
use std::fmt::Write as _;
use std::path::Path;

/// An OpenTorsion assembly node by node: the attributes of its `Shaft`, `Disk` and `Gear`
/// elements, in the order of its element lists (what `kanedyn.from_opentorsion` sends from Python,
/// and what [`convert`] builds from a TORS file).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Assembly {
    /// The shafts (`Assembly.shaft_elements`).
    #[serde(default)]
    pub shafts: Vec<Shaft>,
    /// The disks (`Assembly.disk_elements`).
    #[serde(default)]
    pub disks: Vec<Disk>,
    /// The gears (`Assembly.gear_elements`).
    #[serde(default)]
    pub gears: Vec<Gear>,
    /// Elements that had an excitation in the TORS file (not converted), for the RON's comment.
    #[serde(default)]
    pub excited: Vec<String>,
}

/// An OpenTorsion shaft between two nodes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Shaft {
    /// Left node.
    pub nl: usize,
    /// Right node.
    pub nr: usize,
    /// Torsional stiffness, N·m/rad.
    pub k: f64,
    /// Damping coefficient, N·m·s/rad.
    #[serde(default)]
    pub c: f64,
    /// OpenTorsion's mass factor m of the element mass matrix `m·[[2, 1], [1, 2]]`, kg·m²
    /// (the shaft's own inertia is 6m).
    #[serde(default)]
    pub mass: f64,
}

/// An OpenTorsion disk on a node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Disk {
    /// Its node.
    pub node: usize,
    /// Moment of inertia, kg·m².
    pub inertia: f64,
    /// Damping to ground, N·m·s/rad.
    #[serde(default)]
    pub c: f64,
    /// Stiffness to ground, N·m/rad.
    #[serde(default)]
    pub k: f64,
}

/// An OpenTorsion gear on a node.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Gear {
    /// Its node.
    pub node: usize,
    /// Moment of inertia, kg·m².
    pub inertia: f64,
    /// Radius (mm) or tooth count: only ratios of them matter.
    pub radius: f64,
    /// Index of its parent gear in [`Assembly::gears`], if it has one.
    #[serde(default)]
    pub parent: Option<usize>,
}

/// The head of every converted file: what was converted and how to read it.
const HEADER: &str = "\
// Converted from an OpenTorsion assembly by `kanedyn import` (kanedyn::opentorsion).
// Units: inertia kg·m², stiffness N·m/rad, damping N·m·s/rad (OpenTorsion's).
// One body per OpenTorsion node (`node_N`). A node in a gear stage, with a stiffness to
// ground, or on the shafts between two such nodes turns on a bearing of its own (joint
// `node_N` on ground), as does the first node of a shaft line without one. A shaft between
// two bearing nodes is a coupling of ratio 1 with the shaft's stiffness (`mesh`), any other
// shaft a joint spring (joint `shaft_S`) hanging the far node from the one nearer a bearing.
// Comments cite OpenTorsion's elements: shaft S, disk D, gear G in the assembly's lists.
";

/// A problem found while converting: the field path in [`Assembly`]'s own form
/// (`shafts[2].k`) and the message; the front ends locate it in their input.
#[derive(Debug, Clone, PartialEq)]
pub struct Problem {
    /// Field path in the node form, e.g. `gears[3].parent`.
    pub path: String,
    /// What is wrong.
    pub message: String,
}

fn problem(path: impl Into<String>, message: impl Into<String>) -> Problem {
    Problem { path: path.into(), message: message.into() }
}

/// A mechanism name as kanedyn accepts it (letters, digits, `_`, `-`, `.`), from any text.
pub fn mechanism_name(text: &str) -> String {
    let name: String =
        text.chars().map(|c| if c.is_ascii_alphanumeric() || "_-.".contains(c) { c } else { '_' }).collect();
    if name.is_empty() { "opentorsion".to_string() } else { name }
}

impl Assembly {
    /// Checks the numbers and references, naming the offending field.
    fn check(&self) -> std::result::Result<usize, Problem> {
        let finite_nonneg = |path: String, v: f64, what: &str| {
            if v.is_finite() && v >= 0.0 {
                Ok(())
            } else {
                Err(problem(path, format!("{what} must be finite and non-negative, got {v}")))
            }
        };
        // The highest node index and the field that gives it.
        let mut last: Option<(usize, String)> = None;
        let mut node = |n: usize, path: String| {
            if last.as_ref().is_none_or(|(m, _)| n > *m) {
                last = Some((n, path));
            }
        };
        for (s, sh) in self.shafts.iter().enumerate() {
            if sh.nl == sh.nr {
                return Err(problem(format!("shafts[{s}].nr"), format!("shaft {s} joins node {} to itself", sh.nl)));
            }
            if !(sh.k.is_finite() && sh.k > 0.0) {
                return Err(problem(
                    format!("shafts[{s}].k"),
                    format!("shaft {s}: stiffness must be finite and positive (N·m/rad), got {}", sh.k),
                ));
            }
            finite_nonneg(format!("shafts[{s}].c"), sh.c, "damping (N·m·s/rad)")?;
            finite_nonneg(format!("shafts[{s}].mass"), sh.mass, "inertia (kg·m²)")?;
            node(sh.nl, format!("shafts[{s}].nl"));
            node(sh.nr, format!("shafts[{s}].nr"));
        }
        for (d, disk) in self.disks.iter().enumerate() {
            finite_nonneg(format!("disks[{d}].inertia"), disk.inertia, "inertia (kg·m²)")?;
            finite_nonneg(format!("disks[{d}].c"), disk.c, "damping (N·m·s/rad)")?;
            finite_nonneg(format!("disks[{d}].k"), disk.k, "stiffness to ground (N·m/rad)")?;
            node(disk.node, format!("disks[{d}].node"));
        }
        for (g, gear) in self.gears.iter().enumerate() {
            finite_nonneg(format!("gears[{g}].inertia"), gear.inertia, "inertia (kg·m²)")?;
            // A negative diameter or tooth count is a typo, not a reversed mesh (issue 49: one
            // was accepted and flipped the stage's sign).
            if !(gear.radius.is_finite() && gear.radius > 0.0) {
                return Err(problem(
                    format!("gears[{g}].radius"),
                    format!("gear {g}: radius (or tooth count) must be finite and positive, got {}", gear.radius),
                ));
            }
            if let Some(p) = gear.parent {
                let Some(parent) = self.gears.get(p) else {
                    return Err(problem(
                        format!("gears[{g}].parent"),
                        format!("gear {g}: parent gear {p} does not exist ({} gears)", self.gears.len()),
                    ));
                };
                if parent.node == gear.node {
                    return Err(problem(
                        format!("gears[{g}].parent"),
                        format!("gear {g} and its parent gear {p} are on the same node {}", gear.node),
                    ));
                }
            }
            node(gear.node, format!("gears[{g}].node"));
        }
        let Some((last, last_path)) = last else {
            return Err(problem("", "the assembly has no elements"));
        };
        // Every node holds an element, so there are at most `bound` nodes; an index at or beyond
        // it is a typo and leaves a gap below it. Only what the elements can fill is allocated
        // (issue 49: node 2^64 − 1 overflowed, 2^63 overflowed a capacity, and 1e12 aborted on
        // allocation, taking Python down with it).
        let bound = 2 * self.shafts.len() + self.disks.len() + self.gears.len();
        let mut used = vec![false; bound];
        let mut mark = |n: usize| {
            if let Some(u) = used.get_mut(n) {
                *u = true;
            }
        };
        for sh in &self.shafts {
            mark(sh.nl);
            mark(sh.nr);
        }
        self.disks.iter().for_each(|d| mark(d.node));
        self.gears.iter().for_each(|g| mark(g.node));
        let gap = used[..=last.min(bound - 1)].iter().position(|u| !u);
        if gap.is_some() || last >= bound {
            let (path, beyond) = if last >= bound {
                let what = format!(
                    "node {last} is beyond the elements ({} shaft(s), {} disk(s) and {} gear(s) reach at most {bound} \
                     nodes): ",
                    self.shafts.len(),
                    self.disks.len(),
                    self.gears.len()
                );
                (last_path, what)
            } else {
                (String::new(), String::new())
            };
            let gap = gap.map_or_else(String::new, |n| format!("node {n} has no element "));
            return Err(problem(path, format!("{beyond}{gap}(nodes are numbered 0 to {last} without gaps)")));
        }
        Ok(last + 1)
    }

    /// The mechanism RON of this assembly, named `name` (see the module documentation for the
    /// conversion), or the first problem found.
    pub fn to_ron(&self, name: &str) -> std::result::Result<String, Problem> {
        let n = self.check()?;
        // What sits on each node.
        let mut inertia = vec![0.0; n];
        let mut damping = vec![0.0; n];
        let mut ground_k = vec![0.0; n];
        let mut notes: Vec<Vec<String>> = vec![Vec::new(); n];
        for (d, disk) in self.disks.iter().enumerate() {
            inertia[disk.node] += disk.inertia;
            damping[disk.node] += disk.c;
            ground_k[disk.node] += disk.k;
            notes[disk.node].push(format!("disk {d}"));
        }
        let mut anchored = vec![false; n];
        for (g, gear) in self.gears.iter().enumerate() {
            inertia[gear.node] += gear.inertia;
            notes[gear.node].push(format!("gear {g} (R {:?})", gear.radius));
            if let Some(p) = gear.parent {
                anchored[gear.node] = true;
                anchored[self.gears[p].node] = true;
            }
        }
        let mut lumped = false;
        for (s, sh) in self.shafts.iter().enumerate() {
            if sh.mass > 0.0 {
                lumped = true;
                inertia[sh.nl] += 3.0 * sh.mass;
                inertia[sh.nr] += 3.0 * sh.mass;
                notes[sh.nl].push(format!("half of shaft {s}"));
                notes[sh.nr].push(format!("half of shaft {s}"));
            }
        }
        for i in 0..n {
            if ground_k[i] > 0.0 {
                anchored[i] = true;
            }
        }
        // Shaft lines (connected by shafts): each needs at least one anchored node.
        let mut adjacent: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
        for (s, sh) in self.shafts.iter().enumerate() {
            adjacent[sh.nl].push((s, sh.nr));
            adjacent[sh.nr].push((s, sh.nl));
        }
        let mut line = vec![usize::MAX; n];
        for start in 0..n {
            if line[start] != usize::MAX {
                continue;
            }
            let mut stack = vec![start];
            line[start] = start;
            let mut has_anchor = false;
            while let Some(a) = stack.pop() {
                has_anchor |= anchored[a];
                for &(_, b) in &adjacent[a] {
                    if line[b] == usize::MAX {
                        line[b] = start;
                        stack.push(b);
                    }
                }
            }
            // `start` is the line's lowest node (the scan goes up).
            if !has_anchor {
                anchored[start] = true;
            }
        }
        // Peel the pendant trees: a node that is not anchored and has one shaft left hangs from
        // the node at that shaft's other end. What remains is the core.
        let mut degree: Vec<usize> = adjacent.iter().map(Vec::len).collect();
        let mut hung = vec![false; self.shafts.len()];
        let mut removed = vec![false; n];
        let mut hangs_from: Vec<Option<(usize, usize)>> = vec![None; n];
        let mut queue: Vec<usize> = (0..n).filter(|&i| !anchored[i] && degree[i] == 1).collect();
        while let Some(a) = queue.pop() {
            if removed[a] || degree[a] != 1 {
                continue;
            }
            let Some(&(s, b)) = adjacent[a].iter().find(|&&(s, _)| !hung[s]) else { continue };
            removed[a] = true;
            hung[s] = true;
            hangs_from[a] = Some((s, b));
            degree[a] -= 1;
            degree[b] -= 1;
            if !anchored[b] && degree[b] == 1 {
                queue.push(b);
            }
        }
        // Children of each node in the pendant trees, in shaft order.
        let mut children: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
        for a in 0..n {
            if let Some((s, b)) = hangs_from[a] {
                children[b].push((s, a));
            }
        }
        children.iter_mut().for_each(|c| c.sort_unstable());

        let num = |v: f64| format!("{v:?}");
        let mut out = String::new();
        let w = &mut out;
        w.push_str(HEADER);
        if lumped {
            let _ = writeln!(w, "// NOTE: shafts with inertia have it lumped, half to each end node; OpenTorsion's");
            let _ = writeln!(w, "// consistent mass matrix couples the two ends, so frequencies differ slightly.");
        }
        if !self.excited.is_empty() {
            let _ = writeln!(
                w,
                "// NOTE: excitations are not converted (they were on: {}); add them in a study.",
                // Escaped: a name is the user's text, and a newline in it would end the comment
                // and put the rest of the name into the RON as code (issue 49).
                self.excited.iter().map(|e| e.escape_debug().to_string()).collect::<Vec<_>>().join(", ")
            );
        }
        let _ = writeln!(w, "Mechanism(");
        let _ = writeln!(w, "    name: \"{}\",", mechanism_name(name));
        let _ = writeln!(w, "    speeds: JointRates,");
        // Tree order: each core node, then the nodes hanging from it, depth first.
        let mut order: Vec<usize> = Vec::with_capacity(n);
        for root in (0..n).filter(|&i| !removed[i]) {
            let mut stack = vec![root];
            while let Some(a) = stack.pop() {
                order.push(a);
                stack.extend(children[a].iter().rev().map(|&(_, c)| c));
            }
        }
        let _ = writeln!(w, "    bodies: [");
        for &a in &order {
            let what = if notes[a].is_empty() { "no element".to_string() } else { notes[a].join(", ") };
            let _ = writeln!(w, "        Body(name: \"node_{a}\", inertia: {}), // {what}", num(inertia[a]));
        }
        let _ = writeln!(w, "    ],");
        let _ = writeln!(w, "    joints: [");
        for &a in &order {
            match hangs_from[a] {
                None => {
                    let mut line = format!("        Joint(name: \"node_{a}\", parent: \"ground\", child: \"node_{a}\"");
                    if ground_k[a] > 0.0 {
                        let _ = write!(line, ", spring: (stiffness: {})", num(ground_k[a]));
                    }
                    let _ = writeln!(w, "{line}), // bearing");
                }
                Some((s, b)) => {
                    let sh = &self.shafts[s];
                    let mut line = format!(
                        "        Joint(name: \"shaft_{s}\", parent: \"node_{b}\", child: \"node_{a}\", spring: (stiffness: {})",
                        num(sh.k)
                    );
                    if sh.c > 0.0 {
                        let _ = write!(line, ", damper: {}", num(sh.c));
                    }
                    let _ = writeln!(w, "{line}), // shaft {s}: nodes {}–{}", sh.nl, sh.nr);
                }
            }
        }
        let _ = writeln!(w, "    ],");
        let dampers: Vec<usize> = order.iter().copied().filter(|&a| damping[a] > 0.0).collect();
        if !dampers.is_empty() {
            let _ = writeln!(w, "    loads: [");
            for a in dampers {
                let _ = writeln!(w, "        GroundDamper(body: \"node_{a}\", c: {}),", num(damping[a]));
            }
            let _ = writeln!(w, "    ],");
        }
        let stages: Vec<(usize, &Gear)> = self.gears.iter().enumerate().filter(|(_, g)| g.parent.is_some()).collect();
        let meshes: Vec<usize> = (0..self.shafts.len()).filter(|&s| !hung[s]).collect();
        if !stages.is_empty() || !meshes.is_empty() {
            let _ = writeln!(w, "    gears: [");
            for (g, gear) in stages {
                let p = gear.parent.unwrap_or_default();
                let parent = &self.gears[p];
                let _ = writeln!(
                    w,
                    "        Gear(joint: \"node_{}\", follows: \"node_{}\", ratio: {}), // gear {g} (R {:?}) on gear {p} (R {:?})",
                    gear.node,
                    parent.node,
                    num(-parent.radius / gear.radius),
                    gear.radius,
                    parent.radius
                );
            }
            for s in meshes {
                let sh = &self.shafts[s];
                let mut mesh = format!("stiffness: {}", num(sh.k));
                if sh.c > 0.0 {
                    let _ = write!(mesh, ", damping: {}", num(sh.c));
                }
                let _ = writeln!(
                    w,
                    "        Gear(joint: \"node_{}\", follows: \"node_{}\", ratio: 1.0, mesh: ({mesh})), // shaft {s}: nodes {}–{}",
                    sh.nr, sh.nl, sh.nl, sh.nr
                );
            }
            let _ = writeln!(w, "    ],");
        }
        let _ = writeln!(w, ")");
        Ok(out)
    }
}

// ---------------------------------------------------------------------------------------------
// TORS files.

/// A TORS file as OpenTorsion's parser reads it (other fields are ignored).
#[derive(Debug, Deserialize)]
struct Tors {
    #[serde(default)]
    structure: Vec<(String, String)>,
    components: Vec<Component>,
}

#[derive(Debug, Deserialize)]
struct Component {
    name: String,
    elements: Vec<Element>,
}

/// One element as written: every type's fields, checked against its `type` when it is laid on
/// the nodes (so that a missing or misspelt field is reported at the element, with its name).
#[derive(Debug, Deserialize)]
#[allow(non_snake_case)]
struct Element {
    name: String,
    #[serde(rename = "type")]
    kind: String,
    inertia: Option<f64>,
    damping: Option<f64>,
    stiffness: Option<f64>,
    length: Option<f64>,
    innerDiameter: Option<f64>,
    outerDiameter: Option<f64>,
    density: Option<f64>,
    teeth: Option<f64>,
    diameter: Option<f64>,
    parent: Option<String>,
    excitation: Option<serde_json::Value>,
}

/// OpenTorsion's default shear modulus for a shaft given by its geometry, Pa.
const SHEAR_MODULUS: f64 = 80e9;
/// OpenTorsion's default density, kg/m³.
const DENSITY: f64 = 8000.0;

/// An input error at a JSON field path, located in `text` (line:column of the value, or of the
/// nearest enclosing one).
fn json_error(file: &Path, text: &str, path: &str, message: impl Into<String>) -> Error {
    let line_col = Some(line_col(text, locate_json(text, path)));
    Error::Input {
        location: Location { file: file.to_path_buf(), line_col, path: path.to_string() },
        message: message.into(),
    }
}

/// Deserializes JSON text with serde's field path and serde_json's line:column.
fn parse_json<T: serde::de::DeserializeOwned>(file: &Path, text: &str) -> Result<T> {
    let located = |path: String, inner: serde_json::Error| {
        let line_col = (inner.line() > 0).then(|| (inner.line(), inner.column()));
        // serde_json appends " at line L column C"; the location says it already.
        let message = inner.to_string();
        let message = message.split(" at line ").next().unwrap_or(&message).to_string();
        Error::Input { location: Location { file: file.to_path_buf(), line_col, path }, message }
    };
    let mut de = serde_json::Deserializer::from_str(text);
    let value = serde_path_to_error::deserialize(&mut de).map_err(|e| {
        let path = e.path().to_string();
        let path = if path == "." { String::new() } else { path };
        located(path, e.into_inner())
    })?;
    de.end().map_err(|e| located(String::new(), e))?;
    Ok(value)
}

/// Reads a TORS JSON text (`file` names it in messages) into the node description OpenTorsion's
/// `Parser.from_tors` builds, with the TORS path of each element (`components[c].elements[e]`)
/// for messages.
fn from_tors(file: &Path, text: &str) -> Result<TorsBuilder> {
    let tors: Tors = parse_json(file, text)?;
    let err = |path: &str, message: String| json_error(file, text, path, message);
    if tors.components.is_empty() {
        return Err(err("components", "no components".to_string()));
    }
    let mut by_name: HashMap<&str, usize> = HashMap::new();
    for (c, comp) in tors.components.iter().enumerate() {
        if let Some(prev) = by_name.insert(comp.name.as_str(), c) {
            return Err(err(
                &format!("components[{c}].name"),
                format!("duplicate component name `{}` (also components[{prev}])", comp.name),
            ));
        }
    }
    // Connections: `A.element` → component B.
    let mut next: BTreeMap<(usize, String), (usize, usize)> = BTreeMap::new();
    let mut into: HashSet<usize> = HashSet::new();
    let mut from: Vec<usize> = Vec::new();
    let split = |s: &str, path: &str| -> Result<(usize, String)> {
        let (comp, elem) = s.split_once('.').unwrap_or((s, ""));
        match by_name.get(comp) {
            Some(&c) => Ok((c, elem.to_string())),
            None => Err(err(
                path,
                format!(
                    "unknown component `{comp}` (components: {})",
                    tors.components.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
                ),
            )),
        }
    };
    for (k, (a, b)) in tors.structure.iter().enumerate() {
        let (ca, ea) = split(a, &format!("structure[{k}][0]"))?;
        let (cb, _) = split(b, &format!("structure[{k}][1]"))?;
        if !tors.components[ca].elements.iter().any(|e| e.name == ea) {
            return Err(err(
                &format!("structure[{k}][0]"),
                format!("component `{}` has no element `{ea}`", tors.components[ca].name),
            ));
        }
        if !into.insert(cb) {
            return Err(err(
                &format!("structure[{k}][1]"),
                format!("component `{}` is connected into twice", tors.components[cb].name),
            ));
        }
        next.insert((ca, ea), (cb, k));
        from.push(ca);
    }
    let starts: Vec<usize> = {
        let mut s: Vec<usize> = from.iter().copied().filter(|c| !into.contains(c)).collect();
        s.sort_unstable();
        s.dedup();
        s
    };
    let start = match starts.as_slice() {
        [s] => *s,
        [] if tors.components.len() == 1 => 0,
        [] => {
            return Err(err(
                "structure",
                "no component to start from: every connected component is connected into (a loop?)".to_string(),
            ));
        }
        [_, _, ..] => {
            return Err(err(
                "structure",
                "more than one group of connected components (the model must be one assembly)".to_string(),
            ));
        }
    };

    let mut b = TorsBuilder::default();
    let mut visited = vec![false; tors.components.len()];
    b.walk(&tors, start, &next, &mut visited, &err)?;
    if let Some(c) = visited.iter().position(|v| !v) {
        return Err(err(
            &format!("components[{c}]"),
            format!("component `{}` is not connected to the assembly", tors.components[c].name),
        ));
    }
    Ok(b)
}

/// The node numbering of a TORS file, element by element: the assembly and the TORS path
/// (`components[c].elements[e]`) of each of its shafts, disks and gears.
#[derive(Default)]
struct TorsBuilder {
    node: usize,
    assembly: Assembly,
    shaft_paths: Vec<String>,
    disk_paths: Vec<String>,
    gear_paths: Vec<String>,
    /// Gear index by `component.element`.
    gear_index: HashMap<String, usize>,
}

impl TorsBuilder {
    /// Lays the components on the nodes from `start` as OpenTorsion does: a component's
    /// elements in order, and after an element that a connection leaves from, the whole
    /// component it leads to (and what that one leads to) before the next element. A stack of
    /// (component, next element), not recursion: a chain of 12,300 components overflowed the
    /// stack (issue 49).
    fn walk(
        &mut self,
        tors: &Tors,
        start: usize,
        next: &BTreeMap<(usize, String), (usize, usize)>,
        visited: &mut [bool],
        err: &dyn Fn(&str, String) -> Error,
    ) -> Result<()> {
        visited[start] = true;
        let mut stack = vec![(start, 0usize)];
        while let Some((c, e)) = stack.pop() {
            let Some(element) = tors.components[c].elements.get(e) else { continue };
            stack.push((c, e + 1));
            self.element(tors, c, e, err)?;
            if let Some(&(to, k)) = next.get(&(c, element.name.clone())) {
                if visited[to] {
                    return Err(err(
                        &format!("structure[{k}][1]"),
                        format!(
                            "component `{}` is reached twice (the connections form a loop)",
                            tors.components[to].name
                        ),
                    ));
                }
                visited[to] = true;
                stack.push((to, 0));
            }
        }
        Ok(())
    }

    /// Lays element `e` of component `c` on the nodes.
    fn element(&mut self, tors: &Tors, c: usize, e: usize, err: &dyn Fn(&str, String) -> Error) -> Result<()> {
        let comp = &tors.components[c];
        let element = &comp.elements[e];
        let path = format!("components[{c}].elements[{e}]");
        let id = format!("{}.{}", comp.name, element.name);
        if element.excitation.is_some() {
            self.assembly.excited.push(id.clone());
        }
        let need = |value: Option<f64>, field: &str| {
            value.ok_or_else(|| err(&path, format!("{} `{id}` has no `{field}`", element.kind)))
        };
        let damping = element.damping.unwrap_or(0.0);
        match element.kind.as_str() {
            "Disk" => {
                let inertia = need(element.inertia, "inertia")?;
                // OpenTorsion adds a disk to the previous one when both are on this node.
                match self.assembly.disks.last_mut() {
                    Some(last) if last.node == self.node => {
                        last.inertia += inertia;
                        last.c += damping;
                    }
                    _ => {
                        self.assembly.disks.push(Disk { node: self.node, inertia, c: damping, k: 0.0 });
                        self.disk_paths.push(path.clone());
                    }
                }
            }
            "ShaftDiscrete" => {
                let k = need(element.stiffness, "stiffness")?;
                self.assembly.shafts.push(Shaft { nl: self.node, nr: self.node + 1, k, c: damping, mass: 0.0 });
                self.shaft_paths.push(path.clone());
                self.node += 1;
            }
            "ShaftContinuous" => {
                // mm to m; polar second moment of area J, stiffness G·J/L and the mass factor
                // ρ·J·L/6. OpenTorsion gives such a shaft no damping.
                let l = need(element.length, "length")? * 1e-3;
                let d = need(element.outerDiameter, "outerDiameter")? * 1e-3;
                let di = element.innerDiameter.unwrap_or(0.0) * 1e-3;
                let j = std::f64::consts::PI * (d.powi(4) - di.powi(4)) / 32.0;
                if !(l > 0.0 && j > 0.0 && di >= 0.0) {
                    return Err(err(
                        &format!("{path}.length"),
                        format!("shaft `{id}`: length and outer diameter must be positive, outer above inner (mm)"),
                    ));
                }
                let rho = element.density.unwrap_or(DENSITY);
                let (k, mass) = (SHEAR_MODULUS * j / l, rho * j * l / 6.0);
                self.assembly.shafts.push(Shaft { nl: self.node, nr: self.node + 1, k, c: 0.0, mass });
                self.shaft_paths.push(path.clone());
                self.node += 1;
            }
            "GearElement" => {
                let inertia = need(element.inertia, "inertia")?;
                let Some(radius) = element.teeth.or(element.diameter) else {
                    return Err(err(&path, format!("gear `{id}` has neither `teeth` nor `diameter`")));
                };
                let parent = match &element.parent {
                    None => None,
                    Some(p) => match self.gear_index.get(&format!("{}.{p}", comp.name)) {
                        Some(&g) => {
                            // A gear driven by a parent sits on a node of its own.
                            self.node += 1;
                            Some(g)
                        }
                        None => {
                            return Err(err(
                                &format!("{path}.parent"),
                                format!(
                                    "gear `{id}`: parent `{p}` is not a gear listed before it in component `{}`",
                                    comp.name
                                ),
                            ));
                        }
                    },
                };
                self.gear_index.insert(id.clone(), self.assembly.gears.len());
                self.assembly.gears.push(Gear { node: self.node, inertia, radius, parent });
                self.gear_paths.push(path.clone());
            }
            other => {
                return Err(err(
                    &format!("{path}.type"),
                    format!(
                        "unknown element type `{other}` (TORS types: Disk, ShaftDiscrete, ShaftContinuous, GearElement)"
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// Converts an OpenTorsion model file (a TORS JSON assembly, or the node form [`Assembly`]
/// that `kanedyn.from_opentorsion` uses) to mechanism RON named `name`; errors name the file,
/// line:column and field.
pub fn convert(file: &Path, text: &str, name: &str) -> Result<String> {
    // A UTF-8 byte-order mark, as some Windows editors write, is not JSON but means nothing.
    let text = text.strip_prefix('\u{FEFF}').unwrap_or(text);
    // The node form has `shafts`, `disks` or `gears` at the top; a TORS file `components`.
    let top: serde_json::Value = parse_json(file, text)?;
    let object = top.as_object();
    // Neither form's keys: say so rather than read it as a node form with unknown fields (issue
    // 49: a TORS file without `components` was read as a node form).
    let node_key = |k: &String| matches!(k.as_str(), "shafts" | "disks" | "gears" | "excited");
    if let Some(o) = object.filter(|o| !o.is_empty() && !o.contains_key("components") && !o.keys().any(node_key)) {
        let keys: Vec<String> = o.keys().map(|k| format!("`{}`", k.escape_debug())).collect();
        let (path, message) = if o.contains_key("structure") {
            ("structure", "a TORS file (it has `structure`) without `components`, which list its elements".to_string())
        } else {
            (
                "",
                format!(
                    "neither a TORS file (`components`) nor kanedyn's node form (`shafts`, `disks`, `gears`): its \
                     keys are {}",
                    keys.join(", ")
                ),
            )
        };
        return Err(json_error(file, text, path, message));
    }
    let node_form = object.is_some_and(|o| !o.contains_key("components"));
    if node_form {
        let assembly: Assembly = parse_json(file, text)?;
        assembly.to_ron(name).map_err(|p| json_error(file, text, &p.path, p.message))
    } else {
        let tors = from_tors(file, text)?;
        tors.assembly.to_ron(name).map_err(|p| {
            // The node form's path in TORS terms: the element, and its field under TORS's name.
            let (list, rest) = p.path.split_once('[').unwrap_or(("", ""));
            let (index, field) = rest.split_once(']').unwrap_or(("", ""));
            let paths = match list {
                "shafts" => &tors.shaft_paths,
                "disks" => &tors.disk_paths,
                "gears" => &tors.gear_paths,
                _ => return json_error(file, text, "", p.message),
            };
            let element = index.parse::<usize>().ok().and_then(|i| paths.get(i)).cloned().unwrap_or_default();
            // The node form's own fields (nodes, the mass factor, the parent's index, the radius
            // that is a diameter or a tooth count) are the element itself in TORS terms.
            let path = match field.trim_start_matches('.') {
                "k" => format!("{element}.stiffness"),
                "c" => format!("{element}.damping"),
                "inertia" => format!("{element}.inertia"),
                _ => element,
            };
            json_error(file, text, &path, p.message)
        })
    }
}

// ---------------------------------------------------------------------------------------------
// Locating a field path in JSON text.

/// Byte offset of the value at `path` (`a[1].b`) in JSON `text`, or of the nearest enclosing
/// value that can be found (0 for the whole text). A structural scanner, not a parser: the text
/// has already been parsed when this is asked.
fn locate_json(text: &str, path: &str) -> usize {
    let b = text.as_bytes();
    let mut pos = ws(b, 0);
    for seg in path_segments(path) {
        let found = match seg {
            Seg::Key(key) => find_key(b, pos, key),
            Seg::Index(i) => find_index(b, pos, i),
        };
        match found {
            Some(p) => pos = p,
            None => break,
        }
    }
    pos
}

enum Seg<'a> {
    Key(&'a str),
    Index(usize),
}

fn path_segments(path: &str) -> Vec<Seg<'_>> {
    let mut out = Vec::new();
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (key, mut rest) = part.split_once('[').map_or((part, ""), |(k, r)| (k, r));
        if !key.is_empty() {
            out.push(Seg::Key(key));
        }
        while let Some((i, r)) = rest.split_once(']') {
            if let Ok(i) = i.parse() {
                out.push(Seg::Index(i));
            }
            rest = r.trim_start_matches('[');
        }
    }
    out
}

fn ws(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && b[i].is_ascii_whitespace() {
        i += 1;
    }
    i
}

/// The end of the string starting at `i` (`b[i] == b'"'`), just past its closing quote.
fn string_end(b: &[u8], mut i: usize) -> usize {
    i += 1;
    while i < b.len() {
        match b[i] {
            b'\\' => i += 2,
            b'"' => return i + 1,
            _ => i += 1,
        }
    }
    b.len()
}

/// The end of the value starting at `i`.
fn value_end(b: &[u8], i: usize) -> usize {
    match b.get(i) {
        Some(b'"') => string_end(b, i),
        Some(b'{' | b'[') => {
            let mut depth = 0usize;
            let mut j = i;
            while j < b.len() {
                match b[j] {
                    b'"' => {
                        j = string_end(b, j);
                        continue;
                    }
                    b'{' | b'[' => depth += 1,
                    b'}' | b']' => {
                        depth -= 1;
                        if depth == 0 {
                            return j + 1;
                        }
                    }
                    _ => {}
                }
                j += 1;
            }
            b.len()
        }
        _ => {
            let mut j = i;
            while j < b.len() && !matches!(b[j], b',' | b'}' | b']') && !b[j].is_ascii_whitespace() {
                j += 1;
            }
            j
        }
    }
}

fn find_key(b: &[u8], pos: usize, key: &str) -> Option<usize> {
    if b.get(pos) != Some(&b'{') {
        return None;
    }
    let mut i = ws(b, pos + 1);
    while b.get(i) == Some(&b'"') {
        let end = string_end(b, i);
        let name = &b[i + 1..end.saturating_sub(1).max(i + 1)];
        i = ws(b, end);
        if b.get(i) != Some(&b':') {
            return None;
        }
        let value = ws(b, i + 1);
        if name == key.as_bytes() {
            return Some(value);
        }
        i = ws(b, value_end(b, value));
        if b.get(i) == Some(&b',') {
            i = ws(b, i + 1);
        }
    }
    None
}

fn find_index(b: &[u8], pos: usize, index: usize) -> Option<usize> {
    if b.get(pos) != Some(&b'[') {
        return None;
    }
    let mut i = ws(b, pos + 1);
    for _ in 0..index {
        if matches!(b.get(i), None | Some(b']')) {
            return None;
        }
        i = ws(b, value_end(b, i));
        if b.get(i) != Some(&b',') {
            return None;
        }
        i = ws(b, i + 1);
    }
    (!matches!(b.get(i), None | Some(b']'))).then_some(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locates_json_paths() {
        let text = "{\n  \"a\": [1, {\"b\": \"x\\\"]\", \"c\": 2}],\n  \"d\": {}\n}";
        let at = |p: &str| line_col(text, locate_json(text, p));
        assert_eq!(at("a[1].c"), (2, 31));
        assert_eq!(at("d"), (3, 8));
        // Not found: the nearest enclosing value.
        assert_eq!(at("a[5]"), (2, 8));
    }
}

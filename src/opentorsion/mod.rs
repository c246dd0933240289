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

mod check;
mod locate;
mod ron;
mod tors;

pub use tors::convert;

use serde::{Deserialize, Serialize};

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

//! The node form as mechanism RON: what sits on each node, which nodes turn on bearings (the
//! anchored nodes and the core between them), which hang from others, and the text.

use super::{Assembly, Gear, HEADER, Problem, mechanism_name};
use std::fmt::Write as _;

/// The conversion's plan, node by node (see the module documentation).
struct Layout {
    /// Each node's inertia (its disks and gears, and halves of shafts with inertia), kg·m².
    inertia: Vec<f64>,
    /// Each node's damping to ground (its disks'), N·m·s/rad.
    damping: Vec<f64>,
    /// Each node's stiffness to ground (its disks'), N·m/rad.
    ground_k: Vec<f64>,
    /// What each node holds, for the RON's comments.
    notes: Vec<Vec<String>>,
    /// Whether any shaft's inertia was lumped onto its ends.
    lumped: bool,
    /// The nodes that turn on a bearing of their own.
    anchored: Vec<bool>,
    /// Each node's shafts: (shaft, node at its other end).
    adjacent: Vec<Vec<(usize, usize)>>,
    /// The shafts that hang a node from another (the others are couplings of the core).
    hung: Vec<bool>,
    /// The nodes peeled off the core (they hang from another).
    removed: Vec<bool>,
    /// (shaft, node) each peeled node hangs from.
    hangs_from: Vec<Option<(usize, usize)>>,
    /// The nodes hanging from each node, (shaft, node) in shaft order.
    children: Vec<Vec<(usize, usize)>>,
}

/// A number as the RON writes it (shortest form that reads back the same).
fn num(v: f64) -> String {
    format!("{v:?}")
}

impl Assembly {
    /// The mechanism RON of this assembly, named `name` (see the module documentation for the
    /// conversion), or the first problem found.
    pub fn to_ron(&self, name: &str) -> std::result::Result<String, Problem> {
        let n = self.check()?;
        let mut layout = self.node_contents(n);
        self.anchor_lines(&mut layout);
        self.peel(&mut layout);
        let mut out = String::new();
        self.write_head(&mut out, name, &layout);
        // Tree order: each core node, then the nodes hanging from it, depth first.
        let mut order: Vec<usize> = Vec::with_capacity(n);
        for root in (0..n).filter(|&i| !layout.removed[i]) {
            let mut stack = vec![root];
            while let Some(a) = stack.pop() {
                order.push(a);
                stack.extend(layout.children[a].iter().rev().map(|&(_, c)| c));
            }
        }
        self.write_tree(&mut out, &layout, &order);
        self.write_loads_and_gears(&mut out, &layout, &order);
        let _ = writeln!(out, ")");
        Ok(out)
    }

    /// What sits on each of the `n` nodes, and the nodes anchored by a gear stage or a ground
    /// stiffness.
    fn node_contents(&self, n: usize) -> Layout {
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
        let mut adjacent: Vec<Vec<(usize, usize)>> = vec![Vec::new(); n];
        for (s, sh) in self.shafts.iter().enumerate() {
            adjacent[sh.nl].push((s, sh.nr));
            adjacent[sh.nr].push((s, sh.nl));
        }
        Layout {
            inertia,
            damping,
            ground_k,
            notes,
            lumped,
            anchored,
            adjacent,
            hung: Vec::new(),
            removed: Vec::new(),
            hangs_from: Vec::new(),
            children: Vec::new(),
        }
    }

    /// Shaft lines (connected by shafts): each needs at least one anchored node; one without
    /// gets its lowest node anchored.
    fn anchor_lines(&self, layout: &mut Layout) {
        let n = layout.anchored.len();
        let mut line = vec![usize::MAX; n];
        for start in 0..n {
            if line[start] != usize::MAX {
                continue;
            }
            let mut stack = vec![start];
            line[start] = start;
            let mut has_anchor = false;
            while let Some(a) = stack.pop() {
                has_anchor |= layout.anchored[a];
                for &(_, b) in &layout.adjacent[a] {
                    if line[b] == usize::MAX {
                        line[b] = start;
                        stack.push(b);
                    }
                }
            }
            // `start` is the line's lowest node (the scan goes up).
            if !has_anchor {
                layout.anchored[start] = true;
            }
        }
    }

    /// Peels the pendant trees: a node that is not anchored and has one shaft left hangs from
    /// the node at that shaft's other end. What remains is the core.
    fn peel(&self, layout: &mut Layout) {
        let n = layout.anchored.len();
        let (adjacent, anchored) = (&layout.adjacent, &layout.anchored);
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
        (layout.hung, layout.removed, layout.hangs_from, layout.children) = (hung, removed, hangs_from, children);
    }

    /// The header comments and the mechanism's opening lines.
    fn write_head(&self, w: &mut String, name: &str, layout: &Layout) {
        w.push_str(HEADER);
        if layout.lumped {
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
    }

    /// The bodies and joints, in tree `order`.
    fn write_tree(&self, w: &mut String, layout: &Layout, order: &[usize]) {
        let _ = writeln!(w, "    bodies: [");
        for &a in order {
            let notes = &layout.notes[a];
            let what = if notes.is_empty() { "no element".to_string() } else { notes.join(", ") };
            let _ = writeln!(w, "        Body(name: \"node_{a}\", inertia: {}), // {what}", num(layout.inertia[a]));
        }
        let _ = writeln!(w, "    ],");
        let _ = writeln!(w, "    joints: [");
        for &a in order {
            match layout.hangs_from[a] {
                None => {
                    let mut line = format!("        Joint(name: \"node_{a}\", parent: \"ground\", child: \"node_{a}\"");
                    if layout.ground_k[a] > 0.0 {
                        let _ = write!(line, ", spring: (stiffness: {})", num(layout.ground_k[a]));
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
    }

    /// The disks' dampers to ground, the gear stages and the core's shafts as couplings.
    fn write_loads_and_gears(&self, w: &mut String, layout: &Layout, order: &[usize]) {
        let dampers: Vec<usize> = order.iter().copied().filter(|&a| layout.damping[a] > 0.0).collect();
        if !dampers.is_empty() {
            let _ = writeln!(w, "    loads: [");
            for a in dampers {
                let _ = writeln!(w, "        GroundDamper(body: \"node_{a}\", c: {}),", num(layout.damping[a]));
            }
            let _ = writeln!(w, "    ],");
        }
        let stages: Vec<(usize, &Gear)> = self.gears.iter().enumerate().filter(|(_, g)| g.parent.is_some()).collect();
        let meshes: Vec<usize> = (0..self.shafts.len()).filter(|&s| !layout.hung[s]).collect();
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
    }
}

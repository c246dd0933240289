//! The node form's numbers and references, and its node count bounded by its elements.

use super::{Assembly, Problem, problem};

impl Assembly {
    /// Checks the numbers and references, naming the offending field.
    pub(super) fn check(&self) -> std::result::Result<usize, Problem> {
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
}

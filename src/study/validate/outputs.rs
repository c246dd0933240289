//! The files each analysis may write, known from the study file alone, so that two analyses
//! that would write the same file are refused at load instead of one silently overwriting the
//! other (issue 25: a Compare `c` with label `a` and inner analysis `free` writes `c_a_free.csv`,
//! exactly the file of a top-level analysis named `c_a_free`).
//!
//! The lists are a superset of what a run writes: a figure that is only drawn when elements are
//! reported, or a branch that only exists when the continuation reaches it, is listed all the
//! same, because whether it is written is known only at run time and a collision there would lose
//! a result just as surely.

use super::super::{AnalysisSpec, StudySpec};
use crate::error::Result;
use crate::io::Source;
use std::collections::HashMap;

/// One file an analysis may write, with who writes it (for the message).
struct Owner {
    /// Index of the top-level analysis in `analyses`.
    index: usize,
    /// The analysis as a reader would name it, e.g. "Compare `c` (mechanism `a`, analysis `free`)".
    who: String,
    /// The field an error points at.
    field: String,
}

/// The files of analysis `k`, each with its writer named for a message.
fn owners(spec: &StudySpec, k: usize) -> Vec<(String, Owner)> {
    let a = &spec.analyses[k];
    let locked = !spec.lock.is_empty();
    let top = |f: String| {
        let who = format!("{} `{}` (analyses[{k}])", a.kind(), a.name());
        (f, Owner { index: k, who, field: format!("analyses[{k}].name") })
    };
    let AnalysisSpec::Compare(c) = a else {
        return a.analysis().files(locked).into_iter().map(top).collect();
    };
    let mut out: Vec<(String, Owner)> =
        c.analyses.iter().map(|i| top(format!("{}_{}.svg", c.name, i.name()))).collect();
    for (v, m) in c.mechanisms.iter().enumerate() {
        let locked = m.lock.as_ref().map_or(locked, |l| !l.is_empty());
        for inner in &c.analyses {
            for f in super::super::compare::renamed(&c.name, &m.label, inner).analysis().files(locked) {
                let who = format!(
                    "Compare `{}` (analyses[{k}]), mechanism `{}`, {} `{}`",
                    c.name,
                    m.label,
                    inner.kind(),
                    inner.name()
                );
                let field = format!("analyses[{k}].mechanisms[{v}].label");
                out.push((f, Owner { index: k, who, field }));
            }
        }
    }
    out
}

/// Refuses a study two of whose analyses (counting each comparison's analyses on each of its
/// mechanisms) would write the same file; the error points at the later one and names both.
pub(crate) fn check_unique(spec: &StudySpec, src: &Source) -> Result<()> {
    let mut seen: HashMap<String, Owner> = HashMap::new();
    for k in 0..spec.analyses.len() {
        for (file, owner) in owners(spec, k) {
            match seen.get(&file) {
                // Within one analysis the superset may list a file twice (its own business:
                // amplitudes and labels are checked distinct elsewhere).
                Some(first) if first.index == k && first.who == owner.who => {}
                Some(first) => {
                    return Err(src.error(
                        &owner.field,
                        format!(
                            "{} would write `{file}`, which {} writes too: one would overwrite the other; \
                             rename one of them",
                            owner.who, first.who
                        ),
                    ));
                }
                None => {
                    seen.insert(file, owner);
                }
            }
        }
    }
    Ok(())
}

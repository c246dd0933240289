//! The files each analysis may write, known from the study file alone, so that two analyses
//! that would write the same file are refused at load instead of one silently overwriting the
//! other (issue 25: a Compare `c` with label `a` and inner analysis `free` writes `c_a_free.csv`,
//! exactly the file of a top-level analysis named `c_a_free`).
//!
//! The lists are a superset of what a run writes: a figure that is only drawn when elements are
//! reported, or a branch that only exists when the continuation reaches it, is listed all the
//! same, because whether it is written is known only at run time and a collision there would lose
//! a result just as surely.

use super::super::table::fmt_num;
use super::super::{AnalysisSpec, Direction, StudySpec};
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

/// The names of the files analysis `a` may write into the study's folder. `locked` says whether
/// the study has a locked twin (a sweep then also runs it, and may write its time series).
pub(crate) fn files(a: &AnalysisSpec, locked: bool) -> Vec<String> {
    let n = a.name();
    let mut out = Vec::new();
    let mut csv = |stem: String| out.push(format!("{stem}.csv"));
    match a {
        AnalysisSpec::OrderSweep(s) => {
            for &amp in &s.amplitudes {
                for d in &s.directions {
                    let dir = match d {
                        Direction::Up => "up",
                        Direction::Down => "down",
                    };
                    let label = format!("{n}_{}Nm_{dir}", fmt_num(amp));
                    if s.write_time_series {
                        csv(format!("{label}_time_series"));
                        if locked {
                            csv(format!("{label}_locked_time_series"));
                        }
                    }
                    csv(label);
                }
            }
            out.extend([format!("{n}.svg"), format!("{n}_elements.svg")]);
        }
        AnalysisSpec::HarmonicBalance(h) => {
            for tag in ["from_above", "from_below"] {
                csv(format!("{n}_{tag}"));
                for &amp in &h.amplitudes {
                    csv(format!("{n}_{}Nm_{tag}", fmt_num(amp)));
                }
            }
            out.extend([format!("{n}.svg"), format!("{n}_elements.svg")]);
        }
        AnalysisSpec::LinearResponse(l) => {
            if l.variants.is_empty() {
                csv(format!("{n}_as_built"));
            }
            for v in &l.variants {
                csv(format!("{n}_{}", super::super::linear::slug(&v.label)));
            }
            out.push(format!("{n}.svg"));
        }
        AnalysisSpec::Campbell(_) => {
            csv(n.to_string());
            csv(format!("{n}_crossings"));
            out.push(format!("{n}.svg"));
        }
        AnalysisSpec::Transient(t) => {
            if t.write_time_series {
                csv(format!("{n}_series"));
            }
            csv(format!("{n}_map"));
            csv(format!("{n}_cuts"));
            out.extend([format!("{n}_map.svg"), format!("{n}.svg")]);
        }
        AnalysisSpec::MultiOrder(_) | AnalysisSpec::FreeOscillation(_) | AnalysisSpec::DesignStudy(_) => {
            csv(n.to_string());
            out.push(format!("{n}.svg"));
        }
        AnalysisSpec::Compare(c) => {
            // The overlay figure per inner analysis, then every inner analysis's own files under
            // its run name `<comparison>_<label>_<analysis>`.
            out.extend(c.analyses.iter().map(|a| format!("{n}_{}.svg", a.name())));
            for m in &c.mechanisms {
                let locked = m.lock.as_ref().map_or(locked, |l| !l.is_empty());
                for inner in &c.analyses {
                    out.extend(files(&super::super::compare::renamed(n, &m.label, inner), locked));
                }
            }
        }
    }
    out
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
        return files(a, locked).into_iter().map(top).collect();
    };
    let mut out: Vec<(String, Owner)> =
        c.analyses.iter().map(|i| top(format!("{}_{}.svg", c.name, i.name()))).collect();
    for (v, m) in c.mechanisms.iter().enumerate() {
        let locked = m.lock.as_ref().map_or(locked, |l| !l.is_empty());
        for inner in &c.analyses {
            for f in files(&super::super::compare::renamed(&c.name, &m.label, inner), locked) {
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

//! Studies: one RON file in, every trace, table and figure out.
//!
//! A study names a mechanism, the spin joint that carries the excitation torque, the body whose
//! angular acceleration is reported, the joints to lock for the reference twin, and a list of
//! analyses (the paper's load cases). [`run`] executes them (independent runs in parallel with
//! rayon), writes CSV and SVG files into `<out>/<study name>/`, and returns a summary that is also
//! written as Markdown.
//!
//! The house: each kind of analysis has its room, `study/<analysis>/` (its spec types, checks,
//! plan, run, summary section, figures, tables and JSON), and implements the `Analysis`
//! interface (`analysis.rs`) that the driver here calls without knowing the kinds; the kinds
//! are registered once, in [`AnalysisSpec`] (the `analyses!` list below). Shared pieces:
//! `spec.rs` (the study file's frame and shared settings), `load.rs` (reading and checking a
//! study), `validate/` (the checks every analysis shares and the limits), `plan.rs` (the cost
//! model), `driver.rs` (running the analyses, guarded, and writing the summary), `sim.rs` (time
//! runs and excitation) over `elements.rs` over `track.rs` (order tracking), `table.rs` and
//! `output.rs` (what the analyses write), `json.rs` (`results.json`), `digest.rs` (what
//! `kanedyn run` prints).
//! See docs/design/study.md, "The study layout".
//!
//! The public face is what this module re-exports (the study file's types, [`Study`], [`run`],
//! the results in [`StudyReport`] and their terminal [`digest`]) and the modules [`design`] (design studies case by case),
//! [`json`] (the `results.json` document) and [`validate`] (the input limits, `validate::limits`).

mod analysis;
mod backbone;
mod campbell;
mod compare;
pub mod design;
mod digest;
mod driver;
mod elements;
mod envelope;
mod hbm;
pub mod json;
mod linear;
mod load;
mod multi;
mod output;
mod plan;
mod report_html;
mod sim;
mod spec;
mod sweep;
mod table;
#[cfg(test)]
mod toy;
mod track;
mod transient;
pub mod validate;

use crate::io::Source;
use crate::model::mechanism::Mechanism;
use analysis::{Analysis, Output};
pub use backbone::FreeOscillationSpec;
pub use campbell::CampbellSpec;
pub use compare::{CompareMechanism, CompareSpec};
pub use design::{DesignParameter, DesignSpec, Quantity, Sampling};
pub use digest::{MAX_LINES as DIGEST_MAX_LINES, digest};
pub(crate) use driver::run_guarded;
pub use driver::{RunOptions, run};
pub use envelope::{EnvelopeResult, EnvelopeSpec};
pub use hbm::{HbmParameter, HbmRoute, HbmSpec};
pub use linear::{LinearResponseSpec, Variant};
pub use load::LoadOptions;
pub use multi::{MultiOrderSpec, SpeedPoint};
pub(crate) use output::{cell, finite_text, ratio, write_csv, write_file};
pub use plan::{AnalysisPlan, Limits, Plan, Watchdog};
use serde::{Deserialize, Serialize};
pub use spec::*;
use std::path::PathBuf;
pub use sweep::{Direction, SweepSpec};
pub use transient::{EngineExcitation, JointTorqueSpec, MAX_ENGINE_ORDER, OrderMapSpec, SpeedProfile, TransientSpec};

/// Declares the analysis kinds, one line each: `Kind(Spec)` is both the study file's entry
/// `Kind(…)` (the variant of [`AnalysisSpec`]) and the room whose [`Analysis`] runs it.
/// An entry's attributes (its doc, a `cfg`) go on its variant and on its match arms alike, so a
/// kind that exists only under a `cfg` (the unit tests' `Toy`) is matched only there.
macro_rules! analyses {
    ($($(#[$attr:meta])* $kind:ident($spec:ty),)*) => {
        /// One analysis of a study, as written in its `analyses` list.
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        pub enum AnalysisSpec {
            $($(#[$attr])* $kind($spec),)*
        }

        impl AnalysisSpec {
            /// The analysis kind as written in the study file (`OrderSweep`, …).
            #[allow(unused_doc_comments)]
            pub fn kind(&self) -> &'static str {
                match self {
                    $($(#[$attr])* AnalysisSpec::$kind(_) => stringify!($kind),)*
                }
            }

            /// The analysis behind the entry, as the study driver calls it.
            #[allow(unused_doc_comments)]
            pub(crate) fn analysis(&self) -> &dyn Analysis {
                match self {
                    $($(#[$attr])* AnalysisSpec::$kind(a) => a,)*
                }
            }

            /// The analysis name (its file prefix).
            #[allow(unused_doc_comments)]
            pub fn name(&self) -> &str {
                match self {
                    $($(#[$attr])* AnalysisSpec::$kind(a) => &a.name,)*
                }
            }

            /// Renames the analysis, and the analyses it names, by `rename` (a comparison runs
            /// it under a name per mechanism).
            #[allow(unused_doc_comments)]
            pub(crate) fn rename(&mut self, rename: &dyn Fn(&str) -> String) {
                match self {
                    $($(#[$attr])* AnalysisSpec::$kind(a) => a.name = rename(&a.name),)*
                }
                self.analysis_mut().rename_references(rename);
            }

            /// Whether a comparison may run this entry ([`Analysis::comparable`]).
            #[allow(unused_doc_comments)]
            pub(crate) fn comparable(&self) -> bool {
                match self {
                    $($(#[$attr])* AnalysisSpec::$kind(_) => <$spec as Analysis>::comparable(),)*
                }
            }

            /// The kinds a comparison may run, in registry order (for messages).
            #[allow(unused_doc_comments)]
            pub(crate) fn comparable_kinds() -> Vec<&'static str> {
                let mut kinds = Vec::new();
                $($(#[$attr])* {
                    if <$spec as Analysis>::comparable() {
                        kinds.push(stringify!($kind));
                    }
                })*
                kinds
            }

            /// The kinds as written in the study file, in registry order.
            // One push per entry, because an entry's `cfg` can only sit on a statement.
            #[allow(unused_doc_comments, clippy::vec_init_then_push)]
            pub fn kinds() -> Vec<&'static str> {
                let mut kinds = Vec::new();
                $($(#[$attr])* kinds.push(stringify!($kind));)*
                kinds
            }

            /// Per kind, the JSON Schemas of its `results.json` entry's `result` and `findings`
            /// ([`Analysis::json_schemas`]).
            #[allow(unused_doc_comments)]
            pub(crate) fn json_schemas(
                generator: &mut schemars::SchemaGenerator,
            ) -> Vec<(&'static str, schemars::Schema, schemars::Schema)> {
                let mut out = Vec::new();
                $($(#[$attr])* {
                    let (result, findings) = <$spec as Analysis>::json_schemas(generator);
                    out.push((stringify!($kind), result, findings));
                })*
                out
            }

            /// The analysis behind the entry, to prepare when the study is loaded.
            #[allow(unused_doc_comments)]
            pub(crate) fn analysis_mut(&mut self) -> &mut dyn Analysis {
                match self {
                    $($(#[$attr])* AnalysisSpec::$kind(a) => a,)*
                }
            }
        }
    };
}

analyses! {
    /// Single-order excitation swept in order (the paper's load case 1, Figs. 3 and 4).
    OrderSweep(SweepSpec),
    /// Multi-order excitation at steady speeds (the paper's load case 2, Table 1, Fig. 5).
    MultiOrder(MultiOrderSpec),
    /// Linear order-domain frequency response normalised by the locked twin (eq. 22, Fig. 2).
    LinearResponse(LinearResponseSpec),
    /// Natural frequencies against spin speed with engine-order lines.
    Campbell(CampbellSpec),
    /// Periodic steady states by harmonic balance, continued in the excitation order, with
    /// stability: the branches behind the sweeps' jumps.
    HarmonicBalance(HbmSpec),
    /// One analysis run over many cases of varied mechanism and excitation parameters (a grid, a
    /// Latin hypercube or Monte Carlo), collected in one table (see [`design`]).
    DesignStudy(DesignSpec),
    /// A transient from a given state: free, or through a run-up or run-down of the spin speed
    /// (driven by a torque or prescribed), with an order–rpm map of the response.
    Transient(TransientSpec),
    /// The free oscillation of one joint at held spin, undamped, against its release amplitude:
    /// the absorber's backbone curve (the study's `backbone` room).
    FreeOscillation(FreeOscillationSpec),
    /// The operating envelope in (excitation order, torque): the jump boundary with its cusp and,
    /// for identical absorbers, the unison-loss boundary, each by two-parameter continuation.
    Envelope(EnvelopeSpec),
    /// The same analyses run on several mechanisms (e.g. absorber paths), their results overlaid
    /// per analysis in one figure and compared in one table (the study's `compare` room).
    Compare(CompareSpec),
    /// A toy that the unit tests alone know (see `toy`): what adding a kind takes.
    #[cfg(test)]
    Toy(toy::ToySpec),
}

/// A study ready to run: the spec, its mechanism and the locked twin, with names resolved.
#[derive(Debug, Clone)]
pub struct Study {
    /// The spec as read.
    pub spec: StudySpec,
    /// The study file.
    pub file: PathBuf,
    /// The mechanism.
    pub mechanism: Mechanism,
    /// The mechanism with the `lock` joints locked at q = 0, if any are named.
    pub locked: Option<Mechanism>,
    /// Index of the spin joint.
    pub spin: usize,
    /// The joints reported element by element (`elements` of the spec, or every joint with a
    /// coordinate but the spin joint), by index.
    pub elements: Vec<usize>,
    /// Index of the response body.
    pub body: usize,
    /// Index of the response body in the locked twin.
    pub locked_body: Option<usize>,
    /// The study file's text, to name the line of an analysis that fails at run time.
    pub source: Source,
    /// The studies of other mechanisms that an analysis runs on, by the analysis's index: per
    /// mechanism its label and the study that runs the analysis on it. A `Compare` analysis has
    /// one per mechanism compared (the `compare` room); a design study with its own `mechanism`
    /// has one, labelled by its file, holding the design study alone (the `design` room).
    pub sub_studies: Vec<(usize, compare::Compared)>,
}

/// What a study produced: the Markdown summary and the files written.
#[derive(Debug, Clone, Default)]
pub struct StudyReport {
    /// Markdown summary (also written to `summary.md`).
    pub summary: String,
    /// Files written, in order.
    pub files: Vec<PathBuf>,
    /// Runs that failed (their partial output is still written), with the reason.
    pub failures: Vec<String>,
    /// Sweep results, for tests and further processing.
    pub sweeps: Vec<sweep::SweepRun>,
    /// Multi-order results.
    pub multi: Vec<multi::MultiOrderResult>,
    /// Linear frequency-response results.
    pub linear: Vec<linear::LinearResult>,
    /// Harmonic-balance branches.
    pub hbm: Vec<hbm::HbmBranch>,
    /// Campbell diagrams.
    pub campbell: Vec<crate::linear::Campbell>,
    /// Design studies' case tables.
    pub designs: Vec<design::DesignResult>,
    /// Transients and run-ups.
    pub transient: Vec<transient::TransientResult>,
    /// Free oscillations (backbone curves).
    pub free: Vec<backbone::FreeOscillationResult>,
    /// Operating envelopes.
    pub envelopes: Vec<envelope::EnvelopeResult>,
    /// Comparisons: which of their analyses ran to the end on each mechanism (their results are
    /// in the fields above, under the names `<comparison>_<label>_<analysis>`).
    pub compares: Vec<compare::CompareResult>,
    /// Per analysis of the study file, in its order: whether it ran to the end (its results are
    /// in the fields above; single runs of it may still have failed) rather than failing whole.
    pub completed: Vec<bool>,
}

pub use backbone::FreeOscillationResult;
pub use compare::CompareResult;
pub use elements::{ElementResponse, ElementTorque, Range};
pub use hbm::{HbmBranch, body_accel, jump_orders, parts_absorbers};
pub use linear::{GravityResponse, LinearResult, ResponseVariant};
pub use multi::{MultiOrderResult, SpeedResult};
pub use sweep::SweepRun;
pub use transient::TransientResult;

//! The comparison as written in the study file: its mechanisms and the analyses run on each.

use crate::study::AnalysisSpec;
use serde::{Deserialize, Serialize};

/// One mechanism of a [`CompareSpec`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareMechanism {
    /// Legend and file label (letters, digits, `_`, `-`, `.`).
    pub label: String,
    /// Mechanism file, relative to the study file. It must have the study's spin joint and
    /// response body and the joints the analyses name.
    pub mechanism: String,
    /// Joints locked for this mechanism's reference twin (default: the study's `lock`).
    #[serde(default)]
    pub lock: Option<Vec<String>>,
    /// Joints reported element by element (default: the study's `elements`).
    #[serde(default)]
    pub elements: Option<Vec<String>>,
}

/// The same analyses run on several mechanisms. Each mechanism's outputs are written as by the
/// analyses themselves, with file names `<name>_<label>_<analysis>…`; the comparison adds one
/// figure per analysis, `<name>_<analysis>.svg`, with every mechanism overlaid, and one table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompareSpec {
    /// Name (file prefix).
    pub name: String,
    /// The mechanisms compared, 1 to 8.
    pub mechanisms: Vec<CompareMechanism>,
    /// The analyses run on each, written as in the study's `analyses`: the kinds that run on
    /// one mechanism at a time (those whose `Analysis::comparable` says so; a design study, a
    /// Campbell diagram or another comparison is refused, and the error lists the kinds).
    pub analyses: Vec<AnalysisSpec>,
}

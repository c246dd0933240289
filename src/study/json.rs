//! `results.json`: every number of a study run in one machine-readable file next to
//! `summary.md`, described by the JSON Schema `docs/results.schema.json`, which [`schema`]
//! generates from the types serialised here (`kanedyn schema` prints it).
//!
//! The document holds, per analysis of the study file (in its order):
//! - `result`: the analysis's results as the library returns them ([`SweepRun`](super::SweepRun),
//!   [`MultiOrderResult`](super::MultiOrderResult), [`LinearResult`](super::LinearResult), …),
//!   serialised field by field by the analysis itself (`Analysis::json`, in its room);
//! - `findings`: the numbers the summary reads off those results (minima, intervals, ratios,
//!   counts), computed by the same functions the summary uses;
//! - `tables`: the columns of every CSV file the analysis writes, with their units, in the file's
//!   column order; each value is the same f64 the CSV cell holds.
//!
//! Units: a column carries its SI unit (`"1"` for a dimensionless number such as an order or a
//! ratio); a field's unit is in its name (`wall_s`, `amplitude` in N·m as documented) and in the
//! schema's descriptions.
//!
//! A number that does not exist or does not apply (a ratio to a reference that does not answer,
//! a stability that was not computed) is NaN in memory, an empty cell in a CSV and `null` here:
//! JSON has no NaN or infinity, and a reader must not take a placeholder for data. serde_json
//! writes every non-finite f64 as `null`, so no other value can slip through.
//!
//! The Python package builds its study results from the same [`Document`], so both hold the
//! same data.

pub use super::table::{Column, Table};
use super::{AnalysisSpec, Study, StudyReport, StudySpec};
use crate::error::{Error, Result};
use schemars::transform::{RecursiveTransform, Transform};
use schemars::{Schema, SchemaGenerator, generate::SchemaSettings, json_schema};
use serde::Serialize;
use serde_json::value::RawValue;
use std::path::{Path, PathBuf};

/// The file name, in the study's output folder.
pub const FILE_NAME: &str = "results.json";

/// The document's `format` field.
pub const FORMAT: &str = "kanedyn-results";

/// The document's `format_version`: raised when a field changes meaning or is removed (adding
/// fields keeps it).
pub const FORMAT_VERSION: u32 = 1;

/// kanedyn study results (`results.json`): every number of one study run, written by `kanedyn
/// run` next to `summary.md`. Per analysis: its results as the library returns them, the numbers
/// the summary reads off them (`findings`), and the columns of its CSV files (`tables`). Units
/// are SI (kg, m, s, rad, N·m, Hz) unless a field's name or description says otherwise (speeds
/// in rpm, orders in cycles per revolution, ratios dimensionless). Numbers are IEEE doubles in
/// shortest round-trip form; NaN and infinity never appear (JSON cannot carry them): a number
/// that does not exist or does not apply is `null`, never 0 or a made-up value (where a
/// description says NaN or None, the file holds `null`).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
#[schemars(rename = "KanedynResults")]
pub struct Document<'a> {
    /// Always `kanedyn-results` ([`FORMAT`]): what the file is.
    #[schemars(schema_with = "format_schema")]
    pub format: &'static str,
    /// The layout's version ([`FORMAT_VERSION`]): raised when a field changes meaning or is
    /// removed; added fields keep it.
    #[schemars(schema_with = "format_version_schema")]
    pub format_version: u32,
    /// The kanedyn version that wrote the file.
    pub kanedyn_version: &'static str,
    /// What was run.
    pub study: StudyInfo<'a>,
    /// `complete`, or `partial` when anything failed (see `failures`).
    #[schemars(schema_with = "document_status_schema")]
    pub status: &'static str,
    /// Every failure, as in the summary's "Failures" section: the analysis, its place in the
    /// study file (file:line:column) and the reason.
    pub failures: &'a [String],
    /// One entry per analysis of the study file, in its order.
    pub analyses: Vec<AnalysisEntry<'a>>,
}

/// The study as run.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct StudyInfo<'a> {
    /// The study's name (its output folder).
    pub name: &'a str,
    /// The study file, as given.
    pub file: String,
    /// The study's mechanism.
    pub mechanism: MechanismInfo<'a>,
    /// The study file's content with every default filled in (the user guide's study format;
    /// each analysis as `{Kind: {fields}}`), in the file's units: rpm, N·m, s, Hz.
    #[schemars(schema_with = "spec_schema")]
    pub spec: &'a StudySpec,
}

/// The study's mechanism, as the summary names it.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct MechanismInfo<'a> {
    /// Its name.
    pub name: &'a str,
    /// Its degrees of freedom.
    pub degrees_of_freedom: usize,
    /// The joints owning the coordinates, in coordinate order.
    pub coordinates: Vec<&'a str>,
}

/// One analysis of the study.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct AnalysisEntry<'a> {
    /// Its index in the study file's `analyses`.
    pub index: usize,
    /// Its kind as written in the study file (`OrderSweep`, …); it decides the layout of
    /// `result` and `findings`.
    #[schemars(schema_with = "kind_schema")]
    pub kind: &'static str,
    /// Its name (unique in the study, the prefix of its files).
    pub name: &'a str,
    /// `complete`; `partial` when some of its runs failed (the others are here); `failed` when
    /// it failed as a whole (no result, no findings, no tables).
    #[schemars(schema_with = "entry_status_schema")]
    pub status: &'static str,
    /// Its failures (entries of the document's `failures`).
    pub failures: Vec<&'a str>,
    /// Its results as the library returns them, serialised field by field by the analysis
    /// (null when it failed as a whole); the layout depends on `kind`.
    #[schemars(schema_with = "by_kind_schema")]
    pub result: Option<Box<RawValue>>,
    /// What the summary reads off them (null when it failed as a whole); the layout depends on
    /// `kind`.
    #[schemars(schema_with = "by_kind_schema")]
    pub findings: Option<Box<RawValue>>,
    /// Its CSV files, in the order written: each column with its unit and values.
    pub tables: Vec<Table>,
    /// The columns of the CSV files the analyses inside it wrote (a comparison's mechanisms'),
    /// which its result holds in their own entries.
    #[serde(skip)]
    pub inner_tables: Vec<Table>,
}

impl AnalysisEntry<'_> {
    /// This entry's tables and, for a comparison, those of every compared mechanism's analyses:
    /// one per CSV file the analysis wrote.
    pub fn all_tables(&self) -> Vec<&Table> {
        self.tables.iter().chain(&self.inner_tables).collect()
    }
}

/// An analysis's part of its entry: its results and what the summary reads off them, each as
/// the JSON it serialises to, and the columns of the CSV files it wrote (see
/// `Analysis::json`).
pub(crate) struct Json {
    /// The results.
    pub result: Box<RawValue>,
    /// What the summary reads off them.
    pub findings: Box<RawValue>,
    /// The columns of its CSV files.
    pub tables: Vec<Table>,
    /// The columns of the CSV files of the analyses inside it.
    pub inner_tables: Vec<Table>,
}

impl Json {
    /// The parts of an entry from the analysis's results and findings (None if they cannot be
    /// serialised, which the types here never refuse).
    pub fn new(result: &impl Serialize, findings: &impl Serialize, tables: Vec<Table>) -> Option<Self> {
        Some(Self {
            result: serde_json::value::to_raw_value(result).ok()?,
            findings: serde_json::value::to_raw_value(findings).ok()?,
            tables,
            inner_tables: Vec::new(),
        })
    }
}

/// Writes `results.json` for `report`, a run of `study`, into `dir` and returns its path.
///
/// # Errors
/// When the file cannot be written.
pub fn write(study: &Study, report: &StudyReport, dir: &Path) -> Result<PathBuf> {
    let path = dir.join(FILE_NAME);
    let io = |e: std::io::Error| Error::Io { file: path.clone(), action: "cannot write", source: e };
    let file = std::fs::File::create(&path).map_err(io)?;
    let mut w = std::io::BufWriter::new(file);
    serde_json::to_writer(&mut w, &document(study, report)).map_err(|e| io(e.into()))?;
    std::io::Write::flush(&mut w).map_err(io)?;
    Ok(path)
}

/// The document for `report`, a run of `study` (see the module docs).
///
/// [`StudyReport::completed`] tells which analyses ran to the end; the results of each are found
/// by its name (sweeps, multi-order, linear and harmonic-balance results carry it) or, for
/// Campbell diagrams, by their order among the completed ones.
pub fn document<'a>(study: &'a Study, report: &'a StudyReport) -> Document<'a> {
    let mech = &study.mechanism;
    let coordinates = mech.joints.iter().filter(|j| j.coordinate.is_some()).map(|j| j.name.as_str()).collect();
    let analyses = entries(study, report, &report.completed);
    Document {
        format: FORMAT,
        format_version: FORMAT_VERSION,
        kanedyn_version: env!("CARGO_PKG_VERSION"),
        study: StudyInfo {
            name: &study.spec.name,
            file: study.file.display().to_string(),
            mechanism: MechanismInfo { name: &mech.name, degrees_of_freedom: mech.ndof(), coordinates },
            spec: &study.spec,
        },
        status: if report.failures.is_empty() { "complete" } else { "partial" },
        failures: &report.failures,
        analyses,
    }
}

/// The entries of `study`'s analyses, `completed` telling which ran to the end.
pub(crate) fn entries<'a>(study: &'a Study, report: &'a StudyReport, completed: &[bool]) -> Vec<AnalysisEntry<'a>> {
    let analyses = &study.spec.analyses;
    analyses
        .iter()
        .enumerate()
        .map(|(index, a)| {
            let failures = failures_of(a, &report.failures);
            let completed_here = completed.get(index).copied().unwrap_or(false);
            let nth = nth_of_kind(analyses, completed, index);
            let parts = if completed_here { a.analysis().json(study, report, nth) } else { None };
            let (result, findings, tables, inner_tables) = match parts {
                Some(j) => (Some(j.result), Some(j.findings), j.tables, j.inner_tables),
                None => (None, None, Vec::new(), Vec::new()),
            };
            let status = match (&result, failures.is_empty()) {
                (None, _) => "failed",
                (Some(_), true) => "complete",
                (Some(_), false) => "partial",
            };
            AnalysisEntry {
                index,
                kind: a.kind(),
                name: a.name(),
                status,
                failures,
                result,
                findings,
                tables,
                inner_tables,
            }
        })
        .collect()
}

/// The entries of `failures` that belong to analysis `a`: its own (they start with its kind and
/// name) and those of the analyses a comparison ran inside it (they name it after a colon).
pub(crate) fn failures_of<'a>(a: &AnalysisSpec, failures: &'a [String]) -> Vec<&'a str> {
    let prefix = format!("{} `{}` ", a.kind(), a.name());
    let inner = format!(": {} `{}`", a.kind(), a.name());
    failures.iter().filter(|f| f.starts_with(&prefix) || f.contains(&inner)).map(String::as_str).collect()
}

/// How many analyses of the kind of `analyses[index]` ran to the end before it (`completed`
/// telling which did): a result that carries no name (a Campbell diagram) is found by its place
/// among them.
pub(crate) fn nth_of_kind(analyses: &[AnalysisSpec], completed: &[bool], index: usize) -> usize {
    let kind = analyses[index].kind();
    analyses[..index].iter().zip(completed).filter(|(b, done)| **done && b.kind() == kind).count()
}

// ---------------------------------------------------------------------------------------------
// The JSON Schema (docs/results.schema.json), generated from the types above and the rooms'.
// ---------------------------------------------------------------------------------------------

/// The `$id` of the schema: one per [`FORMAT_VERSION`].
const SCHEMA_ID: &str = "urn:kanedyn:results:1";

/// The JSON Schema (draft 2020-12) of `results.json`, generated from the Rust types the document
/// is serialised from (their doc comments are its descriptions) and the analysis kinds of the
/// registry: an entry's `result` and `findings` are checked against its kind's types.
/// `docs/results.schema.json` is this, pretty-printed (`kanedyn schema` prints it).
///
/// Every number may be `null`: serde_json writes a NaN (a value that does not exist) as `null`,
/// so every `number` of the generated schema admits it. Every object admits only its own
/// fields, so a renamed or added field cannot pass unnoticed.
pub fn schema() -> serde_json::Value {
    let mut generator = SchemaSettings::draft2020_12().for_serialize().into_generator();
    // The kinds' types first, so that their definitions are in the root's `$defs`.
    let kinds = AnalysisSpec::json_schemas(&mut generator);
    let mut root = generator.root_schema_for::<Document<'static>>();
    let by_kind: Vec<serde_json::Value> = kinds
        .into_iter()
        .map(|(kind, result, findings)| {
            let or_null = |s: Schema| serde_json::json!({ "anyOf": [s, { "type": "null" }] });
            serde_json::json!({
                "if": { "properties": { "kind": { "const": kind } } },
                "then": { "properties": { "result": or_null(result), "findings": or_null(findings) } }
            })
        })
        .collect();
    // A failed analysis has nothing but its failures; any other has a result and findings.
    let failed = serde_json::json!({
        "if": { "properties": { "status": { "const": "failed" } } },
        "then": {
            "properties": { "result": { "type": "null" }, "findings": { "type": "null" }, "tables": { "maxItems": 0 } }
        },
        "else": {
            "properties": { "result": { "not": { "type": "null" } }, "findings": { "not": { "type": "null" } } }
        }
    });
    if let Some(entry) = root.get_mut("$defs").and_then(|d| d.get_mut("AnalysisEntry")).and_then(|e| e.as_object_mut())
    {
        let mut all_of = by_kind;
        all_of.push(failed);
        entry.insert("allOf".into(), all_of.into());
    }
    let object = root.ensure_object();
    object.insert("$id".into(), SCHEMA_ID.into());
    object.insert("title".into(), "kanedyn study results (results.json)".into());
    RecursiveTransform(as_written).transform(&mut root);
    root.to_value()
}

/// Makes a generated schema say what serde_json writes: a number may be `null` (NaN), and an
/// object holds its listed fields only.
fn as_written(schema: &mut Schema) {
    let Some(object) = schema.as_object_mut() else { return };
    // Doc comments link Rust items as [`Item`] and wrap at 100 columns; a JSON reader gets the
    // plain name and each paragraph on one line.
    if let Some(serde_json::Value::String(text)) = object.get_mut("description") {
        let paragraphs: Vec<String> =
            text.split("\n\n").map(|p| p.split_whitespace().collect::<Vec<_>>().join(" ")).collect();
        *text = paragraphs.join("\n\n").replace("[`", "`").replace("`]", "`");
    }
    match object.get_mut("type") {
        Some(serde_json::Value::String(t)) if t == "number" => {
            object.insert("type".into(), serde_json::json!(["number", "null"]));
        }
        Some(serde_json::Value::Array(types))
            if types.iter().any(|t| t == "number") && !types.iter().any(|t| t == "null") =>
        {
            types.push("null".into());
        }
        _ => {}
    }
    // Only a type's own object: the `if`/`then` parts of the kinds' rule list some fields only.
    let is_object = object.get("type").is_some_and(|t| t == "object");
    if is_object && object.contains_key("properties") && !object.contains_key("additionalProperties") {
        object.insert("additionalProperties".into(), false.into());
    }
}

fn format_schema(_: &mut SchemaGenerator) -> Schema {
    json_schema!({ "const": FORMAT })
}

fn format_version_schema(_: &mut SchemaGenerator) -> Schema {
    json_schema!({ "const": FORMAT_VERSION })
}

fn document_status_schema(_: &mut SchemaGenerator) -> Schema {
    json_schema!({ "enum": ["complete", "partial"] })
}

fn entry_status_schema(_: &mut SchemaGenerator) -> Schema {
    json_schema!({ "enum": ["complete", "partial", "failed"] })
}

fn kind_schema(_: &mut SchemaGenerator) -> Schema {
    json_schema!({ "enum": AnalysisSpec::kinds() })
}

/// `result` and `findings` alone are any JSON: the entry's `allOf` picks their layout by kind.
fn by_kind_schema(_: &mut SchemaGenerator) -> Schema {
    json_schema!({})
}

/// The study file's content: its top-level fields are required; the analyses' fields are those
/// of the study format (the user guide), which `kanedyn check` validates when the file is read.
fn spec_schema(_: &mut SchemaGenerator) -> Schema {
    json_schema!({
        "type": "object",
        "required": ["name", "mechanism", "spin_joint", "response_body", "lock", "elements", "integration",
                     "order_tracking", "analyses"],
        "properties": {
            "name": { "type": "string", "description": "The study's name (its output folder)." },
            "mechanism": { "type": "string", "description": "The mechanism file, relative to the study file." },
            "spin_joint": { "type": "string", "description": "The joint that carries the excitation torque." },
            "response_body": { "type": "string", "description": "The body whose angular acceleration (rad/s²) is the response." },
            "lock": {
                "type": "array", "items": { "type": "string" },
                "description": "The joints locked at q = 0 in the reference twin (the absorbers)."
            },
            "elements": {
                "type": "array", "items": { "type": "string" },
                "description": "The joints reported element by element (empty: every joint with a coordinate but the spin joint)."
            },
            "integration": { "type": "object", "description": "The time integration's settings: tolerances, sample rate (Hz), step cap, deadline, watchdog." },
            "order_tracking": { "type": "object", "description": "The order tracking's settings: window and hop (s), line half-width (bins)." },
            "analyses": {
                "type": "array",
                "description": "The analyses as written, each `{Kind: {fields}}`, in the file's order.",
                "items": { "type": "object", "minProperties": 1, "maxProperties": 1, "propertyNames": { "enum": AnalysisSpec::kinds() } }
            }
        }
    })
}

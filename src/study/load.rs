//! Loading a study: the study file read and checked, its mechanism and parts read under the read
//! policy, every name resolved, each analysis prepared (the engine files it names) and checked,
//! and the estimated work held against the limits, all before any work is done.

use super::analysis::{Resources, whole_file_at};
use super::{Limits, Study, StudySpec, compare, validate};
use crate::error::{Error, Result};
use crate::io::{ReadPolicy, Source};
use crate::model::mechanism::Mechanism;
use std::path::{Path, PathBuf};

/// How a study is loaded: where its files may come from and the limits its estimated work is
/// checked against.
#[derive(Debug, Clone)]
pub struct LoadOptions {
    /// Limits on memory, output size and CPU time.
    pub limits: Limits,
    /// Folders besides the study's own folder tree that its mechanism and parts may be read
    /// from (`--allow-read DIR`).
    pub allow_read: Vec<PathBuf>,
    /// Read the mechanism and parts from any path (`--allow-any-path`).
    pub allow_any_path: bool,
    /// Largest input file, bytes (`--max-file-kb`).
    pub max_file_bytes: u64,
    /// Most bodies in the mechanism (`--max-bodies`).
    pub max_bodies: usize,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            limits: Limits::default(),
            allow_read: Vec::new(),
            allow_any_path: false,
            max_file_bytes: ReadPolicy::DEFAULT_MAX_FILE_BYTES,
            max_bodies: ReadPolicy::DEFAULT_MAX_BODIES,
        }
    }
}

impl LoadOptions {
    /// The read policy for the files named by the study file `study_file`: its folder tree and
    /// the allowed folders, or anywhere.
    pub fn policy_for(&self, study_file: &Path) -> ReadPolicy {
        let policy = if self.allow_any_path {
            ReadPolicy::unrestricted()
        } else {
            let base = study_file.parent().unwrap_or(Path::new(""));
            self.allow_read.iter().fold(ReadPolicy::within(base), |p, d| p.allow(d))
        };
        policy.with_max_file_bytes(self.max_file_bytes).with_max_bodies(self.max_bodies)
    }
}

impl Study {
    /// Reads a study file and its mechanism with the default [`LoadOptions`], resolving every
    /// name and checking every field and the estimated work; errors name the file, the
    /// line:column and the field.
    pub fn from_file(path: &Path) -> Result<Self> {
        Self::from_file_with(path, &LoadOptions::default())
    }

    /// [`Study::from_file`] with explicit options.
    pub fn from_file_with(path: &Path, opts: &LoadOptions) -> Result<Self> {
        Self::from_source(
            Source::read_with(path, &ReadPolicy::unrestricted().with_max_file_bytes(opts.max_file_bytes))?,
            opts,
        )
    }

    /// Parses and validates a study from its text; its mechanism is read relative to
    /// `src.file`'s folder.
    pub fn from_source(src: Source, opts: &LoadOptions) -> Result<Self> {
        let spec: StudySpec = src.parse_as("Study")?;
        if let Err(m) = validate::check_file_name(&spec.name) {
            return Err(src.error("name", format!("{m} (the study name is its output folder)")));
        }
        Self::from_spec(spec, src, opts)
    }

    /// A study from its parsed spec (`src` is the study file, for locating errors): reads the
    /// mechanism, resolves every name and checks every field and the estimated work.
    pub(crate) fn from_spec(mut spec: StudySpec, src: Source, opts: &LoadOptions) -> Result<Self> {
        spec.integration.watchdog = opts.limits.watchdog;
        let policy = opts.policy_for(&src.file);
        let base = src.file.parent().map(Path::to_path_buf).unwrap_or_default();
        // Too many analyses is `validate`'s error; no engine work is spent on such a file.
        if spec.analyses.len() <= validate::MAX_ANALYSES {
            let mut resources = Resources::new(&src, &policy, &base);
            for (k, a) in spec.analyses.iter_mut().enumerate() {
                resources.k = k;
                a.analysis_mut().prepare(&mut resources)?;
            }
        }
        let mech_path = policy.resolve(&base, &spec.mechanism).map_err(|m| src.error("mechanism", m))?;
        let mechanism = Mechanism::from_file_with(&mech_path, &policy).map_err(|e| match e {
            Error::Io { .. } => src.error("mechanism", format!("cannot read mechanism file: {e}")),
            other if matches!(&other, Error::Input { location, .. } | Error::Limit { location, .. } if location.file == mech_path) => {
                whole_file_at(other, &src, "mechanism")
            }
            other => other,
        })?;
        let joint_names = || mechanism.joints.iter().map(|j| j.name.as_str()).collect::<Vec<_>>().join(", ");
        let spin = mechanism.joint_index(&spec.spin_joint).ok_or_else(|| {
            src.error("spin_joint", format!("unknown joint `{}` (joints: {})", spec.spin_joint, joint_names()))
        })?;
        if mechanism.joints[spin].parent.is_some() {
            return Err(src.error(
                "spin_joint",
                format!("joint `{}` does not connect to ground: the spin joint must", spec.spin_joint),
            ));
        }
        if !mechanism.joints[spin].kind.rotates() {
            return Err(src.error(
                "spin_joint",
                format!("joint `{}` is not revolute: the spin joint turns the rotor", spec.spin_joint),
            ));
        }
        let body = mechanism.body_index(&spec.response_body).ok_or_else(|| {
            let names: Vec<&str> = mechanism.bodies.iter().map(|b| b.name.as_str()).collect();
            src.error("response_body", format!("unknown body `{}` (bodies: {})", spec.response_body, names.join(", ")))
        })?;
        if let Some(j) = mechanism.turning_path_above(body) {
            return Err(src.error(
                "response_body",
                format!(
                    "body `{}` turns with the path joint `{}` (its rotation law), whose turn the \
                     rotor response does not include yet: choose a body above it",
                    spec.response_body, mechanism.joints[j].name
                ),
            ));
        }
        let mut locked = None;
        for (i, j) in spec.lock.iter().enumerate() {
            let m = locked.as_ref().unwrap_or(&mechanism);
            if m.joint_index(j).is_none() {
                return Err(
                    src.error(&format!("lock[{i}]"), format!("unknown joint `{j}` (joints: {})", joint_names()))
                );
            }
            if *j == spec.spin_joint {
                return Err(src.error(&format!("lock[{i}]"), "the spin joint cannot be locked"));
            }
            locked = Some(m.lock(j, 0.0).map_err(|e| src.error(&format!("lock[{i}]"), e.to_string()))?);
        }
        let locked_body = match &locked {
            Some(m) => Some(m.body_index(&spec.response_body).ok_or_else(|| {
                src.error("lock", format!("locking merges the response body `{}` away", spec.response_body))
            })?),
            None => None,
        };
        let elements = if spec.elements.is_empty() {
            (0..mechanism.joints.len()).filter(|&j| j != spin && mechanism.coordinate(j).is_some()).collect()
        } else {
            if spec.elements.len() > validate::MAX_LIST {
                let n = spec.elements.len();
                return Err(src.error("elements", format!("{n} elements; at most {}", validate::MAX_LIST)));
            }
            let mut out = Vec::with_capacity(spec.elements.len());
            for (i, name) in spec.elements.iter().enumerate() {
                let field = format!("elements[{i}]");
                let j = mechanism
                    .joint_index(name)
                    .ok_or_else(|| src.error(&field, format!("unknown joint `{name}` (joints: {})", joint_names())))?;
                // A rigidly driven joint is reported through its gear (factor · the followed
                // coordinate); a Fixed one has nothing to report.
                if mechanism.follow_map()[j].is_none() {
                    return Err(src.error(&field, format!("joint `{name}` is Fixed: it has no motion to report")));
                }
                if out.contains(&j) {
                    return Err(src.error(&field, format!("joint `{name}` is listed twice")));
                }
                out.push(j);
            }
            out
        };
        validate::check(&spec, &mechanism, spin, &src)?;
        let mut sub_studies = compare::load(&spec, &src, opts)?;
        sub_studies.extend(super::design::load_mechanisms(&spec, &src, opts)?);
        let file = src.file.clone();
        let study =
            Study { spec, file, mechanism, locked, spin, elements, body, locked_body, source: src, sub_studies };
        if let Some((k, driver, message)) = study.plan().exceeds(&opts.limits) {
            return Err(study.source.error(&format!("analyses[{k}].{driver}"), message).limit_if(true));
        }
        Ok(study)
    }
}

//! Catalog parts and names: a body or joint spec may name a `part` (a file beside the mechanism,
//! or a `catalog:` entry) whose fields it overrides; parts may refer to further parts up to
//! [`MAX_PART_DEPTH`] levels. Also the rule every body and joint name obeys.

use crate::error::Result;
use crate::io::{ReadPolicy, Source, catalog};
use crate::model::body::BodySpec;
use crate::model::joint::JointSpec;
use std::path::{Path, PathBuf};

/// How deep catalog parts may refer to further parts (guards against a part naming itself).
pub(super) const MAX_PART_DEPTH: usize = 8;

/// A body's or joint's name: not blank, and no control character (C0, DEL, C1). A name is
/// quoted into summaries, CSV headers, figures and messages; a newline or tab in one splits a
/// table row or a comment line there (issue 49), and it is never what the engineer meant.
pub(super) fn check_name(src: &Source, path: &str, name: &str) -> Result<()> {
    if name.trim().is_empty() {
        return Err(src.error(path, "name is empty"));
    }
    check_printable(src, path, name)
}

/// A name (of a body, a joint or the mechanism; a study's variant label) takes printable
/// characters only.
pub(crate) fn check_printable(src: &Source, path: &str, name: &str) -> Result<()> {
    if let Some(c) = name.chars().find(|c| c.is_control()) {
        return Err(src.error(
            path,
            format!(
                "name `{}` holds the control character {:?} (U+{:04X}): names take printable characters only",
                name.escape_debug(),
                c,
                u32::from(c)
            ),
        ));
    }
    Ok(())
}

/// A catalog part type: body or joint specs that can refer to further parts.
pub(super) trait Part: serde::de::DeserializeOwned + Clone {
    /// The RON struct name a part file of this kind begins with.
    const KIND: &'static str;
    fn part(&self) -> Option<&str>;
    fn merged(&self, over: &Self) -> Self;
    fn check_numbers(&self, src: &Source, path: &str) -> Result<()>;
}

impl Part for BodySpec {
    const KIND: &'static str = "Body";
    fn part(&self) -> Option<&str> {
        self.part.as_deref()
    }
    fn merged(&self, over: &Self) -> Self {
        BodySpec::merged(self, over)
    }
    fn check_numbers(&self, src: &Source, path: &str) -> Result<()> {
        BodySpec::check_numbers(self, src, path)
    }
}

impl Part for JointSpec {
    const KIND: &'static str = "Joint";
    fn part(&self) -> Option<&str> {
        self.part.as_deref()
    }
    fn merged(&self, over: &Self) -> Self {
        JointSpec::merged(self, over)
    }
    fn check_numbers(&self, src: &Source, path: &str) -> Result<()> {
        JointSpec::check_numbers(self, src, path)
    }
}

/// The folder of `file`, for resolving the names it writes (empty for a bare file name: the
/// current folder).
pub(super) fn folder_of(file: &Path) -> PathBuf {
    file.parent().map(Path::to_path_buf).unwrap_or_default()
}

/// `item` with its `part` (if any) resolved from `base` and merged under it.
pub(super) fn with_part<T: Part>(item: &T, base: &Path, src: &Source, path: &str, policy: &ReadPolicy) -> Result<T> {
    match item.part() {
        Some(part) => Ok(resolve_part::<T>(base, part, src, path, policy, 0)?.merged(item)),
        None => Ok(item.clone()),
    }
}

/// Loads a catalog part named `part` in `referrer` (whose folder is `base`) under `policy`,
/// following its own `part` references.
pub(super) fn resolve_part<T: Part>(
    base: &Path,
    part: &str,
    referrer: &Source,
    path: &str,
    policy: &ReadPolicy,
    depth: usize,
) -> Result<T> {
    if depth >= MAX_PART_DEPTH {
        return Err(referrer.error(
            &format!("{path}.part"),
            format!("parts nest deeper than {MAX_PART_DEPTH} levels (a part naming itself?)"),
        ));
    }
    let here = format!("{path}.part");
    // A catalog part's own `part` names another catalog part, with or without the prefix: the
    // catalog is its folder.
    let in_catalog = referrer.file.to_str().is_some_and(|f| f.starts_with(catalog::PREFIX));
    let (src, folder) = match catalog::name_of(part).or(in_catalog.then_some(part)) {
        Some(name) => {
            let text = catalog::text(name).map_err(|msg| referrer.error(&here, msg))?;
            (Source::from_text(&format!("{}{name}", catalog::PREFIX), text), None)
        }
        None => {
            let file = policy.resolve(base, part).map_err(|msg| referrer.error(&here, msg))?;
            let src = Source::read_with(&file, policy).map_err(|e| referrer.error(&here, e.to_string()))?;
            (src, Some(folder_of(&file)))
        }
    };
    let spec: T = src.parse_as(T::KIND)?;
    spec.check_numbers(&src, "")?;
    match spec.part() {
        Some(inner) => {
            let folder = folder.unwrap_or_default();
            Ok(resolve_part::<T>(&folder, inner, &src, "", policy, depth + 1)?.merged(&spec))
        }
        None => Ok(spec),
    }
}

//! Reading RON input: parse with serde's field path and ron's span, and find the line:column of
//! any field path afterwards so that semantic errors (an unknown body name, say) point at the
//! offending value just like syntax errors do.
//!
//! RON files are read with the `implicit_some` extension on, so optional fields are written
//! plainly (`damper: 5e-4`, not `damper: Some(5e-4)`), and `unwrap_variant_newtypes`, so an
//! enum variant holding a struct is written `OrderSweep(name: …)`, not `OrderSweep((name: …))`.
//!
//! Files are read under a [`ReadPolicy`] (folders and sizes); the field-path scanner that turns
//! a path into a line:column is the private module `locate`.

pub mod catalog;
mod locate;

pub use locate::{line_col, locate};

use crate::error::{Error, Location, Result};
use locate::{is_word, locate_nearest, skip_attributes, ws};
use serde::de::DeserializeOwned;
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// Where input files may be read from and how large they may be.
///
/// A study or mechanism file names further files (a mechanism, catalog parts). Those names are
/// data, possibly from someone else, so by default they may only lead to files inside the folder
/// tree of the file that was named on the command line: an absolute path, or one that climbs out
/// with `..`, is refused before the disk is touched, and a symbolic link leading out is refused
/// after it is followed. Every file read is capped in size, and a mechanism in its number of
/// bodies, so that a hostile or mistaken input cannot exhaust memory or time.
///
/// # Common mistakes
/// - Roots are folders, not files: `ReadPolicy::within(study.parent())`, not `within(study)`.
/// - The caps still apply to [`ReadPolicy::unrestricted`]; only the folder check is lifted.
#[derive(Debug, Clone)]
pub struct ReadPolicy {
    /// Allowed folders, absolute and lexically normalised (no `.` or `..`).
    roots: Vec<PathBuf>,
    /// `true`: any path may be read (the size and body caps still apply).
    unrestricted: bool,
    /// Largest file that will be read, bytes.
    pub max_file_bytes: u64,
    /// Largest number of bodies (and of joints) in a mechanism; loads may number ten times this.
    pub max_bodies: usize,
}

impl ReadPolicy {
    /// Default size cap: 1 MiB (study, mechanism and part files are a few kB).
    pub const DEFAULT_MAX_FILE_BYTES: u64 = 1 << 20;
    /// Default cap on the number of bodies (and joints) of a mechanism.
    pub const DEFAULT_MAX_BODIES: usize = 1000;

    /// Reads allowed only inside `dir` and the folders below it (an empty `dir` is the current
    /// folder, as `Path::new("m.ron").parent()` gives).
    pub fn within(dir: &Path) -> Self {
        Self {
            roots: vec![absolute_lexical(dir)],
            unrestricted: false,
            max_file_bytes: Self::DEFAULT_MAX_FILE_BYTES,
            max_bodies: Self::DEFAULT_MAX_BODIES,
        }
    }

    /// Allows reads inside another folder too (the CLI's `--allow-read DIR`).
    pub fn allow(mut self, dir: &Path) -> Self {
        self.roots.push(absolute_lexical(dir));
        self
    }

    /// Allows any path (the CLI's `--allow-any-path`); the size and body caps still apply.
    pub fn unrestricted() -> Self {
        Self {
            roots: Vec::new(),
            unrestricted: true,
            max_file_bytes: Self::DEFAULT_MAX_FILE_BYTES,
            max_bodies: Self::DEFAULT_MAX_BODIES,
        }
    }

    /// Sets the largest file that will be read, bytes.
    pub fn with_max_file_bytes(mut self, n: u64) -> Self {
        self.max_file_bytes = n;
        self
    }

    /// Sets the largest number of bodies (and joints) of a mechanism.
    pub fn with_max_bodies(mut self, n: usize) -> Self {
        self.max_bodies = n;
        self
    }

    /// The path `name` (as written in `referrer`'s file) resolved relative to `base`, or why it is refused.
    ///
    /// `base` is the folder of the file that wrote `name`. Under a restricted policy the answer
    /// is the canonical path (symbolic links followed), so that what was checked is what is read.
    /// The refusal of an absolute or climbing path does not depend on whether the file exists:
    /// the message cannot be used to probe the disk.
    pub fn resolve(&self, base: &Path, name: &str) -> std::result::Result<PathBuf, String> {
        let written = Path::new(name);
        if self.unrestricted {
            return Ok(base.join(written));
        }
        // NOTE: `has_root` as well as `is_absolute`: on Windows `\x` has a root but no prefix and
        // is not "absolute", yet it leaves `base` all the same.
        let rooted = written.has_root()
            || written.is_absolute()
            || written.components().any(|c| matches!(c, Component::Prefix(_)));
        let joined = absolute_lexical(&base.join(written));
        if rooted || !self.lexically_inside(&joined) {
            return Err(self.refusal(name));
        }
        // NOTE: the normalised path, so that `x/../a.ron` means `a.ron` as it reads, even when
        // there is no folder `x` (or `x` is a link elsewhere).
        let canonical =
            std::fs::canonicalize(&joined).map_err(|e| format!("cannot read `{}`: {e}", joined.display()))?;
        if !self.canonically_inside(&canonical) {
            return Err(format!(
                "`{name}` leads through a symbolic link to a file outside {}; {}",
                self.roots_list(),
                Self::HOW_TO_ALLOW
            ));
        }
        Ok(canonical)
    }

    const HOW_TO_ALLOW: &'static str =
        "pass `--allow-read DIR` to allow another folder, or `--allow-any-path` to lift the restriction";

    fn roots_list(&self) -> String {
        let names: Vec<String> = self.roots.iter().map(|r| format!("`{}`", r.display())).collect();
        format!("the folder(s) input may be read from ({})", names.join(", "))
    }

    fn refusal(&self, name: &str) -> String {
        format!(
            "`{name}` is outside {}: absolute paths and paths that climb out with `..` are refused; {}",
            self.roots_list(),
            Self::HOW_TO_ALLOW
        )
    }

    fn lexically_inside(&self, p: &Path) -> bool {
        self.roots.iter().any(|r| p.starts_with(r))
    }

    /// Compares with the roots' canonical forms, so that a root that is itself reached through a
    /// symbolic link (a temporary folder on macOS, say) still contains its files.
    fn canonically_inside(&self, canonical: &Path) -> bool {
        self.roots.iter().any(|r| std::fs::canonicalize(r).is_ok_and(|r| canonical.starts_with(r)))
    }

    /// Checks a path named directly (not written in a file) and returns what to open.
    fn admit(&self, path: &Path) -> Result<PathBuf> {
        if self.unrestricted {
            return Ok(path.to_path_buf());
        }
        let refuse = |message: String| Error::Input {
            location: Location { file: path.to_path_buf(), line_col: None, path: String::new() },
            message,
        };
        if !self.lexically_inside(&absolute_lexical(path)) {
            return Err(refuse(self.refusal(&path.display().to_string())));
        }
        let canonical = std::fs::canonicalize(path).map_err(|source| Error::Io {
            file: path.to_path_buf(),
            action: "cannot read",
            source,
        })?;
        if !self.canonically_inside(&canonical) {
            return Err(refuse(format!(
                "leads through a symbolic link to a file outside {}; {}",
                self.roots_list(),
                Self::HOW_TO_ALLOW
            )));
        }
        Ok(canonical)
    }
}

/// `p` made absolute (against the current folder) with `.` and `..` removed by text alone,
/// without asking the file system. `..` at the root stays at the root, as the OS does.
fn absolute_lexical(p: &Path) -> PathBuf {
    let p = if p.as_os_str().is_empty() { Path::new(".") } else { p };
    let full = if p.is_absolute() {
        p.to_path_buf()
    } else {
        // Without a current folder, stay relative: roots and names are then compared alike.
        std::env::current_dir().map_or_else(|_| p.to_path_buf(), |cwd| cwd.join(p))
    };
    let mut out = PathBuf::new();
    for c in full.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                if matches!(out.components().next_back(), Some(Component::Normal(_))) {
                    out.pop();
                } else if !out.has_root() {
                    // A relative path climbing above its start: keep the `..` so it matches no root.
                    out.push("..");
                }
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// A RON source kept in memory with its file name, for locating fields in error messages.
#[derive(Debug, Clone)]
pub struct Source {
    /// The file the text came from (for messages).
    pub file: PathBuf,
    /// The text.
    pub text: String,
}

impl Source {
    /// Reads a file named directly (on the command line, say): any path, but no larger than
    /// [`ReadPolicy::DEFAULT_MAX_FILE_BYTES`] and only a regular file of UTF-8 text.
    pub fn read(path: &Path) -> Result<Self> {
        Self::read_with(path, &ReadPolicy::unrestricted())
    }

    /// Reads a file under `policy`: it must lie inside the policy's folders (after following
    /// symbolic links), be a regular file no larger than `policy.max_file_bytes`, and be UTF-8.
    /// Messages name `path` as given.
    pub fn read_with(path: &Path, policy: &ReadPolicy) -> Result<Self> {
        let open = policy.admit(path)?;
        let bytes = read_capped(path, &open, policy.max_file_bytes)?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let bytes = e.as_bytes();
            let valid = e.utf8_error().valid_up_to();
            let before = std::str::from_utf8(&bytes[..valid]).unwrap_or_default();
            Error::Input {
                location: Location {
                    file: path.to_path_buf(),
                    line_col: Some(line_col(before, before.len())),
                    path: String::new(),
                },
                message: format!("not UTF-8 text (invalid byte 0x{:02x})", bytes.get(valid).copied().unwrap_or(0)),
            }
        })?;
        Ok(Self { file: path.to_path_buf(), text })
    }

    /// Wraps text that has no file (tests, generated input).
    pub fn from_text(name: &str, text: &str) -> Self {
        Self { file: PathBuf::from(name), text: text.to_string() }
    }

    /// Deserializes the text as `T` after checking that it begins with `expected(` (after
    /// whitespace, comments and `#![enable(…)]` attributes), e.g. `expected = "Mechanism"`.
    ///
    /// A file of another kind (a password file named by mistake or by malice, a binary) is then
    /// refused with a message that quotes none of its content.
    pub fn parse_as<T: DeserializeOwned>(&self, expected: &str) -> Result<T> {
        let b = self.text.as_bytes();
        let start = skip_attributes(b, 0);
        let named = b[start..].starts_with(expected.as_bytes()) && {
            let after = start + expected.len();
            // `MechanismX(` is not `Mechanism(`.
            !b.get(after).is_some_and(|&c| is_word(c)) && b.get(ws(b, after)) == Some(&b'(')
        };
        if !named {
            return Err(Error::Input {
                location: Location {
                    file: self.file.clone(),
                    line_col: Some(line_col(&self.text, start)),
                    path: String::new(),
                },
                message: format!("not a `{expected}` file: it must begin with `{expected}(`"),
            });
        }
        self.parse()
    }

    /// Deserializes the whole text as `T`, turning ron and serde errors into [`Error::Input`] with
    /// the file, line:column and field path. Prefer [`Source::parse_as`] for whole files.
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T> {
        let opts = ron::Options::default().with_default_extension(
            ron::extensions::Extensions::IMPLICIT_SOME | ron::extensions::Extensions::UNWRAP_VARIANT_NEWTYPES,
        );
        // NOTE: the options keep ron's default recursion limit (128 levels), which is what stops
        // `[[[[…` or deeply nested compounds from overflowing the stack.
        let mut de = ron::Deserializer::from_str_with_options(&self.text, &opts)
            .map_err(|e| self.spanned_error(&e, String::new()))?;
        let value: T = serde_path_to_error::deserialize(&mut de).map_err(|e| {
            let path = e.path().to_string();
            let path = if path == "." { String::new() } else { path };
            let inner = e.into_inner();
            self.spanned_error(&de.span_error(inner), path)
        })?;
        de.end().map_err(|e| self.spanned_error(&de.span_error(e), String::new()))?;
        Ok(value)
    }

    fn spanned_error(&self, e: &ron::error::SpannedError, path: String) -> Error {
        let top = path.is_empty() && !self.begins_with_a_struct();
        let message = match &e.code {
            // A file of some other kind: ron would quote its first word or character back.
            _ if top => "not a kanedyn input file: it must begin with a name and `(`, e.g. `Mechanism(`".to_string(),
            ron::Error::ExpectedDifferentStructName { expected, .. } if path.is_empty() => {
                format!("not a `{expected}` file: it must begin with `{expected}(`")
            }
            code => code.to_string(),
        };
        Error::Input {
            location: Location { file: self.file.clone(), line_col: Some((e.span.start.line, e.span.start.col)), path },
            message,
        }
    }

    /// Whether the text begins (after attributes) with `Name(` or `(`: the shape of every
    /// kanedyn input file.
    fn begins_with_a_struct(&self) -> bool {
        let b = self.text.as_bytes();
        let mut i = skip_attributes(b, 0);
        while i < b.len() && is_word(b[i]) {
            i += 1;
        }
        b.get(ws(b, i)) == Some(&b'(')
    }

    /// The location of a field path such as `joints[1].parent`: line:column of the value when
    /// found, else of the nearest enclosing value that is (a field merged from a catalog part,
    /// say, is reported at the body that uses the part).
    pub fn locate(&self, path: &str) -> Location {
        Location {
            file: self.file.clone(),
            line_col: locate_nearest(&self.text, path).map(|off| line_col(&self.text, off)),
            path: path.to_string(),
        }
    }

    /// An input error at a field path.
    pub fn error(&self, path: &str, message: impl Into<String>) -> Error {
        Error::Input { location: self.locate(path), message: message.into() }
    }
}

/// Reads at most `max + 1` bytes of the regular file `open`, naming `file` in messages.
fn read_capped(file: &Path, open: &Path, max: u64) -> Result<Vec<u8>> {
    let io = |source| Error::Io { file: file.to_path_buf(), action: "cannot read", source };
    let refuse = |message: String| Error::Input {
        location: Location { file: file.to_path_buf(), line_col: None, path: String::new() },
        message,
    };
    let not_regular = |meta: &std::fs::Metadata| {
        let kind = if meta.is_dir() { "a folder" } else { "a device, pipe or socket" };
        refuse(format!("not a regular file ({kind}): input must be a RON text file"))
    };
    let too_large = |size: String| {
        refuse(format!(
            "file is {size} bytes, more than the limit of {max} bytes (input files are a few kB); \
             if it is genuine, raise the limit with `--max-file-kb` (library: `ReadPolicy::with_max_file_bytes`)"
        ))
        .limit_if(true)
    };
    // Stat before opening: opening a FIFO would block until someone writes to it.
    let meta = std::fs::metadata(open).map_err(io)?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    if meta.len() > max {
        return Err(too_large(meta.len().to_string()));
    }
    let f = std::fs::File::open(open).map_err(io)?;
    // The same checks on the opened handle, in case the path was swapped since the stat.
    let meta = f.metadata().map_err(io)?;
    if !meta.is_file() {
        return Err(not_regular(&meta));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(max) as usize + 1);
    // One byte more than allowed tells a file that grew past the limit from one that fits.
    f.take(max.saturating_add(1)).read_to_end(&mut bytes).map_err(io)?;
    if bytes.len() as u64 > max {
        return Err(too_large(format!("more than {max}")));
    }
    Ok(bytes)
}

/// Names joined by commas, for the "(known: …)" part of an error message.
pub(crate) fn known_list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names.collect::<Vec<_>>().join(", ")
}

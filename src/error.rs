//! Error types: input errors that name the file, the line:column and the field path, and engine
//! errors raised while evaluating the equations of motion.

use std::fmt;
use std::path::PathBuf;

/// A place in an input file: the file, the 1-based line and column when known, and the field path
/// (`joints[1].parent`).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Location {
    /// The file (as given, or `<input>` for text without a file).
    pub file: PathBuf,
    /// 1-based line and column of the value, when it could be found.
    pub line_col: Option<(usize, usize)>,
    /// Field path from the file's top-level value, e.g. `joints[1].parent`; empty for the whole file.
    pub path: String,
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some((l, c)) = self.line_col {
            write!(f, ":{l}:{c}")?;
        }
        if !self.path.is_empty() {
            write!(f, " (field `{}`)", self.path)?;
        }
        Ok(())
    }
}

/// Errors of kanedyn's library API.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {action}: {source}", file.display())]
    Io {
        /// The file.
        file: PathBuf,
        /// What was being done ("cannot read", "cannot write").
        action: &'static str,
        /// The operating-system error.
        source: std::io::Error,
    },
    /// Bad input: a syntax error, an unknown field, a wrong type or a semantic problem.
    #[error("{location}: {message}")]
    Input {
        /// Where the problem is.
        location: Location,
        /// What is wrong, in words.
        message: String,
    },
    /// A limit refused the input: a file, a mechanism or a study's estimated work (memory, output,
    /// CPU time) beyond a limit that can be raised on purpose (the message names the flag or
    /// option). Input that is wrong, not just large, is [`Error::Input`].
    #[error("{location}: {message}")]
    Limit {
        /// Where the refused quantity is set (the file, or the field that drives it).
        location: Location,
        /// What exceeds which limit and how to raise it, in words.
        message: String,
    },
    /// A mechanism that parses but cannot be simulated (e.g. a singular mass matrix).
    #[error("mechanism `{mechanism}`: {message}")]
    Model {
        /// The mechanism's name.
        mechanism: String,
        /// What is wrong.
        message: String,
    },
    /// A failure while evaluating the equations of motion.
    #[error(transparent)]
    Engine(#[from] EngineError),
}

impl Error {
    /// Whether this is a limit's refusal ([`Error::Limit`]).
    pub fn is_limit(&self) -> bool {
        matches!(self, Error::Limit { .. })
    }

    /// This error as a limit's refusal when `limit` is true and it is an [`Error::Input`]; else
    /// unchanged. Code that moves an input error to another file or field (an overlay, a
    /// study's sub-study) builds an `Input` at the new place and keeps the class with this.
    pub(crate) fn limit_if(self, limit: bool) -> Self {
        match self {
            Error::Input { location, message } if limit => Error::Limit { location, message },
            other => other,
        }
    }
}

/// Failures of the equation-of-motion evaluation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EngineError {
    /// The LDLᵀ factorisation of M met a non-positive pivot: the speed `dof` (named by its
    /// joint) has no inertia of its own at this configuration.
    #[error(
        "mass matrix is not positive definite: pivot {pivot:e} at speed {dof} (joint `{joint}`); a body without mass or inertia about that joint, or a massless point mass on its own pivot?"
    )]
    NotPositiveDefinite {
        /// Index of the generalized speed.
        dof: usize,
        /// Name of the joint that owns it.
        joint: String,
        /// The offending pivot value.
        pivot: f64,
    },
    /// The state or a load produced a non-finite number.
    #[error("non-finite value in {what} (index {index})")]
    NonFinite {
        /// Which quantity.
        what: &'static str,
        /// Its index.
        index: usize,
    },
    /// A path joint's coordinate left the path (beyond its end of travel, where the path is
    /// singular, e.g. the epicycloid's cusp) or reached the joint's travel limit. The time of
    /// the failing evaluation is added by the integrator's error around it.
    #[error(
        "joint `{joint}` left its path: arc length {coordinate:e} m, {} ±{travel:e} m (the absorber's amplitude exceeds its travel)",
        if *limit { "beyond its travel limit (field `travel`) of" } else { "the path ends at" }
    )]
    OutOfTravel {
        /// Name of the path joint.
        joint: String,
        /// Its coordinate (the absorber's amplitude when it stopped), m.
        coordinate: f64,
        /// Its end of travel, m: the travel limit when `limit`, else the path's own end.
        travel: f64,
        /// True when the joint's travel limit (its `travel` field) was reached before the path's end.
        limit: bool,
    },
    /// A state vector of the wrong length was passed.
    #[error("{what} has length {got}, the mechanism needs {expected}")]
    Dimension {
        /// Which argument.
        what: &'static str,
        /// Its length.
        got: usize,
        /// The expected length.
        expected: usize,
    },
}

/// Result alias of the library.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// The failure line for a panic caught around one analysis or one design case (so that one bug
/// costs the others nothing): its message, from a `&str` or `String` payload.
pub(crate) fn internal_error(payload: &(dyn std::any::Any + Send)) -> String {
    let what = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_default();
    format!("internal error (please report): {what}")
}

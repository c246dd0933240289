//! Where a study writes: `<out>/<name>/`, built only from validated names, reached atomically.
//!
//! A run holds an exclusive lock on `<out>/.<name>.lock` from start to end (an OS file lock, so
//! it is released however the process ends), writes into a fresh `<out>/.<name>.partial-<pid>/`,
//! and at the end renames that folder into place, after moving the previous results aside. So:
//! two runs into the same folder never mix (the second is refused while the first holds the
//! lock); an interrupted run leaves only a hidden `.partial-` folder, never a half-written
//! folder under the study's name; and a finished run's folder always holds one whole run.

use crate::error::{Error, Result};
use std::fs::{File, OpenOptions, TryLockError};
use std::path::{Component, Path, PathBuf};

/// A study's output in progress: the lock, the temporary folder and the final one.
pub(crate) struct OutputDir {
    _lock: File,
    temp: PathBuf,
    target: PathBuf,
}

fn io<'a>(file: &'a Path, action: &'static str) -> impl FnOnce(std::io::Error) -> Error + 'a {
    move |source| Error::Io { file: file.to_path_buf(), action, source }
}

impl OutputDir {
    /// Takes the lock and makes a fresh temporary folder; `name` must have passed
    /// `validate::check_file_name` (checked again here: a single normal path component).
    pub(crate) fn begin(root: &Path, name: &str) -> Result<Self> {
        let single = matches!(Path::new(name).components().collect::<Vec<_>>()[..], [Component::Normal(_)]);
        if !single || name.starts_with('.') {
            return Err(Error::Io {
                file: root.join(name),
                action: "cannot write",
                source: std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("study name `{}` is not a plain folder name", name.escape_debug()),
                ),
            });
        }
        std::fs::create_dir_all(root).map_err(io(root, "cannot create"))?;
        let lock_path = root.join(format!(".{name}.lock"));
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .map_err(io(&lock_path, "cannot create"))?;
        match lock.try_lock() {
            Ok(()) => {}
            // The folder's path leads the message (it used to read "mechanism ``:", a
            // mechanism error with no mechanism).
            Err(TryLockError::WouldBlock) => {
                return Err(Error::Io {
                    file: root.join(name),
                    action: "output folder busy",
                    source: std::io::Error::new(
                        std::io::ErrorKind::WouldBlock,
                        format!(
                            "it is being written by another kanedyn run (lock {}): wait for it to finish or give \
                             another --out",
                            lock_path.display()
                        ),
                    ),
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(&lock_path, "cannot lock")(e)),
        }
        // Holding the lock, every `.partial-` folder of this name is a dead run's: clear them.
        if let Ok(entries) = std::fs::read_dir(root) {
            let prefix = format!(".{name}.partial-");
            for e in entries.flatten() {
                if e.file_name().to_str().is_some_and(|f| f.starts_with(&prefix)) {
                    std::fs::remove_dir_all(e.path()).ok();
                }
            }
        }
        let temp = root.join(format!(".{name}.partial-{}", std::process::id()));
        std::fs::create_dir(&temp).map_err(io(&temp, "cannot create"))?;
        Ok(Self { _lock: lock, temp, target: root.join(name) })
    }

    /// The folder to write into now.
    pub(crate) fn dir(&self) -> &Path {
        &self.temp
    }

    /// Moves the finished folder into place (the previous results are removed) and returns its
    /// path. On failure the results stay in the temporary folder, which the error names.
    pub(crate) fn finish(self) -> Result<PathBuf> {
        let root = self.target.parent().map(Path::to_path_buf).unwrap_or_default();
        if self.target.exists() {
            let old = root.join(format!(
                ".{}.old-{}",
                self.target.file_name().and_then(|f| f.to_str()).unwrap_or("study"),
                std::process::id()
            ));
            std::fs::rename(&self.target, &old).map_err(io(&self.target, "cannot replace"))?;
            std::fs::remove_dir_all(&old).ok();
        }
        std::fs::rename(&self.temp, &self.target).map_err(io(&self.temp, "cannot move into place"))?;
        Ok(self.target)
    }
}

/// `a / reference`, or NaN ("undefined", an empty CSV cell) when the reference is zero or below
/// `1e-5 · scale`: a locked (linear) twin answers only at the lines it is excited at, and its
/// other traces are numerical noise of ~1e-6 of its largest, whose ratios would read as huge
/// amplifications.
pub(crate) fn ratio(a: f64, reference: f64, scale: f64) -> f64 {
    if reference.abs() > 1e-5 * scale.abs() && reference != 0.0 { a / reference } else { f64::NAN }
}

/// The last guard of the promise that no output reads `NaN` or `inf`: every such word outside
/// backticks (names are quoted in backticks, so a mechanism called `inf` keeps its name) becomes
/// "undefined". The summaries format their numbers with [`cell`] and friends; this catches a
/// number a formatter missed, e.g. in a solver's error message, before it reaches summary.md,
/// results.json or report.html (issue 25: a multi-order run printed "NaN (locked 1.7e-14)").
/// A word here runs over letters, digits and `-+._/\`, so a path such as `/tmp/nan/s.ron` is
/// one word and left alone.
pub(crate) fn finite_text(text: &str) -> String {
    let word_char = |c: char| c.is_ascii_alphanumeric() || matches!(c, '-' | '+' | '.' | '_' | '/' | '\\');
    let mut out = String::with_capacity(text.len());
    let mut quoted = false;
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        if !word_char(c) {
            quoted ^= c == '`';
            out.push(c);
            rest = &rest[c.len_utf8()..];
            continue;
        }
        let end = rest.find(|c: char| !word_char(c)).unwrap_or(rest.len());
        let word = &rest[..end];
        let bare = word.trim_start_matches(['-', '+']).to_ascii_lowercase();
        if !quoted && matches!(bare.as_str(), "nan" | "inf" | "infinity") {
            out.push_str("undefined");
        } else {
            out.push_str(word);
        }
        rest = &rest[end..];
    }
    out
}

/// A number for a summary table, or `undefined` when it is not finite.
pub(crate) fn cell(v: f64, precision: usize) -> String {
    if v.is_finite() { format!("{v:.precision$}") } else { "undefined".into() }
}

/// Writes a text file, naming it on failure.
pub(crate) fn write_file(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e })
}

/// A cell as a spreadsheet will show it, not run it: text starting with `=`, `+`, `-`, `@`, a
/// tab or a carriage return is a formula to Excel, LibreOffice and Google Sheets (a joint named
/// `=HYPERLINK(…)` in a column header, issue 49), so it gets a leading `'`, which they take for
/// "text" and do not display. A number (`-0.5`, `+1e-3`) stays as written: it is a number to
/// them too, and the files must read back as numbers.
pub(crate) fn neutralised(cell: &str) -> std::borrow::Cow<'_, str> {
    let formula = cell.starts_with(['=', '+', '-', '@', '\t', '\r']);
    if formula && !cell.parse::<f64>().is_ok_and(f64::is_finite) {
        std::borrow::Cow::Owned(format!("'{cell}"))
    } else {
        std::borrow::Cow::Borrowed(cell)
    }
}

/// A CSV writer whose every cell, header or value, passes through [`neutralised`]: the one way
/// the study writes CSV files.
pub(crate) struct CsvWriter(csv::Writer<File>);

impl CsvWriter {
    /// Creates (or truncates) the file at `path`.
    pub(crate) fn from_path(path: &Path) -> csv::Result<Self> {
        csv::Writer::from_path(path).map(Self)
    }

    /// Writes one record.
    pub(crate) fn write_record<I, T>(&mut self, record: I) -> csv::Result<()>
    where
        I: IntoIterator<Item = T>,
        T: AsRef<str>,
    {
        // Field by field, so a cell that needs no quote is written from where it lies (no copy).
        for cell in record {
            self.0.write_field(neutralised(cell.as_ref()).as_bytes())?;
        }
        self.0.write_record(std::iter::empty::<&[u8]>())
    }

    /// Writes one record of finite numbers as `f64`'s shortest round-trip text: a number is
    /// never a formula, so no cell is checked.
    fn write_numbers(&mut self, record: &[String]) -> csv::Result<()> {
        self.0.write_record(record)
    }

    /// Flushes the buffered records to the file.
    pub(crate) fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()
    }
}

/// Smallest magnitude written in plain decimal: below it a number is data noise or a physical
/// small quantity whose leading zeros say nothing (`0.000…000452` read as `4.52e-34`).
const PLAIN_MIN: f64 = 1e-5;
/// Smallest magnitude written with an exponent at the top: from 1e16 on, an f64 no longer holds
/// every integer, and plain text would print digits it does not have.
const PLAIN_MAX: f64 = 1e16;

/// A number as a CSV cell: the shortest decimal text that reads back to the same `f64` (Rust's
/// shortest round-trip digits, at most 17 significant), plain for `1e-5 ≤ |v| < 1e16` and in
/// exponent form (`4.52089390554142e-34`, `1.5e16`) outside; zero of either sign is `0`, and a
/// value that is not finite (NaN: does not exist or apply) is an empty cell.
pub(crate) fn csv_number(v: f64) -> String {
    if !v.is_finite() {
        String::new()
    } else if v == 0.0 {
        // -0.0 compares equal to 0.0: a sign on nothing would read as a measurement.
        "0".to_string()
    } else if (PLAIN_MIN..PLAIN_MAX).contains(&v.abs()) {
        v.to_string()
    } else {
        format!("{v:e}")
    }
}

/// Writes a CSV file with a header row and columns of equal length, each number as
/// [`csv_number`] writes it (non-finite values as empty cells); text a spreadsheet would run as a formula is [`neutralised`].
pub(crate) fn write_csv(path: &Path, header: &[&str], columns: &[&[f64]]) -> Result<()> {
    let io = |e: csv::Error| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e.into() };
    let mut w = CsvWriter::from_path(path).map_err(io)?;
    w.write_record(header).map_err(io)?;
    let rows = columns.iter().map(|c| c.len()).min().unwrap_or(0);
    let mut rec = Vec::with_capacity(columns.len());
    for r in 0..rows {
        rec.clear();
        // A value that does not exist or apply (a ratio to a zero reference, a trace that does
        // not reach this order) is NaN in memory and an empty cell on disk, never `NaN`/`inf`.
        rec.extend(columns.iter().map(|c| csv_number(c[r])));
        w.write_numbers(&rec).map_err(io)?;
    }
    w.flush().map_err(|e| Error::Io { file: path.to_path_buf(), action: "cannot write", source: e })
}

#[cfg(test)]
mod finite_text_tests {
    use super::finite_text;

    #[test]
    fn non_finite_words_become_undefined_but_names_and_paths_stay() {
        assert_eq!(finite_text("| NaN (locked 1.7e-14) |"), "| undefined (locked 1.7e-14) |");
        assert_eq!(finite_text("t = -inf, x = Infinity"), "t = undefined, x = undefined");
        assert_eq!(finite_text("mechanism `inf` at /tmp/nan/s.ron:3:4"), "mechanism `inf` at /tmp/nan/s.ron:3:4");
        assert_eq!(finite_text("information, finite, 1e-300, inflow"), "information, finite, 1e-300, inflow");
    }
}

#[cfg(test)]
mod csv_number_tests {
    use super::csv_number;

    #[test]
    fn shortest_round_trip_text_with_exponents_outside_the_plain_range() {
        // Expected texts written by hand from the decimal values (not from the formatter).
        let cases = [
            (4.52089390554142e-34, "4.52089390554142e-34"),
            (-4.336808689942018e-19, "-4.336808689942018e-19"),
            (-0.0, "0"),
            (0.0, "0"),
            (1e-5, "0.00001"),
            (9.99e-6, "9.99e-6"),
            (0.1 + 0.2, "0.30000000000000004"),
            (576.25, "576.25"),
            (3.0, "3"),
            (9999999999999998.0, "9999999999999998"),
            (1e16, "1e16"),
            (-2.5e300, "-2.5e300"),
            (f64::MIN_POSITIVE, "2.2250738585072014e-308"),
            (f64::NAN, ""),
            (f64::INFINITY, ""),
        ];
        for (v, text) in cases {
            assert_eq!(csv_number(v), text, "{v:e}");
            if !text.is_empty() {
                // Reads back to the same double, except that -0 is written as 0 on purpose.
                assert_eq!(text.parse::<f64>().unwrap().to_bits(), (v + 0.0).to_bits(), "{text}");
            }
        }
    }
}

#[cfg(test)]
mod neutralised_tests {
    use super::neutralised;

    #[test]
    fn formulas_get_a_quote_and_numbers_stay_numbers() {
        for formula in ["=HYPERLINK(\"x\")", "+cmd", "-2+3", "@SUM(A1)", "\tx", "\r=1", "-", "-inf", "+NaN"] {
            assert_eq!(neutralised(formula), format!("'{formula}"), "{formula:?}");
        }
        for plain in ["-0.5", "+1e-3", "-1.5e300", "0", "pivot_angle_rad", "a=b", "", "'quoted"] {
            assert_eq!(neutralised(plain), plain, "{plain:?}");
        }
    }
}

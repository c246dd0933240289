//! One CSV file's content as data ([`Table`]): its columns in order, each with its header, SI
//! unit and values. Every analysis builds its CSVs as tables; the same tables are written as CSV
//! files and carried into `results.json`, so the two cannot drift apart.

use super::write_csv;
use crate::error::Result;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// The content of one CSV file: its columns, in order, with their units.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Table {
    /// The file name without `.csv`.
    pub name: String,
    /// The file name.
    pub file: String,
    /// The columns, in the file's order.
    pub columns: Vec<Column>,
}

/// One column of a [`Table`].
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Column {
    /// The header, as in the CSV file (it carries the unit too, e.g. `amp_1x_rad_s2`).
    pub name: String,
    /// SI unit, `"1"` for a dimensionless number.
    pub unit: &'static str,
    /// The values; NaN (written as an empty cell, and as `null` in JSON) where none exists.
    pub values: Vec<f64>,
}

impl Table {
    /// An empty table for the file `<name>.csv`.
    pub fn new(name: impl Into<String>) -> Self {
        let name = name.into();
        Self { file: format!("{name}.csv"), name, columns: Vec::new() }
    }

    /// Appends a column.
    pub fn push(&mut self, name: impl Into<String>, unit: &'static str, values: Vec<f64>) {
        self.columns.push(Column { name: name.into(), unit, values });
    }

    /// The column called `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|c| c.name == name)
    }

    /// Writes the table as `dir/<file>` (see `study::write_csv`: non-finite values become empty
    /// cells) and returns the path.
    pub fn write_csv(&self, dir: &Path) -> Result<PathBuf> {
        let path = dir.join(&self.file);
        let header: Vec<&str> = self.columns.iter().map(|c| c.name.as_str()).collect();
        let columns: Vec<&[f64]> = self.columns.iter().map(|c| c.values.as_slice()).collect();
        write_csv(&path, &header, &columns)?;
        Ok(path)
    }
}

/// A number for a file name or label: whole numbers plainly, tiny or huge ones in exponent form
/// (`1e-300` would otherwise print 300 digits and make a file name too long).
pub(crate) fn fmt_num(v: f64) -> String {
    if v != 0.0 && !(1e-3..1e9).contains(&v.abs()) {
        format!("{v:e}")
    } else if v.fract() == 0.0 {
        format!("{v:.0}")
    } else {
        format!("{v}")
    }
}

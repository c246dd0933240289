//! SVG line plots for reports, in the manner of the paper's figures: panels of x–y series, each
//! solid, dashed or dotted, optionally with a logarithmic y axis (Figure 2 of the paper).
//!
//! This is the one module that sees plotters. SVG needs no system font library (plotters' default
//! features, which pull in font-kit, stay off), so text is laid out with plotters' naive metrics
//! and drawn by the SVG viewer.
//!
//! plotters works in whole backend pixels, which made the figures pixel images in SVG clothing
//! (staircases when zoomed, a quarter of the points repeating the one before). So every figure
//! is drawn [`FINE`] times larger and [`vector`] writes the result back at its nominal size with
//! two decimals, dropping repeated points: a thin pass over plotters' regular output rather than
//! an SVG writer of our own.

mod heatmap;
mod legend;
mod panel;
#[cfg(test)]
mod tests;
mod vector;

pub use heatmap::{Heatmap, write_heatmap_svg};
pub use vector::vector;

use crate::error::{Error, Result};
use panel::draw_panel;
use plotters::prelude::*;
use std::path::Path;
use vector::{groups_for_readers, trim};

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// A continuous line.
    #[default]
    Solid,
    /// Dashes (the paper's down-sweeps).
    Dashed,
    /// Dots (the paper's locked-rotor references).
    Dotted,
    /// A filled circle at each point and no line (cases of a design study drawn at random).
    Points,
    /// The points as a closed polygon, filled in a light tint of the colour and not outlined (a
    /// region of a parameter plane, drawn under the curves that bound it).
    Region,
}

/// One curve: points `(x[i], y[i])`, a legend label, a colour index into a fixed palette and a
/// line style. Non-finite points (and, on a log axis, non-positive `y`) are skipped.
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Legend text (empty: no legend entry).
    pub label: String,
    /// Abscissae.
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
    /// Index into the palette (same index, same colour across panels).
    pub color: usize,
    /// Line style.
    pub style: LineStyle,
}

/// A point marked and labelled on a panel (a resonance on a Campbell diagram), or with
/// `marker: false` a label alone (an order line's name at its end). Labels are placed next to
/// their points where they overlap neither another label nor a marker, pushed further out (with a
/// leader line) when every near place is taken, so close points keep readable labels.
#[derive(Debug, Clone, Default)]
pub struct PointLabel {
    /// Abscissa of the point.
    pub x: f64,
    /// Ordinate of the point.
    pub y: f64,
    /// The label.
    pub text: String,
    /// Draw a marker (an open circle) at the point.
    pub marker: bool,
}

/// One set of axes.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// Title above the axes.
    pub title: String,
    /// x-axis label (with units).
    pub x_label: String,
    /// y-axis label (with units).
    pub y_label: String,
    /// Logarithmic y axis.
    pub log_y: bool,
    /// Fixed x range; `None` fits the data.
    pub x_range: Option<(f64, f64)>,
    /// Fixed y range; `None` fits the data (with a margin).
    pub y_range: Option<(f64, f64)>,
    /// Vertical reference lines (e.g. n_t, n_r), each with a label.
    pub markers: Vec<(f64, String)>,
    /// The curves.
    pub series: Vec<Series>,
    /// Labelled points, drawn over the curves.
    pub labels: Vec<PointLabel>,
}

const PALETTE: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
    RGBColor(255, 127, 14),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

fn color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Backend units per SVG pixel: plotters rounds to whole backend units, so drawing 100 times
/// larger keeps positions to 1/100 pixel, the two decimals [`vector`] writes.
pub const FINE: u32 = 100;

/// `v` pixels in backend units.
const fn px(v: u32) -> u32 {
    v * FINE
}

/// The sans-serif font at `size` pixels.
fn font(size: u32) -> FontDesc<'static> {
    ("sans-serif", f64::from(px(size))).into_font()
}

/// Draws into an SVG of `width`×`height` pixels through `draw` (which sees a backend [`FINE`]
/// times larger), then writes it to `path` at its nominal size ([`vector`]).
fn write_fine(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(DrawingArea<SVGBackend, plotters::coord::Shift>) -> DynResult,
) -> Result<()> {
    let mut text = String::new();
    {
        let root = SVGBackend::with_string(&mut text, (px(width), px(height))).into_drawing_area();
        draw(root).map_err(|e| plot_error(path, e))?;
    }
    std::fs::write(path, groups_for_readers(&vector(&text))).map_err(|source| Error::Io {
        file: path.to_path_buf(),
        action: "cannot write plot",
        source,
    })
}

/// Writes `panels` side by side (one row) to an SVG file of `width`×`height` pixels per panel.
pub fn write_svg(path: &Path, panels: &[Panel], width: u32, height: u32) -> Result<()> {
    let cols = panels.len().max(1) as u32;
    write_fine(path, (width * cols, height), |root| {
        root.fill(&WHITE)?;
        let areas = root.split_evenly((1, cols as usize));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            draw_panel(panel, area)?;
        }
        root.present()?;
        Ok(())
    })
}

/// A drawing error as the I/O error of the plot file it was writing.
fn plot_error(path: &Path, e: Box<dyn std::error::Error>) -> Error {
    Error::Io { file: path.to_path_buf(), action: "cannot write plot", source: std::io::Error::other(e.to_string()) }
}

/// A number as the figures write it, in legends, labels, titles and ticks alike: at most `sig`
/// significant digits, trailing zeros dropped, in exponent form (`5e-4`, `2.5e5`) only below
/// 1e-3 or from 1e5 on. One format for every figure: they used to switch between `0.3859`,
/// `1.0057e-1` and plotters' `9.999999999999999e-6`.
pub fn num(v: f64, sig: usize) -> String {
    let sig = sig.max(1);
    // Rounded to `sig` digits first, so that the form follows the number as written (99 999.9
    // at four digits is 1e5, not 100000).
    let v: f64 = format!("{v:.*e}", sig - 1).parse().unwrap_or(v);
    let a = v.abs();
    if v == 0.0 {
        "0".into()
    } else if !v.is_finite() {
        format!("{v}")
    } else if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.*e}", sig - 1);
        match s.split_once('e') {
            Some((m, e)) if m.contains('.') => format!("{}e{e}", m.trim_end_matches('0').trim_end_matches('.')),
            _ => s,
        }
    } else {
        let decimals = (sig as i32 - 1 - a.log10().floor() as i32).clamp(0, 12) as usize;
        trim(format!("{v:.decimals$}"))
    }
}

/// A tick label: [`num`] with four significant digits.
fn tick(v: f64) -> String {
    num(v, 4)
}

type DynResult = std::result::Result<(), Box<dyn std::error::Error>>;

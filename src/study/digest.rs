//! The terminal's digest of a study run: a screenful that says whether everything ran, what each
//! analysis found, what failed and where, and which file to open next.
//!
//! The full tables stay in `summary.md` (`kanedyn run --verbose` prints them): an engineer at a
//! terminal wants the verdict and the way to the report, not 170 lines that scroll the status
//! off the screen. Each analysis gives its own line ([`Analysis::digest`](super::analysis::Analysis)),
//! read off the same results its summary section and `results.json` use.

use super::{Study, StudyReport, json};
use std::path::PathBuf;

/// Most lines of a digest, whatever the study.
pub const MAX_LINES: usize = 25;

/// Most failures listed one by one; the others are counted on one line.
const MAX_FAILURES: usize = 5;

/// Longest failure line, in characters. A failure starts with its analysis and its place in the
/// study file, so the cut keeps the location; the reason can run to several sentences.
const FAILURE_CHARS: usize = 160;

/// The digest of `report`, a run of `study` that took `elapsed_s` seconds: at most
/// [`MAX_LINES`] lines, without line ends, the last one the path of the page to open
/// (`report.html`, or `summary.md` when no page was written).
pub fn digest(study: &Study, report: &StudyReport, elapsed_s: f64) -> Vec<String> {
    let analyses = &study.spec.analyses;
    let n = analyses.len();
    let completed = |k: usize| report.completed.get(k).copied().unwrap_or(false);
    let hit =
        (0..n).filter(|&k| !completed(k) || !json::failures_of(&analyses[k], &report.failures).is_empty()).count();
    let status = if report.failures.is_empty() {
        format!("{}, all complete", count(n, "analysis", "analyses"))
    } else {
        format!(
            "PARTIAL RESULTS: {} in {hit} of {}",
            count(report.failures.len(), "failure", "failures"),
            count(n, "analysis", "analyses")
        )
    };
    let mut head = vec![format!(
        "Study `{}` (mechanism `{}`, {} DOF): {status}, in {elapsed_s:.2} s",
        study.spec.name,
        study.mechanism.name,
        study.mechanism.ndof()
    )];

    let mut failures = Vec::new();
    if !report.failures.is_empty() {
        failures.push(format!("Failures ({}):", report.failures.len()));
        let shown = if report.failures.len() > MAX_FAILURES { MAX_FAILURES - 1 } else { report.failures.len() };
        for f in &report.failures[..shown] {
            failures.push(format!("  - {}", one_line(f, FAILURE_CHARS)));
        }
        if shown < report.failures.len() {
            failures.push(format!("  … and {} more failures: see summary.md", report.failures.len() - shown));
        }
    }

    let summary = file_named(report, "summary.md");
    let page = file_named(report, "report.html").or_else(|| summary.clone());
    let tail = vec![
        format!(
            "Full tables: {} (or run with --verbose)",
            summary.as_ref().map_or_else(|| "summary.md".to_string(), |p| p.display().to_string())
        ),
        page.map_or_else(|| "summary.md".to_string(), |p| p.display().to_string()),
    ];

    let room = MAX_LINES - head.len() - failures.len() - tail.len();
    let mut lines: Vec<String> = analyses
        .iter()
        .enumerate()
        .map(|(index, a)| {
            let label = format!("  {} `{}`", a.kind(), a.name());
            let own = json::failures_of(a, &report.failures).len();
            if !completed(index) {
                return format!("{label}: FAILED (see Failures)");
            }
            let nth = json::nth_of_kind(analyses, &report.completed, index);
            let found = a.analysis().digest(study, report, nth).unwrap_or_else(|| "no results".to_string());
            let partial =
                if own > 0 { format!(" [partial: {}]", count(own, "failure", "failures")) } else { String::new() };
            format!("{label}: {found}{partial}")
        })
        .collect();
    if lines.len() > room {
        let kept = room - 1;
        let more = lines.len() - kept;
        lines.truncate(kept);
        let noun = if more == 1 { "analysis" } else { "analyses" };
        lines.push(format!("  … and {more} more {noun}: see summary.md"));
    }
    head.extend(lines);
    head.extend(failures);
    head.extend(tail);
    head
}

/// The file of `report` named `name`, if it was written.
fn file_named(report: &StudyReport, name: &str) -> Option<PathBuf> {
    report.files.iter().find(|f| f.file_name().is_some_and(|n| n == name)).cloned()
}

/// `text` on one line (line ends become spaces), cut to `max` characters with an ellipsis.
fn one_line(text: &str, max: usize) -> String {
    let flat: String = text.split_whitespace().collect::<Vec<_>>().join(" ");
    if flat.chars().count() <= max {
        return flat;
    }
    let cut: String = flat.chars().take(max - 1).collect();
    format!("{cut}…")
}

/// A number for a digest line: four significant digits, plainly written between 1e-3 and 1e5,
/// in exponent form outside; `undefined` for NaN (a value that does not exist).
pub(crate) fn num(x: f64) -> String {
    if x.is_nan() {
        return "undefined".to_string();
    }
    let a = x.abs();
    if a == 0.0 || (1e-3..1e5).contains(&a) {
        let decimals = if a == 0.0 { 0 } else { (3 - a.log10().floor() as i32).max(0) as usize };
        trim_zeros(format!("{x:.decimals$}"))
    } else {
        let text = format!("{x:.3e}");
        let (mantissa, exponent) = text.split_once('e').unwrap_or((&text, "0"));
        format!("{}e{exponent}", trim_zeros(mantissa.to_string()))
    }
}

/// `text`, a decimal number, without the zeros that end its fraction (and without a bare point).
fn trim_zeros(text: String) -> String {
    if !text.contains('.') {
        return text;
    }
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// `n` and its noun, singular or plural: `1 mode`, `4 modes`.
pub(crate) fn count(n: usize, one: &str, many: &str) -> String {
    format!("{n} {}", if n == 1 { one } else { many })
}

#[cfg(test)]
mod tests {
    use super::{num, one_line};

    #[test]
    fn numbers_keep_four_significant_digits() {
        assert_eq!(num(242.8812), "242.9");
        assert_eq!(num(3.10997), "3.11");
        assert_eq!(num(600.0), "600");
        assert_eq!(num(-0.01912), "-0.01912");
        assert_eq!(num(1234567.0), "1.235e6");
        assert_eq!(num(2e-7), "2e-7");
        assert_eq!(num(0.0), "0");
        assert_eq!(num(f64::NAN), "undefined");
    }

    #[test]
    fn long_failures_are_cut_on_one_line() {
        assert_eq!(one_line("a\nb  c", 10), "a b c");
        assert_eq!(one_line("abcdefghijkl", 5), "abcd…");
    }
}

//! `report.html`: the study's summary as one self-contained page a person opens from the file
//! system in any browser. The failures come first (when there are any), then the summary's
//! Markdown rendered to HTML (pulldown-cmark, tables on), each analysis's figures inline under
//! its own section (the SVG files' own markup, so nothing is fetched) with a caption saying
//! what the figure shows, links to its data files, and a list of every data file at the end.
//!
//! The figures zoom (mouse wheel, drag a box, double-click to reset) and show the values of
//! the nearest point of the nearest curve on hover, through a small script written inline
//! (`report_html.js`). Wide tables scroll in their own box; long ones show their first rows
//! and fold the rest into a `<details>` element.
//!
//! Why a hand-written layer and not a plotting library (uPlot, MIT, about 50 kB minified, was
//! the candidate), measured on the paper study (`examples/cpva_paper.ron`): its page was 926 kB
//! before this layer, almost all of it the seven figures' SVG, whose curves are 27,762 drawn
//! points. A library draws from its own copy of the data: about 580 kB of JSON for those points
//! at six digits, so 1.55 MB with the library and the SVG figures kept, or the SVG figures
//! dropped and with them what plot.rs draws on them (the Campbell diagram's crossing and
//! order-line labels, fold lines, the legends' placement), to be drawn again in the library's
//! terms. The figures already hold every drawn point: plot.rs adds each panel's axis mapping
//! and each curve's label as groups (6 kB on that page) and the script that inverts the
//! mapping is 10 kB (about 230 lines), so the page is 947 kB.
use super::{AnalysisSpec, write_file};
use crate::error::Result;
use pulldown_cmark::{Event, Options, Parser, Tag, TagEnd, html};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The file name, in the study's output folder.
pub(crate) const FILE_NAME: &str = "report.html";

/// Tables with more rows than this fold after their first [`SHOWN_ROWS`] rows.
const FOLD_ROWS: usize = 40;
/// The rows a folded table shows.
const SHOWN_ROWS: usize = 10;

/// The zoom and hover layer (see the module's documentation).
const SCRIPT: &str = include_str!("report_html.js");

/// One analysis's part of the page: its section of the summary and the files it wrote.
pub(crate) struct Part<'a> {
    /// The analysis as written in the study file (for its figures' captions).
    pub spec: &'a AnalysisSpec,
    /// Its section of the summary (Markdown, starting with its `## ` heading).
    pub markdown: String,
    /// The files it wrote, in the study's output folder.
    pub files: Vec<PathBuf>,
}

/// Text safe inside HTML (element content and double-quoted attributes, the only kind this page
/// writes): every name and label of the study and mechanism files reaches the page through this
/// or through [`markdown`] (issue 49).
fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The file name of `p`.
fn name_of(p: &Path) -> String {
    p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

/// Writes `dir/report.html` for the study `name`: `head` (the summary's Markdown before the
/// analyses), each analysis's [`Part`] with its figures under its section, `tail` (the
/// summary's Markdown after them), the `failures` first and every CSV or JSON file of `files`
/// linked at the end.
pub(crate) fn write(
    dir: &Path,
    name: &str,
    (head, parts, tail): (&str, &[Part<'_>], &str),
    failures: &[String],
    files: &[PathBuf],
) -> Result<PathBuf> {
    let mut body = String::new();
    if !failures.is_empty() {
        let _ = writeln!(body, "<section class=\"failures\"><h2>Failures ({})</h2><ul>", failures.len());
        for f in failures {
            let _ = writeln!(body, "<li>{}</li>", escape(f));
        }
        body.push_str("</ul></section>\n");
    }
    body += &markdown(head);
    if parts.iter().any(|p| p.files.iter().any(|f| is(f, "svg"))) {
        body.push_str(
            "<p class=\"hint\">Figures: turn the mouse wheel over a figure to zoom about the pointer, drag a box \
             to zoom into it, double-click to see it whole again; point at a curve to read its values.</p>\n",
        );
    }
    let mut count = 0;
    for part in parts {
        let _ = writeln!(
            body,
            "<section class=\"analysis\" id=\"{}\" data-kind=\"{}\">",
            escape(&format!("analysis-{}", part.spec.name())),
            part.spec.kind()
        );
        body += &markdown(&part.markdown);
        for p in part.files.iter().filter(|p| is(p, "svg")) {
            count += 1;
            let file = name_of(p);
            // A figure that cannot be read is named, not lost silently.
            let svg = std::fs::read_to_string(p).unwrap_or_else(|e| format!("<p>cannot read {file}: {e}</p>"));
            let svg = svg.trim_start_matches(|c| c != '<').replacen("<?xml version=\"1.0\" standalone=\"no\"?>", "", 1);
            let stem = file.strip_suffix(".svg").unwrap_or(&file);
            let _ = writeln!(
                body,
                "<figure class=\"plot\" id=\"{id}\">{svg}<figcaption><b>Figure {count}.</b> {caption} \
                 <a class=\"file\" href=\"{f}\">{f}</a></figcaption></figure>",
                id = escape(&format!("figure-{stem}")),
                caption = escape(&caption(part.spec, stem)),
                f = escape(&file),
            );
        }
        let data: Vec<String> = part.files.iter().filter(|p| is(p, "csv")).map(|p| name_of(p)).collect();
        if !data.is_empty() {
            let links: Vec<String> = data.iter().map(|n| format!("<a href=\"{0}\">{0}</a>", escape(n))).collect();
            let _ = writeln!(body, "<p class=\"data\">Data: {}</p>", links.join(", "));
        }
        body.push_str("</section>\n");
    }
    body += &markdown(tail);
    let data: Vec<String> = files.iter().filter(|p| is(p, "csv") || is(p, "json")).map(|p| name_of(p)).collect();
    if !data.is_empty() {
        body.push_str("<h2>Data files</h2>\n<ul>\n");
        for n in data {
            let _ = writeln!(body, "<li><a href=\"{0}\">{0}</a></li>", escape(&n));
        }
        body.push_str("</ul>\n");
    }
    let title = escape(&format!("kanedyn study {name}"));
    // A folded table's rows after its first SHOWN_ROWS are hidden while its fold is closed.
    let fold = format!(".fold:has(details:not([open])) tbody tr:nth-child(n+{}){{display:none}}", SHOWN_ROWS + 1);
    let page = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{title}</title><style>{STYLE}{fold}</style></head>\n<body>\n{body}<script>\n{SCRIPT}</script>\n\
         </body></html>\n"
    );
    let path = dir.join(FILE_NAME);
    write_file(&path, &page)?;
    Ok(path)
}

/// Whether `p` has the extension `ext`.
fn is(p: &Path, ext: &str) -> bool {
    p.extension().is_some_and(|e| e == ext)
}

/// Markdown as HTML, its tables made to fit ([`fit_tables`]).
///
/// The summaries quote names and labels from the user's files, so their Markdown is not
/// trusted: raw HTML in it is shown as text, never passed through (issue 49: a joint named
/// ``piv`<svg onload=…>`` closed its code span and became a live element), and a link or image
/// shows its text without the element (a `javascript:` address would run on a click). The
/// summaries themselves write neither, so a normal report is unchanged.
fn markdown(md: &str) -> String {
    let mut options = Options::empty();
    options.insert(Options::ENABLE_TABLES);
    let events = Parser::new_ext(md, options).filter_map(|event| match event {
        Event::Html(text) | Event::InlineHtml(text) => Some(Event::Text(text)),
        Event::Start(Tag::Link { .. } | Tag::Image { .. }) | Event::End(TagEnd::Link | TagEnd::Image) => None,
        other => Some(other),
    });
    let mut out = String::new();
    html::push_html(&mut out, events);
    fit_tables(&out)
}

/// Every table in a box of its own that scrolls sideways when the table is wider than the page;
/// a table of more than [`FOLD_ROWS`] rows shows its first [`SHOWN_ROWS`] and folds the rest
/// behind a `<details>` element (the page's style hides the further rows while it is closed).
fn fit_tables(html: &str) -> String {
    let mut out = String::with_capacity(html.len() + 64);
    let mut rest = html;
    while let Some(start) = rest.find("<table>") {
        let Some(len) = rest[start..].find("</table>") else { break };
        let end = start + len + "</table>".len();
        let table = &rest[start..end];
        out.push_str(&rest[..start]);
        let rows = table.find("<tbody>").map_or(0, |b| table[b..].matches("<tr>").count());
        if rows > FOLD_ROWS {
            let _ = write!(
                out,
                "<div class=\"fold\"><div class=\"table-box\">{table}</div><details><summary>\
                 <span class=\"closed\">Showing the first {SHOWN_ROWS} of {rows} rows: show all</span>\
                 <span class=\"open\">Showing all {rows} rows: show the first {SHOWN_ROWS}</span>\
                 </summary></details></div>"
            );
        } else {
            let _ = write!(out, "<div class=\"table-box\">{table}</div>");
        }
        rest = &rest[end..];
    }
    out.push_str(rest);
    out
}

/// What the figure `stem` (its file name without `.svg`) of analysis `a` shows, in words.
fn caption(a: &AnalysisSpec, stem: &str) -> String {
    let name = a.name();
    let suffix = stem.strip_prefix(name).unwrap_or(stem);
    match (a, suffix) {
        (AnalysisSpec::Compare(c), _) => match c.analyses.iter().find(|i| suffix.strip_prefix('_') == Some(i.name())) {
            Some(inner) => format!(
                "Comparison of the mechanisms: {} — one colour per mechanism.",
                lowercase_first(&caption(inner, inner.name()))
            ),
            None => "Comparison: one mechanism's own figure of one of the compared analyses (both named \
                         in the file name)."
                .into(),
        },
        (AnalysisSpec::OrderSweep(_), "_elements") => {
            "Order sweep, element by element: each element's main-order amplitude over the excitation order \
             as it is swept up (solid) and down (dashed), one panel per torque amplitude."
                .into()
        }
        (AnalysisSpec::OrderSweep(_), _) => {
            "Order sweep: the response's acceleration amplitude over the excitation order, swept slowly up \
             (solid) and down (dashed) through time-domain simulation, one panel per torque amplitude, the \
             response's orders in colours and the locked twin dotted; where up and down part, the response \
             jumps."
                .into()
        }
        (AnalysisSpec::MultiOrder(_), _) => {
            "Multi-order response: the steady amplitude of each order of the response over the mean speed \
             under the combined excitation, by harmonic balance (solid), by the linear model (dashed) and for \
             the locked twin (dotted), as computed."
                .into()
        }
        (AnalysisSpec::LinearResponse(_), _) => {
            "Linear frequency response: the response's acceleration over the excitation order (divided by \
             the locked twin's when there is one, with the dotted unity line where both are equal), one curve \
             per variant, the named orders as vertical lines; a second panel gives each element's amplitude \
             per N·m of excitation."
                .into()
        }
        (AnalysisSpec::Campbell(_), _) => {
            "Campbell diagram: the eigenfrequencies of the tracked modes over the spin speed (named as in the \
             resonance table), the excitation-order lines dotted and named at their ends, each crossing of an \
             order line with a mode marked with its speed."
                .into()
        }
        (AnalysisSpec::HarmonicBalance(_), "_elements") => {
            "Harmonic balance, element by element: each element's amplitude along the periodic branches, \
             stable solid and unstable dashed, one panel per torque amplitude."
                .into()
        }
        (AnalysisSpec::HarmonicBalance(_), "_backbone") => {
            "Harmonic balance with the backbone: the largest peak joint angle along the periodic branches (from \
             each end of the range, solid and dashed) against the order, with the free oscillation's backbone \
             (order against release amplitude, from the linear order at zero) drawn over them."
                .into()
        }
        (AnalysisSpec::HarmonicBalance(_), _) => {
            "Harmonic balance: the amplitude of the periodic steady states along the continued parameter, \
             stable solid and unstable dashed, folds (where the response jumps) as vertical lines, and the \
             order sweep's curves dotted when it is overlaid."
                .into()
        }
        (AnalysisSpec::DesignStudy(_), _) => {
            "Design study: the first result of each case against the first varied parameter, grouped in \
             colours by the second parameter (lines through a grid, points for sampled cases)."
                .into()
        }
        (AnalysisSpec::Transient(_), "_map") => {
            "Order–rpm map: the response's amplitude per order over the spin speed through the transient, in \
             decibels below its largest value, the excitation orders as horizontal lines."
                .into()
        }
        (AnalysisSpec::Transient(_), _) => {
            "Transient: the spin speed over time and the order cuts, the amplitude of each excitation order \
             over the spin speed as the transient passes through it."
                .into()
        }
        (AnalysisSpec::FreeOscillation(_), _) => {
            "Backbone curve: the frequency of the joint's free, undamped oscillation, the spin held or the rotor \
             free, as an order of the (mean) spin speed, against its release amplitude: continuation of free \
             periodic orbits (line) and time integration (points); the linear order dotted."
                .into()
        }
        (AnalysisSpec::Envelope(_), _) => {
            "Operating envelope: the boundaries in the (excitation order, torque) plane where the steady response \
             jumps (fold curves, the region of several states tinted) and where identical absorbers lose unison \
             (dashed), with the cusps and onsets marked; torque on a log scale."
                .into()
        }
        #[cfg(test)]
        (AnalysisSpec::Toy(_), _) => "A toy analysis's figure.".into(),
    }
}

/// `text` with its first letter in lower case.
fn lowercase_first(text: &str) -> String {
    let mut c = text.chars();
    c.next().map_or_else(String::new, |f| f.to_lowercase().chain(c).collect())
}

/// Readable at laptop width: tables scroll in their own box, long ones fold, figures scale to
/// the page, the hover's tooltip follows the pointer.
const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;\
line-height:1.4}.table-box{overflow-x:auto;max-width:100%;margin:1em 0}table{border-collapse:collapse}\
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right;white-space:nowrap}th{white-space:normal}\
.fold details summary{cursor:pointer;color:#05c}.fold details[open] .closed,.fold details:not([open]) .open{display:none}\
figure{margin:1em 0}figure svg{max-width:100%;height:auto;cursor:crosshair;user-select:none}\
figcaption{font-size:0.95em;color:#333}figcaption a.file{font-size:0.85em;color:#666}.hint{color:#555;font-size:0.9em}\
.kd-tip{position:fixed;z-index:10;pointer-events:none;white-space:pre;background:#fffffe;border:1px solid #888;\
padding:3px 6px;font-size:12px;box-shadow:1px 1px 3px #0003}\
.kd-dot{fill:none;stroke:#000;stroke-width:1.5}.kd-band{fill:#05c2;stroke:#05c}\
.failures{border:2px solid #c00;padding:0 1em;background:#fff4f4}";

//! `report.html`: the study's summary as one self-contained page a person opens from the file
//! system in any browser. The failures come first (when there are any), then the summary's
//! Markdown rendered to HTML (pulldown-cmark, tables on), every figure inline (the SVG files'
//! own markup, so nothing is fetched), and a list of links to the CSV files beside it.

use super::write_file;
use crate::error::Result;
use pulldown_cmark::{Options, Parser, html};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The file name, in the study's output folder.
pub(crate) const FILE_NAME: &str = "report.html";

/// Text safe inside HTML (element content and quoted attributes).
fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// Writes `dir/report.html` for the study `name` from its `summary` (Markdown), its `failures`
/// and the `files` it wrote (SVGs are inlined, CSVs linked by their names in `dir`).
pub(crate) fn write(dir: &Path, name: &str, summary: &str, failures: &[String], files: &[PathBuf]) -> Result<PathBuf> {
    let mut body = String::new();
    if !failures.is_empty() {
        let _ = writeln!(body, "<section class=\"failures\"><h2>Failures ({})</h2><ul>", failures.len());
        for f in failures {
            let _ = writeln!(body, "<li>{}</li>", escape(f));
        }
        body.push_str("</ul></section>\n");
    }
    let mut options = Options::empty();
    options.insert(Options::ENABLE_TABLES);
    html::push_html(&mut body, Parser::new_ext(summary, options));
    let name_of = |p: &Path| p.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let svgs: Vec<&PathBuf> = files.iter().filter(|p| p.extension().is_some_and(|e| e == "svg")).collect();
    if !svgs.is_empty() {
        body.push_str("<h2>Figures</h2>\n");
        for p in svgs {
            // A figure that cannot be read is named, not lost silently.
            let svg = std::fs::read_to_string(p).unwrap_or_else(|e| format!("<p>cannot read {}: {e}</p>", name_of(p)));
            let svg = svg.trim_start_matches(|c| c != '<').replacen("<?xml version=\"1.0\" standalone=\"no\"?>", "", 1);
            let _ = writeln!(body, "<figure>{svg}<figcaption>{}</figcaption></figure>", escape(&name_of(p)));
        }
    }
    let csvs: Vec<String> =
        files.iter().filter(|p| p.extension().is_some_and(|e| e == "csv" || e == "json")).map(|p| name_of(p)).collect();
    if !csvs.is_empty() {
        body.push_str("<h2>Data files</h2>\n<ul>\n");
        for n in csvs {
            let _ = writeln!(body, "<li><a href=\"{0}\">{0}</a></li>", escape(&n));
        }
        body.push_str("</ul>\n");
    }
    let page = format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{title}</title><style>{STYLE}</style></head>\n<body>\n{body}</body></html>\n",
        title = escape(&format!("kanedyn study {name}"))
    );
    let path = dir.join(FILE_NAME);
    write_file(&path, &page)?;
    Ok(path)
}

/// Readable at laptop width: tables scroll instead of overflowing, figures scale to the page.
const STYLE: &str = "body{font-family:system-ui,sans-serif;max-width:1100px;margin:1em auto;padding:0 1em;\
line-height:1.4}table{border-collapse:collapse;display:block;overflow-x:auto;margin:1em 0}\
td,th{border:1px solid #ccc;padding:2px 6px;text-align:right;white-space:nowrap}\
figure{margin:1em 0}figure svg{max-width:100%;height:auto}\
.failures{border:2px solid #c00;padding:0 1em;background:#fff4f4}";

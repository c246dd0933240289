//! Issue 25 (acceptance): two runs of the same study write byte-identical files apart from
//! timings.
//!
//! Each study runs twice as whole `kanedyn run` processes into two folders. Every CSV and SVG
//! must be identical byte for byte. `summary.md`, `results.json` and `report.html` carry the wall
//! times of the runs and branches, so they are compared with those values masked, and only
//! those: in a Markdown or HTML table, the cells of a column whose header names a time
//! (`wall time (s)`, `continuation time (ms)`, a branch's `per point (ms)`); in `results.json`, the values of `wall_s`
//! keys. Everything else in them (numbers, order, wording) must be identical.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Runs `kanedyn run study --out out` and returns the study's output folder.
fn run(study: &str, out: &Path) -> PathBuf {
    let _ = std::fs::remove_dir_all(out);
    let status = Command::new(env!("CARGO_BIN_EXE_kanedyn"))
        .args(["run", study, "--out"])
        .arg(out)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(status.status.success(), "{study}: {}", String::from_utf8_lossy(&status.stderr));
    let name = Path::new(study).file_stem().unwrap();
    out.join(name)
}

/// Whether a table header names a time (a wall-clock measurement, not a result).
fn is_time(header: &str) -> bool {
    let h = header.to_ascii_lowercase();
    h.contains("wall") || h.contains("time (s)") || h.contains("time (ms)") || h.contains("per point (ms)")
}

/// `summary.md` with the cells of its time columns replaced by `…`.
fn mask_markdown(text: &str) -> String {
    let mut out = Vec::new();
    let mut masked: Vec<usize> = Vec::new();
    let mut in_table = false;
    for line in text.lines() {
        if !line.starts_with('|') {
            in_table = false;
            out.push(line.to_string());
            continue;
        }
        let cells: Vec<&str> = line.split('|').collect();
        if !in_table {
            in_table = true;
            masked = (0..cells.len()).filter(|&i| is_time(cells[i])).collect();
            out.push(line.to_string());
            continue;
        }
        let row: Vec<String> = cells
            .iter()
            .enumerate()
            .map(|(i, c)| if masked.contains(&i) && !c.starts_with("---") { "…".into() } else { c.to_string() })
            .collect();
        out.push(row.join("|"));
    }
    out.join("\n")
}

/// `report.html` with the `<td>` cells of its tables' time columns replaced by `…`.
fn mask_html(text: &str) -> String {
    let mut out = String::new();
    for (k, table) in text.split("<table>").enumerate() {
        if k > 0 {
            out.push_str("<table>");
        }
        let Some(end) = table.find("</table>").filter(|_| k > 0) else {
            out.push_str(table);
            continue;
        };
        let (body, rest) = table.split_at(end);
        // Header cells: `<th>` or `<th style=…>`, not `<thead>`.
        let headers: Vec<String> = body
            .split("<th")
            .skip(1)
            .filter(|h| h.starts_with(['>', ' ']))
            .map(|h| h.split("</th>").next().unwrap().to_string())
            .collect();
        let masked: Vec<usize> = (0..headers.len()).filter(|&i| is_time(&headers[i])).collect();
        for (r, row) in body.split("<tr>").enumerate() {
            if r > 0 {
                out.push_str("<tr>");
            }
            for (c, cell) in row.split("<td").enumerate() {
                if c > 0 {
                    out.push_str("<td");
                }
                match cell.find("</td>") {
                    Some(e) if c > 0 && masked.contains(&(c - 1)) => {
                        let open = cell.find('>').unwrap();
                        out.push_str(&cell[..=open]);
                        out.push('…');
                        out.push_str(&cell[e..]);
                    }
                    _ => out.push_str(cell),
                }
            }
        }
        out.push_str(rest);
    }
    out
}

/// `results.json` with every `wall_s` value set to null.
fn mask_json(text: &str) -> serde_json::Value {
    fn walk(v: &mut serde_json::Value) {
        match v {
            serde_json::Value::Object(map) => {
                for (k, x) in map.iter_mut() {
                    if k == "wall_s" {
                        *x = serde_json::Value::Null;
                    } else {
                        walk(x);
                    }
                }
            }
            serde_json::Value::Array(a) => a.iter_mut().for_each(walk),
            _ => {}
        }
    }
    let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
    walk(&mut v);
    v
}

fn files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().flatten().map(|e| e.file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn two_runs_write_the_same_files_apart_from_timings() {
    let tmp = crate::support::scratch("reproducible");
    let scratch = tmp.path().to_path_buf();
    for study in ["examples/cpva_paper.ron", "examples/design_study.ron"] {
        let (a, b) = (run(study, &scratch.join("a")), run(study, &scratch.join("b")));
        assert_eq!(files(&a), files(&b), "{study}: different files");
        let mut compared = 0;
        for name in files(&a) {
            let (x, y) = (std::fs::read(a.join(&name)).unwrap(), std::fs::read(b.join(&name)).unwrap());
            let (tx, ty) = (String::from_utf8_lossy(&x), String::from_utf8_lossy(&y));
            match name.as_str() {
                "summary.md" => assert_eq!(mask_markdown(&tx), mask_markdown(&ty), "{study}: {name}"),
                "report.html" => assert!(mask_html(&tx) == mask_html(&ty), "{study}: {name} differs"),
                "results.json" => assert_eq!(mask_json(&tx), mask_json(&ty), "{study}: {name}"),
                _ => assert!(x == y, "{study}: {name} differs between two runs"),
            }
            compared += 1;
        }
        assert!(compared >= 5, "{study}: only {compared} files");
    }
}

/// The masks hide the times and nothing else: a changed result in a timed table still differs.
#[test]
fn the_masks_hide_only_the_time_columns() {
    let md = "| run | peak (rad) | wall time (s) |\n|---|---|---|\n| up | 0.3859 | 0.469 |\n";
    assert_eq!(mask_markdown(md), mask_markdown(&md.replace("0.469", "0.435")));
    assert_ne!(mask_markdown(md), mask_markdown(&md.replace("0.3859", "0.3860")));
    let html = "<p>x</p><table><thead><tr><th>run</th><th>wall time (s)</th></tr></thead><tbody>\n<tr>\n<td>0.38</td>\n<td>0.469</td>\n</tr>\n</tbody></table>";
    assert_eq!(mask_html(html), mask_html(&html.replace("0.469", "0.435")));
    assert_ne!(mask_html(html), mask_html(&html.replace("0.38", "0.39")));
    let json = r#"{"a": {"wall_s": 0.5, "peak": 1.0}}"#;
    assert_eq!(mask_json(json), mask_json(&json.replace("0.5", "0.7")));
    assert_ne!(mask_json(json), mask_json(&json.replace("1.0", "1.5")));
}

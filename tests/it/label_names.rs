//! Issue 49, item 10: a variant's label and a compared mechanism's label reach summary tables,
//! legends and file names; a control character there (a newline splits a summary row) is
//! refused when the study is read, with the file, line:column and field, as body and joint
//! names are.

use crate::support::examples::copy_dir;
use kanedyn::study::Study;
use std::path::Path;

fn load_error(dir: &Path, text: &str) -> String {
    let path = dir.join("bad.ron");
    std::fs::write(&path, text).unwrap();
    match Study::from_file(&path) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn labels_with_control_characters_are_refused_where_they_are() {
    let root = crate::support::scratch("label-names");
    let dir = root.path();
    copy_dir(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples"), dir);
    // The RON escapes `\n`, `\t` and `\u{7}` become the characters themselves.
    for (escape, shown) in [("\\n", "'\\n'"), ("\\t", "'\\t'"), ("\\u{7}", "'\\u{7}'")] {
        let variant = format!(
            r#"Study(name: "v", mechanism: "cpva.ron", lock: ["pivot"],
    analyses: [LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.1, points: 5,
        variants: [(label: "soft{escape}pivot", dampers: [("pivot", 5e-4)])])])"#
        );
        let e = load_error(dir, &variant);
        assert!(e.contains("bad.ron:3:") && e.contains("(field `analyses[0].variants[0].label`)"), "{e}");
        assert!(e.contains("control character") && e.contains(shown), "{e}");
        let compare = format!(
            r#"Study(name: "c", mechanism: "cpva.ron", lock: ["pivot"],
    analyses: [Compare(name: "k", mechanisms: [(label: "a", mechanism: "cpva.ron"),
        (label: "b{escape}c", mechanism: "cpva.ron")],
        analyses: [LinearResponse(name: "l", rpm: 1000.0, from: 0.9, to: 1.1, points: 5)])])"#
        );
        let e = load_error(dir, &compare);
        assert!(e.contains("bad.ron:3:") && e.contains("(field `analyses[0].mechanisms[1].label`)"), "{e}");
        assert!(e.contains(shown), "{e}");
    }
}

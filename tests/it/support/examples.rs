//! Copying example files into a scratch folder, so a study written there can name them: the
//! paper's CPVA (tests/it/results_json.rs, tests/it/report_html.rs), or a whole
//! folder tree (the fuzzers, the failing-study and plan tests). Included with `#[path]`.

use std::path::Path;

/// Copies `examples/cpva.ron` into `dir` (its parts come from the shipped catalog).
#[allow(dead_code)] // the tests that copy whole trees do not use it
pub fn copy_cpva(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    std::fs::copy("examples/cpva.ron", dir.join("cpva.ron")).unwrap();
}

/// Copies the folder tree `from` (files and subfolders) into `to`, creating it.
#[allow(dead_code)] // not every test that includes this module copies a whole tree
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

//! Copying the paper's CPVA with its catalog parts into a scratch folder, so a study written
//! there can name `cpva.ron` (tests/results_json.rs, tests/report_html.rs, with `#[path]`).

use std::path::Path;

/// Copies `examples/cpva.ron` and the `bodies/` and `joints/` catalogs into `dir`.
pub fn copy_cpva(dir: &Path) {
    for sub in ["bodies", "joints"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
        for e in std::fs::read_dir(Path::new("examples").join(sub)).unwrap().flatten() {
            std::fs::copy(e.path(), dir.join(sub).join(e.file_name())).unwrap();
        }
    }
    std::fs::copy("examples/cpva.ron", dir.join("cpva.ron")).unwrap();
}

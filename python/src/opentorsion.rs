//! OpenTorsion assemblies (issue 31, item 6): the native half of `kanedyn.from_opentorsion`,
//! which reads an `opentorsion.Assembly` into kanedyn's node form (`kanedyn::opentorsion::Assembly`)
//! as JSON and gets the mechanism RON back from the same converter as `kanedyn import`.

use crate::errors::{argument_error, guard};
use pyo3::prelude::*;

/// Adds the function to the module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(opentorsion_ron, m)?)
}

/// The mechanism RON of an OpenTorsion assembly in kanedyn's node form (JSON: ``shafts`` with
/// ``nl, nr, k, c, mass``; ``disks`` with ``node, inertia, c, k``; ``gears`` with ``node,
/// inertia, radius, parent`` (an index)), named ``name``. Use ``kanedyn.from_opentorsion``.
/// A bad number or reference raises ``kanedyn.ArgumentError`` naming the element.
#[pyfunction]
#[pyo3(name = "_opentorsion_ron")]
fn opentorsion_ron(py: Python<'_>, assembly_json: &str, name: &str) -> PyResult<String> {
    guard(|| {
        let assembly: kanedyn::opentorsion::Assembly = serde_json::from_str(assembly_json)
            .map_err(|e| argument_error(py, format!("the assembly's node form is not valid: {e}")))?;
        assembly.to_ron(name).map_err(|p| {
            // `shafts[2].k` is `shaft_elements[2]` of the OpenTorsion assembly.
            let element = p
                .path
                .replace("shafts[", "shaft_elements[")
                .replace("disks[", "disk_elements[")
                .replace("gears[", "gear_elements[");
            let at = if element.is_empty() { String::new() } else { format!("assembly.{element}: ") };
            argument_error(py, format!("{at}{}", p.message))
        })
    })
}

//! The shipped parts catalog: the top-level `bodies/` and `joints/` folders of the repository,
//! compiled into the library so that a mechanism anywhere (a user's folder, the Python package,
//! a Dask worker) can name a part as `part: "catalog:bodies/cpva_pendulum.ron"`.
//!
//! Embedding keeps the read policy whole: a `catalog:` name never touches the disk, so it needs
//! no folder allowed outside the mechanism's own tree, and it reads the same everywhere. A part
//! named without the prefix is a file relative to the file that names it, as before; the prefix
//! makes the choice explicit, so a local file can never shadow a catalog part or the reverse.

/// The prefix that names a catalog part.
pub const PREFIX: &str = "catalog:";

/// Every catalog part: its name (the path below the repository root) and its text.
///
/// `tests/it/catalog.rs` holds this list against the folders, so a part added there and not here
/// (or the reverse) fails the tests.
pub const PARTS: &[(&str, &str)] = &[
    ("bodies/cpva_pendulum.ron", include_str!("../../bodies/cpva_pendulum.ron")),
    ("bodies/flywheel_rotor.ron", include_str!("../../bodies/flywheel_rotor.ron")),
    ("bodies/steel_disc_flywheel.ron", include_str!("../../bodies/steel_disc_flywheel.ron")),
    ("bodies/steel_link.ron", include_str!("../../bodies/steel_link.ron")),
    ("joints/bearing.ron", include_str!("../../joints/bearing.ron")),
    ("joints/cpva_pivot.ron", include_str!("../../joints/cpva_pivot.ron")),
    ("joints/dmf_arc_spring.ron", include_str!("../../joints/dmf_arc_spring.ron")),
    ("joints/path_epicycloid.ron", include_str!("../../joints/path_epicycloid.ron")),
    ("joints/path_general.ron", include_str!("../../joints/path_general.ron")),
    ("joints/path_rollers.ron", include_str!("../../joints/path_rollers.ron")),
    ("joints/truck_dmf_arc_spring.ron", include_str!("../../joints/truck_dmf_arc_spring.ron")),
];

/// The catalog name written after [`PREFIX`], when `part` has the prefix.
pub fn name_of(part: &str) -> Option<&str> {
    part.strip_prefix(PREFIX)
}

/// The text of the catalog part `name` (without the prefix), or why there is none (naming the
/// parts there are).
pub fn text(name: &str) -> Result<&'static str, String> {
    PARTS.iter().find(|(n, _)| *n == name).map(|(_, t)| *t).ok_or_else(|| {
        let known: Vec<&str> = PARTS.iter().map(|(n, _)| *n).collect();
        format!("no part `{name}` in the shipped catalog (parts: {})", known.join(", "))
    })
}

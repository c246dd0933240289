//! The `kanedyn` command-line tool (being written).
fn main() {}

//! Shapes with a density → mass properties, through parry2d-f64 (being written).

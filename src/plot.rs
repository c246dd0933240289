//! SVG plots (plotters) and CSV helpers (being written).

//! The integration tests, one module per story, in one test executable (fewer links and less
//! disk than one executable per file). Four stay apart because they measure the process
//! itself: `alloc` (a counting global allocator), `fuzz` (heap per input), `fuzz_runs` and
//! `plan_calibration` (the process's CPU time). Run one story with
//! `cargo test --release --test it <module>::`.

mod support;

mod alternating_torque;
mod backbone;
mod broken_pipe;
mod campbell_crossings;
mod catalog;
mod cli;
mod cli_digest;
mod closed_form;
mod couplings;
mod cpva_paths;
mod damping_laws;
mod design_study;
mod doc_snippets;
mod elements;
mod engine;
mod engine_excitation;
mod engine_study;
mod envelope;
mod envelope_axes;
mod excite_at;
mod figures;
mod gear_reactions;
mod gears;
mod gravity;
mod gravity_linear;
mod hbm;
mod hbm_cyclic;
mod hbm_events;
mod hbm_fold_curve;
mod hbm_neimark_sacker;
mod hbm_period_doubling;
mod hbm_switch;
mod hbm_tongue;
mod honest_peaks;
mod honest_summaries;
mod importer_bounds;
mod importer_fuzz;
mod input_hardening;
mod integration;
mod joint_kinds;
mod linear;
mod marine_gearbox;
mod mistuning;
mod modal_damping;
mod multi_order_states;
mod no_nan_outputs;
mod opentorsion;
mod order_tracking;
mod paper_claims;
mod path_general;
mod path_joint;
mod path_pair_form;
mod random_trees;
mod reactions;
mod reliability_ii;
mod report_html;
mod report_injection;
mod reproducible_runs;
mod results_json;
mod results_schema;
mod rollers;
mod ron_errors;
mod shapes;
mod stiff;
mod study;
mod study_reliability;
mod transient;
mod truck_driveline;
mod unison_averaging;
mod welded_study;

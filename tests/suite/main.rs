//! caustica's integration tests, as one test binary.
//!
//! Each module is one suite (its own file, its own `//!` header saying what it checks). They are one
//! binary, not one per file, because every integration test binary of a release build is linked with
//! thin LTO against the whole crate and its dependencies: 24 binaries cost ~10 minutes of linking on a
//! 2-core CI machine, one costs well under one. Run a single suite with its module path as the filter:
//!
//! ```text
//! cargo test --release --test suite scene_xml::
//! ```

mod common;

mod aov;
mod backends_agree;
mod bvh_backend;
mod caustic_estimators;
mod cli_bench;
mod cli_completions;
mod cli_errors;
mod cli_levels;
mod converge_cli;
mod convert;
mod delta_lights;
mod display_server;
mod embree_backend;
mod film_io;
mod filters;
mod fuzz;
mod hostile_io;
mod hostile_xml;
mod long_delta_chains;
mod max_depth_caustics;
mod mesh_load;
mod materials;
mod mitsuba_features;
mod mutation;
mod parts;
mod path_waves;
mod photon_emission;
mod photon_kdtree;
mod progressive;
mod real_scenes;
mod render_analytic;
mod render_determinism;
mod render_reference;
mod report_compare;
mod scene_errors;
mod scene_files;
mod scene_xml;
mod stress;
mod teapot_glossy;
mod xml_language;

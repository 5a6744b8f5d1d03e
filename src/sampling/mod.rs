//! Sampling building blocks shared by the BSDFs, lights and photon emission.
//!
//! - [`warp`]: maps from the unit square to disks, hemispheres, spheres, cones and triangles, each as a
//!   triplet *sample / pdf / inverse* (inverses make round-trip tests possible).
//! - [`mis`]: THE multiple-importance-sampling weight of the project (power heuristic, method.md §4).
//! - [`distribution`]: piecewise-constant 1-D and 2-D distributions (light selection, env maps).
//! - [`chi2`]: the one χ² goodness-of-fit harness that every direction sampler is tested with.

pub mod chi2;
pub mod distribution;
pub mod mis;
pub mod warp;

//! Light transport: the unidirectional path tracer with next-event estimation and BSDF sampling
//! combined by the power heuristic, and the three caustic estimators of `docs/method.md` §1.
//!
//! - [`path`]: the path tracer. Every emission term a camera path collects goes through one function,
//!   [`path::PathTracer::emission_weight`], which decides between NEE/BSDF MIS, full weight (camera-side
//!   delta chains, `pt` caustics) and the caustic weight `w₂` (method.md §4).
//! - [`caustic`]: the caustic estimators `pt` / `pm` / `mis` in ONE place: the photon density
//!   estimate T1 with its per-photon weight `w₁`, the T2 weight `w₂`, and `q₁` (paper eq. 2).
//!
//! Scene-file snippet read by this module (see `scene` for the full format):
//! ```toml
//! [integrator]
//! max_depth = -1        # longest path in segments; -1 = unlimited (Russian roulette from rr_depth)
//! rr_depth = 5
//! samples_per_pixel = 64
//! seed = 0
//! hide_emitters = false # true: camera rays see no emitter, as Mitsuba's flag (path::PathTracer::hide_unscattered)
//! [integrator.caustics]
//! estimator = "mis"     # pt | pm | mis
//! photons = 70000
//! knn = 50
//! max_radius = 0.1
//! ```

pub mod caustic;
pub mod path;

pub use caustic::{CausticEstimator, CausticOrigin, Gather, GatherBuffers, GatherMemory, GatherScratch, GatherState, LookedUp, OriginArea, Q1Range};
pub use path::{EyePath, PathStats, PathTracer, Wave};

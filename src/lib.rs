//! caustica: an offline path tracer with an MIS-weighted caustic photon map.
//!
//! The method is specified in `docs/method.md`; comments cite its sections as `method.md §1` … `§6`.
//!
//! Module map (see ARCHITECTURE.md):
//! - [`math`]: glam re-exports, [`math::Ray`], [`math::Aabb`], [`math::Frame`], the one ray-origin offset rule.
//! - [`mesh`]: triangle meshes and their loaders (OBJ, PLY, gzipped PLY).
//! - [`accel`]: the `Accel` interface, the brute-force oracle, the pure-Rust BVH and (feature `embree`)
//!   the Embree backend — with [`denoise`]'s FFI to Open Image Denoise, the only code allowed `unsafe`.
//! - [`sampler`]: deterministic random streams keyed by (seed, pixel, sample, dimension).
//! - [`display`]: the live preview of a render in the tev viewer (its TCP packets, a sending thread).
#![deny(unsafe_code)]

pub mod accel;
pub mod bench;
pub mod bsdf;
pub mod camera;
pub mod cli;
pub mod denoise;
pub mod display;
pub mod emitter;
pub mod error;
pub mod film;
pub mod integrator;
pub mod light;
pub mod material;
pub mod math;
pub mod mesh;
pub mod props;
pub mod photon;
pub mod render;
pub mod report;
pub mod sampler;
pub mod sampling;
pub mod scene;
pub mod shape;
pub mod sys;
pub mod texture;

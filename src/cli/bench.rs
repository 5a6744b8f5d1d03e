//! `caustica bench MESH_OR_SCENE... [--rays N] [--threads T] [--backends embree,bvh] [--json OUT]`:
//! the measurements of [`crate::bench`], printed as a table and written as JSON.

use std::path::PathBuf;

use anyhow::Context;

use super::args::{self, named};
use super::log::info;
use super::Outcome;
use crate::accel::BackendKind;
use crate::bench::{format_table, measure};
use crate::film::io::write_json_atomic;

/// Arguments of `caustica bench`.
#[derive(clap::Args, Debug, Clone)]
pub struct BenchArgs {
    /// Mesh files (.obj, .ply, .ply.gz, .serialized) or scene files (.toml or Mitsuba 3 .xml: their shapes, and
    /// their instances in two levels), each on its own.
    #[arg(required = true, value_name = "MESH_OR_SCENE")]
    pub inputs: Vec<PathBuf>,
    #[command(flatten)]
    pub params: args::SceneParams,
    /// Rays per ray set (the primary set uses the nearest square image made of whole 16×16 tiles).
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..=100_000_000))]
    pub rays: u64,
    /// Worker threads for building and tracing [default: all cores].
    #[arg(short = 't', long, value_parser = args::threads)]
    pub threads: Option<usize>,
    /// Also write the results as JSON to this file (atomically).
    #[arg(long, value_name = "OUT")]
    pub json: Option<PathBuf>,
    /// Backends to measure, comma-separated [default: embree,bvh when Embree is compiled in, else bvh].
    #[arg(long, value_delimiter = ',', value_name = "LIST", value_parser = named::<BackendKind>())]
    pub backends: Option<Vec<BackendKind>>,
    /// Measure the backends alone: no raw-Embree baseline and no comparison of Embree's packets, streams and
    /// ROBUST flag (they build more Embree scenes, which a peak-memory figure would count).
    #[arg(long)]
    pub backends_only: bool,
    /// Each input's triangles as one shapegroup placed N times on a grid, in two levels (`bench::instances`).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub instances: Option<u64>,
    /// With --instances: the same placements flattened into one triangle soup.
    #[arg(long, requires = "instances")]
    pub flatten: bool,
}

/// Runs the benchmark, prints the table, and writes the JSON report if asked.
pub fn run(args: &BenchArgs) -> anyhow::Result<Outcome> {
    if let Some(out) = &args.json {
        args::check_output("--json", out)?;
    }
    let threads = args::worker_threads(args.threads);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().context("cannot start the worker threads")?;
    let rays = usize::try_from(args.rays).context("--rays is too large")?;
    let placed = args.instances.map(|n| (n as usize, args.flatten));
    let report = measure(&pool, &args.inputs, &args.params.map(), rays, args.backends.as_deref(), args.backends_only, placed)?;
    print!("{}", format_table(&report));
    if let Some(out) = &args.json {
        write_json_atomic(out, &report)?;
        info!("wrote {}", out.display());
    }
    Ok(Outcome::Done)
}

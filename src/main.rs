//! The `caustica` command line. Each subcommand is one variant of [`Command`] whose arguments and
//! `run` function live in the library; this file only parses, dispatches and reports errors.

use std::process::ExitCode;
use std::sync::LazyLock;

use clap::{Parser, Subcommand};

/// `caustica <version> (embree <version>)`, or `(embree: not compiled in)` without the feature.
static VERSION: LazyLock<String> = LazyLock::new(|| {
    let embree = match caustica::accel::embree_version() {
        Some(v) => format!("embree {v}"),
        None => "embree: not compiled in".to_string(),
    };
    format!("{} ({embree})", env!("CARGO_PKG_VERSION"))
});

#[derive(Parser, Debug)]
#[command(name = "caustica", version = VERSION.as_str(), about = "Offline path tracer with an MIS-weighted caustic photon map")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Measure build time and ray throughput of the intersection backends on meshes.
    Bench(caustica::bench::BenchArgs),
    /// Render a scene file to EXR (and PNG), with statistics.
    Render(caustica::cmd::render::RenderArgs),
    /// Compare an image with a reference: RMSE, relMSE, block and region errors.
    Compare(caustica::report::compare::CompareArgs),
    /// Error against time of the caustic estimators at equal render time, with plots and images.
    Converge(caustica::report::converge::ConvergeArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Bench(args) => caustica::bench::run(args),
        Command::Render(args) => caustica::cmd::render::run(args),
        Command::Compare(args) => caustica::report::compare::run(args),
        Command::Converge(args) => caustica::report::converge::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::from(2)
        }
    }
}

//! The `caustica` command line. Each subcommand is one variant of [`Command`] whose arguments and
//! `run` function live in the library; this file only parses, dispatches and reports errors.

use std::process::ExitCode;
use std::sync::LazyLock;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

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
    /// Add the partial films of `render --part I/N` into the image of the whole render.
    Merge(caustica::cmd::merge::MergeArgs),
    /// Compare an image with a reference: RMSE, relMSE, block and region errors.
    Compare(caustica::report::compare::CompareArgs),
    /// Error against time of the caustic estimators at equal render time, with plots and images.
    Converge(caustica::report::converge::ConvergeArgs),
}

/// Parses the command line. Every option that takes a value accepts a leading `-` as the start of a
/// negative number (`--exposure -1` is valid; `--seed -1` is then rejected by the value parser with an
/// error naming the flag, instead of clap's "unexpected argument '-1'"). Errors exit with code 2.
fn parse_cli() -> Cli {
    let command = Cli::command().mut_subcommands(|sub| {
        sub.mut_args(|arg| if arg.get_action().takes_values() && !arg.is_positional() { arg.allow_negative_numbers(true) } else { arg })
    });
    let mut matches = command.get_matches();
    Cli::from_arg_matches_mut(&mut matches).unwrap_or_else(|e| e.exit())
}

fn main() -> ExitCode {
    let cli = parse_cli();
    let result = match &cli.command {
        Command::Bench(args) => caustica::bench::run(args),
        Command::Render(args) => caustica::cmd::render::run(args),
        Command::Merge(args) => caustica::cmd::merge::run(args),
        Command::Compare(args) => caustica::report::compare::run(args),
        Command::Converge(args) => caustica::report::converge::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", error_chain(&err));
            ExitCode::from(2)
        }
    }
}

/// The error and its causes joined by ": ", leaving out a cause whose text the message before it
/// already contains (typed errors that quote their source, e.g. "cannot read the scene file: No such
/// file or directory", would otherwise print it twice).
fn error_chain(err: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in err.chain() {
        let c = cause.to_string();
        if !text.contains(&c) {
            if !text.is_empty() {
                text.push_str(": ");
            }
            text.push_str(&c);
        }
    }
    text
}

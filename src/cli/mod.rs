//! The command line: the one layer that knows clap and the subcommands. Each subcommand is a file
//! here with its arguments and its `run`; the library below (scene, render, report, bench, …) is
//! called with plain values. Defaults and checks of render settings come from
//! [`crate::scene::settings`], so the scene file and every flag share them.

pub mod args;
pub mod bench;
pub mod compare;
pub mod completions;
pub mod converge;
pub mod convert;
pub mod info;
pub mod merge;
pub mod photon_args;
pub mod progress;
pub mod render;

use std::process::ExitCode;
use std::sync::LazyLock;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// `caustica <version> (embree <version>)`, or `(embree: not compiled in)` without the feature.
static VERSION: LazyLock<String> = LazyLock::new(|| {
    let embree = match crate::accel::embree_version() {
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
    /// Measure build time and ray throughput of the intersection backends on meshes or scenes.
    Bench(bench::BenchArgs),
    /// Render scene files to EXR (and PNG), with statistics.
    Render(render::RenderArgs),
    /// Add the partial films of `render --part I/N` into the image of the whole render.
    Merge(merge::MergeArgs),
    /// Compare an image with a reference: RMSE, relMSE, block and region errors.
    Compare(compare::CompareArgs),
    /// Error against time of the caustic estimators at equal render time, with plots and images.
    Converge(converge::ConvergeArgs),
    /// Describe a scene without rendering it: triangles, materials, lights, photon pass, memory.
    Info(info::InfoArgs),
    /// Convert a scene between Mitsuba 3 XML and TOML (formats from the file names).
    Convert(convert::ConvertArgs),
    /// Print the shell completion script for SHELL (bash, zsh, fish, elvish, powershell).
    Completions(completions::CompletionsArgs),
    /// Print the man page (roff).
    Man,
}

/// How a subcommand ended without an error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Done,
    /// Interrupted by a signal (SIGINT: Ctrl-C, SIGTERM, SIGHUP) after writing what was finished: exit code
    /// 128 + `signal` (130, 143, 129).
    Interrupted { signal: i32 },
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

/// The whole program: parse, dispatch, report. Exit codes: 0 done, 2 error (bad input or a failure,
/// with the message on stderr), 128 + the signal after a render interrupted by SIGINT (130: Ctrl-C),
/// SIGTERM (143) or SIGHUP (129).
#[must_use]
pub fn main() -> ExitCode {
    let cli = parse_cli();
    let result = match &cli.command {
        Command::Bench(args) => bench::run(args),
        Command::Render(args) => render::run(args),
        Command::Merge(args) => merge::run(args),
        Command::Compare(args) => compare::run(args),
        Command::Converge(args) => converge::run(args),
        Command::Info(args) => info::run(args),
        Command::Convert(args) => convert::run(args),
        Command::Completions(args) => completions::run(args, Cli::command()),
        Command::Man => completions::man(Cli::command()),
    };
    match result {
        Ok(Outcome::Done) => ExitCode::SUCCESS,
        Ok(Outcome::Interrupted { signal }) => ExitCode::from(u8::try_from(128 + signal).unwrap_or(130)),
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

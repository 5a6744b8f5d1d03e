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
pub mod log;
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
#[command(
    name = "caustica",
    version = VERSION.as_str(),
    about = "Offline path tracer with an MIS-weighted caustic photon map",
    after_help = "`caustica SCENE [OPTIONS]` (a scene file: .toml, .xml, or any existing file) is short for `caustica render SCENE [OPTIONS]`."
)]
struct Cli {
    #[command(flatten)]
    log: LogArgs,
    #[command(subcommand)]
    command: Command,
}

/// The global flags of how much is printed on stderr (`log`).
#[derive(clap::Args, Debug)]
struct LogArgs {
    /// What is printed on stderr: error (only errors), warn (and warnings), info (and notes, progress and
    /// summaries), debug (and the settings, a line per round, the display server's traffic) [default: info].
    #[arg(long, global = true, value_name = "LEVEL", value_parser = args::named::<log::Level>())]
    log_level: Option<log::Level>,
    /// Print more: --log-level debug.
    #[arg(short = 'v', long, global = true, conflicts_with_all = ["log_level", "quiet"])]
    verbose: bool,
    /// Print less: --log-level warn (no progress, notes or summary; warnings and errors still).
    #[arg(short = 'q', long, global = true, conflicts_with = "log_level")]
    quiet: bool,
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
    let subcommands: Vec<String> = command.get_subcommands().flat_map(|s| std::iter::once(s.get_name().to_string()).chain(s.get_all_aliases().map(String::from))).collect();
    let argv = implied_render(std::env::args_os().collect(), &subcommands);
    let mut matches = command.get_matches_from(argv);
    Cli::from_arg_matches_mut(&mut matches).unwrap_or_else(|e| e.exit())
}

/// `caustica SCENE …` → `caustica render SCENE …`: when the first argument that is not a global flag
/// (`-v`, `-q`, `--log-level LEVEL`, …) is no subcommand (nor `help`) but names a scene — a `.toml` or
/// `.xml` file name, or an existing file — `render` is put before it. Anything else is left to clap (an
/// unknown subcommand is its error, with its suggestion).
fn implied_render(mut argv: Vec<std::ffi::OsString>, subcommands: &[String]) -> Vec<std::ffi::OsString> {
    let mut i = 1;
    while let Some(arg) = argv.get(i).and_then(|a| a.to_str()) {
        match arg {
            "--log-level" => i += 2,
            a if a.starts_with("--log-level=") || a == "-v" || a == "--verbose" || a == "-q" || a == "--quiet" => i += 1,
            _ => break,
        }
    }
    let Some(first) = argv.get(i) else { return argv };
    let text = first.to_string_lossy();
    if text.starts_with('-') || text == "help" || subcommands.iter().any(|s| *s == text) {
        return argv;
    }
    let path = std::path::Path::new(first);
    let scene_name = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml") || e.eq_ignore_ascii_case("xml"));
    if scene_name || path.is_file() {
        argv.insert(i, "render".into());
    }
    argv
}

/// The whole program: parse, dispatch, report. Exit codes: 0 done, 2 error (bad input or a failure,
/// with the message on stderr), 128 + the signal after a render interrupted by SIGINT (130: Ctrl-C),
/// SIGTERM (143) or SIGHUP (129).
#[must_use]
pub fn main() -> ExitCode {
    let cli = parse_cli();
    log::set(log::Level::from_flags(cli.log.log_level, cli.log.verbose, cli.log.quiet));
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

#[cfg(test)]
mod tests {
    use super::*;

    fn implied(args: &[&str]) -> Vec<String> {
        let subcommands: Vec<String> = Cli::command().get_subcommands().map(|s| s.get_name().to_string()).collect();
        let argv = std::iter::once("caustica").chain(args.iter().copied()).map(std::ffi::OsString::from).collect();
        implied_render(argv, &subcommands).into_iter().skip(1).map(|a| a.to_string_lossy().into_owned()).collect()
    }

    #[test]
    fn a_scene_first_is_short_for_render() {
        assert_eq!(implied(&["a.toml", "--spp", "4"]), ["render", "a.toml", "--spp", "4"]);
        assert_eq!(implied(&["dir/A.XML"]), ["render", "dir/A.XML"]);
        assert_eq!(implied(&["-v", "a.toml"]), ["-v", "render", "a.toml"]);
        assert_eq!(implied(&["--log-level", "debug", "a.toml"]), ["--log-level", "debug", "render", "a.toml"]);
        assert_eq!(implied(&["--log-level=warn", "a.xml"]), ["--log-level=warn", "render", "a.xml"]);
        // An existing file of any name is a scene; the manifest is one.
        let manifest = concat!(env!("CARGO_MANIFEST_DIR"), "/Cargo.toml");
        assert_eq!(implied(&[manifest]), ["render", manifest]);
        // Subcommands, flags, help and unknown words are clap's.
        for args in [&["render", "a.toml"][..], &["info", "a.toml"], &["--help"], &["help"], &["rendr", "a.toml"], &[], &["-v"], &["--version"]] {
            assert_eq!(implied(args), args, "{args:?}");
        }
    }

    #[test]
    fn the_command_line_is_consistent() {
        Cli::command().debug_assert();
    }
}

//! The `caustica` binary: everything it does is in the library's command-line layer, [`caustica::cli`].

fn main() -> std::process::ExitCode {
    caustica::cli::main()
}

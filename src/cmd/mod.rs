//! The command-line subcommands' implementations (the binary `src/main.rs` only parses and dispatches).
pub mod merge;
pub mod photon_args;
pub mod progress;
pub mod render;

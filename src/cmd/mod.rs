//! The command-line subcommands' implementations (the binary `src/main.rs` only parses and dispatches).
pub mod progress;
pub mod render;

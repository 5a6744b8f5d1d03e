//! How much the commands say on stderr: one level for the whole process, decided once from the global
//! flags (`--log-level LEVEL`, `-v`, `-q`: [`Level::from_flags`]) and read by every message through the
//! macros below.
//!
//! | level | stderr gets |
//! |---|---|
//! | `error` | only the error that ends a command (exit code 2) |
//! | `warn` | and the warnings: a result that may not be what was asked (threads capped, NaN samples, parts missing or cut, a checkpoint not written, the display server unreachable) |
//! | `info` (default) | and the notes (what a scene used otherwise than written, a long photon pass), the progress bar (on a terminal) or lines (`--log-every`, without one), the summary and `wrote …` lines, converge's pass lines |
//! | `debug` | and the settings a render runs with, a line per round, the display server's connections and sends |
//!
//! `-q`/`--quiet` is `warn` (what it meant before there were levels: no progress, notes or summary, the
//! warnings kept); `-v`/`--verbose` is `debug`. What a command is asked to output — the JSON of
//! `--stats -`, compare's and converge's tables — is not a log message and is printed at every level.

use std::sync::atomic::{AtomicU8, Ordering};

/// A log level, from the fewest messages to the most.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Level {
    Error,
    Warn,
    Info,
    Debug,
}

impl Level {
    pub const ALL: [Level; 4] = [Level::Error, Level::Warn, Level::Info, Level::Debug];

    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Level::Error => "error",
            Level::Warn => "warn",
            Level::Info => "info",
            Level::Debug => "debug",
        }
    }

    /// The level the flags ask for (clap refuses them together): `--log-level`, else `-v` (debug), else
    /// `-q` (warn), else info.
    #[must_use]
    pub fn from_flags(log_level: Option<Level>, verbose: bool, quiet: bool) -> Level {
        match (log_level, verbose, quiet) {
            (Some(l), _, _) => l,
            (None, true, _) => Level::Debug,
            (None, false, true) => Level::Warn,
            (None, false, false) => Level::Info,
        }
    }
}

impl super::args::Named for Level {
    const ALL: &'static [Self] = &Level::ALL;
    fn name(self) -> &'static str {
        Level::name(self)
    }
}

static LEVEL: AtomicU8 = AtomicU8::new(Level::Info as u8);

/// Sets the process's level (once, after parsing the command line).
pub fn set(level: Level) {
    LEVEL.store(level as u8, Ordering::Relaxed);
}

/// The process's level.
#[must_use]
pub fn level() -> Level {
    Level::ALL[usize::from(LEVEL.load(Ordering::Relaxed)).min(Level::ALL.len() - 1)]
}

/// Whether messages of `level` are printed.
#[must_use]
pub fn enabled(level: Level) -> bool {
    level <= self::level()
}

/// `warning: …` on stderr, at `warn` and above.
macro_rules! warning {
    ($($arg:tt)*) => {
        if $crate::cli::log::enabled($crate::cli::log::Level::Warn) {
            eprintln!("warning: {}", format_args!($($arg)*));
        }
    };
}

/// `note: …` on stderr, at `info` and above.
macro_rules! note {
    ($($arg:tt)*) => {
        if $crate::cli::log::enabled($crate::cli::log::Level::Info) {
            eprintln!("note: {}", format_args!($($arg)*));
        }
    };
}

/// A line on stderr as it is (summaries, `wrote …`), at `info` and above.
macro_rules! info {
    ($($arg:tt)*) => {
        if $crate::cli::log::enabled($crate::cli::log::Level::Info) {
            eprintln!($($arg)*);
        }
    };
}

/// `debug: …` on stderr, at `debug`.
macro_rules! debug {
    ($($arg:tt)*) => {
        if $crate::cli::log::enabled($crate::cli::log::Level::Debug) {
            eprintln!("debug: {}", format_args!($($arg)*));
        }
    };
}

pub(crate) use {debug, info, note, warning};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_map_onto_levels() {
        assert_eq!(Level::from_flags(None, false, false), Level::Info);
        assert_eq!(Level::from_flags(None, false, true), Level::Warn);
        assert_eq!(Level::from_flags(None, true, false), Level::Debug);
        assert_eq!(Level::from_flags(Some(Level::Error), false, false), Level::Error);
        assert!(Level::Error < Level::Warn && Level::Warn < Level::Info && Level::Info < Level::Debug);
        for l in Level::ALL {
            assert_eq!(Level::ALL[l as usize], l);
        }
    }
}

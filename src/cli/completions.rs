//! `caustica completions SHELL` and `caustica man`: shell completions (clap_complete) and a man page in
//! roff (clap_mangen), both generated from the one definition of the command line, written to stdout.
//!
//! ```sh
//! caustica completions bash > ~/.local/share/bash-completion/completions/caustica
//! caustica man > ~/.local/share/man/man1/caustica.1
//! ```

use std::io::Write as _;

use anyhow::Result;
use clap::Args;
use clap_complete::Shell;

use super::Outcome;

#[derive(Args, Debug)]
pub struct CompletionsArgs {
    /// The shell: bash, zsh, fish, elvish or powershell.
    pub shell: Shell,
}

/// Writes the completion script for `args.shell` of `command` to stdout.
pub fn run(args: &CompletionsArgs, mut command: clap::Command) -> Result<Outcome> {
    let mut out = std::io::stdout().lock();
    clap_complete::generate(args.shell, &mut command, "caustica", &mut out);
    out.flush()?;
    Ok(Outcome::Done)
}

/// Writes the man page of `command` (roff) to stdout.
pub fn man(command: clap::Command) -> Result<Outcome> {
    let mut buf = Vec::new();
    clap_mangen::Man::new(command).render(&mut buf)?;
    let mut out = std::io::stdout().lock();
    out.write_all(&buf)?;
    out.flush()?;
    Ok(Outcome::Done)
}

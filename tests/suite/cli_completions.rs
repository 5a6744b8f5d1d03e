//! `caustica completions SHELL` and `caustica man` (issue 41, item 6): generated from the command line's one
//! definition, so every subcommand and flag is in them.

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_caustica");

fn stdout(args: &[&str]) -> String {
    let out = Command::new(BIN).args(args).output().expect("run caustica");
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    String::from_utf8(out.stdout).expect("UTF-8")
}

#[test]
fn completions_and_the_man_page_cover_every_subcommand_and_flag() {
    for shell in ["bash", "zsh", "fish"] {
        let script = stdout(&["completions", shell]);
        for word in ["render", "merge", "converge", "convert", "estimator", "log-every", "aov", "log-level", "display-server"] {
            assert!(script.contains(word), "{shell} completions lack {word}");
        }
    }
    let man = stdout(&["man"]);
    assert!(man.starts_with(".ie") && man.contains(".TH caustica 1"), "{}", &man[..man.len().min(200)]);
    assert!(man.contains("render") && man.contains("completions"));
    let bad = Command::new(BIN).args(["completions", "tcsh"]).output().unwrap();
    assert_eq!(bad.status.code(), Some(2));
}

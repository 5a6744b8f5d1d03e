//! The global flags of how much is said (`--log-level`, `-v`, `-q`: `cli::log`) and `caustica SCENE` as short
//! for `caustica render SCENE` (issue 41, item 6).

use std::path::{Path, PathBuf};
use std::process::Command;

use super::common::repo_path;

const BIN: &str = env!("CARGO_BIN_EXE_caustica");

fn case_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_levels").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs caustica in `dir` with `args`, the scene's path put where `SCENE` is; exit code and stderr.
fn run(dir: &Path, args: &[&str]) -> (Option<i32>, String) {
    let scene = repo_path("scenes/cornell-caustics.toml");
    let args: Vec<&str> = args.iter().map(|a| if *a == "SCENE" { scene.to_str().unwrap() } else { a }).collect();
    let out = Command::new(BIN).args(&args).current_dir(dir).output().expect("run caustica");
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

const SMALL: [&str; 8] = ["--width", "24", "--height", "24", "--spp", "2", "--estimator", "pt"];

#[test]
fn log_levels_decide_what_a_render_prints() {
    let dir = case_dir("levels");
    let render = |level: &[&str], out: &str| {
        let mut args = vec!["render", "SCENE", "-o", out];
        args.extend(SMALL);
        args.extend(level);
        let (code, stderr) = run(&dir, &args);
        assert_eq!(code, Some(0), "{level:?}: {stderr}");
        stderr
    };
    // info (default): the summary line; no debug lines.
    let info = render(&[], "a.exr");
    assert!(info.contains("a.exr: 24x24 2 spp") && !info.contains("debug:"), "{info}");
    // -v / debug: the settings and a line per round as well.
    for flag in [&["-v"][..], &["--log-level", "debug"], &["--verbose"]] {
        let debug = render(flag, "a.exr");
        assert!(debug.contains("debug: round 1: pass 1") && debug.contains("debug: 24x24 film") && debug.contains("a.exr: 24x24"), "{flag:?}: {debug}");
    }
    // -q is warn: no summary; error: nothing at all. The flag may come before the subcommand too.
    for flag in [&["-q"][..], &["--quiet"], &["--log-level", "warn"], &["--log-level", "error"]] {
        assert_eq!(render(flag, "a.exr"), "", "{flag:?}");
    }
    let (code, stderr) = run(&dir, &["--log-level", "error", "render", "SCENE", "--spp", "1", "-o", "a.exr"]);
    assert_eq!((code, stderr.as_str()), (Some(0), ""));
    // Errors are printed at every level; contradictory flags are refused.
    let (code, stderr) = run(&dir, &["--log-level", "error", "render", "missing.toml"]);
    assert!(code == Some(2) && stderr.starts_with("error: missing.toml"), "{stderr}");
    for args in [&["-q", "-v", "render", "SCENE"][..], &["--log-level", "info", "-q", "render", "SCENE"], &["--log-level", "loud", "render", "SCENE"]] {
        let (code, stderr) = run(&dir, args);
        assert_eq!(code, Some(2), "{args:?}: {stderr}");
    }
}

#[test]
fn a_scene_alone_is_rendered() {
    let dir = case_dir("shorthand");
    let mut short = vec!["SCENE", "-o", "short.exr"];
    short.extend(SMALL);
    let (code, stderr) = run(&dir, &short);
    assert_eq!(code, Some(0), "{stderr}");
    let mut long = vec!["-q", "render", "SCENE", "-o", "long.exr"];
    long.extend(SMALL);
    assert_eq!(run(&dir, &long).0, Some(0));
    assert!(std::fs::read(dir.join("short.exr")).unwrap() == std::fs::read(dir.join("long.exr")).unwrap());
    // With a global flag first, and a missing .toml: render's own error.
    let (code, stderr) = run(&dir, &["-q", "absent.toml"]);
    assert!(code == Some(2) && stderr.contains("absent.toml: cannot read the scene file"), "{stderr}");
    // Not a scene, not a subcommand: clap's error with its suggestion; help still lists the subcommands.
    let (code, stderr) = run(&dir, &["rendr", "x"]);
    assert!(code == Some(2) && stderr.contains("unrecognized subcommand 'rendr'") && stderr.contains("render"), "{stderr}");
    let help = Command::new(BIN).arg("--help").output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains("render") && help.contains("--log-level") && help.contains("short for `caustica render SCENE"), "{help}");
}

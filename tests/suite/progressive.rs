//! Progressive rendering (issue 41, items 1 and 3): a pass's samples are traced in rounds over the whole
//! frame (`render::round`), so the image after a round — kept by Ctrl-C or SIGTERM, or written by
//! `--checkpoint` / `--write-partial-images` — is the whole frame at the samples per pixel its stats say.
//!
//! The check of "whole frame at S spp" is exact: with the path tracer (no photon map, whose α depends on the
//! pass's samples) an image of S samples per pixel is bit for bit the EXR of `render --spp S`, sample
//! indices 0..S−1 in every pixel. A frame with a tile short of samples, or a round half merged, would not be.
//! Every case runs the binary as a child process on `scenes/cornell-caustics.toml` at 48×48, with rounds
//! of 0.1 s (`--round-seconds`) so that several rounds pass in a second.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use super::common::repo_path;

const BIN: &str = env!("CARGO_BIN_EXE_caustica");

/// A fresh, empty directory for one case.
fn case_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("progressive").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `render` of the Cornell box at 48×48 with the path tracer, in `dir`, with `extra` arguments.
fn render_args(extra: &[&str]) -> Vec<String> {
    let scene = repo_path("scenes/cornell-caustics.toml");
    let mut v: Vec<String> = ["render", scene.to_str().unwrap(), "--width", "48", "--height", "48", "--estimator", "pt", "--threads", "2", "--quiet"].map(String::from).to_vec();
    v.extend(extra.iter().map(|s| s.to_string()));
    v
}

/// Starts a long render (10⁶ spp) writing `out.exr` and `stats.json` in `dir`.
fn start_long_render(dir: &Path, extra: &[&str]) -> Child {
    let mut args = render_args(&["--spp", "1000000", "--round-seconds", "0.1", "-o", "out.exr", "--stats", "stats.json"]);
    args.extend(extra.iter().map(|s| s.to_string()));
    Command::new(BIN).args(&args).current_dir(dir).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().expect("run caustica")
}

/// The stats JSON in `dir`, if there is one (it is replaced atomically, so it is whole when it is there).
fn stats(dir: &Path) -> Option<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join("stats.json")).ok()?;
    Some(serde_json::from_str(&text).unwrap_or_else(|e| panic!("stats.json is not JSON ({e}): {text}")))
}

fn key(stats: &serde_json::Value, key: &str) -> u64 {
    stats[key].as_u64().unwrap_or_else(|| panic!("no {key} in {stats}"))
}

/// Waits until `f` holds, polling every 10 ms; panics after `limit`.
fn wait_for<T>(what: &str, limit: Duration, mut f: impl FnMut() -> Option<T>) -> T {
    let t = Instant::now();
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(t.elapsed() < limit, "{what}: not after {limit:?}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Sends `signal` (a name for kill(1)) and waits for the child's end; its exit code and stderr.
fn signal_and_wait(mut child: Child, signal: &str) -> (Option<i32>, String) {
    assert!(child.try_wait().unwrap().is_none(), "SIG{signal}: the render ended before the signal");
    assert!(Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status().unwrap().success());
    wait_for(&format!("the end after SIG{signal}"), Duration::from_secs(20), || child.try_wait().unwrap());
    let out = child.wait_with_output().unwrap();
    (out.status.code(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// The EXR of a finished `render --spp spp` in `dir` (named by its spp).
fn reference_exr(dir: &Path, spp: u64) -> Vec<u8> {
    let name = format!("ref-{spp}.exr");
    let out = Command::new(BIN).args(render_args(&["--spp", &spp.to_string(), "-o", &name])).current_dir(dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    std::fs::read(dir.join(name)).unwrap()
}

/// Ctrl-C (SIGINT) and SIGTERM after the second round: the image written is the whole frame at the spp
/// of the stats — bit for bit `render --spp S` — and the stats count the rounds that made it.
#[test]
fn a_signal_after_two_rounds_leaves_the_whole_frame_at_its_spp() {
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        let dir = case_dir(&format!("signal_{signal}"));
        let child = start_long_render(&dir, &["--checkpoint", "0"]);
        // The checkpoint after every round tells the test how many rounds are done.
        wait_for("two rounds", Duration::from_secs(60), || stats(&dir).filter(|s| key(s, "rounds") >= 2));
        let (status, stderr) = signal_and_wait(child, signal);
        assert_eq!(status, Some(code), "SIG{signal}: {stderr}");
        let s = stats(&dir).unwrap();
        assert_eq!(s["partial"], true, "{s}");
        let (spp, rounds) = (key(&s, "spp"), key(&s, "rounds"));
        assert!(rounds >= 2 && spp >= 2, "SIG{signal}: {s}");
        assert_eq!(key(&s, "passes"), 1, "{s}");
        let image = std::fs::read(dir.join("out.exr")).unwrap();
        assert!(image == reference_exr(&dir, spp), "SIG{signal}: the image after {rounds} rounds is not the {spp} spp render");
    }
}

/// `--checkpoint 1` rewrites the EXR and stats at most once a second while the render runs, each EXR the
/// whole frame at its stats' spp (partial: true); a render with `--write-partial-images` that runs to its
/// end leaves the image of a render without (partial: false), and the flags are refused where they
/// cannot apply.
#[test]
fn checkpoints_hold_the_samples_their_stats_say() {
    let dir = case_dir("checkpoint");
    let child = start_long_render(&dir, &["--checkpoint", "1"]);
    let mut seen: Vec<(serde_json::Value, Vec<u8>)> = Vec::new();
    while seen.len() < 2 {
        // A new checkpoint (the stats are written last): its EXR is read long before the next (1 s).
        let (s, image) = wait_for("a checkpoint", Duration::from_secs(60), || {
            let s = stats(&dir)?;
            if seen.last().is_some_and(|(last, _)| last["rounds"] == s["rounds"]) {
                return None;
            }
            let image = std::fs::read(dir.join("out.exr")).ok()?;
            (stats(&dir).as_ref() == Some(&s)).then_some((s, image))
        });
        assert_eq!(s["partial"], true, "a checkpoint's stats: {s}");
        seen.push((s, image));
    }
    let (_, stderr) = signal_and_wait(child, "TERM");
    let (first, second) = (&seen[0].0, &seen[1].0);
    assert!(key(second, "spp") > key(first, "spp"), "{first}\n{second}\n{stderr}");
    let gap = second["seconds_total"].as_f64().unwrap() - first["seconds_total"].as_f64().unwrap();
    assert!(gap >= 1.0, "checkpoints {gap} s apart with --checkpoint 1");
    for (s, image) in &seen {
        assert!(*image == reference_exr(&dir, key(s, "spp")), "the checkpoint at {} spp holds another image", key(s, "spp"));
    }

    // To the end: the checkpoints leave the image as it would be.
    let done = Command::new(BIN)
        .args(render_args(&["--spp", "60", "--round-seconds", "0.02", "--write-partial-images", "-o", "done.exr", "--stats", "stats.json"]))
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let s = stats(&dir).unwrap();
    assert_eq!((s["partial"].clone(), key(&s, "spp")), (serde_json::Value::Bool(false), 60), "{s}");
    assert!(key(&s, "rounds") >= 2, "{s}");
    assert!(std::fs::read(dir.join("done.exr")).unwrap() == reference_exr(&dir, 60));

    for (args, needle) in [
        (&["--checkpoint", "5", "--write-partial-images"][..], "cannot be used with"),
        (&["--checkpoint", "5", "--part", "0/2", "-o", "p.exr"][..], "--checkpoint"),
        (&["--checkpoint=-1"][..], "≥ 0"),
    ] {
        let out = Command::new(BIN).args(render_args(args)).current_dir(&dir).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {stderr}");
    }
}

/// Without a terminal (stdout a pipe, as in CI) a render prints a plain progress line on stderr every
/// `--log-every` seconds; `--quiet` and `--log-every 0` print none.
#[test]
fn without_a_terminal_progress_lines_go_to_stderr() {
    let dir = case_dir("log-lines");
    let run = |extra: &[&str]| {
        let mut args: Vec<String> = render_args(&["--time-limit", "1.2", "--round-seconds", "0.1", "-o", "out.exr"]);
        args.retain(|a| a != "--quiet");
        args.extend(extra.iter().map(|s| s.to_string()));
        let out = Command::new(BIN).args(&args).current_dir(&dir).stdout(Stdio::piped()).stderr(Stdio::piped()).output().expect("run caustica");
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        String::from_utf8_lossy(&out.stderr).lines().filter(|l| l.starts_with("progress: ")).map(String::from).collect::<Vec<_>>()
    };
    let lines = run(&["--log-every", "0.25"]);
    assert!(lines.len() >= 2, "{lines:?}");
    assert!(lines.iter().all(|l| l.contains(" spp ") && l.contains("samples/s") && l.contains("ETA")), "{lines:?}");
    assert!(run(&["--log-every", "0"]).is_empty());
    assert!(run(&["--log-every", "0.25", "--quiet"]).is_empty());
}

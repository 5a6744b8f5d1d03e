//! The `caustica` binary on bad input: every case exits with code 2 (our errors and clap's usage errors
//! alike), prints a message naming the offending file, flag or key, never panics, and leaves no output
//! file and no temporary file behind. A control case renders the same scene with good arguments into the
//! same kind of directory and must produce all three outputs, so the "nothing written" checks can fail.

use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_caustica");

/// A fresh, empty directory for one case.
fn case_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("cli_errors").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A tiny valid scene (8 × 6 pixels, a mirror so that `pm`/`mis` run a photon pass).
const GOOD_SCENE: &str = r#"
[integrator]
samples_per_pixel = 2
[sensor]
fov = 40
to_world = { look_at = { origin = [0, 1, 4], target = [0, 0, 0], up = [0, 1, 0] } }
film = { width = 8, height = 6 }
[[shape]]
type = "rectangle"
to_world = [ { rotate = { axis = [1, 0, 0], angle = -90 } } ]
bsdf = { type = "diffuse", reflectance = 0.5 }
[[shape]]
type = "sphere"
center = [0, 0.5, 0]
radius = 0.4
bsdf = { type = "conductor" }
[[shape]]
type = "rectangle"
to_world = [ { scale = 0.2 }, { rotate = { axis = [1, 0, 0], angle = 90 } }, { translate = [0, 2, 0] } ]
emitter = { type = "area", radiance = 5 }
"#;

/// Files in `dir` (names), sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// Runs the binary in `dir` with `args`; asserts exit code 2, that stderr contains every one of `needles`,
/// that nothing panicked, and that `dir` holds exactly the files it held before (no output, no temp file).
fn expect_error(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let before = listing(dir);
    let out = Command::new(BIN).args(args).current_dir(dir).output().expect("run caustica");
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: exit status {:?}, stderr:\n{stderr}", out.status);
    assert!(!stderr.contains("panicked"), "{args:?} panicked:\n{stderr}");
    assert!(!stderr.contains("RUST_BACKTRACE"), "{args:?} panicked:\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{args:?}: stderr does not name {n:?}:\n{stderr}");
    }
    assert_eq!(listing(dir), before, "{args:?} left files behind");
    stderr
}

fn write(dir: &Path, name: &str, text: &str) {
    std::fs::write(dir.join(name), text).unwrap();
}

#[test]
fn control_good_arguments_write_every_output() {
    let dir = case_dir("control");
    write(&dir, "good.toml", GOOD_SCENE);
    std::fs::create_dir(dir.join("sub")).unwrap();
    let out = Command::new(BIN)
        .args(["render", "good.toml", "-q", "--estimator", "mis", "--photons", "2000", "--threads", "1", "-o", "sub/a.exr", "--png", "sub/a.png", "--stats", "sub/a.json"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert_eq!(listing(&dir.join("sub")), ["a.exr", "a.json", "a.png"]);
    // And compare accepts what render wrote.
    let out = Command::new(BIN).args(["compare", "sub/a.exr", "sub/a.exr"]).current_dir(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn bad_scene_files_name_the_file_and_key() {
    let dir = case_dir("scenes");
    expect_error(&dir, &["render", "missing.toml", "-o", "out.exr"], &["missing.toml"]);

    write(&dir, "broken.toml", "[sensor\nfov = 40\n");
    expect_error(&dir, &["render", "broken.toml", "-o", "out.exr"], &["broken.toml"]);

    write(&dir, "unknown.toml", &GOOD_SCENE.replace("fov = 40", "fov = 40\ncolour = 1"));
    expect_error(&dir, &["render", "unknown.toml", "-o", "out.exr"], &["unknown.toml", "sensor.colour"]);

    write(&dir, "nan.toml", &GOOD_SCENE.replace("radiance = 5", "radiance = nan"));
    expect_error(&dir, &["render", "nan.toml", "-o", "out.exr"], &["nan.toml", "shape[2].emitter.radiance"]);

    write(&dir, "nomesh.toml", &format!("{GOOD_SCENE}\n[[shape]]\ntype = \"obj\"\nfilename = \"no-such-mesh.obj\"\n"));
    expect_error(&dir, &["render", "nomesh.toml", "-o", "out.exr"], &["nomesh.toml", "no-such-mesh.obj"]);
}

#[test]
fn bad_numbers_name_the_flag() {
    let dir = case_dir("flags");
    write(&dir, "good.toml", GOOD_SCENE);
    let base = ["render", "good.toml", "-q", "-o", "out.exr", "--png", "out.png", "--stats", "out.json"];
    let cases: &[(&[&str], &str)] = &[
        (&["--spp", "0"], "--spp"),
        (&["--spp", "-1"], "--spp"),
        (&["--spp", "many"], "--spp"),
        (&["--knn", "0"], "--knn"),
        (&["--photons", "0", "--estimator", "pm"], "--photons"),
        (&["--caustic-photons", "0", "--estimator", "mis"], "--caustic-photons"),
        (&["--threads", "0"], "--threads"),
        (&["--pass-spp", "0"], "--pass-spp"),
        (&["--pass-spp", "0", "--time-limit", "1"], "--pass-spp"),
        (&["--seed", "-1"], "--seed"),
        (&["--width", "0"], "--width"),
        (&["--max-radius", "-1"], "--max-radius"),
        (&["--time-limit", "nan"], "--time-limit"),
        (&["--crop", "4,4,2,2"], "--crop"),
    ];
    for (extra, flag) in cases {
        let args: Vec<&str> = base.iter().chain(extra.iter()).copied().collect();
        expect_error(&dir, &args, &[flag]);
    }
}

#[test]
fn missing_output_directories_are_reported_before_rendering() {
    let dir = case_dir("outputs");
    write(&dir, "good.toml", GOOD_SCENE);
    for (flag, path) in [("-o", "nodir/out.exr"), ("--png", "nodir/out.png"), ("--stats", "nodir/out.json")] {
        let mut args = vec!["render", "good.toml", "-q", "-o", "out.exr"];
        if flag == "-o" {
            args[4] = path;
        } else {
            args.extend([flag, path]);
        }
        // A long render: the check must come first, so this returns at once.
        args.extend(["--spp", "100000"]);
        let t = std::time::Instant::now();
        expect_error(&dir, &args, &[flag.trim_start_matches('-'), "nodir"]);
        assert!(t.elapsed().as_secs_f64() < 5.0, "{flag}: the render ran before the output check");
    }
    // An output path that is a directory.
    std::fs::create_dir(dir.join("adir")).unwrap();
    expect_error(&dir, &["render", "good.toml", "-q", "-o", "adir"], &["adir", "directory"]);
}

#[test]
fn compare_rejects_unreadable_and_non_exr_files() {
    let dir = case_dir("compare");
    write(&dir, "good.toml", GOOD_SCENE);
    let out = Command::new(BIN).args(["render", "good.toml", "-q", "-o", "ref.exr"]).current_dir(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    write(&dir, "text.exr", "this is not an OpenEXR file\n");
    expect_error(&dir, &["compare", "nothere.exr", "ref.exr", "--json", "c.json"], &["nothere.exr"]);
    expect_error(&dir, &["compare", "ref.exr", "nothere.exr", "--json", "c.json"], &["nothere.exr"]);
    expect_error(&dir, &["compare", "text.exr", "ref.exr", "--json", "c.json"], &["text.exr"]);
    expect_error(&dir, &["compare", "ref.exr", "good.toml", "--json", "c.json"], &["good.toml"]);
    // A directory is unreadable as an image.
    std::fs::create_dir(dir.join("d.exr")).unwrap();
    expect_error(&dir, &["compare", "d.exr", "ref.exr", "--json", "c.json"], &["d.exr"]);
    expect_error(&dir, &["compare", "ref.exr", "ref.exr", "--json", "nodir/c.json"], &["nodir"]);
}

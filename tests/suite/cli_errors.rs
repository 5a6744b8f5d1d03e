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
film = { width = 8, height = 6, rfilter = { type = "box" } }
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
        (&["--exposure", "nan"], "--exposure"),
        (&["--exposure", "inf"], "--exposure"),
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

#[test]
fn image_outputs_need_the_extension_of_their_format() {
    let dir = case_dir("extensions");
    write(&dir, "good.toml", GOOD_SCENE);
    // `-o a.png` once wrote EXR bytes under a PNG name.
    expect_error(&dir, &["render", "good.toml", "-q", "-o", "a.png"], &["a.png", ".exr", "--png"]);
    expect_error(&dir, &["render", "good.toml", "-q", "-o", "a"], &["-o", ".exr"]);
    expect_error(&dir, &["render", "good.toml", "-q", "-o", "a.exr", "--png", "a.exr.jpg"], &["--png", ".png"]);
}

#[test]
fn a_bad_error_log_path_is_reported_before_rendering() {
    let dir = case_dir("errorlog");
    write(&dir, "good.toml", GOOD_SCENE);
    let out = Command::new(BIN).args(["render", "good.toml", "-q", "-o", "ref.exr"]).current_dir(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    // Once the whole image was rendered, then lost: exit 2 and no EXR.
    expect_error(&dir, &["render", "good.toml", "-q", "-o", "out.exr", "--reference", "ref.exr", "--error-log", "missing/log.csv"], &["--error-log", "missing"]);
}

/// Runs a render that must succeed and returns its stats JSON.
fn render_stats(dir: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["render", "good.toml", "-q", "-o", "out.exr", "--stats", "out.json"];
    args.extend(extra);
    let out = Command::new(BIN).args(&args).current_dir(dir).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_str(&std::fs::read_to_string(dir.join("out.json")).unwrap()).unwrap()
}

#[test]
fn width_or_height_alone_keeps_the_aspect_ratio() {
    let dir = case_dir("aspect");
    write(&dir, "good.toml", GOOD_SCENE);
    let size = |v: &serde_json::Value| (v["width"].as_u64().unwrap(), v["height"].as_u64().unwrap());
    // The scene is 8 × 6.
    assert_eq!(size(&render_stats(&dir, &["--width", "16"])), (16, 12));
    assert_eq!(size(&render_stats(&dir, &["--height", "3"])), (4, 3));
    assert_eq!(size(&render_stats(&dir, &["--width", "5"])), (5, 4)); // 3.75 rounds to 4
    assert_eq!(size(&render_stats(&dir, &["--width", "5", "--height", "5"])), (5, 5));
    // Mitsuba's -t and pbrt-v4's --nthreads / --outfile.
    assert_eq!(render_stats(&dir, &["-t", "1"])["threads"].as_u64(), Some(1));
    assert_eq!(render_stats(&dir, &["--nthreads", "2"])["threads"].as_u64(), Some(2));
    let out = Command::new(BIN).args(["render", "good.toml", "-q", "--outfile", "b.exr"]).current_dir(&dir).output().unwrap();
    assert!(out.status.success() && dir.join("b.exr").is_file(), "{}", String::from_utf8_lossy(&out.stderr));
}

#[test]
fn stats_follow_the_documented_schema() {
    let dir = case_dir("schema");
    write(&dir, "good.toml", GOOD_SCENE);
    let v = render_stats(&dir, &["--estimator", "mis", "--photons", "3000", "--max-radius", "0.25", "--threads", "1"]);
    assert!(v["caustica_version"].as_str().unwrap().starts_with(env!("CARGO_PKG_VERSION")), "{v}");
    assert_eq!(v["max_radius"].as_f64(), Some(0.25));
    assert_eq!((v["photon_budget"].as_str(), v["photon_target"].as_u64()), (Some("emitted"), Some(3000)));
    assert_eq!((v["nan_samples"].as_u64(), v["inf_samples"].as_u64()), (Some(0), Some(0)));
    assert!(v.get("nan_pixels").is_none());
    // `skipped` is an object {phase: reason} (no environment map here).
    assert!(v["skipped"]["environment importance sampling"].is_string(), "{v}");
}

#[test]
fn several_scenes_in_one_render_call() {
    let dir = case_dir("several");
    write(&dir, "a.toml", GOOD_SCENE);
    write(&dir, "b.toml", GOOD_SCENE);
    std::fs::create_dir(dir.join("sub")).unwrap();
    write(&dir.join("sub"), "a.toml", GOOD_SCENE);
    // Options that name one scene's file are refused, as are two scenes with one output name.
    expect_error(&dir, &["render", "a.toml", "b.toml", "-q", "-o", "x.exr"], &["-o", "several scenes"]);
    expect_error(&dir, &["render", "a.toml", "b.toml", "-q", "--stats", "x.json"], &["--stats"]);
    expect_error(&dir, &["render", "a.toml", "sub/a.toml", "-q"], &["sub/a.toml", "a.exr"]);
    let out = Command::new(BIN).args(["render", "a.toml", "b.toml", "-q"]).current_dir(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(dir.join("a.exr").is_file() && dir.join("b.exr").is_file());
}

#[test]
fn renders_beyond_memory_are_refused_before_allocating() {
    let dir = case_dir("memory");
    write(&dir, "good.toml", GOOD_SCENE);
    // 4·10⁹ photons a pass: a 720 GB photon map (180 B per photon).
    expect_error(&dir, &["render", "good.toml", "-q", "--estimator", "mis", "--photons", "4000000000", "--memory-limit", "24"], &["good.toml", "photon map 720.00 GB", "24.00 GB", "the memory limit given"]);
    // A 40000 × 40000 film (136 B a pixel: 218 GB), with the machine's memory as the limit.
    let msg = expect_error(&dir, &["render", "good.toml", "-q", "--width", "40000", "--height", "40000"], &["good.toml", "film 371.20 GB", "--memory-limit"]);
    assert!(msg.contains("physical memory"), "{msg}");
    // The same check in converge (its mis run), and a limit too small for the little scene itself.
    expect_error(&dir, &["converge", "good.toml", "--reference", "missing.exr", "--time-budget", "1", "--memory-limit", "1e-9", "-o", "conv"], &["good.toml", "the memory limit given"]);
    expect_error(&dir, &["render", "good.toml", "-q", "--memory-limit", "-1"], &["--memory-limit"]);
    // The film of 100000 × 100000 is beyond the pixel-index limit, refused by the camera.
    expect_error(&dir, &["render", "good.toml", "-q", "--width", "100000", "--height", "100000"], &["too large"]);
}

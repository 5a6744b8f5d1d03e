//! Hostile files and conditions outside the XML reader (issue 40, items 2 to 4): mesh files whose headers
//! promise more than the file or the memory holds, meshes that are not regular files, outputs that are
//! devices, standard output or the command's own inputs, and SIGTERM / SIGHUP during a render.
//!
//! Every case is generated at test time in its own directory and run as a child process of the binary
//! under an address-space limit of 1 GB (`ulimit -v`) and a time limit: the bad inputs must exit with
//! code 2 within 2 s, with a message naming the file and what is wrong, no signal, and no file left
//! behind. The signal cases must write the partial image and stats and exit with 128 + the signal.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_caustica");
/// The address-space limit every child runs under, in KiB (`ulimit -v`).
const ULIMIT_KIB: u64 = 1_000_000;

/// A fresh, empty directory for one case.
fn case_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("hostile_io").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// The binary with `args` in `dir` under the 1 GB address-space limit, killed after `limit`; its output
/// and how long it ran.
fn run_limited(dir: &Path, args: &[&str], limit: Duration) -> (Output, Duration) {
    let mut cmd = Command::new("sh");
    cmd.arg("-c").arg(format!("ulimit -v {ULIMIT_KIB}; exec \"$0\" \"$@\"")).arg(BIN).args(args).current_dir(dir);
    cmd.stdout(Stdio::piped()).stderr(Stdio::piped());
    let t = Instant::now();
    let mut child = cmd.spawn().expect("run caustica");
    while child.try_wait().unwrap().is_none() {
        if t.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().unwrap();
            panic!("{args:?}: still running after {limit:?}; stderr:\n{}", String::from_utf8_lossy(&out.stderr));
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    let elapsed = t.elapsed();
    (child.wait_with_output().unwrap(), elapsed)
}

/// Runs `args` in `dir` and asserts: exit code 2 (no signal) within 2 s under the memory limit, every one
/// of `needles` in stderr, no panic, and no file added to `dir`. Returns stderr.
fn expect_refused(dir: &Path, args: &[&str], needles: &[&str]) -> String {
    let before = listing(dir);
    let (out, elapsed) = run_limited(dir, args, Duration::from_secs(20));
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(out.status.code(), Some(2), "{args:?}: status {:?}, stderr:\n{stderr}", out.status);
    assert!(elapsed < Duration::from_secs(2), "{args:?}: took {elapsed:?}");
    assert!(!stderr.contains("panicked") && !stderr.contains("memory allocation"), "{args:?}:\n{stderr}");
    for n in needles {
        assert!(stderr.contains(n), "{args:?}: stderr does not name {n:?}:\n{stderr}");
    }
    assert_eq!(listing(dir), before, "{args:?} left files behind");
    stderr
}

/// A one-shape scene whose shape is the mesh file `mesh` of plugin `kind` (`ply`, `obj`, `serialized`).
fn mesh_scene(dir: &Path, kind: &str, mesh: &str) -> String {
    let text = format!(
        r#"
[integrator]
samples_per_pixel = 1
[sensor]
fov = 40
to_world = {{ look_at = {{ origin = [0, 0, 5], target = [0, 0, 0], up = [0, 1, 0] }} }}
film = {{ width = 8, height = 8 }}
[[shape]]
type = "{kind}"
filename = "{mesh}"
bsdf = {{ type = "diffuse" }}
emitter = {{ type = "area", radiance = 1 }}
"#
    );
    std::fs::write(dir.join("scene.toml"), text).unwrap();
    "scene.toml".to_string()
}

/// `n` bytes that do not compress (xorshift), so a gzip file's size is what the test asks.
fn noise(n: usize) -> Vec<u8> {
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect()
}

fn gzip(parts: &[&[u8]]) -> Vec<u8> {
    let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    for p in parts {
        z.write_all(p).unwrap();
    }
    z.finish().unwrap()
}

fn ply_header(vertices: u64, faces: u64) -> String {
    format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {vertices}\nproperty float x\nproperty float y\nproperty float z\n\
element face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
    )
}

/// The issue's case: a 2.3 MB `.ply.gz` whose header promises 10⁹ vertices and faces (13 GB of data,
/// more than 1032 times its size can inflate to). Before: 8.6 GB resident, or an abort under a 4 GB limit.
#[test]
fn ply_gz_promising_more_than_it_can_inflate_to() {
    let dir = case_dir("ply_gz_promise");
    std::fs::write(dir.join("huge.ply.gz"), gzip(&[ply_header(1_000_000_000, 1_000_000_000).as_bytes(), &noise(2_300_000)])).unwrap();
    let scene = mesh_scene(&dir, "ply", "huge.ply.gz");
    expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet"], &["huge.ply.gz", "promises 1000000000 vertices", "can hold"]);
}

/// A header whose promise a 2.3 MB gzip file could hold (100 M vertices, 90 M faces: 2.4 GB) but whose
/// mesh (11 GB to render) the memory cannot: refused from the header, before its arrays are read.
#[test]
fn ply_gz_mesh_larger_than_memory() {
    let dir = case_dir("ply_gz_memory");
    std::fs::write(dir.join("big.ply.gz"), gzip(&[ply_header(100_000_000, 90_000_000).as_bytes(), &noise(2_400_000)])).unwrap();
    let scene = mesh_scene(&dir, "ply", "big.ply.gz");
    expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet"], &["big.ply.gz", "100000000 vertices", "ulimit -v"]);
    // The same with --memory-limit and no address-space limit to speak of: the user's limit is named.
    expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet", "--memory-limit", "0.5"], &["big.ply.gz", "the memory limit given"]);
}

/// A plain PLY file shorter than its header's counts: refused from the header, before reading.
#[test]
fn ply_promising_more_than_the_file() {
    let dir = case_dir("ply_short");
    let mut bytes = ply_header(50_000_000, 0).into_bytes();
    bytes.extend_from_slice(&[0u8; 1000]);
    std::fs::write(dir.join("short.ply"), bytes).unwrap();
    let scene = mesh_scene(&dir, "ply", "short.ply");
    expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet"], &["short.ply", "more than the 1000 bytes after its header"]);
    // A binary list whose length exceeds what is left.
    let mut bytes = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list int int vertex_indices\nend_header\n"
        .as_bytes()
        .to_vec();
    bytes.extend_from_slice(&[0u8; 36]);
    bytes.extend_from_slice(&i32::MAX.to_le_bytes());
    bytes.extend_from_slice(&[0u8; 12]);
    std::fs::write(dir.join("list.ply"), bytes).unwrap();
    let scene = mesh_scene(&dir, "ply", "list.ply");
    expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet"], &["list.ply", "a list of 2147483647 items"]);
}

/// A Mitsuba serialized file whose counts promise 10⁸ vertices and triangles in a few bytes of zlib.
#[test]
fn serialized_promising_more_than_it_can_inflate_to() {
    let dir = case_dir("serialized_promise");
    let mut raw = Vec::new();
    raw.extend_from_slice(&0x1000u32.to_le_bytes());
    raw.extend_from_slice(&100_000_000u64.to_le_bytes());
    raw.extend_from_slice(&100_000_000u64.to_le_bytes());
    raw.extend_from_slice(&[0u8; 4096]);
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(&raw).unwrap();
    let mut file = 0x041Cu16.to_le_bytes().to_vec();
    file.extend_from_slice(&3u16.to_le_bytes());
    file.extend_from_slice(&z.finish().unwrap());
    std::fs::write(dir.join("lie.serialized"), file).unwrap();
    let scene = mesh_scene(&dir, "serialized", "lie.serialized");
    expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet"], &["lie.serialized", "promises 100000000 vertices", "can hold"]);
}

/// An OBJ file whose faces make a mesh larger than `--memory-limit`: refused after counting its lines,
/// before tobj parses it.
#[test]
fn obj_larger_than_the_memory_limit() {
    let dir = case_dir("obj_memory");
    let mut text = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    text.push_str(&"f 1 2 3\n".repeat(100_000));
    std::fs::write(dir.join("many.obj"), text).unwrap();
    let scene = mesh_scene(&dir, "obj", "many.obj");
    expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet", "--memory-limit", "0.01"], &["many.obj", "100000 triangles", "the memory limit given"]);
}

/// A mesh that is a device or a FIFO: refused before it is opened (a FIFO would wait for a writer).
#[test]
fn meshes_must_be_regular_files() {
    let dir = case_dir("mesh_not_regular");
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/dev/zero", dir.join("zero.obj")).unwrap();
        let scene = mesh_scene(&dir, "obj", "zero.obj");
        expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet"], &["zero.obj", "not a regular file"]);
    }
    let fifo = dir.join("pipe.ply");
    if Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
        let scene = mesh_scene(&dir, "ply", "pipe.ply");
        expect_refused(&dir, &["render", &scene, "-o", "out.exr", "--quiet"], &["pipe.ply", "not a regular file"]);
    }
}

/// The scene file named on the command line, TOML or XML, is read as an included file is: a device, a FIFO,
/// a directory or a file over 256 MiB is refused (a FIFO would wait for a writer, /dev/zero fill memory).
#[test]
fn scene_files_must_be_regular_files_within_the_bound() {
    let dir = case_dir("scene_not_regular");
    for ext in ["toml", "xml"] {
        #[cfg(unix)]
        {
            let zero = format!("zero.{ext}");
            std::os::unix::fs::symlink("/dev/zero", dir.join(&zero)).unwrap();
            expect_refused(&dir, &["render", &zero, "-o", "out.exr", "--quiet"], &[&zero, "not a regular file"]);
            expect_refused(&dir, &["info", &zero], &[&zero, "not a regular file"]);
            std::fs::remove_file(dir.join(&zero)).unwrap();
        }
        let fifo = format!("pipe.{ext}");
        if Command::new("mkfifo").arg(dir.join(&fifo)).status().is_ok_and(|s| s.success()) {
            expect_refused(&dir, &["render", &fifo, "-o", "out.exr", "--quiet"], &[&fifo, "not a regular file"]);
            expect_refused(&dir, &["convert", &fifo, "-o", "out.toml"], &[&fifo, "not a regular file"]);
            std::fs::remove_file(dir.join(&fifo)).unwrap();
        }
        let sub = format!("sub.{ext}");
        std::fs::create_dir(dir.join(&sub)).unwrap();
        expect_refused(&dir, &["render", &sub, "-o", "out.exr", "--quiet"], &[&sub, "a directory"]);
        std::fs::remove_dir(dir.join(&sub)).unwrap();
        // A sparse file: 257 MiB stated, nothing written.
        let huge = format!("huge.{ext}");
        std::fs::File::create(dir.join(&huge)).unwrap().set_len(257 << 20).unwrap();
        expect_refused(&dir, &["render", &huge, "-o", "out.exr", "--quiet"], &[&huge, "larger than 256 MiB"]);
        std::fs::remove_file(dir.join(&huge)).unwrap();
    }
}

/// A tiny scene that renders in well under a second.
const QUICK_SCENE: &str = r#"
[integrator]
samples_per_pixel = 1
[sensor]
fov = 40
to_world = { look_at = { origin = [0, 1, 4], target = [0, 0, 0], up = [0, 1, 0] } }
film = { width = 8, height = 6 }
[[shape]]
type = "rectangle"
to_world = [ { rotate = { axis = [1, 0, 0], angle = -90 } } ]
bsdf = { type = "diffuse", reflectance = 0.5 }
[[shape]]
type = "rectangle"
to_world = [ { scale = 0.2 }, { rotate = { axis = [1, 0, 0], angle = 90 } }, { translate = [0, 2, 0] } ]
emitter = { type = "area", radiance = 5 }
"#;

/// `--stats -` and `--stats /dev/stdout` write the JSON to standard output (no file named `-`), a
/// symbolic link to a device is written through (the device stays a device), and a block device is refused.
#[test]
fn stats_to_standard_output_and_devices() {
    let dir = case_dir("stats_streams");
    std::fs::write(dir.join("s.toml"), QUICK_SCENE).unwrap();
    for target in ["-", "/dev/stdout"] {
        let (out, _) = run_limited(&dir, &["render", "s.toml", "-o", "out.exr", "--quiet", "--stats", target], Duration::from_secs(30));
        assert_eq!(out.status.code(), Some(0), "{target}: {}", String::from_utf8_lossy(&out.stderr));
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(stdout.trim_start().starts_with('{') && stdout.contains("\"partial\": false"), "{target}: {stdout}");
        assert_eq!(listing(&dir), ["out.exr", "s.toml"], "{target}");
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("/dev/null", dir.join("null.json")).unwrap();
        let (out, _) = run_limited(&dir, &["render", "s.toml", "-o", "out.exr", "--quiet", "--stats", "null.json"], Duration::from_secs(30));
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        assert!(std::fs::symlink_metadata(dir.join("null.json")).unwrap().file_type().is_symlink());
        assert!(std::os::unix::fs::FileTypeExt::is_char_device(&std::fs::metadata("/dev/null").unwrap().file_type()));
        if let Some(block) = ["/dev/loop0", "/dev/sda", "/dev/vda", "/dev/nvme0n1"].into_iter().find(|p| Path::new(p).exists()) {
            expect_refused(&dir, &["render", "s.toml", "-o", "out2.exr", "--quiet", "--stats", block], &[block, "block device"]);
        }
    }
    // `-` only where standard output is meant.
    expect_refused(&dir, &["render", "s.toml", "-o", "out2.exr", "--quiet", "--png", "-"], &["--png -", "standard output"]);
}

/// `merge` refuses an output that is one of its parts, under any name (a symbolic link, `./`), and leaves
/// the part as it was; `render -o` refuses its own `--reference`.
#[test]
fn outputs_that_are_inputs_are_refused() {
    let dir = case_dir("output_is_input");
    std::fs::write(dir.join("s.toml"), QUICK_SCENE).unwrap();
    for i in 0..2 {
        let part = format!("{i}/2");
        let out = format!("p{i}.exr");
        let (o, _) = run_limited(&dir, &["render", "s.toml", "--spp", "2", "--pass-spp", "1", "--part", &part, "-o", &out, "--quiet"], Duration::from_secs(30));
        assert_eq!(o.status.code(), Some(0), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let p0 = std::fs::read(dir.join("p0.exr")).unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink("p1.exr", dir.join("link.exr")).unwrap();
    for output in ["p0.exr", "./p0.exr", "link.exr"] {
        if dir.join(output).exists() {
            expect_refused(&dir, &["merge", "p0.exr", "p1.exr", "-o", output], &[output, "is the input"]);
        }
    }
    assert_eq!(std::fs::read(dir.join("p0.exr")).unwrap(), p0);
    expect_refused(&dir, &["render", "s.toml", "-o", "p0.exr", "--reference", "p0.exr", "--quiet"], &["p0.exr", "is the input"]);
}

/// A scene that takes several seconds (many samples per pixel on a few pixels).
const SLOW_SCENE: &str = r#"
[integrator]
samples_per_pixel = 100000
[sensor]
fov = 40
to_world = { look_at = { origin = [0, 1, 4], target = [0, 0, 0], up = [0, 1, 0] } }
film = { width = 32, height = 32 }
[[shape]]
type = "rectangle"
to_world = [ { rotate = { axis = [1, 0, 0], angle = -90 } } ]
bsdf = { type = "diffuse", reflectance = 0.5 }
[[shape]]
type = "sphere"
center = [0, 0.5, 0]
radius = 0.4
bsdf = { type = "dielectric" }
[[shape]]
type = "rectangle"
to_world = [ { scale = 0.2 }, { rotate = { axis = [1, 0, 0], angle = 90 } }, { translate = [0, 2, 0] } ]
emitter = { type = "area", radiance = 5 }
"#;

/// SIGTERM and SIGHUP in the middle of a render do what the first Ctrl-C does: the image rendered so far
/// and the stats (`partial: true`) are written, no temporary file is left, and the exit code is 128 + the
/// signal (143, 129). Slurm sends SIGTERM at a job's time limit and on `scancel`.
#[test]
fn sigterm_and_sighup_keep_the_work() {
    for (signal, code) in [("TERM", 143), ("HUP", 129)] {
        let dir = case_dir(&format!("signal_{signal}"));
        std::fs::write(dir.join("slow.toml"), SLOW_SCENE).unwrap();
        let mut child = Command::new(BIN)
            .args(["render", "slow.toml", "-o", "out.exr", "--stats", "stats.json", "--quiet", "--pass-spp", "4", "--threads", "2"])
            .current_dir(&dir)
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(Duration::from_millis(1500));
        assert!(child.try_wait().unwrap().is_none(), "SIG{signal}: the render ended before the signal");
        let sent = Instant::now();
        assert!(Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status().unwrap().success());
        while child.try_wait().unwrap().is_none() {
            assert!(sent.elapsed() < Duration::from_secs(20), "SIG{signal}: still running 20 s after the signal");
            std::thread::sleep(Duration::from_millis(10));
        }
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(code), "SIG{signal}: {:?}\n{stderr}", out.status);
        let stats = std::fs::read_to_string(dir.join("stats.json")).unwrap();
        assert!(stats.contains("\"partial\": true"), "{stats}");
        let image = caustica::film::io::read_exr(dir.join("out.exr")).unwrap();
        assert_eq!((image.width(), image.height()), (32, 32));
        assert!(image.pixels().iter().any(|p| p.x > 0.0), "SIG{signal}: the partial image is black");
        assert_eq!(listing(&dir), ["out.exr", "slow.toml", "stats.json"], "SIG{signal}");
    }
}

/// A `render --part` cut by SIGTERM (a Slurm array task at its time limit) writes the passes it finished
/// as a part marked partial and exits 143; `merge` refuses it, naming it, unless `--allow-missing`, whose
/// stats list it with the samples per pixel really merged.
#[test]
fn sigterm_mid_part_keeps_a_partial_part_for_merge() {
    let dir = case_dir("signal_part");
    std::fs::write(dir.join("slow.toml"), SLOW_SCENE).unwrap();
    let mut children: Vec<_> = (0..2)
        .map(|i| {
            let (part, out, stats) = (format!("{i}/2"), format!("p{i}.exr"), format!("p{i}.json"));
            Command::new(BIN)
                .args(["render", "slow.toml", "--part", &part, "-o", &out, "--stats", &stats, "--quiet", "--pass-spp", "4", "--threads", "1"])
                .current_dir(&dir)
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    std::thread::sleep(Duration::from_millis(2000));
    for child in &mut children {
        assert!(child.try_wait().unwrap().is_none(), "the part ended before the signal");
        assert!(Command::new("kill").arg("-TERM").arg(child.id().to_string()).status().unwrap().success());
    }
    for (i, child) in children.into_iter().enumerate() {
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(143), "part {i}: {:?}\n{stderr}", out.status);
        assert!(stderr.contains(&format!("part {i}/2 was interrupted")) && stderr.contains("--allow-missing"), "{stderr}");
        let stats: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join(format!("p{i}.json"))).unwrap()).unwrap();
        assert_eq!(stats["partial"], true, "{stats}");
    }
    assert_eq!(listing(&dir), ["p0.exr", "p0.json", "p1.exr", "p1.json", "slow.toml"]);
    // Without --allow-missing: exit 2, the cut part and its passes named, no image.
    let stderr = expect_refused(&dir, &["merge", "p0.exr", "p1.exr", "-o", "merged.exr"], &["p0.exr: part 0/2 was interrupted after", "--allow-missing"]);
    assert!(stderr.contains("of its 12500 passes"), "{stderr}");
    // With it: merged, the stats say which parts were cut and how many samples there are.
    let (out, _) = run_limited(&dir, &["merge", "p1.exr", "p0.exr", "-o", "merged.exr", "--stats", "merged.json", "--allow-missing"], Duration::from_secs(20));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("part(s) 0/2, 1/2 were interrupted"), "{stderr}");
    let stats: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(dir.join("merged.json")).unwrap()).unwrap();
    assert_eq!(stats["partial"], serde_json::json!([0, 1]));
    assert_eq!(stats["missing"], serde_json::json!([]));
    assert_eq!(stats["spp"], 100_000);
    let (mean, min) = (stats["spp_merged"].as_f64().unwrap(), stats["spp_merged_min"].as_u64().unwrap());
    let passes: u64 = stats["part_stats"].as_array().unwrap().iter().map(|p| p["phases"]["passes_rendered"].as_u64().unwrap()).sum();
    // Every pixel has the samples of the whole passes (4 each), some also the finished tiles of a cut pass.
    assert!(min >= 4 * passes && mean >= min as f64 && mean < 100_000.0, "{stats}");
    assert!(passes >= 1, "no pass finished in 2 s: {stats}");
    let image = caustica::film::io::read_exr(dir.join("merged.exr")).unwrap();
    assert!(image.pixels().iter().all(|p| p.is_finite()) && image.pixels().iter().any(|p| p.x > 0.0));
}

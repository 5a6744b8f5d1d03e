//! Fuzzing of every reader of outside input (issue 13 §4): the TOML scene loader, OBJ, PLY, PLY.gz, EXR and
//! HDR. A seeded mutation fuzzer (no extra dependency, deterministic): each round takes a valid seed input,
//! applies 1–8 random byte-level mutations (bit flips, interesting bytes, insertions, deletions, duplicated
//! and truncated ranges, for text also digit runs and extreme numbers), and feeds the result to the reader,
//! which must return `Ok` or an error whose message names the file — never panic. Inputs that panicked
//! once are kept under `tests/data/fuzz/<reader>/` and replayed by every run.
//!
//! `cargo test` runs [`ROUNDS_IN_TESTS`] rounds per reader (seconds). `scripts/fuzz SECONDS` runs the same
//! harness for a bounded time per reader (`CAUSTICA_FUZZ_SECONDS`), writing each new crashing input to
//! `tests/data/fuzz/<reader>/` and failing at the end if there was one.

use crate::common;

use common::Rng;

use std::io::Write;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use caustica::film::{read_exr, write_exr, Image};
use caustica::light::EnvMap;
use caustica::math::{Mat4, Vec3};
use caustica::mesh::load_mesh;
use caustica::scene::Scene;

const ROUNDS_IN_TESTS: u64 = 300;

const INTERESTING: &[u8] = &[0, 0xff, 0x7f, 0x80, b'\n', b' ', b'-', b'9', b'e', b'.', b'"', b'[', b'=', b'#'];
const NUMBERS: &[&str] = &["0", "-1", "4294967295", "1e38", "3e39", "nan", "inf", "-0", "1e-45", "99999999999999999999"];

/// 1–8 mutations of `seed`.
fn mutate(seed: &[u8], rng: &mut Rng, text: bool) -> Vec<u8> {
    let mut b = seed.to_vec();
    for _ in 0..1 + rng.below(8) {
        let len = b.len();
        let at = rng.below(len + 1);
        match rng.below(if text { 8 } else { 7 }) {
            0 if len > 0 => {
                let i = rng.below(len);
                b[i] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let i = rng.below(len);
                b[i] = INTERESTING[rng.below(INTERESTING.len())];
            }
            2 => {
                let n = 1 + rng.below(16);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                b.splice(at..at, bytes);
            }
            3 if len > 0 => {
                let end = (at + 1 + rng.below(64)).min(len);
                b.drain(at.min(len - 1)..end);
            }
            4 if len > 0 => {
                let start = rng.below(len);
                let end = (start + 1 + rng.below(256)).min(len);
                let piece = b[start..end].to_vec();
                b.splice(at..at, piece);
            }
            5 => b.truncate(at),
            6 if len >= 4 => {
                // A 32-bit field (binary formats: sizes, counts, offsets) set to an extreme.
                let i = rng.below(len - 3);
                let v = [0u32, 1, 0x7fff_ffff, 0xffff_ffff, 0x8000_0000, 1 << 20][rng.below(6)];
                b[i..i + 4].copy_from_slice(&v.to_le_bytes());
            }
            7 => {
                let n = NUMBERS[rng.below(NUMBERS.len())].as_bytes().to_vec();
                // Replace the digit run at or after `at` (or insert).
                let start = (at..len).find(|&i| b[i].is_ascii_digit()).unwrap_or(at);
                let end = (start..len).find(|&i| !(b[i].is_ascii_digit() || b[i] == b'.')).unwrap_or(len);
                b.splice(start..end.max(start), n);
            }
            _ => {}
        }
    }
    b
}

/// One reader: its name, file extension, seed inputs, whether it reads text, and the call.
struct Target {
    name: &'static str,
    ext: &'static str,
    seeds: Vec<Vec<u8>>,
    text: bool,
    read: fn(&Path) -> Result<(), String>,
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

const PLY_ASCII: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
property float nx\nproperty float ny\nproperty float nz\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0 0 0 1\n2 0 0 0 0 1\n2 3 0 0 0 1\n0 3 -1.5 0 0 1\n4 0 1 2 3\n";

fn ply_binary() -> Vec<u8> {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar uint vertex_indices\nend_header\n"
        .to_vec();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in v {
            b.extend_from_slice(&c.to_le_bytes());
        }
    }
    b.push(3);
    for i in [0u32, 1, 2] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// A 4×2 Radiance HDR, flat (uncompressed) scanlines.
fn hdr() -> Vec<u8> {
    let mut b = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 4\n".to_vec();
    for i in 0..8u8 {
        b.extend_from_slice(&[100 + i, 90, 80, 129]);
    }
    b
}

fn exr(dir: &Path) -> Vec<u8> {
    let path = dir.join("seed.exr");
    write_exr(&path, &Image::from_fn(5, 3, |x, y| Vec3::new(x as f32, y as f32 * 0.5, 1.0))).unwrap();
    std::fs::read(path).unwrap()
}

fn named(path: &Path, e: impl std::fmt::Display) -> String {
    let msg = e.to_string();
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    assert!(msg.contains(&name), "the error does not name {name}: {msg}");
    msg
}

fn targets(dir: &Path) -> Vec<Target> {
    let scenes = ["cornell-caustics.toml", "envmap-glass.toml", "teapot-glossy.toml"]
        .map(|f| std::fs::read(common::repo_path("scenes").join(f)).unwrap())
        .to_vec();
    vec![
        Target {
            name: "scene",
            ext: "toml",
            seeds: scenes,
            text: true,
            read: |p| {
                // Relative asset paths resolve against the shipped scenes.
                let text = std::fs::read_to_string(p).map_err(|e| e.to_string())?;
                match Scene::from_toml_str(&text, &common::repo_path("scenes"), p) {
                    Ok(_) => Ok(()),
                    Err(e) => Err(named(p, e)),
                }
            },
        },
        Target {
            name: "obj",
            ext: "obj",
            seeds: vec![
                b"v 0 0 0\nv 2 0 0\nv 2 3 0\nv 0 3 -1.5\nvn 0 0 1\nvt 0 0\nf 1/1/1 2/1/1 3/1/1 4/1/1\nf -1 -2 -3\n".to_vec(),
                std::fs::read(common::repo_path("scenes/assets/models/bunny_lowres.obj")).unwrap()[..1500].to_vec(),
            ],
            text: true,
            read: |p| load_mesh(p).map(|_| ()).map_err(|e| named(p, e)),
        },
        Target {
            name: "ply",
            ext: "ply",
            seeds: vec![PLY_ASCII.as_bytes().to_vec(), ply_binary()],
            text: false,
            read: |p| load_mesh(p).map(|_| ()).map_err(|e| named(p, e)),
        },
        Target {
            name: "plygz",
            ext: "ply.gz",
            seeds: vec![gzip(PLY_ASCII.as_bytes()), gzip(&ply_binary())],
            text: false,
            read: |p| load_mesh(p).map(|_| ()).map_err(|e| named(p, e)),
        },
        Target {
            name: "exr",
            ext: "exr",
            seeds: vec![exr(dir)],
            text: false,
            read: |p| read_exr(p).map(|_| ()).map_err(|e| named(p, e)),
        },
        Target {
            name: "hdr",
            ext: "hdr",
            seeds: vec![hdr()],
            text: false,
            read: |p| EnvMap::load(p, 1.0, Mat4::IDENTITY).map(|_| ()).map_err(|e| named(p, e)),
        },
    ]
}

fn regression_dir(target: &str) -> PathBuf {
    common::repo_path("tests/data/fuzz").join(target)
}

/// Runs `read` on `bytes` written to `path`; `Err(panic message)` if it panicked.
fn try_input(t: &Target, path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).unwrap();
    let read = t.read;
    catch_unwind(AssertUnwindSafe(|| {
        let _ = read(path);
    }))
    .map_err(|p| p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default())
}

/// Fuzzes one target for `rounds` rounds or `time` (whichever ends first); returns the crashing inputs.
fn fuzz(t: &Target, dir: &Path, rounds: u64, time: Duration, save: bool) -> Vec<String> {
    let path = dir.join(format!("input.{}", t.ext));
    let mut crashes = Vec::new();
    // The kept regression inputs first.
    if let Ok(entries) = std::fs::read_dir(regression_dir(t.name)) {
        for e in entries.flatten() {
            let bytes = std::fs::read(e.path()).unwrap();
            if let Err(m) = try_input(t, &path, &bytes) {
                crashes.push(format!("{}: regression input {} panics again: {m}", t.name, e.path().display()));
            }
        }
    }
    let start = Instant::now();
    let mut round = 0u64;
    while round < rounds && start.elapsed() < time {
        let mut rng = Rng(round.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ t.name.len() as u64);
        let seed = &t.seeds[rng.below(t.seeds.len())];
        let input = mutate(seed, &mut rng, t.text);
        if let Err(m) = try_input(t, &path, &input) {
            let mut file = format!("{}-{round}", t.name);
            if save {
                let d = regression_dir(t.name);
                std::fs::create_dir_all(&d).unwrap();
                let p = d.join(format!("crash-{round:08}.{}", t.ext));
                std::fs::write(&p, &input).unwrap();
                file = p.display().to_string();
            }
            crashes.push(format!("{}: round {round} panics ({file}): {m}", t.name));
        }
        round += 1;
    }
    eprintln!("fuzz {}: {round} rounds in {:.1} s, {} crashes", t.name, start.elapsed().as_secs_f64(), crashes.len());
    crashes
}

#[test]
fn readers_never_panic_on_mutated_input() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz");
    std::fs::create_dir_all(&dir).unwrap();
    // Bounded-time mode (scripts/fuzz): seconds per target, crashes saved as regression inputs.
    let seconds: Option<f64> = std::env::var("CAUSTICA_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok());
    let (rounds, time, save) = match seconds {
        Some(s) => (u64::MAX, Duration::from_secs_f64(s), true),
        None => (ROUNDS_IN_TESTS, Duration::MAX, false),
    };
    // Panics are caught and reported per input; keep the default hook's backtrace noise out of the log.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut crashes = Vec::new();
    for t in targets(&dir) {
        crashes.extend(fuzz(&t, &dir, rounds, time, save));
    }
    std::panic::set_hook(hook);
    assert!(crashes.is_empty(), "{} crashing inputs:\n{}", crashes.len(), crashes.join("\n"));
}

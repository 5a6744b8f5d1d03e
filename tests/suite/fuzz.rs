//! Fuzzing of every reader of outside input (issues 13 §4 and 40 §6): the scene readers (TOML and Mitsuba
//! XML, with its includes), the meshes (OBJ, PLY, PLY.gz, Mitsuba `serialized`), the images (EXR, HDR),
//! `merge`'s part files (partial-film EXR) and the textures (PNG, JPEG, OpenEXR, Radiance HDR and PFM, through
//! `texture::ImageCache`, which recognises the format by the first bytes). A seeded mutation fuzzer (no extra dependency, deterministic):
//! input k of a reader is its k-th kept corpus file, then round k − (corpus size): a seed input (a shipped
//! scene or mesh, or a small file made here) with 1–8 random byte-level mutations (bit flips, interesting
//! bytes, insertions, deletions, duplicated and truncated ranges, for text also digit runs and extreme
//! numbers). The reader must return `Ok` or an error whose message names the file and stays readable
//! (at most [`MESSAGE_BYTES`]) — never panic, abort, hang or exhaust memory.
//!
//! The inputs run in a child process (this test binary's ignored test [`fuzz_child`]) under an address-space
//! limit ([`MEMORY_KIB`], `ulimit -v`): it prints each input's index before reading it, so that the parent
//! knows the input that aborted the child (an allocation failure, a stack overflow) or that gave no answer
//! within [`HANG`], and restarts the child past it. Panics are caught in the child and reported.
//!
//! `cargo test` runs [`ROUNDS_IN_TESTS`] rounds per reader (seconds in all). `scripts/fuzz SECONDS` runs the
//! same harness for a bounded time per reader (`CAUSTICA_FUZZ_SECONDS`), writing each new failing input to
//! `tests/data/fuzz/<reader>/` (the corpus kept in the repository, replayed by every run) and failing at the
//! end if there was one; it prints the executions per reader.

use crate::common;

use common::Rng;

use std::io::{BufRead, Write};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::mpsc::{channel, RecvTimeoutError};
use std::time::{Duration, Instant};

use caustica::film::partial::write_partial_film;
use caustica::film::{read_exr, write_exr, Film, Image, PixelFilter, Rect};
use caustica::light::EnvMap;
use caustica::math::{Mat4, Vec3};
use caustica::mesh::load_mesh;
use caustica::mesh::serialized::load_serialized;
use caustica::render::part::read_part;
use caustica::scene::Scene;
use caustica::texture::{ImageCache, StorageFormat};

const ROUNDS_IN_TESTS: u64 = 300;
/// An input without an answer after this long is a hang (the slowest valid input takes well under a second).
const HANG: Duration = Duration::from_secs(10);
/// The child's address space, in KiB (`ulimit -v`): a reader must refuse, not abort, what does not fit.
const MEMORY_KIB: u64 = 2_000_000;
/// The longest error message a reader may give (values it echoes are cut).
const MESSAGE_BYTES: usize = 4096;
/// The environment variable that makes [`fuzz_child`] run: `READER FIRST END SECONDS`.
const CHILD: &str = "CAUSTICA_FUZZ_CHILD";

const INTERESTING: &[u8] = &[0, 0xff, 0x7f, 0x80, b'\n', b' ', b'-', b'9', b'e', b'.', b'"', b'[', b'=', b'#', b'<', b'>', b'/'];
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

/// A 6×4 partial film of `render --part` with a few samples and its part description (a real part's).
fn part(dir: &Path) -> Vec<u8> {
    let path = dir.join("seed-part.exr");
    let mut film = Film::with_filter(6, 4, Rect::new(1, 0, 6, 4), PixelFilter::Box).unwrap();
    for y in 0..4 {
        for x in 1..6 {
            film.add(x, y, Vec3::new(x as f32, y as f32, 0.5));
        }
    }
    let info = r#"{"part":{"index":1,"count":2},"fingerprint":"339631d50651c1781d3492248d434dc1","share":"passes","passes":4,"tiles":1,"spp":4,"scene":"s.toml","seconds_total":0.5,"phases":{"spp":4,"passes":4,"seconds_render":0.1,"seconds_photons":0.0,"seconds_kdtree":0.0,"rays_traced":40,"knn_queries":0,"knn_area_queries":0,"photons_emitted":0,"photons_stored":0,"photon_bytes":0,"photon_chains_capped":0,"mis_q1_range":null,"passes_rendered":2,"partial":false,"skipped":{}}}"#;
    write_partial_film(&path, &film, &std::collections::BTreeMap::from([("part".to_string(), info.to_string())])).unwrap();
    std::fs::read(path).unwrap()
}

fn exr(dir: &Path) -> Vec<u8> {
    let path = dir.join("seed.exr");
    write_exr(&path, &Image::from_fn(5, 3, |x, y| Vec3::new(x as f32, y as f32 * 0.5, 1.0))).unwrap();
    std::fs::read(path).unwrap()
}

/// Small texture images made here, beside the shipped ones: formats and layouts the shipped seeds lack (a
/// grey JPEG, a run-length encoded Radiance HDR, a big-endian PFM, a scan-line ZIP and a tiled, mip-mapped
/// half-float OpenEXR).
fn generated_textures(dir: &Path) -> Vec<Vec<u8>> {
    use image::ImageEncoder;
    let mut jpeg = Vec::new();
    let grey: Vec<u8> = (0..6 * 5).map(|i| (i * 37 % 256) as u8).collect();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 90).write_image(&grey, 6, 5, image::ExtendedColorType::L8).unwrap();
    let mut hdr = Vec::new();
    let rgb: Vec<image::Rgb<f32>> = (0..16 * 3).map(|i| image::Rgb([i as f32 * 0.25, 1.0, (i % 5) as f32])).collect();
    image::codecs::hdr::HdrEncoder::new(&mut hdr).encode(&rgb, 16, 3).unwrap();
    let mut pfm = b"PF\n3 2\n1.0\n".to_vec();
    for i in 0..3 * 2 * 3 {
        pfm.extend_from_slice(&(i as f32 * 0.5).to_be_bytes());
    }
    let tiled = {
        use exr::prelude::*;
        let size = Vec2(9, 7);
        let levels: Vec<_> = exr::meta::mip_map_levels(exr::math::RoundingMode::Down, size).collect();
        let channel = |name: &str, k: f32| {
            let data = levels.iter().map(|(_, s)| FlatSamples::F16((0..s.area()).map(|i| f16::from_f32(i as f32 * k)).collect())).collect();
            AnyChannel::new(name, Levels::Mip { level_data: data, rounding_mode: exr::math::RoundingMode::Down })
        };
        let channels = AnyChannels::sort(vec![channel("R", 0.5), channel("G", 0.25), channel("B", 1.0), channel("A", 0.0)].into());
        let encoding = Encoding { compression: Compression::RLE, blocks: Blocks::Tiles(Vec2(4, 4)), line_order: LineOrder::Increasing };
        let path = dir.join("seed-tiled.exr");
        Image::from_layer(Layer::new(size, LayerAttributes::default(), encoding, channels)).write().to_file(&path).unwrap();
        std::fs::read(path).unwrap()
    };
    vec![jpeg, hdr, pfm, exr(dir), tiled]
}

fn named(path: &Path, e: impl std::fmt::Display) -> String {
    let msg = e.to_string();
    let name = path.file_name().unwrap().to_string_lossy().into_owned();
    assert!(msg.contains(&name), "the error does not name {name}: {msg}");
    msg
}

fn targets(dir: &Path) -> Vec<Target> {
    let read_all = |dir: &str, files: &[&str]| files.iter().map(|f| std::fs::read(common::repo_path(dir).join(f)).unwrap()).collect::<Vec<_>>();
    vec![
        Target {
            name: "scene",
            ext: "toml",
            seeds: read_all("scenes", &["cornell-caustics.toml", "envmap-glass.toml", "teapot-glossy.toml"]),
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
            name: "xml",
            ext: "xml",
            seeds: read_all("tests/data/xml", &["cornell-caustics.xml", "hand-cornell.xml", "legacy-0.6.xml", "spectra.xml", "teapot-glossy.xml"]),
            text: true,
            read: |p| {
                // Includes and meshes resolve against the shipped XML test scenes.
                let text = std::fs::read_to_string(p).map_err(|e| e.to_string())?;
                match Scene::from_xml_str(&text, &common::repo_path("tests/data/xml"), p, &std::collections::BTreeMap::new()) {
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
            name: "serialized",
            ext: "serialized",
            seeds: read_all("tests/data/real/meshes", &["matpreview-2.serialized"]),
            text: false,
            read: |p| load_serialized(p, 0).map(|_| ()).map_err(|e| named(p, e)),
        },
        Target {
            name: "exr",
            ext: "exr",
            seeds: vec![exr(dir)],
            text: false,
            read: |p| read_exr(p).map(|_| ()).map_err(|e| named(p, e)),
        },
        Target {
            name: "part",
            ext: "exr",
            seeds: vec![part(dir)],
            text: false,
            read: |p| read_part(p).map(|_| ()).map_err(|e| named(p, e)),
        },
        Target {
            name: "texture",
            ext: "tex",
            seeds: [
                read_all("tests/data/materials/textures", &["emitter.pfm", "height.png", "normals.png", "pattern.png"]),
                read_all("tests/data/textures", &[
                    "column.png", "grey.pfm", "grey16.png", "half.exr", "palette.png", "rgb.pfm", "rgb16.png", "rgb8.jpg", "rgb8.png",
                    "rgba-float.exr", "rgba8.png", "rgbe.hdr", "y-float.exr", "ya8.png",
                ]),
                generated_textures(dir),
            ]
            .concat(),
            text: false,
            // A fresh cache per input, its limit half the child's address space (as a render's).
            read: |p| ImageCache::default().load(p, false, StorageFormat::Auto).map(|_| ()).map_err(|e| named(p, e)),
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

fn corpus_dir(target: &str) -> PathBuf {
    common::repo_path("tests/data/fuzz").join(target)
}

/// The kept inputs of `target`, in name order.
fn corpus(target: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(corpus_dir(target)).map(|d| d.flatten().map(|e| e.path()).collect()).unwrap_or_default();
    files.sort();
    files
}

/// Input `k` of `t`: corpus file k, or the mutation round k − corpus size (seeded by the round and the
/// reader's name).
fn input(t: &Target, corpus: &[PathBuf], k: u64) -> Vec<u8> {
    if let Some(file) = corpus.get(k as usize) {
        return std::fs::read(file).unwrap();
    }
    let round = k - corpus.len() as u64;
    let name = t.name.bytes().fold(0u64, |h, b| h.wrapping_mul(31).wrapping_add(u64::from(b)));
    let mut rng = Rng(round.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ name);
    let seed = &t.seeds[rng.below(t.seeds.len())];
    mutate(seed, &mut rng, t.text)
}

/// Reads `bytes` written to `path` with `t`; `Err(why)` if the reader panicked or gave an overlong message.
fn try_input(t: &Target, path: &Path, bytes: &[u8]) -> Result<(), String> {
    std::fs::write(path, bytes).unwrap();
    let read = t.read;
    match catch_unwind(AssertUnwindSafe(|| read(path))) {
        Ok(Err(message)) if message.len() > MESSAGE_BYTES => Err(format!("an error message of {} bytes", message.len())),
        Ok(_) => Ok(()),
        Err(p) => Err(format!(
            "panics: {}",
            p.downcast_ref::<String>().cloned().or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_default()
        )),
    }
}

/// The child process: reads inputs FIRST.. of one reader until END or SECONDS have passed, printing
/// `fuzz-start K` before input K, `fuzz-fail K WHY` after one that failed, `fuzz-end K` (K: the next input)
/// at the end. Run by [`readers_never_panic_hang_or_exhaust_memory`] only.
#[test]
#[ignore = "the child process of readers_never_panic_hang_or_exhaust_memory (it sets CAUSTICA_FUZZ_CHILD)"]
fn fuzz_child() {
    let spec = std::env::var(CHILD).expect("run by readers_never_panic_hang_or_exhaust_memory");
    let v: Vec<&str> = spec.split(' ').collect();
    let (first, end, seconds): (u64, u64, f64) = (v[1].parse().unwrap(), v[2].parse().unwrap(), v[3].parse().unwrap());
    let dir = work_dir();
    let t = targets(&dir).into_iter().chain([misbehaving()]).find(|t| t.name == v[0]).expect("a reader");
    let corpus = corpus(t.name);
    let path = dir.join(format!("input-{}.{}", t.name, t.ext));
    // Panics are caught and reported per input; keep the default hook's backtrace noise out of the log.
    std::panic::set_hook(Box::new(|_| {}));
    let deadline = Instant::now() + Duration::from_secs_f64(seconds);
    let mut out = std::io::stdout().lock();
    let mut k = first;
    while k < end && Instant::now() < deadline {
        writeln!(out, "fuzz-start {k}").unwrap();
        out.flush().unwrap();
        if let Err(why) = try_input(&t, &path, &input(&t, &corpus, k)) {
            writeln!(out, "fuzz-fail {k} {}", why.replace('\n', " ")).unwrap();
        }
        k += 1;
    }
    writeln!(out, "fuzz-end {k}").unwrap();
}

fn work_dir() -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// What fuzzing one reader did.
struct Run {
    executions: u64,
    slowest: Duration,
    failures: Vec<String>,
}

/// Fuzzes `t` over inputs 0..`end` or for `time` (whichever ends first) in child processes, an input
/// without an answer within `hang` counted as a hang; a failing input is named, and with `save` a new one
/// is kept in the corpus.
fn fuzz(t: &Target, end: u64, time: Duration, hang: Duration, save: bool) -> Run {
    let corpus = corpus(t.name);
    let end = end.saturating_add(corpus.len() as u64);
    let mut run = Run { executions: 0, slowest: Duration::ZERO, failures: Vec::new() };
    // New failing inputs are kept at the end: the children number the inputs by the corpus they started with.
    let mut keep: Vec<(PathBuf, Vec<u8>)> = Vec::new();
    let mut fail = |k: u64, why: &str, failures: &mut Vec<String>| {
        if let Some(file) = corpus.get(k as usize) {
            failures.push(format!("{}: kept input {} fails again: {why}", t.name, file.display()));
            return;
        }
        let mut file = format!("round {}", k - corpus.len() as u64);
        if save {
            let kind = why.split([' ', ':']).next().unwrap_or("fail");
            let p = corpus_dir(t.name).join(format!("{kind}-{:08}.{}", k - corpus.len() as u64, t.ext));
            file = p.display().to_string();
            keep.push((p, input(t, &corpus, k)));
        }
        failures.push(format!("{} ({file}): {why}", t.name));
    };
    let start = Instant::now();
    let stderr_path = work_dir().join(format!("child-{}.stderr", t.name));
    let mut k = 0u64;
    while k < end && start.elapsed() < time {
        let seconds = time.saturating_sub(start.elapsed()).as_secs_f64().min(1e9);
        let mut child = Command::new("sh")
            .arg("-c")
            .arg(format!("ulimit -v {MEMORY_KIB}; exec \"$0\" \"$@\""))
            .arg(std::env::current_exe().unwrap())
            .args(["fuzz::fuzz_child", "--exact", "--ignored", "--nocapture", "--test-threads", "1"])
            .env(CHILD, format!("{} {k} {end} {seconds}", t.name))
            .env_remove("RUST_BACKTRACE")
            .stdout(Stdio::piped())
            .stderr(std::fs::File::create(&stderr_path).unwrap())
            .spawn()
            .unwrap();
        let (tx, rx) = channel();
        let stdout = child.stdout.take().unwrap();
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
                // (libtest writes the test's name without a newline before the test's own output.)
                let Some(at) = line.find("fuzz-") else { continue };
                if tx.send(line[at..].to_string()).is_err() {
                    break;
                }
            }
        });
        let mut current: Option<(u64, Instant)> = None;
        let mut next = None;
        loop {
            match rx.recv_timeout(hang) {
                Ok(line) => {
                    let mut words = line.splitn(3, ' ');
                    let (word, n) = (words.next().unwrap_or(""), words.next().and_then(|n| n.parse::<u64>().ok()));
                    match (word, n) {
                        ("fuzz-start", Some(n)) => {
                            if let Some((_, since)) = current {
                                run.slowest = run.slowest.max(since.elapsed());
                            }
                            current = Some((n, Instant::now()));
                            run.executions += 1;
                        }
                        ("fuzz-fail", Some(n)) => fail(n, words.next().unwrap_or(""), &mut run.failures),
                        ("fuzz-end", Some(n)) => {
                            if let Some((_, since)) = current.take() {
                                run.slowest = run.slowest.max(since.elapsed());
                            }
                            next = Some(n);
                        }
                        _ => {}
                    }
                }
                Err(RecvTimeoutError::Timeout) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    let (n, _) = current.expect("the fuzz child started no input");
                    fail(n, &format!("hangs: no answer after {} s", hang.as_secs_f64()), &mut run.failures);
                    next = Some(n + 1);
                    break;
                }
                Err(RecvTimeoutError::Disconnected) => {
                    let status = child.wait().unwrap();
                    if next.is_none() || !status.success() {
                        let stderr = std::fs::read_to_string(&stderr_path).unwrap_or_default();
                        let tail: String = stderr.lines().filter(|l| !l.trim().is_empty()).take(2).collect::<Vec<_>>().join(" / ");
                        let (n, _) = current.unwrap_or_else(|| panic!("the fuzz child failed before its first input ({status}): {stderr}"));
                        fail(n, &format!("aborts: {status}, {tail}"), &mut run.failures);
                        next = Some(n + 1);
                    }
                    break;
                }
            }
        }
        k = next.unwrap();
    }
    for (path, bytes) in keep {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }
    eprintln!(
        "fuzz {}: {} executions in {:.1} s ({} kept inputs), slowest {:.3} s, {} failures",
        t.name,
        run.executions,
        start.elapsed().as_secs_f64(),
        corpus.len(),
        run.slowest.as_secs_f64(),
        run.failures.len()
    );
    run
}

#[test]
fn readers_never_panic_hang_or_exhaust_memory() {
    let dir = work_dir();
    // Bounded-time mode (scripts/fuzz): seconds per reader (optionally only the readers named in
    // CAUSTICA_FUZZ_READERS), failing inputs kept in the corpus.
    let seconds: Option<f64> = std::env::var("CAUSTICA_FUZZ_SECONDS").ok().and_then(|s| s.parse().ok());
    let only: Option<String> = std::env::var("CAUSTICA_FUZZ_READERS").ok().filter(|s| !s.is_empty());
    let (rounds, time, save) = match seconds {
        Some(s) => (u64::MAX, Duration::from_secs_f64(s), true),
        None => (ROUNDS_IN_TESTS, Duration::MAX, false),
    };
    let mut failures = Vec::new();
    for t in targets(&dir) {
        if only.as_ref().is_some_and(|o| !o.split([',', ' ']).any(|n| n == t.name)) {
            continue;
        }
        let run = fuzz(&t, rounds, time, HANG, save);
        assert!(run.executions > 0, "{}: no input was read", t.name);
        failures.extend(run.failures);
    }
    assert!(failures.is_empty(), "{} failing inputs:\n{}", failures.len(), failures.join("\n"));
}

/// A reader that misbehaves in every way the harness must catch, by its input's length: it reads, panics,
/// aborts, hangs, exhausts the memory limit, or gives an overlong message.
fn misbehaving() -> Target {
    Target {
        name: "misbehaving",
        ext: "txt",
        seeds: vec![b"a seed of some length".to_vec()],
        text: true,
        read: |p| {
            let n = std::fs::read(p).unwrap().len();
            match n % 6 {
                0 => Ok(()),
                1 => panic!("on purpose"),
                2 => std::process::abort(),
                3 => loop {
                    std::thread::sleep(Duration::from_secs(1));
                },
                4 => Err(format!("{}: {}", p.display(), std::hint::black_box(vec![1u8; (4u64 << 30) as usize]).len())),
                _ => Err(format!("{}: {}", p.display(), "x".repeat(MESSAGE_BYTES))),
            }
        },
    }
}

/// The harness itself: every input is read once, and each way of failing is caught and named, the next
/// inputs still read (a hang within the shorter limit given here).
#[test]
fn the_harness_catches_panics_aborts_hangs_and_memory_exhaustion() {
    let t = misbehaving();
    let corpus_len = corpus(t.name).len();
    assert_eq!(corpus_len, 0, "no input of the misbehaving reader is kept");
    let run = fuzz(&t, 24, Duration::MAX, Duration::from_secs(1), false);
    let lengths: Vec<usize> = (0..24).map(|k| input(&t, &[], k).len() % 6).collect();
    let failures = run.failures.join("\n");
    for (kind, why) in [(1, "panics: on purpose"), (2, "aborts"), (3, "hangs"), (4, "aborts"), (5, "an error message of")] {
        let expected = lengths.iter().filter(|&&l| l == kind).count();
        assert!(expected > 0, "no input of kind {kind} among {lengths:?}");
        let found = run.failures.iter().filter(|f| f.contains(why)).count();
        assert!(found >= expected, "{why}: {found} of {expected}:\n{failures}");
    }
    assert_eq!(run.failures.len(), lengths.iter().filter(|&&l| l != 0).count(), "{failures}");
    assert_eq!(run.executions, 24, "{failures}");
    assert!(failures.contains("memory allocation of 4294967296 bytes failed"), "{failures}");
}

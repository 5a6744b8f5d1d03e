//! `render --display-server HOST:PORT` (issue 41, item 2): the image goes to the tev viewer after every
//! round over tev's TCP protocol. A listener here plays tev: it decodes the packets as tev's
//! `IpcPacket::interpretAsCreateImage` / `interpretAsUpdateImage` read them (written out again here from
//! tev's `src/Ipc.cpp`, not taken from caustica's encoder) and puts the tiles together into images.
//!
//! The check of the pixels is exact: with the path tracer, the image after pass k of `--spp 3 --pass-spp 1`
//! is bit for bit the EXR of `render --spp k` (sample indices 0..k−1 in every pixel; see `progressive`).

use std::io::Read as _;
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;

use caustica::film::read_exr;

use super::common::repo_path;

const BIN: &str = env!("CARGO_BIN_EXE_caustica");

fn case_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("display_server").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `render` of the Cornell box at 160×48 (two tiles of tev's packets across) with the path tracer.
fn render(dir: &Path, extra: &[&str]) -> (bool, String) {
    let scene = repo_path("scenes/cornell-caustics.toml");
    let mut args: Vec<String> = ["render", scene.to_str().unwrap(), "--width", "160", "--height", "48", "--estimator", "pt", "--threads", "2"].map(String::from).to_vec();
    args.extend(extra.iter().map(|s| s.to_string()));
    let out = Command::new(BIN).args(&args).current_dir(dir).output().expect("run caustica");
    (out.status.success(), String::from_utf8_lossy(&out.stderr).into_owned())
}

/// A reader of tev's packet fields (little-endian).
struct Fields<'a> {
    data: &'a [u8],
    at: usize,
}

impl Fields<'_> {
    fn take(&mut self, n: usize) -> &[u8] {
        assert!(self.at + n <= self.data.len(), "packet too short");
        self.at += n;
        &self.data[self.at - n..self.at]
    }
    fn u8(&mut self) -> u8 {
        self.take(1)[0]
    }
    fn i32(&mut self) -> i32 {
        i32::from_le_bytes(self.take(4).try_into().unwrap())
    }
    fn i64(&mut self) -> i64 {
        i64::from_le_bytes(self.take(8).try_into().unwrap())
    }
    fn string(&mut self) -> String {
        let end = self.data[self.at..].iter().position(|&b| b == 0).expect("unterminated string");
        let s = String::from_utf8(self.data[self.at..self.at + end].to_vec()).unwrap();
        self.at += end + 1;
        s
    }
}

#[derive(Debug)]
enum Packet {
    Create { grab_focus: bool, name: String, width: usize, height: usize, channels: Vec<String> },
    Update { name: String, channels: Vec<String>, x: usize, y: usize, width: usize, height: usize, data: Vec<Vec<f32>> },
}

/// Splits a stream into packets (u32 length first, counting itself) and decodes them.
fn decode(stream: &[u8]) -> Vec<Packet> {
    let mut packets = Vec::new();
    let mut at = 0;
    while at < stream.len() {
        let len = u32::from_le_bytes(stream[at..at + 4].try_into().unwrap()) as usize;
        let mut f = Fields { data: &stream[at..at + len], at: 4 };
        packets.push(match f.u8() {
            4 => {
                let grab_focus = f.u8() == 1;
                let name = f.string();
                let (width, height, n) = (f.i32() as usize, f.i32() as usize, f.i32() as usize);
                let channels = (0..n).map(|_| f.string()).collect();
                assert_eq!(f.at, len, "CreateImage: trailing bytes");
                Packet::Create { grab_focus, name, width, height, channels }
            }
            6 => {
                let _grab_focus = f.u8();
                let name = f.string();
                let n = f.i32() as usize;
                let channels: Vec<String> = (0..n).map(|_| f.string()).collect();
                let (x, y, width, height) = (f.i32() as usize, f.i32() as usize, f.i32() as usize, f.i32() as usize);
                let offsets: Vec<i64> = (0..n).map(|_| f.i64()).collect();
                let strides: Vec<i64> = (0..n).map(|_| f.i64()).collect();
                let pixels = width * height;
                let floats = (0..n).map(|c| offsets[c] as usize + (pixels - 1) * strides[c] as usize + 1).max().unwrap();
                let raw = f.take(4 * floats);
                let value = |i: usize| f32::from_le_bytes(raw[4 * i..4 * i + 4].try_into().unwrap());
                let data = (0..n).map(|c| (0..pixels).map(|p| value(offsets[c] as usize + p * strides[c] as usize)).collect()).collect();
                assert_eq!(f.at, len, "UpdateImage: trailing bytes");
                Packet::Update { name, channels, x, y, width, height, data }
            }
            other => panic!("unexpected packet type {other}"),
        });
        at += len;
    }
    packets
}

/// The images the updates make: a new image starts when the last one has every pixel.
fn frames(packets: &[Packet], width: usize, height: usize) -> Vec<Vec<[f32; 3]>> {
    let mut frames = Vec::new();
    let (mut image, mut filled) = (vec![[0f32; 3]; width * height], 0);
    for p in packets {
        let Packet::Update { channels, x, y, width: w, height: h, data, .. } = p else { continue };
        assert_eq!(channels, &["R", "G", "B"]);
        for ty in 0..*h {
            for tx in 0..*w {
                for c in 0..3 {
                    image[(y + ty) * width + x + tx][c] = data[c][ty * w + tx];
                }
            }
        }
        filled += w * h;
        assert!(filled <= width * height, "tiles overlap within an image");
        if filled == width * height {
            frames.push(std::mem::replace(&mut image, vec![[0f32; 3]; width * height]));
            filled = 0;
        }
    }
    assert_eq!(filled, 0, "an image was left with missing tiles");
    frames
}

fn exr_pixels(path: &Path) -> Vec<[f32; 3]> {
    read_exr(path).unwrap().pixels().iter().map(|p| [p.x, p.y, p.z]).collect()
}

/// A render of three passes sends one CreateImage (R, G, B, the output's name, taking the focus), then
/// the whole image after every pass, each the image of that many samples per pixel, the last the EXR.
#[test]
fn a_render_sends_every_pass_to_the_viewer() {
    let dir = case_dir("passes");
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let address = listener.local_addr().unwrap().to_string();
    let server = std::thread::spawn(move || {
        let (mut conn, _) = listener.accept().unwrap();
        let mut stream = Vec::new();
        conn.read_to_end(&mut stream).unwrap();
        stream
    });
    let (ok, stderr) = render(&dir, &["--spp", "3", "--pass-spp", "1", "-o", "out.exr", "--display-server", &address]);
    assert!(ok, "{stderr}");
    assert!(!stderr.contains("warning"), "{stderr}");
    let packets = decode(&server.join().unwrap());
    let Packet::Create { grab_focus, name, width, height, channels } = &packets[0] else { panic!("first packet: {:?}", packets[0]) };
    assert_eq!((*grab_focus, name.as_str(), *width, *height), (true, "out.exr", 160, 48));
    assert_eq!(channels, &["R", "G", "B"]);
    assert!(packets[1..].iter().all(|p| matches!(p, Packet::Update { name, .. } if name == "out.exr")), "one create, then updates");
    // 160 pixels across: two tiles (128 + 32) per image.
    assert_eq!(packets.len(), 1 + 3 * 2);
    let frames = frames(&packets, 160, 48);
    assert_eq!(frames.len(), 3);
    for (k, frame) in frames.iter().enumerate() {
        let spp = k + 1;
        let reference = if spp == 3 {
            dir.join("out.exr")
        } else {
            let name = format!("ref-{spp}.exr");
            let (ok, stderr) = render(&dir, &["--spp", &spp.to_string(), "-q", "-o", &name]);
            assert!(ok, "{stderr}");
            dir.join(name)
        };
        assert!(*frame == exr_pixels(&reference), "the image after pass {spp} is not the {spp} spp render");
    }
}

/// No viewer (a closed port): one warning, the render goes on and writes the image it writes without
/// `--display-server`; `--log-level error` silences the warning.
#[test]
fn an_absent_viewer_costs_a_warning_only() {
    let dir = case_dir("absent");
    let address = {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        listener.local_addr().unwrap().to_string()
    };
    let (ok, stderr) = render(&dir, &["--spp", "3", "--pass-spp", "1", "-o", "with.exr", "--display-server", &address]);
    assert!(ok, "{stderr}");
    assert_eq!(stderr.matches("warning: --display-server").count(), 1, "{stderr}");
    assert!(stderr.contains(&address) && stderr.contains("the render goes on"), "{stderr}");
    let (ok, stderr) = render(&dir, &["--spp", "3", "--pass-spp", "1", "-o", "without.exr", "-q"]);
    assert!(ok, "{stderr}");
    assert!(std::fs::read(dir.join("with.exr")).unwrap() == std::fs::read(dir.join("without.exr")).unwrap());
    let (ok, stderr) = render(&dir, &["--spp", "1", "-o", "silent.exr", "--display-server", &address, "--log-level", "error"]);
    assert!(ok && stderr.is_empty(), "{stderr}");
    let (ok, stderr) = render(&dir, &["--spp", "1", "--display-server", "localhost"]);
    assert!(!ok && stderr.contains("HOST:PORT"), "{stderr}");
}

//! Mutation test of the scene loader and the renderer (issue 13 §4): 200 seeded single-token mutations of
//! each shipped scene file (a number replaced by an extreme value, a string or key replaced, a token
//! deleted or duplicated), each loaded and, when accepted, rendered at 32×32 with 1 spp in-process. Every
//! mutation must either be refused with an error naming the file and the key (or the line, for TOML
//! syntax), or render without a panic and without NaN/Inf samples. A watchdog aborts the test, naming the
//! mutation, if one takes longer than [`WATCHDOG_SECONDS`] (a hang).
//!
//! The photon budget of an accepted mutation is capped at 20,000 emitted (or 2,000 stored) photons:
//! mutated budgets beyond that are a question of time, not of correctness, and are refused up front only
//! where memory runs out (the limits are tested elsewhere).

use crate::common;

use common::Rng;

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc;
use std::time::Duration;

use caustica::accel::build_accel;
use caustica::film::Film;
use caustica::photon::PhotonBudget;
use caustica::render::{render, RenderSettings};
use caustica::scene::{Scene, SceneError};

const MUTATIONS_PER_SCENE: u64 = 200;
const WATCHDOG_SECONDS: u64 = 120;

/// Values a number is replaced by.
const EXTREMES: &[&str] = &[
    "0", "-1", "1", "0.5", "-0.0", "1e-30", "1e30", "-1e30", "3e38", "4294967295", "-4294967296", "1e9", "nan", "inf", "-inf",
    "2", "100000",
];

#[derive(Clone, Debug, PartialEq)]
enum Kind {
    Number,
    Str,
    Ident,
    Punct,
}

/// The file's tokens as (byte range, kind); comments and whitespace are skipped.
fn tokens(text: &str) -> Vec<(std::ops::Range<usize>, Kind)> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i];
        let start = i;
        if c == b'#' {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let kind = if c == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                i += 1;
            }
            i += 1;
            Kind::Str
        } else if c.is_ascii_digit() || ((c == b'-' || c == b'+') && b.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            i += 1;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b"._+-".contains(&b[i])) {
                i += 1;
            }
            Kind::Number
        } else if c.is_ascii_alphabetic() || c == b'_' {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_' || b[i] == b'-') {
                i += 1;
            }
            Kind::Ident
        } else {
            i += 1;
            Kind::Punct
        };
        out.push((start..i.min(b.len()), kind));
    }
    out
}

/// One single-token mutation of `text`, with a description.
fn mutate(text: &str, toks: &[(std::ops::Range<usize>, Kind)], rng: &mut Rng) -> (String, String) {
    let (range, kind) = toks[rng.below(toks.len())].clone();
    let old = &text[range.clone()];
    let pick_same = |rng: &mut Rng, k: &Kind| {
        let same: Vec<_> = toks.iter().filter(|(_, kk)| kk == k).collect();
        text[same[rng.below(same.len())].0.clone()].to_string()
    };
    let new = match (rng.below(4), &kind) {
        (0, _) => String::new(),
        (1, _) => format!("{old} {old}"),
        (_, Kind::Number) => EXTREMES[rng.below(EXTREMES.len())].to_string(),
        (2, Kind::Str) => ["\"\"", "\"x\"", "\"../../../etc/passwd\"", "\"assets\""][rng.below(4)].to_string(),
        (_, Kind::Ident | Kind::Str) => pick_same(rng, &kind),
        (_, Kind::Punct) => ["[", "]", "{", "}", "=", ",", "."][rng.below(7)].to_string(),
    };
    let what = format!("byte {}: `{old}` -> `{new}`", range.start);
    (format!("{}{new}{}", &text[..range.start], &text[range.end..]), what)
}

/// The error names the file, and the key (or the line and column of a TOML syntax error).
fn check_error(name: &str, err: &SceneError, what: &str) {
    let msg = err.to_string();
    assert!(msg.starts_with(name), "{name} {what}: the error does not start with the file name: {msg}");
    match err {
        SceneError::Syntax { line, .. } => assert!(*line >= 1, "{name} {what}: {msg}"),
        SceneError::Read { .. } => panic!("{name} {what}: read error on an in-memory scene: {msg}"),
        _ => assert!(err.key().is_some(), "{name} {what}: no key: {msg}"),
    }
    assert!(msg.len() > name.len() + 10, "{name} {what}: vague message: {msg}");
}

/// Renders an accepted mutation at 32×32, 1 spp.
fn render_small(mut scene: Scene, name: &str, what: &str) {
    if let Err(e) = scene.camera.set_resolution(32, 32) {
        panic!("{name} {what}: 32x32 refused: {e}");
    }
    let mut settings = RenderSettings::from_scene(&scene);
    settings.spp = 1;
    settings.photons = match settings.photons {
        PhotonBudget::Emitted(n) => PhotonBudget::Emitted(n.min(20_000)),
        PhotonBudget::Stored(m) => PhotonBudget::Stored(m.min(2_000)),
    };
    let accel = build_accel(common::backend(), &scene.geometry()).unwrap_or_else(|e| panic!("{name} {what}: {e}"));
    let mut film = Film::with_crop(32, 32, scene.camera.crop()).expect("film");
    let cancel = AtomicBool::new(false);
    match render(&scene, accel.as_ref(), &settings, &mut film, &cancel, |_, _| {}, &|_| {}) {
        Ok(_) => assert_eq!(film.nan_count() + film.inf_count(), 0, "{name} {what}: non-finite samples"),
        Err(e) => assert!(!e.to_string().is_empty(), "{name} {what}: empty render error"),
    }
}

fn mutate_scene(file: &str) {
    let path = common::repo_path("scenes").join(file);
    let text = std::fs::read_to_string(&path).unwrap();
    let toks = tokens(&text);
    let base = common::repo_path("scenes");
    let (mut refused, mut rendered) = (0, 0);
    for i in 0..MUTATIONS_PER_SCENE {
        let mut rng = Rng(i.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ file.len() as u64);
        let (mutated, what) = mutate(&text, &toks, &mut rng);
        // The watchdog: a mutation that hangs aborts the process with its description.
        let (done, wait) = mpsc::channel::<()>();
        let label = format!("{file} mutation {i} ({what})");
        let watchdog = std::thread::spawn(move || {
            if wait.recv_timeout(Duration::from_secs(WATCHDOG_SECONDS)) == Err(mpsc::RecvTimeoutError::Timeout) {
                eprintln!("HANG: {label} took more than {WATCHDOG_SECONDS} s");
                std::process::abort();
            }
        });
        match Scene::from_toml_str(&mutated, &base, Path::new(file)) {
            Err(e) => {
                check_error(file, &e, &what);
                refused += 1;
            }
            Ok(scene) => {
                render_small(scene, file, &what);
                rendered += 1;
            }
        }
        done.send(()).unwrap();
        watchdog.join().unwrap();
    }
    eprintln!("{file}: {MUTATIONS_PER_SCENE} mutations, {refused} refused with a clear error, {rendered} rendered");
    assert!(refused > 0 && rendered > 0, "the mutations exercise both outcomes");
}

#[test]
fn cornell_caustics() {
    mutate_scene("cornell-caustics.toml");
}

#[test]
fn envmap_glass() {
    mutate_scene("envmap-glass.toml");
}

#[test]
fn teapot_glossy() {
    mutate_scene("teapot-glossy.toml");
}

#[test]
fn teapot_glossy_small_light() {
    mutate_scene("teapot-glossy-small-light.toml");
}

#[test]
fn tokens_cover_the_file() {
    let t = tokens("a = [1, -2.5e3] # c\nb = \"s\"\n");
    let kinds: Vec<Kind> = t.iter().map(|(_, k)| k.clone()).collect();
    use Kind::*;
    assert_eq!(kinds, vec![Ident, Punct, Punct, Number, Punct, Number, Punct, Ident, Punct, Str]);
}

//! Split renders (`render::part`): merging the N parts of a render gives the whole render's image **bit
//! for bit**, for `pt`, `pm` and `mis`, for every N from 1 to the number of passes (shares of the passes)
//! and beyond it up to the number of tiles (shares of the tiles, every part building the same photon
//! maps), in any merge order; the parts go through their files (`write_part` / `read_part`), as they do
//! between machines. Also: the set checks (missing, duplicated, foreign parts) and the part plan's limits.
//!
//! Why it holds: each (pass, tile) is rendered by one part exactly as in the whole render, and the film
//! adds the tiles' f64 sums into exact fixed-point sums (`film::exact`), so grouping and order cannot
//! change a bit (see `render::part`). A test that cannot fail? It fails if the film goes back to f64
//! accumulation (then the 4-pass renders differ in the last bits for N = 2, 3), if a part skips a pass
//! without advancing the sample index, or if the photon map of a pass depends on the passes before it.

use crate::common;

use std::sync::atomic::AtomicBool;

use caustica::accel::build_accel;
use caustica::film::{Film, Image, PixelFilter};
use caustica::photon::PhotonBudget;
use caustica::render::part::{self, check_set, merge_parts, read_part, write_part, MergeError, Part, PartError, PartFile, PartInfo};
use caustica::render::{render_share, RenderSettings, Share, TILE_SIZE};
use caustica::scene::{Estimator, Scene};
use common::*;

/// 48×32 pixels: 3×2 = 6 tiles of 16².
fn small_cornell() -> Scene {
    let mut scene = load_scene("cornell-caustics.toml");
    scene.camera.set_resolution(48, 32).expect("resolution");
    scene
}

fn settings(scene: &Scene, estimator: Estimator, spp: u32, pass_spp: u32) -> RenderSettings {
    let mut s = RenderSettings::from_scene(scene);
    s.spp = spp;
    s.pass_spp = pass_spp;
    s.seed = 11;
    s.estimator = estimator;
    s.photons = PhotonBudget::Emitted(4_000);
    s.knn = 8;
    s
}

fn new_film(scene: &Scene) -> Film {
    Film::for_camera(&scene.camera).expect("film")
}

fn render(scene: &Scene, accel: &dyn caustica::accel::Accel, s: &RenderSettings, share: Share) -> (Film, caustica::render::RenderPhaseStats) {
    let mut film = new_film(scene);
    let cancel = AtomicBool::new(false);
    let stats = render_share(scene, accel, s, share, &mut film, &cancel, |_, _| {}, &|_| {}).expect("render");
    (film, stats)
}

/// Renders part `part`, writes it to `dir` and reads it back.
fn part_file(dir: &std::path::Path, scene: &Scene, accel: &dyn caustica::accel::Accel, s: &RenderSettings, part: Part) -> PartFile {
    let share = part::plan(s, new_film(scene).tiles(TILE_SIZE).len(), part).expect("plan");
    let (film, phases) = render(scene, accel, s, share);
    let info = PartInfo {
        part,
        fingerprint: part::fingerprint(scene, s, backend(), part.count),
        share: PartInfo::share_name(share).into(),
        passes: s.pass_count().expect("fixed spp"),
        tiles: 6,
        spp: s.spp,
        scene: "cornell-caustics".into(),
        seconds_total: 0.0,
        phases,
    };
    let path = dir.join(format!("part-{}-of-{}.exr", part.index, part.count));
    write_part(&path, &film, &info).expect("write part");
    read_part(&path).expect("read part")
}

fn bits(image: &Image) -> Vec<[u32; 3]> {
    image.pixels().iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-parts-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

#[test]
fn merged_parts_are_bit_identical_to_the_whole_render() {
    let scene = small_cornell();
    let accel = build_accel(backend(), &scene.geometry()).expect("accel");
    let dir = temp_dir("exact");
    // 4 passes of 1 spp, and the paper's configuration: one pass (of 3 spp).
    for (spp, pass_spp) in [(4, 1), (3, u32::MAX)] {
        for est in [Estimator::Pt, Estimator::Pm, Estimator::Mis] {
            let s = settings(&scene, est, spp, pass_spp);
            let (whole, whole_stats) = render(&scene, accel.as_ref(), &s, Share::All);
            let passes = s.pass_count().unwrap();
            assert_eq!(whole_stats.passes, passes);
            if est != Estimator::Pt {
                assert!(whole_stats.photons_stored > 0, "{est:?}: the test needs photons");
            }
            for n in 1..=6u32 {
                let mut parts: Vec<PartFile> = (0..n).map(|i| part_file(&dir, &scene, accel.as_ref(), &s, Part { index: i, count: n })).collect();
                let expect_share = if n <= passes { "passes" } else { "tiles" };
                assert!(parts.iter().all(|p| p.info.share == expect_share));
                // Merge order must not matter: reverse the list.
                parts.reverse();
                let (merged, stats) = merge_parts(parts, false).unwrap_or_else(|e| panic!("{e}"));
                assert!(stats.missing.is_empty());
                let what = format!("{est:?}, {spp} spp in {passes} passes, N = {n}");
                assert_eq!(merged.total_samples(), whole.total_samples(), "{what}: sample count");
                let (a, b) = (bits(&merged.image()), bits(&whole.image()));
                let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
                assert_eq!(differing, 0, "{what}: {differing} of {} pixels differ", a.len());
                for (m, w) in merged.sums().iter().zip(whole.sums()) {
                    assert_eq!((m.rgb, m.count), (w.rgb, w.count), "{what}: the exact sums differ");
                    assert!((m.lum_sq - w.lum_sq).abs() <= 1e-12 * w.lum_sq.abs(), "{what}: Σ Y² {} vs {}", m.lum_sq, w.lum_sq);
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Under Mitsuba's default Gaussian filter a tile's samples splat into its neighbours' pixels, which other
/// parts render: the parts' films (weights included, through their files) still add up to the whole.
#[test]
fn merged_parts_under_a_gaussian_filter_are_bit_identical() {
    let mut scene = small_cornell();
    scene.camera.set_filter(PixelFilter::default());
    let accel = build_accel(backend(), &scene.geometry()).expect("accel");
    let dir = temp_dir("gaussian");
    // Shares of the passes (2 passes, N = 2) and of the tiles (1 pass, N = 2 and 4).
    for (spp, pass_spp, n) in [(2, 1, 2), (2, u32::MAX, 2), (2, u32::MAX, 4)] {
        for est in [Estimator::Pt, Estimator::Mis] {
            let s = settings(&scene, est, spp, pass_spp);
            let (whole, _) = render(&scene, accel.as_ref(), &s, Share::All);
            let parts: Vec<PartFile> = (0..n).rev().map(|i| part_file(&dir, &scene, accel.as_ref(), &s, Part { index: i, count: n })).collect();
            assert!(parts.iter().all(|p| p.film.filter() == PixelFilter::default()));
            let (merged, _) = merge_parts(parts, false).unwrap_or_else(|e| panic!("{e}"));
            let what = format!("{est:?}, {spp} spp, pass spp {pass_spp}, N = {n}");
            let (a, b) = (bits(&merged.image()), bits(&whole.image()));
            let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
            assert_eq!(differing, 0, "{what}: {differing} of {} pixels differ", a.len());
            assert!(whole.image().mean_luminance() > 0.05, "{what}: black");
            for (m, w) in merged.weights().iter().zip(whole.weights()) {
                assert_eq!(m.weight, w.weight, "{what}: the exact weight sums differ");
            }
            assert_eq!(merged.total_samples(), whole.total_samples(), "{what}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_set_must_be_complete_unique_and_from_one_render() {
    let scene = small_cornell();
    let accel = build_accel(backend(), &scene.geometry()).expect("accel");
    let dir = temp_dir("set");
    let s = settings(&scene, Estimator::Pt, 3, 1);
    let p = |i, n| part_file(&dir, &scene, accel.as_ref(), &s, Part { index: i, count: n });
    let (a, b, c) = (p(0, 3), p(1, 3), p(2, 3));
    assert_eq!(check_set(&[a.clone(), b.clone(), c.clone()], false).unwrap(), Vec::<u32>::new());
    // Missing: named; allowed with allow_missing, which reports it.
    match check_set(&[c.clone(), a.clone()], false) {
        Err(e @ MergeError::Missing { .. }) => assert!(e.to_string().contains("part 1/3"), "{e}"),
        other => panic!("expected a missing part, got {other:?}"),
    }
    assert_eq!(check_set(&[c.clone(), a.clone()], true).unwrap(), vec![1]);
    let (partial, stats) = merge_parts(vec![a.clone(), c.clone()], true).unwrap();
    assert_eq!(stats.missing, vec![1]);
    assert_eq!(partial.total_samples(), 2 * 48 * 32);
    // Cut short (a part interrupted by a signal): named with its passes, allowed with allow_missing.
    let mut cut = b.clone();
    cut.info.phases.partial = true;
    match check_set(&[a.clone(), cut.clone(), c.clone()], false) {
        Err(e @ MergeError::Partial { .. }) => assert!(e.to_string().contains("part 1/3 was interrupted after 1 of its 1 passes"), "{e}"),
        other => panic!("expected a partial part, got {other:?}"),
    }
    let (_, stats) = merge_parts(vec![a.clone(), cut, c.clone()], true).unwrap();
    assert_eq!((stats.partial, stats.missing, stats.spp_merged, stats.spp_merged_min), (vec![1], vec![], 3.0, 3));
    // Duplicated: both files named, even with allow_missing.
    let mut b2 = b.clone();
    b2.path = dir.join("copy-of-part-1.exr");
    match check_set(&[a.clone(), b.clone(), b2, c.clone()], true) {
        Err(e @ MergeError::Duplicate { .. }) => {
            let t = e.to_string();
            assert!(t.contains("part 1/3") && t.contains("part-1-of-3.exr") && t.contains("copy-of-part-1.exr"), "{t}");
        }
        other => panic!("expected a duplicate, got {other:?}"),
    }
    // Foreign: another seed, or another N: the odd one out is named.
    let mut other_seed = s.clone();
    other_seed.seed += 1;
    let mut foreign = part_file(&dir, &scene, accel.as_ref(), &other_seed, Part { index: 1, count: 3 });
    foreign.path = dir.join("other-seed.exr");
    match check_set(&[a.clone(), foreign, c.clone()], false) {
        Err(e @ MergeError::Foreign { .. }) => assert!(e.to_string().starts_with(&format!("{}:", dir.join("other-seed.exr").display())), "{e}"),
        other => panic!("expected a foreign part, got {other:?}"),
    }
    let mut four = p(1, 4);
    four.path = dir.join("of-four.exr");
    assert!(matches!(check_set(&[a, four, c], false), Err(MergeError::Foreign { .. })));
    // A plain image is not a part.
    let plain = dir.join("plain.exr");
    caustica::film::write_exr(&plain, &Image::new(2, 2)).unwrap();
    let e = read_part(&plain).unwrap_err();
    assert!(e.to_string().contains("not a caustica partial film"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn plans_need_a_fixed_sample_count_and_enough_work() {
    let scene = small_cornell();
    let mut s = settings(&scene, Estimator::Pt, 8, 2);
    assert_eq!(s.pass_count(), Some(4));
    let part = |i, n| Part { index: i, count: n };
    assert_eq!(part::plan(&s, 6, part(3, 4)), Ok(Share::Passes { index: 3, count: 4 }));
    assert_eq!(part::plan(&s, 6, part(5, 6)), Ok(Share::Tiles { index: 5, count: 6 }));
    assert_eq!(part::plan(&s, 6, part(0, 7)), Err(PartError::TooManyParts { parts: 7, passes: 4, tiles: 6 }));
    s.time_limit = Some(10.0);
    assert_eq!(part::plan(&s, 6, part(0, 2)), Err(PartError::TimeLimited));
    assert_eq!("2/4".parse::<Part>(), Ok(part(2, 4)));
    for bad in ["4/4", "1/0", "1", "a/2", "-1/2"] {
        assert!(bad.parse::<Part>().is_err(), "{bad}");
    }
    // The fingerprint tells renders apart by settings and N, not by the part index.
    let s = settings(&scene, Estimator::Pt, 8, 2);
    let f = |s: &RenderSettings, n| part::fingerprint(&scene, s, backend(), n);
    let mut t = s.clone();
    t.spp = 9;
    assert_eq!(f(&s, 4), f(&s, 4));
    assert_ne!(f(&s, 4), f(&s, 3));
    assert_ne!(f(&s, 4), f(&t, 4));
    let mut moved = small_cornell();
    moved.mesh.positions[0].x += 1e-3;
    assert_ne!(part::fingerprint(&moved, &s, backend(), 4), f(&s, 4));
}

/// The command line: `render --part` + `merge` make the same EXR bytes as `render`; an incomplete set and
/// a time-limited part exit 2 with a message naming the part or the flag, and write nothing.
#[test]
fn cli_parts_and_merge() {
    let bin = env!("CARGO_BIN_EXE_caustica");
    let dir = temp_dir("cli");
    let scene = repo_path("scenes/cornell-caustics.toml");
    let flags = ["--width", "32", "--height", "16", "--spp", "3", "--pass-spp", "1", "--estimator", "mis", "--photons", "3000", "--quiet", "--backend", backend().name()];
    let run = |args: &[&str]| std::process::Command::new(bin).args(args).output().expect("run caustica");
    let path = |name: &str| dir.join(name).display().to_string();
    let scene = scene.display().to_string();
    let whole = run(&[&["render", &scene, "-o", &path("whole.exr")][..], &flags].concat());
    assert!(whole.status.success(), "{}", String::from_utf8_lossy(&whole.stderr));
    for i in 0..3 {
        let p = run(&[&["render", &scene, "--part", &format!("{i}/3"), "-o", &path(&format!("p{i}.exr")), "--stats", &path(&format!("p{i}.json"))][..], &flags].concat());
        assert!(p.status.success(), "{}", String::from_utf8_lossy(&p.stderr));
    }
    let stats: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path("p1.json")).unwrap()).unwrap();
    assert_eq!(stats["part"]["share"], "passes");
    assert_eq!(stats["part"]["passes_rendered"], 1);
    // Incomplete: exit 2, the missing part named, no image.
    let m = run(&["merge", &path("p2.exr"), &path("p0.exr"), "-o", &path("merged.exr")]);
    assert_eq!(m.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&m.stderr).contains("part 1/3"), "{}", String::from_utf8_lossy(&m.stderr));
    assert!(!dir.join("merged.exr").exists());
    // Complete: the same bytes as the whole render.
    let m = run(&["merge", &path("p2.exr"), &path("p0.exr"), &path("p1.exr"), "-o", &path("merged.exr"), "--stats", &path("merge.json")]);
    assert!(m.status.success(), "{}", String::from_utf8_lossy(&m.stderr));
    assert_eq!(std::fs::read(path("merged.exr")).unwrap(), std::fs::read(path("whole.exr")).unwrap(), "merged EXR differs from the whole render's");
    // --allow-missing says which part is missing in the stats, and the spp merged (2 of 3), also under -q.
    let m = run(&["merge", &path("p0.exr"), &path("p2.exr"), "-o", &path("subset.exr"), "--stats", &path("subset.json"), "--allow-missing"]);
    let stderr = String::from_utf8_lossy(&m.stderr);
    assert!(m.status.success(), "{stderr}");
    let stats: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(path("subset.json")).unwrap()).unwrap();
    assert_eq!(stats["missing"], serde_json::json!([1]));
    assert_eq!((stats["spp"].as_u64(), stats["spp_merged"].as_f64(), stats["spp_merged_min"].as_u64()), (Some(3), Some(2.0), Some(2)));
    assert!(stderr.contains("warning: merged without part(s) 1/3: the image has 2.00 spp of the 3") && stderr.contains("3 spp asked, 2.00 merged"), "{stderr}");
    let m = run(&["merge", &path("p0.exr"), &path("p2.exr"), "-o", &path("subset.exr"), "--allow-missing", "-q"]);
    let stderr = String::from_utf8_lossy(&m.stderr);
    assert!(stderr.contains("2.00 spp of the 3") && !stderr.contains("merged 2 of 3 parts"), "{stderr}");
    // A time-limited part is refused before rendering.
    let t = run(&["render", &scene, "--part", "0/2", "--time-limit", "1", "-o", &path("t.exr"), "--quiet"]);
    assert_eq!(t.status.code(), Some(2));
    let err = String::from_utf8_lossy(&t.stderr);
    assert!(err.contains("--part") && err.contains("fixed sample count"), "{err}");
    assert!(!dir.join("t.exr").exists());
    let _ = std::fs::remove_dir_all(&dir);
}

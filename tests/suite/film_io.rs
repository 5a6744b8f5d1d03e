//! Reading and writing images: EXR round trip, PNG encoding, atomic writes, bad files, the Mitsuba reference.

use std::path::{Path, PathBuf};

use caustica::film::io::{temp_path_for, write_bytes_atomic};
use caustica::film::{read_exr, write_exr, write_png, Image, ImageError, Tonemap};
use caustica::math::Vec3;

const REFERENCE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/reference/cornell-caustics/mitsuba-path-9984spp.exr");

/// A fresh, empty directory for one test.
fn test_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("film_io-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn dir_entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn assert_names_file(err: &ImageError, path: &Path) {
    let msg = err.to_string();
    assert!(
        msg.contains(&path.display().to_string()),
        "error does not name {}: {msg}",
        path.display()
    );
}

#[test]
fn exr_round_trip_is_bit_exact() {
    let dir = test_dir("roundtrip");
    let special = [
        0.0,
        -0.0,
        1e-40,
        -3.5,
        6.0e37,
        f32::MIN_POSITIVE,
        f32::INFINITY,
        f32::NAN,
        0.1,
        1.0 / 3.0,
    ];
    let img = Image::from_fn(37, 19, |x, y| {
        let i = (y * 37 + x) as usize;
        Vec3::new(special[i % special.len()], (x as f32 + 0.25).sqrt() * 1.7, (y as f32).sin() * 1e3)
    });
    let path = dir.join("rt.exr");
    write_exr(&path, &img).unwrap();
    let back = read_exr(&path).unwrap();
    assert_eq!((back.width(), back.height()), (37, 19));
    for (a, b) in img.pixels().iter().zip(back.pixels()) {
        assert_eq!(a.to_array().map(f32::to_bits), b.to_array().map(f32::to_bits));
    }
    // Overwriting replaces the file atomically and leaves no temp file behind.
    let img2 = Image::from_fn(2, 3, |x, y| Vec3::splat((x + y) as f32));
    write_exr(&path, &img2).unwrap();
    assert_eq!(read_exr(&path).unwrap(), img2);
    assert_eq!(dir_entries(&dir), vec!["rt.exr".to_string()]);
}

#[test]
fn png_encodes_srgb() {
    let dir = test_dir("png");
    let img = Image::from_fn(3, 2, |x, y| match (x, y) {
        (0, 0) => Vec3::splat(0.5),
        (1, 0) => Vec3::new(0.0, 1.0, 7.0),
        (2, 0) => Vec3::splat(f32::NAN),
        (0, 1) => Vec3::splat(1.0),
        _ => Vec3::splat(0.25),
    });
    let path = dir.join("a.png");
    write_png(&path, &img, 0.0, Tonemap::Clamp).unwrap();
    let png = image::open(&path).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (3, 2));
    assert_eq!(png.get_pixel(0, 0).0, [188, 188, 188]);
    assert_eq!(png.get_pixel(1, 0).0, [0, 255, 255]);
    assert_eq!(png.get_pixel(2, 0).0, [0, 0, 0]);
    assert_eq!(png.get_pixel(0, 1).0, [255, 255, 255]);
    // 0.25 → 1.055·0.25^(1/2.4) − 0.055 = 0.5371 → 136.97 → 137.
    assert_eq!(png.get_pixel(1, 1).0, [137, 137, 137]);
    // +1 stop turns 0.25 into 0.5 (188); Reinhard maps 1.0·2 = 2 → 2/3 → 1.055·(2/3)^(1/2.4) − 0.055 = 0.8359 → 213.2 → 213.
    write_png(&path, &img, 1.0, Tonemap::Reinhard).unwrap();
    let png = image::open(&path).unwrap().to_rgb8();
    assert_eq!(png.get_pixel(0, 1).0, [213, 213, 213]);
    write_png(&path, &img, 1.0, Tonemap::Clamp).unwrap();
    let png = image::open(&path).unwrap().to_rgb8();
    assert_eq!(png.get_pixel(1, 1).0, [188, 188, 188]);
    assert_eq!(dir_entries(&dir), vec!["a.png".to_string()]);
}

#[test]
fn writes_into_missing_directory_fail_cleanly() {
    let dir = test_dir("missing");
    let img = Image::new(4, 4);
    let target = dir.join("no-such-dir").join("out.exr");
    let err = write_exr(&target, &img).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err}");
    assert_names_file(&err, &target);
    let err = write_png(target.with_extension("png"), &img, 0.0, Tonemap::Aces).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err}");
    assert!(write_bytes_atomic(target.with_extension("json"), b"{}").is_err());
    assert!(dir_entries(&dir).is_empty());
}

#[test]
fn failed_rename_removes_the_temp_file() {
    // The target is a non-empty directory: the temp file is written, the rename fails, the temp must go.
    let dir = test_dir("rename");
    let target = dir.join("taken.exr");
    std::fs::create_dir_all(target.join("inside")).unwrap();
    let err = write_exr(&target, &Image::new(2, 2)).unwrap_err();
    assert_names_file(&err, &target);
    assert!(!temp_path_for(&target).unwrap().exists());
    assert_eq!(dir_entries(&dir), vec!["taken.exr".to_string()]);
    let err = write_exr(dir.join("empty.exr"), &Image::new(0, 3)).unwrap_err();
    assert!(matches!(err, ImageError::Size { .. }), "{err}");
    assert_eq!(dir_entries(&dir), vec!["taken.exr".to_string()]);
}

#[test]
fn bad_files_are_errors_naming_the_file() {
    let dir = test_dir("bad");
    // Missing.
    let missing = dir.join("missing.exr");
    let err = read_exr(&missing).unwrap_err();
    assert!(matches!(err, ImageError::Io { .. }), "{err}");
    assert_names_file(&err, &missing);
    // Unreadable: a directory (permission bits do not stop root, which the tests may run as).
    let unreadable = dir.join("a-directory.exr");
    std::fs::create_dir(&unreadable).unwrap();
    let err = read_exr(&unreadable).unwrap_err();
    assert_names_file(&err, &unreadable);
    // Not an EXR file.
    let text = dir.join("text.exr");
    std::fs::write(&text, b"this is not an OpenEXR file at all\n").unwrap();
    let err = read_exr(&text).unwrap_err();
    assert!(matches!(err, ImageError::Exr { .. }), "{err}");
    assert_names_file(&err, &text);
    // A PNG is not an EXR either.
    let png = dir.join("image.png");
    write_png(&png, &Image::new(2, 2), 0.0, Tonemap::Clamp).unwrap();
    assert_names_file(&read_exr(&png).unwrap_err(), &png);
    // Truncated EXR files, cut at several points (header, offset table, pixel data).
    let good = dir.join("good.exr");
    write_exr(&good, &Image::from_fn(64, 64, |x, y| Vec3::new(x as f32, y as f32, 0.5))).unwrap();
    let bytes = std::fs::read(&good).unwrap();
    for cut in [0, 3, 20, bytes.len() / 2, bytes.len() - 1] {
        let truncated = dir.join(format!("truncated-{cut}.exr"));
        std::fs::write(&truncated, &bytes[..cut]).unwrap();
        let err = read_exr(&truncated).unwrap_err();
        assert_names_file(&err, &truncated);
    }
}

#[test]
fn reads_the_mitsuba_reference() {
    let path = Path::new(REFERENCE);
    let img = read_exr(path).unwrap();
    assert_eq!((img.width(), img.height()), (256, 256));
    assert_eq!(img.non_finite_counts(), (0, 0));
    assert!(img.pixels().iter().all(|p| p.min_element() >= 0.0));
    let mean = img.mean();
    println!("reference mean RGB = {mean:?}, luminance = {}", img.mean_luminance());
    // Values measured once from the file (see the film helper's report), kept to 1e-6 relative.
    let expected = [MEAN_R, MEAN_G, MEAN_B];
    for c in 0..3 {
        assert!(
            (mean[c] - expected[c]).abs() <= 1e-6 * expected[c],
            "channel {c}: {} vs {}",
            mean[c],
            expected[c]
        );
    }
    // The light (radiance 15, seen directly) covers rows 31–42 at the centre column; nothing is brighter.
    assert_eq!(img.get(128, 36), Vec3::splat(15.0));
    assert!(img.pixels().iter().all(|p| p.max_element() <= 15.0));
    // Round trip through our writer keeps it bit-exact.
    let dir = test_dir("reference");
    write_exr(dir.join("ref.exr"), &img).unwrap();
    assert_eq!(read_exr(dir.join("ref.exr")).unwrap().pixels(), img.pixels());
}

/// Per-channel means of the reference, measured with this reader (f64 sums over the 65,536 pixels).
const MEAN_R: f64 = 0.311_710_190_400_393_8;
const MEAN_G: f64 = 0.315_360_839_328_978_07;
const MEAN_B: f64 = 0.241_816_632_917_822_54;

/// Independent check of the decoder (channel order, orientation, PIZ decompression): the reference's PNG
/// preview, made by Mitsuba with a plain clamp and the sRGB curve, matches our encoding of the EXR to
/// within one 8-bit level in every channel of every pixel (they differ only in rounding).
#[test]
fn reference_matches_its_png_preview() {
    let img = read_exr(REFERENCE).unwrap();
    let preview = image::open(Path::new(REFERENCE).with_extension("png")).unwrap().to_rgb8();
    assert_eq!(preview.dimensions(), (256, 256));
    let mut exact = 0;
    for y in 0..256 {
        for x in 0..256 {
            let ours = caustica::film::io::display_rgb8(img.get(x, y), 0.0, Tonemap::Clamp);
            let theirs = preview.get_pixel(x, y).0;
            for c in 0..3 {
                let d = (i32::from(ours[c]) - i32::from(theirs[c])).abs();
                assert!(d <= 1, "pixel ({x}, {y}) channel {c}: ours {} vs preview {}", ours[c], theirs[c]);
                exact += u32::from(d == 0);
            }
        }
    }
    // Most values agree exactly (measured: 151,327 of 196,608).
    assert!(exact > 196_608 / 2, "only {exact} exact matches");
}

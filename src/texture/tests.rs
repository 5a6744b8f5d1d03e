//! Texture tests: wrap modes and filters on known texels, sRGB decoding, each file format (written here),
//! bad files, the cache, the checkerboard, statistics, the plugin descriptions, and the comparison with
//! Mitsuba 3.9.1's numbers (`tests/data/textures/references.json`, written by
//! `scripts/make-texture-references`).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::*;

/// A fresh directory for one test's files.
fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-texture-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn cache() -> ImageCache {
    ImageCache::new(1 << 30)
}

/// The bitmap of `path` with the given options.
fn bitmap(path: &Path, raw: bool, filter: FilterType, wrap: WrapMode) -> Result<Texture, TextureError> {
    let spec = TextureSpec::Bitmap(BitmapSpec { filename: path.to_string_lossy().into_owned(), raw, filter, wrap, format: StorageFormat::Auto });
    spec.load(Path::new("/"), &mut cache())
}

/// A 3×2 RGB image in memory: texel (x, y) = (x, y, 10 + x + 3y) / 16.
fn image_3x2() -> Arc<TextureImage> {
    let mut data = Vec::new();
    for y in 0..2 {
        for x in 0..3 {
            data.extend([x as f32 / 16.0, y as f32 / 16.0, (10 + x + 3 * y) as f32 / 16.0]);
        }
    }
    Arc::new(TextureImage::from_linear("<3x2>", 3, 2, 3, data).unwrap())
}

fn texel_3x2(x: i32, y: i32) -> Vec3 {
    Vec3::new(x as f32, y as f32, (10 + x + 3 * y) as f32) / 16.0
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 1e-6
}

#[test]
fn wrap_modes_follow_drjit_for_negative_and_large_indices() {
    let n = 3;
    let got = |m: WrapMode| (-7..=8).map(|i| m.wrap(i, n)).collect::<Vec<_>>();
    // i:                                        -7 -6 -5 -4 -3 -2 -1  0  1  2  3  4  5  6  7  8
    assert_eq!(got(WrapMode::Repeat), vec![2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0, 1, 2]);
    assert_eq!(got(WrapMode::Mirror), vec![0, 0, 1, 2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0, 1, 2]);
    assert_eq!(got(WrapMode::Clamp), vec![0, 0, 0, 0, 0, 0, 0, 0, 1, 2, 2, 2, 2, 2, 2, 2]);
    // Far away and non-finite coordinates give some texel, no panic.
    for m in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
        assert!(m.wrap(i64::MIN, n) < 3 && m.wrap(i64::MAX, n) < 3);
        let b = Bitmap::new(image_3x2(), FilterType::Bilinear, m);
        for uv in [Vec2::splat(f32::NAN), Vec2::splat(f32::INFINITY), Vec2::new(-1e30, 1e30)] {
            let _ = b.eval_rgb(uv);
        }
    }
}

#[test]
fn nearest_reads_the_texel_containing_uv_with_v_down_the_rows() {
    for wrap in [WrapMode::Repeat, WrapMode::Mirror, WrapMode::Clamp] {
        let b = Bitmap::new(image_3x2(), FilterType::Nearest, wrap);
        for y in 0..2 {
            for x in 0..3 {
                // Anywhere inside the texel's square [x/3, (x+1)/3) × [y/2, (y+1)/2).
                for (du, dv) in [(0.01, 0.01), (0.5, 0.5), (0.99, 0.99)] {
                    let uv = Vec2::new((x as f32 + du) / 3.0, (y as f32 + dv) / 2.0);
                    assert_eq!(b.eval_rgb(uv), texel_3x2(x, y), "{wrap:?} {uv}");
                }
            }
        }
    }
    // Outside [0, 1): u = −0.1 is texel column −1: repeat → 2, mirror → 0, clamp → 0.
    let at = |wrap| Bitmap::new(image_3x2(), FilterType::Nearest, wrap).eval_rgb(Vec2::new(-0.1, 0.25));
    assert_eq!(at(WrapMode::Repeat), texel_3x2(2, 0));
    assert_eq!(at(WrapMode::Mirror), texel_3x2(0, 0));
    assert_eq!(at(WrapMode::Clamp), texel_3x2(0, 0));
    // v = 1.25: row 2 → repeat 0, mirror 1, clamp 1.
    let at = |wrap| Bitmap::new(image_3x2(), FilterType::Nearest, wrap).eval_rgb(Vec2::new(0.5, 1.25));
    assert_eq!(at(WrapMode::Repeat), texel_3x2(1, 0));
    assert_eq!(at(WrapMode::Mirror), texel_3x2(1, 1));
    assert_eq!(at(WrapMode::Clamp), texel_3x2(1, 1));
}

#[test]
fn bilinear_reads_texel_centres_at_half_integers_and_blends_between() {
    let b = Bitmap::new(image_3x2(), FilterType::Bilinear, WrapMode::Repeat);
    let centre = |x: f32, y: f32| Vec2::new((x + 0.5) / 3.0, (y + 0.5) / 2.0);
    for y in 0..2 {
        for x in 0..3 {
            assert!(close(b.eval_rgb(centre(x as f32, y as f32)), texel_3x2(x, y)));
        }
    }
    // A quarter of the way from texel (0,0) to (1,0), and half way down to row 1.
    let got = b.eval_rgb(centre(0.25, 0.5));
    let want = (texel_3x2(0, 0) * 0.75 + texel_3x2(1, 0) * 0.25) * 0.5 + (texel_3x2(0, 1) * 0.75 + texel_3x2(1, 1) * 0.25) * 0.5;
    assert!(close(got, want), "{got} {want}");
    // At the corner uv = (0, 0) the four texels around it are the image's four corners (repeat), or texel
    // (0, 0) alone (clamp), or texel (0, 0) alone too (mirror: −1 → 0).
    let corners = (texel_3x2(0, 0) + texel_3x2(2, 0) + texel_3x2(0, 1) + texel_3x2(2, 1)) / 4.0;
    assert!(close(b.eval_rgb(Vec2::ZERO), corners));
    for wrap in [WrapMode::Clamp, WrapMode::Mirror] {
        assert!(close(Bitmap::new(image_3x2(), FilterType::Bilinear, wrap).eval_rgb(Vec2::ZERO), texel_3x2(0, 0)));
    }
    // Repeat is periodic in both directions, also for negative coordinates.
    for uv in [Vec2::new(0.13, 0.37), Vec2::new(0.9, 0.05)] {
        for shift in [Vec2::new(1.0, 0.0), Vec2::new(-2.0, 3.0), Vec2::new(-5.0, -1.0)] {
            assert!(close(b.eval_rgb(uv + shift), b.eval_rgb(uv)), "{uv} {shift}");
        }
    }
    // Mirror: u and −u read the same.
    let m = Bitmap::new(image_3x2(), FilterType::Bilinear, WrapMode::Mirror);
    assert!(close(m.eval_rgb(Vec2::new(-0.2, 0.3)), m.eval_rgb(Vec2::new(0.2, 0.3))));
    assert!(close(m.eval_rgb(Vec2::new(1.2, 0.3)), m.eval_rgb(Vec2::new(0.8, 0.3))));
}

#[test]
fn to_uv_applies_before_the_lookup() {
    // Scale u by 2 and shift v by a half: texel at (0.6, 0.1) is the original at (1.2, 0.6) → (0.2, 0.6).
    let m = Mat3::from_cols(Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 0.5, 1.0));
    let t = Texture::Bitmap(Bitmap::new(image_3x2(), FilterType::Bilinear, WrapMode::Repeat));
    let shifted = t.clone().with_to_uv(m);
    assert!(close(shifted.eval_rgb(Vec2::new(0.6, 0.1)), t.eval_rgb(Vec2::new(0.2, 0.6))));
    assert_eq!(Texture::Constant(Vec3::ONE).with_to_uv(m).eval_rgb(Vec2::ZERO), Vec3::ONE);
}

#[test]
fn eval_1_grad_is_the_derivative_of_the_bilinear_lookup() {
    // Central differences of eval_1 inside texel cells (away from the cell edges where the derivative jumps),
    // with and without a to_uv (a diagonal one on this non-square image, where Mitsuba's order of the
    // resolution and the transform agrees with the chain rule), and wrapping across the edge.
    let scale = Mat3::from_cols(Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, -3.0, 0.0), Vec3::new(0.1, 0.2, 1.0));
    for to_uv in [Mat3::IDENTITY, scale] {
        let t = Texture::Bitmap(Bitmap::new(image_3x2(), FilterType::Bilinear, WrapMode::Repeat).with_to_uv(to_uv));
        for uv in [Vec2::new(0.3, 0.6), Vec2::new(0.71, 0.13), Vec2::new(-0.02, 0.9), Vec2::new(0.95, 1.1)] {
            let h = 1e-3f32;
            let fd = Vec2::new(
                (t.eval_1(uv + Vec2::new(h, 0.0)) - t.eval_1(uv - Vec2::new(h, 0.0))) / (2.0 * h),
                (t.eval_1(uv + Vec2::new(0.0, h)) - t.eval_1(uv - Vec2::new(0.0, h))) / (2.0 * h),
            );
            let g = t.eval_1_grad(uv);
            assert!((g - fd).abs().max_element() <= 2e-3 * (1.0 + fd.abs().max_element()), "{to_uv:?} at {uv}: {g} vs {fd}");
        }
    }
    let nearest = Texture::Bitmap(Bitmap::new(image_3x2(), FilterType::Nearest, WrapMode::Repeat));
    assert_eq!(nearest.eval_1_grad(Vec2::new(0.3, 0.6)), Vec2::ZERO);
    assert_eq!(Texture::Constant(Vec3::ONE).eval_1_grad(Vec2::new(0.3, 0.6)), Vec2::ZERO);
}

#[test]
fn eval_1_is_luminance_of_rgb_and_the_value_of_grey() {
    let b = Bitmap::new(image_3x2(), FilterType::Bilinear, WrapMode::Repeat);
    let uv = Vec2::new(0.3, 0.7);
    assert!((b.eval_1(uv) - luminance(b.eval_rgb(uv))).abs() < 1e-7);
    let grey = Arc::new(TextureImage::from_linear("<grey>", 2, 2, 1, vec![0.1, 0.2, 0.3, 0.4]).unwrap());
    let g = Bitmap::new(grey, FilterType::Nearest, WrapMode::Repeat);
    assert_eq!(g.eval_1(Vec2::new(0.75, 0.75)), 0.4);
    assert_eq!(g.eval_rgb(Vec2::new(0.75, 0.25)), Vec3::splat(0.2));
    assert!((Texture::Constant(Vec3::new(0.3, 0.6, 0.9)).eval_1(uv) - 0.6).abs() < 1e-7);
}

#[test]
fn statistics_of_constant_bitmap_and_checkerboard() {
    let t = Texture::Bitmap(Bitmap::new(image_3x2(), FilterType::Bilinear, WrapMode::Repeat));
    let texels: Vec<Vec3> = (0..2).flat_map(|y| (0..3).map(move |x| texel_3x2(x, y))).collect();
    let mean_rgb = texels.iter().sum::<Vec3>() / 6.0;
    assert!(close(t.mean_rgb(), mean_rgb));
    assert!((t.mean() - texels.iter().map(|&c| luminance(c)).sum::<f32>() / 6.0).abs() < 1e-7);
    assert_eq!(t.max(), Vec3::new(2.0, 1.0, 15.0) / 16.0);
    assert_eq!(t.min(), Vec3::new(0.0, 0.0, 10.0) / 16.0);
    assert_eq!(t.memory_bytes(), 6 * 3 * 4);
    let c = Texture::Constant(Vec3::new(0.1, 0.2, 0.6));
    assert!((c.mean() - 0.3).abs() < 1e-7);
    assert_eq!((c.max(), c.min(), c.mean_rgb()), (Vec3::new(0.1, 0.2, 0.6), Vec3::new(0.1, 0.2, 0.6), Vec3::new(0.1, 0.2, 0.6)));
    assert!(!c.is_spatially_varying() && t.is_spatially_varying());
    let k = TextureSpec::Checkerboard { color0: Vec3::new(0.9, 0.0, 0.3), color1: Vec3::new(0.1, 0.6, 0.0) }.load(Path::new("."), &mut cache()).unwrap();
    assert!((k.mean() - 0.5 * (0.4 + 0.7 / 3.0)).abs() < 1e-7);
    assert_eq!(k.max(), Vec3::new(0.9, 0.6, 0.3));
    assert_eq!(k.min(), Vec3::new(0.1, 0.0, 0.0));
    assert!(close(k.mean_rgb(), Vec3::new(0.5, 0.3, 0.15)));
}

#[test]
fn checkerboard_pattern_and_its_swapped_eval_1() {
    let (c0, c1) = (Vec3::new(0.9, 0.3, 0.0), Vec3::new(0.0, 0.15, 0.3));
    let k = Checkerboard { color0: c0, color1: c1, to_uv: Mat3::IDENTITY };
    for (u, v, want) in [(0.25, 0.25, c0), (0.75, 0.75, c0), (0.75, 0.25, c1), (0.25, 0.75, c1), (-0.25, 0.25, c1), (-0.75, -0.75, c0), (1.25, 2.25, c0), (0.5, 0.5, c0), (0.5001, 0.5, c1)] {
        let uv = Vec2::new(u, v);
        assert_eq!(k.eval_rgb(uv), want, "{uv}");
        // Mitsuba 3.9.1's eval_1 reads the other colour.
        let other = if want == c0 { c1 } else { c0 };
        assert!((k.eval_1(uv) - (other.x + other.y + other.z) / 3.0).abs() < 1e-7, "{uv}");
    }
    // to_uv scaling by 2: squares of a quarter.
    let k2 = Texture::Checkerboard(k.clone()).with_to_uv(Mat3::from_scale(Vec2::splat(2.0)));
    assert_eq!(k2.eval_rgb(Vec2::new(0.375, 0.125)), c1);
    assert_eq!(k2.eval_rgb(Vec2::new(0.375, 0.375)), c0);
}

#[test]
fn small_images_are_padded_to_two_by_two_as_mitsuba() {
    let one = TextureImage::from_linear("<1x3>", 1, 3, 1, vec![0.1, 0.2, 0.3]).unwrap();
    assert_eq!((one.width(), one.height()), (2, 3));
    assert_eq!(one.data(), &[0.1, 0.1, 0.2, 0.2, 0.3, 0.3]);
    let dot = TextureImage::from_linear("<1x1>", 1, 1, 3, vec![0.5, 0.25, 0.125]).unwrap();
    assert_eq!((dot.width(), dot.height()), (2, 2));
    assert_eq!(dot.texel(1, 1), Vec3::new(0.5, 0.25, 0.125));
    assert!(matches!(TextureImage::from_linear("<0>", 0, 3, 1, vec![]), Err(TextureError::Empty { .. })));
    assert!(matches!(TextureImage::from_linear("<bad>", 2, 2, 2, vec![0.0; 8]), Err(TextureError::Unsupported { .. })));
    assert!(matches!(TextureImage::from_linear("<nan>", 2, 1, 1, vec![0.0, f32::NAN]), Err(TextureError::NonFinite { x: 1, y: 0, .. })));
}

// ---- file formats ----

fn save(dir: &Path, name: &str, img: impl Into<::image::DynamicImage>) -> PathBuf {
    let p = dir.join(name);
    img.into().save(&p).unwrap();
    p
}

fn srgb8(k: u8) -> f32 {
    srgb_to_linear(f64::from(k) / 255.0) as f32
}

fn first_texel(t: &Texture) -> Vec3 {
    match t {
        Texture::Bitmap(b) => b.image().texel(0, 0),
        _ => unreachable!(),
    }
}

#[test]
fn png_8_bit_grey_alpha_rgb_rgba_decode_srgb_unless_raw_and_drop_alpha() {
    let d = temp_dir("png8");
    let rgba = ::image::RgbaImage::from_raw(2, 1, vec![128, 10, 255, 0, 1, 2, 3, 77]).unwrap();
    let rgb = ::image::RgbImage::from_raw(2, 1, vec![128, 10, 255, 1, 2, 3]).unwrap();
    let la = ::image::GrayAlphaImage::from_raw(2, 1, vec![200, 0, 5, 255]).unwrap();
    let l = ::image::GrayImage::from_raw(2, 1, vec![200, 5]).unwrap();
    let nearest = |p: &Path, raw| bitmap(p, raw, FilterType::Nearest, WrapMode::Repeat).unwrap();
    for p in [save(&d, "rgba.png", rgba), save(&d, "rgb.png", rgb)] {
        let t = nearest(&p, false);
        assert_eq!(first_texel(&t), Vec3::new(srgb8(128), srgb8(10), 1.0), "{p:?}");
        // The sRGB curve: 128 → 0.2158605, 10 → 10/255/12.92 (linear part).
        assert!((srgb8(128) - 0.215_860_5).abs() < 1e-6 && (srgb8(10) - 10.0 / 255.0 / 12.92).abs() < 1e-9);
        let raw = nearest(&p, true);
        assert_eq!(first_texel(&raw), Vec3::new(128.0 / 255.0, 10.0 / 255.0, 1.0));
        let Texture::Bitmap(b) = &t else { unreachable!() };
        assert_eq!((b.image().channels(), b.image().width(), b.image().height()), (3, 2, 2));
    }
    for p in [save(&d, "la.png", la), save(&d, "l.png", l)] {
        let t = nearest(&p, false);
        let Texture::Bitmap(b) = &t else { unreachable!() };
        assert_eq!(b.image().channels(), 1);
        assert_eq!(b.image().data(), &[srgb8(200), srgb8(5), srgb8(200), srgb8(5)], "{p:?}");
    }
}

#[test]
fn png_16_bit_is_decoded_then_rounded_to_half_as_mitsuba_stores_it() {
    let d = temp_dir("png16");
    let img = ::image::ImageBuffer::<::image::Luma<u16>, _>::from_raw(2, 2, vec![0u16, 1000, 32768, 65535]).unwrap();
    let p = save(&d, "l16.png", img);
    let t = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap();
    let Texture::Bitmap(b) = &t else { unreachable!() };
    let want = |k: u16| half::f16::from_f32(srgb_to_linear(f64::from(k) / 65535.0) as f32).to_f32();
    assert_eq!(b.image().data(), &[0.0, want(1000), want(32768), 1.0]);
    assert_ne!(want(32768), srgb_to_linear(32768.0 / 65535.0) as f32, "half rounding is visible");
    // `variant` keeps f32.
    let spec = TextureSpec::Bitmap(BitmapSpec { filename: "l16.png".into(), raw: true, filter: FilterType::Nearest, wrap: WrapMode::Repeat, format: StorageFormat::Variant });
    let Texture::Bitmap(v) = spec.load(&d, &mut cache()).unwrap() else { unreachable!() };
    assert_eq!(v.image().data()[2], 32768.0 / 65535.0);
    // `uint8` on a 16-bit image: Mitsuba dithers; refused.
    let spec = TextureSpec::Bitmap(BitmapSpec { format: StorageFormat::UInt8, ..bitmap_spec("l16.png") });
    let e = spec.load(&d, &mut cache()).unwrap_err();
    assert!(e.to_string().contains("uint8") && e.to_string().contains("l16.png"), "{e}");
}

fn bitmap_spec(name: &str) -> BitmapSpec {
    BitmapSpec { filename: name.into(), raw: false, filter: FilterType::Bilinear, wrap: WrapMode::Repeat, format: StorageFormat::Auto }
}

#[test]
fn jpeg_decodes_as_srgb() {
    let d = temp_dir("jpeg");
    // A flat colour survives JPEG exactly (every block is its DC term).
    let p = d.join("flat.jpg");
    let img = ::image::GrayImage::from_pixel(16, 8, ::image::Luma([128]));
    let mut f = std::fs::File::create(&p).unwrap();
    ::image::codecs::jpeg::JpegEncoder::new_with_quality(&mut f, 100).encode_image(&img).unwrap();
    drop(f);
    let t = bitmap(&p, false, FilterType::Bilinear, WrapMode::Repeat).unwrap();
    assert!((t.eval_rgb(Vec2::new(0.3, 0.6)) - Vec3::splat(srgb8(128))).abs().max_element() < 1e-7);
    let raw = bitmap(&p, true, FilterType::Bilinear, WrapMode::Repeat).unwrap();
    assert!((raw.eval_1(Vec2::new(0.3, 0.6)) - 128.0 / 255.0).abs() < 1e-7);
}

#[test]
fn radiance_hdr_is_linear() {
    let d = temp_dir("hdr");
    let p = d.join("a.hdr");
    let px = [::image::Rgb([1.0f32, 0.5, 0.25]), ::image::Rgb([2.0, 4.0, 0.125]), ::image::Rgb([0.0, 0.0, 0.0]), ::image::Rgb([8.0, 1.0, 0.5])];
    ::image::codecs::hdr::HdrEncoder::new(std::fs::File::create(&p).unwrap()).encode(&px, 2, 2).unwrap();
    // raw changes nothing for a linear format.
    for raw in [false, true] {
        let t = bitmap(&p, raw, FilterType::Nearest, WrapMode::Repeat).unwrap();
        assert_eq!(t.eval_rgb(Vec2::new(0.25, 0.25)), Vec3::new(1.0, 0.5, 0.25));
        assert_eq!(t.eval_rgb(Vec2::new(0.75, 0.25)), Vec3::new(2.0, 4.0, 0.125));
        assert_eq!(t.eval_rgb(Vec2::new(0.75, 0.75)), Vec3::new(8.0, 1.0, 0.5));
    }
    // 16 columns: the encoder writes run-length encoded scanlines.
    let p = d.join("rle.hdr");
    let px: Vec<_> = (0..32).map(|i| ::image::Rgb([(i % 4) as f32, 0.5, if i < 16 { 1.0 } else { 0.25 }])).collect();
    ::image::codecs::hdr::HdrEncoder::new(std::fs::File::create(&p).unwrap()).encode(&px, 16, 2).unwrap();
    let t = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap();
    for (i, want) in px.iter().enumerate() {
        let uv = Vec2::new(((i % 16) as f32 + 0.5) / 16.0, ((i / 16) as f32 + 0.5) / 2.0);
        assert_eq!(t.eval_rgb(uv), Vec3::from_array(want.0), "{i}");
    }
}

/// A PFM file: `rows` from the top, `channels` per pixel, written bottom row first.
fn write_pfm(path: &Path, width: usize, channels: usize, rows_top_first: &[f32], scale: f32) {
    let mut bytes = format!("{}\n{} {}\n{}\n", if channels == 3 { "PF" } else { "Pf" }, width, rows_top_first.len() / width / channels, scale).into_bytes();
    for row in rows_top_first.chunks(width * channels).rev() {
        for v in row {
            bytes.extend(if scale < 0.0 { v.to_le_bytes() } else { v.to_be_bytes() });
        }
    }
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn pfm_rows_run_bottom_up_with_scale_and_byte_order() {
    let d = temp_dir("pfm");
    let rows = [1.0f32, 2.0, 3.0, 4.0, 5.0, 6.0, /* second row */ 7.0, 8.0, 9.0, 10.0, 11.0, 12.0];
    for (name, scale, factor) in [("le.pfm", -1.0, 1.0), ("be.pfm", 1.0, 1.0), ("scaled.pfm", -2.0, 2.0)] {
        let p = d.join(name);
        write_pfm(&p, 2, 3, &rows, scale);
        let t = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap();
        assert_eq!(t.eval_rgb(Vec2::new(0.25, 0.25)), Vec3::new(1.0, 2.0, 3.0) * factor, "{name}");
        assert_eq!(t.eval_rgb(Vec2::new(0.75, 0.75)), Vec3::new(10.0, 11.0, 12.0) * factor, "{name}");
    }
    let p = d.join("grey.pfm");
    write_pfm(&p, 2, 1, &[0.5, 0.25, 0.125, 2.0], -1.0);
    let t = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap();
    assert_eq!(t.eval_rgb(Vec2::new(0.75, 0.75)), Vec3::splat(2.0));
}

/// An OpenEXR file of the named f32 channels (each `w × h` samples).
fn write_exr(path: &Path, w: usize, h: usize, channels: &[(&str, Vec<f32>)]) {
    use exr::prelude::*;
    let list: SmallVec<[AnyChannel<FlatSamples>; 4]> = channels.iter().map(|(n, v)| AnyChannel::new(*n, FlatSamples::F32(v.clone()))).collect();
    Image::from_channels((w, h), AnyChannels::sort(list)).write().to_file(path).unwrap();
}

#[test]
fn openexr_reads_rgb_rgba_and_y_and_refuses_other_channels() {
    let d = temp_dir("exr");
    let p = d.join("rgba.exr");
    write_exr(&p, 2, 1, &[("R", vec![1.5, -0.25]), ("G", vec![2.0, 0.0]), ("B", vec![0.125, 9.0]), ("A", vec![0.0, 0.5])]);
    let t = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap();
    assert_eq!(t.eval_rgb(Vec2::new(0.25, 0.5)), Vec3::new(1.5, 2.0, 0.125));
    assert_eq!(t.eval_rgb(Vec2::new(0.75, 0.5)), Vec3::new(-0.25, 0.0, 9.0));
    assert_eq!(t.min(), Vec3::new(-0.25, 0.0, 0.125));
    let p = d.join("layer.exr");
    write_exr(&p, 1, 2, &[("diffuse.Y", vec![0.25, 3.0])]);
    let t = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap();
    assert_eq!(t.eval_1(Vec2::new(0.5, 0.75)), 3.0);
    let p = d.join("depth.exr");
    write_exr(&p, 1, 1, &[("Z", vec![1.0])]);
    let e = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap_err();
    assert!(matches!(e, TextureError::Unsupported { .. }) && e.to_string().contains("depth.exr") && e.to_string().contains("Z"), "{e}");
    let p = d.join("nan.exr");
    write_exr(&p, 2, 1, &[("Y", vec![0.0, f32::INFINITY])]);
    let e = bitmap(&p, false, FilterType::Nearest, WrapMode::Repeat).unwrap_err();
    assert!(matches!(e, TextureError::NonFinite { x: 1, y: 0, .. }), "{e}");
}

#[test]
fn bad_files_are_errors_that_name_the_file() {
    let d = temp_dir("bad");
    let check = |p: &Path, what: &str| {
        let e = bitmap(p, false, FilterType::Bilinear, WrapMode::Repeat).unwrap_err();
        let m = e.to_string();
        assert!(m.contains(&*p.to_string_lossy()) && m.contains(what), "{m}");
        e
    };
    assert!(matches!(check(&d.join("missing.png"), "No such file"), TextureError::Io { .. }));
    assert!(matches!(check(&d, "directory"), TextureError::Io { .. }));
    let p = d.join("text.png");
    std::fs::write(&p, "not an image").unwrap();
    assert!(matches!(check(&p, "not an image caustica reads"), TextureError::UnknownFormat { .. }));
    let p = d.join("empty.pfm");
    std::fs::write(&p, "PF\n0 4\n-1\n").unwrap();
    assert!(matches!(check(&p, "empty"), TextureError::Empty { .. }));
    // A header asking for 10⁶ × 10⁶ pixels (12 TB): refused before anything is allocated.
    let p = d.join("huge.pfm");
    std::fs::write(&p, "PF\n1000000 1000000\n-1\n").unwrap();
    assert!(matches!(check(&p, "memory limit"), TextureError::TooLarge { .. }));
    let p = d.join("short.pfm");
    std::fs::write(&p, "PF\n2 2\n-1\n\0\0\0\0").unwrap();
    assert!(matches!(check(&p, "ends before"), TextureError::Decode { .. }));
    let p = d.join("trunc.png");
    let full = d.join("full.png");
    ::image::RgbImage::from_pixel(64, 64, ::image::Rgb([1, 2, 3])).save(&full).unwrap();
    let bytes = std::fs::read(&full).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    assert!(matches!(check(&p, "PNG"), TextureError::Decode { .. } | TextureError::Io { .. }));
    let p = d.join("trunc.exr");
    write_exr(&full.with_extension("exr"), 2, 2, &[("Y", vec![0.0; 4])]);
    let bytes = std::fs::read(full.with_extension("exr")).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() - 8]).unwrap();
    let _ = check(&p, "trunc.exr");
    // A PNG within the format but beyond a cache's limit.
    let mut small = ImageCache::new(1000);
    let e = small.load(&full, false, StorageFormat::Auto).unwrap_err();
    assert!(matches!(e, TextureError::TooLarge { width: 64, height: 64, .. }), "{e}");
    assert_eq!(small.memory_bytes(), 0);
}

#[test]
fn the_cache_decodes_each_image_once() {
    let d = temp_dir("cache");
    save(&d, "a.png", ::image::RgbImage::from_pixel(4, 4, ::image::Rgb([10, 20, 30])));
    let mut c = cache();
    let spec = TextureSpec::Bitmap(bitmap_spec("a.png"));
    let (t1, t2) = (spec.load(&d, &mut c).unwrap(), spec.load(&d, &mut c).unwrap());
    // Through another name of the same file.
    let t3 = TextureSpec::Bitmap(BitmapSpec { filename: format!("{}/./a.png", d.display()), wrap: WrapMode::Clamp, ..bitmap_spec("") }).load(Path::new("/elsewhere"), &mut c).unwrap();
    let arc = |t: &Texture| match t {
        Texture::Bitmap(b) => Arc::clone(b.image_arc()),
        _ => unreachable!(),
    };
    assert!(Arc::ptr_eq(&arc(&t1), &arc(&t2)) && Arc::ptr_eq(&arc(&t1), &arc(&t3)));
    assert_eq!((c.len(), c.memory_bytes()), (1, 4 * 4 * 3 * 4));
    // raw decodes an 8-bit image differently: a second image.
    let raw = TextureSpec::Bitmap(BitmapSpec { raw: true, ..bitmap_spec("a.png") }).load(&d, &mut c).unwrap();
    assert!(!Arc::ptr_eq(&arc(&t1), &arc(&raw)));
    assert_eq!((c.len(), c.memory_bytes()), (2, 2 * 4 * 4 * 3 * 4));
    // On a float image raw changes nothing: the same texels, kept once.
    let p = d.join("f.pfm");
    write_pfm(&p, 2, 1, &[0.5, 0.25, 0.125, 2.0], -1.0);
    let a = TextureSpec::Bitmap(bitmap_spec("f.pfm")).load(&d, &mut c).unwrap();
    let b = TextureSpec::Bitmap(BitmapSpec { raw: true, ..bitmap_spec("f.pfm") }).load(&d, &mut c).unwrap();
    assert!(Arc::ptr_eq(&arc(&a), &arc(&b)));
    assert_eq!(c.len(), 3);
    assert_eq!(a.memory_bytes(), 2 * 2 * 4);
    let _ = p;
}

// ---- plugin descriptions ----

fn build(name: &str, toml_text: &str) -> Result<TextureSpec, PropError> {
    let table: toml::Table = toml_text.parse().unwrap();
    let plugin = plugin(name).unwrap();
    for k in table.keys() {
        assert!(plugin.keys.contains(&k.as_str()), "{k}");
    }
    (plugin.build)(Props::new(&table, plugin.keys, Vec::new()))
}

#[test]
fn plugins_read_mitsubas_keys_and_defaults() {
    assert_eq!(PLUGINS.iter().map(|p| p.name).collect::<Vec<_>>(), ["bitmap", "checkerboard", "mesh_attribute", "rawconstant"]);
    assert_eq!(build("bitmap", "filename = \"a.png\"").unwrap(), TextureSpec::Bitmap(BitmapSpec { filename: "a.png".into(), ..bitmap_spec("") }));
    let all = "filename = \"b.exr\"\nraw = true\nfilter_type = \"nearest\"\nwrap_mode = \"mirror\"\nformat = \"fp16\"\naccel = false";
    assert_eq!(
        build("bitmap", all).unwrap(),
        TextureSpec::Bitmap(BitmapSpec { filename: "b.exr".into(), raw: true, filter: FilterType::Nearest, wrap: WrapMode::Mirror, format: StorageFormat::Float16 })
    );
    let e = build("bitmap", "filename = \"a.png\"\nwrap_mode = \"wrap\"").unwrap_err();
    assert_eq!((e.key.as_str(), e.message.as_str()), ("wrap_mode", "\"wrap\" is not one of \"repeat\", \"mirror\", \"clamp\""));
    assert_eq!(build("bitmap", "raw = true").unwrap_err().key, "filename");
    assert_eq!(build("bitmap", "filename = \"\"").unwrap_err().key, "filename");
    assert_eq!(build("bitmap", "filename = \"a\"\nfilter_type = 1").unwrap_err().key, "filter_type");
    assert_eq!(build("checkerboard", "").unwrap(), TextureSpec::Checkerboard { color0: Vec3::splat(0.4), color1: Vec3::splat(0.2) });
    assert_eq!(build("checkerboard", "color0 = [0.1, 0.2, 0.3]\ncolor1 = 1").unwrap(), TextureSpec::Checkerboard { color0: Vec3::new(0.1, 0.2, 0.3), color1: Vec3::ONE });
    // A number is Mitsuba's unbounded `uniform`, an RGB colour its bounded `srgb`.
    assert_eq!(build("checkerboard", "color1 = 1.5").unwrap(), TextureSpec::Checkerboard { color0: Vec3::splat(0.4), color1: Vec3::splat(1.5) });
    assert_eq!(build("checkerboard", "color1 = [1.5, 0.5, 0.5]").unwrap_err().key, "color1");
    assert_eq!(build("checkerboard", "color0 = nan").unwrap_err().key, "color0");
    // `rawconstant`: one value or three, as written (no colour conversion, no range check); required.
    assert_eq!(build("rawconstant", "value = [0.5, 0.5, 1.0]").unwrap(), TextureSpec::Constant(Vec3::new(0.5, 0.5, 1.0)));
    assert_eq!(build("rawconstant", "value = -2.5").unwrap(), TextureSpec::Constant(Vec3::splat(-2.5)));
    assert_eq!(build("rawconstant", "").unwrap_err().key, "value");
    assert_eq!(build("rawconstant", "value = [1, 2]").unwrap_err().key, "value");
    assert_eq!(build("rawconstant", "value = \"red\"").unwrap_err().key, "value");
}

// ---- against Mitsuba 3.9.1 ----

fn repo_path(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

fn f(v: &serde_json::Value) -> f32 {
    v.as_f64().unwrap() as f32
}

fn to_uv(v: &serde_json::Value) -> Option<Mat3> {
    let rows = v.as_array()?;
    let r: Vec<[f32; 3]> = rows.iter().map(|row| std::array::from_fn(|j| f(&row[j]))).collect();
    Some(Mat3::from_cols_array_2d(&[r[0], r[1], r[2]]).transpose())
}

/// |a − b| relative to the larger magnitude (values below 1e-6 compared absolutely).
fn rel(a: f32, b: f32) -> f64 {
    f64::from((a - b).abs()) / f64::from(a.abs().max(b.abs()).max(1e-6))
}

/// Bounds of the JPEG evaluations' relative difference from Mitsuba's (mean, worst): a little above what
/// was measured (mean 1.70e-2, worst 1.435e-1 on 2026-12-06), so a change of decoder or of its rounding shows.
const JPEG_MEAN: f64 = 0.02;
const JPEG_WORST: f64 = 0.15;

#[test]
fn evaluations_match_mitsuba_3_9_1() {
    let text = std::fs::read_to_string(repo_path("tests/data/textures/references.json")).unwrap();
    let refs: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(refs["mitsuba"], "3.9.1");
    let uvs: Vec<Vec2> = refs["uvs"].as_array().unwrap().iter().map(|p| Vec2::new(f(&p[0]), f(&p[1]))).collect();
    let dir = repo_path("tests/data/textures");
    let mut c = cache();
    // (worst relative difference, where) for every format but JPEG; for JPEG, the worst and the mean
    // (another decoder: the `image` crate's zune-jpeg against Mitsuba's libjpeg-turbo, below).
    let (mut worst, mut worst_jpeg) = ((0.0f64, String::new()), (0.0f64, String::new()));
    let (mut jpeg_sum, mut jpeg_n) = (0.0f64, 0usize);
    let cases = refs["cases"].as_array().unwrap();
    for case in cases {
        let t = &case["texture"];
        let (spec, name) = match t["type"].as_str().unwrap() {
            "bitmap" => {
                let pick = |k: &str| t[k].as_str().unwrap().to_string();
                let filter = if pick("filter_type") == "nearest" { FilterType::Nearest } else { FilterType::Bilinear };
                let wrap = match pick("wrap_mode").as_str() {
                    "repeat" => WrapMode::Repeat,
                    "mirror" => WrapMode::Mirror,
                    _ => WrapMode::Clamp,
                };
                let format = StorageFormat::NAMES.iter().find(|(n, _)| *n == pick("format")).unwrap().1;
                let spec = BitmapSpec { filename: pick("filename"), raw: t["raw"].as_bool().unwrap(), filter, wrap, format };
                (TextureSpec::Bitmap(spec), pick("filename"))
            }
            _ => {
                let colour = |k: &str| t[k].as_array().map_or(Vec3::splat(if k == "color0" { 0.4 } else { 0.2 }), |a| Vec3::new(f(&a[0]), f(&a[1]), f(&a[2])));
                (TextureSpec::Checkerboard { color0: colour("color0"), color1: colour("color1") }, "checkerboard".into())
            }
        };
        let mut tex = spec.load(&dir, &mut c).unwrap_or_else(|e| panic!("{e}"));
        if let Some(m) = to_uv(&t["to_uv"]) {
            tex = tex.with_to_uv(m);
        }
        let jpeg = name.ends_with(".jpg");
        let slot = if jpeg { &mut worst_jpeg } else { &mut worst };
        let mut note = |e: f64, what: String| {
            if jpeg {
                jpeg_sum += e;
                jpeg_n += 1;
            }
            if e > slot.0 {
                *slot = (e, what);
            }
        };
        note(rel(tex.mean(), f(&case["mean"])), format!("{t} mean"));
        for (uv, row) in uvs.iter().zip(case["evals"].as_array().unwrap()) {
            let got = tex.eval_rgb(*uv);
            for k in 0..3 {
                note(rel(got[k], f(&row[k])), format!("{t} at {uv} channel {k}: {} against {}", got[k], f(&row[k])));
            }
            note(rel(tex.eval_1(*uv), f(&row[3])), format!("{t} eval_1 at {uv}: {} against {}", tex.eval_1(*uv), f(&row[3])));
        }
    }
    let jpeg_mean = jpeg_sum / jpeg_n as f64;
    eprintln!(
        "{} cases: worst relative difference {:.3e} ({}); JPEG: mean {jpeg_mean:.3e}, worst {:.3e} ({})",
        cases.len(),
        worst.0,
        worst.1,
        worst_jpeg.0,
        worst_jpeg.1
    );
    assert!(worst.0 <= 1e-5, "{:.3e}: {}", worst.0, worst.1);
    // JPEG decoders differ: on this 8×8 4:2:0 image zune-jpeg's chroma upsampling differs from
    // libjpeg-turbo's in the last column (up to 14 codes of 255; 64 of its 192 samples differ, the others'
    // by 1 or 2 codes), which bilinear lookups near that column see.
    assert!(jpeg_mean <= JPEG_MEAN && worst_jpeg.0 <= JPEG_WORST, "JPEG mean {jpeg_mean:.3e}, worst {:.3e}: {}", worst_jpeg.0, worst_jpeg.1);
}

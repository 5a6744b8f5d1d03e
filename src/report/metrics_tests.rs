//! Hand-computed metrics on tiny images.

use super::*;
use crate::math::Vec3;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-9 * b.abs().max(1.0)
}

macro_rules! assert_close {
    ($a:expr, $b:expr) => {
        assert!(close($a, $b), "{} = {} but expected {}", stringify!($a), $a, $b)
    };
}

/// 2×2: one pixel exact, one against a black reference (ε matters), two with one wrong channel.
fn two_by_two() -> (Image, Image) {
    let reference = Image::from_pixels(2, 2, vec![Vec3::splat(1.0), Vec3::ZERO, Vec3::splat(2.0), Vec3::splat(1.0)]).unwrap();
    let image = Image::from_pixels(
        2,
        2,
        vec![
            Vec3::splat(1.0),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(3.0, 2.0, 2.0),
            Vec3::new(1.0, 1.0, 0.5),
        ],
    )
    .unwrap();
    (image, reference)
}

#[test]
fn two_by_two_hand_computed() {
    let (image, reference) = two_by_two();
    let m = region_metrics(&image, &reference, &Region::whole(2, 2), 1).unwrap();
    // Differences: 0.1 (R of a black pixel), 1 (R of a pixel 2), −0.5 (B of a pixel 1); 12 channel values.
    assert_eq!((m.pixels, m.valid_pixels, m.nan_count, m.inf_count), (4, 4, 0, 0));
    assert_close!(m.rmse, (1.26f64 / 12.0).sqrt());
    assert_close!(m.mae, 1.6 / 12.0);
    // relMSE: 0.1²/(0 + ε) = 1 exactly-ish (f32 0.1), 1/(4 + ε), 0.25/(1 + ε).
    let d0 = f64::from(0.1f32);
    let rel = d0 * d0 / 0.01 + 1.0 / 4.01 + 0.25 / 1.01;
    assert_close!(m.relmse, rel / 12.0);
    assert!((m.relmse - 1.496_901_311 / 12.0).abs() < 1e-8);
    let mean_r = (1.0 + d0 + 3.0 + 1.0) / 4.0;
    assert_close!(m.mean_image[0], mean_r);
    assert_close!(m.mean_image[1], 1.0);
    assert_close!(m.mean_image[2], 0.875);
    assert_eq!(m.mean_reference, [1.0, 1.0, 1.0]);
    assert_close!(m.mean_ratio[0], mean_r);
    assert_close!(m.mean_ratio[2], 0.875);
    assert_close!(m.luminance_ratio, 0.2126 * mean_r + 0.7152 + 0.0722 * 0.875);
    // 1-pixel blocks: block RMSE = RMSE.
    assert_eq!(m.blocks, 4);
    assert_close!(m.block_rmse, m.rmse);
    // One 2×2 block (and a 3×3 block, partial, is the same block): mean differences (0.275, 0, −0.125).
    for block in [2, 3] {
        let m = region_metrics(&image, &reference, &Region::whole(2, 2), block).unwrap();
        assert_eq!(m.blocks, 1);
        let dr = mean_r - 1.0;
        assert_close!(m.block_rmse, ((dr * dr + 0.125 * 0.125) / 3.0).sqrt());
    }
}

/// 3×3 grey image with values v = x + 3y against a reference of 1: blocks of 2 leave partial blocks.
fn ramp() -> (Image, Image) {
    (
        Image::from_fn(3, 3, |x, y| Vec3::splat((x + 3 * y) as f32)),
        Image::from_fn(3, 3, |_, _| Vec3::ONE),
    )
}

#[test]
fn partial_blocks_weighted_by_their_pixel_count() {
    let (image, reference) = ramp();
    let m = region_metrics(&image, &reference, &Region::whole(3, 3), 2).unwrap();
    // Blocks: {0,1,3,4} mean 2 → diff 1 (4 px); {2,5} → 2.5 (2 px); {6,7} → 5.5 (2 px); {8} → 7 (1 px).
    assert_eq!(m.blocks, 4);
    assert_close!(m.block_rmse, ((4.0 * 1.0 + 2.0 * 6.25 + 2.0 * 30.25 + 49.0) / 9.0f64).sqrt());
    assert_close!(m.block_rmse, 14f64.sqrt());
    // Per-pixel: d = −1..7, Σd² = 1+0+1+4+9+16+25+36+49 = 141 per channel.
    assert_close!(m.rmse, (141.0f64 / 9.0).sqrt());
    assert_close!(m.mae, (1.0 + 0.0 + 1.0 + 2.0 + 3.0 + 4.0 + 5.0 + 6.0 + 7.0) / 9.0);
    // relMSE with R = 1: d² / 1.01.
    assert_close!(m.relmse, 141.0 / 9.0 / 1.01);
}

#[test]
fn nan_and_inf_pixels_are_excluded_and_counted() {
    let (mut image, mut reference) = ramp();
    image.set(1, 1, Vec3::new(4.0, f32::NAN, 4.0)); // v = 4
    image.set(0, 2, Vec3::new(6.0, f32::INFINITY, 6.0)); // v = 6
    image.set(2, 2, Vec3::new(f32::NAN, f32::NEG_INFINITY, 8.0)); // v = 8: NaN wins
    reference.set(2, 0, Vec3::new(1.0, 1.0, f32::NAN)); // v = 2
    let m = region_metrics(&image, &reference, &Region::whole(3, 3), 2).unwrap();
    assert_eq!(
        (m.pixels, m.valid_pixels, m.nan_count, m.inf_count, m.reference_non_finite),
        (9, 5, 2, 1, 1)
    );
    // Valid v: 0, 1, 3, 5, 7 → d = −1, 0, 2, 4, 6; Σd² = 57, Σ|d| = 13.
    assert_close!(m.rmse, (57.0f64 / 5.0).sqrt());
    assert_close!(m.mae, 13.0 / 5.0);
    assert_close!(m.mean_image[1], 16.0 / 5.0);
    assert_eq!(m.mean_reference, [1.0; 3]);
    // Blocks: {0,1,3} → 4/3 − 1 = 1/3 (3 px); {5} → 4 (1 px); {7} → 6 (1 px); {} skipped.
    assert_eq!(m.blocks, 3);
    assert_close!(m.block_rmse, ((3.0 / 9.0 + 16.0 + 36.0) / 5.0f64).sqrt());
    assert!(m.rmse.is_finite() && m.relmse.is_finite() && m.block_rmse.is_finite());
}

#[test]
fn all_invalid_gives_nan_metrics_not_a_panic() {
    let image = Image::from_fn(2, 1, |_, _| Vec3::splat(f32::NAN));
    let m = region_metrics(&image, &Image::new(2, 1), &Region::whole(2, 1), 4).unwrap();
    assert_eq!((m.valid_pixels, m.nan_count, m.blocks), (0, 2, 0));
    assert!(m.rmse.is_nan() && m.block_rmse.is_nan());
    let json = serde_json::to_string(&m).unwrap();
    assert!(json.contains("\"rmse\":null"), "{json}");
}

#[test]
fn regions_clip_at_the_border() {
    let (image, reference) = ramp();
    let corner = Region::parse("corner=2,2,10,10", 3, 3).unwrap();
    assert_eq!(
        (corner.name.as_str(), corner.x0, corner.y0, corner.x1, corner.y1),
        ("corner", 2, 2, 3, 3)
    );
    let origin = Region::parse("-5,-5,1,1", 3, 3).unwrap();
    assert_eq!(
        (origin.name.as_str(), origin.x0, origin.y0, origin.x1, origin.y1),
        ("-5,-5,1,1", 0, 0, 1, 1)
    );
    let c = compare(&image, &reference, &[corner, origin], 16).unwrap();
    assert_eq!(c.regions.len(), 2);
    // Corner pixel v = 8: d = 7. Origin pixel v = 0: d = −1, relMSE = 1/1.01.
    assert_close!(c.regions[0].metrics.rmse, 7.0);
    assert_close!(c.regions[0].metrics.block_rmse, 7.0);
    assert_eq!(c.regions[0].metrics.pixels, 1);
    assert_close!(c.regions[1].metrics.relmse, 1.0 / 1.01);
    assert_close!(c.whole.block_rmse, 3.0); // one partial 3×3 block of the 16-px grid: mean 4 − 1.
    assert!(matches!(Region::parse("far=5,5,9,9", 3, 3), Err(MetricsError::EmptyRegion { .. })));
    assert!(matches!(Region::parse("2,0,2,3", 3, 3), Err(MetricsError::EmptyRegion { .. })));
    // A region with edited fields beyond the image is clipped by compare too.
    let edited = Region {
        name: "wide".into(),
        rect: crate::film::Rect::new(1, 0, 99, 1),
    };
    let c = compare(&image, &reference, &[edited], 1).unwrap();
    assert_eq!((c.regions[0].region.x1, c.regions[0].metrics.pixels), (3, 2));
}

#[test]
fn region_parse_errors() {
    for bad in ["1,2,3", "a,b,c,d", "=1,2,3,4", "x=1,2,3,4,5", "1.5,0,2,2", "x%,0,1,1", "inf%,0,1,1"] {
        let err = Region::parse(bad, 10, 10).unwrap_err();
        assert!(matches!(err, MetricsError::ParseRegion { .. }), "{bad}: {err}");
        assert!(err.to_string().contains(bad), "{err}");
    }
}

#[test]
fn fractional_regions_round_outward() {
    // 256: 0.62·256 = 158.72 → 158; 0.80·256 = 204.8 → 205; 0.86·256 = 220.16 → 220; 0.94·256 = 240.64 → 241.
    let r = Region::cornell_caustic(256, 256).unwrap();
    assert_eq!((r.x0, r.y0, r.x1, r.y1), (158, 220, 205, 241));
    assert_eq!(Region::parse("caustic=62%,86%,80%,94%", 256, 256).unwrap(), r);
    // Products that are integers up to rounding stay on the integer (0.8·100 = 80.00000000000001).
    let r = Region::from_fractions("c", 100, 100, 0.62, 0.86, 0.80, 0.94).unwrap();
    assert_eq!((r.x0, r.y0, r.x1, r.y1), (62, 86, 80, 94));
    let r = Region::from_fractions("all", 7, 5, -0.5, 0.0, 1.5, 1.0).unwrap();
    assert_eq!((r.x0, r.y0, r.x1, r.y1), (0, 0, 7, 5));
    assert!(Region::from_fractions("nan", 7, 5, f64::NAN, 0.0, 1.0, 1.0).is_err());
    // A zero-width fractional window on a pixel boundary is empty; inside a pixel it covers that pixel.
    assert!(Region::from_fractions("thin", 10, 5, 0.5, 0.0, 0.5, 1.0).is_err());
    let r = Region::from_fractions("thin", 7, 5, 0.5, 0.0, 0.5, 1.0).unwrap();
    assert_eq!((r.x0, r.x1), (3, 4));
}

#[test]
fn size_mismatch_and_bad_block_are_errors() {
    let err = compare(&Image::new(2, 2), &Image::new(3, 2), &[], 16).unwrap_err();
    let msg = err.to_string();
    assert!(msg.contains("2×2") && msg.contains("3×2"), "{msg}");
    assert_eq!(
        compare(&Image::new(2, 2), &Image::new(2, 2), &[], 0).unwrap_err(),
        MetricsError::InvalidBlock
    );
    assert!(compare(&Image::new(0, 0), &Image::new(0, 0), &[], 4).is_err());
}

#[test]
fn identical_images_have_zero_error() {
    let (image, _) = ramp();
    let c = compare(&image, &image, &[Region::parse("1,1,3,3", 3, 3).unwrap()], 2).unwrap();
    for m in [&c.whole, &c.regions[0].metrics] {
        assert_eq!((m.rmse, m.relmse, m.mae, m.block_rmse), (0.0, 0.0, 0.0, 0.0));
        assert_eq!(m.mean_ratio, [1.0; 3]);
    }
}

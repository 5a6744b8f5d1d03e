//! Unit tests of the accumulation film.

use super::*;

#[test]
fn tiles_cover_crop_once_in_scan_order() {
    let film = Film::with_crop(10, 7, Rect::new(1, 2, 10, 7)).unwrap();
    let tiles = film.tiles(4);
    // 9 wide → 3 tiles per row (4, 4, 1); 5 high → 2 rows (4, 1).
    assert_eq!(tiles.len(), 6);
    assert_eq!(tiles[0], Rect::new(1, 2, 5, 6));
    assert_eq!(tiles[2], Rect::new(9, 2, 10, 6));
    assert_eq!(tiles[3], Rect::new(1, 6, 5, 7));
    let mut hits = vec![0u32; 70];
    for t in &tiles {
        for y in t.y0..t.y1 {
            for x in t.x0..t.x1 {
                hits[(y * 10 + x) as usize] += 1;
            }
        }
    }
    for y in 0..7 {
        for x in 0..10 {
            assert_eq!(
                hits[(y * 10 + x) as usize],
                u32::from(film.crop().contains(x, y)),
                "pixel ({x}, {y})"
            );
        }
    }
    // tile_size 0 is taken as 1.
    assert_eq!(film.tiles(0).len(), 45);
}

#[test]
fn invalid_crops_are_errors() {
    assert!(Film::new(0, 4).is_err());
    assert!(Film::with_crop(4, 4, Rect::new(2, 0, 2, 4)).is_err());
    assert!(Film::with_crop(4, 4, Rect::new(0, 0, 5, 4)).is_err());
}

/// Deterministic pseudo-random sample values (fixed-seed local generator, as the tests may use).
fn sample_value(x: u32, y: u32, s: u32) -> Vec3 {
    let mut sampler = crate::sampler::Sampler::for_key(7, u64::from(y * 1000 + x), u64::from(s));
    Vec3::new(sampler.next_1d(), sampler.next_1d() * 2.0, sampler.next_1d() * 0.5)
}

fn render_tiles(film: &Film, order: &[usize], spp: u32) -> Film {
    let tiles = film.tiles(3);
    let buffers: Vec<TileBuffer> = tiles
        .iter()
        .map(|&t| {
            let mut b = TileBuffer::new(t);
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    for s in 0..spp {
                        b.add(x, y, sample_value(x, y, s));
                    }
                }
            }
            b
        })
        .collect();
    let mut out = film.clone();
    for &i in order {
        out.merge_tile(&buffers[i]).unwrap();
    }
    out
}

#[test]
fn merge_is_independent_of_tile_order_and_equals_direct_adds() {
    let film = Film::new(8, 7).unwrap();
    let n = film.tiles(3).len();
    let forward: Vec<usize> = (0..n).collect();
    let backward: Vec<usize> = (0..n).rev().collect();
    let a = render_tiles(&film, &forward, 5);
    let b = render_tiles(&film, &backward, 5);
    let mut direct = film.clone();
    for y in 0..7 {
        for x in 0..8 {
            for s in 0..5 {
                direct.add(x, y, sample_value(x, y, s));
            }
        }
    }
    assert_eq!(a.image(), b.image());
    assert_eq!(a.image(), direct.image());
    assert_eq!(a.samples_per_pixel(), 5.0);
    assert_eq!(a.total_samples(), 8 * 7 * 5);
    for y in 0..7 {
        for x in 0..8 {
            assert_eq!(a.pixel(x, y), b.pixel(x, y));
        }
    }
}

#[test]
fn mean_and_variance_of_known_samples() {
    let mut film = Film::new(2, 1).unwrap();
    // Grey samples 1, 2, 3, 6 in pixel (0, 0): mean 3, luminance = value, variance = (4+1+0+9)/3 = 14/3.
    for v in [1.0, 2.0, 3.0, 6.0] {
        film.add(0, 0, Vec3::splat(v));
    }
    film.add(1, 0, Vec3::new(1.0, 0.0, 0.0));
    let img = film.image();
    assert_eq!(img.get(0, 0), Vec3::splat(3.0));
    assert_eq!(img.get(1, 0), Vec3::new(1.0, 0.0, 0.0));
    assert!((film.luminance_variance(0, 0).unwrap() - 14.0 / 3.0).abs() < 1e-9);
    assert_eq!(film.luminance_variance(1, 0), None);
    assert_eq!(film.samples_per_pixel(), 2.5);
}

#[test]
fn non_finite_samples_are_counted_not_accumulated() {
    let mut film = Film::new(1, 1).unwrap();
    film.add(0, 0, Vec3::splat(4.0));
    film.add(0, 0, Vec3::new(f32::NAN, 1.0, 1.0));
    film.add(0, 0, Vec3::new(1.0, f32::INFINITY, 1.0));
    film.add(0, 0, Vec3::new(f32::NAN, f32::NEG_INFINITY, 1.0));
    let mut buffer = TileBuffer::new(film.tiles(16)[0]);
    buffer.add(0, 0, Vec3::new(0.0, 0.0, f32::NEG_INFINITY));
    assert_eq!((buffer.nan_count(), buffer.inf_count()), (0, 1));
    film.merge_tile(&buffer).unwrap();
    assert_eq!(film.nan_count(), 2);
    assert_eq!(film.inf_count(), 2);
    // The five samples count; only the finite one is summed: mean = 4/5.
    assert_eq!(film.total_samples(), 5);
    assert_eq!(film.image().get(0, 0), Vec3::splat(0.8));
    assert!(film.image().pixels().iter().all(|p| p.is_finite()));
}

#[test]
fn crop_film_image_and_add_film() {
    let mut a = Film::with_crop(6, 6, Rect::new(2, 3, 5, 5)).unwrap();
    a.add(2, 3, Vec3::ONE);
    a.add(4, 4, Vec3::splat(2.0));
    let mut b = a.clone();
    b.add(2, 3, Vec3::splat(3.0));
    a.add_film(&b).unwrap();
    let img = a.image();
    assert_eq!((img.width(), img.height()), (3, 2));
    // Pixel (2,3): samples 1, 1, 3 → 5/3. Pixel (4,4): 2, 2 → 2.
    assert!((img.get(0, 0).x - 5.0 / 3.0).abs() < 1e-6);
    assert_eq!(img.get(2, 1), Vec3::splat(2.0));
    assert_eq!(img.get(1, 0), Vec3::ZERO);
    assert!(a.pixel(0, 0).is_none());
    let other = Film::new(6, 6).unwrap();
    assert!(matches!(a.add_film(&other), Err(FilmError::Mismatch { .. })));
    let outside = TileBuffer::new(Rect::new(0, 0, 2, 2));
    assert!(matches!(a.merge_tile(&outside), Err(FilmError::TileOutsideCrop { .. })));
}

#[test]
fn tile_buffer_reset_reuses_for_another_tile() {
    let film = Film::new(4, 4).unwrap();
    let tiles = film.tiles(2);
    let mut buffer = TileBuffer::new(tiles[0]);
    buffer.add(1, 1, Vec3::splat(f32::NAN));
    buffer.reset(tiles[3]);
    assert_eq!(buffer.tile(), Rect::new(2, 2, 4, 4));
    assert_eq!(buffer.nan_count(), 0);
    buffer.add(3, 3, Vec3::ONE);
    let mut film = film;
    film.merge_tile(&buffer).unwrap();
    assert_eq!(film.image().get(3, 3), Vec3::ONE);
    assert_eq!(film.total_samples(), 1);
}

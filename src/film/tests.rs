//! Unit tests of the accumulation film.

use super::*;
use crate::math::Vec2;

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

/// One sample splats `w = f(cₓ − pₓ)·f(c_y − p_y)` into every pixel whose centre `c` is within the radius
/// (and nothing elsewhere); each reached pixel's value is the sample's; the weight sums are exact.
#[test]
fn a_splat_reaches_the_pixels_within_the_radius_with_the_filters_weights() {
    for filter in [PixelFilter::default(), PixelFilter::Tent { radius: 1.5 }, PixelFilter::Lanczos { lobes: 3 }, PixelFilter::CatmullRom] {
        let mut film = Film::with_filter(12, 10, Rect::new(0, 0, 12, 10), filter).unwrap();
        let tile = Rect::new(4, 4, 8, 8);
        let mut b = film.tile_buffer(tile);
        let (x, y, o) = (5u32, 6u32, Vec2::new(0.3, 0.75));
        b.add_at(x, y, o, Vec3::new(2.0, 1.0, 0.5));
        film.merge_tile(&b).unwrap();
        let (r, t) = (filter.radius(), filter::FilterTable::new(&filter));
        for j in 0..10u32 {
            for i in 0..12u32 {
                // As the splat computes it: the pixel's offset, then its centre, then the sample's.
                let (dx, dy) = ((i as f32 - x as f32) + 0.5 - o.x, (j as f32 - y as f32) + 0.5 - o.y);
                let k = (j * 12 + i) as usize;
                let w = film.weights()[k].weight.to_f64();
                let expect = if dx.abs() < r && dy.abs() < r { f64::from(t.weight(dx) * t.weight(dy)) } else { 0.0 };
                assert_eq!(w, expect, "{filter}: pixel ({i}, {j})");
                if w != 0.0 {
                    let v = film.image().get(i, j);
                    assert!((v - Vec3::new(2.0, 1.0, 0.5)).abs().max_element() < 1e-6, "{filter}: pixel ({i}, {j}) = {v}");
                }
            }
        }
        // The sample counts in its own pixel only.
        assert_eq!(film.total_samples(), 1);
        assert_eq!(film.pixel(x, y).unwrap().count, 1);
    }
}

/// Under a wide filter tiles splat into their neighbours' pixels: the film is the same bits whatever the
/// merge order, each pixel is `Σ w·L / Σ w`, and pixels at the crop's edge only get what lies inside it.
#[test]
fn filtered_tiles_merge_in_any_order_into_the_weighted_mean() {
    let filter = PixelFilter::default();
    let t = filter::FilterTable::new(&filter);
    let crop = Rect::new(1, 1, 9, 8);
    let film = Film::with_filter(10, 9, crop, filter).unwrap();
    let tiles = film.tiles(3);
    let offset = |x: u32, y: u32, s: u32| {
        let mut r = crate::sampler::Sampler::for_key(11, u64::from(y * 100 + x), u64::from(s));
        r.next_2d()
    };
    let buffers: Vec<TileBuffer> = tiles
        .iter()
        .map(|&t| {
            let mut b = film.tile_buffer(t);
            for y in t.y0..t.y1 {
                for x in t.x0..t.x1 {
                    for s in 0..4 {
                        b.add_at(x, y, offset(x, y, s), sample_value(x, y, s));
                    }
                }
            }
            b
        })
        .collect();
    let (mut a, mut b) = (film.clone(), film.clone());
    for buf in &buffers {
        a.merge_tile(buf).unwrap();
    }
    for buf in buffers.iter().rev() {
        b.merge_tile(buf).unwrap();
    }
    assert_eq!(a.sums(), b.sums());
    assert_eq!(a.weights().iter().map(|w| w.weight).collect::<Vec<_>>(), b.weights().iter().map(|w| w.weight).collect::<Vec<_>>());
    assert_eq!(a.image(), b.image());
    assert_eq!(a.total_samples(), 8 * 7 * 4);
    // Pixel values against a direct f64 evaluation of Σ w·L / Σ w over every sample of the crop.
    for py in crop.y0..crop.y1 {
        for px in crop.x0..crop.x1 {
            let (mut num, mut den) = (Vec3::ZERO.as_dvec3(), 0.0f64);
            for y in crop.y0..crop.y1 {
                for x in crop.x0..crop.x1 {
                    for s in 0..4 {
                        let o = offset(x, y, s);
                        let w = t.weight((px as f32 - x as f32) + 0.5 - o.x) * t.weight((py as f32 - y as f32) + 0.5 - o.y);
                        num += (sample_value(x, y, s) * w).as_dvec3();
                        den += f64::from(w);
                    }
                }
            }
            let got = a.image().get(px - crop.x0, py - crop.y0).as_dvec3();
            assert!((got - num / den).abs().max_element() < 1e-5, "pixel ({px}, {py}): {got} vs {}", num / den);
        }
    }
    // The box film's tiles and other filters' films do not mix.
    let mut boxed = Film::with_crop(10, 9, crop).unwrap();
    assert!(matches!(boxed.merge_tile(&buffers[0]), Err(FilmError::FilterMismatch { .. })));
    assert!(matches!(boxed.add_film(&a), Err(FilmError::FilterMismatch { .. })));
}

/// A non-finite sample under a filter adds its weights (a zero-valued sample), its count, not its value.
#[test]
fn non_finite_samples_under_a_filter_weigh_as_zero() {
    let mut film = Film::with_filter(5, 5, Rect::new(0, 0, 5, 5), PixelFilter::Tent { radius: 1.0 }).unwrap();
    let mut b = film.tile_buffer(Rect::new(0, 0, 5, 5));
    b.add_at(2, 2, Vec2::splat(0.5), Vec3::splat(4.0));
    b.add_at(2, 2, Vec2::splat(0.5), Vec3::new(f32::NAN, 0.0, 0.0));
    assert_eq!((b.nan_count(), b.inf_count()), (1, 0));
    film.merge_tile(&b).unwrap();
    assert_eq!(film.image().get(2, 2), Vec3::splat(2.0));
    assert_eq!(film.pixel(2, 2).unwrap().count, 2);
    assert_eq!(film.nan_count(), 1);
    // Its variance counts it as a 0: samples 4 and 0 of equal weight, s²/n = 8/2.
    assert!((film.value_variance(2, 2).unwrap() - 4.0).abs() < 1e-9, "{:?}", film.value_variance(2, 2));
}

/// The statistics under a filter: the value's variance is the ratio estimator's, which is `s²/n` for
/// `w = 1`, and `n ·` it is the per-sample variance.
#[test]
fn value_variance_follows_the_weights() {
    for filter in [PixelFilter::Box, PixelFilter::Tent { radius: 1.0 }] {
        let mut film = Film::with_filter(3, 1, Rect::new(0, 0, 3, 1), filter).unwrap();
        let mut b = film.tile_buffer(Rect::new(0, 0, 3, 1));
        let samples = [(1.0f32, 0.5f32), (2.0, 0.25), (3.0, 0.75), (6.0, 0.5)];
        for (v, o) in samples {
            b.add_at(1, 0, Vec2::new(o, 0.5), Vec3::splat(v));
        }
        film.merge_tile(&b).unwrap();
        let vv = film.value_variance(1, 0).unwrap();
        let expect = if filter.is_box() {
            // s² = (4 + 1 + 0 + 9)/3 around the mean 3.
            14.0 / 3.0 / 4.0
        } else {
            // Weights on pixel 1 along x at offsets 0, ±0.25 from its centre (the y weight is 1 there).
            let t = filter::FilterTable::new(&filter);
            let w: Vec<f64> = samples.iter().map(|&(_, o)| f64::from(t.weight(0.5 - o))).collect();
            let sw: f64 = w.iter().sum();
            let sw2: f64 = w.iter().map(|w| w * w).sum();
            let v: f64 = samples.iter().zip(&w).map(|(&(y, _), w)| f64::from(y) * w).sum::<f64>() / sw;
            let n_eff = sw * sw / sw2;
            samples.iter().zip(&w).map(|(&(y, _), w)| w * w * (f64::from(y) - v).powi(2)).sum::<f64>() / (sw * sw) * n_eff / (n_eff - 1.0)
        };
        assert!((vv - expect).abs() < 1e-9, "{filter}: {vv} vs {expect}");
        assert!((film.luminance_variance(1, 0).unwrap() - 4.0 * vv).abs() < 1e-9, "{filter}");
    }
}

/// A tile buffer merged after every round of samples (`Film::merge_tile_since` with the copy merged
/// before) leaves the film with the RGB sums, weights and image of one merge of the final buffer, bit
/// for bit, with the box filter and a wide one, even where the buffer's f64 sums round (samples from 2⁻²⁰
/// to 2⁴⁰, so that summing them in rounds instead would change the last bits); the count and non-finite
/// counts add up.
#[test]
fn merging_a_buffer_after_every_round_equals_one_merge() {
    let value = |x: u32, y: u32, s: u32| {
        let v = sample_value(x, y, s);
        let scale = 2f32.powi((((x * 7 + y * 13 + s * 5) % 61) as i32) - 20);
        if s == 9 && x == 2 {
            Vec3::new(f32::NAN, 0.0, 0.0)
        } else {
            v * scale
        }
    };
    for filter in [PixelFilter::Box, PixelFilter::default()] {
        let crop = Rect::new(1, 1, 9, 8);
        let film = Film::with_filter(10, 9, crop, filter).unwrap();
        let (mut once, mut rounds, mut by_delta) = (film.clone(), film.clone(), film.clone());
        for tile in film.tiles(3) {
            let mut buf = film.tile_buffer(tile);
            let mut merged: Option<TileBuffer> = None;
            let mut delta = film.tile_buffer(tile);
            for (from, to) in [(0, 1), (1, 2), (2, 4), (4, 8), (8, 13)] {
                delta.reset(tile);
                for s in from..to {
                    for y in tile.y0..tile.y1 {
                        for x in tile.x0..tile.x1 {
                            let offset = Vec2::new(((x + s) % 4) as f32 * 0.25, ((y + 2 * s) % 4) as f32 * 0.25);
                            buf.add_at(x, y, offset, value(x, y, s));
                            delta.add_at(x, y, offset, value(x, y, s));
                        }
                    }
                }
                rounds.merge_tile_since(&buf, merged.as_ref()).unwrap();
                merged = Some(buf.clone());
                by_delta.merge_tile(&delta).unwrap();
            }
            once.merge_tile(&buf).unwrap();
        }
        let rgb = |f: &Film| f.sums().iter().map(|p| (p.rgb, p.count)).collect::<Vec<_>>();
        assert_eq!(rgb(&rounds), rgb(&once), "{filter:?}");
        assert_eq!(rounds.weights().iter().map(|w| w.weight).collect::<Vec<_>>(), once.weights().iter().map(|w| w.weight).collect::<Vec<_>>());
        assert_eq!(rounds.image(), once.image(), "{filter:?}");
        assert_eq!((rounds.nan_count(), rounds.total_samples()), (once.nan_count(), once.total_samples()));
        // The test can fail: rounds merged as separate buffers (f64 sums per round) do not give these bits.
        assert_ne!(rgb(&by_delta), rgb(&once), "{filter:?}: the samples never rounded in f64");
    }
}

/// AOV values ride with their samples: the RGB sums are the same bits as without AOVs, and each AOV
/// channel is the filter-weighted mean `Σ w·a / Σ w` of its samples, merged whole or round by round.
#[test]
fn aov_channels_are_weighted_like_the_image_and_leave_it_unchanged() {
    for filter in [PixelFilter::Box, PixelFilter::default(), PixelFilter::Tent { radius: 1.5 }] {
        let crop = Rect::new(0, 0, 6, 5);
        let plain = Film::with_filter(6, 5, crop, filter).unwrap();
        let mut plain = plain;
        let mut with = Film::with_filter(6, 5, crop, filter).unwrap().with_aov_channels(2);
        let mut rounds = Film::with_filter(6, 5, crop, filter).unwrap().with_aov_channels(2);
        let tile = Rect::new(1, 1, 5, 4);
        let (mut a, mut b) = (plain.tile_buffer(tile), with.tile_buffer(tile));
        let mut r = rounds.tile_buffer(tile);
        let mut before: Option<TileBuffer> = None;
        // A constant AOV (its mean is that constant wherever a sample reached) and one that varies.
        let mut n = 0;
        for y in tile.y0..tile.y1 {
            for x in tile.x0..tile.x1 {
                for s in 0..3 {
                    let offset = Vec2::new(0.1 + 0.3 * s as f32, 0.7 - 0.2 * s as f32);
                    let l = Vec3::new(0.3 + x as f32, 1.0 / (1.0 + y as f32), 0.1 * s as f32);
                    let aov = [4.5, (x * 10 + y) as f32];
                    a.add_at(x, y, offset, l);
                    b.add_at_aov(x, y, offset, l, &aov);
                    r.add_at_aov(x, y, offset, l, &aov);
                    n += 1;
                    if n % 7 == 0 {
                        rounds.merge_tile_since(&r, before.as_ref()).unwrap();
                        before = Some(r.clone());
                    }
                }
            }
        }
        rounds.merge_tile_since(&r, before.as_ref()).unwrap();
        plain.merge_tile(&a).unwrap();
        with.merge_tile(&b).unwrap();
        assert_eq!(plain.sums(), with.sums(), "{filter}: RGB sums");
        assert_eq!(plain.weights(), with.weights(), "{filter}: weights");
        assert_eq!(rounds.sums(), with.sums(), "{filter}: RGB sums merged by rounds");
        let planes = with.aov_planes();
        let image = with.image();
        for (i, (&c, &v)) in planes[0].iter().zip(&planes[1]).enumerate() {
            let (x, y) = (i as u32 % 6, i as u32 / 6);
            let weight = if filter.is_box() { with.sums()[i].count as f64 } else { with.weights()[i].weight.to_f64() };
            if weight == 0.0 {
                assert_eq!((c, v), (0.0, 0.0), "{filter}: pixel ({x}, {y}) has no sample");
                assert_eq!(image.get(x, y), Vec3::ZERO);
                continue;
            }
            assert!((c - 4.5).abs() < 1e-5, "{filter}: constant AOV at ({x}, {y}) = {c}");
            assert!((0.0..=50.0).contains(&v), "{filter}: a mean of the samples' values, {v}");
        }
        // With the box filter a pixel's AOV is the mean of its own samples.
        if filter.is_box() {
            assert_eq!(planes[1][6 + 2], 21.0);
        }
        for (p, q) in planes.iter().zip(rounds.aov_planes()) {
            for (u, v) in p.iter().zip(&q) {
                assert!((u - v).abs() <= 1e-5 * u.abs().max(1.0), "{filter}: rounds {v} against one merge {u}");
            }
        }
        // A buffer without the film's AOV channels is refused.
        assert!(matches!(with.merge_tile(&a), Err(FilmError::AovMismatch { film: 2, other: 0 })));
    }
}

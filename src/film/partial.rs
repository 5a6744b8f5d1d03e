//! Partial films: a [`Film`]'s sums at full precision in one OpenEXR file, so that films rendered by
//! separate processes can be added later without losing a bit (`caustica render --part`, `caustica merge`).
//!
//! The file is an ordinary OpenEXR image whose `R`, `G`, `B` (float32) are the film's per-pixel mean, so any
//! viewer shows it, with extra channels that hold the sums themselves:
//!
//! | channels | type | content |
//! |---|---|---|
//! | `sum.R.w0` … `sum.R.w9` (and `G`, `B`) | u32 | the exact RGB sum ([`ExactSum`]): 320 bits, least significant word first |
//! | `lumsq.lo`, `lumsq.hi` | u32 | the bits of the f64 Σ Y² (luminance squared) |
//! | `count.lo`, `count.hi` | u32 | the u64 sample count |
//! | `weight.w0` … `weight.w9` | u32 | a wide filter's exact Σ w ([`super::PixelWeight`]; not with the box filter) |
//! | `weightsq`, `wsqlum`, `wsqlumsq` (`.lo`, `.hi`) | u32 | the bits of its f64 Σ w², Σ w²·Y, Σ w²·Y² (idem) |
//!
//! The layer covers the crop window (data window at `(crop.x0, crop.y0)`); string attributes give the
//! film's size and crop (`caustica.size`, `caustica.crop`), its reconstruction filter (`caustica.filter`,
//! as [`PixelFilter`]'s `Display`; absent in files from before filters: box), its non-finite sample counts
//! (`caustica.nonfinite`), the format (`caustica.film = partial-film-1`), and whatever the writer adds
//! (`render::part` stores its part description as JSON). The file is written atomically, like every
//! image ([`super::io::write_atomic`]): a process killed while writing leaves no file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use exr::prelude::traits::*;
use exr::prelude::{AnyChannel, AnyChannels, AttributeValue, Encoding, FlatSamples, Layer, LayerAttributes, Text, WritableImage};

use super::exact::LIMBS;
use super::io::{write_atomic, ImageError};
use super::{ExactSum, Film, PixelFilter, PixelSum, PixelWeight, Rect};

/// The value of the `caustica.film` attribute of a partial film.
pub const FORMAT: &str = "partial-film-1";

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Errors from reading a partial film; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum PartialFilmError {
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error("{path}: not a caustica partial film ({reason})")]
    NotPartial { path: PathBuf, reason: String },
}

fn text(s: &str) -> Text {
    // exr's `Text` holds bytes; UTF-8 is stored as is (and read back as such).
    Text::from_bytes_unchecked(s.as_bytes().to_vec().into())
}

fn exr_error(path: &Path, source: exr::error::Error) -> ImageError {
    match source {
        exr::error::Error::Io(source) => ImageError::Io { path: path.to_owned(), source },
        source => ImageError::Exr { path: path.to_owned(), source },
    }
}

/// Writes `film` with its sums and `attributes` (names should not start with `caustica.`, which this
/// module uses) to `path`, atomically.
pub fn write_partial_film(path: impl AsRef<Path>, film: &Film, attributes: &BTreeMap<String, String>) -> Result<(), ImageError> {
    let path = path.as_ref();
    let crop = film.crop();
    let (w, h) = (crop.width() as usize, crop.height() as usize);
    let sums = film.sums();
    let image = film.image();
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::with_capacity(3 + 4 * 2 * LIMBS + 8);
    let words = |name: String, sums: Vec<ExactSum>| -> Vec<AnyChannel<FlatSamples>> {
        let words: Vec<[u32; 2 * LIMBS]> = sums.iter().map(ExactSum::to_words).collect();
        (0..2 * LIMBS).map(|k| AnyChannel::new(format!("{name}.w{k}").as_str(), FlatSamples::U32(words.iter().map(|ws| ws[k]).collect()))).collect()
    };
    for (c, name) in CHANNELS.iter().enumerate() {
        channels.push(AnyChannel::new(*name, FlatSamples::F32(image.pixels().iter().map(|p| p[c]).collect())));
        channels.extend(words(format!("sum.{name}"), sums.iter().map(|p| p.rgb[c]).collect()));
    }
    fn split<T>(items: &[T], name: &str, v: fn(&T) -> u64) -> [AnyChannel<FlatSamples>; 2] {
        [
            AnyChannel::new(format!("{name}.lo").as_str(), FlatSamples::U32(items.iter().map(|p| v(p) as u32).collect())),
            AnyChannel::new(format!("{name}.hi").as_str(), FlatSamples::U32(items.iter().map(|p| (v(p) >> 32) as u32).collect())),
        ]
    }
    channels.extend(split(sums, "lumsq", |p| p.lum_sq.to_bits()));
    channels.extend(split(sums, "count", |p| p.count));
    let weights = film.weights();
    if !weights.is_empty() {
        channels.extend(words("weight".into(), weights.iter().map(|w| w.weight).collect()));
        channels.extend(split(weights, "weightsq", |w| w.weight_sq.to_bits()));
        channels.extend(split(weights, "wsqlum", |w| w.wsq_lum.to_bits()));
        channels.extend(split(weights, "wsqlumsq", |w| w.wsq_lum_sq.to_bits()));
    }

    let mut attrs = LayerAttributes::named("caustica");
    attrs.layer_position = exr::math::Vec2(crop.x0 as i32, crop.y0 as i32);
    let mut put = |k: &str, v: &str| {
        attrs.other.insert(text(k), AttributeValue::Text(text(v)));
    };
    put("caustica.film", FORMAT);
    put("caustica.size", &format!("{} {}", film.width(), film.height()));
    put("caustica.crop", &format!("{} {} {} {}", crop.x0, crop.y0, crop.x1, crop.y1));
    put("caustica.filter", &film.filter().to_string());
    put("caustica.nonfinite", &format!("{} {}", film.nan_count(), film.inf_count()));
    for (k, v) in attributes {
        put(k, v);
    }
    let layer = Layer::new((w, h), attrs, Encoding::SMALL_LOSSLESS, AnyChannels::sort(channels.into()));
    let image = exr::prelude::Image::from_layer(layer);
    write_atomic(path, |writer| image.write().to_buffered(writer)).map_err(|e| exr_error(path, e))
}

/// Reads a file written by [`write_partial_film`]: the film (bit for bit) and the writer's attributes.
pub fn read_partial_film(path: impl AsRef<Path>) -> Result<(Film, BTreeMap<String, String>), PartialFilmError> {
    let path = path.as_ref();
    let not_partial = |reason: String| PartialFilmError::NotPartial { path: path.to_owned(), reason };
    std::fs::File::open(path).map_err(|source| ImageError::Io { path: path.to_owned(), source })?;
    super::io::check_exr_size(path, 0)?;
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(|e| exr_error(path, e))?;
    let layer = image.layer_data;
    let mut attributes = BTreeMap::new();
    for (k, v) in &layer.attributes.other {
        if let AttributeValue::Text(t) = v {
            attributes.insert(String::from_utf8_lossy(k.bytes()).into_owned(), String::from_utf8_lossy(t.bytes()).into_owned());
        }
    }
    match attributes.remove("caustica.film") {
        Some(f) if f == FORMAT => {}
        Some(f) => return Err(not_partial(format!("format {f:?}, this version reads {FORMAT:?}"))),
        None => return Err(not_partial("no caustica.film attribute: an image, not a part".into())),
    }
    let numbers = |key: &str, n: usize| -> Result<Vec<u64>, PartialFilmError> {
        let v = attributes.get(key).ok_or_else(|| not_partial(format!("no {key} attribute")))?;
        let xs: Vec<u64> = v.split_whitespace().map(str::parse).collect::<Result<_, _>>().map_err(|_| not_partial(format!("{key} = {v:?}")))?;
        if xs.len() != n || xs.iter().any(|&x| n != 2 && x > u64::from(u32::MAX)) {
            return Err(not_partial(format!("{key} = {v:?}")));
        }
        Ok(xs)
    };
    let size = numbers("caustica.size", 2)?;
    let c = numbers("caustica.crop", 4)?;
    let nonfinite = numbers("caustica.nonfinite", 2)?;
    let filter = match attributes.remove("caustica.filter") {
        Some(f) => f.parse::<PixelFilter>().map_err(|e| not_partial(format!("caustica.filter: {e}")))?,
        None => PixelFilter::Box,
    };
    for key in ["caustica.size", "caustica.crop", "caustica.nonfinite"] {
        attributes.remove(key);
    }
    if size.iter().any(|&x| x > u64::from(u32::MAX)) {
        return Err(not_partial(format!("film size {size:?}")));
    }
    let crop = Rect::new(c[0] as u32, c[1] as u32, c[2] as u32, c[3] as u32);
    let pixels = crop.area() as usize;
    if (layer.size.width(), layer.size.height()) != (crop.width() as usize, crop.height() as usize) {
        return Err(not_partial(format!("data of {}×{} pixels for a crop {crop:?}", layer.size.width(), layer.size.height())));
    }
    let channel = |name: &str| -> Result<&[u32], PartialFilmError> {
        let ch = layer.channel_data.list.iter().find(|ch| ch.name.bytes() == name.as_bytes()).ok_or_else(|| not_partial(format!("no channel {name}")))?;
        match &ch.sample_data {
            FlatSamples::U32(v) if v.len() == pixels => Ok(v.as_slice()),
            _ => Err(not_partial(format!("channel {name} is not {pixels} u32 samples"))),
        }
    };
    let exact = |name: &str| -> Result<Vec<ExactSum>, PartialFilmError> {
        let words: Vec<&[u32]> = (0..2 * LIMBS).map(|k| channel(&format!("{name}.w{k}"))).collect::<Result<_, _>>()?;
        Ok((0..pixels).map(|i| ExactSum::from_words(std::array::from_fn(|k| words[k][i]))).collect())
    };
    let mut sums = vec![PixelSum::default(); pixels];
    for (c, name) in CHANNELS.iter().enumerate() {
        for (p, s) in sums.iter_mut().zip(exact(&format!("sum.{name}"))?) {
            p.rgb[c] = s;
        }
    }
    let joined = |name: &str| -> Result<Vec<u64>, PartialFilmError> {
        let (lo, hi) = (channel(&format!("{name}.lo"))?, channel(&format!("{name}.hi"))?);
        Ok(lo.iter().zip(hi).map(|(&l, &h)| u64::from(l) | (u64::from(h) << 32)).collect())
    };
    for (p, (l, n)) in sums.iter_mut().zip(joined("lumsq")?.into_iter().zip(joined("count")?)) {
        p.lum_sq = f64::from_bits(l);
        p.count = n;
    }
    let mut weights = Vec::new();
    if !filter.is_box() {
        let (w, sq, lum, lum_sq) = (exact("weight")?, joined("weightsq")?, joined("wsqlum")?, joined("wsqlumsq")?);
        weights = (w.into_iter().zip(sq).zip(lum).zip(lum_sq))
            .map(|(((weight, sq), lum), lum_sq)| PixelWeight { weight, weight_sq: f64::from_bits(sq), wsq_lum: f64::from_bits(lum), wsq_lum_sq: f64::from_bits(lum_sq) })
            .collect();
    }
    let film = Film::from_sums(size[0] as u32, size[1] as u32, crop, filter, sums, weights, nonfinite[0], nonfinite[1])
        .map_err(|e| not_partial(e.to_string()))?
        .ok_or_else(|| not_partial("pixel count does not match the crop".into()))?;
    Ok((film, attributes))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    #[test]
    fn round_trip_is_bit_exact_with_crop_filter_and_attributes() {
        for filter in [PixelFilter::Box, PixelFilter::default(), PixelFilter::Lanczos { lobes: 2 }] {
            let crop = Rect::new(3, 2, 8, 6);
            let mut film = Film::with_filter(10, 7, crop, filter).unwrap();
            for (i, tile) in film.tiles(2).into_iter().enumerate() {
                let mut b = film.tile_buffer(tile);
                for y in tile.y0..tile.y1 {
                    for x in tile.x0..tile.x1 {
                        b.add_at(x, y, crate::math::Vec2::new(0.3, 0.9), Vec3::new(0.1 * i as f32, -1e-30, 3e30));
                        b.add(x, y, Vec3::new(1.0 / 3.0, 2.5, 1e-40));
                    }
                }
                film.merge_tile(&b).unwrap();
            }
            film.add(4, 3, Vec3::splat(f32::NAN));
            film.add(5, 3, Vec3::new(f32::INFINITY, 0.0, 0.0));
            let path = std::env::temp_dir().join(format!("caustica-partial-{}-{}.exr", std::process::id(), filter.name()));
            let attrs = BTreeMap::from([("part".to_string(), "{\"x\": \"≥ ü\"}".to_string())]);
            write_partial_film(&path, &film, &attrs).unwrap();
            let (back, back_attrs) = read_partial_film(&path).unwrap();
            assert_eq!(back.sums(), film.sums(), "{filter}");
            assert_eq!(back.weights(), film.weights(), "{filter}");
            assert_eq!(back.weights().is_empty(), filter.is_box());
            assert_eq!((back.width(), back.height(), back.crop(), back.filter()), (10, 7, crop, filter));
            assert_eq!((back.nan_count(), back.inf_count()), (1, 1));
            assert_eq!(back_attrs, attrs);
            // Its RGB is the film's image, so any EXR reader sees the part's image.
            assert_eq!(super::super::read_exr(&path).unwrap(), film.image());
            // A plain image is refused, naming the file.
            super::super::write_exr(&path, &film.image()).unwrap();
            let e = read_partial_film(&path).unwrap_err().to_string();
            assert!(e.contains(&path.display().to_string()) && e.contains("not a caustica partial film"), "{e}");
            let _ = std::fs::remove_file(&path);
        }
    }
}

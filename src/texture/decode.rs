//! Reading an image file into its samples as the file stores them (8- or 16-bit integers, half or single
//! floats), before any colour decoding: what Mitsuba 3.9.1's `Bitmap` constructor reads
//! (src/core/bitmap.cpp: `read_png`, `read_jpeg`, `read_exr`, `read_rgbe`, `read_pfm`, `read_bmp`: module
//! `bmp`). The format is
//! recognised by the file's first bytes, as `Bitmap::detect_file_format` does (not by its name).
//!
//! The header is read first and its size passed to a budget check before the pixels are allocated, so a
//! corrupt or hostile header is an error, not an allocation that aborts the process.

use std::fs::File;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use super::TextureError;

/// An image file format caustica reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FileFormat {
    Png,
    Jpeg,
    OpenExr,
    /// Radiance RGBE (`.hdr`).
    Rgbe,
    /// Portable float map (`PF` colour, `Pf` grey).
    Pfm,
    /// Windows bitmap (`BM`), uncompressed.
    Bmp,
}

impl FileFormat {
    /// The format's name in messages.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            FileFormat::Png => "PNG",
            FileFormat::Jpeg => "JPEG",
            FileFormat::OpenExr => "OpenEXR",
            FileFormat::Rgbe => "Radiance HDR",
            FileFormat::Pfm => "PFM",
            FileFormat::Bmp => "BMP",
        }
    }

    /// The format whose signature starts `start` (Mitsuba's `detect_file_format`), if one caustica reads.
    fn detect(start: &[u8]) -> Option<Self> {
        match start {
            [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n', ..] => Some(FileFormat::Png),
            [0xff, 0xd8, ..] => Some(FileFormat::Jpeg),
            [0x76, 0x2f, 0x31, 0x01, ..] => Some(FileFormat::OpenExr),
            [b'#', b'?', ..] => Some(FileFormat::Rgbe),
            [b'P', b'F' | b'f', ..] => Some(FileFormat::Pfm),
            [b'B', b'M', ..] => Some(FileFormat::Bmp),
            _ => None,
        }
    }
}

/// Samples as the file stores them.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Samples {
    U8(Vec<u8>),
    U16(Vec<u16>),
    /// Half floats (OpenEXR `HALF` channels), widened exactly to f32.
    Half(Vec<f32>),
    F32(Vec<f32>),
}

impl Samples {
    /// Bytes per sample in the file's precision (Mitsuba chooses the storage precision by it).
    pub(super) fn bytes_per_sample(&self) -> u64 {
        match self {
            Samples::U8(_) => 1,
            Samples::U16(_) | Samples::Half(_) => 2,
            Samples::F32(_) => 4,
        }
    }

    /// How many samples.
    pub(super) fn len(&self) -> usize {
        match self {
            Samples::U8(v) => v.len(),
            Samples::U16(v) => v.len(),
            Samples::Half(v) | Samples::F32(v) => v.len(),
        }
    }

    /// The precision's name in messages.
    pub(super) fn depth_name(&self) -> &'static str {
        match self {
            Samples::U8(_) => "8-bit",
            Samples::U16(_) => "16-bit",
            Samples::Half(_) => "half-float",
            Samples::F32(_) => "float",
        }
    }
}

/// An image as the file stores it: rows from the top (the first row of a PNG, JPEG, OpenEXR data window
/// or Radiance file; a PFM's last), `channels` samples per pixel.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Decoded {
    pub width: u32,
    pub height: u32,
    /// 1 (Y), 2 (Y, alpha), 3 (R, G, B) or 4 (R, G, B, alpha).
    pub channels: usize,
    pub samples: Samples,
    /// sRGB-encoded: Mitsuba flags 8- and 16-bit PNGs and JPEGs so (`m_srgb_gamma = true`), the float
    /// formats linear.
    pub srgb: bool,
    pub format: FileFormat,
}

/// What the header declares, for the memory check before the pixels are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Header {
    pub width: u64,
    pub height: u64,
    /// Bytes reading takes besides the texels kept: the decoder's pixel buffers.
    pub decoder_bytes: u64,
    /// Whether the image is grey (one stored channel) rather than colour (three).
    pub grey: bool,
}

/// Reads `path`; `budget` sees the header before any pixel buffer is allocated and may refuse it.
pub(super) fn read(path: &Path, budget: &mut dyn FnMut(&Header) -> Result<(), TextureError>) -> Result<Decoded, TextureError> {
    let io_err = |source| TextureError::Io { path: path.to_path_buf(), source };
    let mut file = File::open(path).map_err(io_err)?;
    if file.metadata().map_err(io_err)?.is_dir() {
        return Err(io_err(std::io::Error::other("a directory, not an image")));
    }
    let mut start = [0u8; 8];
    let n = read_up_to(&mut file, &mut start).map_err(io_err)?;
    let format = FileFormat::detect(&start[..n]).ok_or_else(|| TextureError::UnknownFormat { path: path.to_path_buf() })?;
    drop(file);
    let d = match format {
        FileFormat::Png | FileFormat::Jpeg => read_with_image(path, format, budget),
        FileFormat::Rgbe => read_rgbe(path, budget),
        FileFormat::OpenExr => read_exr(path, budget),
        FileFormat::Pfm => read_pfm(path, budget),
        FileFormat::Bmp => super::bmp::read_bmp(path, budget),
    }?;
    // What the texels are made from relies on this; a decoder that broke it is an error, not a panic.
    if d.samples.len() as u64 != u64::from(d.width) * u64::from(d.height) * d.channels as u64 {
        let message = format!("the decoder gave {} samples for {}×{} pixels of {} channels", d.samples.len(), d.width, d.height, d.channels);
        return Err(TextureError::Decode { path: path.to_path_buf(), format, message });
    }
    Ok(d)
}

/// Fills as much of `buf` as the file has.
fn read_up_to(r: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) => break,
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(n)
}

fn empty_check(path: &Path, width: u64, height: u64) -> Result<(), TextureError> {
    if width == 0 || height == 0 {
        return Err(TextureError::Empty { path: path.to_path_buf(), width, height });
    }
    Ok(())
}

/// PNG and JPEG through the `image` crate (its decoders: `png`, `zune-jpeg`).
fn read_with_image(path: &Path, format: FileFormat, budget: &mut dyn FnMut(&Header) -> Result<(), TextureError>) -> Result<Decoded, TextureError> {
    use image::{ColorType, DynamicImage, ImageDecoder};
    // The file opened: an error reading it is a broken image (a truncated one says "unexpected end of file").
    let decode_err = |e: image::ImageError| TextureError::Decode { path: path.to_path_buf(), format, message: e.to_string() };
    let file = File::open(path).map_err(|source| TextureError::Io { path: path.to_path_buf(), source })?;
    let image_format = if format == FileFormat::Png { image::ImageFormat::Png } else { image::ImageFormat::Jpeg };
    let mut reader = image::ImageReader::with_format(BufReader::new(file), image_format);
    // Our own budget bounds the allocation (below); the crate's default (512 MiB) would refuse large textures.
    reader.limits(image::Limits::no_limits());
    let decoder = reader.into_decoder().map_err(decode_err)?;
    let (w, h) = decoder.dimensions();
    let (width, height) = (u64::from(w), u64::from(h));
    empty_check(path, width, height)?;
    let color = decoder.color_type();
    let grey = matches!(color, ColorType::L8 | ColorType::La8 | ColorType::L16 | ColorType::La16);
    let decoder_bytes = width.saturating_mul(height).saturating_mul(u64::from(color.bytes_per_pixel()));
    budget(&Header { width, height, decoder_bytes, grey })?;
    let image = DynamicImage::from_decoder(decoder).map_err(decode_err)?;
    let (channels, samples) = match image {
        DynamicImage::ImageLuma8(b) => (1, Samples::U8(b.into_raw())),
        DynamicImage::ImageLumaA8(b) => (2, Samples::U8(b.into_raw())),
        DynamicImage::ImageRgb8(b) => (3, Samples::U8(b.into_raw())),
        DynamicImage::ImageRgba8(b) => (4, Samples::U8(b.into_raw())),
        DynamicImage::ImageLuma16(b) => (1, Samples::U16(b.into_raw())),
        DynamicImage::ImageLumaA16(b) => (2, Samples::U16(b.into_raw())),
        DynamicImage::ImageRgb16(b) => (3, Samples::U16(b.into_raw())),
        DynamicImage::ImageRgba16(b) => (4, Samples::U16(b.into_raw())),
        DynamicImage::ImageRgb32F(b) => (3, Samples::F32(b.into_raw())),
        DynamicImage::ImageRgba32F(b) => (4, Samples::F32(b.into_raw())),
        other => {
            let what = format!("its pixel type ({:?}) is not one of grey, grey+alpha, RGB, RGBA", other.color());
            return Err(TextureError::Unsupported { path: path.to_path_buf(), what });
        }
    };
    Ok(Decoded { width: w, height: h, channels, samples, srgb: true, format })
}

/// A Radiance RGBE file as Mitsuba's `read_rgbe` reads it (the `image` crate's reader wants the header to
/// start `#?RADIANCE`; Mitsuba, and the files it writes, have `#?RGBE`): a first line starting `#?`, lines
/// up to the resolution line `-Y <height> +X <width>` among which `FORMAT=32-bit_rle_rgbe` must be, then the
/// pixels, each scanline run-length encoded (`2 2 <width>`, then each of the four channels as runs) or, from
/// the first scanline that is not, flat; a pixel `(r, g, b, e)` is `(r, g, b)·2^(e−136)`, 0 when `e = 0`
/// (`rgbe_to_float`).
fn read_rgbe(path: &Path, budget: &mut dyn FnMut(&Header) -> Result<(), TextureError>) -> Result<Decoded, TextureError> {
    const MAX_LINE: usize = 4096;
    const MAX_HEADER_LINES: usize = 1024;
    let bad = |message: String| TextureError::Decode { path: path.to_path_buf(), format: FileFormat::Rgbe, message };
    let io_err = |source: std::io::Error| match source.kind() {
        std::io::ErrorKind::UnexpectedEof => bad("the file ends before its pixels do".into()),
        _ => TextureError::Io { path: path.to_path_buf(), source },
    };
    let mut r = BufReader::new(File::open(path).map_err(io_err)?);
    let mut line = Vec::new();
    let mut read_line = |r: &mut BufReader<File>| -> Result<String, TextureError> {
        line.clear();
        (&mut *r).take(MAX_LINE as u64).read_until(b'\n', &mut line).map_err(io_err)?;
        if line.is_empty() {
            return Err(bad("the header ends before its resolution line (\"-Y <height> +X <width>\")".into()));
        }
        Ok(String::from_utf8_lossy(&line).trim_end().to_string())
    };
    if !read_line(&mut r)?.starts_with("#?") {
        return Err(bad("the first line does not start with \"#?\"".into()));
    }
    let mut format_ok = false;
    let mut size = None;
    for _ in 0..MAX_HEADER_LINES {
        let l = read_line(&mut r)?;
        if l.starts_with("FORMAT=32-bit_rle_rgbe") {
            format_ok = true;
        } else if l.starts_with("FORMAT=32-bit_rle_xyze") {
            let what = "its pixels are XYZE (CIE XYZ), which Mitsuba converts and caustica does not".to_string();
            return Err(TextureError::Unsupported { path: path.to_path_buf(), what });
        } else if let [y, h, x, w] = l.split_whitespace().collect::<Vec<_>>()[..] {
            if y == "-Y" && x == "+X" {
                let parse = |t: &str| t.parse::<u32>().map_err(|_| bad(format!("the resolution line {l:?} does not hold two whole numbers")));
                size = Some((parse(w)?, parse(h)?));
                break;
            }
        }
    }
    let Some((w, h)) = size else { return Err(bad("no resolution line (\"-Y <height> +X <width>\") in the header".into())) };
    if !format_ok {
        return Err(bad("the header has no FORMAT=32-bit_rle_rgbe line".into()));
    }
    let (width, height) = (u64::from(w), u64::from(h));
    empty_check(path, width, height)?;
    let pixels = width * height;
    budget(&Header { width, height, decoder_bytes: pixels.saturating_mul(12), grey: false })?;
    let pixels = pixels as usize;
    let mut out = Vec::with_capacity(pixels * 3);
    let push = |out: &mut Vec<f32>, p: [u8; 4]| {
        let f = if p[3] == 0 { 0.0 } else { libm::ldexpf(1.0, i32::from(p[3]) - (128 + 8)) };
        out.extend([f32::from(p[0]) * f, f32::from(p[1]) * f, f32::from(p[2]) * f]);
    };
    let flat = |r: &mut BufReader<File>, out: &mut Vec<f32>, count: usize| -> Result<(), TextureError> {
        let mut p = [0u8; 4];
        for _ in 0..count {
            r.read_exact(&mut p).map_err(io_err)?;
            push(out, p);
        }
        Ok(())
    };
    if !(8..=0x7fff).contains(&w) {
        // Run-length encoding is not allowed at these widths.
        flat(&mut r, &mut out, pixels)?;
    } else {
        let wu = w as usize;
        let mut buffer = vec![0u8; 4 * wu];
        for y in 0..h as usize {
            let mut p = [0u8; 4];
            r.read_exact(&mut p).map_err(io_err)?;
            if p[0] != 2 || p[1] != 2 || p[2] & 0x80 != 0 {
                // Not run-length encoded: this pixel and the rest of the image, flat.
                push(&mut out, p);
                flat(&mut r, &mut out, pixels - y * wu - 1)?;
                break;
            }
            if (usize::from(p[2]) << 8 | usize::from(p[3])) != wu {
                return Err(bad(format!("scanline {y} declares a width other than {w}")));
            }
            let mut at = 0;
            for channel in 0..4 {
                let end = (channel + 1) * wu;
                while at < end {
                    let mut run = [0u8; 2];
                    r.read_exact(&mut run).map_err(io_err)?;
                    let (count, repeat) = if run[0] > 128 { (usize::from(run[0] - 128), true) } else { (usize::from(run[0]), false) };
                    if count == 0 || count > end - at {
                        return Err(bad(format!("scanline {y} has a run of {count} bytes where {} remain", end - at)));
                    }
                    buffer[at] = run[1];
                    if repeat {
                        buffer[at..at + count].fill(run[1]);
                    } else if count > 1 {
                        r.read_exact(&mut buffer[at + 1..at + count]).map_err(io_err)?;
                    }
                    at += count;
                }
            }
            for x in 0..wu {
                push(&mut out, [buffer[x], buffer[wu + x], buffer[2 * wu + x], buffer[3 * wu + x]]);
            }
        }
    }
    Ok(Decoded { width: w, height: h, channels: 3, samples: Samples::F32(out), srgb: false, format: FileFormat::Rgbe })
}

/// What a channel of an OpenEXR file is, by the part of its name after the last `.`, case-insensitive
/// (Mitsuba's `read_exr`: `channel_class`).
fn exr_channel_class(name: &str) -> String {
    name.rsplit('.').next().unwrap_or(name).to_ascii_lowercase()
}

/// Rec. ITU-R BT.709 primaries and D65 white (OpenEXR's default chromaticities, those of linear sRGB).
const REC709: [[f32; 2]; 4] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06], [0.3127, 0.3290]];

/// The first part of an OpenEXR file, as Mitsuba's `read_exr` reads it into a texture: its channels must be
/// R, G, B (and A) or Y (and A), each sampled at every pixel; all are read at the precision of the
/// alphabetically first channel (OpenEXR converts the others to it, as Mitsuba asks), half or float.
fn read_exr(path: &Path, budget: &mut dyn FnMut(&Header) -> Result<(), TextureError>) -> Result<Decoded, TextureError> {
    use exr::prelude::*;
    let exr_err = |e: exr::error::Error| match e {
        exr::error::Error::Io(source) => TextureError::Io { path: path.to_path_buf(), source },
        e => TextureError::Decode { path: path.to_path_buf(), format: FileFormat::OpenExr, message: e.to_string() },
    };
    let unsupported = |what: String| TextureError::Unsupported { path: path.to_path_buf(), what };
    // The header, and the chunk table checked before the decoder allocates a chunk's declared size.
    let meta = crate::film::exr_scan::scan_exr(path).map_err(|e| match e {
        crate::film::ImageError::Io { source, .. } => TextureError::Io { path: path.to_path_buf(), source },
        e => TextureError::Decode { path: path.to_path_buf(), format: FileFormat::OpenExr, message: e.reason() },
    })?;
    let header = meta.headers.first().ok_or_else(|| unsupported("the file has no image part".into()))?;
    if header.deep {
        return Err(unsupported("deep OpenEXR data is not an image a texture can read".into()));
    }
    let list = &header.channels.list;
    let classes: Vec<String> = list.iter().map(|c| exr_channel_class(&c.name.to_string())).collect();
    let has = |c: &str| classes.iter().any(|k| k == c);
    let order: Vec<&str> = if has("r") && has("g") && has("b") && (list.len() == 3 || (list.len() == 4 && has("a"))) {
        vec!["r", "g", "b", "a"]
    } else if has("y") && !has("ry") && !has("by") && (list.len() == 1 || (list.len() == 2 && has("a"))) {
        vec!["y", "a"]
    } else {
        let names: Vec<String> = list.iter().map(|c| c.name.to_string()).collect();
        return Err(unsupported(format!(
            "its channels ({}) are not R, G, B[, A] or Y[, A] (Mitsuba's bitmap texture reads no others; caustica also not its XYZ and luminance-chroma images)",
            names.join(", ")
        )));
    };
    if list.iter().any(|c| c.sampling != Vec2(1, 1)) {
        return Err(unsupported("its channels are subsampled, which caustica does not read".into()));
    }
    let first_type = list[0].sample_type;
    if first_type == SampleType::U32 {
        return Err(unsupported("its samples are 32-bit integers, not colours (half or float channels are read)".into()));
    }
    if let Some(c) = header.shared_attributes.chromaticities {
        let file = [[c.red.0, c.red.1], [c.green.0, c.green.1], [c.blue.0, c.blue.1], [c.white.0, c.white.1]];
        let d2: f32 = file.iter().zip(REC709).map(|(a, b)| (a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sum();
        // Mitsuba's test (`chroma_eq`): the squared distances of the four points sum below 1e-6.
        if d2 >= 1e-6 {
            return Err(unsupported(format!(
                "its chromaticities (red {:?}, green {:?}, blue {:?}, white {:?}) are not those of linear sRGB (Rec. 709), which Mitsuba converts and caustica does not",
                file[0], file[1], file[2], file[3]
            )));
        }
    }
    let (width, height) = (header.layer_size.width() as u64, header.layer_size.height() as u64);
    empty_check(path, width, height)?;
    // The decoder's samples, then our interleaved f32 copy of the channels kept.
    let bytes_per_pixel: u64 = list.iter().map(|c| c.sample_type.bytes_per_sample() as u64 + 4).sum();
    budget(&Header {
        width,
        height,
        decoder_bytes: width.saturating_mul(height).saturating_mul(bytes_per_pixel),
        grey: order[0] == "y",
    })?;
    let (w, h) = (u32::try_from(width), u32::try_from(height));
    let (Ok(w), Ok(h)) = (w, h) else {
        return Err(unsupported(format!("its size {width}×{height} exceeds 2³² − 1 pixels per side")));
    };
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .map_err(exr_err)?;
    let channels = &image.layer_data.channel_data.list;
    let pixels = (width * height) as usize;
    let mut picked: Vec<&FlatSamples> = Vec::new();
    for class in &order {
        if let Some(c) = channels.iter().find(|c| exr_channel_class(&c.name.to_string()) == *class) {
            picked.push(&c.sample_data);
        }
    }
    let n = picked.len();
    let half = first_type == SampleType::F16;
    let mut out = Vec::with_capacity(pixels * n);
    for i in 0..pixels {
        for s in &picked {
            let v = match s {
                FlatSamples::F16(v) => v[i].to_f32(),
                FlatSamples::F32(v) if half => half::f16::from_f32(v[i]).to_f32(),
                FlatSamples::F32(v) => v[i],
                FlatSamples::U32(v) => v[i] as f32,
            };
            out.push(v);
        }
    }
    let samples = if half { Samples::Half(out) } else { Samples::F32(out) };
    Ok(Decoded { width: w, height: h, channels: n, samples, srgb: false, format: FileFormat::OpenExr })
}

/// A portable float map (Mitsuba's `read_pfm`): `PF` (RGB) or `Pf` (grey), width, height and a scale whose
/// sign gives the byte order (negative: little-endian) and whose magnitude multiplies every sample, each
/// token followed by one whitespace byte; then the rows, the bottom row first (Mitsuba flips them, so the
/// first row read here is the image's top).
fn read_pfm(path: &Path, budget: &mut dyn FnMut(&Header) -> Result<(), TextureError>) -> Result<Decoded, TextureError> {
    let bad = |message: String| TextureError::Decode { path: path.to_path_buf(), format: FileFormat::Pfm, message };
    let io_err = |source| TextureError::Io { path: path.to_path_buf(), source };
    let file = File::open(path).map_err(io_err)?;
    let mut r = BufReader::new(file);
    let mut tokens = Vec::with_capacity(4);
    for _ in 0..4 {
        tokens.push(pfm_token(&mut r).map_err(io_err)?.ok_or_else(|| bad("the header ends early".into()))?);
    }
    let channels = match tokens[0].as_str() {
        "PF" => 3,
        "Pf" => 1,
        t => return Err(bad(format!("the header starts {t:?}, not \"PF\" or \"Pf\""))),
    };
    let number = |i: usize, what: &str| -> Result<u64, TextureError> {
        tokens[i].parse::<u64>().map_err(|_| bad(format!("the {what} {:?} is not a whole number", tokens[i])))
    };
    let (width, height) = (number(1, "width")?, number(2, "height")?);
    let scale: f32 = tokens[3].parse().map_err(|_| bad(format!("the scale {:?} is not a number", tokens[3])))?;
    if !scale.is_finite() || scale == 0.0 {
        return Err(bad(format!("the scale {scale} is not a finite nonzero number")));
    }
    empty_check(path, width, height)?;
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(bad(format!("its size {width}×{height} exceeds 2³² − 1 pixels per side")));
    };
    let samples = width.saturating_mul(height).saturating_mul(channels);
    // The file's bytes, then their f32 values.
    budget(&Header { width, height, decoder_bytes: samples.saturating_mul(8), grey: channels == 1 })?;
    let mut bytes = vec![0u8; (samples * 4) as usize];
    r.read_exact(&mut bytes).map_err(|e| match e.kind() {
        std::io::ErrorKind::UnexpectedEof => bad(format!("the file ends before its {width}×{height}×{channels} samples")),
        _ => io_err(e),
    })?;
    let little = scale < 0.0;
    let magnitude = scale.abs();
    let row = (width * channels) as usize;
    let mut out = Vec::with_capacity(samples as usize);
    // Rows bottom to top in the file: the last row read is the top of the image.
    for y in (0..height as usize).rev() {
        for chunk in bytes[y * row * 4..(y + 1) * row * 4].chunks_exact(4) {
            let b = [chunk[0], chunk[1], chunk[2], chunk[3]];
            let v = if little { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
            out.push(if magnitude != 1.0 { v * magnitude } else { v });
        }
    }
    Ok(Decoded { width: w, height: h, channels: channels as usize, samples: Samples::F32(out), srgb: false, format: FileFormat::Pfm })
}

/// The next whitespace-separated token of a PFM header (at most 64 bytes) and the one whitespace byte
/// after it; `None` at the end of the file.
fn pfm_token(r: &mut impl BufRead) -> std::io::Result<Option<String>> {
    const MAX: usize = 64;
    let mut token = Vec::new();
    let mut byte = [0u8; 1];
    loop {
        if r.read(&mut byte)? == 0 {
            return Ok(if token.is_empty() { None } else { Some(String::from_utf8_lossy(&token).into_owned()) });
        }
        if byte[0].is_ascii_whitespace() {
            if token.is_empty() {
                continue;
            }
            return Ok(Some(String::from_utf8_lossy(&token).into_owned()));
        }
        if token.len() == MAX {
            return Ok(Some(String::from_utf8_lossy(&token).into_owned()));
        }
        token.push(byte[0]);
    }
}

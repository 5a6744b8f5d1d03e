//! Reading and writing [`Image`]s: OpenEXR (float32 RGB, ZIP compression, lossless) and 8-bit sRGB PNG.
//!
//! Every write to a file is atomic ([`write_atomic`]): the bytes go to `<dir>/.<name>.tmp-<pid>` in the
//! target's directory, are flushed and fsynced, then renamed over the target. On any error the temporary
//! file is removed, so a reader never sees a half-written image and no debris is left behind.
//!
//! Only a regular file (or a new path) is replaced so ([`OutputTarget`]): a symbolic link to a file has its
//! target replaced (the link stays); a FIFO, character device or socket (`/dev/stdout`, `/dev/null`, a pipe
//! under `/proc/self/fd`) is written through, once, whole; `-` is standard output; anything else (a block
//! device, a directory, a link to nothing) is refused.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use exr::prelude::{Encoding, SpecificChannels, WritableImage};

use super::Image;
use crate::math::Vec3;

/// Errors from reading or writing an image (or any file written through [`write_atomic`]); each names the file.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: io::Error },
    #[error("{path}: not a readable RGB OpenEXR image: {source}")]
    Exr { path: PathBuf, source: exr::error::Error },
    #[error("{path}: PNG encoding failed: {source}")]
    Png { path: PathBuf, source: ::image::ImageError },
    #[error("{path}: image size {width}×{height} is not supported (empty, or over u32 pixels per side)")]
    Size { path: PathBuf, width: usize, height: usize },
    #[error("{path}: its header declares {width}×{height} pixels of {channels} channels ({}), more than {} (the largest film, 2³¹ pixels, or the memory this process may use): a corrupt header, or an image too large to read here", crate::sys::gb(*bytes), crate::sys::gb(*limit))]
    TooLarge { path: PathBuf, width: usize, height: usize, channels: usize, bytes: u64, limit: u64 },
    #[error("{path}: cannot serialise as JSON: {source}")]
    Json { path: PathBuf, source: serde_json::Error },
    /// A corrupt OpenEXR chunk table ([`super::exr_scan`]).
    #[error("{path}: a corrupt OpenEXR file: {message}")]
    Chunks { path: PathBuf, message: String },
}

impl ImageError {
    /// What is wrong, without the file's name (for readers whose own error names it).
    #[must_use]
    pub fn reason(&self) -> String {
        match self {
            ImageError::Io { source, .. } => source.to_string(),
            ImageError::Exr { source, .. } => source.to_string(),
            ImageError::Png { source, .. } => source.to_string(),
            ImageError::Json { source, .. } => source.to_string(),
            ImageError::Chunks { message, .. } => message.clone(),
            e => e.to_string(),
        }
    }
}

/// The tone curve applied (after exposure) before the sRGB encoding of [`write_png`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Tonemap {
    /// No curve: values are clamped to [0, 1].
    #[default]
    Clamp,
    /// Per-channel Reinhard, `x / (1 + x)` (Reinhard et al. 2002, eq. 3, applied to each channel).
    Reinhard,
    /// Narkowicz's fit of the ACES filmic curve, `x(2.51x + 0.03) / (x(2.43x + 0.59) + 0.14)`
    /// ("ACES Filmic Tone Mapping Curve", 2015), applied per channel to the exposed value as is.
    Aces,
}

impl Tonemap {
    /// Every curve.
    pub const ALL: [Tonemap; 3] = [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces];

    /// The name used on the command line and in JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Tonemap::Clamp => "clamp",
            Tonemap::Reinhard => "reinhard",
            Tonemap::Aces => "aces",
        }
    }

    /// Maps a linear, exposed channel value to [0, 1]. NaN and negative values map to 0.
    #[must_use]
    pub fn apply(self, x: f32) -> f32 {
        if x.is_nan() || x <= 0.0 {
            return 0.0;
        }
        let y = match self {
            Tonemap::Clamp => x,
            Tonemap::Reinhard => {
                if x.is_infinite() {
                    1.0
                } else {
                    x / (1.0 + x)
                }
            }
            Tonemap::Aces => {
                if x.is_infinite() {
                    1.0
                } else {
                    let x = f64::from(x);
                    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)) as f32
                }
            }
        };
        y.clamp(0.0, 1.0)
    }
}

/// The sRGB opto-electronic transfer function (IEC 61966-2-1): linear [0, 1] → encoded [0, 1].
#[must_use]
pub fn srgb_oetf(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

impl std::str::FromStr for Tonemap {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Tonemap::ALL.into_iter().find(|t| t.name() == s).ok_or_else(|| format!("unknown tone mapping {s:?} (clamp, reinhard or aces)"))
    }
}

/// One pixel as displayed: `rgb · 2^exposure_stops`, tone-mapped, sRGB-encoded, rounded to 8 bits.
#[must_use]
pub fn display_rgb8(rgb: Vec3, exposure_stops: f32, tonemap: Tonemap) -> [u8; 3] {
    let scale = exposure_stops.exp2();
    let enc = |c: f32| -> u8 { (srgb_oetf(tonemap.apply(c * scale)) * 255.0).round().clamp(0.0, 255.0) as u8 };
    [enc(rgb.x), enc(rgb.y), enc(rgb.z)]
}

/// The temporary path used while writing `path`: `<dir>/.<name>.tmp-<pid>`.
#[must_use]
pub fn temp_path_for(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp-{}", std::process::id()));
    Some(path.with_file_name(tmp_name))
}

/// A writer that can also seek (the EXR encoder needs both): a buffered file, or a buffer in memory.
pub trait WriteSeek: Write + io::Seek {}
impl<T: Write + io::Seek> WriteSeek for T {}

/// What writing to an output path does (module docs).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OutputTarget {
    /// A regular file or a new path, replaced atomically: the path itself, or a symbolic link's final target.
    File(PathBuf),
    /// A FIFO, character device or socket (or a link to one, or a link under `/dev` or `/proc`: the
    /// process's own streams), written through.
    Stream,
    /// `-`: standard output.
    Stdout,
}

impl OutputTarget {
    /// What writing to `path` does, or why it cannot be written.
    pub fn of(path: &Path) -> io::Result<Self> {
        if path == Path::new("-") {
            return Ok(Self::Stdout);
        }
        let refuse = |what: &str| io::Error::new(io::ErrorKind::InvalidInput, format!("is {what}: neither a file nor a stream to write to"));
        let link = match std::fs::symlink_metadata(path) {
            Ok(m) => m,
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Self::File(path.to_path_buf())),
            Err(e) => return Err(e),
        };
        let meta = if link.file_type().is_symlink() {
            std::fs::metadata(path).map_err(|e| match e.kind() {
                io::ErrorKind::NotFound => refuse("a symbolic link to nothing"),
                _ => e,
            })?
        } else {
            link.clone()
        };
        let own_stream = link.file_type().is_symlink() && (path.starts_with("/dev") || path.starts_with("/proc"));
        if meta.is_file() && !own_stream {
            return Ok(Self::File(if link.file_type().is_symlink() { std::fs::canonicalize(path)? } else { path.to_path_buf() }));
        }
        if meta.is_file() || is_stream(&meta) {
            return Ok(Self::Stream);
        }
        Err(refuse(if meta.is_dir() { "a directory" } else { "a block device or another special file" }))
    }
}

/// A FIFO, character device or socket.
#[cfg(unix)]
fn is_stream(meta: &std::fs::Metadata) -> bool {
    use std::os::unix::fs::FileTypeExt;
    let t = meta.file_type();
    t.is_fifo() || t.is_char_device() || t.is_socket()
}

#[cfg(not(unix))]
fn is_stream(_meta: &std::fs::Metadata) -> bool {
    false
}

/// Writes a file atomically: `write` fills a buffered temporary file next to `path`
/// (see [`temp_path_for`]), which is flushed, fsynced and renamed over `path`. On any error the temporary
/// file is removed and the error returned; `path` is then untouched. After the rename the directory is
/// fsynced too (best effort: some file systems refuse to fsync a directory, which is not an error here).
/// A stream or `-` ([`OutputTarget`]) gets the bytes `write` makes in memory, written through once.
///
/// Two writers of the same path in one process must not run at the same time (they share the temp name).
pub fn write_atomic<E: From<io::Error>>(path: &Path, write: impl FnOnce(&mut dyn WriteSeek) -> Result<(), E>) -> Result<(), E> {
    let path = match OutputTarget::of(path)? {
        OutputTarget::File(target) => target,
        stream => {
            let mut buffer = io::Cursor::new(Vec::new());
            write(&mut buffer)?;
            let bytes = buffer.into_inner();
            if stream == OutputTarget::Stdout {
                let mut out = io::stdout().lock();
                out.write_all(&bytes)?;
                out.flush()?;
            } else {
                // Appending: a stream has no start to write at, and a file behind `/dev/stdout` (a shell's `>>`)
                // keeps what it holds.
                std::fs::OpenOptions::new().append(true).open(path)?.write_all(&bytes)?;
            }
            return Ok(());
        }
    };
    let path = path.as_path();
    let tmp = temp_path_for(path).ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "path has no file name"))?;
    let file = File::create(&tmp)?;
    let result = (|| {
        let mut writer = BufWriter::new(file);
        write(&mut writer)?;
        let file = writer.into_inner().map_err(io::IntoInnerError::into_error)?;
        file.sync_all()?;
        drop(file);
        std::fs::rename(&tmp, path)?;
        Ok(())
    })();
    match result {
        Ok(()) => {
            let dir = match path.parent() {
                Some(p) if !p.as_os_str().is_empty() => p,
                _ => Path::new("."),
            };
            if let Ok(d) = File::open(dir) {
                let _ = d.sync_all();
            }
            Ok(())
        }
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

/// Reads the first layer of an OpenEXR file that has `R`, `G` and `B` channels (an `A` channel is
/// ignored); f16, f32 and u32 samples are converted to f32. Pixel `(0, 0)` is the top-left pixel of the
/// layer's data window (the display window is not applied). Reads files of Mitsuba 3 and of [`write_exr`].
pub fn read_exr(path: impl AsRef<Path>) -> Result<Image, ImageError> {
    let path = path.as_ref();
    // exr's own error for a missing file does not say which file; open it first for a clear message.
    File::open(path).map_err(|source| ImageError::Io {
        path: path.to_owned(),
        source,
    })?;
    check_exr_size(path, 3)?;
    let exr_image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |size, _channels| (size.width(), vec![Vec3::ZERO; size.width() * size.height()]),
        |pixels: &mut (usize, Vec<Vec3>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let (w, data) = pixels;
            data[pos.y() * *w + pos.x()] = Vec3::new(r, g, b);
        },
    )
    .map_err(|source| match source {
        exr::error::Error::Io(source) => ImageError::Io {
            path: path.to_owned(),
            source,
        },
        source => ImageError::Exr {
            path: path.to_owned(),
            source,
        },
    })?;
    let size = exr_image.layer_data.size;
    let (width, height) = (size.width(), size.height());
    let size_err = || ImageError::Size {
        path: path.to_owned(),
        width,
        height,
    };
    let w = u32::try_from(width).map_err(|_| size_err())?;
    let h = u32::try_from(height).map_err(|_| size_err())?;
    let (_, pixels) = exr_image.layer_data.channel_data.pixels;
    Image::from_pixels(w, h, pixels).ok_or_else(size_err)
}

/// Scans the header and chunk table of the EXR at `path` ([`super::exr_scan::scan_exr`]) and refuses a layer whose pixels, at `channels` f32 values each
/// (what the reader will allocate), exceed the largest film ([`crate::camera::MAX_FILM_PIXELS`]) or the
/// memory this process may use ([`crate::sys::memory_bound`]: under `ulimit -v 2000000` the fuzzer found a
/// header asking for 9.7 GB that passed the physical-memory check and aborted the allocation): a corrupt header must be an error, not an allocation that aborts the process (found by
/// `tests/suite/fuzz.rs`: a mutated header asked for 34 GB).
pub fn check_exr_size(path: &Path, channels: usize) -> Result<(), ImageError> {
    let meta = super::exr_scan::scan_exr(path)?;
    // The memory this process may use: physical, its cgroup's limit, or its address-space limit.
    let memory = crate::sys::memory_bound().map_or(u64::MAX, |(bytes, _)| bytes);
    for header in &meta.headers {
        let (width, height) = (header.layer_size.width(), header.layer_size.height());
        let pixels = (width as u64).saturating_mul(height as u64);
        let channels = channels.max(header.channels.list.len());
        let bytes = pixels.saturating_mul(4 * channels as u64);
        // Reading takes about three times the samples: the decoder's samples, its block buffers (a block
        // of a wide image is large), and the image built from them.
        let limit = (memory / 3).min(crate::camera::MAX_FILM_PIXELS.saturating_mul(4 * channels as u64));
        if bytes > limit {
            return Err(ImageError::TooLarge { path: path.to_owned(), width, height, channels, bytes, limit });
        }
    }
    Ok(())
}

/// Writes `image` as a float32 RGB OpenEXR file (ZIP compression in 16-line blocks: lossless), atomically.
pub fn write_exr(path: impl AsRef<Path>, image: &Image) -> Result<(), ImageError> {
    let path = path.as_ref();
    let (w, h) = (image.width() as usize, image.height() as usize);
    if w == 0 || h == 0 {
        return Err(ImageError::Size {
            path: path.to_owned(),
            width: w,
            height: h,
        });
    }
    let pixels = image.pixels();
    let channels = SpecificChannels::rgb(|pos: exr::math::Vec2<usize>| {
        let p = pixels[pos.y() * w + pos.x()];
        (p.x, p.y, p.z)
    });
    let exr_image = exr::prelude::Image::from_encoded_channels((w, h), Encoding::SMALL_LOSSLESS, channels);
    write_atomic(path, |writer| exr_image.write().to_buffered(writer)).map_err(|source| match source {
        exr::error::Error::Io(source) => ImageError::Io {
            path: path.to_owned(),
            source,
        },
        source => ImageError::Exr {
            path: path.to_owned(),
            source,
        },
    })
}

/// [`write_exr`] with extra float32 channels `extra` (name, one value per pixel in the image's order): the
/// AOVs (`scene::aov`), as Mitsuba writes them, beside `R`, `G`, `B` in one layer. The `R`, `G`, `B`
/// values are those `write_exr` writes.
pub fn write_exr_channels(path: impl AsRef<Path>, image: &Image, extra: &[(String, Vec<f32>)]) -> Result<(), ImageError> {
    use exr::prelude::{AnyChannel, AnyChannels, FlatSamples, Layer, LayerAttributes};
    let path = path.as_ref();
    if extra.is_empty() {
        return write_exr(path, image);
    }
    let (w, h) = (image.width() as usize, image.height() as usize);
    if w == 0 || h == 0 || extra.iter().any(|(_, v)| v.len() != w * h) {
        return Err(ImageError::Size { path: path.to_owned(), width: w, height: h });
    }
    let pixels = image.pixels();
    let mut channels: Vec<AnyChannel<FlatSamples>> = ["R", "G", "B"]
        .iter()
        .enumerate()
        .map(|(c, name)| AnyChannel::new(*name, FlatSamples::F32(pixels.iter().map(|p| p[c]).collect())))
        .collect();
    channels.extend(extra.iter().map(|(name, values)| AnyChannel::new(name.as_str(), FlatSamples::F32(values.clone()))));
    let layer = Layer::new((w, h), LayerAttributes::default(), Encoding::SMALL_LOSSLESS, AnyChannels::sort(channels.into()));
    let exr_image = exr::prelude::Image::from_layer(layer);
    write_atomic(path, |writer| exr_image.write().to_buffered(writer)).map_err(|source| match source {
        exr::error::Error::Io(source) => ImageError::Io { path: path.to_owned(), source },
        source => ImageError::Exr { path: path.to_owned(), source },
    })
}

/// Writes `image` as an 8-bit sRGB PNG, atomically: each channel is multiplied by `2^exposure_stops`,
/// mapped by `tonemap`, encoded with the sRGB OETF and rounded (no dithering). NaN channels become 0.
pub fn write_png(path: impl AsRef<Path>, image: &Image, exposure_stops: f32, tonemap: Tonemap) -> Result<(), ImageError> {
    use ::image::ImageEncoder;
    let path = path.as_ref();
    let (w, h) = (image.width(), image.height());
    if w == 0 || h == 0 {
        return Err(ImageError::Size {
            path: path.to_owned(),
            width: w as usize,
            height: h as usize,
        });
    }
    let bytes: Vec<u8> = image
        .pixels()
        .iter()
        .flat_map(|&p| display_rgb8(p, exposure_stops, tonemap))
        .collect();
    write_atomic(path, |writer| {
        ::image::codecs::png::PngEncoder::new(writer).write_image(&bytes, w, h, ::image::ExtendedColorType::Rgb8)
    })
    .map_err(|source| match source {
        ::image::ImageError::IoError(source) => ImageError::Io {
            path: path.to_owned(),
            source,
        },
        source => ImageError::Png {
            path: path.to_owned(),
            source,
        },
    })
}

/// Writes `bytes` to `path` atomically (used for JSON reports and the like).
pub fn write_bytes_atomic(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), ImageError> {
    let path = path.as_ref();
    write_atomic(path, |w: &mut dyn WriteSeek| w.write_all(bytes)).map_err(|source| ImageError::Io {
        path: path.to_owned(),
        source,
    })
}

/// Writes `value` as pretty-printed JSON to `path` atomically.
pub fn write_json_atomic<T: serde::Serialize>(path: impl AsRef<Path>, value: &T) -> Result<(), ImageError> {
    let path = path.as_ref();
    let text = serde_json::to_string_pretty(value).map_err(|source| ImageError::Json { path: path.to_owned(), source })?;
    write_bytes_atomic(path, text.as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_of_half_is_188() {
        // 1.055 · 0.5^(1/2.4) − 0.055 = 0.735357; · 255 = 187.52 → 188.
        assert!((srgb_oetf(0.5) - 0.735_357).abs() < 1e-5);
        assert_eq!(display_rgb8(Vec3::splat(0.5), 0.0, Tonemap::Clamp), [188; 3]);
        // One stop down from 1.0 is 0.5 again.
        assert_eq!(display_rgb8(Vec3::splat(1.0), -1.0, Tonemap::Clamp), [188; 3]);
        // Linear segment: 0.002 · 12.92 · 255 = 6.59 → 7.
        assert_eq!(display_rgb8(Vec3::splat(0.002), 0.0, Tonemap::Clamp), [7; 3]);
    }

    #[test]
    fn tonemaps_on_known_values() {
        assert_eq!(Tonemap::Clamp.apply(3.0), 1.0);
        assert_eq!(Tonemap::Reinhard.apply(1.0), 0.5);
        assert_eq!(Tonemap::Reinhard.apply(f32::INFINITY), 1.0);
        // ACES fit at x = 1: 2.54 / 3.16.
        assert!((Tonemap::Aces.apply(1.0) - 2.54 / 3.16).abs() < 1e-6);
        assert_eq!(Tonemap::Aces.apply(1e9), 1.0);
        for t in [Tonemap::Clamp, Tonemap::Reinhard, Tonemap::Aces] {
            assert_eq!(t.apply(f32::NAN), 0.0);
            assert_eq!(t.apply(-1.0), 0.0);
        }
        assert_eq!(
            display_rgb8(Vec3::new(f32::NAN, f32::INFINITY, -2.0), 0.0, Tonemap::Clamp),
            [0, 255, 0]
        );
    }

    #[test]
    fn output_targets_replace_only_files() {
        let dir = std::env::temp_dir().join(format!("caustica-output-targets-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let file = dir.join("a.json");
        assert_eq!(OutputTarget::of(&file).unwrap(), OutputTarget::File(file.clone()));
        std::fs::write(&file, "x").unwrap();
        assert_eq!(OutputTarget::of(&file).unwrap(), OutputTarget::File(file.clone()));
        assert_eq!(OutputTarget::of(Path::new("-")).unwrap(), OutputTarget::Stdout);
        assert!(OutputTarget::of(&dir).is_err());
        #[cfg(unix)]
        {
            let link = dir.join("link.json");
            std::os::unix::fs::symlink(&file, &link).unwrap();
            // The link's target is replaced, the link stays.
            assert_eq!(OutputTarget::of(&link).unwrap(), OutputTarget::File(std::fs::canonicalize(&file).unwrap()));
            write_bytes_atomic(&link, b"new").unwrap();
            assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
            assert_eq!(std::fs::read(&file).unwrap(), b"new");
            let dangling = dir.join("dangling.json");
            std::os::unix::fs::symlink(dir.join("nothing"), &dangling).unwrap();
            assert!(OutputTarget::of(&dangling).is_err());
            assert_eq!(OutputTarget::of(Path::new("/dev/null")).unwrap(), OutputTarget::Stream);
            write_bytes_atomic("/dev/null", b"gone").unwrap();
            // Written through: still the device.
            assert!(std::os::unix::fs::FileTypeExt::is_char_device(&std::fs::metadata("/dev/null").unwrap().file_type()));
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temp_path_is_hidden_sibling() {
        let t = temp_path_for(Path::new("/a/b/out.exr")).unwrap();
        assert_eq!(t, PathBuf::from(format!("/a/b/.out.exr.tmp-{}", std::process::id())));
        assert!(temp_path_for(Path::new("/")).is_none());
    }
}

//! The pre-scan of every OpenEXR file caustica reads (images, `--reference`, partial films, environment maps,
//! textures), before the `exr` crate decodes it: the header and the chunk offset tables are read and each
//! chunk's declared size is checked against the file and against its block of pixels, so that a corrupt file
//! is an error naming it, never an allocation that aborts the process.
//!
//! Why: the crate allocates a chunk's bytes from the chunk's size field before reading them, bounded only by
//! a whole block of the header's width (`CompressedScanLineBlock::read`, `read_i32_sized_vec_le`); the fuzzer
//! (`tests/suite/fuzz.rs`) found 476-byte files whose one chunk declares 1.85 GB, which abort under a 2 GB
//! address-space limit.
//!
//! The layout read here (OpenEXR's "OpenEXR File Layout" document): the magic number and the version word
//! (bit 12: multi-part); the headers, each a list of attributes (`name\0type\0` i32 size, value) ended by a
//! `\0`, a multi-part file's list of headers ended by one more `\0`; then per header (part) its offset table,
//! one u64 file offset per chunk; then the chunks. A chunk starts, in a multi-part file, with its i32 part
//! number, then: scan lines `i32 y, i32 size`; tiles `4 × i32` (tile and level), `i32 size`; deep scan lines
//! `i32 y` and deep tiles `4 × i32`, then `u64` packed offset-table size, `u64` packed sample size, `u64`
//! unpacked sample size.
//!
//! The rules: every offset lies in the file after the tables, and the chunk's fields fit in the file; a
//! size is not negative and not larger than the bytes that follow it in the file; a flat (not deep) chunk
//! holds at most its block's pixels uncompressed (OpenEXR and the `exr` crate store a block uncompressed when
//! compression does not make it smaller: `ScanLineOutputFile`, `Compression::compress_image_section_to_le`),
//! i.e. `bytes per pixel × block width × block height`; and the flat chunks of a part hold together at most
//! the bytes of all its pixels (every level of a mip- or rip-mapped file).

use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::Path;

use exr::meta::attribute::LevelMode;
use exr::meta::header::Header;
use exr::meta::{BlockDescription, MetaData};

use super::io::ImageError;

/// A file being scanned: its reader, position and length.
struct Cursor {
    read: BufReader<File>,
    at: u64,
    len: u64,
}

impl Cursor {
    fn bytes<const N: usize>(&mut self) -> std::io::Result<[u8; N]> {
        let mut b = [0u8; N];
        self.read.read_exact(&mut b)?;
        self.at += N as u64;
        Ok(b)
    }

    fn i32(&mut self) -> std::io::Result<i32> {
        self.bytes().map(i32::from_le_bytes)
    }

    fn u64(&mut self) -> std::io::Result<u64> {
        self.bytes().map(u64::from_le_bytes)
    }

    fn seek(&mut self, to: u64) -> std::io::Result<()> {
        // (`seek_relative` keeps the buffer for the short hops between neighbouring chunks.)
        self.read.seek_relative(to as i64 - self.at as i64)?;
        self.at = to;
        Ok(())
    }

    fn remaining(&self) -> u64 {
        self.len.saturating_sub(self.at)
    }
}

/// The header and chunk table of the OpenEXR file at `path` ([the module's rules](self)): its metadata as the
/// `exr` crate reads it, or an error naming the file.
pub fn scan_exr(path: &Path) -> Result<MetaData, ImageError> {
    let io_err = |source| ImageError::Io { path: path.to_owned(), source };
    let file = File::open(path).map_err(io_err)?;
    let len = file.metadata().map_err(io_err)?.len();
    let mut header = Counting { inner: BufReader::new(&file), bytes: 0 };
    let meta = MetaData::read_from_buffered(&mut header, false).map_err(|source| match source {
        exr::error::Error::Io(source) => io_err(source),
        source => ImageError::Exr { path: path.to_owned(), source },
    })?;
    let tables = header.bytes;
    let mut file = file;
    file.rewind().map_err(io_err)?;
    let mut c = Cursor { read: BufReader::new(file), at: 0, len };
    c.seek(tables).map_err(io_err)?;
    let bad = |message: String| ImageError::Chunks { path: path.to_owned(), message };
    // A file that ends inside its tables: an io error would only say "failed to fill whole buffer".
    let truncated = |what: &str| bad(format!("the file ({len} bytes) ends inside {what}"));
    let chunk_count: u64 = meta.headers.iter().map(|h| h.chunk_count as u64).sum();
    let table_bytes = chunk_count.saturating_mul(8);
    if table_bytes > c.remaining() {
        return Err(bad(format!(
            "its header asks for {chunk_count} chunks, whose offset table alone ({table_bytes} bytes) is longer than the {} bytes left in the file",
            c.remaining()
        )));
    }
    let chunks_start = tables + table_bytes;
    let mut offsets = Vec::with_capacity(chunk_count as usize);
    for _ in 0..chunk_count {
        offsets.push(c.u64().map_err(|_| truncated("its offset table"))?);
    }
    let mut totals = vec![0u64; meta.headers.len()];
    // Chunks in file order (the order the crate reads them, and the cheapest to seek).
    let mut order: Vec<usize> = (0..offsets.len()).collect();
    order.sort_by_key(|&k| offsets[k]);
    for k in order {
        let offset = offsets[k];
        if offset < chunks_start || offset >= len {
            return Err(bad(format!("chunk {k}'s offset {offset} is outside the chunks (bytes {chunks_start} to {len})")));
        }
        c.seek(offset).map_err(io_err)?;
        let chunk = chunk_fields(&mut c, &meta).map_err(|_| truncated(&format!("chunk {k}'s fields (at byte {offset})")))?;
        let Some(Chunk { part, size, block }) = chunk else {
            return Err(bad(format!("chunk {k} (at byte {offset}) names a part the file does not have, or declares a negative size")));
        };
        if size > c.remaining() {
            return Err(bad(format!(
                "chunk {k} (at byte {offset}) declares {size} bytes of pixel data, but only {} bytes of the file follow it",
                c.remaining()
            )));
        }
        if let Some(block) = block {
            if size > block {
                return Err(bad(format!(
                    "chunk {k} (at byte {offset}) declares {size} bytes, more than its block of pixels holds uncompressed ({block} bytes)"
                )));
            }
            totals[part] = totals[part].saturating_add(size);
        }
    }
    for (part, header) in meta.headers.iter().enumerate().filter(|(_, h)| !h.deep) {
        let all = all_pixel_bytes(header);
        if totals[part] > all {
            return Err(bad(format!(
                "the chunks of part {part} declare {} bytes together, more than all its pixels hold uncompressed ({all} bytes)",
                totals[part]
            )));
        }
    }
    Ok(meta)
}

/// What a chunk declares: its part, the bytes that follow its fields, and for a flat chunk the most its
/// block can hold.
struct Chunk {
    part: usize,
    size: u64,
    block: Option<u64>,
}

/// Reads the fields of the chunk at the cursor; `None` for a part the file does not have or a negative size.
fn chunk_fields(c: &mut Cursor, meta: &MetaData) -> std::io::Result<Option<Chunk>> {
    let part = if meta.requirements.is_multilayer() { c.i32()? } else { 0 };
    let Some((part, header)) = usize::try_from(part).ok().and_then(|p| Some((p, meta.headers.get(p)?))) else {
        return Ok(None);
    };
    // The scan line's y, or the tile's x, y and levels.
    c.bytes::<4>()?;
    if matches!(header.blocks, BlockDescription::Tiles(_)) {
        c.bytes::<12>()?;
    }
    if header.deep {
        // Packed offset table and packed samples follow; the unpacked size is not read from the file.
        let (table, samples) = (c.u64()?, c.u64()?);
        c.u64()?;
        return Ok(Some(Chunk { part, size: table.saturating_add(samples), block: None }));
    }
    let Ok(size) = u64::try_from(c.i32()?) else { return Ok(None) };
    Ok(Some(Chunk { part, size, block: Some(max_block_bytes(header)) }))
}

/// A reader that counts the bytes read through it: the `exr` crate's header reader takes exactly the
/// header's bytes (its one-byte look-ahead is consumed by the header's closing `\0`), so the count is where
/// the offset tables start, as the crate's own reader finds them.
struct Counting<R> {
    inner: R,
    bytes: u64,
}

impl<R: Read> Read for Counting<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }
}

/// The bytes of a flat header's largest block of pixels, uncompressed: every channel at every pixel (an upper
/// bound for subsampled channels).
fn max_block_bytes(header: &Header) -> u64 {
    let (w, h) = (header.layer_size.width() as u64, header.layer_size.height() as u64);
    let (bw, bh) = match header.blocks {
        BlockDescription::ScanLines => (w, (header.compression.scan_lines_per_block() as u64).min(h)),
        BlockDescription::Tiles(t) => ((t.tile_size.width() as u64).min(w), (t.tile_size.height() as u64).min(h)),
    };
    (header.channels.bytes_per_pixel as u64).saturating_mul(bw).saturating_mul(bh)
}

/// The bytes of all pixels of a flat header, uncompressed, over all its levels.
fn all_pixel_bytes(header: &Header) -> u64 {
    let size = header.layer_size;
    let pixels: u64 = match header.blocks {
        BlockDescription::Tiles(t) if t.level_mode == LevelMode::MipMap => {
            exr::meta::mip_map_levels(t.rounding_mode, size).map(|(_, s)| (s.width() as u64).saturating_mul(s.height() as u64)).sum()
        }
        BlockDescription::Tiles(t) if t.level_mode == LevelMode::RipMap => {
            exr::meta::rip_map_levels(t.rounding_mode, size).map(|(_, s)| (s.width() as u64).saturating_mul(s.height() as u64)).sum()
        }
        _ => (size.width() as u64).saturating_mul(size.height() as u64),
    };
    (header.channels.bytes_per_pixel as u64).saturating_mul(pixels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use exr::math::RoundingMode;
    use exr::prelude::*;

    fn dir() -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("caustica-exr-scan-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    /// Values that do not compress (so some blocks are stored raw, at exactly their block's bound).
    fn noise(n: usize, seed: u32) -> Vec<f32> {
        let mut x = seed.wrapping_mul(2_654_435_761) | 1;
        (0..n)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                (x >> 8) as f32 / (1 << 24) as f32
            })
            .collect()
    }

    /// A two-part file of mip-mapped tiled layers (RLE and PIZ), as the `exr` crate's example writes.
    fn write_two_part_mip_maps(path: &Path) {
        let size = Vec2(37, 21);
        let levels: Vec<_> = exr::meta::mip_map_levels(RoundingMode::Up, size).collect();
        let channel = |name: &str, seed: u32| {
            let data = levels.iter().map(|(i, s)| FlatSamples::F32(noise(s.area(), seed + *i as u32))).collect();
            AnyChannel::new(name, Levels::Mip { level_data: data, rounding_mode: RoundingMode::Up })
        };
        let channels = AnyChannels::sort(vec![channel("R", 1), channel("G", 20), channel("B", 40)].into());
        let tiles = |compression| Encoding { compression, blocks: Blocks::Tiles(Vec2(8, 8)), line_order: LineOrder::Increasing };
        let first = Layer::new(size, LayerAttributes::named("first"), tiles(Compression::RLE), channels);
        let mut second = first.clone();
        second.attributes.layer_name = Some("second".into());
        second.encoding = tiles(Compression::PIZ);
        Image::empty(ImageAttributes::new(IntegerBounds::from_dimensions(size))).with_layer(first).with_layer(second).write().to_file(path).unwrap();
    }

    /// A single-part scan-line file (ZIP, 16 lines per block) of `w × h` noisy RGB pixels; its chunk offsets.
    fn write_scan_lines(path: &Path, w: usize, h: usize) -> Vec<u64> {
        let channels = AnyChannels::sort(
            vec![
                AnyChannel::new("R", FlatSamples::F32(noise(w * h, 1))),
                AnyChannel::new("G", FlatSamples::F32(noise(w * h, 2))),
                AnyChannel::new("B", FlatSamples::F32(noise(w * h, 3))),
            ]
            .into(),
        );
        Image::from_layer(Layer::new((w, h), LayerAttributes::default(), Encoding::SMALL_LOSSLESS, channels)).write().to_file(path).unwrap();
        let bytes = std::fs::read(path).unwrap();
        let mut header = Counting { inner: bytes.as_slice(), bytes: 0 };
        let meta = MetaData::read_from_buffered(&mut header, false).unwrap();
        let at = header.bytes as usize;
        (0..meta.headers[0].chunk_count).map(|k| u64::from_le_bytes(bytes[at + 8 * k..at + 8 * k + 8].try_into().unwrap())).collect()
    }

    fn message(path: &Path) -> String {
        let e = scan_exr(path).unwrap_err();
        let m = e.to_string();
        assert!(m.contains(&*path.to_string_lossy()), "{m}");
        m
    }

    #[test]
    fn valid_files_pass_and_their_metadata_is_the_crates() {
        let d = dir();
        let p = d.join("mip.exr");
        write_two_part_mip_maps(&p);
        let meta = scan_exr(&p).unwrap();
        assert_eq!(meta.headers.len(), 2);
        assert!(meta.requirements.is_multilayer());
        let p = d.join("lines.exr");
        let offsets = write_scan_lines(&p, 13, 40);
        assert_eq!(offsets.len(), 3);
        assert_eq!(scan_exr(&p).unwrap().headers[0].layer_size, Vec2(13, 40));
        // (every image caustica writes goes through the scan when read back: film::io's and partial's tests)
    }

    #[test]
    fn a_chunk_size_beyond_the_file_or_its_block_is_refused_before_decoding() {
        let d = dir();
        let p = d.join("size.exr");
        let offsets = write_scan_lines(&p, 13, 40);
        let good = std::fs::read(&p).unwrap();
        let with_sizes = |sizes: &[(usize, i32)], pad: usize| {
            let mut b = good.clone();
            for &(k, size) in sizes {
                let at = offsets[k] as usize + 4;
                b[at..at + 4].copy_from_slice(&size.to_le_bytes());
            }
            b.extend(std::iter::repeat(0).take(pad));
            std::fs::write(&p, b).unwrap();
        };
        let with_size = |k: usize, size: i32, pad: usize| with_sizes(&[(k, size)], pad);
        // The fuzzer's case: a size of gigabytes in a small file.
        with_size(0, 1_852_397_409, 0);
        let m = message(&p);
        assert!(m.contains("chunk 0") && m.contains("declares 1852397409 bytes") && m.contains("follow it"), "{m}");
        with_size(1, -5, 0);
        assert!(message(&p).contains("negative size"));
        // Within the file (padded) but more than 16 lines of 13 RGB f32 pixels: 16 · 13 · 12 = 2496 bytes.
        with_size(2, 2497, 4000);
        let m = message(&p);
        assert!(m.contains("chunk 2") && m.contains("declares 2497 bytes") && m.contains("(2496 bytes)"), "{m}");
        // Each at most a block, but the last block has 8 lines: together (7488 bytes) more than 40 lines hold.
        with_sizes(&[(0, 2496), (1, 2496), (2, 2496)], 8000);
        let m = message(&p);
        assert!(m.contains("part 0 declare") && m.contains("(6240 bytes)"), "{m}");
    }

    #[test]
    fn offsets_outside_the_chunks_and_truncated_files_are_refused() {
        let d = dir();
        let p = d.join("offsets.exr");
        let offsets = write_scan_lines(&p, 13, 40);
        let good = std::fs::read(&p).unwrap();
        let table = offsets[0] as usize - 8 * offsets.len();
        for (k, offset) in [(0, 0u64), (1, good.len() as u64), (2, table as u64)] {
            let mut b = good.clone();
            b[table + 8 * k..table + 8 * k + 8].copy_from_slice(&offset.to_le_bytes());
            std::fs::write(&p, b).unwrap();
            let m = message(&p);
            assert!(m.contains(&format!("chunk {k}'s offset {offset} is outside the chunks")), "{m}");
        }
        std::fs::write(&p, &good[..table + 4]).unwrap();
        let m = message(&p);
        assert!(m.contains("3 chunks, whose offset table alone (24 bytes) is longer than the 4 bytes left"), "{m}");
        let len = offsets[2] as usize + 6;
        std::fs::write(&p, &good[..len]).unwrap();
        let m = message(&p);
        assert!(m.contains(&format!("the file ({len} bytes) ends inside chunk 2's fields")), "{m}");
        // A file shorter than its header is the crate's error, and a missing file an io error; both name it.
        std::fs::write(&p, &good[..40]).unwrap();
        assert!(matches!(scan_exr(&p), Err(ImageError::Exr { .. })));
        message(&p);
        assert!(matches!(scan_exr(&d.join("missing.exr")), Err(ImageError::Io { .. })));
    }
}

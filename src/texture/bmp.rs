//! Windows bitmaps (`.bmp`) as Mitsuba 3.9.1's `Bitmap::read_bmp` reads them (src/core/bitmap.cpp): the
//! `BM` signature, a 40-byte `BITMAPINFOHEADER`, one plane, a positive width, no compression; 8, 16, 24 or
//! 32 bits per pixel read as grey, grey + alpha, RGB and RGBA (Mitsuba ignores an 8-bit file's palette and
//! reads its indices as grey; so does this), 8-bit sRGB-encoded samples; rows padded to 4 bytes, stored
//! bottom-up when the height is positive (top-down when negative); colour samples in B, G, R order.

use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use super::decode::{Decoded, FileFormat, Header, Samples};
use super::TextureError;

/// Bytes of the file header and of the `BITMAPINFOHEADER` fields up to the compression type.
const FIELDS: usize = 34;

pub(super) fn read_bmp(path: &Path, budget: &mut dyn FnMut(&Header) -> Result<(), TextureError>) -> Result<Decoded, TextureError> {
    let bad = |message: String| TextureError::Decode { path: path.to_path_buf(), format: FileFormat::Bmp, message };
    let io_err = |source: std::io::Error| match source.kind() {
        std::io::ErrorKind::UnexpectedEof => bad("the file ends before its pixels do".into()),
        _ => TextureError::Io { path: path.to_path_buf(), source },
    };
    let mut r = BufReader::new(File::open(path).map_err(io_err)?);
    let mut h = [0u8; FIELDS];
    r.read_exact(&mut h).map_err(io_err)?;
    let u16_at = |i: usize| u16::from_le_bytes([h[i], h[i + 1]]);
    let u32_at = |i: usize| u32::from_le_bytes([h[i], h[i + 1], h[i + 2], h[i + 3]]);
    if &h[..2] != b"BM" {
        return Err(bad("it does not start with \"BM\"".into()));
    }
    let (offset, header_size, width, height) = (u32_at(10), u32_at(14), u32_at(18) as i32, u32_at(22) as i32);
    let (planes, bpp, compression) = (u16_at(26), u16_at(28), u32_at(30));
    if header_size != 40 || planes != 1 || width <= 0 || height == 0 || (offset as usize) < FIELDS {
        let what = format!("header size {header_size}, {planes} planes, {width}×{height} pixels");
        return Err(bad(format!("an unsupported bitmap ({what}; Mitsuba reads a 40-byte header, one plane, a positive width)")));
    }
    if compression != 0 {
        return Err(bad(format!("compression type {compression}: compressed bitmaps are not supported (nor by Mitsuba)")));
    }
    let channels: u64 = match bpp {
        8 => 1,
        16 => 2,
        24 => 3,
        32 => 4,
        _ => return Err(bad(format!("{bpp} bits per pixel (Mitsuba reads 8, 16, 24 or 32)"))),
    };
    let (w, rows) = (u64::from(width.unsigned_abs()), u64::from(height.unsigned_abs()));
    let row_bytes = w * channels;
    let padding = (4 - row_bytes % 4) % 4;
    budget(&Header { width: w, height: rows, decoder_bytes: row_bytes + padding, grey: channels <= 2 })?;
    r.seek(SeekFrom::Start(u64::from(offset))).map_err(io_err)?;
    let mut data = vec![0u8; (row_bytes * rows) as usize];
    let mut pad = [0u8; 3];
    for y in 0..rows {
        // Bottom-up files fill the image from its last row.
        let target = if height > 0 { rows - 1 - y } else { y };
        let start = (target * row_bytes) as usize;
        r.read_exact(&mut data[start..start + row_bytes as usize]).map_err(io_err)?;
        r.read_exact(&mut pad[..padding as usize]).map_err(io_err)?;
    }
    if channels >= 3 {
        for px in data.chunks_exact_mut(channels as usize) {
            px.swap(0, 2);
        }
    }
    Ok(Decoded { width: w as u32, height: rows as u32, channels: channels as usize, samples: Samples::U8(data), srgb: true, format: FileFormat::Bmp })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bitmap file of `width × height` (negative: top-down) with `bpp` bits per pixel and these rows'
    /// bytes as stored (padding added here).
    fn file(name: &str, width: i32, height: i32, bpp: u16, stored_rows: &[Vec<u8>]) -> std::path::PathBuf {
        let mut pixels = Vec::new();
        for row in stored_rows {
            pixels.extend_from_slice(row);
            pixels.resize(pixels.len().next_multiple_of(4), 0);
        }
        let mut b = Vec::new();
        b.extend_from_slice(b"BM");
        b.extend_from_slice(&(54 + pixels.len() as u32).to_le_bytes());
        b.extend_from_slice(&[0; 4]);
        b.extend_from_slice(&54u32.to_le_bytes());
        b.extend_from_slice(&40u32.to_le_bytes());
        b.extend_from_slice(&width.to_le_bytes());
        b.extend_from_slice(&height.to_le_bytes());
        b.extend_from_slice(&1u16.to_le_bytes());
        b.extend_from_slice(&bpp.to_le_bytes());
        b.extend_from_slice(&[0; 24]);
        b.extend_from_slice(&pixels);
        let path = std::env::temp_dir().join(format!("caustica-bmp-{}-{name}.bmp", std::process::id()));
        std::fs::write(&path, b).unwrap();
        path
    }

    fn read(path: &Path) -> Result<Decoded, TextureError> {
        read_bmp(path, &mut |_| Ok(()))
    }

    #[test]
    fn rows_colours_and_padding_as_mitsuba_reads_them() {
        // 3×2 RGB, bottom-up: the first stored row is the image's last; B, G, R per pixel; rows of 9 bytes
        // padded to 12.
        let bottom = vec![1, 2, 3, 4, 5, 6, 7, 8, 9];
        let top = vec![10, 11, 12, 13, 14, 15, 16, 17, 18];
        let path = file("rgb", 3, 2, 24, &[bottom, top]);
        let d = read(&path).unwrap();
        assert_eq!((d.width, d.height, d.channels, d.srgb), (3, 2, 3, true));
        assert_eq!(d.samples, Samples::U8(vec![12, 11, 10, 15, 14, 13, 18, 17, 16, 3, 2, 1, 6, 5, 4, 9, 8, 7]));
        // Top-down (negative height), 8-bit: indices read as grey, no palette.
        let path2 = file("grey", 2, -2, 8, &[vec![1, 2], vec![3, 4]]);
        let d = read(&path2).unwrap();
        assert_eq!((d.channels, d.samples.clone()), (1, Samples::U8(vec![1, 2, 3, 4])));
        // Unsupported depths and truncated files are errors naming the file.
        let path3 = file("bpp", 2, 2, 4, &[vec![0], vec![0]]);
        assert!(read(&path3).unwrap_err().to_string().contains("4 bits per pixel"));
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..bytes.len() - 5]).unwrap();
        assert!(read(&path).unwrap_err().to_string().contains("ends before its pixels"));
        for p in [path, path2, path3] {
            let _ = std::fs::remove_file(p);
        }
    }
}

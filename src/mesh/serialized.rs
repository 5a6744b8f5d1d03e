//! Mitsuba's `serialized` mesh files, versions 3 and 4 (what Mitsuba 0.5/0.6 write and Mitsuba 3 up to
//! 3.9 reads; Mitsuba 3's `src/shapes/serialized.cpp`, `SerializedMesh` and `load_legacy`).
//!
//! ```xml
//! <shape type="serialized">
//!     <string name="filename" value="meshes/scene.serialized"/>
//!     <integer name="shape_index" value="2"/>   <!-- default 0: the file's first shape -->
//! </shape>
//! ```
//!
//! The layout, little endian throughout:
//! ```text
//! u16 format id 0x041C, u16 version (3 or 4)            ┐ one block per shape, concatenated
//! zlib stream:                                          │
//!   u32 flags   0x0001 vertex normals, 0x0002 uvs,      │
//!               0x0008 vertex colours, 0x2000 doubles   │
//!               (else single precision)                 │
//!   version 4: the shape's name, NUL-terminated UTF-8   │
//!   u64 V, u64 F                                        │
//!   V×3 positions, [V×3 normals], [V×2 uvs], [V×3 colours] (f32, or f64 with 0x2000)
//!   F×3 u32 vertex indices                              ┘
//! dictionary: each shape's file offset (u32 in version 3, u64 in version 4), then u32 the shape count
//! ```
//! `shape_index` > 0 is found through the dictionary at the end of the file, whose count bounds it (Mitsuba
//! 3.9.1 accepts an index equal to the count and fails in the decompressor; here it is out of range); the
//! first shape is read from the start, as Mitsuba does, so a file without a dictionary still loads.
//! Normals and uvs are kept, colours read and dropped (as Mitsuba). The flag 0x0010 (face normals) is
//! ignored, as Mitsuba 3 does for these versions: only the scene's `face_normals` makes a shape flat.
//! Version 5 (Mitsuba after 3.9: packed records, surface-point maps) is named and refused.
//!
//! Reading is bounded by the data: the counts are checked before any array is allocated, against what the
//! shape's compressed bytes can inflate to ([`super::MAX_INFLATE_RATIO`] times their size: a header that
//! promises more is refused at once) and against the memory left (`render::memory::check_mesh`); the
//! arrays are then reserved with `try_reserve` and filled as the stream delivers, chunk by chunk, so a
//! stream shorter than its counts is an error after at most its own size. The compressed input of a shape
//! found through the dictionary ends where the next shape (or the dictionary) begins.

use std::io::{self, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use flate2::read::ZlibDecoder;

use super::{reserved, TriangleMesh, MAX_INFLATE_RATIO};
use crate::error::MeshError;
use crate::math::{Vec2, Vec3};

/// The format id every shape block starts with (Mitsuba's `MTS_FILEFORMAT_HEADER`).
pub const FORMAT_ID: u16 = 0x041C;

/// The flag bits of versions 3 and 4 (Mitsuba 3's `TriMeshFlags`).
const HAS_NORMALS: u32 = 0x0001;
const HAS_UVS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE_PRECISION: u32 = 0x2000;

/// One shape of a serialized file.
#[derive(Clone, Debug)]
pub struct SerializedShape {
    /// The shape's name (version 4 files; version 3 has none).
    pub name: Option<String>,
    /// Its triangles, checked by [`TriangleMesh::validate`].
    pub mesh: TriangleMesh,
}

/// Reads shape `shape_index` of the serialized file at `path`.
pub fn load_serialized(path: &Path, shape_index: u32) -> Result<SerializedShape, MeshError> {
    let (file, _) = super::open_regular(path)?;
    read_serialized(BufReader::new(file), shape_index, path)
}

/// Reads shape `shape_index` of serialized data from `reader`; `path` only names the source in errors.
pub fn read_serialized<R: Read + Seek>(mut reader: R, shape_index: u32, path: &Path) -> Result<SerializedShape, MeshError> {
    let err = |message: String| MeshError::Serialized { path: path.to_path_buf(), shape: shape_index, message };
    let io_err = |error: io::Error| MeshError::Io { path: path.to_path_buf(), error };
    let file_len = reader.seek(SeekFrom::End(0)).map_err(io_err)?;
    reader.rewind().map_err(io_err)?;
    let version = read_block_header(&mut reader, None).map_err(err)?;

    // Where the shape's zlib stream lies: [start, end) in the file.
    let (start, end) = if shape_index == 0 {
        (4, file_len)
    } else {
        let (count, offsets) = read_dictionary(&mut reader, file_len, version).map_err(err)?;
        if shape_index >= count {
            return Err(MeshError::ShapeIndexOutOfRange { path: path.to_path_buf(), index: shape_index, count });
        }
        let mut offset_of = |i: u32| read_offset(&mut reader, offsets, i, version);
        // Blocks follow each other: the one before ends where this one starts, this one where the next
        // starts (or the dictionary, after the last), and each holds at least its 4-byte header.
        let previous = offset_of(shape_index - 1).map_err(err)?;
        let offset = offset_of(shape_index).map_err(err)?;
        let next = if shape_index + 1 < count { offset_of(shape_index + 1).map_err(err)? } else { offsets };
        let ordered = |a: u64, b: u64| a.checked_add(4).is_some_and(|a4| a4 <= b);
        if !(ordered(previous, offset) && ordered(offset, next) && next <= offsets) {
            return Err(err(format!(
                "the dictionary's offsets are not in order: shape {} at byte {previous}, shape {shape_index} at byte \
                 {offset}, then byte {next}, the dictionary at byte {offsets}",
                shape_index - 1
            )));
        }
        reader.seek(SeekFrom::Start(offset)).map_err(io_err)?;
        read_block_header(&mut reader, Some(version)).map_err(|m| err(format!("the block at byte {offset}: {m}")))?;
        (offset + 4, next)
    };
    reader.seek(SeekFrom::Start(start)).map_err(io_err)?;
    let mut stream = Stream { inner: ZlibDecoder::new(reader.take(end - start)) };
    let mesh = read_shape(&mut stream, version, end - start).map_err(err)?;
    mesh.mesh.validate(path)?;
    Ok(mesh)
}

/// Reads and checks a block's `u16` format id and `u16` version; returns the version. `expected`: the
/// version of the file's first block, which every later block must repeat.
fn read_block_header<R: Read>(reader: &mut R, expected: Option<u16>) -> Result<u16, String> {
    let mut header = [0u8; 4];
    reader.read_exact(&mut header).map_err(|e| match e.kind() {
        io::ErrorKind::UnexpectedEof => "the file is shorter than the 4-byte header of a serialized mesh".to_string(),
        _ => format!("reading the header: {e}"),
    })?;
    let id = u16::from_le_bytes([header[0], header[1]]);
    let version = u16::from_le_bytes([header[2], header[3]]);
    if id != FORMAT_ID {
        return Err(format!("not a Mitsuba serialized mesh: it starts with {id:#06x}, not the format id {FORMAT_ID:#06x}"));
    }
    match (version, expected) {
        (3 | 4, None) => Ok(version),
        (v, Some(e)) if v == e => Ok(v),
        (v, Some(e)) => Err(format!("version {v}, but the file's first block is version {e}")),
        (5, None) => Err("version 5 (written by Mitsuba after 3.9) is not read; versions 3 and 4 are".into()),
        (v, None) => Err(format!("version {v}; versions 3 and 4 are read")),
    }
}

/// The end-of-file dictionary: the shape count and the byte where the offsets begin.
fn read_dictionary<R: Read + Seek>(reader: &mut R, file_len: u64, version: u16) -> Result<(u32, u64), String> {
    if file_len < 8 {
        return Err(format!("the {file_len}-byte file has no room for the shape dictionary at its end"));
    }
    reader.seek(SeekFrom::Start(file_len - 4)).map_err(|e| e.to_string())?;
    let count = read_u32(reader).map_err(|e| e.to_string())?;
    let entry = offset_size(version);
    // The offsets must lie after the first block's 4-byte header.
    let offsets = (file_len - 4).checked_sub(u64::from(count) * entry).filter(|&o| o >= 4).ok_or_else(|| {
        format!("the dictionary at the end of the file lists {count} shapes, more offsets than the {file_len}-byte file holds")
    })?;
    Ok((count, offsets))
}

/// Bytes of one dictionary offset: `u32` in version 3, `u64` in version 4.
fn offset_size(version: u16) -> u64 {
    if version == 3 {
        4
    } else {
        8
    }
}

/// The file offset of shape `i`, from the dictionary starting at byte `offsets`.
fn read_offset<R: Read + Seek>(reader: &mut R, offsets: u64, i: u32, version: u16) -> Result<u64, String> {
    let entry = offset_size(version);
    reader.seek(SeekFrom::Start(offsets + u64::from(i) * entry)).map_err(|e| e.to_string())?;
    let read = if entry == 4 { read_u32(reader).map(u64::from) } else { read_u64(reader) };
    read.map_err(|e| format!("the dictionary's offset of shape {i}: {e}"))
}

fn read_u32<R: Read>(reader: &mut R) -> io::Result<u32> {
    let mut b = [0u8; 4];
    reader.read_exact(&mut b)?;
    Ok(u32::from_le_bytes(b))
}

fn read_u64<R: Read>(reader: &mut R) -> io::Result<u64> {
    let mut b = [0u8; 8];
    reader.read_exact(&mut b)?;
    Ok(u64::from_le_bytes(b))
}

/// The decompressed stream of one shape.
struct Stream<R: Read> {
    inner: R,
}

impl<R: Read> Stream<R> {
    /// Exactly `count × size` bytes (`what` names them in errors), read as they arrive: a count larger than
    /// the stream is an error once the stream ends, never an allocation of the promised size.
    fn bytes(&mut self, count: u64, size: u64, what: &str) -> Result<Vec<u8>, String> {
        let n = count.checked_mul(size).ok_or_else(|| format!("{count} {what} is more data than any file holds"))?;
        let mut buf = Vec::new();
        let got = (&mut self.inner).take(n).read_to_end(&mut buf).map_err(|e| format!("reading the {what}: {e}"))?;
        if (got as u64) < n {
            return Err(format!("the stream ends after {got} of the {n} bytes of {count} {what}"));
        }
        Ok(buf)
    }

    /// Skips `count × size` bytes without keeping them.
    fn skip(&mut self, count: u64, size: u64, what: &str) -> Result<(), String> {
        let n = count.checked_mul(size).ok_or_else(|| format!("{count} {what} is more data than any file holds"))?;
        let got = io::copy(&mut (&mut self.inner).take(n), &mut io::sink()).map_err(|e| format!("reading the {what}: {e}"))?;
        if got < n {
            return Err(format!("the stream ends after {got} of the {n} bytes of {count} {what}"));
        }
        Ok(())
    }

    fn u32(&mut self, what: &str) -> Result<u32, String> {
        let b = self.bytes(1, 4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self, what: &str) -> Result<u64, String> {
        let b = self.bytes(1, 8, what)?;
        Ok(u64::from_le_bytes(b[..8].try_into().unwrap_or_default()))
    }

    /// `count` records of `size` bytes each, made by `make` into a vector reserved up front (the counts were
    /// checked against the memory left) and filled chunk by chunk as the stream delivers.
    fn records<T>(&mut self, count: u64, size: usize, what: &str, make: impl Fn(&[u8]) -> T) -> Result<Vec<T>, String> {
        let n = count.checked_mul(size as u64).ok_or_else(|| format!("{count} {what} is more data than any file holds"))?;
        let mut out = reserved(count, what)?;
        let mut chunk = vec![0u8; size * (1 << 12)];
        let mut got = 0u64;
        while got < n {
            let len = chunk.len().min((n - got) as usize);
            let buf = &mut chunk[..len];
            let mut filled = 0;
            while filled < len {
                match self.inner.read(&mut buf[filled..]) {
                    Ok(0) => return Err(format!("the stream ends after {} of the {n} bytes of {count} {what}", got + filled as u64)),
                    Ok(k) => filled += k,
                    Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(format!("reading the {what}: {e}")),
                }
            }
            out.extend(buf.chunks_exact(size).map(&make));
            got += len as u64;
        }
        Ok(out)
    }

    /// `count` values of `D` floats each (f32, or f64 rounded to f32), made by `make`.
    fn floats<T, const D: usize>(&mut self, count: u64, double: bool, what: &str, make: impl Fn([f32; D]) -> T) -> Result<Vec<T>, String> {
        let size = if double { 8 } else { 4 };
        self.records(count, D * size, what, |c| {
            make(std::array::from_fn(|k| {
                let b = &c[k * size..(k + 1) * size];
                if double {
                    f64::from_le_bytes(b.try_into().unwrap_or_default()) as f32
                } else {
                    f32::from_le_bytes(b.try_into().unwrap_or_default())
                }
            }))
        })
    }

    /// A NUL-terminated string (version 4's shape name), at most `MAX_NAME` bytes.
    fn c_string(&mut self) -> Result<String, String> {
        let mut name = Vec::new();
        let mut byte = [0u8; 1];
        loop {
            self.inner.read_exact(&mut byte).map_err(|e| format!("reading the shape's name: {e}"))?;
            if byte[0] == 0 {
                return Ok(String::from_utf8_lossy(&name).into_owned());
            }
            if name.len() == MAX_NAME {
                return Err(format!("the shape's name has no end within {MAX_NAME} bytes"));
            }
            name.push(byte[0]);
        }
    }
}

/// The longest shape name read (Mitsuba sets no limit; real names are object names from a modeller).
const MAX_NAME: usize = 1 << 16;

/// The shape record after the block header: flags, name (version 4), counts, arrays. `compressed`: the
/// bytes of the shape's zlib stream, which bound what the counts may promise.
fn read_shape<R: Read>(s: &mut Stream<R>, version: u16, compressed: u64) -> Result<SerializedShape, String> {
    let flags = s.u32("flags")?;
    let name = if version == 4 { Some(s.c_string()?) } else { None };
    let vertex_count = s.u64("vertex count")?;
    let face_count = s.u64("triangle count")?;
    if u32::try_from(vertex_count).is_err() {
        return Err(format!("{vertex_count} vertices is more than 32-bit indices can address"));
    }
    let double = flags & DOUBLE_PRECISION != 0;
    let (has_normals, has_uvs, has_colors) = (flags & HAS_NORMALS != 0, flags & HAS_UVS != 0, flags & HAS_COLORS != 0);
    let floats_per_vertex = 3 + 3 * u64::from(has_normals) + 2 * u64::from(has_uvs) + 3 * u64::from(has_colors);
    let promised = vertex_count
        .saturating_mul(floats_per_vertex * if double { 8 } else { 4 })
        .saturating_add(face_count.saturating_mul(12));
    if promised > compressed.saturating_mul(MAX_INFLATE_RATIO) {
        return Err(format!(
            "the header promises {vertex_count} vertices and {face_count} triangles, {promised} bytes of data, more than \
             the shape's {compressed} compressed bytes can hold ({MAX_INFLATE_RATIO} times as many at most)"
        ));
    }
    crate::render::memory::check_mesh(vertex_count, face_count, has_normals, has_uvs, 0)?;
    let positions = s.floats(vertex_count, double, "vertex positions", Vec3::from_array)?;
    let normals = if has_normals { Some(s.floats(vertex_count, double, "vertex normals", Vec3::from_array)?) } else { None };
    let uvs = if has_uvs { Some(s.floats(vertex_count, double, "vertex uvs", Vec2::from_array)?) } else { None };
    if has_colors {
        s.skip(vertex_count, 3 * if double { 8 } else { 4 }, "vertex colours")?;
    }
    let indices = s.records(face_count, 12, "triangles", |c| {
        let u = |k: usize| u32::from_le_bytes([c[k], c[k + 1], c[k + 2], c[k + 3]]);
        [u(0), u(4), u(8)]
    })?;
    Ok(SerializedShape { name, mesh: TriangleMesh { positions, indices, normals, uvs } })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::{Cursor, Write};

    /// What the test writer puts in a shape.
    #[derive(Clone)]
    struct Spec {
        mesh: TriangleMesh,
        name: &'static str,
        double: bool,
        colors: bool,
    }

    /// A test-only writer of the format (Mitsuba 0.5's `TriMesh::serialize` layout): each shape a block
    /// with its own header and zlib stream, then the dictionary. `counts` overrides the header's (V, F).
    fn write_file(version: u16, shapes: &[Spec], counts: Option<(u64, u64)>) -> Vec<u8> {
        let mut file = Vec::new();
        let mut offsets = Vec::new();
        for spec in shapes {
            offsets.push(file.len() as u64);
            file.extend_from_slice(&FORMAT_ID.to_le_bytes());
            file.extend_from_slice(&version.to_le_bytes());
            let m = &spec.mesh;
            let mut raw = Vec::new();
            let flags = u32::from(m.normals.is_some()) * HAS_NORMALS
                | u32::from(m.uvs.is_some()) * HAS_UVS
                | u32::from(spec.colors) * HAS_COLORS
                | if spec.double { DOUBLE_PRECISION } else { 0x1000 };
            raw.extend_from_slice(&flags.to_le_bytes());
            if version == 4 {
                raw.extend_from_slice(spec.name.as_bytes());
                raw.push(0);
            }
            let (v, f) = counts.unwrap_or((m.positions.len() as u64, m.indices.len() as u64));
            raw.extend_from_slice(&v.to_le_bytes());
            raw.extend_from_slice(&f.to_le_bytes());
            let mut put = |values: &mut dyn Iterator<Item = f32>| {
                for x in values {
                    if spec.double {
                        raw.extend_from_slice(&f64::from(x).to_le_bytes());
                    } else {
                        raw.extend_from_slice(&x.to_le_bytes());
                    }
                }
            };
            put(&mut m.positions.iter().flat_map(|p| p.to_array()));
            if let Some(n) = &m.normals {
                put(&mut n.iter().flat_map(|p| p.to_array()));
            }
            if let Some(uv) = &m.uvs {
                put(&mut uv.iter().flat_map(|p| p.to_array()));
            }
            if spec.colors {
                put(&mut m.positions.iter().flat_map(|_| [0.25, 0.5, 0.75]));
            }
            for t in &m.indices {
                for i in t {
                    raw.extend_from_slice(&i.to_le_bytes());
                }
            }
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            z.write_all(&raw).unwrap();
            file.extend_from_slice(&z.finish().unwrap());
        }
        for o in &offsets {
            if version == 3 {
                file.extend_from_slice(&(*o as u32).to_le_bytes());
            } else {
                file.extend_from_slice(&o.to_le_bytes());
            }
        }
        file.extend_from_slice(&(shapes.len() as u32).to_le_bytes());
        file
    }

    fn read(bytes: &[u8], index: u32) -> Result<SerializedShape, MeshError> {
        read_serialized(Cursor::new(bytes), index, Path::new("t.serialized"))
    }

    /// A quad with every attribute, values not exact in f32 halves so double precision is exercised.
    fn quad() -> TriangleMesh {
        TriangleMesh {
            positions: vec![Vec3::new(0.1, 0.0, -0.3), Vec3::new(2.0, 0.0, 0.0), Vec3::new(2.0, 3.7, 0.0), Vec3::new(0.0, 3.0, -1.5)],
            indices: vec![[0, 1, 2], [0, 2, 3]],
            normals: Some(vec![Vec3::Z, Vec3::Z, Vec3::new(0.0, 0.6, 0.8), Vec3::Z]),
            uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 0.3), Vec2::new(0.0, 1.0)]),
        }
    }

    fn triangle() -> TriangleMesh {
        TriangleMesh {
            positions: vec![Vec3::new(-1.0, -1.0, 5.0), Vec3::new(1.0, -1.0, 5.0), Vec3::new(0.0, 1.0, 5.0)],
            indices: vec![[0, 1, 2]],
            normals: None,
            uvs: None,
        }
    }

    fn spec(mesh: TriangleMesh, double: bool) -> Spec {
        Spec { mesh, name: "quad", double, colors: false }
    }

    fn assert_same(a: &TriangleMesh, b: &TriangleMesh) {
        assert_eq!(a.positions, b.positions);
        assert_eq!(a.indices, b.indices);
        assert_eq!(a.normals, b.normals);
        assert_eq!(a.uvs, b.uvs);
    }

    #[test]
    fn both_versions_both_precisions_with_and_without_attributes() {
        let bare = TriangleMesh { normals: None, uvs: None, ..quad() };
        let normals_only = TriangleMesh { uvs: None, ..quad() };
        let uvs_only = TriangleMesh { normals: None, ..quad() };
        for version in [3, 4] {
            for double in [false, true] {
                for mesh in [quad(), bare.clone(), normals_only.clone(), uvs_only.clone()] {
                    for colors in [false, true] {
                        let s = Spec { colors, ..spec(mesh.clone(), double) };
                        let got = read(&write_file(version, &[s], None), 0).unwrap();
                        // f32 → f64 → f32 is exact, so double files read back the same values.
                        assert_same(&got.mesh, &mesh);
                        assert_eq!(got.name.as_deref(), (version == 4).then_some("quad"));
                    }
                }
            }
        }
    }

    #[test]
    fn double_values_round_to_nearest_f32() {
        // A value written as f64 that f32 cannot hold: the reader rounds it (as Mitsuba's `(float)` cast).
        let mut raw_mesh = triangle();
        raw_mesh.positions[0].x = 0.1;
        let mut bytes = write_file(4, &[spec(raw_mesh, true)], None);
        // Replace the f64 of 0.1f32 by the f64 0.1 (not the same number) inside the decompressed stream.
        let z_start = 4;
        let mut raw = Vec::new();
        ZlibDecoder::new(&bytes[z_start..]).read_to_end(&mut raw).unwrap();
        let at = raw.windows(8).position(|w| w == f64::from(0.1f32).to_le_bytes()).unwrap();
        raw[at..at + 8].copy_from_slice(&0.1f64.to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        bytes.truncate(z_start);
        bytes.extend_from_slice(&z.finish().unwrap());
        bytes.extend_from_slice(&0u64.to_le_bytes());
        bytes.extend_from_slice(&1u32.to_le_bytes());
        assert_eq!(read(&bytes, 0).unwrap().mesh.positions[0].x, 0.1f32);
    }

    #[test]
    fn shape_index_picks_the_shape_through_the_dictionary() {
        for version in [3, 4] {
            let shapes = [spec(quad(), false), Spec { name: "tri", ..spec(triangle(), true) }, spec(quad(), true)];
            let bytes = write_file(version, &shapes, None);
            for (i, s) in shapes.iter().enumerate() {
                let got = read(&bytes, i as u32).unwrap();
                assert_same(&got.mesh, &s.mesh);
                assert_eq!(got.name.as_deref(), (version == 4).then_some(s.name));
            }
            match read(&bytes, 3) {
                Err(e @ MeshError::ShapeIndexOutOfRange { index: 3, count: 3, .. }) => {
                    let text = e.to_string();
                    assert!(text.starts_with("t.serialized: ") && text.contains("3 shapes"), "{text}");
                }
                other => panic!("version {version}: {other:?}"),
            }
        }
    }

    #[test]
    fn first_shape_needs_no_dictionary() {
        let mut bytes = write_file(4, &[spec(quad(), false)], None);
        bytes.truncate(bytes.len() - 12);
        assert_same(&read(&bytes, 0).unwrap().mesh, &quad());
        // ... but another shape does.
        assert!(matches!(read(&bytes, 1), Err(MeshError::Serialized { .. })));
    }

    /// The error text of reading `bytes` at `index`, which must be an error naming the file.
    fn error(bytes: &[u8], index: u32) -> String {
        let e = read(bytes, index).expect_err("must fail").to_string();
        assert!(e.starts_with("t.serialized: "), "{e}");
        e
    }

    #[test]
    fn lying_counts_are_errors_not_allocations() {
        for double in [false, true] {
            let s = spec(quad(), double);
            // More vertices or triangles than the stream holds; the largest counts would be terabytes.
            for counts in [(5, 2), (4, 3), (1 << 31, 2), (4, u64::MAX / 12), (4, u64::MAX)] {
                let e = error(&write_file(4, &[s.clone()], Some(counts)), 0);
                assert!(e.contains("the stream ends after") || e.contains("compressed bytes can hold"), "{counts:?}: {e}");
            }
            let e = error(&write_file(3, &[s.clone()], Some((1 << 33, 2))), 0);
            assert!(e.contains("more than 32-bit indices can address"), "{e}");
        }
    }

    #[test]
    fn truncated_and_broken_files_are_errors() {
        let good = write_file(4, &[spec(quad(), false), spec(triangle(), false)], None);
        let second = u64::from_le_bytes(good[good.len() - 12..good.len() - 4].try_into().unwrap()) as usize;
        let mut cases: Vec<(Vec<u8>, u32, &str)> = vec![
            (Vec::new(), 0, "shorter than the 4-byte header"),
            (b"ply\nformat ascii 1.0\n".to_vec(), 0, "not a Mitsuba serialized mesh"),
            (good[..40].to_vec(), 0, ""),
            (good[..second - 20].to_vec(), 0, ""),
            (good[..second + 30].to_vec(), 1, ""),
        ];
        for (version, needle) in [(2u16, "version 2"), (5, "version 5")] {
            let mut b = good.clone();
            b[2..4].copy_from_slice(&version.to_le_bytes());
            cases.push((b, 0, needle));
        }
        // The second block's header names another version than the first.
        let mut b = good.clone();
        b[second + 2] = 3;
        cases.push((b, 1, "but the file's first block is version 4"));
        // A dictionary that lists more shapes than the file has room for.
        let mut b = good.clone();
        let n = b.len();
        b[n - 4..].copy_from_slice(&1000u32.to_le_bytes());
        cases.push((b, 1, "lists 1000 shapes"));
        // Offsets out of order.
        let mut b = good.clone();
        b[n - 12..n - 4].copy_from_slice(&2u64.to_le_bytes());
        cases.push((b, 1, "not in order"));
        // Garbage in the compressed stream.
        let mut b = good.clone();
        for x in &mut b[6..30] {
            *x ^= 0x5a;
        }
        cases.push((b, 0, ""));
        for (i, (bytes, index, needle)) in cases.iter().enumerate() {
            let e = error(bytes, *index);
            assert!(e.contains(needle), "case {i}: {e}");
        }
    }

    #[test]
    fn indices_out_of_range_and_non_finite_values_are_errors() {
        let mut m = quad();
        m.indices[1][2] = 4;
        let e = error(&write_file(4, &[spec(m, false)], None), 0);
        assert!(e.contains("refers to vertex 4"), "{e}");
        let mut m = quad();
        m.positions[2].y = f32::NAN;
        let e = error(&write_file(3, &[spec(m, true)], None), 0);
        assert!(e.contains("non-finite position"), "{e}");
        // An f64 beyond f32's range becomes ∞: refused too.
        let bytes = write_file(4, &[spec(triangle(), true)], None);
        let mut raw = Vec::new();
        ZlibDecoder::new(&bytes[4..]).read_to_end(&mut raw).unwrap();
        let at = raw.windows(8).position(|w| w == 5.0f64.to_le_bytes()).unwrap();
        raw[at..at + 8].copy_from_slice(&1e300f64.to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        let mut b = bytes[..4].to_vec();
        b.extend_from_slice(&z.finish().unwrap());
        assert!(error(&b, 0).contains("non-finite position"));
    }

    /// `tests/data/real/meshes/matpreview-2.serialized`: the first two shapes of Mitsuba's material-preview
    /// mesh (version 3, see tests/data/real/README.md). The figures are Mitsuba 3.9.1's (scalar_rgb,
    /// `mi.load_dict({'type': 'serialized', 'filename': …, 'shape_index': i})`, then `mi.traverse` for
    /// `vertex_positions` and `faces`; the box is the positions' min and max).
    #[test]
    fn a_file_mitsuba_wrote_reads_as_mitsuba_reads_it() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/real/meshes/matpreview-2.serialized");
        #[allow(clippy::type_complexity)]
        let mitsuba: [(usize, usize, [f32; 3], [f32; 3], [f32; 3], [u32; 3], [f32; 2]); 2] = [
            (
                289,
                512,
                [-1.0024269819259644, -1.0, 0.0],
                [1.1313550472259521, 0.622808575630188, 1.2964400053024292],
                [-0.5048662424087524, 0.5747208595275879, 0.7843790054321289],
                [285, 288, 286],
                [0.6446580290794373, 0.8092356324195862],
            ),
            (
                2078,
                3936,
                [-0.9272717833518982, -0.927271842956543, -0.031111598014831543],
                [0.9272717833518982, 0.927271842956543, 1.6868669986724854],
                [0.667028546333313, 0.27629226446151733, 0.06282293796539307],
                [1861, 2077, 1865],
                [0.15914541482925415, 0.3169771432876587],
            ),
        ];
        for (i, (v, f, lo, hi, first, last_face, uv0)) in mitsuba.into_iter().enumerate() {
            let shape = load_serialized(&path, i as u32).unwrap();
            let m = &shape.mesh;
            assert_eq!((m.positions.len(), m.indices.len()), (v, f), "shape {i}");
            let b = m.bounds();
            assert_eq!((b.min.to_array(), b.max.to_array()), (lo, hi), "shape {i}");
            assert_eq!(m.positions[0].to_array(), first, "shape {i}");
            assert_eq!(m.indices[f - 1], last_face, "shape {i}");
            assert_eq!(m.uvs.as_ref().map(|u| u[0].to_array()), Some(uv0), "shape {i}");
            assert_eq!(m.normals.as_ref().map(Vec::len), Some(v), "shape {i}");
            assert_eq!(shape.name, None, "version 3 has no names");
        }
        assert!(matches!(
            load_serialized(&path, 2),
            Err(MeshError::ShapeIndexOutOfRange { index: 2, count: 2, .. })
        ));
    }
}

//! PLY reading (ASCII, binary little and big endian, optionally gzip-compressed) through ply-rs-bw.
//!
//! What is read:
//! ```text
//! element vertex N
//! property float|double x, y, z          (required; integer types are converted too)
//! property float nx, ny, nz              (optional: normals, kept only if all three are declared)
//! property float u, v  |  s, t  |  texture_u, texture_v   (optional: uvs)
//! element face M
//! property list uchar int vertex_indices (or vertex_index; any integer types)
//! ```
//! Polygons are triangulated as fans `(v0, v_i, v_{i+1})`, which keeps their winding. Other elements
//! (edges, materials, ...) are skipped; other properties of `vertex` and `face` are the mesh's attributes
//! (colours, weights: named and converted as Mitsuba does, `super::attribute`), read only by
//! [`load_ply_with_attributes`] and only those asked for (a face attribute once per triangle of its polygon). Out-of-range or negative indices and faces
//! with fewer than three vertices are errors that name the file and the face.
//!
//! [`write_ply`] writes the same subset (binary little endian: positions, normals and uvs if present,
//! `uchar`/`int` index lists), e.g. so that another renderer can load exactly our triangles.
//!
//! The header is read by ply-rs-bw (at most [`MAX_HEADER_BYTES`]); the data by this module, element by
//! element, straight into the mesh's arrays. Before any array is allocated, the header's counts are checked
//! against what the file can hold (every value takes at least its binary size, or in ASCII a character and
//! a separator; a `.ply.gz` file inflates to at most [`super::MAX_INFLATE_RATIO`] times its size) and the
//! mesh they make against the memory left (`render::memory::check_mesh`); a binary list whose length
//! exceeds the data left is refused when its length is read, an ASCII line may be at most
//! [`MAX_ASCII_LINE`] bytes, and the triangles of polygons beyond the face count are checked against the
//! memory left as the array grows. So a hostile header costs neither memory nor time.

use std::io::{BufRead, BufReader, Read};
use std::path::Path;

use flate2::bufread::GzDecoder;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, PropertyAccess, PropertyType, ScalarType};

use super::attribute::{attribute_value, group_fields, AttributeFields, Attributes, MeshAttribute};
use super::{reserved, TriangleMesh, MAX_INFLATE_RATIO};
use crate::error::MeshError;
use crate::math::{Vec2, Vec3};

/// The longest header read (real headers are a few hundred bytes; comments make some a few kilobytes).
pub const MAX_HEADER_BYTES: u64 = 1 << 20;
/// The longest line of ASCII data (a polygon of 65,536 corners, each up to 15 characters, fits).
pub const MAX_ASCII_LINE: u64 = 1 << 20;

/// Reads a PLY file (ASCII or binary).
pub fn load_ply(path: &Path) -> Result<TriangleMesh, MeshError> {
    load(path, false, &|_| false).map(|(mesh, _)| mesh)
}

/// Reads a gzip-compressed PLY file (`.ply.gz`).
pub fn load_ply_gz(path: &Path) -> Result<TriangleMesh, MeshError> {
    load(path, true, &|_| false).map(|(mesh, _)| mesh)
}

/// Reads a PLY file, gzip-compressed if its name ends with `.gz` (any case), with the attributes whose
/// names `keep` accepts.
pub fn load_ply_with_attributes(path: &Path, keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), MeshError> {
    load(path, path.to_string_lossy().to_ascii_lowercase().ends_with(".gz"), keep)
}

/// Reads a PLY file, gzip-compressed if `gz`, with the attributes `keep` accepts.
fn load(path: &Path, gz: bool, keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), MeshError> {
    let (file, len) = super::open_regular(path)?;
    if gz {
        let bound = DataBound { bytes: len.saturating_mul(MAX_INFLATE_RATIO), inflated: true };
        read_ply_within(BufReader::new(GzDecoder::new(BufReader::new(file.take(len)))), path, bound, keep)
    } else {
        read_ply_within(BufReader::new(file), path, DataBound { bytes: len, inflated: false }, keep)
    }
}

/// Reads PLY data from `reader`; `path` only names the source in errors. Nothing bounds the data but the
/// header's counts and the memory left (for files: [`load_ply`]).
pub fn read_ply<R: BufRead>(reader: R, path: &Path) -> Result<TriangleMesh, MeshError> {
    read_ply_within(reader, path, DataBound { bytes: u64::MAX, inflated: false }, &|_| false).map(|(mesh, _)| mesh)
}

/// [`read_ply`] with the attributes `keep` accepts.
pub fn read_ply_with_attributes<R: BufRead>(reader: R, path: &Path, keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), MeshError> {
    read_ply_within(reader, path, DataBound { bytes: u64::MAX, inflated: false }, keep)
}

/// The most bytes (header included) a source can deliver: a file's size, or what a compressed file can
/// inflate to.
#[derive(Clone, Copy, Debug)]
struct DataBound {
    bytes: u64,
    inflated: bool,
}

/// Reads PLY data of at most `bound` bytes from `reader`.
fn read_ply_within<R: BufRead>(mut reader: R, path: &Path, bound: DataBound, keep: &dyn Fn(&str) -> bool) -> Result<(TriangleMesh, Attributes), MeshError> {
    // ply-rs-bw's messages span several lines ("...\n\tString: '...'\n\tError: ..."): keep them on one.
    let parse_error = |message: String| MeshError::Parse {
        path: path.to_path_buf(),
        message: format!("PLY: {}", message.trim_end().replace("\n\t", "; ").replace('\n', " ")),
    };
    // A PLY file starts with the line `ply`; anything else (binary garbage, another format) is named as
    // such instead of by the header parser's first failure ("stream did not contain valid UTF-8").
    let start = reader.fill_buf().map_err(|e| parse_error(e.to_string()))?;
    // (Only the bytes at hand are compared: a decompressing reader may deliver fewer than four at first.)
    let fits = |magic: &[u8]| start[..start.len().min(magic.len())] == magic[..start.len().min(magic.len())];
    if !(fits(b"ply\n") || fits(b"ply\r\n")) {
        return Err(parse_error("not a PLY file: it must start with the line `ply`".into()));
    }
    let mut reader = Reader::new(reader.take(MAX_HEADER_BYTES));
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| {
        if reader.get_ref().limit() == 0 {
            parse_error(format!("no `end_header` within the first {MAX_HEADER_BYTES} bytes"))
        } else {
            parse_error(e.to_string())
        }
    })?;
    let reader = reader.into_inner();
    let header_bytes = MAX_HEADER_BYTES - reader.limit();
    let reader = reader.into_inner();

    let vertex_def = header
        .elements
        .get("vertex")
        .ok_or_else(|| parse_error("no `vertex` element".into()))?;
    let declared = |name: &str| vertex_def.properties.contains_key(name);
    if !(declared("x") && declared("y") && declared("z")) {
        return Err(parse_error("the `vertex` element lacks one of the properties x, y, z".into()));
    }
    let has_normals = declared("nx") && declared("ny") && declared("nz");
    let uv_names = UV_NAMES.iter().find(|[u, v]| declared(u) && declared(v));
    let face_def = header
        .elements
        .get("face")
        .ok_or_else(|| parse_error("no `face` element (a point cloud?)".into()))?;
    let index_list = face_def
        .properties
        .values()
        .find(|p| is_index_list(&p.name))
        .ok_or_else(|| parse_error("the `face` element has no `vertex_indices` (or `vertex_index`) list".into()))?
        .name
        .clone();
    for element in header.elements.values() {
        for p in element.properties.values() {
            match p.data_type {
                PropertyType::List(ScalarType::Float | ScalarType::Double, _) => {
                    return Err(parse_error(format!("element `{}`: the list `{}` has a floating-point length", element.name, p.name)))
                }
                PropertyType::List(_, ScalarType::Float | ScalarType::Double) if p.name == index_list && element.name == "face" => {
                    return Err(parse_error(format!("the `face` element's `{index_list}` holds floating-point numbers, not vertex indices")))
                }
                _ => {}
            }
        }
    }

    // What the header promises, against what the file can hold and the memory left.
    let (vertex_count, face_count) = (vertex_def.count as u64, face_def.count as u64);
    if u32::try_from(vertex_count).is_err() {
        return Err(parse_error(format!("{vertex_count} vertices is more than 32-bit indices can address")));
    }
    let binary = header.encoding != Encoding::Ascii;
    let promised = header.elements.values().fold(0u64, |sum, e| sum.saturating_add((e.count as u64).saturating_mul(least_row_bytes(e, binary))));
    let data_bound = bound.bytes.saturating_sub(header_bytes);
    if promised > data_bound {
        return Err(parse_error(format!(
            "the header promises {vertex_count} vertices and {face_count} faces, at least {promised} bytes of data, more than {}",
            if bound.inflated {
                format!("the file can hold ({MAX_INFLATE_RATIO} times its {} compressed bytes at most)", bound.bytes / MAX_INFLATE_RATIO)
            } else {
                format!("the {data_bound} bytes after its header")
            }
        )));
    }
    // The attributes (module `attribute`): all named, those asked for kept.
    let scalar_names = |e: &ElementDef| -> Vec<String> {
        e.properties.values().map(|p| if matches!(p.data_type, PropertyType::Scalar(_)) { p.name.clone() } else { String::new() }).collect()
    };
    let vertex_names = scalar_names(vertex_def);
    let face_names = scalar_names(face_def);
    let mut vertex_reserved = vec!["x", "y", "z", "nx", "ny", "nz", "u", "v", ""];
    if let Some([u, v]) = uv_names {
        vertex_reserved.extend([*u, *v]);
    }
    let group = |kind, names: &[String], reserved: &[&str]| group_fields(kind, &names.iter().map(String::as_str).collect::<Vec<_>>(), reserved);
    let vertex_groups = group("vertex_", &vertex_names, &vertex_reserved);
    let face_groups = group("face_", &face_names, &[""]);
    let mut attributes = Attributes { names: vertex_groups.iter().chain(&face_groups).map(|a| a.name.clone()).collect(), kept: Vec::new() };
    let vertex_groups: Vec<AttributeFields> = vertex_groups.into_iter().filter(|a| keep(&a.name)).collect();
    let face_groups: Vec<AttributeFields> = face_groups.into_iter().filter(|a| keep(&a.name)).collect();
    let attribute_bytes = |groups: &[AttributeFields], n: u64| groups.iter().map(|a| a.fields.len() as u64 * 4).sum::<u64>().saturating_mul(n);
    let extra = attribute_bytes(&vertex_groups, vertex_count).saturating_add(attribute_bytes(&face_groups, face_count));
    crate::render::memory::check_mesh(vertex_count, face_count, has_normals, uv_names.is_some(), extra).map_err(parse_error)?;
    // Where each property's value goes: (attribute, component), by the property's position in its element.
    let targets = |groups: &[AttributeFields], n: usize| {
        let mut t = vec![None; n];
        for (k, a) in groups.iter().enumerate() {
            for (c, &f) in a.fields.iter().enumerate() {
                t[f] = Some((k, c));
            }
        }
        t
    };
    let vertex_targets = targets(&vertex_groups, vertex_names.len());
    let face_targets = targets(&face_groups, face_names.len());
    let new_values = |groups: &[AttributeFields], n: u64| -> Result<Vec<MeshAttribute>, MeshError> {
        groups
            .iter()
            .map(|a| {
                let values = reserved(n.saturating_mul(a.fields.len() as u64), "attribute values").map_err(parse_error)?;
                Ok(MeshAttribute { name: a.name.clone(), dim: a.fields.len() as u8, values })
            })
            .collect()
    };
    let mut vertex_values = new_values(&vertex_groups, vertex_count)?;
    let mut face_values = new_values(&face_groups, face_count)?;

    let mut mesh = TriangleMesh {
        positions: reserved(vertex_count, "vertex positions").map_err(parse_error)?,
        indices: reserved(face_count, "triangles").map_err(parse_error)?,
        normals: if has_normals { Some(reserved(vertex_count, "vertex normals").map_err(parse_error)?) } else { None },
        uvs: if uv_names.is_some() { Some(reserved(vertex_count, "vertex uvs").map_err(parse_error)?) } else { None },
    };
    let mut data = Data { reader, left: data_bound, encoding: header.encoding, line: Vec::new(), at: 0 };
    // Elements must be read in the order the header declares them.
    for element in header.elements.values() {
        let context = |i: usize, m: String| parse_error(format!("element `{}` {i}: {m}", element.name));
        match element.name.as_str() {
            "vertex" => {
                let slot = |name: &str| -> Option<usize> {
                    match name {
                        "x" => Some(0),
                        "y" => Some(1),
                        "z" => Some(2),
                        "nx" if has_normals => Some(3),
                        "ny" if has_normals => Some(4),
                        "nz" if has_normals => Some(5),
                        n if uv_names.is_some_and(|[u, _]| *u == n) => Some(6),
                        n if uv_names.is_some_and(|[_, v]| *v == n) => Some(7),
                        _ => None,
                    }
                };
                let slots: Vec<Option<usize>> = element.properties.values().map(|p| slot(&p.name)).collect();
                let mut a = vec![0f32; 4 * vertex_groups.len()];
                for i in 0..element.count {
                    data.begin_element().map_err(|m| context(i, m))?;
                    let mut v = [0f32; 8];
                    for (j, (p, &slot)) in element.properties.values().zip(&slots).enumerate() {
                        match (&p.data_type, slot, vertex_targets[j]) {
                            (PropertyType::Scalar(t), Some(k), _) => v[k] = data.scalar(t).map_err(|m| context(i, m))?.to_f32(),
                            (PropertyType::Scalar(t), None, Some((k, c))) => {
                                let value = data.scalar(t).map_err(|m| context(i, m))?.to_f64();
                                a[k * 4 + c] = attribute_value(value, t);
                            }
                            (t, _, _) => data.skip(t).map_err(|m| context(i, m))?,
                        }
                    }
                    data.end_element().map_err(|m| context(i, m))?;
                    for (k, attribute) in vertex_values.iter_mut().enumerate() {
                        attribute.values.extend_from_slice(&a[k * 4..k * 4 + usize::from(attribute.dim)]);
                    }
                    mesh.positions.push(Vec3::new(v[0], v[1], v[2]));
                    if let Some(n) = &mut mesh.normals {
                        n.push(Vec3::new(v[3], v[4], v[5]));
                    }
                    if let Some(uv) = &mut mesh.uvs {
                        uv.push(Vec2::new(v[6], v[7]));
                    }
                }
            }
            "face" => {
                let mut corners: Vec<u32> = Vec::new();
                let mut a = vec![0f32; 4 * face_groups.len()];
                for face in 0..element.count {
                    data.begin_element().map_err(|m| context(face, m))?;
                    let first_triangle = mesh.indices.len();
                    for (j, p) in element.properties.values().enumerate() {
                        match &p.data_type {
                            PropertyType::Scalar(t) if face_targets[j].is_some() => {
                                let (k, c) = face_targets[j].expect("matched");
                                a[k * 4 + c] = attribute_value(data.scalar(t).map_err(|m| context(face, m))?.to_f64(), t);
                            }
                            PropertyType::List(count_type, item_type) if p.name == index_list => {
                                corners.clear();
                                let n = data.list_len(count_type, item_type).map_err(|m| context(face, m))?;
                                // The fan's triangles beyond the face count: checked against the memory left.
                                let fan = n.saturating_sub(2);
                                let room = (mesh.indices.capacity() - mesh.indices.len()) as u64;
                                if fan > room {
                                    let more = (fan - room).max(mesh.indices.capacity() as u64 / 2);
                                    crate::render::memory::check_mesh(0, more, false, false, 0).map_err(|m| context(face, format!("its polygons make more triangles than the faces: {m}")))?;
                                    mesh.indices.try_reserve(more as usize).map_err(|_| context(face, format!("cannot allocate {more} more triangles: out of memory")))?;
                                }
                                for _ in 0..n {
                                    let i = data.scalar(item_type).map_err(|m| context(face, m))?.to_i64();
                                    let index = u32::try_from(i).ok().filter(|&i| (i as u64) < vertex_count).ok_or_else(|| {
                                        parse_error(format!("face {face} refers to vertex {i}, but there are {vertex_count} vertices"))
                                    })?;
                                    corners.push(index);
                                }
                                if corners.len() < 3 {
                                    return Err(parse_error(format!("face {face} has {} vertices; a face needs at least 3", corners.len())));
                                }
                                mesh.indices.extend(corners.windows(2).skip(1).map(|w| [corners[0], w[0], w[1]]));
                            }
                            t => data.skip(t).map_err(|m| context(face, m))?,
                        }
                    }
                    data.end_element().map_err(|m| context(face, m))?;
                    // One value per triangle of the polygon (its fan).
                    let triangles = mesh.indices.len() - first_triangle;
                    for (k, attribute) in face_values.iter_mut().enumerate() {
                        let value = &a[k * 4..k * 4 + usize::from(attribute.dim)];
                        if triangles > 1 {
                            attribute.values.try_reserve(value.len() * (triangles - 1)).map_err(|_| context(face, "cannot allocate its attribute values: out of memory".into()))?;
                        }
                        for _ in 0..triangles {
                            attribute.values.extend_from_slice(value);
                        }
                    }
                }
            }
            _ => {
                for i in 0..element.count {
                    data.begin_element().map_err(|m| context(i, m))?;
                    for p in element.properties.values() {
                        data.skip(&p.data_type).map_err(|m| context(i, m))?;
                    }
                    data.end_element().map_err(|m| context(i, m))?;
                }
            }
        }
    }
    attributes.kept = vertex_values.into_iter().chain(face_values).collect();
    Ok((mesh, attributes))
}

/// The fewest bytes one element of `e` takes: binary, each scalar's size and each list's length field; ASCII,
/// a character and a separator per scalar and list length.
fn least_row_bytes(e: &ElementDef, binary: bool) -> u64 {
    e.properties
        .values()
        .map(|p| match (&p.data_type, binary) {
            (PropertyType::Scalar(t) | PropertyType::List(t, _), true) => scalar_size(t),
            (_, false) => 2,
        })
        .sum()
}

fn scalar_size(t: &ScalarType) -> u64 {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// One value as its type holds it.
#[derive(Clone, Copy)]
enum Value {
    Int(i64),
    F32(f32),
    F64(f64),
}

impl Value {
    /// As f32: a double rounded to nearest (out-of-range doubles become ±∞, refused by
    /// `TriangleMesh::validate`), an integer converted.
    fn to_f32(self) -> f32 {
        match self {
            Value::Int(i) => i as f32,
            Value::F32(f) => f,
            Value::F64(f) => f as f32,
        }
    }

    /// As f64 (exact for every integer type and float).
    fn to_f64(self) -> f64 {
        match self {
            Value::Int(i) => i as f64,
            Value::F32(f) => f64::from(f),
            Value::F64(f) => f,
        }
    }

    /// As an index: floats are refused by the header check, so only integers reach here.
    fn to_i64(self) -> i64 {
        match self {
            Value::Int(i) => i,
            Value::F32(f) => f as i64,
            Value::F64(f) => f as i64,
        }
    }
}

/// The data after the header: binary values as they come, or ASCII lines of values; `left` bytes at most.
struct Data<R: BufRead> {
    reader: R,
    left: u64,
    encoding: Encoding,
    /// ASCII: the current element's line and the read position in it.
    line: Vec<u8>,
    at: usize,
}

impl<R: BufRead> Data<R> {
    /// ASCII: reads the element's line (at most [`MAX_ASCII_LINE`] bytes).
    fn begin_element(&mut self) -> Result<(), String> {
        if self.encoding != Encoding::Ascii {
            return Ok(());
        }
        self.line.clear();
        self.at = 0;
        let cap = MAX_ASCII_LINE.min(self.left);
        let n = (&mut self.reader).take(cap).read_until(b'\n', &mut self.line).map_err(|e| e.to_string())?;
        self.left -= n as u64;
        if n == 0 {
            return Err("the file ends before this element".into());
        }
        // (A last line may end with the data, without a newline.)
        if self.line.last() != Some(&b'\n') && n as u64 == MAX_ASCII_LINE {
            return Err(format!("a line longer than {MAX_ASCII_LINE} bytes"));
        }
        Ok(())
    }

    /// ASCII: nothing may follow the element's values on its line.
    fn end_element(&mut self) -> Result<(), String> {
        if self.encoding == Encoding::Ascii && self.token()?.is_some() {
            return Err("the line has more values than the element's properties".into());
        }
        Ok(())
    }

    /// ASCII: the next value on the line.
    fn token(&mut self) -> Result<Option<&str>, String> {
        let rest = &self.line[self.at..];
        let Some(start) = rest.iter().position(|b| !b.is_ascii_whitespace()) else { return Ok(None) };
        let len = rest[start..].iter().position(u8::is_ascii_whitespace).unwrap_or(rest.len() - start);
        let (from, to) = (self.at + start, self.at + start + len);
        self.at = to;
        std::str::from_utf8(&self.line[from..to]).map(Some).map_err(|_| "a value is not text".to_string())
    }

    /// Exactly `N` bytes of binary data.
    fn bytes<const N: usize>(&mut self) -> Result<[u8; N], String> {
        if self.left < N as u64 {
            return Err("the data ends within this element (the file is shorter than its header says)".into());
        }
        let mut b = [0u8; N];
        self.reader.read_exact(&mut b).map_err(|e| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => "the file ends within this element (shorter than its header says)".to_string(),
            _ => e.to_string(),
        })?;
        self.left -= N as u64;
        Ok(b)
    }

    /// One value of type `t`.
    fn scalar(&mut self, t: &ScalarType) -> Result<Value, String> {
        macro_rules! binary {
            ($ty:ty, $n:literal) => {{
                let b = self.bytes::<$n>()?;
                if self.encoding == Encoding::BinaryBigEndian {
                    <$ty>::from_be_bytes(b)
                } else {
                    <$ty>::from_le_bytes(b)
                }
            }};
        }
        if self.encoding == Encoding::Ascii {
            let token = self.token()?.ok_or("the line has fewer values than the element's properties")?;
            // (A token is at most a line, up to a megabyte: the error shows its start.)
            let shown: String = token.chars().take(40).collect();
            let bad = |e: &dyn std::fmt::Display| format!("{shown:?}{} is not a {t:?}: {e}", if shown.len() < token.len() { "…" } else { "" });
            return match t {
                ScalarType::Float => token.parse::<f32>().map(Value::F32).map_err(|e| bad(&e)),
                ScalarType::Double => token.parse::<f64>().map(Value::F64).map_err(|e| bad(&e)),
                ScalarType::Char => token.parse::<i8>().map(|v| Value::Int(v.into())).map_err(|e| bad(&e)),
                ScalarType::UChar => token.parse::<u8>().map(|v| Value::Int(v.into())).map_err(|e| bad(&e)),
                ScalarType::Short => token.parse::<i16>().map(|v| Value::Int(v.into())).map_err(|e| bad(&e)),
                ScalarType::UShort => token.parse::<u16>().map(|v| Value::Int(v.into())).map_err(|e| bad(&e)),
                ScalarType::Int => token.parse::<i32>().map(|v| Value::Int(v.into())).map_err(|e| bad(&e)),
                ScalarType::UInt => token.parse::<u32>().map(|v| Value::Int(v.into())).map_err(|e| bad(&e)),
            };
        }
        Ok(match t {
            ScalarType::Char => Value::Int(binary!(i8, 1).into()),
            ScalarType::UChar => Value::Int(binary!(u8, 1).into()),
            ScalarType::Short => Value::Int(binary!(i16, 2).into()),
            ScalarType::UShort => Value::Int(binary!(u16, 2).into()),
            ScalarType::Int => Value::Int(binary!(i32, 4).into()),
            ScalarType::UInt => Value::Int(binary!(u32, 4).into()),
            ScalarType::Float => Value::F32(binary!(f32, 4)),
            ScalarType::Double => Value::F64(binary!(f64, 8)),
        })
    }

    /// A list's length, refused at once when its items cannot fit in the data left.
    fn list_len(&mut self, count_type: &ScalarType, item_type: &ScalarType) -> Result<u64, String> {
        let n = self.scalar(count_type)?.to_i64();
        let n = u64::try_from(n).map_err(|_| format!("a list of length {n}"))?;
        let least = if self.encoding == Encoding::Ascii { 2 } else { scalar_size(item_type) };
        if self.encoding != Encoding::Ascii && n.saturating_mul(least) > self.left {
            return Err(format!("a list of {n} items, more than the {} bytes of data left can hold", self.left));
        }
        Ok(n)
    }

    /// Reads and drops a property's value(s).
    fn skip(&mut self, t: &PropertyType) -> Result<(), String> {
        match t {
            PropertyType::Scalar(s) => self.scalar(s).map(drop),
            PropertyType::List(c, item) => {
                for _ in 0..self.list_len(c, item)? {
                    self.scalar(item)?;
                }
                Ok(())
            }
        }
    }
}

/// Writes `mesh` as a binary little-endian PLY: `x y z` (float), `nx ny nz` and `u v` (float) when the mesh
/// has them, faces as `list uchar int vertex_indices`. [`read_ply`] reads it back exactly.
pub fn write_ply<W: std::io::Write>(mesh: &TriangleMesh, mut w: W) -> std::io::Result<()> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by caustica\nelement vertex {}\n\
property float x\nproperty float y\nproperty float z\n",
        mesh.positions.len()
    );
    if mesh.normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if mesh.uvs.is_some() {
        header.push_str("property float u\nproperty float v\n");
    }
    header.push_str(&format!("element face {}\nproperty list uchar int vertex_indices\nend_header\n", mesh.indices.len()));
    let mut bytes = header.into_bytes();
    for (i, p) in mesh.positions.iter().enumerate() {
        let mut attrs: Vec<f32> = p.to_array().to_vec();
        if let Some(n) = &mesh.normals {
            attrs.extend_from_slice(&n[i].to_array());
        }
        if let Some(uv) = &mesh.uvs {
            attrs.extend_from_slice(&uv[i].to_array());
        }
        for a in attrs {
            bytes.extend_from_slice(&a.to_le_bytes());
        }
    }
    for tri in &mesh.indices {
        bytes.push(3);
        for &i in tri {
            let i = i32::try_from(i).map_err(|_| std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("vertex index {i} does not fit a PLY int")))?;
            bytes.extend_from_slice(&i.to_le_bytes());
        }
    }
    w.write_all(&bytes)
}

/// Property-name pairs read as texture coordinates, in order of preference.
const UV_NAMES: [[&str; 2]; 4] = [["u", "v"], ["s", "t"], ["texture_u", "texture_v"], ["texture_s", "texture_t"]];

fn is_index_list(name: &str) -> bool {
    name == "vertex_indices" || name == "vertex_index"
}

/// The header parser's element type (ply-rs-bw's parser is generic over one; this module reads the data).
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn read(bytes: &[u8]) -> Result<TriangleMesh, MeshError> {
        read_ply(Cursor::new(bytes), Path::new("t.ply"))
    }

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment a quad and a triangle\nelement vertex 5\n\
property double x\nproperty double y\nproperty double z\nproperty float nx\nproperty float ny\nproperty float nz\n\
property float s\nproperty float t\nproperty uchar red\n\
element face 2\nproperty list uchar uint vertex_index\nproperty int flags\n\
element edge 1\nproperty int vertex1\nproperty int vertex2\nend_header\n\
0 0 0 0 0 1 0 0 255\n1 0 0 0 0 1 1 0 0\n1 1 0 0 0 1 1 1 0\n0 1 0 0 0 1 0 1 0\n0.5 0.5 1 0 0 1 0.5 0.5 7\n\
4 0 1 2 3 9\n3 0 1 4 0\n0 1\n";

    #[test]
    fn ascii_with_normals_uvs_quads_and_extra_elements() {
        let mesh = read(ASCII.as_bytes()).unwrap();
        assert_eq!(mesh.positions.len(), 5);
        assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3], [0, 1, 4]]);
        assert_eq!(mesh.positions[4], Vec3::new(0.5, 0.5, 1.0));
        assert_eq!(mesh.normals.as_ref().unwrap()[2], Vec3::Z);
        assert_eq!(mesh.uvs.as_ref().unwrap()[2], Vec2::new(1.0, 1.0));
    }

    fn binary_ply(big_endian: bool, index: i32) -> Vec<u8> {
        let format = if big_endian { "binary_big_endian" } else { "binary_little_endian" };
        let header = format!(
            "ply\nformat {format} 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        );
        let mut bytes = header.into_bytes();
        let f32_bytes = |v: f32| if big_endian { v.to_be_bytes() } else { v.to_le_bytes() };
        for p in [[0.0f32, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 3.0, 0.0], [0.0, 3.0, -1.5]] {
            for c in p {
                bytes.extend_from_slice(&f32_bytes(c));
            }
        }
        bytes.push(4);
        for i in [0, 1, 2, index] {
            bytes.extend_from_slice(&if big_endian { i.to_be_bytes() } else { i.to_le_bytes() });
        }
        bytes
    }

    #[test]
    fn ascii_without_a_last_newline() {
        let text = ASCII.trim_end_matches('\n');
        assert_eq!(read(text.as_bytes()).unwrap().indices.len(), 3);
        // The same within a file's bound: the data ends where the last line does.
        let bound = DataBound { bytes: text.len() as u64, inflated: false };
        assert_eq!(read_ply_within(Cursor::new(text.as_bytes()), Path::new("t.ply"), bound, &|_| false).unwrap().0.indices.len(), 3);
    }

    #[test]
    fn binary_both_endiannesses() {
        for big_endian in [false, true] {
            let mesh = read(&binary_ply(big_endian, 3)).unwrap();
            assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3]]);
            assert_eq!(mesh.positions[3], Vec3::new(0.0, 3.0, -1.5));
            assert!(mesh.normals.is_none() && mesh.uvs.is_none());
        }
    }

    #[test]
    fn write_then_read_is_exact() {
        let sphere = crate::mesh::shapes::sphere(Vec3::new(0.4, -0.35, 0.25), 0.3, 5, 7);
        let mut bytes = Vec::new();
        write_ply(&sphere, &mut bytes).unwrap();
        let back = read(&bytes).unwrap();
        assert_eq!(back.positions, sphere.positions);
        assert_eq!(back.indices, sphere.indices);
        assert_eq!(back.normals, sphere.normals);
        assert_eq!(back.uvs, sphere.uvs);
    }

    #[test]
    fn bad_indices_name_the_face() {
        for index in [4, -1] {
            let err = read(&binary_ply(false, index)).unwrap_err().to_string();
            assert!(err.starts_with("t.ply: ") && err.contains("face 0 refers to vertex"), "{err}");
        }
    }

    #[test]
    fn broken_files_are_errors_not_panics() {
        let full = binary_ply(false, 3);
        let cases: Vec<Vec<u8>> = vec![
            b"".to_vec(),
            b"not a ply file\n".to_vec(),
            full[..full.len() - 3].to_vec(),
            ASCII.replace("4 0 1 2 3 9\n", "2 0 1 9\n").into_bytes(),
            ASCII.replace("4 0 1 2 3 9\n", "4 0 1 zz 3 9\n").into_bytes(),
            ASCII.replace("property double z\n", "").into_bytes(),
            ASCII.replace("element face 2", "element face 5").into_bytes(),
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n".to_vec(),
        ];
        for (i, bytes) in cases.iter().enumerate() {
            let err = read(bytes).expect_err(&format!("case {i}"));
            assert!(err.to_string().starts_with("t.ply: "), "case {i}: {err}");
        }
    }

    const COLOURED: &str = "ply\nformat ascii 1.0\nelement vertex 4\n\
property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
property ushort q_0\nproperty float w_x\nproperty float w_y\n\
element face 2\nproperty list uchar int vertex_indices\nproperty float color_0\nproperty float color_1\nproperty float color_2\n\
property float weight_0\nend_header\n\
0 0 0 255 0 128 65535 1 2\n1 0 0 0 255 0 0 1 2\n1 1 0 0 0 255 32768 1 2\n0 1 0 1 2 3 5000 1 2\n\
4 0 1 2 3 0.5 0.25 1.5 0.75\n3 0 1 2 1 2 3 -1\n";

    #[test]
    fn vertex_colours_and_face_attributes_are_read_as_mitsuba_reads_them() {
        let (mesh, a) = read_ply_with_attributes(Cursor::new(COLOURED.as_bytes()), Path::new("t.ply"), &|_| true).unwrap();
        assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
        // Every attribute is named; `w_x, w_y` (two fields) is not one.
        assert_eq!(a.names, ["vertex_color", "vertex_q", "face_color", "face_weight"]);
        let colour = a.get("vertex_color").unwrap();
        // 8-bit values stay as they are (Mitsuba 3.9.1), in r, g, b order.
        assert_eq!((colour.dim, &colour.values[..6]), (3, &[255.0, 0.0, 128.0, 0.0, 255.0, 0.0][..]));
        let q = a.get("vertex_q").unwrap();
        // 16-bit values scaled to [0, 1] and decoded from sRGB.
        assert_eq!((q.dim, q.values[0], q.values[1]), (1, 1.0, 0.0));
        assert!((q.values[2] / 0.214_048_09 - 1.0).abs() < 5e-6 && (q.values[3] / 0.006_729_608 - 1.0).abs() < 5e-6);
        // A face's value once per triangle of its polygon.
        let face = a.get("face_color").unwrap();
        assert_eq!(face.values, [0.5, 0.25, 1.5, 0.5, 0.25, 1.5, 1.0, 2.0, 3.0]);
        assert_eq!(a.get("face_weight").unwrap().values, [0.75, 0.75, -1.0]);
        // Only what is asked for is kept; every name is still listed.
        let (_, some) = read_ply_with_attributes(Cursor::new(COLOURED.as_bytes()), Path::new("t.ply"), &|n| n == "face_weight").unwrap();
        assert_eq!((some.names.len(), some.kept.len(), some.kept[0].name.as_str()), (4, 1, "face_weight"));
        assert_eq!(read(COLOURED.as_bytes()).unwrap().indices, mesh.indices);
    }

    #[test]
    fn binary_vertex_colours_read_like_ascii() {
        let header = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
property uchar r\nproperty uchar g\nproperty uchar b\nproperty uchar a\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n";
        let mut bytes = header.as_bytes().to_vec();
        for (p, c) in [([0f32, 0.0, 0.0], [10u8, 20, 30, 40]), ([1.0, 0.0, 0.0], [1, 2, 3, 4]), ([0.0, 1.0, 0.0], [5, 6, 7, 8])] {
            p.iter().for_each(|x| bytes.extend_from_slice(&x.to_le_bytes()));
            bytes.extend_from_slice(&c);
        }
        bytes.push(3);
        [0i32, 1, 2].iter().for_each(|i| bytes.extend_from_slice(&i.to_le_bytes()));
        let (_, a) = read_ply_with_attributes(Cursor::new(bytes), Path::new("t.ply"), &|_| true).unwrap();
        let c = a.get("vertex_color").unwrap();
        assert_eq!((c.dim, c.values.len(), c.values[4]), (4, 12, 1.0));
    }
}

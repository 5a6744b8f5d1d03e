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
//! (edges, materials, ...) and other properties are skipped. Out-of-range or negative indices and faces
//! with fewer than three vertices are errors that name the file and the face.
//!
//! [`write_ply`] writes the same subset (binary little endian: positions, normals and uvs if present,
//! `uchar`/`int` index lists), e.g. so that another renderer can load exactly our triangles.

use std::fs::File;
use std::io::{BufRead, BufReader};
use std::path::Path;

use flate2::bufread::GzDecoder;
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{BeginList, ElementDef, Property, PropertyAccess, PropertyAccessResult};

use super::TriangleMesh;
use crate::error::MeshError;
use crate::math::{Vec2, Vec3};

/// Reads a PLY file (ASCII or binary).
pub fn load_ply(path: &Path) -> Result<TriangleMesh, MeshError> {
    let file = File::open(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    read_ply(BufReader::new(file), path)
}

/// Reads a gzip-compressed PLY file (`.ply.gz`).
pub fn load_ply_gz(path: &Path) -> Result<TriangleMesh, MeshError> {
    let file = File::open(path).map_err(|error| MeshError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    read_ply(BufReader::new(GzDecoder::new(BufReader::new(file))), path)
}

/// Reads PLY data from `reader`; `path` only names the source in errors.
pub fn read_ply<R: BufRead>(reader: R, path: &Path) -> Result<TriangleMesh, MeshError> {
    // ply-rs-bw's messages span several lines ("...\n\tString: '...'\n\tError: ..."): keep them on one.
    let parse_error = |message: String| MeshError::Parse {
        path: path.to_path_buf(),
        message: format!("PLY: {}", message.trim_end().replace("\n\t", "; ").replace('\n', " ")),
    };
    let mut reader = Reader::new(reader);
    let header = Parser::<Skip>::new()
        .read_header(&mut reader)
        .map_err(|e| parse_error(e.to_string()))?;

    let vertex_def = header
        .elements
        .get("vertex")
        .ok_or_else(|| parse_error("no `vertex` element".into()))?;
    let declared = |name: &str| vertex_def.properties.contains_key(name);
    if !(declared("x") && declared("y") && declared("z")) {
        return Err(parse_error("the `vertex` element lacks one of the properties x, y, z".into()));
    }
    let has_normals = declared("nx") && declared("ny") && declared("nz");
    let has_uvs = UV_NAMES.iter().any(|[u, v]| declared(u) && declared(v));
    let face_def = header
        .elements
        .get("face")
        .ok_or_else(|| parse_error("no `face` element (a point cloud?)".into()))?;
    if !face_def.properties.keys().any(|k| is_index_list(k)) {
        return Err(parse_error(
            "the `face` element has no `vertex_indices` (or `vertex_index`) list".into(),
        ));
    }

    // Elements must be read in the order the header declares them.
    let mut vertices: Vec<PlyVertex> = Vec::new();
    let mut faces: Vec<PlyFace> = Vec::new();
    for element in header.elements.values() {
        let context = |e: ply_rs_bw::parser::ParseError| parse_error(format!("element `{}`: {e}", element.name));
        match element.name.as_str() {
            "vertex" => {
                vertices = Parser::<PlyVertex>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(context)?
            }
            "face" => {
                faces = Parser::<PlyFace>::new()
                    .read_payload_for_element(&mut reader, element, &header)
                    .map_err(context)?
            }
            _ => skip_element(&mut reader, element, &header).map_err(context)?,
        }
    }

    let vertex_count = vertices.len();
    if u32::try_from(vertex_count).is_err() {
        return Err(parse_error(format!(
            "{vertex_count} vertices is more than 32-bit indices can address"
        )));
    }
    let mut mesh = TriangleMesh {
        positions: vertices.iter().map(|v| Vec3::from_array(v.position)).collect(),
        indices: Vec::with_capacity(faces.len()),
        normals: has_normals.then(|| vertices.iter().map(|v| Vec3::from_array(v.normal)).collect()),
        uvs: has_uvs.then(|| vertices.iter().map(|v| Vec2::from_array(v.uv)).collect()),
    };
    drop(vertices);

    let mut corners: Vec<u32> = Vec::new();
    for (face, f) in faces.iter().enumerate() {
        corners.clear();
        let out_of_range = |index: i64| {
            parse_error(format!(
                "face {face} refers to vertex {index}, but there are {vertex_count} vertices"
            ))
        };
        // A face reads its list into `signed` or `unsigned` depending on the declared type.
        for &i in &f.signed {
            let index = u32::try_from(i).map_err(|_| out_of_range(i64::from(i)))?;
            corners.push(index);
        }
        corners.extend_from_slice(&f.unsigned);
        if let Some(&bad) = corners.iter().find(|&&i| i as usize >= vertex_count) {
            return Err(out_of_range(i64::from(bad)));
        }
        if corners.len() < 3 {
            return Err(parse_error(format!(
                "face {face} has {} vertices; a face needs at least 3",
                corners.len()
            )));
        }
        mesh.indices.extend(corners.windows(2).skip(1).map(|w| [corners[0], w[0], w[1]]));
    }
    Ok(mesh)
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

/// One PLY vertex: the attributes we keep (absent ones stay zero and are dropped by the header check).
#[derive(Default)]
struct PlyVertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
}

impl PlyVertex {
    fn slot(&mut self, name: &str) -> Option<&mut f32> {
        match name {
            "x" => Some(&mut self.position[0]),
            "y" => Some(&mut self.position[1]),
            "z" => Some(&mut self.position[2]),
            "nx" => Some(&mut self.normal[0]),
            "ny" => Some(&mut self.normal[1]),
            "nz" => Some(&mut self.normal[2]),
            "u" | "s" | "texture_u" | "texture_s" => Some(&mut self.uv[0]),
            "v" | "t" | "texture_v" | "texture_t" => Some(&mut self.uv[1]),
            _ => None,
        }
    }
}

impl PropertyAccess for PlyVertex {
    fn new() -> Self {
        Self::default()
    }

    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        match self.slot(name) {
            Some(slot) => {
                *slot = value;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::Ignored,
        }
    }

    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        // Out-of-range doubles become ±∞ here and are rejected by `TriangleMesh::validate`.
        self.set_float(name, value as f32)
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        match (self.slot(name), property.to_f32_lossy()) {
            (Some(slot), Some(value)) => {
                *slot = value;
                PropertyAccessResult::Set
            }
            (Some(_), None) => PropertyAccessResult::UnsupportedType,
            (None, _) => PropertyAccessResult::Ignored,
        }
    }
}

/// One PLY face: its vertex list, in `signed` or `unsigned` depending on the declared list type.
#[derive(Default)]
struct PlyFace {
    signed: Vec<i32>,
    unsigned: Vec<u32>,
}

impl PropertyAccess for PlyFace {
    fn new() -> Self {
        Self::default()
    }

    fn begin_list_int(&mut self, name: &str, _len: usize) -> BeginList<'_, i32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.signed)
        } else {
            BeginList::UseSetter
        }
    }

    fn begin_list_uint(&mut self, name: &str, _len: usize) -> BeginList<'_, u32> {
        if is_index_list(name) {
            BeginList::Fill(&mut self.unsigned)
        } else {
            BeginList::UseSetter
        }
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        if !is_index_list(name) {
            return PropertyAccessResult::Ignored;
        }
        match property {
            Property::ListChar(v) => self.signed = v.into_iter().map(i32::from).collect(),
            Property::ListUChar(v) => self.signed = v.into_iter().map(i32::from).collect(),
            Property::ListShort(v) => self.signed = v.into_iter().map(i32::from).collect(),
            Property::ListUShort(v) => self.signed = v.into_iter().map(i32::from).collect(),
            Property::ListInt(v) => self.signed = v,
            Property::ListUInt(v) => self.unsigned = v,
            _ => return PropertyAccessResult::UnsupportedType,
        }
        PropertyAccessResult::Set
    }
}

/// An element we do not use; every property is parsed and dropped.
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

fn skip_element<R: BufRead>(
    reader: &mut Reader<R>,
    element: &ElementDef,
    header: &ply_rs_bw::ply::Header,
) -> Result<(), ply_rs_bw::parser::ParseError> {
    Parser::<Skip>::new().read_payload_for_element(reader, element, header).map(drop)
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
}

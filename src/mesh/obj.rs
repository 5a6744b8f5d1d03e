//! Wavefront OBJ reading through tobj.
//!
//! Faces are triangulated (fans) and every vertex gets one index shared by its position, normal and uv
//! (`single_index`), so the result is directly a [`TriangleMesh`]. All objects and groups in the file
//! are merged into one mesh. Normals (uvs) are kept only if every vertex of every object has one;
//! materials (`mtllib`/`usemtl`) are ignored here: the scene file assigns materials.
//!
//! OBJ has no header: the file (a regular file, read no further than its size) is read into memory, its
//! `f` lines' corners counted, and the mesh they can make (at most one vertex per corner, a fan's
//! triangles per face) checked against the memory left (`render::memory::check_mesh`, with the text and
//! tobj's own arrays besides) before tobj parses it.

use std::io::{BufRead, Read};
use std::path::Path;

use super::TriangleMesh;
use crate::error::MeshError;
use crate::math::{Vec2, Vec3};

/// Reads an OBJ file into one triangle mesh (not yet validated; [`super::load_mesh`] validates).
pub fn load_obj(path: &Path) -> Result<TriangleMesh, MeshError> {
    let (file, len) = super::open_regular(path)?;
    let parse_error = |message: String| MeshError::Parse { path: path.to_path_buf(), message: format!("OBJ: {message}") };
    let mut text: Vec<u8> = super::reserved(len, "bytes of text").map_err(parse_error)?;
    file.take(len).read_to_end(&mut text).map_err(|error| MeshError::Io { path: path.to_path_buf(), error })?;
    let (corners, triangles) = count_faces(&text);
    // tobj's arrays: a position, normal and uv per vertex, an index per corner, besides the text.
    let tobj_bytes = corners.saturating_mul(4 * (3 + 3 + 2 + 1));
    crate::render::memory::check_mesh(corners, triangles, true, true, (text.len() as u64).saturating_add(tobj_bytes)).map_err(parse_error)?;
    read_obj(&mut std::io::Cursor::new(text), path)
}

/// The corners of an OBJ text's faces (`f` lines) and the triangles their fans make.
fn count_faces(text: &[u8]) -> (u64, u64) {
    let (mut corners, mut triangles) = (0u64, 0u64);
    for line in text.split(|&b| b == b'\n') {
        let line = line.trim_ascii_start();
        if let Some(rest) = line.strip_prefix(b"f") {
            if rest.first().is_some_and(u8::is_ascii_whitespace) {
                let n = rest.split(u8::is_ascii_whitespace).filter(|t| !t.is_empty()).count() as u64;
                corners += n;
                triangles += n.saturating_sub(2);
            }
        }
    }
    (corners, triangles)
}

/// Reads OBJ text from `reader`; `path` only names the source in errors.
pub fn read_obj<R: BufRead>(reader: &mut R, path: &Path) -> Result<TriangleMesh, MeshError> {
    // `..Default::default()` covers the fields that exist only with tobj's `merging`/`reordering` features.
    #[allow(clippy::needless_update)]
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
        ..Default::default()
    };
    // Materials are not read: the loader refuses every material library, which tobj records and skips.
    let (models, _materials) =
        tobj::load_obj_buf(reader, &options, |_| Err(tobj::LoadError::OpenFileFailed)).map_err(|e| MeshError::Parse {
            path: path.to_path_buf(),
            message: match e {
                tobj::LoadError::ReadError => "OBJ: not a text file (a line is not valid UTF-8) or the read failed".to_string(),
                e => format!("OBJ: {e}"),
            },
        })?;

    let mut mesh = TriangleMesh::default();
    for model in &models {
        let m = &model.mesh;
        if m.indices.is_empty() {
            continue;
        }
        let parse_error = |message: String| MeshError::Parse {
            path: path.to_path_buf(),
            message: format!("OBJ object '{}': {message}", model.name),
        };
        if m.positions.len() % 3 != 0 || m.indices.len() % 3 != 0 {
            return Err(parse_error(format!(
                "{} position floats and {} indices after triangulation",
                m.positions.len(),
                m.indices.len()
            )));
        }
        let vertex_count = m.positions.len() / 3;
        let positions: Vec<Vec3> = m.positions.chunks_exact(3).map(Vec3::from_slice).collect();
        let normals = (m.normals.len() == 3 * vertex_count).then(|| m.normals.chunks_exact(3).map(Vec3::from_slice).collect());
        let uvs = (m.texcoords.len() == 2 * vertex_count).then(|| m.texcoords.chunks_exact(2).map(Vec2::from_slice).collect());
        let indices = m.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        let part = TriangleMesh { positions, indices, normals, uvs };
        // The first object is moved, not copied (what `append` to an empty mesh would make).
        if mesh.positions.is_empty() {
            mesh = part;
        } else {
            mesh.append(&part);
        }
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn read(text: &str) -> Result<TriangleMesh, MeshError> {
        read_obj(&mut Cursor::new(text.as_bytes()), Path::new("test.obj"))
    }

    #[test]
    fn quads_and_pentagons_become_fans() {
        let mesh = read("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 0.5 0\nf 1 2 3 4\nf 1 4 5\nf 1 2 3 4 5\n").unwrap();
        assert_eq!(mesh.triangle_count(), 2 + 1 + 3);
        assert!(mesh.normals.is_none() && mesh.uvs.is_none());
        // Every triangle of the planar input has the same winding as its polygon (+z).
        for i in 0..mesh.triangle_count() {
            let [a, b, c] = mesh.triangle(i);
            assert!((b - a).cross(c - a).z >= 0.0, "triangle {i}");
        }
    }

    #[test]
    fn normals_and_uvs_share_the_position_index() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nvn 0 0 -1\nf 1/1/1 2/2/1 3/3/1\nf 1/1/2 3/3/2 2/2/2\n";
        let mesh = read(text).unwrap();
        assert_eq!(mesh.triangle_count(), 2);
        // The same position with two different normals becomes two vertices.
        assert_eq!(mesh.positions.len(), 6);
        let normals = mesh.normals.as_ref().unwrap();
        let uvs = mesh.uvs.as_ref().unwrap();
        for (t, expected_n) in mesh.indices.iter().zip([Vec3::Z, -Vec3::Z]) {
            for &i in t {
                assert_eq!(normals[i as usize], expected_n);
                let p = mesh.positions[i as usize];
                assert_eq!(uvs[i as usize], Vec2::new(p.x, p.y));
            }
        }
    }

    #[test]
    fn objects_merge_and_partial_normals_are_dropped() {
        let text = "o a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\no b\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n";
        let mesh = read(text).unwrap();
        assert_eq!(mesh.triangle_count(), 2);
        assert_eq!(mesh.positions.len(), 6);
        assert!(mesh.normals.is_none());
        assert_eq!(mesh.triangle(1)[0], Vec3::new(0.0, 0.0, 1.0));
    }

    #[test]
    fn faces_are_counted_before_parsing() {
        assert_eq!(count_faces(b"v 0 0 0\nf 1 2 3 4\n  f\t1/1 2/2 3/3\nfo 1 2 3\n# f 1 2 3\nf 1 2\n"), (9, 3));
    }

    #[test]
    fn broken_files_are_errors() {
        for text in [
            "v 0 0 0\nv 1 0 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 x\nv 0 1 0\nf 1 2 3\n",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -7\n",
            "v 0 0 0\nf 0 1 1\n",
        ] {
            let err = read(text).expect_err(text);
            assert!(err.to_string().starts_with("test.obj: "), "{err}");
        }
    }
}

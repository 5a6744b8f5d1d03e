//! `load_mesh` on real files: every format through the file system, the shipped assets, and broken
//! input (errors that name the file, never panics).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};

use caustica::error::MeshError;
use caustica::math::Vec3;
use caustica::mesh::load_mesh;

/// A fresh directory under the system temp dir, unique per process and call.
fn temp_dir() -> PathBuf {
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let dir = std::env::temp_dir().join(format!(
        "caustica-mesh-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

const PLY_ASCII: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n2 0 0\n2 3 0\n0 3 -1.5\n4 0 1 2 3\n";

fn ply_binary_le() -> Vec<u8> {
    ply_binary_le_with_y2(3.0)
}

/// The binary quad with vertex 2's y coordinate set to `y2`.
fn ply_binary_le_with_y2(y2: f64) -> Vec<u8> {
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\nproperty double y\nproperty double z\n\
element face 1\nproperty list uchar uint vertex_indices\nend_header\n"
        .to_vec();
    for p in [[0.0f64, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, y2, 0.0], [0.0, 3.0, -1.5]] {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    bytes.push(4);
    for i in [0u32, 1, 2, 3] {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    bytes
}

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(bytes).unwrap();
    enc.finish().unwrap()
}

fn assert_quad(path: &Path) {
    let mesh = load_mesh(path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mesh.indices, vec![[0, 1, 2], [0, 2, 3]], "{}", path.display());
    assert_eq!(mesh.positions[3], Vec3::new(0.0, 3.0, -1.5));
}

#[test]
fn every_format_through_the_file_system() {
    let dir = temp_dir();
    assert_quad(&write(&dir, "quad.obj", b"v 0 0 0\nv 2 0 0\nv 2 3 0\nv 0 3 -1.5\nf 1 2 3 4\n"));
    assert_quad(&write(&dir, "quad.ply", PLY_ASCII.as_bytes()));
    assert_quad(&write(&dir, "quad_le.ply", &ply_binary_le()));
    assert_quad(&write(&dir, "quad.ply.gz", &gzip(PLY_ASCII.as_bytes())));
    assert_quad(&write(&dir, "quad_le.ply.gz", &gzip(&ply_binary_le())));
    // Extensions are matched case-insensitively.
    assert_quad(&write(&dir, "QUAD.PLY.GZ", &gzip(PLY_ASCII.as_bytes())));
    assert_quad(&write(&dir, "Quad.Obj", b"v 0 0 0\nv 2 0 0\nv 2 3 0\nv 0 3 -1.5\nf 1 2 3 4\n"));
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn shipped_models_load() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/assets/models");
    let bunny = load_mesh(&root.join("bunny_lowres.obj")).unwrap();
    assert_eq!((bunny.positions.len(), bunny.triangle_count()), (1839, 3674));
    assert!(bunny.normals.is_none());
    let teapot = load_mesh(&root.join("teapot.obj")).unwrap();
    assert_eq!(teapot.triangle_count(), 16_256);
    let normals = teapot.normals.as_ref().expect("the teapot has vertex normals");
    assert!(normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-3));
    let b = teapot.bounds();
    assert!((b.min.y + 1.0).abs() < 1e-3 && (b.max.y - 1.0).abs() < 1e-3, "{b:?}");
}

#[test]
fn broken_files_are_errors_that_name_the_file() {
    let dir = temp_dir();
    let huge_ply = PLY_ASCII
        .replace("property float x", "property double x")
        .replace("2 3 0\n", "1e300 3 0\n");
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("nan.ply", ply_binary_le_with_y2(f64::NAN)),
        ("nan_ascii.ply", PLY_ASCII.replace("2 3 0\n", "2 nan 0\n").into_bytes()),
        ("huge.ply", huge_ply.into_bytes()),
        ("inf.obj", b"v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n".to_vec()),
        ("range.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n".to_vec()),
        ("range.ply", PLY_ASCII.replace("4 0 1 2 3\n", "4 0 1 2 4\n").into_bytes()),
        ("empty.obj", b"# nothing\n".to_vec()),
        ("empty.ply", Vec::new()),
        ("truncated.ply", ply_binary_le()[..ply_binary_le().len() - 5].to_vec()),
        ("notgzip.ply.gz", PLY_ASCII.as_bytes().to_vec()),
        ("truncated.ply.gz", gzip(PLY_ASCII.as_bytes())[..40].to_vec()),
        ("binary.obj", vec![0xff, 0xfe, 0x00, 0x80, 0x10]),
        ("mesh.stl", b"solid x\nendsolid x\n".to_vec()),
    ];
    for (name, bytes) in &cases {
        let path = write(&dir, name, bytes);
        let err = load_mesh(&path).expect_err(name);
        let message = err.to_string();
        assert!(message.contains(&path.display().to_string()), "{name}: {message}");
    }
    // The error kinds of the cases with a specific variant.
    assert!(matches!(
        load_mesh(&dir.join("nan.ply")),
        Err(MeshError::NonFinite { vertex: 2, .. })
    ));
    assert!(matches!(
        load_mesh(&dir.join("inf.obj")),
        Err(MeshError::NonFinite { vertex: 1, .. })
    ));
    assert!(matches!(load_mesh(&dir.join("empty.obj")), Err(MeshError::NoTriangles { .. })));
    assert!(matches!(load_mesh(&dir.join("mesh.stl")), Err(MeshError::UnsupportedFormat { .. })));
    // Garbage says what is wrong (issue 13: "read error", "stream did not contain valid UTF-8").
    let garbage: Vec<u8> = (0..300u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 13) as u8).collect();
    let garbage_obj = write(&dir, "garbage.obj", &garbage);
    let msg = load_mesh(&garbage_obj).unwrap_err().to_string();
    assert!(msg.contains("not a text file"), "{msg}");
    let garbage_ply = write(&dir, "garbage.ply", &garbage);
    let msg = load_mesh(&garbage_ply).unwrap_err().to_string();
    assert!(msg.contains("not a PLY file: it must start with the line `ply`"), "{msg}");
    let missing = dir.join("missing.ply");
    assert!(matches!(load_mesh(&missing), Err(MeshError::Io { .. })));
    std::fs::remove_dir_all(dir).unwrap();
}

/// The Stanford dragon from `scripts/fetch-dragon` (not committed, so run on demand:
/// `scripts/fetch-dragon && cargo test --release --test suite -- --ignored mesh_load::`).
#[test]
#[ignore = "needs build/dragon from scripts/fetch-dragon"]
fn fetched_dragons_load() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("build/dragon");
    for (name, vertices, triangles) in [
        ("dragon_vrip_res4.ply.gz", 5_205, 11_102),
        ("dragon_vrip_res3.ply.gz", 22_998, 47_794),
        ("dragon_vrip_res2.ply.gz", 100_250, 202_520),
        ("dragon_vrip.ply.gz", 437_645, 871_414),
    ] {
        let start = std::time::Instant::now();
        let mesh = load_mesh(&dir.join(name)).unwrap_or_else(|e| panic!("{e} (run scripts/fetch-dragon first)"));
        eprintln!(
            "{name}: {} triangles in {:.2} s",
            mesh.triangle_count(),
            start.elapsed().as_secs_f64()
        );
        assert_eq!((mesh.positions.len(), mesh.triangle_count()), (vertices, triangles));
    }
}

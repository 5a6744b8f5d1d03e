//! Built-in shapes as triangle meshes, in Mitsuba's canonical frames (before `to_world`).
//!
//! - [`rectangle`]: the square [-1,1]² in the xy-plane, facing +z (2 triangles).
//! - [`cube`]: the cube [-1,1]³, outward faces, flat normals (12 triangles, 24 vertices), Mitsuba's uvs.
//! - [`sphere`]: a closed UV sphere, watertight in its positions, smooth normals, Mitsuba's uvs.
//! - [`disk`]: the unit disk at z = 0 facing +z, a fan of `segments` triangles, Mitsuba's uvs.
//! - [`cylinder`]: the open unit cylinder from z = 0 to z = 1 (radius 1), outward normals, Mitsuba's uvs.
//!
//! Triangles wind counter-clockwise seen from the side their normal points to, so the geometric
//! normal `(p1 − p0) × (p2 − p0)` is the outward/front normal.

use super::TriangleMesh;
use crate::math::{Vec2, Vec3};

/// The square [-1,1]² at z = 0 facing +z.
#[must_use]
pub fn rectangle() -> TriangleMesh {
    TriangleMesh {
        positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: Some(vec![Vec3::Z; 4]),
        uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)]),
    }
}

/// The cube [-1,1]³ with outward-facing flat faces: Mitsuba's `cube` mesh (src/shapes/cube.cpp), its 24
/// vertices, their uvs (each face onto [0, 1]²) and its 12 triangles as Mitsuba lists them.
#[must_use]
pub fn cube() -> TriangleMesh {
    const P: [[f32; 3]; 24] = [
        [1.0, -1.0, -1.0], [1.0, -1.0, 1.0], [-1.0, -1.0, 1.0], [-1.0, -1.0, -1.0],
        [1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0],
        [1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [1.0, -1.0, 1.0],
        [1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, -1.0, 1.0],
        [-1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, -1.0],
        [1.0, 1.0, -1.0], [1.0, -1.0, -1.0], [-1.0, -1.0, -1.0], [-1.0, 1.0, -1.0],
    ];
    const N: [[f32; 3]; 6] = [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    const UV: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let mut indices = Vec::with_capacity(12);
    for face in 0..6u32 {
        let b = 4 * face;
        indices.push([b, b + 1, b + 2]);
        indices.push([b + 3, b, b + 2]);
    }
    TriangleMesh {
        positions: P.iter().map(|&p| Vec3::from_array(p)).collect(),
        indices,
        normals: Some((0..24).map(|i| Vec3::from_array(N[i / 4])).collect()),
        uvs: Some((0..24).map(|i| Vec2::from_array(UV[i % 4])).collect()),
    }
}

/// A closed UV sphere with `rings` latitude bands (≥ 2) and `segments` longitude bands (≥ 3), its poles on
/// ±z and its uvs Mitsuba's (`sphere.cpp`: `u = φ/2π` with `φ = atan2(y, x)` in [0, 2π), `v = θ/π` with `θ`
/// from +z). The seam (`φ = 0`, where `u` jumps from 1 to 0) and the poles (where `u` is undefined) have a
/// vertex per band, at bit-identical positions, so the mesh is watertight in its positions while each
/// triangle's uvs are continuous; pole vertices take the `u` of their band's middle. Normals are the exact
/// sphere normals at the vertices.
#[must_use]
pub fn sphere(center: Vec3, radius: f32, rings: u32, segments: u32) -> TriangleMesh {
    use std::f32::consts::{PI, TAU};
    let rings = rings.max(2);
    let segments = segments.max(3);
    let columns = segments + 1;
    let vertex_count = ((rings - 1) * columns + 2 * segments) as usize;
    let mut positions = Vec::with_capacity(vertex_count);
    let mut normals = Vec::with_capacity(vertex_count);
    let mut uvs = Vec::with_capacity(vertex_count);
    for s in 0..segments {
        positions.push(center + radius * Vec3::Z);
        normals.push(Vec3::Z);
        uvs.push(Vec2::new((s as f32 + 0.5) / segments as f32, 0.0));
    }
    for r in 1..rings {
        let theta = PI * r as f32 / rings as f32;
        let row = positions.len();
        for s in 0..columns {
            // The seam's second column repeats the first's position and normal bit for bit.
            let (p, n) = if s == segments {
                (positions[row], normals[row])
            } else {
                let phi = TAU * s as f32 / segments as f32;
                let n = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos());
                (center + radius * n, n)
            };
            positions.push(p);
            normals.push(n);
            uvs.push(Vec2::new(s as f32 / segments as f32, r as f32 / rings as f32));
        }
    }
    let south = positions.len() as u32;
    for s in 0..segments {
        positions.push(center - radius * Vec3::Z);
        normals.push(-Vec3::Z);
        uvs.push(Vec2::new((s as f32 + 0.5) / segments as f32, 1.0));
    }
    let ring = |r: u32, s: u32| segments + (r - 1) * columns + s;
    let mut indices = Vec::with_capacity((2 * segments * (rings - 1)) as usize);
    for s in 0..segments {
        indices.push([s, ring(1, s), ring(1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
            indices.push([a, d, b]);
            indices.push([a, c, d]);
        }
    }
    for s in 0..segments {
        indices.push([south + s, ring(rings - 1, s + 1), ring(rings - 1, s)]);
    }
    TriangleMesh { positions, indices, normals: Some(normals), uvs: Some(uvs) }
}

/// The point at angle `2π·s/segments` on the unit circle, the seam `s = segments` bit-identical to `s = 0`.
fn circle(s: u32, segments: u32) -> (f32, f32) {
    let phi = std::f32::consts::TAU * (s % segments) as f32 / segments as f32;
    (phi.cos(), phi.sin())
}

/// The unit disk at z = 0 facing +z as a fan of `segments` (≥ 3) triangles, with Mitsuba's uvs (`disk.cpp`:
/// `u = r`, `v = φ/2π` with `φ` in [0, 2π)). As on the sphere, the seam (`φ = 0`, where `v` jumps from 1 to
/// 0) and the centre (where `v` is undefined) have a vertex per triangle at bit-identical positions, the
/// centre's `v` that of its triangle's middle.
#[must_use]
pub fn disk(segments: u32) -> TriangleMesh {
    let segments = segments.max(3);
    let n = segments as usize;
    let mut positions = Vec::with_capacity(2 * n + 1);
    let mut uvs = Vec::with_capacity(2 * n + 1);
    for s in 0..segments {
        positions.push(Vec3::ZERO);
        uvs.push(Vec2::new(0.0, (s as f32 + 0.5) / segments as f32));
    }
    for s in 0..=segments {
        let (c, si) = circle(s, segments);
        positions.push(Vec3::new(c, si, 0.0));
        uvs.push(Vec2::new(1.0, s as f32 / segments as f32));
    }
    let indices = (0..segments).map(|s| [s, segments + s, segments + s + 1]).collect();
    TriangleMesh { normals: Some(vec![Vec3::Z; positions.len()]), positions, indices, uvs: Some(uvs) }
}

/// The open cylinder of radius 1 around the z axis from z = 0 to z = 1, `segments` (≥ 3) quads of two
/// triangles, outward normals (exact at the vertices) and Mitsuba's uvs (`cylinder.cpp`: `u = φ/2π` with
/// `φ` in [0, 2π), `v = z`); the seam column repeated at bit-identical positions.
#[must_use]
pub fn cylinder(segments: u32) -> TriangleMesh {
    let segments = segments.max(3);
    let mut positions = Vec::with_capacity(2 * (segments as usize + 1));
    let mut normals = Vec::with_capacity(positions.capacity());
    let mut uvs = Vec::with_capacity(positions.capacity());
    for s in 0..=segments {
        let (c, si) = circle(s, segments);
        for z in [0.0, 1.0] {
            positions.push(Vec3::new(c, si, z));
            normals.push(Vec3::new(c, si, 0.0));
            uvs.push(Vec2::new(s as f32 / segments as f32, z));
        }
    }
    let mut indices = Vec::with_capacity(2 * segments as usize);
    for s in 0..segments {
        let (b0, t0, b1, t1) = (2 * s, 2 * s + 1, 2 * s + 2, 2 * s + 3);
        indices.push([b0, b1, t1]);
        indices.push([b0, t1, t0]);
    }
    TriangleMesh { positions, indices, normals: Some(normals), uvs: Some(uvs) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometric_normal(m: &TriangleMesh, i: usize) -> Vec3 {
        let [p0, p1, p2] = m.triangle(i);
        (p1 - p0).cross(p2 - p0)
    }

    #[test]
    fn faces_point_outward_and_areas_are_right() {
        let r = rectangle();
        assert!(geometric_normal(&r, 0).normalize().abs_diff_eq(Vec3::Z, 1e-6));
        let area: f32 = (0..2).map(|i| 0.5 * geometric_normal(&r, i).length()).sum();
        assert!((area - 4.0).abs() < 1e-5);

        let c = cube();
        for i in 0..c.triangle_count() {
            let [p0, p1, p2] = c.triangle(i);
            let centroid = (p0 + p1 + p2) / 3.0;
            assert!(geometric_normal(&c, i).dot(centroid) > 0.0, "cube triangle {i} faces inward");
        }

        let s = sphere(Vec3::new(1.0, 2.0, 3.0), 2.0, 64, 128);
        let mut area = 0.0f64;
        for i in 0..s.triangle_count() {
            let [p0, p1, p2] = s.triangle(i);
            let g = geometric_normal(&s, i);
            assert!(g.dot((p0 + p1 + p2) / 3.0 - Vec3::new(1.0, 2.0, 3.0)) > 0.0, "sphere triangle {i} faces inward");
            area += 0.5 * f64::from(g.length());
        }
        let exact = 4.0 * std::f64::consts::PI * 4.0;
        assert!((area - exact).abs() / exact < 2e-3, "area {area} vs {exact}");

        let d = disk(256);
        let area: f32 = (0..d.triangle_count()).map(|i| 0.5 * geometric_normal(&d, i).length()).sum();
        assert!((0..d.triangle_count()).all(|i| geometric_normal(&d, i).z > 0.0));
        assert!((area - std::f32::consts::PI).abs() < 1e-3, "disk area {area}");

        let c = cylinder(256);
        let mut area = 0.0;
        for i in 0..c.triangle_count() {
            let [p0, p1, p2] = c.triangle(i);
            let centroid = (p0 + p1 + p2) / 3.0;
            let g = geometric_normal(&c, i);
            assert!(g.dot(Vec3::new(centroid.x, centroid.y, 0.0)) > 0.0, "cylinder triangle {i} faces inward");
            area += 0.5 * g.length();
        }
        assert!((area - std::f32::consts::TAU).abs() < 1e-3, "cylinder area {area}");
    }

    #[test]
    fn disk_and_cylinder_uvs_are_mitsubas_and_their_seams_close() {
        use std::f32::consts::TAU;
        // (mesh, which uv coordinate is the angle φ/2π)
        for (m, angle) in [(disk(12), 1), (cylinder(12), 0)] {
            let uvs = m.uvs.as_ref().unwrap();
            for t in &m.indices {
                // Within a triangle the angle coordinate runs continuously (no jump across the seam).
                let a = t.map(|k| uvs[k as usize][angle]);
                assert!(a.iter().all(|x| (x - a[0]).abs() <= 1.0 / 12.0 + 1e-6), "{t:?}");
            }
            for (p, uv) in m.positions.iter().zip(uvs) {
                if p.truncate().length() > 0.5 {
                    let phi = p.y.atan2(p.x).rem_euclid(TAU) / TAU;
                    assert!((uv[angle] - phi).abs() < 1e-5 || (uv[angle] - phi - 1.0).abs() < 1e-5, "{p} {uv}");
                }
            }
        }
        let d = disk(12);
        assert_eq!(d.positions[12], d.positions[24], "the disk's seam vertices are one position");
        assert!(d.positions.iter().zip(d.uvs.as_ref().unwrap()).all(|(p, uv)| (uv.x - p.length()).abs() < 1e-6));
        let c = cylinder(12);
        assert_eq!(c.positions[0], c.positions[24], "the cylinder's seam vertices are one position");
        assert!(c.positions.iter().zip(c.uvs.as_ref().unwrap()).all(|(p, uv)| uv.y == p.z));
    }

    #[test]
    fn sphere_is_closed() {
        // Every undirected edge, by its end points' positions bit for bit, is shared by exactly two triangles
        // (the seam and the poles repeat vertices for their uvs, at identical positions).
        let s = sphere(Vec3::ZERO, 1.0, 7, 9);
        let key = |i: u32| s.positions[i as usize].to_array().map(f32::to_bits);
        let mut edges = std::collections::HashMap::new();
        for t in &s.indices {
            for k in 0..3 {
                let (a, b) = (key(t[k]), key(t[(k + 1) % 3]));
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
        assert!(edges.values().all(|&c| c == 2));
    }

    #[test]
    fn sphere_and_cube_uvs_are_mitsubas() {
        use std::f32::consts::{PI, TAU};
        let s = sphere(Vec3::ZERO, 1.0, 16, 32);
        for (p, uv) in s.positions.iter().zip(s.uvs.as_ref().unwrap()) {
            if p.z.abs() < 0.999 {
                let phi = p.y.atan2(p.x).rem_euclid(TAU);
                let du = (uv.x - phi / TAU).abs();
                assert!(du < 1e-5 || (du - 1.0).abs() < 1e-5, "{p} {uv}");
            }
            assert!((uv.y - p.z.clamp(-1.0, 1.0).acos() / PI).abs() < 1e-5, "{p} {uv}");
        }
        // Every cube face maps onto [0, 1]² with its corners, as Mitsuba's table does.
        let c = cube();
        let uvs = c.uvs.as_ref().unwrap();
        for face in 0..6 {
            let mut corners: Vec<[u32; 2]> = (0..4).map(|k| uvs[4 * face + k].to_array().map(|x| x as u32)).collect();
            corners.sort_unstable();
            assert_eq!(corners, [[0, 0], [0, 1], [1, 0], [1, 1]]);
        }
    }
}

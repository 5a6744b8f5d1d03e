//! Built-in shapes as triangle meshes, in Mitsuba's canonical frames (before `to_world`).
//!
//! - [`rectangle`]: the square [-1,1]² in the xy-plane, facing +z (2 triangles).
//! - [`cube`]: the cube [-1,1]³, outward faces, flat normals (12 triangles, 24 vertices).
//! - [`sphere`]: a closed UV sphere with shared vertices (watertight) and smooth normals.
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

/// The cube [-1,1]³ with outward-facing flat faces.
#[must_use]
pub fn cube() -> TriangleMesh {
    let mut mesh = TriangleMesh { normals: Some(Vec::new()), uvs: Some(Vec::new()), ..Default::default() };
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // Two tangents with t1 × t2 = n.
            let mut t1 = Vec3::ZERO;
            t1[(axis + 1) % 3] = 1.0;
            let t2 = n.cross(t1);
            let base = mesh.positions.len() as u32;
            for (a, b) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                mesh.positions.push(n + a * t1 + b * t2);
                mesh.normals.as_mut().expect("set above").push(n);
                mesh.uvs.as_mut().expect("set above").push(Vec2::new(0.5 * (a + 1.0), 0.5 * (b + 1.0)));
            }
            mesh.indices.push([base, base + 1, base + 2]);
            mesh.indices.push([base, base + 2, base + 3]);
        }
    }
    mesh
}

/// A closed UV sphere with `rings` latitude bands (≥ 2) and `segments` longitude bands (≥ 3).
/// Vertices are shared, so the mesh is watertight; the poles are single vertices with triangle fans
/// (no zero-area triangles). Normals are the exact sphere normals at the vertices.
#[must_use]
pub fn sphere(center: Vec3, radius: f32, rings: u32, segments: u32) -> TriangleMesh {
    let rings = rings.max(2);
    let segments = segments.max(3);
    let mut positions = Vec::with_capacity(((rings - 1) * segments + 2) as usize);
    let mut normals = Vec::with_capacity(positions.capacity());
    let mut uvs = Vec::with_capacity(positions.capacity());
    let push = |n: Vec3, uv: Vec2, positions: &mut Vec<Vec3>, normals: &mut Vec<Vec3>, uvs: &mut Vec<Vec2>| {
        positions.push(center + radius * n);
        normals.push(n);
        uvs.push(uv);
    };
    push(Vec3::Y, Vec2::new(0.5, 0.0), &mut positions, &mut normals, &mut uvs); // north pole = 0
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            let n = Vec3::new(theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin());
            push(n, Vec2::new(s as f32 / segments as f32, r as f32 / rings as f32), &mut positions, &mut normals, &mut uvs);
        }
    }
    let south = positions.len() as u32;
    push(-Vec3::Y, Vec2::new(0.5, 1.0), &mut positions, &mut normals, &mut uvs);
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + (s % segments);
    let mut indices = Vec::with_capacity((2 * segments * (rings - 1)) as usize);
    for s in 0..segments {
        indices.push([0, ring(1, s), ring(1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (ring(r, s), ring(r, s + 1), ring(r + 1, s), ring(r + 1, s + 1));
            indices.push([a, d, b]);
            indices.push([a, c, d]);
        }
    }
    for s in 0..segments {
        indices.push([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
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
    }

    #[test]
    fn sphere_is_closed() {
        // Every undirected edge is shared by exactly two triangles.
        let s = sphere(Vec3::ZERO, 1.0, 7, 9);
        let mut edges = std::collections::HashMap::new();
        for t in &s.indices {
            for k in 0..3 {
                let (a, b) = (t[k].min(t[(k + 1) % 3]), t[k].max(t[(k + 1) % 3]));
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        assert!(edges.values().all(|&c| c == 2));
    }
}

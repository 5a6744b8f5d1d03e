//! `caustica bench --instances N [--flatten]`: issue 39's instancing benchmark made from any input. The input's
//! triangles become one prototype placed N times on a grid (100 per row, spaced by 1.25 times the input's
//! bounding diameter, each turned about +y by 53° more than the last and scaled by (s, 1.6 − 0.5·s, s),
//! s ∈ [0.8, 1.2]), traced in two levels; with `--flatten`, the same placements' triangles in world space, one
//! flat soup, as the scene would be without instancing. Made in memory, not read from a scene file, so that
//! what is measured (build time, rays/s, peak memory) is the geometry and its accelerator, not the reading of
//! N shape tables.

use glam::Affine3A;

use super::BenchInput;
use crate::accel::Instance;
use crate::math::Vec3;
use crate::mesh::TriangleMesh;

/// The k-th placement (module docs), for an input whose bounding sphere has radius `r` around `centre`.
fn placement(k: usize, centre: Vec3, r: f32) -> Affine3A {
    let s = 0.8 + 0.4 * ((k * 37) % 11) as f32 / 10.0;
    let spacing = 2.5 * r;
    let (x, z) = ((k % 100) as f32 * spacing, (k / 100) as f32 * spacing);
    Affine3A::from_translation(Vec3::new(x, 0.0, z))
        * Affine3A::from_rotation_y((((k * 53) % 360) as f32).to_radians())
        * Affine3A::from_scale(Vec3::new(s, 1.6 - 0.5 * s, s))
        * Affine3A::from_translation(-centre)
}

/// `input`'s whole soup placed `n` times: as one prototype and `n` instances, or (`flatten`) as one soup.
pub fn placed(input: BenchInput, n: usize, flatten: bool) -> anyhow::Result<BenchInput> {
    if !input.instances.is_empty() {
        anyhow::bail!("--instances places a mesh or a scene without instances; this one has {}", input.instances.len());
    }
    let mesh = input.mesh;
    let (centre, r) = mesh.bounds().bounding_sphere();
    let placements: Vec<Affine3A> = (0..n).map(|k| placement(k, centre, r)).collect();
    if !flatten {
        let instances = placements.iter().map(|&m| Instance::new(0, m).expect("scales and turns are invertible")).collect();
        let triangles = mesh.triangle_count() as u32;
        return Ok(BenchInput { mesh, flat: 0, prototypes: vec![0..triangles], instances, analytic: Vec::new() });
    }
    let (v, t) = (mesh.positions.len(), mesh.triangle_count());
    if (v as u128 * n as u128) > u128::from(u32::MAX) || (t as u128 * n as u128) > u128::from(u32::MAX) {
        anyhow::bail!("{n} flattened copies of {t} triangles pass 2^32 vertices or triangles");
    }
    let mut flat = TriangleMesh { positions: Vec::with_capacity(v * n), indices: Vec::with_capacity(t * n), ..Default::default() };
    for m in &placements {
        let base = flat.positions.len() as u32;
        flat.positions.extend(mesh.positions.iter().map(|&p| m.transform_point3(p)));
        flat.indices.extend(mesh.indices.iter().map(|tri| tri.map(|i| i + base)));
    }
    let triangles = flat.triangle_count() as u32;
    Ok(BenchInput { mesh: flat, flat: triangles, prototypes: Vec::new(), instances: Vec::new(), analytic: Vec::new() })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::brute::BruteForce;
    use crate::accel::Accel;
    use crate::mesh::shapes;

    /// The instanced and the flattened forms are the same scene: every ray meets the same surface.
    #[test]
    fn instanced_and_flattened_placements_agree() {
        let input = || BenchInput { mesh: shapes::cube(), flat: 12, prototypes: Vec::new(), instances: Vec::new(), analytic: Vec::new() };
        let (a, b) = (placed(input(), 150, false).unwrap(), placed(input(), 150, true).unwrap());
        assert_eq!((a.instances.len(), a.mesh.triangle_count(), b.mesh.triangle_count()), (150, 12, 1800));
        let (oa, ob) = (BruteForce::from_geometry(&a.geometry()), BruteForce::from_geometry(&b.geometry()));
        let rays = super::super::rays::RaySets::generate_for(&b.geometry(), 300).unwrap();
        for ray in rays.incoherent.iter().chain(&rays.primary) {
            let (ha, hb) = (oa.intersect(ray), ob.intersect(ray));
            assert_eq!(ha.is_some(), hb.is_some(), "{ray:?}");
            if let (Some(x), Some(y)) = (ha, hb) {
                assert!((x.t - y.t).abs() <= 1e-3 * y.t.max(1.0), "{x:?} {y:?}");
            }
        }
    }
}

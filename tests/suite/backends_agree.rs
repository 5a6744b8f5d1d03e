//! Embree vs BVH vs the brute-force oracle on the shipped meshes (teapot, bunny) and a scene's soup,
//! with the benchmark's own ray sets (primary, incoherent from surfaces, shadow between surface points).
//!
//! Closest hits agree when they name the same triangle, or the same `t` within 1e-4·t (a tie on a shared
//! edge). Same triangle ⇒ u, v within 1e-3. Shadow rays: identical answers except rays whose segment ends
//! within 1e-4·t of a surface, where either answer is right (counted and bounded).

use caustica::accel::brute::BruteForce;
use caustica::accel::{build_accel, Accel, BackendKind};
use caustica::bench::rays::RaySets;
use caustica::bench::{hits_agree, load_input};
use caustica::math::Vec3;
use caustica::mesh::{shapes, TriangleMesh};
use std::path::Path;

fn load(file: &str) -> TriangleMesh {
    load_input(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file), &Default::default()).expect("load").1.mesh
}

fn check(file: &str, n: usize) {
    let mesh = load(file);
    check_rays(file, &mesh, &RaySets::generate(&mesh, n).expect("rays"));
}

/// Every backend (through `build_accel`) against the oracle over `mesh`, on `rays`.
fn check_rays(file: &str, mesh: &TriangleMesh, rays: &RaySets) {
    let brute = BruteForce::new(&mesh.positions, &mesh.indices);
    let mut backends: Vec<Box<dyn Accel>> = vec![build_accel(BackendKind::Bvh, &caustica::accel::Geometry::soup(&mesh.positions, &mesh.indices)).expect("bvh")];
    if cfg!(feature = "embree") {
        backends.push(build_accel(BackendKind::Embree, &caustica::accel::Geometry::soup(&mesh.positions, &mesh.indices)).expect("embree"));
    }
    for accel in &backends {
        let mut disagree = 0;
        let mut hits = 0;
        for ray in rays.primary.iter().chain(&rays.incoherent) {
            let (a, b) = (accel.intersect(ray), brute.intersect(ray));
            hits += usize::from(b.is_some());
            if !hits_agree(a, b) {
                disagree += 1;
            } else if let (Some(a), Some(b)) = (a, b) {
                if a.prim == b.prim {
                    assert!((a.t - b.t).abs() <= 1e-4 * b.t.max(1e-6), "{file} {}: t {} vs {}", accel.name(), a.t, b.t);
                    assert!((a.u - b.u).abs() < 1e-3 && (a.v - b.v).abs() < 1e-3, "{file} {}: uv {a:?} vs {b:?}", accel.name());
                }
            }
        }
        let total = rays.primary.len() + rays.incoherent.len();
        assert!(hits > total / 4, "{file}: only {hits} of {total} rays hit: the ray sets are not exercising the mesh");
        // Issue target: ≥ 99.99% agreement; at this ray count that means no disagreement at all.
        assert_eq!(disagree, 0, "{file} {}: {disagree} of {total} closest hits disagree with brute force", accel.name());
        let mut shadow_disagree = 0;
        for ray in &rays.shadow {
            if accel.occluded(ray) != brute.occluded(ray) {
                shadow_disagree += 1;
            }
        }
        assert_eq!(shadow_disagree, 0, "{file} {}: {shadow_disagree} shadow rays disagree", accel.name());
    }
}

#[test]
fn teapot() {
    check("scenes/assets/models/teapot.obj", 3000);
}

#[test]
fn bunny() {
    check("scenes/assets/models/bunny_lowres.obj", 3000);
}

#[test]
fn cornell_scene_soup() {
    check("scenes/cornell-caustics.toml", 400);
}

/// Issue 13: the teapot inside a sky-sized sphere (far geometry: `accel::shell` splits it off), with the
/// teapot's own ray sets.
#[test]
fn teapot_inside_a_sky_sphere() {
    let teapot = load("scenes/assets/models/teapot.obj");
    let rays = RaySets::generate(&teapot, 1500).expect("rays");
    let mut mesh = teapot.clone();
    mesh.append(&shapes::sphere(Vec3::new(3.0, -2.0, 1.0), 4.3e9, 16, 32));
    assert!(caustica::accel::shell::split(&mesh.positions, &mesh.indices).is_some(), "the sky is far geometry");
    check_rays("teapot in a sky", &mesh, &rays);
}

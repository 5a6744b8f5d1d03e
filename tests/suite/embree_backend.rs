//! The Embree backend against the brute-force oracle: same `(t, prim, u, v)` and the same shadow-ray
//! answers on spheres, cubes and random soups, plus empty and degenerate scenes, far coordinates,
//! ray-interval bounds, concurrency and the detected version.
#![cfg(feature = "embree")]

use caustica::accel::brute::BruteForce;
use caustica::accel::embree::{Batching, EmbreeAccel, VERSION};
use caustica::accel::{Accel, Hit};
use caustica::error::AccelError;
use caustica::math::{Ray, Vec3};
use caustica::mesh::shapes;
use caustica::sampler::Sampler;
use rayon::prelude::*;

/// Agreement tolerances. `t_abs` covers the rounding of f32 coordinates of magnitude `m`: both
/// intersectors work in f32 on translated vertices, so t may differ by a few ulps of `m` (per unit of
/// |dir|); `uv` likewise scales with ulp(m) / edge length.
#[derive(Clone, Copy)]
struct Tol {
    t_abs: f32,
    uv: f32,
}

impl Tol {
    const UNIT: Tol = Tol { t_abs: 0.0, uv: 1e-3 };
}

struct Pair {
    embree: EmbreeAccel,
    brute: BruteForce,
    positions: Vec<Vec3>,
    indices: Vec<[u32; 3]>,
}

impl Pair {
    fn new(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> Self {
        let embree = EmbreeAccel::new(&positions, &indices).expect("Embree builds the scene");
        let brute = BruteForce::new(&positions, &indices);
        Self {
            embree,
            brute,
            positions,
            indices,
        }
    }

    /// Whether Embree's hit on another triangle than the oracle's is a legitimate tie on a shared
    /// edge or vertex: its `(u, v)` lie in the triangle (up to `tol.uv`) and the point they give is the
    /// point at `t` on the ray (up to `t_tol`·|dir| plus `tol.uv` of the triangle's longest edge).
    fn is_tie(&self, ray: &Ray, e: Hit, t_tol: f32, tol: Tol) -> bool {
        let [p0, p1, p2] = self.indices[e.prim as usize].map(|i| self.positions[i as usize]);
        let inside = e.u >= -tol.uv && e.v >= -tol.uv && e.u + e.v <= 1.0 + tol.uv;
        let p = (1.0 - e.u - e.v) * p0 + e.u * p1 + e.v * p2;
        let edge = (p1 - p0).length().max((p2 - p1).length()).max((p0 - p2).length());
        inside && (p - ray.at(e.t)).length() <= t_tol * ray.dir.length() + tol.uv * edge
    }

    /// Compares closest hits; returns whether the two picked different triangles at the same t (a tie
    /// on a shared edge or vertex).
    fn check_intersect(&self, ray: &Ray, tol: Tol) -> bool {
        let e = self.embree.intersect(ray);
        let b = self.brute.intersect(ray);
        match (e, b) {
            (None, None) => false,
            (Some(e), Some(b)) => {
                let t_tol = 1e-4 * b.t + tol.t_abs / ray.dir.length();
                assert!((e.t - b.t).abs() <= t_tol, "t differs: embree {e:?} brute {b:?} ray {ray:?}");
                if e.prim == b.prim {
                    assert_uv_close(e, b, tol.uv, ray);
                    false
                } else {
                    assert!(
                        self.is_tie(ray, e, t_tol, tol),
                        "embree's prim is not hit at t: {e:?} vs {b:?} ray {ray:?}"
                    );
                    true
                }
            }
            _ => panic!("hit/miss disagree: embree {e:?} brute {b:?} ray {ray:?}"),
        }
    }
}

fn assert_uv_close(e: Hit, b: Hit, tol: f32, ray: &Ray) {
    assert!(
        (e.u - b.u).abs() <= tol && (e.v - b.v).abs() <= tol,
        "uv differ: embree {e:?} brute {b:?} ray {ray:?}"
    );
}

fn uniform_in_box(s: &mut Sampler, lo: Vec3, hi: Vec3) -> Vec3 {
    lo + (hi - lo) * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d())
}

/// Rays from random points of the enlarged box `[lo, hi]` toward random points of the inner box:
/// most hit, some miss, some start inside the mesh.
fn random_rays(seed: u64, n: u64, inner_lo: Vec3, inner_hi: Vec3) -> Vec<Ray> {
    let c = 0.5 * (inner_lo + inner_hi);
    let (lo, hi) = (c + 2.0 * (inner_lo - c), c + 2.0 * (inner_hi - c));
    (0..n)
        .map(|i| {
            let mut s = Sampler::for_key(seed, i, 0);
            let o = uniform_in_box(&mut s, lo, hi);
            let target = uniform_in_box(&mut s, inner_lo, inner_hi);
            Ray::new(o, target - o)
        })
        .collect()
}

/// Random triangles (sizes from tiny to large) in the unit cube.
fn random_soup(seed: u64, n: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for i in 0..n {
        let mut s = Sampler::for_key(seed, u64::from(i), 1);
        let c = uniform_in_box(&mut s, Vec3::ZERO, Vec3::ONE);
        let size = 0.01 + 0.3 * s.next_1d();
        let base = positions.len() as u32;
        for _ in 0..3 {
            positions.push(c + size * (uniform_in_box(&mut s, Vec3::ZERO, Vec3::ONE) - 0.5));
        }
        indices.push([base, base + 1, base + 2]);
    }
    (positions, indices)
}

fn check_all(pair: &Pair, rays: &[Ray], tol: Tol) -> (usize, usize) {
    let hits = rays.iter().filter(|r| pair.brute.intersect(r).is_some()).count();
    let ties = rays.iter().filter(|r| pair.check_intersect(r, tol)).count();
    (hits, ties)
}

#[test]
fn sphere_matches_brute_force() {
    let m = shapes::sphere(Vec3::new(0.2, -0.1, 0.3), 1.5, 24, 48);
    let pair = Pair::new(m.positions.clone(), m.indices.clone());
    let rays = random_rays(1, 4000, m.bounds().min, m.bounds().max);
    let (hits, ties) = check_all(&pair, &rays, Tol::UNIT);
    assert!(hits > 2000, "the ray set must mostly hit ({hits})");
    assert!(ties < 40, "ties on shared edges must be rare ({ties})");
}

#[test]
fn rays_from_inside_through_every_vertex_hit_a_closed_sphere() {
    // Watertightness: rays from the centre through each vertex (where 4–6 triangles meet) must hit.
    let center = Vec3::new(0.5, 0.25, -0.75);
    let m = shapes::sphere(center, 2.0, 16, 32);
    let pair = Pair::new(m.positions.clone(), m.indices.clone());
    for &p in &m.positions {
        let ray = Ray::new(center, p - center);
        assert!(pair.embree.intersect(&ray).is_some(), "ray through vertex {p} leaked");
        pair.check_intersect(&ray, Tol::UNIT);
    }
}

/// The scene `caustica bench` builds without ROBUST (as Mitsuba 3 builds its own) answers random rays as
/// the oracle does — the same primitive or a tie on a shared edge, the same occlusion — so the rates the
/// bench reports for it are for real answers. (Its watertightness is what it gives up: rays through
/// vertices may leak, which the renderer's scene, `EmbreeAccel::new`, must not; not asserted here, since
/// that is Embree's behaviour, not ours.)
#[test]
fn the_scene_without_robust_answers_random_rays_like_the_oracle() {
    let m = shapes::sphere(Vec3::new(0.2, -0.1, 0.3), 1.5, 24, 48);
    let fast = EmbreeAccel::without_robust(&m.positions, &m.indices).expect("Embree builds the scene");
    let pair = Pair::new(m.positions.clone(), m.indices.clone());
    let rays = random_rays(5, 4000, m.bounds().min, m.bounds().max);
    let (mut hits, mut ties) = (0, 0);
    for ray in &rays {
        let (f, b) = (fast.intersect(ray), pair.brute.intersect(ray));
        assert_eq!(f.is_some(), b.is_some(), "hit or miss differs for {ray:?}");
        if let (Some(f), Some(b)) = (f, b) {
            hits += 1;
            if f.prim != b.prim {
                assert!(pair.is_tie(ray, f, 1e-5, Tol::UNIT), "{ray:?}: without ROBUST {f:?}, oracle {b:?}");
                ties += 1;
            } else {
                assert!((f.t - b.t).abs() <= 1e-5 * b.t.max(1.0), "{ray:?}: t {} vs {}", f.t, b.t);
            }
        }
        assert_eq!(fast.occluded(ray), pair.brute.occluded(ray), "occlusion differs for {ray:?}");
    }
    assert!(hits > 2000 && ties < 40, "{hits} hits, {ties} ties");
}

#[test]
fn cube_matches_brute_force() {
    let m = shapes::cube();
    let pair = Pair::new(m.positions.clone(), m.indices.clone());
    let rays = random_rays(2, 4000, m.bounds().min, m.bounds().max);
    let (hits, ties) = check_all(&pair, &rays, Tol::UNIT);
    assert!(hits > 2000, "{hits}");
    assert!(ties < 40, "{ties}");
}

#[test]
fn random_soup_matches_brute_force() {
    let (positions, indices) = random_soup(3, 600);
    let pair = Pair::new(positions, indices);
    let rays = random_rays(4, 3000, Vec3::ZERO, Vec3::ONE);
    let (hits, _) = check_all(&pair, &rays, Tol::UNIT);
    assert!(hits > 1500, "{hits}");
    // Also through the interval bounds: random [t_min, t_max] sub-ranges of the same rays.
    for (i, r) in rays.iter().enumerate() {
        let mut s = Sampler::for_key(5, i as u64, 0);
        let (a, b) = (s.next_1d(), s.next_1d());
        pair.check_intersect(&Ray::segment(r.origin, r.dir, a.min(b), a.max(b)), Tol::UNIT);
    }
}

#[test]
fn shadow_rays_agree_with_brute_force() {
    let (positions, indices) = random_soup(6, 400);
    let pair = Pair::new(positions, indices);
    let rays = random_rays(7, 3000, Vec3::ZERO, Vec3::ONE);
    let (mut blocked, mut compared) = (0, 0);
    for (i, r) in rays.iter().enumerate() {
        let t_max = Sampler::for_key(8, i as u64, 0).next_1d() * 1.5;
        let seg = Ray::segment(r.origin, r.dir, 0.0, t_max);
        // Skip segments whose end lies within rounding of a surface (either answer is right there).
        let first_after = pair
            .brute
            .intersect(&Ray::segment(r.origin, r.dir, t_max * (1.0 - 1e-4), f32::INFINITY));
        if first_after.is_some_and(|h| h.t <= t_max * (1.0 + 1e-4)) {
            continue;
        }
        compared += 1;
        let b = pair.brute.occluded(&seg);
        assert_eq!(pair.embree.occluded(&seg), b, "ray {seg:?}");
        assert_eq!(pair.brute.intersect(&seg).is_some(), b);
        blocked += usize::from(b);
    }
    assert!(compared > 2900 && blocked > 500 && blocked < compared - 500, "{compared} {blocked}");
}

#[test]
fn empty_scenes_miss_everything() {
    let rays = random_rays(9, 100, -Vec3::ONE, Vec3::ONE);
    let no_triangles = [
        EmbreeAccel::new(&[], &[]).unwrap(),
        EmbreeAccel::new(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[]).unwrap(),
    ];
    for accel in &no_triangles {
        assert_eq!(accel.triangle_count(), 0);
        for r in &rays {
            assert_eq!(accel.intersect(r), None);
            assert!(!accel.occluded(r));
        }
        assert_eq!(accel.intersect_raw_baseline(&rays), 0);
    }
}

#[test]
fn zero_area_triangles_are_never_hit() {
    // Triangles 0..3 are degenerate (repeated vertex, collinear, a point); triangle 3 is a real quad half.
    let positions = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.5, 0.5, 0.0),
    ];
    let indices = vec![[0, 0, 1], [0, 1, 2], [4, 4, 4], [0, 1, 3]];
    let pair = Pair::new(positions, indices);
    let rays = random_rays(10, 2000, Vec3::new(-0.5, -0.5, -0.5), Vec3::new(2.5, 1.5, 0.5));
    let (hits, _) = check_all(&pair, &rays, Tol::UNIT);
    assert!(hits > 100, "{hits}");
    for r in &rays {
        assert!(pair.embree.intersect(r).is_none_or(|h| h.prim == 3));
    }
    // Rays aimed exactly at the degenerate ones (in the plane's normal direction) hit only triangle 3 or nothing.
    let down = Ray::new(Vec3::new(1.5, 0.0, 1.0), -Vec3::Z);
    assert_eq!(pair.embree.intersect(&down), pair.brute.intersect(&down));
}

#[test]
fn coordinates_near_one_million() {
    let center = Vec3::new(1.0e6, -1.0e6, 1.0e6);
    let m = shapes::sphere(center, 1000.0, 8, 16);
    let pair = Pair::new(m.positions.clone(), m.indices.clone());
    // ulp(2^20) = 0.125 bounds the spacing of every coordinate here; allow a few ulps.
    let ulp = 0.125f32;
    let edge = 300.0; // shortest edge of this 8×16 sphere is ≈ 390
    let tol = Tol {
        t_abs: 8.0 * ulp,
        uv: 1e-3 + 8.0 * ulp / edge,
    };
    let rays = random_rays(11, 3000, m.bounds().min, m.bounds().max);
    let (hits, ties) = check_all(&pair, &rays, tol);
    assert!(hits > 1500 && ties < 30, "{hits} {ties}");
    for &p in &m.positions {
        assert!(pair.embree.intersect(&Ray::new(center, p - center)).is_some(), "leak at vertex {p}");
    }
}

#[test]
fn interval_bounds_select_the_right_layer() {
    // Two parallel quads at z = 1 (triangles 0, 1) and z = 2 (triangles 2, 3); ray along +z from z = 0.
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    for z in [1.0f32, 2.0] {
        let b = positions.len() as u32;
        positions.extend([
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ]);
        indices.extend([[b, b + 1, b + 2], [b, b + 2, b + 3]]);
    }
    let pair = Pair::new(positions, indices);
    let (o, d) = (Vec3::new(0.3, -0.2, 0.0), Vec3::Z);
    let hit = |t_min, t_max| pair.embree.intersect(&Ray::segment(o, d, t_min, t_max));
    let layer = |h: Option<Hit>| h.map(|h| ((h.t - h.t.round()).abs() < 1e-6, h.t.round(), h.prim));
    // (0.3, −0.2) has x > y, so it lies in the first triangle of each quad ([b, b+1, b+2]).
    assert_eq!(layer(hit(0.0, f32::INFINITY)), Some((true, 1.0, 0)));
    assert_eq!(layer(hit(0.0, 1.5)), Some((true, 1.0, 0)));
    assert_eq!(layer(hit(1.5, f32::INFINITY)), Some((true, 2.0, 2)));
    assert_eq!(hit(2.5, f32::INFINITY), None);
    assert_eq!(hit(0.0, 0.5), None);
    assert!(pair.embree.occluded(&Ray::segment(o, d, 0.0, 1.5)));
    assert!(pair.embree.occluded(&Ray::segment(o, d, 1.5, 2.5)));
    assert!(!pair.embree.occluded(&Ray::segment(o, d, 0.0, 0.5)));
    assert!(!pair.embree.occluded(&Ray::segment(o, d, 2.5, f32::INFINITY)));
    assert!(
        !pair.embree.occluded(&Ray::segment(o, d, 1.5, 1.0)),
        "an empty interval is never occluded"
    );
    // Barycentrics in Embree's convention at the hit (triangle 0 = [0, 1, 2]): p = (1−u−v)p0 + u·p1 + v·p2.
    let h = hit(0.0, f32::INFINITY).unwrap();
    let [p0, p1, p2] = [Vec3::new(-1.0, -1.0, 1.0), Vec3::new(1.0, -1.0, 1.0), Vec3::new(1.0, 1.0, 1.0)];
    let p = (1.0 - h.u - h.v) * p0 + h.u * p1 + h.v * p2;
    assert!((p - (o + d)).length() < 1e-5, "{p}");
}

#[test]
fn packets_and_streams_answer_as_single_rays() {
    let (positions, indices) = random_soup(14, 300);
    let pair = Pair::new(positions, indices);
    // 1,001 rays: the last packet of every width is partial. Segments of random length (some empty,
    // t_max < t_min) so that occlusion has both answers.
    let rays: Vec<Ray> = random_rays(15, 1001, Vec3::ZERO, Vec3::ONE)
        .into_iter()
        .enumerate()
        .map(|(i, r)| {
            let mut s = Sampler::for_key(16, i as u64, 0);
            Ray::segment(r.origin, r.dir, 0.2 * s.next_1d(), 1.5 * s.next_1d())
        })
        .collect();
    let closest: Vec<Option<Hit>> = rays.iter().map(|r| pair.embree.intersect(r)).collect();
    let blocked: Vec<bool> = rays.iter().map(|r| pair.embree.occluded(r)).collect();
    let hits = closest.iter().filter(|h| h.is_some()).count();
    let n_blocked = blocked.iter().filter(|&&b| b).count();
    assert!(hits > 200 && hits < 900 && n_blocked > 200 && n_blocked < 900, "{hits} {n_blocked}");
    for &batching in Batching::AVAILABLE {
        let mut out = vec![None; rays.len()];
        pair.embree.intersect_batched(&rays, &mut out, batching);
        assert_eq!(out, closest, "{}", batching.name());
        if batching != Batching::Stream {
            let mut out = vec![false; rays.len()];
            pair.embree.occluded_batched(&rays, &mut out, batching);
            assert_eq!(out, blocked, "{}", batching.name());
        }
    }
}

#[test]
fn concurrent_queries_match_sequential_ones() {
    let (positions, indices) = random_soup(12, 300);
    let pair = Pair::new(positions, indices);
    let rays = random_rays(13, 4000, Vec3::ZERO, Vec3::ONE);
    let sequential: Vec<Option<Hit>> = rays.iter().map(|r| pair.embree.intersect(r)).collect();
    let parallel: Vec<Option<Hit>> = rays.par_iter().map(|r| pair.embree.intersect(r)).collect();
    assert_eq!(sequential, parallel);
    let hits = sequential.iter().filter(|h| h.is_some()).count();
    assert_eq!(pair.embree.intersect_raw_baseline(&rays), hits);
}

#[test]
fn invalid_soups_are_rejected() {
    let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
    assert!(matches!(EmbreeAccel::new(&p, &[[0, 1, 3]]), Err(AccelError::InvalidGeometry(_))));
    assert!(matches!(
        EmbreeAccel::new(&[Vec3::ZERO, Vec3::X, Vec3::NAN], &[[0, 1, 2]]),
        Err(AccelError::InvalidGeometry(_))
    ));
}

#[test]
fn version_is_reported() {
    assert!(VERSION.starts_with("3.") || VERSION.starts_with("4."), "{VERSION}");
    assert_eq!(caustica::accel::embree_version(), Some(VERSION));
    assert_eq!(EmbreeAccel::new(&[], &[]).unwrap().name(), "embree");
}

//! The BVH backend against the brute-force oracle: random rays on generated meshes and soups,
//! watertightness at shared edges and vertices, re-intersection from hit points, degenerate input,
//! the `[t_min, t_max]` interval; plus an ignored throughput measurement (`bvh_speed`).

use caustica::accel::brute::BruteForce;
use caustica::accel::bvh::Bvh;
use caustica::accel::{Accel, Hit};
use caustica::math::{barycentric_point_error, offset_ray_origin, Aabb, Ray, Vec3};
use caustica::mesh::shapes::{cube, sphere};
use caustica::mesh::TriangleMesh;
use caustica::sampler::Sampler;

fn uniform_sphere(s: &mut Sampler) -> Vec3 {
    let z = 1.0 - 2.0 * s.next_1d();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * s.next_1d();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn point_in(b: &Aabb, s: &mut Sampler) -> Vec3 {
    b.min + Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * (b.max - b.min)
}

/// `n` random triangles with centres in `[-1, 1]³` (scaled by `scale`, offset by `offset`) and
/// edges up to `size`.
fn random_soup(seed: u64, n: usize, size: f32, scale: f32, offset: Vec3) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    for i in 0..n {
        let mut s = Sampler::for_key(seed, i as u64, 0);
        let c = Vec3::new(2.0 * s.next_1d() - 1.0, 2.0 * s.next_1d() - 1.0, 2.0 * s.next_1d() - 1.0);
        let base = mesh.positions.len() as u32;
        for _ in 0..3 {
            let p = c + size * Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, s.next_1d() - 0.5);
            mesh.positions.push(offset + scale * p);
        }
        mesh.indices.push([base, base + 1, base + 2]);
    }
    mesh
}

fn build(mesh: &TriangleMesh) -> Bvh {
    let bvh = Bvh::build(&mesh.positions, &mesh.indices);
    bvh.validate().unwrap_or_else(|e| panic!("invalid BVH: {e}"));
    bvh
}

/// Rays with origins in the (slightly enlarged) bounds of `mesh` and uniform directions.
fn random_rays(mesh: &TriangleMesh, seed: u64, n: usize) -> Vec<Ray> {
    rays_from(&mesh.bounds(), seed, n)
}

/// Rays with origins in the (slightly enlarged) box `b` and uniform directions.
fn rays_from(b: &Aabb, seed: u64, n: usize) -> Vec<Ray> {
    let pad = 0.1 * (b.max - b.min);
    let b = Aabb {
        min: b.min - pad,
        max: b.max + pad,
    };
    (0..n)
        .map(|i| {
            let mut s = Sampler::for_key(seed, i as u64, 1);
            Ray::new(point_in(&b, &mut s), uniform_sphere(&mut s))
        })
        .collect()
}

fn assert_same_hit(got: Option<Hit>, want: Option<Hit>, ray: &Ray, what: &str) {
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => {
            if g.prim == w.prim {
                // The BVH's packet test is bit-identical to the oracle's scalar test.
                assert_eq!(g, w, "{what}: same triangle, different hit for {ray:?}");
            } else {
                // A tie on a shared edge may legitimately resolve to either triangle.
                assert!((g.t - w.t).abs() <= 1e-4 * w.t.abs(), "{what}: prim {g:?} vs {w:?} for {ray:?}");
            }
        }
        _ => panic!("{what}: {got:?} vs brute force {want:?} for {ray:?}"),
    }
}

fn agree_with_brute(mesh: &TriangleMesh, seed: u64, n_rays: usize, what: &str) -> usize {
    agree_on_rays(mesh, random_rays(mesh, seed, n_rays), what)
}

fn agree_on_rays(mesh: &TriangleMesh, rays: Vec<Ray>, what: &str) -> usize {
    let bvh = build(mesh);
    let brute = BruteForce::new(&mesh.positions, &mesh.indices);
    let mut hits = 0;
    for ray in rays {
        let want = brute.intersect(&ray);
        assert_same_hit(bvh.intersect(&ray), want, &ray, what);
        hits += usize::from(want.is_some());
        assert_eq!(bvh.occluded(&ray), brute.occluded(&ray), "{what}: occluded for {ray:?}");
        // A shadow segment ending half way to the closest hit (or at t = 1) must agree too.
        let t_max = want.map_or(1.0, |h| 0.5 * h.t);
        let seg = Ray::segment(ray.origin, ray.dir, 0.0, t_max);
        assert_eq!(bvh.occluded(&seg), brute.occluded(&seg), "{what}: occluded segment {seg:?}");
    }
    hits
}

#[test]
fn agrees_with_brute_force_on_meshes_and_soups() {
    let hits = agree_with_brute(&sphere(Vec3::new(0.3, -0.2, 0.1), 1.5, 24, 40), 1, 3000, "sphere");
    assert!(hits > 1000, "sphere hits {hits}");
    let hits = agree_with_brute(&cube(), 2, 3000, "cube");
    assert!(hits > 1000, "cube hits {hits}");
    let hits = agree_with_brute(&random_soup(3, 3000, 0.2, 1.0, Vec3::ZERO), 3, 3000, "soup");
    assert!(hits > 1000, "soup hits {hits}");
    // Several meshes in one soup, as a scene flattens them.
    let mut scene = sphere(Vec3::new(2.0, 0.0, 0.0), 0.7, 12, 20);
    scene.append(&cube());
    scene.append(&random_soup(4, 500, 0.3, 3.0, Vec3::ZERO));
    agree_with_brute(&scene, 4, 3000, "scene");
}

/// Issue 13: small geometry inside a sky-sized sphere (fine, and coarse enough that its triangles'
/// boxes contain the whole scene) and under a huge tilted triangle. Rays from the small geometry
/// agree with the oracle, closest hits, shadow rays and shadow segments alike, and the BVH is valid.
#[test]
fn small_geometry_inside_sky_sized_shapes_agrees() {
    let mut small = sphere(Vec3::new(0.3, -0.2, 0.1), 0.8, 24, 40);
    small.append(&cube());
    small.append(&random_soup(21, 500, 0.3, 1.5, Vec3::ZERO));
    let around = small.bounds();
    let huge_triangle = TriangleMesh {
        positions: vec![Vec3::new(-3e8, -1e8, -2e8), Vec3::new(2e8, 1.5, 3e8), Vec3::new(1e8, 2e8, -1e8)],
        indices: vec![[0, 1, 2]],
        ..TriangleMesh::default()
    };
    for (k, (rings, segments)) in [(2, 4), (64, 128)].into_iter().enumerate() {
        let mut scene = small.clone();
        scene.append(&sphere(Vec3::new(0.2, 0.1, 0.0), 4.3e9, rings, segments));
        scene.append(&huge_triangle);
        let hits = agree_on_rays(&scene, rays_from(&around, 30 + k as u64, 3000), &format!("sky {rings}×{segments}"));
        assert_eq!(hits, 3000, "every ray hits something inside the sky");
    }
}

#[test]
fn rays_along_axes_and_box_planes_agree() {
    // Axis-aligned directions (1/d = ±∞ on two axes, including −0) and origins on the cube's face
    // planes, where the slab test meets 0·∞.
    let mesh = cube();
    let bvh = build(&mesh);
    let brute = BruteForce::new(&mesh.positions, &mesh.indices);
    let mut s = Sampler::for_key(5, 0, 0);
    let mut n_hits = 0;
    for i in 0..2000 {
        let axis = i % 3;
        let mut dir = Vec3::ZERO;
        dir[axis] = if i % 2 == 0 { 1.0 } else { -1.0 };
        let mut o = Vec3::new(4.0 * s.next_1d() - 2.0, 4.0 * s.next_1d() - 2.0, 4.0 * s.next_1d() - 2.0);
        if i % 5 == 0 {
            o[(axis + 1) % 3] = 1.0; // on a face plane, parallel to it
        }
        if i % 7 == 0 {
            dir[(axis + 2) % 3] = -0.0;
        }
        let ray = Ray::new(o, dir);
        let want = brute.intersect(&ray);
        n_hits += usize::from(want.is_some());
        assert_same_hit(bvh.intersect(&ray), want, &ray, "axis ray");
        assert_eq!(bvh.occluded(&ray), brute.occluded(&ray), "axis ray occluded {ray:?}");
    }
    assert!(n_hits > 200, "{n_hits}");
}

#[test]
fn t_interval_is_inclusive_and_honoured() {
    for mesh in [sphere(Vec3::ZERO, 1.0, 16, 24), cube()] {
        let bvh = build(&mesh);
        let brute = BruteForce::new(&mesh.positions, &mesh.indices);
        let mut n = 0;
        for ray in random_rays(&mesh, 6, 2000) {
            let Some(h) = brute.intersect(&ray) else { continue };
            n += 1;
            // t_max exactly at the hit: still hit (inclusive), with the same answer.
            let r = Ray::segment(ray.origin, ray.dir, ray.t_min, h.t);
            assert_same_hit(bvh.intersect(&r), Some(h), &r, "t_max = t");
            assert!(bvh.occluded(&r));
            // t_min exactly at the hit: the same triangle is found.
            let r = Ray::segment(ray.origin, ray.dir, h.t, f32::INFINITY);
            assert_eq!(bvh.intersect(&r).map(|g| g.t), Some(h.t), "t_min = t for {r:?}");
            // Just before the hit: nothing in [0, t⁻] but brute force's answer.
            let r = Ray::segment(ray.origin, ray.dir, 0.0, h.t * (1.0 - 1e-5));
            assert_same_hit(bvh.intersect(&r), brute.intersect(&r), &r, "t_max < t");
            assert_eq!(bvh.occluded(&r), brute.occluded(&r));
            // Past the hit: the next surface, as brute force sees it.
            let r = Ray::segment(ray.origin, ray.dir, h.t * (1.0 + 1e-4), f32::INFINITY);
            assert_same_hit(bvh.intersect(&r), brute.intersect(&r), &r, "t_min > t");
        }
        assert!(n > 600, "{n}");
    }
}

#[test]
fn closed_sphere_is_watertight_at_edges_and_vertices() {
    let mesh = sphere(Vec3::new(0.1, 0.2, -0.3), 1.3, 40, 64);
    let bvh = build(&mesh);
    let centre = Vec3::new(0.1, 0.2, -0.3);
    let mut targets: Vec<Vec3> = mesh.positions.clone();
    for t in &mesh.indices {
        for k in 0..3 {
            let (a, b) = (mesh.positions[t[k] as usize], mesh.positions[t[(k + 1) % 3] as usize]);
            targets.push(a + 0.5 * (b - a));
            targets.push(a + 0.25 * (b - a));
        }
    }
    let mut s = Sampler::for_key(7, 0, 0);
    let mut missed = 0;
    for (i, &p) in targets.iter().enumerate() {
        // From outside, towards the target, with a random tilt away from the radial direction.
        let radial = (p - centre).normalize();
        let tilt = 0.5 * uniform_sphere(&mut s);
        let origin = p + 3.0 * (radial + tilt);
        let ray = Ray::new(origin, p - origin);
        if bvh.intersect(&ray).is_none() || !bvh.occluded(&ray) {
            missed += 1;
            eprintln!("ray {i} through {p} slipped through");
        }
    }
    assert_eq!(missed, 0, "{missed} of {} rays slipped through the closed sphere", targets.len());
}

#[test]
fn reintersection_from_hit_points() {
    let centre = Vec3::new(0.5, -0.25, 0.125);
    for (mesh, scale) in [(sphere(centre, 1.0, 30, 50), 1.0f32), (sphere(centre * 1e4, 1e4, 30, 50), 1e4)] {
        let bvh = build(&mesh);
        let mut s = Sampler::for_key(8, 0, 0);
        let mut n = 0;
        for i in 0..3000 {
            let origin = centre * scale + 3.0 * scale * uniform_sphere(&mut s);
            let target = centre * scale + 0.5 * scale * uniform_sphere(&mut s);
            let Some(h) = bvh.intersect(&Ray::new(origin, target - origin)) else {
                panic!("ray {i} missed the sphere")
            };
            n += 1;
            let tri = mesh.triangle(h.prim as usize);
            let b = [1.0 - h.u - h.v, h.u, h.v];
            let p = b[0] * tri[0] + b[1] * tri[1] + b[2] * tri[2];
            let err = barycentric_point_error(b, tri);
            let ng = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
            // Leaving the surface (outward, random direction in the hemisphere): no hit at all,
            // since the sphere is convex.
            let mut out = uniform_sphere(&mut s);
            if out.dot(ng) < 0.0 {
                out = -out;
            }
            let leave = Ray::new(offset_ray_origin(p, err, ng, out), out);
            assert_eq!(bvh.intersect(&leave), None, "ray {i}: outward ray re-hit the sphere");
            assert!(!bvh.occluded(&leave));
            // Entering: the far side, well away from the spawn point.
            let inward = -ng + 0.3 * uniform_sphere(&mut s);
            let enter = Ray::new(offset_ray_origin(p, err, ng, inward), inward);
            let far = bvh
                .intersect(&enter)
                .unwrap_or_else(|| panic!("ray {i}: inward ray escaped the closed sphere"));
            assert!(
                far.prim != h.prim && far.t * inward.length() > 0.1 * scale,
                "ray {i}: re-hit {far:?} from {h:?}"
            );
        }
        assert_eq!(n, 3000);
    }
}

#[test]
fn degenerate_input() {
    // Empty soup.
    let empty = Bvh::build(&[], &[]);
    empty.validate().unwrap();
    assert_eq!(empty.intersect(&Ray::new(Vec3::ZERO, Vec3::X)), None);
    assert!(!empty.occluded(&Ray::new(Vec3::ZERO, Vec3::X)));
    assert_eq!(empty.stats().triangles, 0);

    // One triangle, and all triangles identical (every centroid equal).
    let one = TriangleMesh {
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        indices: vec![[0, 1, 2]],
        ..Default::default()
    };
    agree_with_brute(&one, 9, 500, "one triangle");
    let same = TriangleMesh {
        positions: one.positions.clone(),
        indices: vec![[0, 1, 2]; 100],
        ..Default::default()
    };
    let bvh = build(&same);
    let h = bvh.intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z)).expect("hit");
    assert_eq!(h.prim, 0, "ties resolve to the lowest index");
    agree_with_brute(&same, 10, 500, "identical triangles");

    // Zero-area triangles (points and segments) mixed with real ones.
    let mut degen = random_soup(11, 400, 0.2, 1.0, Vec3::ZERO);
    for i in 0..200u32 {
        let p = Vec3::new(i as f32 * 0.01 - 1.0, 0.0, 0.0);
        let base = degen.positions.len() as u32;
        degen.positions.extend([p, p, p + Vec3::Y * 0.1]);
        degen.indices.push([base, base, base]);
        degen.indices.push([base, base + 1, base + 2]);
    }
    agree_with_brute(&degen, 11, 2000, "zero-area");

    // Coordinates near 1e6.
    let far = random_soup(12, 2000, 0.2, 1000.0, Vec3::splat(1e6));
    agree_with_brute(&far, 12, 2000, "offset 1e6");
    let far_sphere = sphere(Vec3::new(1e6, -1e6, 1e6), 100.0, 20, 30);
    agree_with_brute(&far_sphere, 13, 2000, "sphere at 1e6");

    // Triangles along a line with exponentially growing gaps: the SAH would recurse once per
    // triangle; the depth cap switches to median splits.
    let mut line = TriangleMesh::default();
    for i in 0..2000u32 {
        let x = 1.02f32.powi(i as i32);
        line.positions
            .extend([Vec3::new(x, -1.0, -1.0), Vec3::new(x, 1.0, -1.0), Vec3::new(x, 0.0, 1.0)]);
        line.indices.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let deep = build(&line);
    assert!(deep.stats().max_depth < 64, "{:?}", deep.stats());
    agree_with_brute(&line, 14, 1000, "exponential line");

    // Degenerate rays: zero direction, NaN components, an empty interval. No hit, no panic.
    let bvh = build(&cube());
    let nan = Vec3::new(f32::NAN, 0.0, 0.0);
    for ray in [
        Ray::new(Vec3::ZERO, Vec3::ZERO),
        Ray::new(nan, Vec3::X),
        Ray::new(Vec3::ZERO, nan),
        Ray::segment(Vec3::ZERO, Vec3::X, 2.0, 1.0),
        Ray::segment(Vec3::ZERO, Vec3::X, f32::NAN, f32::NAN),
    ] {
        assert_eq!(bvh.intersect(&ray), None, "{ray:?}");
        assert!(!bvh.occluded(&ray), "{ray:?}");
    }
}

#[test]
fn stats_are_consistent() {
    let mesh = sphere(Vec3::ZERO, 1.0, 40, 60);
    let bvh = build(&mesh);
    let st = bvh.stats();
    assert_eq!(st.triangles, mesh.triangle_count());
    assert!(st.nodes >= 1 && st.leaves >= st.triangles / caustica::accel::bvh::MAX_LEAF);
    assert!(st.max_depth >= 3 && st.max_depth < 40, "{st:?}");
    assert!(st.memory_bytes >= st.triangles * 40 + st.nodes * 64, "{st:?}");
}

/// Nanoseconds the calling thread has run on a CPU (`/proc/thread-self/schedstat`, field 1), so
/// the benchmark reports per-core throughput even on a machine shared with other jobs.
fn thread_cpu_ns() -> Option<u64> {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Runs `f`, returning its result with its wall time and (if available) the calling thread's CPU time.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, Option<f64>) {
    let (c0, t0) = (thread_cpu_ns(), std::time::Instant::now());
    let out = f();
    let wall = t0.elapsed().as_secs_f64();
    let cpu = thread_cpu_ns().zip(c0).map(|(c1, c0)| (c1 - c0) as f64 * 1e-9);
    (out, wall, cpu)
}

/// Incoherent-ray throughput and build time. Run with
/// `cargo test --release --no-default-features --test suite -- --ignored bvh_speed --nocapture`.
/// Environment: `BVH_SPEED_RINGS` (sphere resolution, default 317 → 200k triangles), `BVH_SPEED_RAYS`.
#[test]
#[ignore = "benchmark"]
fn bvh_speed() {
    let rings: u32 = std::env::var("BVH_SPEED_RINGS").ok().and_then(|s| s.parse().ok()).unwrap_or(317);
    let n_rays: usize = std::env::var("BVH_SPEED_RAYS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let cases = [
        ("sphere", sphere(Vec3::ZERO, 1.0, rings, rings)),
        ("soup", random_soup(21, 200_000, 0.05, 1.0, Vec3::ZERO)),
    ];
    for (name, mesh) in cases {
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let (mut wall, mut cpu) = (f64::INFINITY, f64::INFINITY);
            for _ in 0..5 {
                // On one thread all the work runs on the pool's worker, so its CPU time is the build's.
                let (bvh, w, c) = pool.install(|| timed(|| Bvh::build(&mesh.positions, &mesh.indices)));
                std::hint::black_box(&bvh);
                wall = wall.min(w);
                cpu = cpu.min(c.unwrap_or(f64::NAN));
            }
            let cpu = if threads == 1 {
                format!(", {:.1} ms CPU", cpu * 1e3)
            } else {
                String::new()
            };
            println!(
                "{name}: {} tris, build {:.1} ms wall on {threads} thread(s){cpu}",
                mesh.triangle_count(),
                wall * 1e3
            );
        }
        let bvh = Bvh::build(&mesh.positions, &mesh.indices);
        bvh.validate().unwrap();
        println!("{name}: {:?}", bvh.stats());
        let b = mesh.bounds();
        let rays: Vec<Ray> = (0..n_rays)
            .map(|i| {
                let mut s = Sampler::for_key(22, i as u64, 0);
                Ray::new(point_in(&b, &mut s), uniform_sphere(&mut s))
            })
            .collect();
        let shadow: Vec<Ray> = (0..n_rays)
            .map(|i| {
                let mut s = Sampler::for_key(23, i as u64, 0);
                let (p, q) = (point_in(&b, &mut s), point_in(&b, &mut s));
                Ray::segment(p, q - p, 0.0, 1.0)
            })
            .collect();
        let rate = |wall: f64, cpu: Option<f64>| {
            format!(
                "{:.2} Mrays/s CPU ({:.2} wall)",
                n_rays as f64 / cpu.unwrap_or(f64::NAN) / 1e6,
                n_rays as f64 / wall / 1e6
            )
        };
        for _ in 0..2 {
            let (hits, w, c) = timed(|| rays.iter().filter(|r| bvh.intersect(r).is_some()).count());
            let (occ, ws, cs) = timed(|| shadow.iter().filter(|r| bvh.occluded(r)).count());
            println!(
                "{name}: 1 thread: closest {} ({hits} hits), shadow {} ({occ} occluded)",
                rate(w, c),
                rate(ws, cs)
            );
        }
    }
}

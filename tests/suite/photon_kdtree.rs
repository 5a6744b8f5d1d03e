//! The photon kd-tree's k-NN query against a brute-force scan: same sorted distances (exactly), same
//! radius, on uniform, planar, clustered and degenerate photon sets, with and without an acceptance test.

use caustica::math::Vec3;
use caustica::photon::{KdTree, KnnResult, Photon};
use caustica::sampler::Sampler;

fn uniform_sphere(s: &mut Sampler) -> Vec3 {
    let z = 1.0 - 2.0 * s.next_1d();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * s.next_1d();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn photon_at(p: Vec3, s: &mut Sampler) -> Photon {
    Photon::new(p, uniform_sphere(s), Vec3::new(s.next_1d(), 1.0, 2.0), 1.0 + s.next_1d())
}

/// Squared distance with the tree's operation order, so brute force and tree agree to the bit.
fn dist2(a: Vec3, b: Vec3) -> f32 {
    let d = a - b;
    (d.x * d.x + d.y * d.y) + d.z * d.z
}

/// Brute force: sorted squared distances of the k nearest accepted photons within `max_radius`, and r².
fn brute(photons: &[Photon], q: Vec3, k: usize, max_radius: f32, accept: &dyn Fn(&Photon) -> bool) -> (Vec<f32>, f32) {
    let max_r2 = max_radius * max_radius;
    let mut d: Vec<f32> = photons
        .iter()
        .filter(|p| accept(p))
        .map(|p| dist2(p.position(), q))
        .filter(|&d2| d2 <= max_r2)
        .collect();
    d.sort_by(f32::total_cmp);
    d.truncate(k);
    let r2 = if k == 0 {
        0.0
    } else if d.len() == k {
        d[k - 1]
    } else {
        max_r2
    };
    (d, r2)
}

/// Checks one query: distances, radius, that every returned photon is accepted and that the reported
/// distance is that photon's, and that indices are distinct.
fn check(tree: &KdTree, photons: &[Photon], q: Vec3, k: usize, max_radius: f32, accept: &dyn Fn(&Photon) -> bool, out: &mut KnnResult) {
    tree.knn(q, k, max_radius, accept, out);
    let (want, want_r2) = brute(photons, q, k, max_radius, accept);
    for (ph, d2) in out.photons(tree) {
        assert!(accept(ph), "a rejected photon was returned");
        assert_eq!(dist2(ph.position(), q), d2);
    }
    let mut idx: Vec<u32> = out.neighbors().iter().map(|n| n.index).collect();
    idx.sort_unstable();
    idx.dedup();
    assert_eq!(idx.len(), out.len(), "duplicate photons in the result");
    let mut got: Vec<f32> = out.neighbors().iter().map(|n| n.dist2).collect();
    got.sort_by(f32::total_cmp);
    assert_eq!(got, want, "q={q:?} k={k} max_radius={max_radius}");
    assert_eq!(out.r2().to_bits(), want_r2.to_bits(), "r² at q={q:?} k={k} max_radius={max_radius}");
}

/// Runs queries near the photons and at random points of a slightly enlarged box, for several k, radii,
/// leaf sizes, with and without a hemisphere acceptance test.
fn compare_on(photons: &[Photon], seed: u64, n_queries: usize) {
    let bounds = photons.iter().fold(caustica::math::Aabb::EMPTY, |b, p| b.grow(p.position()));
    let (lo, ext) = (
        bounds.min - 0.1 * bounds.extent() - Vec3::splat(0.01),
        1.2 * bounds.extent() + Vec3::splat(0.02),
    );
    let normal = Vec3::new(0.3, -0.2, 0.9).normalize();
    let hemisphere = move |p: &Photon| p.wi_world().dot(normal) > 0.0;
    let all = |_: &Photon| true;
    let diag = ext.length();
    for leaf in [1, 5, 8, 32] {
        let tree = KdTree::build_with_leaf_size(photons.to_vec(), leaf).unwrap();
        assert_eq!(tree.len(), photons.len());
        let mut out = KnnResult::default();
        let mut s = Sampler::for_key(seed, leaf as u64, 0);
        for qi in 0..n_queries {
            let q = if qi % 2 == 0 && !photons.is_empty() {
                let p = photons[(s.next_u32() as usize) % photons.len()].position();
                p + 0.01 * diag * (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5)
            } else {
                lo + ext * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d())
            };
            for k in [1usize, 7, 50, 300] {
                for max_radius in [f32::INFINITY, 0.02 * diag, 0.2 * diag] {
                    check(&tree, photons, q, k, max_radius, &all, &mut out);
                    check(&tree, photons, q, k, max_radius, &hemisphere, &mut out);
                }
            }
        }
    }
}

#[test]
fn uniform_points_match_brute_force() {
    let mut s = Sampler::for_key(1, 0, 0);
    let photons: Vec<Photon> = (0..4000)
        .map(|_| photon_at(Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()), &mut s))
        .collect();
    compare_on(&photons, 11, 120);
}

#[test]
fn planar_and_clustered_points_match_brute_force() {
    // A caustic on a floor: all photons at z = 0, half of them in a tight focus.
    let mut s = Sampler::for_key(2, 0, 0);
    let photons: Vec<Photon> = (0..4000)
        .map(|i| {
            let (x, y) = if i % 2 == 0 {
                (s.next_1d() * 4.0 - 2.0, s.next_1d() * 4.0 - 2.0)
            } else {
                (0.3 + 1e-3 * s.next_1d(), -0.2 + 1e-3 * s.next_1d())
            };
            photon_at(Vec3::new(x, y, 0.0), &mut s)
        })
        .collect();
    compare_on(&photons, 12, 120);
}

#[test]
fn sparse_clusters_and_empty_space_match_brute_force() {
    // Tight clusters far apart: most queries between them find nothing (the occupancy-grid reject), and
    // queries exactly one radius away from a photon along an axis must still find it (inclusive radius).
    let mut s = Sampler::for_key(5, 0, 0);
    let centres: Vec<Vec3> = (0..8).map(|_| 10.0 * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d())).collect();
    let photons: Vec<Photon> = (0..800)
        .map(|i| photon_at(centres[i % 8] + 1e-2 * Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()), &mut s))
        .collect();
    compare_on(&photons, 15, 200);
    let tree = KdTree::build(photons.clone()).unwrap();
    let mut out = KnnResult::default();
    let all = |_: &Photon| true;
    for (i, ph) in photons.iter().enumerate().step_by(37) {
        for r in [1e-3f32, 0.1, 0.37, 2.0] {
            let mut offset = Vec3::ZERO;
            offset[i % 3] = if i % 2 == 0 { r } else { -r };
            check(&tree, &photons, ph.position() + offset, 5, r, &all, &mut out);
        }
    }
}

#[test]
fn duplicates_and_ties_match_brute_force() {
    // Positions on a coarse integer grid: many exact duplicates and many equal distances.
    let mut s = Sampler::for_key(3, 0, 0);
    let photons: Vec<Photon> = (0..3000)
        .map(|_| {
            let p = Vec3::new(
                (s.next_1d() * 5.0).floor(),
                (s.next_1d() * 5.0).floor(),
                (s.next_1d() * 3.0).floor(),
            );
            photon_at(p, &mut s)
        })
        .collect();
    compare_on(&photons, 13, 80);
    // Queries exactly on grid points, where ties are everywhere.
    let tree = KdTree::build(photons.clone()).unwrap();
    let mut out = KnnResult::default();
    for q in [
        Vec3::ZERO,
        Vec3::new(2.0, 2.0, 1.0),
        Vec3::new(2.5, 2.0, 1.0),
        Vec3::new(4.0, 4.0, 2.0),
    ] {
        for k in [1, 10, 100, 129, 500] {
            check(&tree, &photons, q, k, f32::INFINITY, &|_| true, &mut out);
        }
    }
}

#[test]
fn all_coincident_photons() {
    let mut s = Sampler::for_key(4, 0, 0);
    let c = Vec3::new(0.5, -1.0, 2.0);
    let photons: Vec<Photon> = (0..1000).map(|_| photon_at(c, &mut s)).collect();
    let tree = KdTree::build(photons.clone()).unwrap();
    let mut out = KnnResult::default();
    // At the point itself the radius collapses to 0 (the caller clamps ΔA).
    tree.knn(c, 50, f32::INFINITY, |_| true, &mut out);
    assert_eq!((out.len(), out.r2()), (50, 0.0));
    for q in [c, c + Vec3::new(0.1, 0.0, 0.0), c + Vec3::new(0.0, -3.0, 7.0)] {
        for k in [1, 50, 999, 1000, 1001] {
            check(&tree, &photons, q, k, f32::INFINITY, &|_| true, &mut out);
            check(&tree, &photons, q, k, 0.5, &|p: &Photon| p.wi_world().z > 0.0, &mut out);
        }
    }
    compare_on(&photons, 14, 10);
}

#[test]
fn empty_map_k_zero_and_k_larger_than_n() {
    let mut out = KnnResult::default();
    let empty = KdTree::build(Vec::new()).unwrap();
    assert!(empty.is_empty() && empty.photons().is_empty());
    empty.knn(Vec3::ZERO, 10, 2.0, |_| true, &mut out);
    assert!(out.is_empty());
    assert_eq!(out.r2(), 4.0);
    empty.knn(Vec3::ZERO, 10, f32::INFINITY, |_| true, &mut out);
    assert_eq!(out.r2(), f32::INFINITY);

    let mut s = Sampler::for_key(5, 0, 0);
    let photons: Vec<Photon> = (0..37)
        .map(|_| photon_at(Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()), &mut s))
        .collect();
    let tree = KdTree::build(photons.clone()).unwrap();
    tree.knn(Vec3::splat(0.5), 0, f32::INFINITY, |_| true, &mut out);
    assert!(out.is_empty());
    assert_eq!(out.r2(), 0.0);
    tree.knn(Vec3::splat(0.5), 100, f32::INFINITY, |_| true, &mut out);
    assert_eq!((out.len(), out.r2()), (37, f32::INFINITY));
    tree.knn(Vec3::splat(0.5), 100, 0.3, |_| true, &mut out);
    assert_eq!(out.r2(), 0.09);
    // Predicate rejecting everything: nothing found, radius = max_radius.
    tree.knn(Vec3::splat(0.5), 5, 1.0, |_| false, &mut out);
    assert_eq!((out.len(), out.r2()), (0, 1.0));
    check(&tree, &photons, Vec3::splat(0.5), 37, f32::INFINITY, &|_| true, &mut out);
    check(
        &tree,
        &photons,
        Vec3::splat(0.5),
        38,
        0.4,
        &|p: &Photon| p.power().x > 0.5,
        &mut out,
    );
    // A single photon.
    let one = KdTree::build(photons[..1].to_vec()).unwrap();
    check(&one, &photons[..1], Vec3::ZERO, 3, f32::INFINITY, &|_| true, &mut out);
    // Query at a photon: distance exactly 0.
    tree.knn(photons[3].position(), 1, f32::INFINITY, |_| true, &mut out);
    assert_eq!((out.len(), out.r2()), (1, 0.0));
}

#[test]
fn rejected_photons_do_not_shrink_the_radius() {
    // Ten photons close to the query arrive from below (rejected), ten farther ones from above.
    let mut photons = Vec::new();
    for i in 0..10 {
        photons.push(Photon::new(Vec3::new(0.01 * (i as f32 + 1.0), 0.0, 0.0), -Vec3::Z, Vec3::ONE, 1.0));
        photons.push(Photon::new(Vec3::new(0.0, 1.0 + i as f32, 0.0), Vec3::Z, Vec3::ONE, 1.0));
    }
    let tree = KdTree::build_with_leaf_size(photons, 2).unwrap();
    let mut out = KnnResult::default();
    tree.knn(Vec3::ZERO, 3, f32::INFINITY, |p| p.wi_world().dot(Vec3::Z) > 0.0, &mut out);
    out.sort_by_distance();
    let d: Vec<f32> = out.neighbors().iter().map(|n| n.dist2).collect();
    assert_eq!(d, vec![1.0, 4.0, 9.0]);
    assert_eq!(out.r2(), 9.0);
}

#[test]
#[cfg_attr(debug_assertions, should_panic(expected = "non-finite query point"))]
fn nan_query_point_returns_empty() {
    let tree = KdTree::build(vec![Photon::new(Vec3::ZERO, Vec3::Z, Vec3::ONE, 1.0)]).unwrap();
    let mut out = KnnResult::default();
    tree.knn(Vec3::new(f32::NAN, 0.0, 0.0), 4, 1.0, |_| true, &mut out);
    assert!(out.is_empty());
    assert_eq!(out.r2(), 1.0);
}

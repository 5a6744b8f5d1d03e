//! Tests of area lights, the constant light and the light set: pdf consistency between `sample_li` and the
//! `pdf_li_*` queries (1e-3 relative), Monte Carlo estimates of known integrals within 5 standard errors,
//! selection ∝ power, and the primitive → light table.

use super::test_util::{assert_within_5_sigma, Mean};
use super::*;
use crate::math::{Aabb, Vec2, Vec3};
use crate::sampler::Sampler;
use std::f32::consts::PI;

/// A tilted quad (two triangles, normal ∝ (0.06, −0.48, −0.01), i.e. facing down) above the origin, prims 10 and 11.
fn quad_light(radiance: Vec3) -> AreaLight {
    let c = Vec3::new(0.2, 2.0, -0.1);
    let (a, b) = (Vec3::new(0.8, 0.1, 0.0), Vec3::new(0.1, 0.0, 0.6));
    let (p0, p1, p2, p3) = (c - a - b, c + a - b, c + a + b, c - a + b);
    // (p1 − p0) × (p2 − p0) = 2a × (2a + 2b) ∝ a × b = (0.06, −0.48, −0.01).
    AreaLight::new(radiance, vec![(10, [p0, p1, p2]), (11, [p0, p2, p3])])
}

/// Brute-force `∫_A f(ω) L cos θ_l / d² dA` over the front-facing part of `tris` (each triangle split into
/// n² congruent sub-triangles, centroid rule; relative error O(1/n²)).
fn quadrature(tris: &[[Vec3; 3]], p_ref: Vec3, n: usize, f: impl Fn(Vec3) -> f64) -> f64 {
    let mut total = 0.0f64;
    for t in tris {
        let c = (t[1] - t[0]).cross(t[2] - t[0]);
        let ng = c.normalize();
        let sub_area = f64::from(0.5 * c.length()) / (n * n) as f64;
        let at = |i: f32, j: f32| t[0] + (t[1] - t[0]) * (i / n as f32) + (t[2] - t[0]) * (j / n as f32);
        for i in 0..n {
            for j in 0..n - i {
                let mut centroids = vec![(at(i as f32, j as f32) + at(i as f32 + 1.0, j as f32) + at(i as f32, j as f32 + 1.0)) / 3.0];
                if i + j + 1 < n {
                    centroids
                        .push((at(i as f32 + 1.0, j as f32) + at(i as f32, j as f32 + 1.0) + at(i as f32 + 1.0, j as f32 + 1.0)) / 3.0);
                }
                for p in centroids {
                    let d = p - p_ref;
                    let d2 = d.length_squared();
                    let w = d / d2.sqrt();
                    let cos_l = -ng.dot(w);
                    if cos_l > 0.0 {
                        total += f(w) * f64::from(cos_l / d2) * sub_area;
                    }
                }
            }
        }
    }
    total
}

#[test]
fn area_light_mc_integrals_match_quadrature_within_5_sigma() {
    // A quad facing p_ref plus one triangle facing away (its samples return None and count as 0).
    let radiance = Vec3::new(1.0, 2.0, 0.5);
    let quad = quad_light(radiance);
    let back = [Vec3::new(-1.0, 1.5, 0.5), Vec3::new(-1.0, 1.5, 1.0), Vec3::new(-0.5, 1.5, 0.5)]; // normal +y: away
    let mut tris = quad.triangle_list();
    tris.push((12, back));
    let light = AreaLight::new(radiance, tris.clone());
    let p_ref = Vec3::new(0.3, 0.0, 0.2);
    let n_r = Vec3::new(0.2, 1.0, -0.3).normalize();
    let y = f64::from(luminance(radiance));
    type TestFn = Box<dyn Fn(Vec3) -> f64>;
    let fs: [(&str, TestFn); 3] = [
        ("solid angle", Box::new(|_| 1.0)),
        ("irradiance", Box::new(move |w: Vec3| f64::from(n_r.dot(w).max(0.0)))),
        ("x² lobe", Box::new(|w: Vec3| f64::from(w.x * w.x))),
    ];
    let shapes: Vec<[Vec3; 3]> = tris.iter().map(|t| t.1).collect();
    let mut sampler = Sampler::for_key(1, 2, 3);
    let samples: Vec<Option<LightSample>> = (0..200_000).map(|_| light.sample_li(p_ref, sampler.next_2d())).collect();
    let back_count = samples.iter().filter(|s| s.is_none()).count() as f64;
    // The back triangle is chosen ∝ area, and those samples must all be rejected.
    let p_back = 0.125 / f64::from(light.area());
    assert!(
        (back_count / 200_000.0 - p_back).abs() < 5.0 * (p_back * (1.0 - p_back) / 200_000.0).sqrt(),
        "{back_count}"
    );
    for (name, f) in &fs {
        let mut m = Mean::default();
        for s in &samples {
            m.add(s.map_or(0.0, |s| f64::from(luminance(s.li)) * f(s.wi_world) / f64::from(s.pdf_w)));
        }
        let reference = y * quadrature(&shapes, p_ref, 300, f);
        assert_within_5_sigma(name, &m, reference, 1e-4 * reference);
    }
}

#[test]
fn area_light_one_sided_and_degenerate() {
    let light = quad_light(Vec3::ONE);
    // Above the downward-facing quad: behind it.
    let behind = Vec3::new(0.2, 3.0, 0.0);
    let mut sampler = Sampler::for_key(4, 0, 0);
    assert!((0..1000).all(|_| light.sample_li(behind, sampler.next_2d()).is_none()));
    assert_eq!(light.le(-Vec3::Y, Vec3::Y, || unreachable!()), Vec3::ZERO);
    assert_eq!(light.le(-Vec3::Y, -Vec3::Y, || unreachable!()), Vec3::ONE);
    assert_eq!(light.pdf_li(behind, Vec3::new(0.2, 2.0, -0.1), -Vec3::Y), 0.0);
    // A point on the light itself.
    assert_eq!(light.pdf_li(Vec3::new(0.2, 2.0, -0.1), Vec3::new(0.2, 2.0, -0.1), -Vec3::Y), 0.0);
    // Only degenerate triangles: no area, no power, no samples.
    let flat = AreaLight::new(Vec3::ONE, vec![(0, [Vec3::ZERO, Vec3::X, 2.0 * Vec3::X])]);
    assert_eq!((flat.area(), flat.power()), (0.0, 0.0));
    assert!(flat.sample_li(Vec3::Y, Vec2::splat(0.3)).is_none());
    assert!(flat.sample_le(Vec2::splat(0.3), Vec2::splat(0.3), 0.5).is_none());
    // A degenerate triangle beside a good one is never sampled.
    let mixed = AreaLight::new(
        Vec3::ONE,
        vec![(0, [Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]), (1, [Vec3::ZERO, Vec3::X, Vec3::Z])],
    );
    for _ in 0..1000 {
        let s = mixed.sample_li(Vec3::new(0.2, -1.0, 0.2), sampler.next_2d()).unwrap();
        assert_eq!(s.n_light, -Vec3::Y);
    }
}

#[test]
fn area_light_emission_samples() {
    let light = quad_light(Vec3::new(2.0, 1.0, 1.0));
    assert!((light.area() - 4.0 * Vec3::new(0.8, 0.1, 0.0).cross(Vec3::new(0.1, 0.0, 0.6)).length()).abs() < 1e-5);
    assert!((light.power() - PI * light.area() * luminance(light.radiance())).abs() < 1e-5);
    let mut sampler = Sampler::for_key(9, 0, 0);
    let (mut cos_mean, mut flux) = (Mean::default(), Mean::default());
    let n = 100_000;
    let mut first_triangle = 0u32;
    let n_quad = Vec3::new(0.8, 0.1, 0.0).cross(Vec3::new(0.1, 0.0, 0.6)).normalize();
    for _ in 0..n {
        let e = light.sample_le(sampler.next_2d(), sampler.next_2d(), sampler.next_1d()).unwrap();
        assert!((e.n - n_quad).length() < 1e-5 && e.dir.dot(e.n) > 0.0);
        assert!((e.pdf_a - 1.0 / light.area()).abs() < 1e-6);
        // The origin sits just off the quad's plane, on the emitting side.
        let height = (e.origin - Vec3::new(0.2, 2.0, -0.1)).dot(n_quad);
        assert!((0.0..1e-5).contains(&height), "height {height}");
        let cos = e.n.dot(e.dir);
        assert!((e.pdf_w_dir - cos / PI).abs() < 1e-5);
        cos_mean.add(f64::from(cos));
        flux.add(f64::from(luminance(e.le) * cos / (e.pdf_a * e.pdf_w_dir)));
        // Which triangle: the quad's diagonal p0–p2 splits it; triangle 10 holds the corner c + a − b.
        let q = e.origin - Vec3::new(0.2, 2.0, -0.1);
        let (a, b) = (Vec3::new(0.8, 0.1, 0.0), Vec3::new(0.1, 0.0, 0.6));
        let (aa, ab, bb) = (a.dot(a), a.dot(b), b.dot(b));
        let det = aa * bb - ab * ab;
        let (s, t) = ((bb * q.dot(a) - ab * q.dot(b)) / det, (aa * q.dot(b) - ab * q.dot(a)) / det);
        if s > t {
            first_triangle += 1;
        }
    }
    // Cosine-weighted directions: E[cos θ] = 2/3.
    assert_within_5_sigma("E[cos]", &cos_mean, 2.0 / 3.0, 0.0);
    // ∫∫ Y(L) cos dω dA = π·A·Y(L) = Φ (per-sample exact, so only rounding remains).
    assert!((flux.mean() - f64::from(light.power())).abs() < 1e-4 * f64::from(light.power()));
    // Both triangles have the same area: selected half the time each.
    assert!((f64::from(first_triangle) - 0.5 * f64::from(n)).abs() < 5.0 * (0.25 * f64::from(n)).sqrt());
}

fn scene_bounds() -> Aabb {
    Aabb::from_points(&[Vec3::splat(-1.0), Vec3::splat(1.0)])
}

/// A set with two area lights, a constant light and a black area light (zero power).
fn mixed_set() -> LightSet {
    let tilted = AreaLight::new(
        Vec3::new(5.0, 5.0, 5.0),
        vec![(
            3,
            [Vec3::new(-1.0, 1.0, -1.0), Vec3::new(-1.0, 1.2, 0.0), Vec3::new(0.0, 1.5, -1.0)],
        )],
    );
    let black = AreaLight::new(
        Vec3::ZERO,
        vec![(4, [Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0), Vec3::new(1.0, 1.0, 0.0)])],
    );
    let lights = vec![
        Light::Area(quad_light(Vec3::new(1.0, 2.0, 0.5))),
        Light::Area(black),
        Light::Constant {
            radiance: Vec3::splat(0.01),
        },
        Light::Area(tilted),
    ];
    LightSet::new(lights, 20, scene_bounds())
}

#[test]
fn light_set_pdfs_match_the_queries_and_zero_power_is_never_chosen() {
    let set = mixed_set();
    assert_eq!(set.power(1), 0.0);
    let p_ref = Vec3::new(0.1, -0.5, 0.3);
    let mut sampler = Sampler::for_key(21, 0, 0);
    let mut counts = [0u64; 4];
    let n = 100_000u64;
    for _ in 0..n {
        let Some((index, ls)) = set.sample_li(p_ref, sampler.next_1d(), sampler.next_2d()) else {
            continue;
        };
        counts[index] += 1;
        let recomputed = match &set.lights()[index] {
            Light::Area(a) => {
                // Find the emissive triangle holding p_light to query by primitive.
                let prim = (0..20u32)
                    .find(|&p| set.light_of_prim(p) == Some(index) && a.contains(p, ls.p_light))
                    .expect("p_light on a triangle");
                assert_eq!(set.le_area(prim, ls.n_light, -ls.wi_world, || unreachable!()), ls.li);
                set.pdf_li_area(prim, p_ref, ls.p_light, ls.n_light)
            }
            _ => {
                assert_eq!(set.le_escaped(ls.wi_world), ls.li);
                set.pdf_li_escaped(ls.wi_world)
            }
        };
        assert!(
            (recomputed - ls.pdf_w).abs() <= 1e-3 * ls.pdf_w,
            "light {index}: {recomputed} vs {}",
            ls.pdf_w
        );
    }
    assert_eq!(counts[1], 0, "the black light was chosen");
    // Emission selection ∝ power within 5σ.
    let mut em = [0u64; 4];
    for _ in 0..n {
        let (i, pmf) = set.sample_light_for_emission(sampler.next_1d()).unwrap();
        assert_eq!(pmf, set.selection_pmf(i));
        em[i] += 1;
    }
    let total: f32 = (0..4).map(|i| set.power(i)).sum();
    assert!((set.total_power() - total).abs() <= 1e-6 * total);
    for (i, &c) in em.iter().enumerate() {
        let p = f64::from(set.power(i) / total);
        assert!(
            (c as f64 - n as f64 * p).abs() <= 5.0 * (n as f64 * p * (1.0 - p)).sqrt().max(1e-9),
            "light {i}"
        );
    }
}

#[test]
fn light_set_nee_estimates_irradiance_from_all_lights() {
    // E[f·Li/pdf] over NEE samples = Σ over lights of ∫ Li cos dω: the area lights by quadrature, the
    // constant light analytically (π·L for a cosine lobe).
    let set = mixed_set();
    let p_ref = Vec3::new(0.1, -0.5, 0.3);
    let n_r = Vec3::new(0.1, 1.0, 0.2).normalize();
    let mut m = Mean::default();
    let mut sampler = Sampler::for_key(22, 0, 0);
    for _ in 0..300_000 {
        m.add(set.sample_li(p_ref, sampler.next_1d(), sampler.next_2d()).map_or(0.0, |(_, ls)| {
            f64::from(luminance(ls.li) * n_r.dot(ls.wi_world).max(0.0) / ls.pdf_w)
        }));
    }
    let mut reference = f64::from(PI * luminance(Vec3::splat(0.01)));
    for light in set.lights() {
        if let Light::Area(a) = light {
            let tris: Vec<[Vec3; 3]> = a.triangle_list().into_iter().map(|t| t.1).collect();
            reference += f64::from(luminance(a.radiance())) * quadrature(&tris, p_ref, 300, |w| f64::from(n_r.dot(w).max(0.0)));
        }
    }
    assert_within_5_sigma("irradiance", &m, reference, 1e-4 * reference);
}

/// With one light the choice reads nothing of `u_select` (the path tracer then draws no dimension for it):
/// the same sample for any value.
#[test]
fn one_light_ignores_the_selection_number() {
    let set = LightSet::new(vec![Light::Area(quad_light(Vec3::new(1.0, 2.0, 0.5)))], 20, scene_bounds());
    assert!(!set.chooses_light() && mixed_set().chooses_light());
    let key = |s: Option<(usize, LightSample)>| s.map(|(i, ls)| (i, ls.wi_world, ls.dist, ls.li, ls.pdf_w, ls.p_light));
    let mut sampler = Sampler::for_key(29, 0, 0);
    for _ in 0..1000 {
        let (p_ref, u) = (Vec3::new(sampler.next_1d() - 0.5, -0.5, sampler.next_1d() - 0.5), sampler.next_2d());
        let first = key(set.sample_li(p_ref, 0.0, u));
        assert!(first.is_some());
        for u_select in [0.3, 0.999] {
            assert_eq!(key(set.sample_li(p_ref, u_select, u)), first);
        }
    }
}

#[test]
fn prim_table_and_area_emission() {
    let set = mixed_set();
    assert_eq!(set.light_of_prim(10), Some(0));
    assert_eq!(set.light_of_prim(11), Some(0));
    assert_eq!(set.light_of_prim(4), Some(1));
    assert_eq!(set.light_of_prim(3), Some(3));
    assert_eq!(set.light_of_prim(0), None);
    assert_eq!(set.light_of_prim(1000), None);
    assert_eq!(set.le_area(10, -Vec3::Y, -Vec3::Y, || unreachable!()), Vec3::new(1.0, 2.0, 0.5));
    assert_eq!(set.le_area(10, -Vec3::Y, Vec3::Y, || unreachable!()), Vec3::ZERO);
    assert_eq!(set.le_area(0, -Vec3::Y, -Vec3::Y, || unreachable!()), Vec3::ZERO);
    assert_eq!(set.pdf_li_area(0, Vec3::ZERO, Vec3::Y, -Vec3::Y), 0.0);
    assert!(!set.has_env());
    assert!(!set.is_empty());
    // A primitive beyond triangle_count still maps (the table grows) in release builds; empty set.
    let empty = LightSet::new(Vec::new(), 0, Aabb::EMPTY);
    assert!(empty.is_empty() && empty.sample_li(Vec3::ZERO, 0.5, Vec2::splat(0.5)).is_none() && empty.total_power() == 0.0);
    assert!(empty.sample_light_for_emission(0.5).is_none());
    assert_eq!(empty.le_escaped(Vec3::Y), Vec3::ZERO);
}

#[test]
fn constant_light_only() {
    let radiance = Vec3::new(0.5, 1.0, 2.0);
    let set = LightSet::new(vec![Light::Constant { radiance }], 0, scene_bounds());
    let (_, r) = set.scene_sphere();
    assert!((r - 3f32.sqrt()).abs() < 1e-6);
    assert!((set.total_power() - PI * r * r * 4.0 * PI * luminance(radiance)).abs() < 1e-4 * set.total_power());
    assert_eq!(set.le_escaped(Vec3::X), radiance);
    assert!((set.pdf_li_escaped(Vec3::X) - 1.0 / (4.0 * PI)).abs() < 1e-7);
    assert!(!set.has_env());
    let n_r = Vec3::new(0.3, -0.2, 1.0).normalize();
    let mut m = Mean::default();
    let mut sampler = Sampler::for_key(23, 0, 0);
    for _ in 0..100_000 {
        let (i, ls) = set.sample_li(Vec3::ZERO, sampler.next_1d(), sampler.next_2d()).unwrap();
        assert_eq!(i, 0);
        assert!(ls.dist.is_infinite() && (ls.wi_world.length() - 1.0).abs() < 1e-5 && ls.pdf_w == set.pdf_li_escaped(ls.wi_world));
        m.add(f64::from(luminance(ls.li) * n_r.dot(ls.wi_world).max(0.0) / ls.pdf_w));
    }
    // Irradiance from a uniform environment: π·L.
    assert_within_5_sigma("constant irradiance", &m, f64::from(PI * luminance(radiance)), 0.0);
    // Emission: origin on the disk outside the bounding sphere, travelling inward.
    let (c, r) = set.scene_sphere();
    for _ in 0..1000 {
        let e = set.lights()[0]
            .sample_le(sampler.next_2d(), sampler.next_2d(), sampler.next_1d(), c, r)
            .unwrap();
        assert!(((e.origin - c).dot(-e.dir) - r).abs() < 1e-4 * r && (e.origin - c).length() <= r * 2f32.sqrt() * (1.0 + 1e-5));
        assert!((e.pdf_a - 1.0 / (PI * r * r)).abs() < 1e-6 && (e.pdf_w_dir - 1.0 / (4.0 * PI)).abs() < 1e-7 && e.n == e.dir);
    }
}

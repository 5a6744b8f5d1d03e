//! Tests of the analytic emitting surfaces: χ² of every NEE sampler in direction space (the density of a
//! direction being the sum of `pdf_toward` over the shape's points along it), sample/pdf agreement,
//! the areas (an elliptic tube's against an independent quadrature and against Monte Carlo of `1/pdf_a`),
//! Mitsuba 3.9.1's normals and uvs at points it intersected, the irradiance of a sphere light against
//! the closed form `π·L·(r/d)²·cos θ` (and the variance of solid-angle against area sampling), for
//! each shape the power through a patch estimated by NEE and by photons, and the light set's queries on an
//! analytic primitive (`light_of_prim`, `le_area`, `pdf_li_area`: direct light by NEE alone and by NEE +
//! BSDF sampling under the power heuristic agree).

use super::*;
use crate::light::test_util::{assert_within_5_sigma, Mean};
use crate::light::{luminance, AreaLight};
use crate::math::{Frame, Vec2, Vec3};
use crate::sampler::Sampler;
use crate::sampling::chi2::{adaptive_simpson, Chi2Test, PdfIntegral};
use crate::sampling::warp::square_to_uniform_disk_concentric;
use crate::texture::{Checkerboard, Texture};
use glam::{Affine3A, Mat3, Quat};
use std::f32::consts::PI;

fn affine(rows: [[f32; 4]; 3]) -> Affine3A {
    let c = |j: usize| Vec3::new(rows[0][j], rows[1][j], rows[2][j]);
    Affine3A::from_mat3_translation(Mat3::from_cols(c(0), c(1), c(2)), c(3))
}

/// A sphere of radius 0.4 at (0.2, 1.5, −0.3), rotated (for its uvs).
fn sphere(flip: bool) -> SphereShape {
    let t = Affine3A::from_scale_rotation_translation(Vec3::splat(0.4), Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.7), Vec3::new(0.2, 1.5, -0.3));
    SphereShape::new(t, flip).unwrap()
}

/// A disk under a non-uniform scale, a shear and a rotation.
fn disk(flip: bool) -> DiskShape {
    let shear = Mat3::from_cols(Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.4, 1.0, 0.0), Vec3::new(0.1, -0.2, 1.0));
    let m = Mat3::from_quat(Quat::from_axis_angle(Vec3::new(1.0, -0.5, 0.3).normalize(), 2.2)) * shear * Mat3::from_diagonal(Vec3::new(0.9, 0.35, 2.0));
    DiskShape::new(Affine3A::from_mat3_translation(m, Vec3::new(-0.1, 1.2, 0.2)), flip).unwrap()
}

/// An elliptic tube (scale 0.6 × 0.2 across, 1.5 along), sheared and rotated.
fn tube(flip: bool) -> CylinderShape {
    let shear = Mat3::from_cols(Vec3::X, Vec3::Y, Vec3::new(0.3, 0.1, 1.0));
    let m = Mat3::from_quat(Quat::from_axis_angle(Vec3::new(0.2, 1.0, 0.4).normalize(), 1.1)) * shear * Mat3::from_diagonal(Vec3::new(0.6, 0.2, 1.5));
    CylinderShape::new(Affine3A::from_mat3_translation(m, Vec3::new(0.3, 0.8, -0.5)), flip).unwrap()
}

/// Every point at `t > 0` where the ray `o + t·d` meets the shape, in f64 from its object-space
/// equation (sphere, tube: the roots of a quadratic, a discriminant within rounding of 0 taken as a
/// tangent, so the samplers' rim points are found; disk: the plane z = 0).
fn hits(shape: &AnalyticShape, o: Vec3, d: Vec3) -> Vec<Vec3> {
    use glam::DVec3;
    let (o, d) = (o.as_dvec3(), d.as_dvec3());
    let roots = |a: f64, b: f64, c: f64| -> Vec<f64> {
        // a t² + 2b t + c = 0
        let disc = b * b - a * c;
        if a == 0.0 || disc < -1e-6 * a {
            return Vec::new();
        }
        let r = disc.max(0.0).sqrt();
        vec![(-b - r) / a, (-b + r) / a]
    };
    let (to_world, kind) = match shape {
        AnalyticShape::Sphere(s) => {
            let (oc, r) = (o - s.center().as_dvec3(), f64::from(s.radius()));
            let on = roots(1.0, oc.dot(d) / r, oc.length_squared() / (r * r) - 1.0);
            return on.into_iter().map(|t| t * r).filter(|&t| t > 0.0).map(|t| (o + t * d).as_vec3()).collect();
        }
        AnalyticShape::Disk(x) => (x.to_world_for_tests(), 0),
        AnalyticShape::Cylinder(x) => (x.to_world_for_tests(), 1),
    };
    let m = Mat3::from(to_world.matrix3).as_dmat3().inverse();
    let (lo, ld): (DVec3, DVec3) = (m * (o - Vec3::from(to_world.translation).as_dvec3()), m * d);
    if kind == 0 {
        let t = -lo.z / ld.z;
        let q = lo + t * ld;
        return if t > 0.0 && q.x * q.x + q.y * q.y <= 1.0 + 1e-6 { vec![(o + t * d).as_vec3()] } else { Vec::new() };
    }
    roots(ld.x * ld.x + ld.y * ld.y, lo.x * ld.x + lo.y * ld.y, lo.x * lo.x + lo.y * lo.y - 1.0)
        .into_iter()
        .filter(|&t| t > 0.0 && (-1e-6..=1.0 + 1e-6).contains(&(lo.z + t * ld.z)))
        .map(|t| (o + t * d).as_vec3())
        .collect()
}

/// χ² of `sample_toward` from `p_ref` in direction space; the density of a direction sums `pdf_toward`
/// over every point of the shape along it (a sampler may give an occluded far-side point). The reference
/// point must see no silhouette of a sampled-by-area surface (`d²/cos θ_l` grows without bound there, beyond
/// what the harness's cell integration follows). A sample at the silhouette itself, where the test's f64
/// intersection finds the tangent point facing away by rounding, is dropped (at most 1 in 10⁴).
fn chi2_toward(name: &str, shape: &AnalyticShape, p_ref: Vec3, integral: PdfIntegral) {
    let test = Chi2Test { theta_res: 32, phi_res: 64, sample_count: 400_000, integral, integral_tol: 2e-3, test_count: 8, ..Chi2Test::default() };
    let density = |d: Vec3| -> f32 { hits(shape, p_ref, d).into_iter().map(|p| shape.pdf_toward(p_ref, p, shape.normal(p))).sum() };
    let mut tangent = 0usize;
    let outcome = test.run(
        |s| {
            let (sp, pdf_w) = shape.sample_toward(p_ref, s.next_2d())?;
            let d = (sp.p - p_ref).normalize();
            let along = density(d);
            assert!((shape.pdf_toward(p_ref, sp.p, sp.n) - pdf_w).abs() <= 1e-3 * pdf_w, "{name}: pdf_toward of the sample");
            // The sample's direction carries at least the sample's own density (at grazing angles d²/cos θ_l
            // is too sensitive to the point to compare).
            let cos_l = sp.n.dot(-d);
            assert!(cos_l < 0.05 || along >= pdf_w * (1.0 - 1e-3), "{name}: the sample {sp:?} (pdf {pdf_w}) is not along its direction {d}");
            if along == 0.0 && cos_l < 1e-3 {
                tangent += 1;
                return None;
            }
            Some((d, along))
        },
        density,
    );
    println!("{name}: {outcome}; {tangent} tangent samples dropped");
    assert!(outcome.passed(), "{name}: {outcome}");
    assert!(tangent * 10_000 <= test.sample_count, "{name}: {tangent} tangent samples");
}

#[test]
fn sphere_nee_chi2_outside_by_cone_and_inside_by_area() {
    let s = sphere(false);
    // Outside, near (a wide cone) and farther (narrower): every sample is a visible point.
    chi2_toward("sphere near", &AnalyticShape::Sphere(s.clone()), Vec3::new(0.1, 0.9, 0.0), PdfIntegral::One);
    chi2_toward("sphere far", &AnalyticShape::Sphere(s.clone()), Vec3::new(1.5, -0.5, 0.8), PdfIntegral::One);
    // Inside a sphere emitting inward: by area, every point seen.
    let flipped = AnalyticShape::Sphere(sphere(true));
    chi2_toward("inside a flipped sphere", &flipped, Vec3::new(0.3, 1.6, -0.2), PdfIntegral::One);
    // No light reaches the inside of an outward sphere, nor the outside of an inward one.
    let mut sampler = Sampler::for_key(5, 0, 0);
    for _ in 0..2000 {
        let u = sampler.next_2d();
        assert!(s.sample_toward(Vec3::new(0.3, 1.6, -0.2), u).is_none());
        assert!(sphere(true).sample_toward(Vec3::new(0.1, 0.9, 0.0), u).is_none());
    }
}

#[test]
fn sphere_cone_samples_are_the_near_points_even_far_away() {
    // r/d = 10⁻³ and 10⁻⁵: the cone's density from 1 − cos θ_max without cancellation, each point on the
    // sphere, the first one along its direction, within the cone.
    let s = sphere(false);
    let mut sampler = Sampler::for_key(6, 0, 0);
    for dist in [400.0f32, 40_000.0] {
        let p_ref = s.center() + dist * Vec3::new(0.3, -0.9, 0.3).normalize();
        let sin2 = f64::from(s.radius() / dist).powi(2);
        let expected = 1.0 / (2.0 * std::f64::consts::PI * (sin2 / (1.0 + (1.0 - sin2).sqrt())));
        for _ in 0..1000 {
            let (sp, pdf_w) = s.sample_toward(p_ref, sampler.next_2d()).unwrap();
            assert!((f64::from(pdf_w) - expected).abs() < 1e-4 * expected, "{pdf_w} vs {expected}");
            assert!(((sp.p - s.center()).length() - s.radius()).abs() < 1e-5 * dist);
            assert!(sp.n.dot(p_ref - sp.p) > 0.0, "a far-side point");
        }
    }
}

#[test]
fn disk_and_tube_nee_chi2_by_area() {
    let d = AnalyticShape::Disk(disk(false));
    // In front of the disk (its normal's side), then behind: no sample.
    let front = Vec3::new(-0.1, 1.2, 0.2) + 0.7 * disk(false).sample_area(Vec2::splat(0.5)).n + Vec3::new(0.1, 0.05, 0.0);
    chi2_toward("disk", &d, front, PdfIntegral::One);
    chi2_toward("flipped disk", &AnalyticShape::Disk(disk(true)), Vec3::new(-0.1, 1.2, 0.2) - 0.5 * disk(false).sample_area(Vec2::ZERO).n, PdfIntegral::One);
    // The elliptic tube emitting inward (its points sampled as the outward tube's, only the normal
    // differs), seen from inside and from beyond one end near its axis (the inner wall through the
    // opening, no silhouette): some samples face away, some are along one direction twice.
    let t = tube(true).to_world_for_tests();
    chi2_toward("inside a flipped tube", &AnalyticShape::Cylinder(tube(true)), t.transform_point3(Vec3::new(0.1, -0.2, 0.4)), PdfIntegral::AtMostOne);
    chi2_toward("flipped tube from beyond its end", &AnalyticShape::Cylinder(tube(true)), t.transform_point3(Vec3::new(0.1, 0.05, 1.6)), PdfIntegral::AtMostOne);
}

#[test]
fn areas_and_area_densities() {
    // The elliptic tube's area against an independent quadrature of its perimeter: the tube is
    // M·(cos φ, sin φ, z); |∂p/∂φ × ∂p/∂z| integrated by adaptive Simpson.
    let t = tube(false);
    let m = Mat3::from(t.to_world_for_tests().matrix3).as_dmat3();
    let element = |phi: f64| (m * glam::DVec3::new(-phi.sin(), phi.cos(), 0.0)).cross(m * glam::DVec3::Z).length();
    let reference = adaptive_simpson(&element, 0.0, 2.0 * std::f64::consts::PI, 1e-10);
    assert!((f64::from(t.area()) - reference).abs() < 1e-6 * reference, "{} vs {reference}", t.area());
    // E[1/pdf_a] = A for every sampler, and each sample's pdf_a is pdf_a at its point.
    let mut sampler = Sampler::for_key(7, 0, 0);
    for (name, shape) in [("sphere", AnalyticShape::Sphere(sphere(false))), ("disk", AnalyticShape::Disk(disk(false))), ("tube", AnalyticShape::Cylinder(t.clone()))] {
        let mut m = Mean::default();
        for _ in 0..100_000 {
            let s = shape.sample_area(sampler.next_2d());
            assert!((shape.pdf_a(s.p) - s.pdf_a).abs() <= 1e-4 * s.pdf_a, "{name}");
            assert!((shape.normal(s.p) - s.n).length() < 1e-4, "{name}: normal");
            assert!((s.n.length() - 1.0).abs() < 1e-5 && (shape.uv(s.p) - s.uv).abs().max_element() < 1e-4, "{name}: uv {} vs {}", shape.uv(s.p), s.uv);
            m.add(1.0 / f64::from(s.pdf_a));
        }
        assert_within_5_sigma(name, &m, f64::from(shape.area()), 1e-6 * f64::from(shape.area()));
    }
    // Mitsuba's placements (a uniform scale across the axis) give Mitsuba's constant 1/(2π r ℓ).
    let uniform = CylinderShape::new(Affine3A::from_mat3_translation(Mat3::from_quat(Quat::from_rotation_x(0.4)) * Mat3::from_diagonal(Vec3::new(0.5, 0.5, 2.0)), Vec3::ONE), false).unwrap();
    assert!((uniform.area() - 2.0 * PI * 0.5 * 2.0).abs() < 1e-5);
    for u in [Vec2::new(0.1, 0.2), Vec2::new(0.9, 0.7)] {
        assert!((uniform.sample_area(u).pdf_a - 1.0 / (2.0 * PI)).abs() < 1e-6);
    }
    let d = DiskShape::new(Affine3A::from_scale(Vec3::new(2.0, 3.0, 5.0)), false).unwrap();
    assert!((d.area() - 6.0 * PI).abs() < 1e-5);
    // Degenerate placements are refused.
    assert!(SphereShape::new(Affine3A::from_scale(Vec3::ZERO), false).is_none());
    assert!(DiskShape::new(Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0)), false).is_none());
    assert!(CylinderShape::new(Affine3A::from_scale(Vec3::new(1.0, 1.0, 0.0)), false).is_none());
}

/// Points Mitsuba 3.9.1 intersected (`scene.ray_intersect` on each shape alone, scalar_rgb), with its normal
/// and uv there; the placements are Mitsuba's `to_world` matrices (rows) of
/// `translate·rotate(unit axis, degrees)·scale`.
#[test]
fn normals_and_uvs_are_mitsubas() {
    type Row = ([f32; 3], [f32; 3], [f32; 2]);
    let sphere_to_world = affine([[0.5479289, -0.3373681, 0.2756024, 0.3], [0.3841592, 0.5830222, -0.0500679, -0.2], [-0.2054157, 0.1904412, 0.6415111, 0.5]]);
    let sphere_rows: [Row; 5] = [
        ([0.673718, 0.363187, 0.317912], [0.533882, 0.804552, -0.260126], [0.055771, 0.527325]),
        ([-0.213955, 0.22435, 0.713955], [-0.734222, 0.606215, 0.30565], [0.303891, 0.516663]),
        ([0.392276, 0.482288, 0.373635], [0.131823, 0.974697, -0.180521], [0.125927, 0.558662]),
        ([0.147728, 0.352272, 0.902255], [-0.217531, 0.78896, 0.57465], [0.233752, 0.374354]),
        ([0.042592, 0.371296, 0.187971], [-0.367726, 0.816137, -0.445756], [0.190079, 0.7095]),
    ];
    let disk_to_world = affine([[1.3325317, -0.2583464, -0.159466, 0.1], [0.5788788, 0.5330127, -0.2487824, 0.4], [0.3731735, 0.0956796, 0.9553418, -0.3]]);
    let disk_rows: [Row; 2] = [
        ([0.751745, 0.167544, -0.251745], [-0.159466, -0.248782, 0.955342], [0.866124, 0.813044]),
        ([0.200408, 0.299592, -0.309387], [-0.159466, -0.248782, 0.955342], [0.225507, 0.772715]),
    ];
    let tube_to_world = affine([[0.4888462, -0.0282653, 0.2629794, 0.2], [0.0639576, 0.462077, -0.4679589, 0.1], [-0.0832998, 0.1889073, 1.184, -0.4]]);
    let tube_rows: [Row; 6] = [
        ([0.587009, 0.288865, 0.273319], [0.521743, 0.82664, 0.210833], [0.151386, 0.479647]),
        ([0.06004, 0.208233, 0.43996], [-0.562214, 0.718792, 0.408966], [0.338129, 0.536721]),
        ([0.16456, -0.456976, -0.32912], [-0.175214, -0.928294, -0.327978], [0.712179, 0.198369]),
        ([0.354833, 0.327167, 0.384333], [0.041066, 0.932297, 0.359356], [0.234132, 0.510689]),
        ([0.172788, 0.327212, 0.325872], [-0.286577, 0.867529, 0.40653], [0.288073, 0.441391]),
        ([0.050583, 0.375292, 0.12004], [-0.438137, 0.798468, 0.412898], [0.31463, 0.264857]),
    ];
    let cases: [(AnalyticShape, &[Row]); 3] = [
        (AnalyticShape::Sphere(SphereShape::new(sphere_to_world, false).unwrap()), &sphere_rows),
        (AnalyticShape::Disk(DiskShape::new(disk_to_world, false).unwrap()), &disk_rows),
        (AnalyticShape::Cylinder(CylinderShape::new(tube_to_world, false).unwrap()), &tube_rows),
    ];
    for (shape, rows) in cases {
        for &(p, n, uv) in rows {
            let (p, n, uv) = (Vec3::from(p), Vec3::from(n), Vec2::from(uv));
            assert!((shape.uv(p) - uv).abs().max_element() < 2e-5, "{shape:?}: uv {} vs Mitsuba's {uv}", shape.uv(p));
            assert!((shape.normal(p) - n).length() < 2e-5, "{shape:?}: normal {} vs Mitsuba's {n}", shape.normal(p));
            // The pdf at the point is the sampler's: sampling at Mitsuba's uv gives Mitsuba's point.
            let s = match &shape {
                AnalyticShape::Cylinder(c) => c.sample_area(Vec2::new(uv.y, uv.x)),
                _ => continue,
            };
            assert!((s.p - p).length() < 2e-5 && (s.n - n).length() < 2e-5);
        }
    }
}

#[test]
fn sphere_irradiance_is_the_closed_form_and_the_cone_beats_area_sampling() {
    // E = π·L·(r/d)²·cos θ for a sphere wholly above the tangent plane; the cone estimator's noise comes
    // from cos θ alone, the area estimator's also from the points behind (wasted) and d²/cos at the rim.
    let radiance = Vec3::new(3.0, 2.0, 1.0);
    let s = sphere(false);
    let light = AreaLight::analytic(radiance, 7, AnalyticShape::Sphere(s.clone()));
    let y = f64::from(luminance(radiance));
    let p_ref = s.center() + Vec3::new(0.3, -1.1, 0.4);
    let to_c = s.center() - p_ref;
    let n_ref = Frame::from_normal(to_c.normalize()).to_world(Vec3::new(0.5, 0.0, 1.0).normalize());
    let d2 = f64::from(to_c.length_squared());
    let cos = f64::from(n_ref.dot(to_c.normalize()));
    let closed_form = std::f64::consts::PI * y * f64::from(s.radius()).powi(2) / d2 * cos;
    let (mut cone, mut area) = (Mean::default(), Mean::default());
    let mut sampler = Sampler::for_key(8, 0, 0);
    let pdf_a = f64::from(s.pdf_a());
    for _ in 0..200_000 {
        let u = sampler.next_2d();
        cone.add(light.sample_li(p_ref, u).map_or(0.0, |ls| f64::from(luminance(ls.li) * n_ref.dot(ls.wi_world).max(0.0) / ls.pdf_w)));
        let q = s.sample_area(u);
        let d = q.p - p_ref;
        let (dist2, w) = (f64::from(d.length_squared()), d.normalize());
        let cos_l = f64::from(-q.n.dot(w));
        area.add(if cos_l > 0.0 { y * f64::from(n_ref.dot(w).max(0.0)) * cos_l / dist2 / pdf_a } else { 0.0 });
    }
    assert_within_5_sigma("sphere irradiance by the cone", &cone, closed_form, 1e-6 * closed_form);
    assert_within_5_sigma("sphere irradiance by area", &area, closed_form, 1e-6 * closed_form);
    let ratio = (area.stderr() / cone.stderr()).powi(2);
    println!("variance of area sampling / cone sampling at d/r = {:.2}: {ratio:.1}", d2.sqrt() / f64::from(s.radius()));
    assert!(ratio > 4.0, "the cone should beat area sampling: variance ratio {ratio}");
}

/// The power through a small one-sided patch (a disk of radius ρ at `q` facing `n_q`) from `light`,
/// estimated by NEE at points of the patch and by the photons `sample_le` emits that cross it.
fn patch_power(name: &str, light: &AreaLight, q: Vec3, n_q: Vec3, rho: f32) {
    let frame = Frame::from_normal(n_q);
    let patch_area = f64::from(PI * rho * rho);
    let mut sampler = Sampler::for_key(10, 0, 0);
    let mut nee = Mean::default();
    for _ in 0..200_000 {
        let d = square_to_uniform_disk_concentric(sampler.next_2d());
        let x = q + rho * (d.x * frame.s + d.y * frame.t);
        let e = light.sample_li(x, sampler.next_2d()).map_or(0.0, |ls| f64::from(luminance(ls.li) * n_q.dot(ls.wi_world).max(0.0) / ls.pdf_w));
        nee.add(patch_area * e);
    }
    let mut photons = Mean::default();
    let n = 2_000_000;
    for _ in 0..n {
        let Some(e) = light.sample_le(sampler.next_2d(), sampler.next_2d(), sampler.next_1d()) else {
            photons.add(0.0);
            continue;
        };
        let power = f64::from(luminance(e.le) * e.n.dot(e.dir) / (e.pdf_a * e.pdf_w_dir));
        let t = (q - e.origin).dot(n_q) / e.dir.dot(n_q);
        let crosses = e.dir.dot(n_q) < 0.0 && t > 0.0 && (e.origin + t * e.dir - q).length() <= rho;
        photons.add(if crosses { power } else { 0.0 });
    }
    println!("{name}: NEE {} ± {}, photons {} ± {}", nee.mean(), nee.stderr(), photons.mean(), photons.stderr());
    let sigma = (nee.stderr().powi(2) + photons.stderr().powi(2)).sqrt();
    assert!((nee.mean() - photons.mean()).abs() <= 5.0 * sigma, "{name}: NEE {} vs photons {} (σ {sigma})", nee.mean(), photons.mean());
    assert!(nee.mean() > 20.0 * sigma, "{name}: the patch receives too little to test");
}

#[test]
fn nee_and_photons_agree_on_the_power_through_a_patch() {
    let radiance = Vec3::new(2.0, 1.0, 0.5);
    let sphere_light = AreaLight::analytic(radiance, 0, AnalyticShape::Sphere(sphere(false)));
    patch_power("sphere", &sphere_light, Vec3::new(0.5, 0.6, -0.1), Vec3::new(-0.2, 1.0, -0.1).normalize(), 0.25);
    let dk = disk(false);
    let centre = dk.sample_area(Vec2::splat(0.5)).p;
    let disk_light = AreaLight::analytic(radiance, 0, AnalyticShape::Disk(dk.clone()));
    patch_power("disk", &disk_light, centre + 0.8 * dk.sample_area(Vec2::ZERO).n + Vec3::new(0.2, 0.0, 0.1), -dk.sample_area(Vec2::ZERO).n, 0.25);
    let tube_light = AreaLight::analytic(radiance, 0, AnalyticShape::Cylinder(tube(false)));
    patch_power("elliptic tube", &tube_light, Vec3::new(1.2, 0.1, 0.4), Vec3::new(-1.0, 0.4, -0.3).normalize(), 0.25);
    // Emission: cosine directions on the emitting side, the power of the light per sample on average.
    let mut sampler = Sampler::for_key(11, 0, 0);
    for light in [&sphere_light, &disk_light, &tube_light] {
        assert!((light.power() - PI * light.area() * luminance(radiance)).abs() < 1e-5 * light.power());
        let mut flux = Mean::default();
        for _ in 0..100_000 {
            let e = light.sample_le(sampler.next_2d(), sampler.next_2d(), sampler.next_1d()).unwrap();
            assert!(e.dir.dot(e.n) > 0.0 && (e.pdf_w_dir - e.n.dot(e.dir) / PI).abs() < 1e-5);
            assert!((light.pdf_a_at(e.origin) - e.pdf_a).abs() < 1e-3 * e.pdf_a);
            flux.add(f64::from(luminance(e.le) * e.n.dot(e.dir) / (e.pdf_a * e.pdf_w_dir)));
        }
        assert_within_5_sigma("emitted power", &flux, f64::from(light.power()), 1e-5 * f64::from(light.power()));
    }
}

#[test]
fn textured_shape_lights_read_the_texture_at_the_shapes_uv() {
    let checks = Texture::Checkerboard(Checkerboard { color0: Vec3::new(1.0, 0.5, 0.2), color1: Vec3::new(0.1, 0.2, 0.3), to_uv: Mat3::from_diagonal(Vec3::new(4.0, 3.0, 1.0)) });
    let mut sampler = Sampler::for_key(12, 0, 0);
    for shape in [AnalyticShape::Sphere(sphere(false)), AnalyticShape::Disk(disk(false)), AnalyticShape::Cylinder(tube(false))] {
        let light = AreaLight::analytic_textured(checks.clone(), 3, shape.clone());
        assert_eq!(light.prims().collect::<Vec<_>>(), vec![3]);
        let p_ref = Vec3::new(1.2, 0.1, 0.4);
        for _ in 0..2000 {
            if let Some(ls) = light.sample_li(p_ref, sampler.next_2d()) {
                let expected = checks.eval_rgb(shape.uv(ls.p_light));
                assert_eq!(ls.li, expected);
                assert_eq!(light.le(ls.n_light, -ls.wi_world, || shape.uv(ls.p_light)), expected);
                assert!((light.pdf_li(p_ref, ls.p_light, ls.n_light) - ls.pdf_w).abs() <= 1e-4 * ls.pdf_w);
            }
            let e = light.sample_le(sampler.next_2d(), sampler.next_2d(), sampler.next_1d()).unwrap();
            let on_surface = e.origin; // offset by the error bound only
            assert!((checks.eval_rgb(shape.uv(on_surface)) - e.le).abs().max_element() < 1e-6 || (shape.uv(on_surface) * Vec2::new(4.0, 3.0)).fract().min_element() < 1e-3);
        }
    }
}

/// Direct light at `p_ref` (a diffuse receiver of normal `n_r`) by NEE alone, and by NEE and cosine-weighted
/// BSDF sampling under the power heuristic, the BSDF-sampled ray's density at the light asked of
/// `LightSet::pdf_li_area` for the primitive it hit (as the path tracer does): the two agree only if
/// that query is the sampler's density and `le_area` its radiance.
fn mis_agrees_with_nee(name: &str, set: &crate::light::LightSet, index: usize, shape: &AnalyticShape, prim: u32, p_ref: Vec3, n_r: Vec3) {
    use crate::sampling::mis::power_heuristic;
    use crate::sampling::warp::square_to_cosine_hemisphere;
    let frame = Frame::from_normal(n_r);
    let (mut nee, mut mis) = (Mean::default(), Mean::default());
    let mut sampler = Sampler::for_key(13, 0, 0);
    for _ in 0..300_000 {
        let (u_select, u_light, u_bsdf) = (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
        // NEE: its plain estimate, and its share under the power heuristic.
        let (mut plain, mut total) = (0.0, 0.0);
        if let Some((i, ls)) = set.sample_li(p_ref, u_select, u_light) {
            assert_eq!(i, index);
            let f = n_r.dot(ls.wi_world).max(0.0) / PI;
            plain = f64::from(luminance(ls.li) * f / ls.pdf_w);
            total = plain * f64::from(power_heuristic(ls.pdf_w, f));
        }
        nee.add(plain);
        // BSDF sampling: the first point of the shape along the direction, as a ray finds it.
        let local = square_to_cosine_hemisphere(u_bsdf);
        let w = frame.to_world(local);
        let nearest = hits(shape, p_ref, w).into_iter().min_by(|a, b| (*a - p_ref).length().total_cmp(&(*b - p_ref).length()));
        if let Some(p) = nearest {
            assert_eq!(set.light_of_prim(prim), Some(index));
            let n = shape.normal(p);
            let le = set.le_area(prim, n, -w, || shape.uv(p));
            if le != Vec3::ZERO {
                let pdf_bsdf = local.z / PI;
                total += f64::from(luminance(le) * power_heuristic(pdf_bsdf, set.pdf_li_area(prim, p_ref, p, n)));
            }
        }
        mis.add(total);
    }
    println!("{name}: NEE {} ± {}, MIS {} ± {}", nee.mean(), nee.stderr(), mis.mean(), mis.stderr());
    let sigma = (nee.stderr().powi(2) + mis.stderr().powi(2)).sqrt();
    assert!((nee.mean() - mis.mean()).abs() <= 5.0 * sigma + 1e-6 * nee.mean(), "{name}: NEE {} vs MIS {} (σ {sigma})", nee.mean(), mis.mean());
}

#[test]
fn light_set_queries_on_analytic_prims_are_the_samplers() {
    use crate::light::{Light, LightSet};
    use crate::math::Aabb;
    let radiance = Vec3::new(1.0, 0.7, 0.4);
    let shapes = [AnalyticShape::Sphere(sphere(false)), AnalyticShape::Disk(disk(false)), AnalyticShape::Cylinder(tube(false))];
    let bounds = Aabb::from_points(&[Vec3::splat(-2.0), Vec3::splat(2.0)]);
    for (k, shape) in shapes.iter().enumerate() {
        // A triangle soup of 5 triangles (one of them emitting), then this shape as primitive 5.
        let quad = AreaLight::new(Vec3::ONE, vec![(2, [Vec3::new(-2.0, 2.0, -2.0), Vec3::new(-1.5, 2.0, -2.0), Vec3::new(-2.0, 2.0, -1.5)])]);
        let set = LightSet::new(vec![Light::Area(quad), Light::Area(AreaLight::analytic(radiance, 5, shape.clone()))], 6, bounds);
        assert_eq!((set.light_of_prim(5), set.light_of_prim(4), set.light_of_prim(2)), (Some(1), None, Some(0)));
        let lone = LightSet::new(vec![Light::Area(AreaLight::analytic(radiance, 5, shape.clone()))], 6, bounds);
        let (p_ref, n_r) = match k {
            0 => (Vec3::new(0.1, 0.7, 0.1), Vec3::new(0.2, 1.0, -0.3).normalize()),
            1 => {
                let d = disk(false);
                (d.sample_area(Vec2::splat(0.5)).p + 0.6 * d.normal() + Vec3::new(0.2, 0.0, 0.1), (-d.normal() + Vec3::new(0.3, 0.0, 0.0)).normalize())
            }
            _ => (Vec3::new(1.2, 0.1, 0.4), Vec3::new(-1.0, 0.4, -0.3).normalize()),
        };
        // Every NEE sample of the shape: the set's queries at its point give its density (× selection)
        // and its radiance.
        let mut sampler = Sampler::for_key(14, k as u64, 0);
        for _ in 0..5000 {
            if let Some((i, ls)) = set.sample_li(p_ref, sampler.next_1d(), sampler.next_2d()) {
                if i == 1 {
                    assert!((set.pdf_li_area(5, p_ref, ls.p_light, ls.n_light) - ls.pdf_w).abs() <= 1e-4 * ls.pdf_w);
                    assert_eq!(set.le_area(5, ls.n_light, -ls.wi_world, || unreachable!()), ls.li);
                    assert_eq!(set.le_area(5, ls.n_light, ls.wi_world, || unreachable!()), Vec3::ZERO);
                }
            }
        }
        mis_agrees_with_nee(["sphere", "disk", "elliptic tube"][k], &lone, 0, shape, 5, p_ref, n_r);
    }
}

/// The light's surface is the intersector's (`accel::analytic`): at every point the light samples, the
/// primitive's own surface (point re-projected, normal, uv) is the sample's, for each kind under a
/// non-uniform scale and under a mirror, with and without `flip_normals`.
#[test]
fn the_lights_surface_is_the_intersectors() {
    use crate::accel::analytic::{Analytic, Kind};
    use crate::math::{Mat4, Ray};
    let turned = Mat4::from_translation(Vec3::new(0.3, -0.2, 0.5)) * Mat4::from_quat(Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7));
    let placements = [turned * Mat4::from_scale(Vec3::new(0.6, 0.4, 1.3)), turned * Mat4::from_scale(Vec3::new(-0.5, 0.5, 0.8))];
    let mut sampler = Sampler::for_key(15, 0, 0);
    for kind in [Kind::Sphere, Kind::Disk, Kind::Cylinder] {
        for (m, to_world) in placements.iter().enumerate() {
            for flip in [false, true] {
                let a = Analytic::new(kind, *to_world, flip).unwrap();
                let shape = AnalyticShape::from_primitive(&a).unwrap();
                for _ in 0..200 {
                    let s = shape.sample_area(sampler.next_2d());
                    let dir = Vec3::new(0.3, -0.8, 0.5).normalize();
                    let hit = a.surface(&Ray::new(s.p - dir, dir), 1.0);
                    let what = format!("{} placement {m} flip {flip}", kind.name());
                    assert!((hit.p - s.p).length() < 1e-5, "{what}: point {} vs {}", hit.p, s.p);
                    assert!((hit.n - s.n).length() < 1e-4, "{what}: normal {} vs {}", hit.n, s.n);
                    assert!((hit.uv - s.uv).abs().max_element() < 1e-4 || (hit.uv.x - s.uv.x).abs() > 0.999, "{what}: uv {} vs {}", hit.uv, s.uv);
                    assert!((shape.normal(s.p) - s.n).length() < 1e-4 && (shape.uv(s.p) - hit.uv).abs().max_element() < 1e-4 || (hit.uv.x - s.uv.x).abs() > 0.999);
                }
            }
        }
    }
}

//! Tests of the delta lights (module `delta`): the spot's falloff and its integral, NEE samples, the
//! power of photon starts (Monte Carlo within 5 standard errors of the closed form), χ² of the photon
//! directions of point and spot lights aimed at a sphere, χ² of the directional light's disk of origins.

use super::test_util::{assert_within_5_sigma, Mean};
use super::delta::PointDirection;
use super::*;
use crate::math::{Aabb, Vec2, Vec3};
use crate::sampler::Sampler;
use crate::sampling::chi2::{chi2_p_value, integrate_sphere, Chi2Test, PdfIntegral};
use std::f32::consts::PI;

fn spot(axis: Vec3, cutoff: f32, beam: f32) -> SpotProfile {
    SpotProfile::new(axis, cutoff, beam).expect("valid spot")
}

#[test]
fn spot_falloff_is_mitsubas_linear_ramp() {
    let s = spot(Vec3::new(0.0, 0.0, 2.0), 30.0, 10.0);
    let at = |deg: f32| s.falloff(Vec3::new(deg.to_radians().sin(), 0.0, deg.to_radians().cos()));
    assert_eq!(at(0.0), 1.0);
    assert_eq!(at(9.9), 1.0);
    // (cutoff − θ)/(cutoff − beam) in the transition.
    for deg in [12.0f32, 20.0, 25.0, 29.0] {
        let expected = (30.0 - deg) / 20.0;
        assert!((at(deg) - expected).abs() < 1e-4, "{deg}°: {} vs {expected}", at(deg));
    }
    assert_eq!(at(30.5), 0.0);
    assert_eq!(at(90.0), 0.0);
    assert_eq!(at(180.0), 0.0);
    // A beam as wide as the cutoff: a hard edge.
    let hard = spot(Vec3::Z, 40.0, 40.0);
    assert_eq!(hard.falloff(Vec3::new(39f32.to_radians().sin(), 0.0, 39f32.to_radians().cos())), 1.0);
    assert_eq!(hard.falloff(Vec3::new(41f32.to_radians().sin(), 0.0, 41f32.to_radians().cos())), 0.0);
    // Invalid profiles.
    assert!(SpotProfile::new(Vec3::Z, 0.0, 0.0).is_none());
    assert!(SpotProfile::new(Vec3::Z, 20.0, 25.0).is_none());
    assert!(SpotProfile::new(Vec3::Z, 181.0, 10.0).is_none());
    assert!(SpotProfile::new(Vec3::ZERO, 20.0, 10.0).is_none());
}

/// `∫falloff dω = 2π(1 − (sin c − sin b)/(c − b))` against the harness's quadrature of the falloff, for
/// narrow, wide (> 90°), hard-edged and beam-less spots.
#[test]
fn spot_solid_angle_integral_matches_quadrature() {
    for (cutoff, beam) in [(20.0, 15.0), (8.0, 4.0), (60.0, 0.0), (120.0, 90.0), (45.0, 45.0), (180.0, 135.0)] {
        let s = spot(Vec3::new(0.3, -0.5, 0.8), cutoff, beam);
        let quad = integrate_sphere(|w| s.falloff(w));
        let closed = f64::from(s.solid_angle_integral());
        // The hard edge of (45, 45) falls inside quadrature cells: a looser bound there.
        let tol = if cutoff == beam { 2e-3 } else { 2e-4 };
        assert!((closed / quad - 1.0).abs() < tol, "cutoff {cutoff}, beam {beam}: closed {closed} vs quadrature {quad}");
    }
}

#[test]
fn nee_samples_of_delta_lights() {
    let i = Vec3::new(2.0, 4.0, 8.0);
    let light = Light::Point(PointLight::new(Vec3::new(0.0, 3.0, 0.0), i, None));
    let ls = light.sample_li(Vec3::new(0.0, 1.0, 0.0), Vec2::new(0.3, 0.7)).expect("sample");
    assert!(ls.delta && ls.pdf_w == 1.0 && ls.dist == 2.0 && ls.wi_world == Vec3::Y);
    assert_eq!(ls.li, i / 4.0);
    assert!((light.power(1.0) - 4.0 * PI * luminance(i)).abs() < 1e-3 * light.power(1.0));

    // A spot along −y: the point below it is lit at full intensity, one to the side is not.
    let s = spot(-Vec3::Y, 20.0, 10.0);
    let light = Light::Point(PointLight::new(Vec3::new(0.0, 3.0, 0.0), i, Some(s)));
    assert_eq!(light.sample_li(Vec3::ZERO, Vec2::ZERO).expect("in the beam").li, i / 9.0);
    assert!(light.sample_li(Vec3::new(3.0, 0.0, 0.0), Vec2::ZERO).is_none());
    assert!((light.power(1.0) - luminance(i) * s.solid_angle_integral()).abs() < 1e-3 * light.power(1.0));

    let d = Vec3::new(1.0, -2.0, 0.5);
    let light = Light::Directional(DirectionalLight::new(d, Vec3::splat(3.0)).expect("direction"));
    let ls = light.sample_li(Vec3::new(1.0, 2.0, 3.0), Vec2::ZERO).expect("sample");
    assert!(ls.delta && ls.pdf_w == 1.0 && ls.dist == f32::INFINITY);
    assert!((ls.wi_world + d.normalize()).length() < 1e-6);
    assert_eq!(ls.li, Vec3::splat(3.0));
    assert!(!light.is_infinite() && light.is_delta(), "escaping rays never see a directional light");
    assert_eq!(light.le_escaped(-d.normalize()), Vec3::ZERO);
    assert_eq!(light.pdf_li_escaped(-d.normalize()), 0.0);
    assert!(DirectionalLight::new(Vec3::ZERO, Vec3::ONE).is_none());

    // In a set: the NEE pdf is the selection probability (a probability: the light's one point).
    let set = LightSet::new(
        vec![Light::Point(PointLight::new(Vec3::Y, Vec3::ONE, None)), Light::Point(PointLight::new(-Vec3::Y, Vec3::splat(3.0), None))],
        0,
        Aabb::from_points(&[Vec3::splat(-1.0), Vec3::splat(1.0)]),
    );
    let (index, ls) = set.sample_li(Vec3::ZERO, 0.9, Vec2::ZERO).expect("sample");
    assert_eq!(index, 1);
    assert!(ls.delta && (ls.pdf_w - 0.75).abs() < 1e-6, "pdf {}", ls.pdf_w);
}

/// The photon directions of point and spot lights aimed at a sphere (`direction_toward`) have the
/// density they report: a cone toward the sphere, the sphere of directions from inside it, a spot's
/// beam when it is the narrower cone. Each rule is χ²-tested against its own pdf.
#[test]
fn aimed_point_and_spot_directions_pass_chi2() {
    let center = Vec3::new(0.3, -0.2, 0.5);
    let cases = [
        ("point outside", PointLight::new(Vec3::new(2.0, 1.5, -1.0), Vec3::ONE, None), 0.7),
        ("point inside", PointLight::new(Vec3::new(0.5, 0.0, 0.4), Vec3::ONE, None), 0.7),
        ("spot, narrow beam", PointLight::new(Vec3::new(2.0, 1.5, -1.0), Vec3::ONE, Some(spot(Vec3::new(-1.0, -0.8, 1.0), 9.0, 3.0))), 0.7),
        ("spot, wide beam", PointLight::new(Vec3::new(2.0, 1.5, -1.0), Vec3::ONE, Some(spot(Vec3::new(-1.0, -0.8, 1.0), 70.0, 30.0))), 0.7),
    ];
    let test = Chi2Test { sample_count: 300_000, test_count: cases.len(), integral: PdfIntegral::One, ..Chi2Test::default() };
    for (name, light, radius) in cases {
        let rule = light.direction_toward(center, radius);
        let expected = match name {
            "point inside" => matches!(rule, PointDirection::Sphere),
            // The beam (9°) is narrower than the sphere's cone (asin(0.7/2.7) = 15°): the beam is sampled.
            "spot, narrow beam" => matches!(rule, PointDirection::Cone { cos_max, .. } if cos_max == 9f32.to_radians().cos()),
            _ => matches!(rule, PointDirection::Cone { cos_max, .. } if cos_max > 0.96),
        };
        assert!(expected, "{name}: unexpected rule {rule:?}");
        // The density the rule reports: uniform in its cone (whose edge a rounded sample may cross by an
        // ulp or two of the cosine), or over the sphere.
        let pdf = |w: Vec3| match rule {
            PointDirection::Cone { axis, cos_max } if axis.dot(w) >= cos_max - 4.0 * f32::EPSILON => 1.0 / (2.0 * PI * (1.0 - cos_max)),
            PointDirection::Cone { .. } => 0.0,
            PointDirection::Sphere => 0.25 / PI,
            PointDirection::Frustum(_) => unreachable!("no projector here"),
        };
        let out = test.run(|s| Some(rule.sample(s.next_2d())), pdf);
        eprintln!("{name}: {out}");
        assert!(out.passed(), "{name}: {out}");
    }
}

/// Power of the photon starts: the mean of `le·|cos|/(pdf_a·pdf_w_dir)` over the starts is the power the
/// light sends into the target sphere, in closed form for a point light (`I·2π(1 − cos θ_max)`) and for a
/// directional light (`E·π·r²`), and by quadrature of the falloff over the sphere's cone for a spot.
#[test]
fn photon_starts_carry_the_power_sent_into_the_sphere() {
    let (center, radius) = (Vec3::new(0.3, -0.2, 0.5), 0.7f32);
    let pos = Vec3::new(2.0, 1.5, -1.0);
    let d = center - pos;
    let cos_max = (1.0 - radius * radius / d.length_squared()).sqrt();
    let inside_cone = |w: Vec3| w.dot(d.normalize()) >= cos_max;
    let power = |es: &EmissionSample| f64::from(luminance(es.le) * es.n.dot(es.dir).abs() / (es.pdf_a * es.pdf_w_dir));
    let lights = [
        ("point", PointLight::new(pos, Vec3::splat(2.0), None)),
        ("spot, narrow beam", PointLight::new(pos, Vec3::splat(2.0), Some(spot(Vec3::new(-1.0, -0.8, 1.0), 9.0, 3.0)))),
        ("spot, wide beam", PointLight::new(pos, Vec3::splat(2.0), Some(spot(Vec3::new(-1.0, -0.6, 1.2), 40.0, 10.0)))),
    ];
    for (name, light) in lights {
        let mut m = Mean::default();
        let mut s = Sampler::for_key(21, 0, 0);
        for _ in 0..200_000 {
            // Only the directions into the sphere count (the aimed cone may be a spot's beam).
            let x = light.sample_le_toward(s.next_2d(), center, radius).filter(|es| inside_cone(es.dir)).map_or(0.0, |es| power(&es));
            m.add(x);
        }
        let expected = integrate_sphere(|w| if inside_cone(w) { luminance(light.intensity_toward(w)) } else { 0.0 });
        if name == "point" {
            let closed = 2.0 * std::f64::consts::PI * f64::from(1.0 - cos_max) * f64::from(luminance(light.intensity()));
            assert!((expected / closed - 1.0).abs() < 1e-3, "quadrature {expected} vs closed form {closed}");
            assert!((m.mean() / closed - 1.0).abs() < 1e-4, "{name}: constant power per start {} vs {closed}", m.mean());
        } else {
            // The sphere's cone edge falls inside quadrature cells: 0.3% slack on top of 5σ.
            assert_within_5_sigma(name, &m, expected, 3e-3 * expected);
        }
    }
    let dl = DirectionalLight::new(Vec3::new(1.0, -2.0, 0.5), Vec3::splat(3.0)).expect("direction");
    let es = dl.sample_le_toward(Vec2::new(0.3, 0.8), center, radius, 10.0).expect("start");
    let expected = 3.0 * f64::from(PI * radius * radius);
    assert!((power(&es) / expected - 1.0).abs() < 1e-5, "directional: {} vs {expected}", power(&es));
}

/// The directional light's photon origins are uniform on the disk of radius r perpendicular to the
/// light, `distance` before the target's centre: χ² over 8 rings of equal area × 16 sectors.
#[test]
fn directional_disk_origins_are_uniform_chi2() {
    let dir = Vec3::new(1.0, -2.0, 0.5).normalize();
    let dl = DirectionalLight::new(dir, Vec3::ONE).expect("direction");
    let (center, radius, distance) = (Vec3::new(0.3, -0.2, 0.5), 0.7f32, 5.0f32);
    let (rings, sectors) = (8usize, 16usize);
    let mut counts = vec![0u64; rings * sectors];
    let n = 256_000u64;
    let frame = crate::math::Frame::from_normal(-dir);
    let mut s = Sampler::for_key(22, 0, 0);
    for _ in 0..n {
        let es = dl.sample_le_toward(s.next_2d(), center, radius, distance).expect("start");
        assert!((es.dir - dir).length() < 1e-6, "{:?} vs {dir:?}", es.dir);
        let rel = es.origin - (center - distance * dir);
        assert!(rel.dot(dir).abs() < 1e-4, "origin off the disk's plane: {rel:?}");
        let (x, y) = (rel.dot(frame.s) / radius, rel.dot(frame.t) / radius);
        let r2 = x * x + y * y;
        assert!(r2 <= 1.0 + 1e-4, "origin outside the disk: r² = {r2}");
        let ring = ((r2 * rings as f32) as usize).min(rings - 1);
        let phi = y.atan2(x).rem_euclid(2.0 * PI);
        let sector = ((phi / (2.0 * PI) * sectors as f32) as usize).min(sectors - 1);
        counts[ring * sectors + sector] += 1;
    }
    let expected = n as f64 / (rings * sectors) as f64;
    let stat: f64 = counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum();
    let p = chi2_p_value(stat, rings * sectors - 1);
    eprintln!("directional disk: chi2 = {stat:.1} (dof {}), p = {p:.3}", rings * sectors - 1);
    assert!(p > 0.01, "origins not uniform on the disk: chi2 = {stat}, p = {p}");
}

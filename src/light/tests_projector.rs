//! Tests of the projector (modules `projector` and `delta`): χ² of its photon directions through the
//! film, its power against quadrature, the power its photons carry through a patch against the
//! irradiance NEE sees there (the two sides of a caustic estimate must agree), and which direction rule
//! aims its photons. Its radiance against Mitsuba's formula is tested with its plugin
//! (`emitter::projector`).

use super::delta::PointDirection;
use super::test_util::{assert_photons_through_patch_match_nee, checker};
use super::*;
use crate::math::{Frame, Mat3, Vec2, Vec3};
use crate::sampling::chi2::{integrate_sphere, Chi2Test, PdfIntegral};
use crate::texture::Texture;

/// A frame looking along `dir` (any length), mirrored when `mirror` (a look_at frame is left-handed).
fn frame(dir: Vec3, mirror: bool) -> Mat3 {
    let f = Frame::from_normal(dir.normalize());
    Mat3::from_cols(if mirror { -f.s } else { f.s }, f.t, f.n)
}

fn projector(pos: Vec3, dir: Vec3, tan_half: Vec2, texture: Texture) -> PointLight {
    let frustum = Frustum::new(frame(dir, true), tan_half).expect("valid frustum");
    PointLight::projector(pos, Vec3::splat(1.5), ProjectorProfile::new(frustum, texture))
}

/// The film-point rule has the density it reports (`|q|³/A` inside the frustum, 0 outside), for a
/// narrow, a wide and a very wide (165°, the corpus's) frustum.
#[test]
fn frustum_directions_pass_chi2() {
    let cases = [Vec2::new(0.2, 0.1), Vec2::new(1.0, 0.6), Vec2::splat((82.5f32).to_radians().tan())];
    let test = Chi2Test { sample_count: 300_000, test_count: cases.len(), integral: PdfIntegral::One, ..Chi2Test::default() };
    for tan_half in cases {
        let f = Frustum::new(frame(Vec3::new(0.3, -1.0, 0.4), true), tan_half).expect("valid frustum");
        let out = test.run(|s| Some(f.sample_direction(s.next_2d())), |w| f.pdf_direction(w));
        eprintln!("frustum {tan_half:?}: {out}");
        assert!(out.passed(), "frustum {tan_half:?}: {out}");
        // Its solid angle in closed form against quadrature of its indicator.
        let quad = integrate_sphere(|w| if f.film_uv(w).is_some() { 1.0 } else { 0.0 });
        assert!((f64::from(f.solid_angle()) / quad - 1.0).abs() < 5e-3, "solid angle {} vs {quad}", f.solid_angle());
    }
}

/// Power `Y(π·scale·k·A·mean T)` against quadrature of the intensity over the sphere, for a constant and
/// a checkerboard texture (whose mean is exact).
#[test]
fn power_matches_quadrature() {
    for texture in [Texture::Constant(Vec3::new(0.5, 1.0, 2.0)), checker()] {
        let light = projector(Vec3::new(0.1, 2.0, 0.0), Vec3::new(0.2, -1.0, 0.1), Vec2::new(0.7, 0.4), texture);
        let quad = integrate_sphere(|w| luminance(light.intensity_toward(w)));
        let power = f64::from(Light::Point(light).power(1.0));
        assert!((power / quad - 1.0).abs() < 1e-2, "power {power} vs quadrature {quad}");
    }
}

/// The power photons carry through a patch equals the irradiance NEE sees integrated over it. The patch
/// straddles the checkerboard's cells and the frustum's edge.
#[test]
fn photons_through_a_patch_carry_what_nee_sees() {
    let light = projector(Vec3::new(0.0, 3.0, 0.5), Vec3::new(0.1, -1.0, -0.2), Vec2::new(0.5, 0.35), checker());
    assert_photons_through_patch_match_nee(&light, Vec3::new(0.9, 0.0, -0.3), Vec3::new(0.2, 1.0, 0.1).normalize(), 31);
}


/// Photons leave through the film when the frustum is the smaller solid angle, in the cone toward the
/// target sphere when that is (outside the frustum their intensity is 0).
#[test]
fn photons_aim_at_the_smaller_of_frustum_and_cone() {
    let light = projector(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y, Vec2::new(0.1, 0.05), checker());
    assert!(matches!(light.direction_toward(Vec3::ZERO, 1.0), PointDirection::Frustum(_)), "a narrow frustum");
    let wide = projector(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y, Vec2::new(2.0, 1.0), checker());
    assert!(matches!(wide.direction_toward(Vec3::ZERO, 0.2), PointDirection::Cone { .. }), "a small target");
    assert!(matches!(wide.direction_toward(Vec3::new(0.0, 3.0, 0.0), 0.2), PointDirection::Frustum(_)), "inside the target");
    // Directions behind the projector or off its film carry nothing.
    assert_eq!(light.intensity_toward(Vec3::Y), Vec3::ZERO);
    assert_eq!(light.intensity_toward(Vec3::new(1.0, -1.0, 0.0).normalize()), Vec3::ZERO);
    assert!(light.sample_li(Vec3::new(0.0, 4.0, 0.0)).is_none());
}

//! Tests of the textured spot (module `delta`, [`SpotTexture`]): χ² of the power its photons carry by
//! direction against its intensity, its power against quadrature, and the power its photons carry through a
//! patch against the irradiance NEE sees there (the two sides of a caustic estimate must agree). Its
//! radiance against Mitsuba's formula is tested with its plugin (`emitter::spot`).

use super::test_util::{assert_photons_through_patch_match_nee, checker};
use super::*;
use crate::math::{Frame, Mat3, Vec3};
use crate::sampling::chi2::{integrate_sphere, Chi2Test, PdfIntegral};


const INTENSITY: Vec3 = Vec3::new(2.0, 1.0, 0.5);

/// A textured spot at `pos` along `dir` (a mirrored frame, as a look_at gives).
fn textured_spot(pos: Vec3, dir: Vec3, cutoff: f32, beam: f32) -> PointLight {
    let profile = SpotProfile::new(dir, cutoff, beam).expect("valid spot");
    let f = Frame::from_normal(dir.normalize());
    let texture = SpotTexture::new(&profile, Mat3::from_cols(-f.s, f.t, f.n), checker()).expect("cutoff below 90°");
    PointLight::textured_spot(pos, INTENSITY, profile, texture)
}

/// Photon directions kept with probability `Y(le)/Y_max` are distributed as `Y(I(ω))·p_cone/Y_max`: the
/// photons carry the texture's pattern and the falloff, for a narrow and a wide beam.
#[test]
fn photon_power_by_direction_passes_chi2() {
    let cases = [(25.0f32, 15.0f32), (70.0, 30.0)];
    let test = Chi2Test { sample_count: 400_000, test_count: cases.len(), integral: PdfIntegral::AtMostOne, ..Chi2Test::default() };
    for (cutoff, beam) in cases {
        let light = textured_spot(Vec3::new(0.1, 2.0, 0.0), Vec3::new(0.3, -1.0, 0.4), cutoff, beam);
        let y_max = luminance(INTENSITY * Vec3::new(1.0, 0.5, 2.0));
        let p_cone = 1.0 / (2.0 * std::f32::consts::PI * (1.0 - cutoff.to_radians().cos()));
        let out = test.run(
            |s| {
                let es = light.sample_le(s.next_2d())?;
                let keep = luminance(es.le) / y_max;
                assert!(keep <= 1.0 + 1e-6);
                (s.next_1d() < keep).then(|| (es.dir, keep * es.pdf_w_dir))
            },
            |w| luminance(light.intensity_toward(w)) / y_max * p_cone,
        );
        eprintln!("textured spot {cutoff}°/{beam}°: {out}");
        assert!(out.passed(), "textured spot {cutoff}°/{beam}°: {out}");
    }
}

/// The power (luminance of the quadrature of `I·falloff·T` over the cone) against the harness's quadrature of
/// the intensity over the sphere.
#[test]
fn power_matches_quadrature() {
    for (cutoff, beam) in [(25.0f32, 15.0f32), (70.0, 30.0), (40.0, 40.0)] {
        let light = textured_spot(Vec3::new(0.1, 2.0, 0.0), Vec3::new(0.2, -1.0, 0.1), cutoff, beam);
        let quad = integrate_sphere(|w| luminance(light.intensity_toward(w)));
        let power = f64::from(Light::Point(light).power(1.0));
        assert!((power / quad - 1.0).abs() < 1e-2, "{cutoff}°/{beam}°: power {power} vs quadrature {quad}");
    }
}

/// The power photons carry through a patch equals the irradiance NEE sees integrated over it. The patch
/// straddles the checkerboard's cells and the falloff's ramp.
#[test]
fn photons_through_a_patch_carry_what_nee_sees() {
    let light = textured_spot(Vec3::new(0.0, 3.0, 0.5), Vec3::new(0.1, -1.0, -0.2), 20.0, 12.0);
    assert_photons_through_patch_match_nee(&light, Vec3::new(0.5, 0.0, -0.3), Vec3::new(0.2, 1.0, 0.1).normalize(), 43);
}


/// The texture is read only inside the beam: nothing leaves outside the cutoff or behind the spot.
#[test]
fn nothing_leaves_outside_the_beam() {
    let light = textured_spot(Vec3::ZERO, Vec3::Z, 30.0, 20.0);
    assert_eq!(light.intensity_toward(-Vec3::Z), Vec3::ZERO);
    assert_eq!(light.intensity_toward(Vec3::new(1.0, 0.0, 1.0).normalize()), Vec3::ZERO);
    assert!(light.intensity_toward(Vec3::Z).max_element() > 0.0);
    assert!(light.spot_texture().is_some() && light.spot().is_some());
    // A cutoff of 90° or more has no film.
    let wide = SpotProfile::new(Vec3::Z, 90.0, 45.0).unwrap();
    assert!(SpotTexture::new(&wide, Mat3::IDENTITY, checker()).is_none());
}

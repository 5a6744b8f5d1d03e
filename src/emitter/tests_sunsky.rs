//! `sunsky` against Mitsuba 3.9.1 itself: `tests/data/sunsky/mitsuba-eval.toml` (written by
//! `scripts/make-sunsky-data`) holds, for seven emitters (directions given or computed from a date and place,
//! turbidities 1–10, grey and RGB albedos, scales, a wide sun, rotated frames), the world sun direction
//! Mitsuba holds and its `eval` at 13 directions each: zenith, mid-sky, the horizon, below it, inside the
//! sun's disc, just outside it, and 2° and 10° from it. The model ([`SunSky::radiance`]) must give Mitsuba's
//! values; the baked light (the environment map and its sun) must too, within its bilinear error away from
//! the horizon.

use super::sunsky::{read, SunSky, PLUGIN, SKY_HEIGHT};
use super::Emitter;
use crate::light::Light;
use crate::math::{Mat3, Mat4, Vec3};
use crate::props::{PropError, Props};

fn build(table: &toml::Table, to_world: Option<Mat4>) -> Result<SunSky, PropError> {
    let nested = to_world.map(|m| ("to_world", m)).into_iter().collect();
    read(&mut Props::new(table, PLUGIN.keys, nested))
}

fn light(table: &toml::Table, to_world: Option<Mat4>) -> Result<Emitter, PropError> {
    let nested = to_world.map(|m| ("to_world", m)).into_iter().collect();
    (PLUGIN.build)(Props::new(table, PLUGIN.keys, nested))
}

fn vec3(v: &toml::Value) -> Vec3 {
    let a: Vec<f32> = v.as_array().unwrap().iter().map(|x| x.as_float().unwrap() as f32).collect();
    Vec3::new(a[0], a[1], a[2])
}

struct Case {
    keys: toml::Table,
    to_world: Option<Mat4>,
    sun: Vec3,
    dirs: Vec<Vec3>,
    rgb: Vec<Vec3>,
}

fn cases() -> Vec<Case> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/sunsky/mitsuba-eval.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let table: toml::Table = text.parse().unwrap();
    table["case"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let rot = c["rotate_z"].as_float().unwrap() as f32;
            Case {
                keys: c["keys"].as_table().unwrap().clone(),
                to_world: (rot != 0.0).then(|| Mat4::from_rotation_z(rot.to_radians())),
                sun: vec3(&c["sun"]),
                dirs: c["dirs"].as_array().unwrap().iter().map(vec3).collect(),
                rgb: c["rgb"].as_array().unwrap().iter().map(vec3).collect(),
            }
        })
        .collect()
}

/// The largest relative difference of the channels, relative to the largest channel of `b` (plus `floor`).
fn rel(a: Vec3, b: Vec3, floor: f32) -> f32 {
    (a - b).abs().max_element() / (b.abs().max_element() + floor)
}

#[test]
fn sun_direction_and_radiance_match_mitsuba() {
    let mut worst = 0.0f32;
    for (i, c) in cases().iter().enumerate() {
        let s = build(&c.keys, c.to_world).unwrap();
        let to_world = Mat3::from_mat4(c.to_world.unwrap_or(Mat4::IDENTITY));
        let sun = (to_world * s.sun_local).normalize();
        let angle = sun.angle_between(c.sun);
        assert!(angle < 2e-4, "case {i}: sun {sun} against Mitsuba's {} ({angle} rad)", c.sun);
        for (d, &want) in c.dirs.iter().zip(&c.rgb) {
            let got = s.radiance((to_world.transpose() * *d).normalize());
            let e = rel(got, want, 1e-6);
            worst = worst.max(e);
            assert!(e < 2e-3, "case {i}, direction {d}: {got} against Mitsuba's {want}");
        }
    }
    println!("sunsky model against Mitsuba 3.9.1: worst relative difference {worst:e}");
}

#[test]
fn baked_light_matches_mitsuba_away_from_the_horizon() {
    // One map row is 180°/SKY_HEIGHT; within a row of the horizon the bilinear map blends the sky with the
    // black ground, and within a row of the zenith (the map's pole) it reads the first row's centres, 0.18°
    // away (these directions are checked by the model test above; their solid angle is 10⁻⁵ of the sky's).
    let horizon = (std::f32::consts::PI / SKY_HEIGHT as f32).sin();
    let pole = (std::f32::consts::PI / SKY_HEIGHT as f32).cos();
    let (mut worst, mut checked) = (0.0f32, 0);
    for (i, c) in cases().iter().enumerate() {
        let Ok(Emitter::Built(Some(Light::Env(env)))) = light(&c.keys, c.to_world) else { panic!("case {i}: no light") };
        let to_local = Mat3::from_mat4(c.to_world.unwrap_or(Mat4::IDENTITY)).transpose();
        for (d, &want) in c.dirs.iter().zip(&c.rgb) {
            let z = (to_local * *d).normalize().z;
            if z.abs() < horizon || z > pole {
                continue;
            }
            let got = env.eval(*d);
            let e = rel(got, want, 1e-6);
            worst = worst.max(e);
            checked += 1;
            assert!(e < 5e-3, "case {i}, direction {d}: {got} against Mitsuba's {want}");
        }
    }
    println!("baked sunsky against Mitsuba 3.9.1: worst relative difference {worst:e} over {checked} directions");
}

#[test]
fn defaults_and_black_cases() {
    let empty = toml::Table::new();
    let s = build(&empty, None).unwrap();
    assert_eq!((s.turbidity, s.albedo, s.sun_scale, s.sky_scale), (3.0, Vec3::splat(0.3), 1.0, 1.0));
    assert!((s.sun_half_aperture.to_degrees() - 0.2679).abs() < 1e-6);
    // A sun below the horizon, or both scales 0: Mitsuba's emitter is black, ours is left out.
    let below: toml::Table = "sun_direction = [0, 1, -0.1]".parse().unwrap();
    assert!(matches!(light(&below, None), Ok(Emitter::Built(None))));
    let off: toml::Table = "sun_scale = 0\nsky_scale = 0".parse().unwrap();
    assert!(matches!(light(&off, None), Ok(Emitter::Built(None))));
    // The sky alone is a map without a sun; the sun alone a map that samples only its sun.
    let Ok(Emitter::Built(Some(Light::Env(sky)))) = light(&"sun_scale = 0".parse().unwrap(), None) else { panic!() };
    assert!(sky.sun().is_none());
    let Ok(Emitter::Built(Some(Light::Env(sun)))) = light(&"sky_scale = 0".parse().unwrap(), None) else { panic!() };
    let axis = sun.sun().unwrap().axis();
    assert_eq!(sun.eval(-axis), Vec3::ZERO);
    assert!(sun.pdf_li(axis) > 1e3 && sun.pdf_li(-axis) == 0.0);
}

#[test]
fn bad_values_are_named_by_key() {
    let key = |text: &str, to_world: Option<Mat4>| light(&text.parse().unwrap(), to_world).unwrap_err().key;
    assert_eq!(key("turbidity = 0.5", None), "turbidity");
    assert_eq!(key("turbidity = 11", None), "turbidity");
    assert_eq!(key("albedo = 1.5", None), "albedo");
    assert_eq!(key("albedo = [0.2, -0.1, 0.3]", None), "albedo");
    assert_eq!(key("sun_scale = -1", None), "sun_scale");
    assert_eq!(key("sky_scale = -1", None), "sky_scale");
    assert_eq!(key("sun_aperture = 0", None), "sun_aperture");
    assert_eq!(key("sun_aperture = 180", None), "sun_aperture");
    assert_eq!(key("sun_direction = [0, 0, 0]", None), "sun_direction");
    assert_eq!(key("sun_direction = [0, 0, 1]\nhour = 12", None), "hour");
    assert_eq!(key("month = 13", None), "month");
    assert_eq!(key("day = 0", None), "day");
    assert_eq!(key("year = 2010.5", None), "year");
    assert_eq!(key("complex_sun = true", None), "complex_sun");
    assert_eq!(key("", Some(Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0)))), "to_world");
}

/// The bake's error (decision 35): the map against the model at 20,000 uniform directions of each case's sky
/// (outside the sun's disc, the horizon's and the zenith's rows), and the irradiance of a horizontal surface
/// from the sky by both (paired, the same directions).
#[test]
fn baked_sky_is_within_its_bilinear_error_of_the_model() {
    use crate::sampler::Sampler;
    use crate::sampling::warp::square_to_uniform_hemisphere;
    let band = (std::f32::consts::PI / SKY_HEIGHT as f32).sin();
    let mut s = Sampler::for_key(3, 0, 0);
    for (i, c) in cases().iter().enumerate() {
        let sky = build(&c.keys, c.to_world).unwrap();
        let Ok(Emitter::Built(Some(Light::Env(env)))) = light(&c.keys, c.to_world) else { panic!("case {i}: no light") };
        let to_world = Mat3::from_mat4(c.to_world.unwrap_or(Mat4::IDENTITY));
        let model = super::sunsky_model::Sky::new(f64::from(sky.turbidity), sky.albedo.as_dvec3().to_array(), sky.sun_elevation(), f64::from(sky.sky_scale));
        let (mut worst, mut sum_rel, mut n) = (0.0f64, 0.0f64, 0usize);
        let (mut e_map, mut e_model) = (0.0f64, 0.0f64);
        for _ in 0..20_000 {
            let d = square_to_uniform_hemisphere(s.next_2d());
            let w = (to_world * d).normalize();
            if env.sun().is_some_and(|sun| sun.contains(w)) {
                continue;
            }
            let (a, b) = (crate::film::luminance(env.eval(w)), crate::film::luminance(sky.sky_radiance(&model, d)));
            e_map += f64::from(a * d.z);
            e_model += f64::from(b * d.z);
            if d.z < band || d.z > (1.0 - band * band / 2.0) {
                continue;
            }
            let r = f64::from((a - b).abs() / b);
            worst = worst.max(r);
            sum_rel += r;
            n += 1;
        }
        let irradiance = e_map / e_model - 1.0;
        println!("case {i}: map against model: mean {:.2e}, worst {worst:.2e}; horizontal irradiance {irradiance:+.2e}", sum_rel / n as f64);
        assert!(worst < 2e-2 && sum_rel / (n as f64) < 2e-4 && irradiance.abs() < 1e-4, "case {i}: worst {worst}, irradiance {irradiance}");
    }
}

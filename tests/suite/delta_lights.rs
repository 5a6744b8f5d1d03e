//! Mitsuba's delta lights (`point`, `spot`, `directional`; method.md §4.1) in whole renders.
//!
//! # (a) Direct light on a diffuse plane, in closed form
//!
//! A white-ish Lambertian plane (ρ = 0.5) under one delta light has radiance `ρ/π·E(p)` with
//! `E = I·falloff·cos θ/r²` (point, spot) or `E = irradiance·cos θ` (directional): NEE with MIS weight 1
//! is exact up to where in the pixel the camera ray lands. The expected pixel value is that formula
//! averaged over an 8×8 grid of points in the pixel (camera rays intersected with the plane in the test),
//! the spot's falloff written here from Mitsuba's `spot.cpp`, independently of the renderer's code.
//! Bound: |z| < 4 for the image mean and every 8×8 block, σ from the film's per-pixel variance plus 10⁻⁴
//! of the pixel's expected value plus the image's mean (the 8×8 quadrature's error on the spot's kinks and
//! edge, where a pixel's few samples may all miss a sliver of light).
//!
//! # (b) Caustics of delta lights in a mirror, against the unfolded scene
//!
//! No BSDF-sampled path reaches a delta light, so `pt` cannot render their caustics (Mitsuba's path tracer
//! cannot either); only photons can, with `w₁ = 1` in `mis` (method.md §4.1). The reference is therefore
//! the unfolded scene: a diffuse floor (y = 0, x < 1) meets a vertical perfect mirror (x = 1); seen from
//! the floor the mirror is a window onto the mirrored scene, so the floor's radiance equals that of the
//! scene without the mirror and with the light's mirror image added (the floor cannot see itself or its
//! image: they are coplanar). The camera looks straight down at the floor and sees no mirror. `pm` and
//! `mis` of the mirror scene are compared with `pt` of the unfolded one: whole-image mean |z| < 4 with
//! σ² = the pixel variances of both renders plus (2% of the mean)² for the photon map (its noise and
//! kernel bias are shared by all pixels, so the pixel variances do not see them), and every 8×8 block
//! within 8% (measured below). `mis` equals `pm` bit for bit (w₁ = 1 exactly), and `pt` of the mirror
//! scene lacks the caustic (it is darker than the unfolded scene by more than 10% + 6σ).
//!
//! Measured (32×32, 16 spp, seed 3): see the eprintln lines of each test.

use crate::common;

use caustica::camera::Camera;
use caustica::math::Vec3;
use caustica::render::RenderSettings;
use caustica::scene::{Estimator, Scene};
use common::*;

const RHO: f64 = 0.5;

fn settings(scene: &Scene, estimator: Estimator, spp: u32) -> RenderSettings {
    let mut s = RenderSettings::from_scene(scene);
    s.spp = spp;
    s.seed = 3;
    s.estimator = estimator;
    s
}

/// A 32×32 camera above the floor at height 3 looking straight down; the floor is x ∈ [−3, 1],
/// z ∈ [−3, 3] (the camera sees x, z ∈ [−0.85, 0.85]).
fn floor_scene(extra: &str) -> String {
    format!(
        r#"
[sensor]
fov = 31.6
to_world = {{ look_at = {{ origin = [0, 3, 0], target = [0, 0, 0], up = [0, 0, -1] }} }}
film = {{ width = 32, height = 32, rfilter = {{ type = "box" }} }}

[[shape]]
type = "rectangle"
to_world = [ {{ scale = [2, 3, 1] }}, {{ rotate = {{ axis = [1, 0, 0], angle = -90 }} }}, {{ translate = [-1, 0, 0] }} ]
bsdf = {{ type = "diffuse", reflectance = {RHO} }}
{extra}
"#
    )
}

/// The mirror x = 1 (facing −x), y ∈ [0, 2], z ∈ [−1.5, 1.5].
const MIRROR: &str = r#"
[[shape]]
type = "rectangle"
to_world = [ { scale = [1.5, 1, 1] }, { rotate = { axis = [0, 1, 0], angle = -90 } }, { translate = [1, 1, 0] } ]
bsdf = { type = "conductor" }
"#;

/// Mitsuba's spot falloff (`spot.cpp`, `falloff_curve`) for the angle θ to the axis, in degrees.
fn falloff(cos_theta: f64, cutoff_deg: f64, beam_deg: f64) -> f64 {
    let theta = cos_theta.clamp(-1.0, 1.0).acos().to_degrees();
    if theta >= cutoff_deg {
        0.0
    } else if theta <= beam_deg {
        1.0
    } else {
        (cutoff_deg - theta) / (cutoff_deg - beam_deg)
    }
}

/// The floor point (y = 0) seen through film position (fx, fy).
fn floor_point(camera: &Camera, fx: f32, fy: f32) -> Option<Vec3> {
    let ray = camera.generate_ray(fx, fy);
    let t = -ray.origin.y / ray.dir.y;
    (t > 0.0).then(|| ray.at(t))
}

/// Expected pixel luminances: `ρ/π·E(p)` averaged over 8×8 points of each pixel.
fn expected_image(scene: &Scene, irradiance: &dyn Fn(Vec3) -> f64) -> Vec<f64> {
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = 0.0;
            for j in 0..8 {
                for i in 0..8 {
                    let (fx, fy) = (x as f32 + (i as f32 + 0.5) / 8.0, y as f32 + (j as f32 + 0.5) / 8.0);
                    let p = floor_point(&scene.camera, fx, fy).expect("every pixel sees the floor");
                    sum += RHO / std::f64::consts::PI * irradiance(p);
                }
            }
            out.push(sum / 64.0);
        }
    }
    out
}

/// |z| < 4 for the mean and every 8×8 block (σ² = film variance + (10⁻⁴·(expected + image mean))²).
fn check_closed_form(name: &str, lum: &LumImage, expected: &[f64]) {
    let mut exp = lum.clone();
    exp.lum = expected.to_vec();
    let mean = expected.iter().sum::<f64>() / expected.len() as f64;
    exp.var = expected.iter().map(|e| (1e-4 * (e + mean)).powi(2)).collect();
    let (a, e) = (lum.whole(), exp.whole());
    let zw = z(a, e);
    eprintln!("{name}: mean {:.6} ± {:.6} vs closed form {:.6}: ratio {:.5}, z = {zw:+.2}", a.mean, a.sigma(), e.mean, a.mean / e.mean);
    assert!(zw.abs() < 4.0, "{name}: mean {} vs {} (z = {zw})", a.mean, e.mean);
    let mut zmax: f64 = 0.0;
    for ((_, _, b), (_, _, eb)) in lum.blocks(8).into_iter().zip(exp.blocks(8)) {
        if eb.mean == 0.0 {
            // Outside the spot's beam: exactly black.
            assert_eq!(b.mean, 0.0, "{name}: a block outside the light is not black");
        } else {
            zmax = zmax.max(z(b, eb).abs());
        }
    }
    eprintln!("{name}: max 8×8 block |z| = {zmax:.2}");
    assert!(zmax < 4.0, "{name}: an 8×8 block is {zmax}σ off");
}

#[test]
fn direct_light_of_point_spot_and_directional_on_a_plane_is_the_closed_form() {
    let n = Vec3::Y;
    // Point light at (0.3, 1, −0.2), intensity 2.
    let pl = Vec3::new(0.3, 1.0, -0.2);
    let scene = scene_from_toml("point-plane.toml", &floor_scene("[[emitter]]\ntype = \"point\"\nposition = [0.3, 1, -0.2]\nintensity = 2\n"));
    let r = render_with_variance(&scene, backend(), &settings(&scene, Estimator::Pt, 16));
    let expected = expected_image(&scene, &|p| {
        let d = pl - p;
        2.0 * f64::from(n.dot(d.normalize())) / f64::from(d.length_squared())
    });
    check_closed_form("point", &r.lum, &expected);

    // Spot at (−0.2, 1.2, 0.1) aimed at (0.2, 0, 0), cutoff 35°, beam 20°, intensity 3: the image holds
    // the beam, the ramp and the dark outside.
    let (sp, target) = (Vec3::new(-0.2, 1.2, 0.1), Vec3::new(0.2, 0.0, 0.0));
    let spot = "[[emitter]]\ntype = \"spot\"\nintensity = 3\ncutoff_angle = 35\nbeam_width = 20\nto_world = { look_at = { origin = [-0.2, 1.2, 0.1], target = [0.2, 0, 0], up = [0, 1, 0] } }\n";
    let scene = scene_from_toml("spot-plane.toml", &floor_scene(spot));
    let r = render_with_variance(&scene, backend(), &settings(&scene, Estimator::Pt, 16));
    let axis = (target - sp).normalize();
    let expected = expected_image(&scene, &|p| {
        let d = sp - p;
        let w = -d.normalize();
        3.0 * falloff(f64::from(axis.dot(w)), 35.0, 20.0) * f64::from(n.dot(d.normalize())) / f64::from(d.length_squared())
    });
    assert!(expected.iter().any(|&e| e == 0.0) && expected.iter().any(|&e| e > 0.0), "the beam's edge is in view");
    check_closed_form("spot", &r.lum, &expected);

    // Directional light travelling along (1, −2, 0.5), irradiance 1.5: uniform E·cos θ.
    let dir = Vec3::new(1.0, -2.0, 0.5).normalize();
    let scene = scene_from_toml("directional-plane.toml", &floor_scene("[[emitter]]\ntype = \"directional\"\ndirection = [1, -2, 0.5]\nirradiance = 1.5\n"));
    let r = render_with_variance(&scene, backend(), &settings(&scene, Estimator::Pt, 16));
    let expected = expected_image(&scene, &|_| 1.5 * f64::from(n.dot(-dir)));
    check_closed_form("directional", &r.lum, &expected);
}

/// Renders the mirror scene with `light`, and the unfolded scene with `light` and `image` (the light
/// mirrored in x = 1), and compares as the module docs say.
fn mirror_case(name: &str, light: &str, image: &str) {
    let mirror = scene_from_toml(&format!("{name}-mirror.toml"), &floor_scene(&format!("{MIRROR}\n{light}")));
    let unfolded = scene_from_toml(&format!("{name}-unfolded.toml"), &floor_scene(&format!("{light}\n{image}")));
    let reference = render_with_variance(&unfolded, backend(), &settings(&unfolded, Estimator::Pt, 16));
    let ref_whole = reference.lum.whole();
    let pt = render_with_variance(&mirror, backend(), &settings(&mirror, Estimator::Pt, 16)).lum.whole();
    eprintln!("{name}: unfolded pt {:.5} ± {:.5}; mirror pt {:.5} (no caustic: {:.3}×)", ref_whole.mean, ref_whole.sigma(), pt.mean, pt.mean / ref_whole.mean);
    assert!(ref_whole.mean - pt.mean > 6.0 * ref_whole.sigma() + 0.1 * ref_whole.mean, "{name}: pt of the mirror scene should miss the caustic");
    let mut images = Vec::new();
    for est in [Estimator::Pm, Estimator::Mis] {
        let mut s = settings(&mirror, est, 16);
        s.photons = caustica::photon::PhotonBudget::Emitted(400_000);
        let r = render_with_variance(&mirror, backend(), &s);
        let m = r.lum.whole();
        let shared = 0.02 * m.mean;
        let zw = z(Stat { mean: m.mean, var: m.var + shared * shared }, ref_whole);
        let worst = r.lum.blocks(8).into_iter().zip(reference.lum.blocks(8)).map(|((_, _, b), (_, _, rb))| (b.mean / rb.mean - 1.0).abs()).fold(0.0, f64::max);
        eprintln!(
            "{name} {est:?}: {:.5} (ratio {:.4}, z = {zw:+.2}), worst 8×8 block {:.1}%, {} photons stored of {}",
            m.mean,
            m.mean / ref_whole.mean,
            100.0 * worst,
            r.stats.photons_stored,
            r.stats.photons_emitted
        );
        assert!(zw.abs() < 4.0, "{name} {est:?}: mean {} vs unfolded {} (z = {zw})", m.mean, ref_whole.mean);
        assert!(worst < 0.08, "{name} {est:?}: an 8×8 block is {:.1}% off", 100.0 * worst);
        images.push(r.image);
    }
    assert!(images[0].pixels() == images[1].pixels(), "{name}: mis must equal pm bit for bit (w₁ = 1 for delta lights)");
}

#[test]
fn point_light_caustic_in_a_mirror_matches_the_unfolded_scene() {
    mirror_case(
        "point",
        "[[emitter]]\ntype = \"point\"\nposition = [0.5, 1, 0]\nintensity = 1\n",
        "[[emitter]]\ntype = \"point\"\nposition = [1.5, 1, 0]\nintensity = 1\n",
    );
}

#[test]
fn spot_light_caustic_in_a_mirror_matches_the_unfolded_scene() {
    mirror_case(
        "spot",
        "[[emitter]]\ntype = \"spot\"\nintensity = 2\ncutoff_angle = 110\nbeam_width = 30\nto_world = { look_at = { origin = [0.5, 1, 0], target = [1, 0, 0.2], up = [0, 1, 0] } }\n",
        "[[emitter]]\ntype = \"spot\"\nintensity = 2\ncutoff_angle = 110\nbeam_width = 30\nto_world = { look_at = { origin = [1.5, 1, 0], target = [1, 0, 0.2], up = [0, 1, 0] } }\n",
    );
}

#[test]
fn directional_light_caustic_in_a_mirror_matches_the_unfolded_scene() {
    mirror_case(
        "directional",
        "[[emitter]]\ntype = \"directional\"\ndirection = [1, -1, 0.2]\nirradiance = 1\n",
        "[[emitter]]\ntype = \"directional\"\ndirection = [-1, -1, 0.2]\nirradiance = 1\n",
    );
}

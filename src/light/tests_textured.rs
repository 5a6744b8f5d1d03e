//! Tests of textured area lights in a scene (Mitsuba's `area` emitter with a `radiance` texture): every
//! reading of the light sees the texture at the same point — NEE's sample, the emission a ray finds there
//! (`LightSet::le_area` at `Scene::tex_uv`, what the path tracer reads), a photon's start — on a shape with
//! uvs (a rectangle, a bitmap) and one without (an OBJ quad: its barycentrics, a checkerboard), with T2's
//! density at a photon's start equal to the photon's (`mis`'s weights sum to one); and the direct light at
//! a point estimated by NEE alone, by BSDF sampling alone and by both under the power heuristic agree (two
//! techniques of one integral whose weights sum to one), while lights of the textures' mean radiance give a
//! different answer (the agreement is the texture's, not the mean's).

use super::test_util::Mean;
use super::*;
use crate::accel::brute::BruteForce;
use crate::accel::Accel;
use crate::math::Ray;
use crate::photon::PhotonEmission;
use crate::sampler::Sampler;
use crate::sampling::mis::power_heuristic;
use crate::sampling::warp::square_to_cosine_hemisphere;
use crate::scene::Scene;
use crate::texture::{BitmapSpec, StorageFormat, TextureSpec};
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

const CHECKS: &str = "{ type = \"checkerboard\", color0 = [1, 1, 0.5], color1 = [0, 0, 0], to_uv = { scale = [2, 3, 1] } }";

fn pattern() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/materials/textures/pattern.png")
}

/// A bitmap light (a rectangle facing down, the pattern of `tests/data/materials/textures`), a
/// checkerboard light on an OBJ quad without uvs (facing down), a glass sphere (a target for photons) and a
/// floor. With `mean`, each light emits its texture's mean instead. The OBJ is written to `dir`.
fn scene(dir: &Path, mean: bool) -> Scene {
    let quad = dir.join("quad-without-uvs.obj");
    std::fs::write(&quad, "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv -1 0 1\nf 1 3 4\nf 1 2 3\n").expect("write the OBJ");
    let bitmap = format!("{{ type = \"bitmap\", filename = {:?} }}", pattern().display().to_string());
    let (bitmap, checks) = if mean {
        let spec = BitmapSpec { filename: pattern().display().to_string(), raw: false, filter: Default::default(), wrap: Default::default(), format: StorageFormat::Auto };
        let m = TextureSpec::Bitmap(spec).load(Path::new("."), &mut Default::default()).expect("the pattern loads").mean_rgb();
        (format!("[{}, {}, {}]", m.x, m.y, m.z), "[0.5, 0.5, 0.25]".to_string())
    } else {
        (bitmap, CHECKS.to_string())
    };
    let text = format!(
        r#"
[[shape]]   # floor
type = "rectangle"
to_world = [ {{ scale = 4 }}, {{ rotate = {{ axis = [1, 0, 0], angle = -90 }} }} ]

[[shape]]   # the bitmap light, facing down
type = "rectangle"
to_world = [ {{ scale = [0.8, 0.5, 1] }}, {{ rotate = {{ axis = [1, 0, 0], angle = 90 }} }}, {{ translate = [0.3, 1.2, 0] }} ]
emitter = {{ type = "area", radiance = {bitmap} }}

[[shape]]   # the checkerboard light on a shape without uvs, facing down
type = "obj"
filename = {quad:?}
to_world = [ {{ scale = 0.4 }}, {{ translate = [-1, 0.9, 0.5] }} ]
emitter = {{ type = "area", radiance = {checks} }}

[[shape]]
type = "sphere"
center = [0, 0.3, 1.5]
radius = 0.2
rings = 6
segments = 12
bsdf = {{ type = "dielectric" }}
"#
    );
    Scene::from_toml_str(&text, dir, Path::new("textured-lights.toml")).unwrap_or_else(|e| panic!("{e}"))
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caustica-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    dir
}

/// The light a ray finds first and the emission it reads there, as the path tracer reads it (`None`:
/// no light first).
fn emission_seen(scene: &Scene, accel: &BruteForce, ray: &Ray) -> Option<(usize, Vec3, f32)> {
    let hit = accel.intersect(ray)?;
    let light = scene.lights.light_of_prim(hit.prim)?;
    let si = scene.interaction(ray, &hit);
    let le = scene.lights.le_area(hit.prim, si.ng, -ray.dir, || scene.tex_uv(&si));
    Some((light, le, scene.lights.pdf_li_area(hit.prim, ray.origin, si.p, si.ng)))
}

/// Two radiances equal but for rounding: a ray finds the sampled point again within rounding of it, where a
/// bilinear bitmap moves as little (a point on a checkerboard's edge may read the other colour: allowed,
/// rarely; measured: none in 35,741).
fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= 1e-3 * a.max_element().max(b.max_element()).max(1e-3)
}

#[test]
fn nee_hits_and_photons_read_the_texture_at_one_point() {
    let dir = temp_dir("textured-lights-points");
    let scene = scene(&dir, false);
    let accel = BruteForce::new(&scene.mesh.positions, &scene.mesh.indices);
    let lights = scene.lights.lights();
    assert_eq!(lights.iter().filter(|l| matches!(l, Light::Area(a) if a.is_textured())).count(), 2);
    let mut s = Sampler::for_key(5, 0, 0);
    let (mut agree, mut differ) = (0, 0);
    let mut distinct: Vec<Vec3> = Vec::new();
    // NEE from points on the floor: a ray toward the sampled point finds its radiance there.
    for _ in 0..20_000 {
        let p = Vec3::new(4.0 * s.next_1d() - 2.0, 0.0, 4.0 * s.next_1d() - 2.0);
        let Some((index, ls)) = scene.lights.sample_li(p, s.next_1d(), s.next_2d()) else { continue };
        let origin = p + 1e-4 * Vec3::Y;
        let Some((light, seen, _)) = emission_seen(&scene, &accel, &Ray::new(origin, (ls.p_light - origin).normalize())) else { continue };
        if light != index || ((ls.p_light - p).length() - ls.dist).abs() > 1e-3 {
            continue; // another light, or the sphere, in between
        }
        if close(seen, ls.li) { agree += 1 } else { differ += 1 }
        if distinct.len() < 64 && !distinct.contains(&ls.li) {
            distinct.push(ls.li);
        }
    }
    // Photon starts: a ray onto the start point from in front of it finds the radiance the photon carries.
    let em = PhotonEmission::new(&scene).expect("the lights emit photons");
    let mut photons = 0;
    for _ in 0..20_000 {
        let Some(st) = em.sample(lights, s.next_1d(), s.next_2d(), s.next_2d(), s.next_1d()) else { continue };
        let es = st.emission;
        photons += 1;
        let (light, seen, _) = emission_seen(&scene, &accel, &Ray::new(es.origin + 1e-3 * es.n, -es.n)).expect("the start is on a light");
        if close(seen, es.le) { agree += 1 } else { differ += 1 }
        // Power × N × p_emit is the radiance at the start (method.md §2, §4), and T2's density at the start
        // is the photon's (both sides of `mis`'s weight read one p_emit: w₁ + w₂ = 1).
        assert!(close(st.power_n * st.pdf_emit, es.le), "{} vs {}", st.power_n * st.pdf_emit, es.le);
        let t2 = em.pdf_emit_area(light, es.origin, es.n, es.dir);
        assert!((t2 / st.pdf_emit - 1.0).abs() < 1e-3, "light {light}: sampled p_emit {} vs T2's {t2}", st.pdf_emit);
    }
    println!("{agree} agree, {differ} differ, {photons} photons, {} distinct radiances", distinct.len());
    assert!(photons > 5_000 && agree > 20_000, "{photons} photons, {agree} points checked");
    assert!(distinct.len() == 64, "NEE saw {} distinct radiances: the texture does not vary", distinct.len());
    assert!(differ * 500 < agree, "{differ} of {} disagree", agree + differ);
    let _ = std::fs::remove_dir_all(dir);
}

/// The irradiance at `p` (on the floor, normal +y) by NEE, by cosine-weighted BSDF sampling, and by both
/// under the power heuristic (luminance; `n` samples each).
fn irradiance(scene: &Scene, accel: &BruteForce, p: Vec3, n: usize) -> [Mean; 3] {
    let (mut nee, mut bsdf, mut mis) = (Mean::default(), Mean::default(), Mean::default());
    let mut s = Sampler::for_key(9, u64::from(p.x.to_bits()), u64::from(p.z.to_bits()));
    let origin = p + 1e-4 * Vec3::Y;
    for _ in 0..n {
        // NEE, with its shadow ray.
        let (mut e_nee, mut w_nee) = (0.0, 0.0);
        if let Some((_, ls)) = scene.lights.sample_li(p, s.next_1d(), s.next_2d()) {
            let cos = ls.wi_world.y;
            let d = ls.p_light - origin;
            if cos > 0.0 && !accel.occluded(&Ray::segment(origin, d, 0.0, 1.0 - 1e-3)) {
                e_nee = f64::from(luminance(ls.li) * cos / ls.pdf_w);
                w_nee = f64::from(power_heuristic(ls.pdf_w, cos / PI));
            }
        }
        // BSDF sampling: a cosine-weighted direction, the emission of the light it finds first.
        let (mut e_bsdf, mut w_bsdf) = (0.0, 0.0);
        let local = square_to_cosine_hemisphere(s.next_2d());
        let w = Vec3::new(local.x, local.z, local.y).normalize();
        if let Some((_, le, pdf_light)) = emission_seen(scene, accel, &Ray::new(origin, w)) {
            e_bsdf = f64::from(luminance(le) * PI);
            w_bsdf = f64::from(power_heuristic(w.y / PI, pdf_light));
        }
        nee.add(e_nee);
        bsdf.add(e_bsdf);
        mis.add(w_nee * e_nee + w_bsdf * e_bsdf);
    }
    [nee, bsdf, mis]
}

fn within_5_sigma(what: &str, a: &Mean, b: &Mean) -> bool {
    let (d, se) = ((a.mean() - b.mean()).abs(), a.stderr().hypot(b.stderr()));
    println!("{what}: {} ± {} vs {} ± {}: {:.2} σ", a.mean(), a.stderr(), b.mean(), b.stderr(), d / se);
    d <= 5.0 * se
}

#[test]
fn nee_and_bsdf_sampling_of_a_textured_light_estimate_one_integral() {
    let dir = temp_dir("textured-lights-mis");
    let textured = scene(&dir, false);
    let mean = scene(&dir, true);
    let (accel, accel_mean) = (BruteForce::new(&textured.mesh.positions, &textured.mesh.indices), BruteForce::new(&mean.mesh.positions, &mean.mesh.indices));
    let mut differ = 0;
    for p in [Vec3::new(0.6, 0.0, 0.2), Vec3::new(-1.1, 0.0, 0.35), Vec3::new(0.0, 0.0, -0.8), Vec3::new(-0.4, 0.0, 0.9)] {
        let [nee, bsdf, mis] = irradiance(&textured, &accel, p, 200_000);
        assert!(nee.mean() > 0.0, "{p}: no light");
        assert!(within_5_sigma(&format!("{p}: NEE vs BSDF"), &nee, &bsdf));
        assert!(within_5_sigma(&format!("{p}: MIS vs NEE"), &mis, &nee));
        assert!(within_5_sigma(&format!("{p}: MIS vs BSDF"), &mis, &bsdf));
        let [nee_mean, ..] = irradiance(&mean, &accel_mean, p, 200_000);
        differ += usize::from(!within_5_sigma(&format!("{p}: textured vs mean"), &mis, &nee_mean));
    }
    // Measured: two points 14σ and 23σ from the means' answer; at the other two the texture averages out.
    assert!(differ >= 2, "only {differ} of 4 points tell the texture from its mean");
    let _ = std::fs::remove_dir_all(dir);
}

//! The stiff/extreme suite (issue 13 §3): small scenes at the edges of what the renderer accepts, each
//! rendered with `pt`, `pm` and `mis` in-process. Every render must be free of NaN/Inf samples (checked by
//! `common::render_with_variance`) and must not panic; `pm`/`mis` must agree with `pt` (or with each
//! other, where `pt` cannot find the light) on the image's mean luminance within
//!
//! `|m − m_ref| ≤ 4·√(σ² + σ_ref²) + KERNEL_BIAS·m_ref`,
//!
//! σ being each mean's standard error from the film's per-pixel variance, and `KERNEL_BIAS` the
//! allowance for the density estimate's kernel bias at these small photon counts (method.md §3).
//!
//! The scenes are written by [`scene`] from one template (a floor, a mirror wall, a glass sphere and a
//! small light facing down, 32×24 pixels), so that the scaled and translated variants are exactly the base
//! scene in other units: their images must have the base scene's mean.

use crate::common;

use caustica::photon::PhotonBudget;
use caustica::render::{RenderSettings, RenderPhaseStats};
use caustica::scene::{Estimator, Scene};
use common::{backend, render_with_variance, Stat};

/// Allowance for the kernel bias of `pm`/`mis` relative to the reference mean (k = 20, 20,000 photons).
const KERNEL_BIAS: f64 = 0.08;
/// Standard errors allowed between two means.
const Z: f64 = 4.0;
/// Samples per pixel of the `pt` reference renders (pm/mis use 16).
const PT_SPP: u32 = 256;

/// The template's parameters.
#[derive(Clone)]
struct Params {
    /// Uniform scale and translation along x applied to the whole scene (camera included).
    scale: f64,
    offset: f64,
    /// Half side of the square light, and its radiance.
    light_half: f64,
    radiance: f64,
    /// The floor's and the sphere's BSDF (inline TOML tables).
    floor: String,
    sphere: String,
    /// A second glass sphere inside the first (nested dielectrics).
    inner_sphere: Option<String>,
    /// The light sits inside the sphere, facing down.
    light_in_sphere: bool,
    width: u32,
    height: u32,
    photons: u64,
    knn: u32,
    max_radius: Option<f64>,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            scale: 1.0,
            offset: 0.0,
            light_half: 0.1,
            radiance: 40.0,
            floor: r#"{ type = "diffuse", reflectance = 0.6 }"#.into(),
            sphere: r#"{ type = "dielectric", int_ior = 1.5 }"#.into(),
            inner_sphere: None,
            light_in_sphere: false,
            width: 32,
            height: 24,
            photons: 20_000,
            knn: 20,
            max_radius: None,
        }
    }
}

/// The scene text of `p`.
fn scene(p: &Params) -> String {
    let (s, d) = (p.scale, p.offset);
    let place = |x: f64, y: f64, z: f64| format!("[{}, {}, {}]", x * s + d, y * s, z * s);
    let tail = format!("{{ scale = {s} }}, {{ translate = [{d}, 0, 0] }}");
    let (light_y, light_side) = if p.light_in_sphere { (0.45, p.light_half.min(0.1)) } else { (1.2, p.light_half) };
    let max_radius = p.max_radius.map_or(String::new(), |r| format!("max_radius = {}\n", r * s));
    // Mitsuba's default clip planes in the scene's units (0.01 and 10⁴ at scale 1): the same scene in other units.
    let (near_clip, far_clip) = (0.01 * s, 1e4 * s);
    let inner = p.inner_sphere.as_ref().map_or(String::new(), |b| {
        format!("[[shape]]\ntype = \"sphere\"\ncenter = {}\nradius = {}\nrings = 12\nsegments = 24\nbsdf = {b}\n", place(0.0, 0.4, 0.0), 0.15 * s)
    });
    format!(
        r#"[integrator]
max_depth = -1
rr_depth = 5
samples_per_pixel = 16
seed = 7

[integrator.caustics]
estimator = "mis"
photons = {photons}
knn = {knn}
{max_radius}
[sensor]
fov = 50
fov_axis = "x"
near_clip = {near_clip}
far_clip = {far_clip}
to_world = {{ look_at = {{ origin = {cam}, target = {target}, up = [0, 1, 0] }} }}
film = {{ width = {w}, height = {h}, rfilter = {{ type = "box" }} }}

[[shape]]   # floor y = 0, 3 x 3
type = "rectangle"
to_world = [ {{ scale = 1.5 }}, {{ rotate = {{ axis = [1, 0, 0], angle = -90 }} }}, {tail} ]
bsdf = {floor}

[[shape]]   # mirror wall z = -1.5
type = "rectangle"
to_world = [ {{ scale = [1.5, 1, 1] }}, {{ translate = [0, 1, -1.5] }}, {tail} ]
bsdf = {{ type = "conductor", specular_reflectance = 1 }}

[[shape]]   # glass sphere
type = "sphere"
center = {center}
radius = {radius}
rings = 12
segments = 24
bsdf = {sphere}

{inner}
[[shape]]   # light facing down
type = "rectangle"
to_world = [ {{ scale = [{lh}, {lh}, 1] }}, {{ rotate = {{ axis = [1, 0, 0], angle = 90 }} }}, {{ translate = [0, {light_y}, 0] }}, {tail} ]
bsdf = {{ type = "diffuse", reflectance = 0 }}
emitter = {{ type = "area", radiance = {radiance} }}
"#,
        photons = p.photons,
        knn = p.knn,
        cam = place(0.0, 1.1, 2.6),
        target = place(0.0, 0.2, -0.2),
        w = p.width,
        h = p.height,
        center = place(0.0, 0.4, 0.0),
        radius = 0.3 * s,
        lh = light_side,
        radiance = p.radiance,
        floor = p.floor,
        sphere = p.sphere,
    )
}

fn load(name: &str, p: &Params) -> Result<Scene, caustica::scene::SceneError> {
    Scene::from_toml_str(&scene(p), &common::repo_path("tests"), std::path::Path::new(name))
}

struct Run {
    mean: Stat,
    stats: RenderPhaseStats,
    seconds: f64,
}

fn run(scene: &Scene, estimator: Estimator, spp: u32) -> Run {
    let mut settings = RenderSettings::from_scene(scene);
    settings.estimator = estimator;
    settings.spp = spp;
    let r = render_with_variance(scene, backend(), &settings);
    Run { mean: r.lum.whole(), stats: r.stats, seconds: r.seconds }
}

/// The three estimators on one case of the template ([`run_scene`]).
fn run_all(name: &str, p: &Params) -> [Run; 3] {
    run_scene(name, &load(name, p).unwrap_or_else(|e| panic!("{name}: {e}")))
}

/// The three estimators on a loaded scene (pt with 16× the samples: it carries the reference).
fn run_scene(name: &str, scene: &Scene) -> [Run; 3] {
    let runs = [run(scene, Estimator::Pt, PT_SPP), run(scene, Estimator::Pm, 16), run(scene, Estimator::Mis, 16)];
    for (e, r) in ["pt", "pm", "mis"].iter().zip(&runs) {
        eprintln!(
            "{name:>18} {e:>3}: mean {:.5e} ± {:.5e}  {:.2} s  photons stored {} chains capped {}",
            r.mean.mean,
            r.mean.sigma(),
            r.seconds,
            r.stats.photons_stored,
            r.stats.photon_chains_capped
        );
    }
    runs
}

/// `m` agrees with `reference` within the suite's tolerance (module docs).
fn assert_agrees(name: &str, what: &str, m: Stat, reference: Stat) {
    let tol = Z * (m.var + reference.var).sqrt() + KERNEL_BIAS * reference.mean.abs();
    assert!(
        (m.mean - reference.mean).abs() <= tol,
        "{name}: {what} mean {:.5} vs {:.5} (tolerance {tol:.5})",
        m.mean,
        reference.mean
    );
}

/// pm and mis against pt.
fn check_against_pt(name: &str, p: &Params) -> [Run; 3] {
    let runs = check_mis_against_pt(name, p);
    assert_agrees(name, "pm vs pt", runs[1].mean, runs[0].mean);
    runs
}

/// mis against pt, where pm is known to fail (a near-delta receiver: the density estimate evaluates the
/// receiver's lobe at the photons' directions, which almost never fall inside a lobe of width α; that is
/// the case BSDF sampling must take over, method.md §4).
fn check_mis_against_pt(name: &str, p: &Params) -> [Run; 3] {
    let runs = run_all(name, p);
    assert!(runs[0].mean.mean > 0.0, "{name}: black image");
    assert_agrees(name, "mis vs pt", runs[2].mean, runs[0].mean);
    runs
}

#[test]
fn base_scene() {
    let runs = check_against_pt("base", &Params::default());
    assert!(runs[1].stats.photons_stored > 100, "the glass sphere makes caustic photons");
}

/// A tiny, very bright light (side 1e-4, radiance 1e9) and a huge, dim one (side 40, radiance 1e-3).
/// Through the glass sphere the tiny light's caustic is out of `pt`'s reach (BSDF sampling from the floor
/// almost never hits a 1e-4 light), so there pm and mis are checked against each other.
#[test]
fn tiny_bright_and_huge_dim_lights() {
    let tiny = Params { light_half: 5e-5, radiance: 1e9, ..Params::default() };
    let runs = run_all("tiny-bright-light", &tiny);
    assert!(runs[0].mean.mean > 0.0);
    assert_agrees("tiny-bright-light", "mis vs pm", runs[2].mean, runs[1].mean);
    check_against_pt("huge-dim-light", &Params { light_half: 20.0, radiance: 1e-3, ..Params::default() });
}

/// GGX α at 1e-4, 1e-3 and 1 on the floor, and blends at weights 0 and 1.
#[test]
fn ggx_roughness_extremes_and_blend_weights() {
    for alpha in [1e-4, 1e-3, 1.0] {
        let floor = format!(r#"{{ type = "roughconductor", alpha = {alpha} }}"#);
        let p = Params { floor, ..Params::default() };
        if alpha < 0.01 {
            // Everything the camera sees lies in the floor's reflection of the mirror and the glass
            // (E G S⁺ L): pm cannot estimate it (dark; measured 0 at α = 1e-4), mis must.
            let runs = check_mis_against_pt(&format!("ggx-{alpha:e}"), &p);
            assert!(runs[1].mean.mean <= runs[0].mean.mean, "ggx-{alpha:e}: pm above pt");
        } else {
            check_against_pt(&format!("ggx-{alpha:e}"), &p);
        }
    }
    for w in [0, 1] {
        let floor = format!(
            r#"{{ type = "blendbsdf", weight = {w}, bsdf_0 = {{ type = "diffuse", reflectance = 0.6 }}, bsdf_1 = {{ type = "roughconductor", alpha = 0.1 }} }}"#
        );
        check_against_pt(&format!("blend-{w}"), &Params { floor, ..Params::default() });
    }
}

/// The scene scaled by 1e-3 and 1e5 and translated by 2e3 is the base scene in other units: every
/// estimator gives the base scene's mean (offsets, the search radius and the minimum ΔA scale with it).
#[test]
fn scaled_and_translated_scenes_render_the_same_image() {
    let base = run_all("base", &Params::default());
    for (name, p) in [
        ("scale-1e-3", Params { scale: 1e-3, ..Params::default() }),
        ("scale-1e5", Params { scale: 1e5, ..Params::default() }),
        ("offset-2e3", Params { offset: 2e3, ..Params::default() }),
    ] {
        let runs = run_all(name, &p);
        for (e, (r, b)) in ["pt", "pm", "mis"].iter().zip(runs.iter().zip(&base)) {
            assert_agrees(name, &format!("{e} vs the base scene's {e}"), r.mean, b.mean);
        }
    }
}

/// Translated by 1e6, f32 cannot hold the 0.3-radius sphere (its coordinates keep 1/16 of a unit):
/// the loader refuses it, naming the file, the shape and the limit, instead of rendering it wrong.
#[test]
fn far_from_the_origin_is_refused_with_the_limit() {
    let Err(err) = load("offset-1e6.toml", &Params { offset: 1e6, ..Params::default() }) else {
        panic!("a scene 1e6 from the origin was accepted");
    };
    let err = err.to_string();
    assert!(err.starts_with("offset-1e6.toml"), "{err}");
    assert!(err.contains("shape[0]") && err.contains("limit: 16384 times its size"), "{err}");
}

/// Dielectrics: IOR 1.0001 (nearly invisible) and 10 (mostly total internal reflection inside), nested
/// glass, and a light inside a glass sphere.
#[test]
fn dielectric_extremes() {
    for ior in [1.0001, 10.0] {
        let sphere = format!(r#"{{ type = "dielectric", int_ior = {ior} }}"#);
        check_against_pt(&format!("ior-{ior}"), &Params { sphere, ..Params::default() });
    }
    let inner = Some(r#"{ type = "dielectric", int_ior = 1.33, ext_ior = 1.5 }"#.to_string());
    check_against_pt("nested-glass", &Params { inner_sphere: inner, ..Params::default() });
    check_against_pt("light-in-glass", &Params { light_in_sphere: true, light_half: 0.05, radiance: 100.0, ..Params::default() });
}

/// Photon extremes: k larger than the photons stored, a single photon, and a tiny search radius. With
/// so few photons pm is far from pt (no test of its mean), but nothing may break, and mis hands the
/// caustic back to BSDF sampling (q₁ → 0), so mis still agrees with pt.
#[test]
fn photon_extremes() {
    for (name, p) in [
        ("knn-above-stored", Params { photons: 300, knn: 1000, ..Params::default() }),
        ("one-photon", Params { photons: 1, ..Params::default() }),
        ("max-radius-1e-6", Params { max_radius: Some(1e-6), ..Params::default() }),
    ] {
        let runs = run_all(name, &p);
        assert!(runs[1].mean.mean.is_finite() && runs[1].mean.mean <= runs[0].mean.mean * 1.5 + 0.05, "{name}: pm");
        assert_agrees(name, "mis vs pt", runs[2].mean, runs[0].mean);
    }
}

/// Film extremes: 1×1 and 4000×1 pixels (all three estimators, no NaN, means agree).
#[test]
fn film_extremes() {
    check_against_pt("film-1x1", &Params { width: 1, height: 1, ..Params::default() });
    check_against_pt("film-4000x1", &Params { width: 4000, height: 1, ..Params::default() });
}

/// A huge `max_radius` must not remove the caustic (issue 13 §2: the ΔA clamp followed the user's search
/// bound). Measured before that fix: pm = mis = 0.0430, the image without the caustic, against pt
/// 0.0581 ± 0.0014.
#[test]
fn huge_max_radius_keeps_the_caustic() {
    check_against_pt("max-radius-1e6", &Params { max_radius: Some(1e6), ..Params::default() });
}

/// A camera inside a closed box of perfect mirrors (reflectance 1) with a glass sphere and a diffuse
/// floor patch: long delta chains must terminate, and the estimators agree (issue 13 §2, delta-chain
/// bias); the stats count the chains the photon pass cut.
#[test]
fn closed_mirror_box() {
    let text = r#"
[integrator]
max_depth = -1
rr_depth = 5
samples_per_pixel = 16
seed = 7
[integrator.caustics]
photons = 20000
knn = 20
[sensor]
fov = 70
to_world = { look_at = { origin = [0, 0.3, 0.8], target = [0, -0.5, 0], up = [0, 1, 0] } }
film = { width = 24, height = 24, rfilter = { type = "box" } }
[bsdf.mirror]
type = "conductor"
specular_reflectance = 1
[[shape]]
type = "cube"
flip_normals = true
bsdf = "mirror"
[[shape]]   # diffuse patch on the floor
type = "rectangle"
to_world = [ { scale = 0.4 }, { rotate = { axis = [1, 0, 0], angle = -90 } }, { translate = [0, -0.999, 0] } ]
bsdf = { type = "diffuse", reflectance = 0.5 }
[[shape]]
type = "sphere"
center = [0.3, -0.5, -0.2]
radius = 0.3
rings = 12
segments = 24
bsdf = { type = "dielectric", int_ior = 1.5 }
[[shape]]   # small light under the ceiling
type = "rectangle"
to_world = [ { scale = 0.1 }, { rotate = { axis = [1, 0, 0], angle = 90 } }, { translate = [0, 0.95, 0] } ]
bsdf = { type = "diffuse", reflectance = 0 }
emitter = { type = "area", radiance = 10 }
"#;
    let scene = Scene::from_toml_str(text, &common::repo_path("tests"), std::path::Path::new("closed-mirror-box")).unwrap();
    let runs = [run(&scene, Estimator::Pt, 64), run(&scene, Estimator::Pm, 16), run(&scene, Estimator::Mis, 16)];
    for (e, r) in ["pt", "pm", "mis"].iter().zip(&runs) {
        eprintln!("closed-mirror-box {e}: mean {:.5} ± {:.5} {:.2} s, chains capped {}", r.mean.mean, r.mean.sigma(), r.seconds, r.stats.photon_chains_capped);
    }
    assert!(runs[1].stats.photons_emitted > 0);
    assert_agrees("closed-mirror-box", "pm vs pt", runs[1].mean, runs[0].mean);
    assert_agrees("closed-mirror-box", "mis vs pt", runs[2].mean, runs[0].mean);
}

#[test]
fn photon_budget_is_the_emitted_count() {
    // Guards the template: the settings come from the scene file.
    let scene = load("base", &Params::default()).unwrap();
    assert_eq!(RenderSettings::from_scene(&scene).photons, PhotonBudget::Emitted(20_000));
}

/// The integrator and sensor tables of the scenes written outside the template: mis, 20,000 photons,
/// k = 20, 32×24 pixels, the camera at `origin` looking at `target`.
fn header(origin: &str, target: &str) -> String {
    format!(
        r#"[integrator]
max_depth = -1
rr_depth = 5
samples_per_pixel = 16
seed = 7
[integrator.caustics]
estimator = "mis"
photons = 20000
knn = 20
[sensor]
fov = 50
fov_axis = "x"
to_world = {{ look_at = {{ origin = {origin}, target = {target}, up = [0, 1, 0] }} }}
film = {{ width = 32, height = 24, rfilter = {{ type = "box" }} }}"#
    )
}

/// The environment-map scene: a diffuse floor and a glass sphere under an equirectangular map written to
/// a temporary EXR (`texels` is the map, 32×16, row 0 at the zenith), scaled by `scale`.
fn env_scene(name: &str, texels: impl FnMut(u32, u32) -> glam::Vec3, scale: f64) -> Scene {
    let dir = std::env::temp_dir().join(format!("caustica-stress-env-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    caustica::film::write_exr(dir.join("map.exr"), &caustica::film::Image::from_fn(32, 16, texels)).unwrap();
    let text = format!(
        r#"{header}
[[shape]]
type = "rectangle"
to_world = [ {{ scale = 1.5 }}, {{ rotate = {{ axis = [1, 0, 0], angle = -90 }} }} ]
bsdf = {{ type = "diffuse", reflectance = 0.6 }}
[[shape]]
type = "sphere"
center = [0, 0.4, 0]
radius = 0.3
rings = 12
segments = 24
bsdf = {{ type = "dielectric", int_ior = 1.5 }}
[[emitter]]
type = "envmap"
filename = "map.exr"
scale = {scale:e}
"#,
        header = header("[0, 1.1, 2.6]", "[0, 0.2, -0.2]"),
    );
    let scene = Scene::from_toml_str(&text, &dir, std::path::Path::new(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
    std::fs::remove_dir_all(&dir).ok();
    scene
}


/// `s` divided by `k` (a mean and its variance in other units).
fn scaled(s: Stat, k: f64) -> Stat {
    Stat { mean: s.mean / k, var: s.var / (k * k) }
}

/// Environment maps at the edges: a smooth sky at scale 1e-6 and 1e6 renders the scale-1 image times
/// the scale (every estimator; emission, the photon pass and the MIS weights are linear or scale-free in
/// the map's radiance); an all-zero map renders black with every estimator and emits no photon; a single
/// bright texel (a sun) over the glass sphere: mis agrees with pt, pm with mis.
#[test]
fn environment_map_extremes() {
    let sky = |_x: u32, y: u32| glam::Vec3::splat(0.2 + (16 - y) as f32 / 16.0);
    let base = run_scene("env-sky", &env_scene("env-sky", sky, 1.0));
    for k in [1e-6, 1e6] {
        let name = format!("env-sky-{k:e}");
        let runs = run_scene(&name, &env_scene(&name, sky, k));
        for (e, (r, b)) in ["pt", "pm", "mis"].iter().zip(runs.iter().zip(&base)) {
            assert_agrees(&name, &format!("{e}/scale vs the scale-1 {e}"), scaled(r.mean, k), b.mean);
        }
    }

    let zero = run_scene("env-zero", &env_scene("env-zero", |_, _| glam::Vec3::ZERO, 1.0));
    for (e, r) in ["pt", "pm", "mis"].iter().zip(&zero) {
        assert_eq!(r.mean.mean, 0.0, "env-zero: {e} is not black");
        assert_eq!(r.stats.photons_stored, 0, "env-zero: {e} stored photons");
    }

    // The sun: one texel about 40° above the horizon (row 4 of 16), radiance 2e4, nothing else.
    let sun = |x: u32, y: u32| if (x, y) == (8, 4) { glam::Vec3::splat(2e4) } else { glam::Vec3::ZERO };
    let runs = run_scene("env-sun", &env_scene("env-sun", sun, 1.0));
    assert!(runs[0].mean.mean > 0.0, "env-sun: black");
    assert!(runs[1].stats.photons_stored > 100, "env-sun: the sun's photons miss the sphere ({} stored)", runs[1].stats.photons_stored);
    assert_agrees("env-sun", "mis vs pt", runs[2].mean, runs[0].mean);
    assert_agrees("env-sun", "pm vs mis", runs[1].mean, runs[2].mean);
}

/// Degenerate meshes render like the clean mesh: a floor given as an OBJ with zero-area triangles (a
/// repeated vertex, three collinear vertices) and every triangle duplicated has the clean floor's mean
/// with every estimator. (Meshes with no faces and non-finite vertices are refused: `mesh_load`.)
#[test]
fn degenerate_meshes_render_like_clean_ones() {
    let dir = std::env::temp_dir().join(format!("caustica-stress-mesh-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let quad = "v -1.5 0 -1.5\nv 1.5 0 -1.5\nv 1.5 0 1.5\nv -1.5 0 1.5\nv 0 0 0\nv 0.5 0 0.5\n";
    std::fs::write(dir.join("clean.obj"), format!("{quad}f 1 3 2\nf 1 4 3\n")).unwrap();
    std::fs::write(dir.join("degenerate.obj"), format!("{quad}f 1 3 2\nf 1 4 3\nf 1 1 2\nf 5 6 3\nf 1 3 2\nf 1 4 3\nf 2 2 2\n")).unwrap();
    let text = |file: &str| {
        scene(&Params::default()).replacen(
            "type = \"rectangle\"\nto_world = [ { scale = 1.5 }, { rotate = { axis = [1, 0, 0], angle = -90 } }, { scale = 1 }, { translate = [0, 0, 0] } ]",
            &format!("type = \"obj\"\nfilename = \"{file}\""),
            1,
        )
    };
    assert!(text("x").contains("filename = \"x\""), "the template's floor changed");
    let load = |file: &str| Scene::from_toml_str(&text(file), &dir, std::path::Path::new(file)).unwrap_or_else(|e| panic!("{file}: {e}"));
    let (clean, degenerate) = (load("clean.obj"), load("degenerate.obj"));
    std::fs::remove_dir_all(&dir).ok();
    let clean = run_scene("clean-floor", &clean);
    let degenerate = run_scene("degenerate-floor", &degenerate);
    for (e, (d, c)) in ["pt", "pm", "mis"].iter().zip(degenerate.iter().zip(&clean)) {
        assert_agrees("degenerate-floor", &format!("{e} vs the clean floor's {e}"), d.mean, c.mean);
    }
}

/// Crop windows on the film's border (one corner pixel, the last column, the last row, the whole film)
/// render exactly the full film's pixels there, with pt and with mis (photon pass included): a crop only
/// selects pixels (camera.rs), it never changes their samples.
#[test]
fn crop_windows_on_the_border_render_the_full_films_pixels() {
    let (w, h) = (32u32, 24u32);
    for estimator in [Estimator::Pt, Estimator::Mis] {
        let render_crop = |crop: Option<[u32; 4]>| {
            let mut text = scene(&Params::default());
            if let Some([x0, y0, x1, y1]) = crop {
                text = text.replace(&format!("film = {{ width = {w}, height = {h}, "), &format!("film = {{ width = {w}, height = {h}, crop = [{x0}, {y0}, {x1}, {y1}], "));
                assert!(text.contains("crop = ["), "the template's film changed");
            }
            let scene = Scene::from_toml_str(&text, &common::repo_path("tests"), std::path::Path::new("crop")).unwrap();
            let mut settings = RenderSettings::from_scene(&scene);
            settings.estimator = estimator;
            settings.spp = 4;
            render_with_variance(&scene, backend(), &settings).image
        };
        let full = render_crop(None);
        for crop in [[w - 1, h - 1, w, h], [0, 0, 1, 1], [w - 1, 0, w, h], [0, h - 1, w, h], [0, 0, w, h]] {
            let part = render_crop(Some(crop));
            assert_eq!((part.width(), part.height()), (crop[2] - crop[0], crop[3] - crop[1]), "{crop:?}");
            for y in crop[1]..crop[3] {
                for x in crop[0]..crop[2] {
                    assert_eq!(part.get(x - crop[0], y - crop[1]), full.get(x, y), "{estimator:?} crop {crop:?}: pixel ({x}, {y})");
                }
            }
        }
    }
}

/// Two lights over a floor (half side `floor_half`) and a glass sphere: first in the scene (so first in the
/// light selection's CDF, where f64 keeps its tiny share) a square light of half side `dim_half` and
/// radiance `dim` 0.8 above the origin, then a square light of half side `half` at the origin with power
/// π (radiance 1/(4·half²)), both facing down.
fn two_lights_scene(name: &str, half: f64, dim: f64, dim_half: f64, floor_half: f64) -> Scene {
    let text = format!(
        r#"{header}
[[shape]]
type = "rectangle"
to_world = [ {{ scale = [{dim_half:e}, {dim_half:e}, 1] }}, {{ rotate = {{ axis = [1, 0, 0], angle = 90 }} }}, {{ translate = [0, 0.8, 0] }} ]
bsdf = {{ type = "diffuse", reflectance = 0 }}
emitter = {{ type = "area", radiance = {dim:e} }}
[[shape]]
type = "rectangle"
to_world = [ {{ scale = [{half:e}, {half:e}, 1] }}, {{ rotate = {{ axis = [1, 0, 0], angle = 90 }} }} ]
bsdf = {{ type = "diffuse", reflectance = 0 }}
emitter = {{ type = "area", radiance = {radiance:e} }}
[[shape]]
type = "rectangle"
to_world = [ {{ scale = {floor_half:e} }}, {{ rotate = {{ axis = [1, 0, 0], angle = -90 }} }}, {{ translate = [0, -1.2, 0] }} ]
bsdf = {{ type = "diffuse", reflectance = 0.6 }}
[[shape]]
type = "sphere"
center = [0, -0.8, 0]
radius = 0.3
rings = 12
segments = 24
bsdf = {{ type = "dielectric", int_ior = 1.5 }}
"#,
        header = header("[0, -0.1, 2.6]", "[0, -1.0, -0.2]"),
        radiance = 0.25 / (half * half),
    );
    Scene::from_toml_str(&text, &common::repo_path("tests"), std::path::Path::new(name)).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// q₁ across 10⁻³⁰ … 10³⁰ through real renders (issue 13 §3), read from the renders' `mis_q1_range`:
/// - **q₁ ≥ 10³⁰**: the photons of a light of half side 10⁻¹⁷ (`p_emit` = `1/A`·… ≈ 10³³); its caustic
///   through the glass sphere is the same as that of a light of half side 10⁻⁶ with the same power, in
///   `pm` and `mis` (pt cannot reach such a light through glass), and `mis` agrees with `pm` (w₁ → 1);
/// - **q₁ ≤ 10⁻³⁰**: T2's paths to the large light of radiance 10⁻³⁰, whose selection probability (and so
///   `p_emit`) is ~10⁻³¹ (w₂ → 1).
/// Regression for two bugs this case found: a light of side ≲ 10⁻¹⁰ was dropped as zero-area (|e₁×e₂|²
/// underflowed f32; `math::triangle_normal_area`), and Embree 3 reported the emitting triangle itself at
/// t = −0 to every photon leaving a 10⁻⁹ light, so no photon was stored (`EmissionSample::t_min`).
#[test]
fn q1_extremes_through_real_renders() {
    let dim = 1e-30;
    let small = run_scene("two-lights-1e-6", &two_lights_scene("two-lights-1e-6", 1e-6, dim, 1.5, 1.5));
    let tiny = run_scene("two-lights-1e-17", &two_lights_scene("two-lights-1e-17", 1e-17, dim, 1.5, 1.5));
    let name = "two-lights";
    for (what, a, b) in [("pm", &small[1], &tiny[1]), ("mis", &small[2], &tiny[2])] {
        assert!(a.stats.photons_stored > 1000 && b.stats.photons_stored == a.stats.photons_stored, "{name} {what}: photons stored {} vs {}", b.stats.photons_stored, a.stats.photons_stored);
        let rel = (b.mean.mean / a.mean.mean - 1.0).abs();
        assert!(rel < 1e-3, "{name} {what}: the 1e-17 light's image mean {:.6e} vs the 1e-6 light's {:.6e}", b.mean.mean, a.mean.mean);
    }
    assert!(tiny[1].mean.mean > 1.1 * tiny[0].mean.mean, "{name}: no caustic in pm ({:.4e}) over pt ({:.4e})", tiny[1].mean.mean, tiny[0].mean.mean);
    assert_agrees(name, "mis vs pm", tiny[2].mean, tiny[1].mean);
    let [lo, hi] = tiny[2].stats.mis_q1_range.expect("mis records q₁");
    eprintln!("{name}: q₁ from {lo:.3e} to {hi:.3e}");
    assert!(lo <= 1e-30 && hi >= 1e30, "{name}: q₁ spans only {lo:.3e} … {hi:.3e}");
    assert!(tiny[1].stats.mis_q1_range.is_none() && tiny[0].stats.mis_q1_range.is_none(), "q₁ is recorded for mis only");
}

/// Parts of a scene far larger than its caustics must not blur them away: a ground plane of half side 10⁴
/// and a dim light of half side 10³ beside a 3-unit scene. The floor of ΔA followed the scene's radius
/// (`caustic::min_delta_area`), and pm/mis were 17% dark with the big plane, 21% with the big light; it
/// now follows the photons' extent, and black surfaces (the lights) store no photon. That extent is set by
/// the farthest photon: with stratified photons one landed 470 units out on the big plane, the floor grew
/// to (0.014)² and the caustic was 42% dark; the floor is now also bounded by the precision of positions at
/// the query point (`min_delta_area`'s `4ε·‖x‖∞` term). pm and mis must agree
/// with the small scene's (same photons, same caustic) and with pt, which finds the light (half side
/// 0.05) through the glass.
#[test]
fn huge_plane_or_light_keeps_the_caustic() {
    let small = run_scene("small", &two_lights_scene("small", 0.05, 1e-30, 1.5, 1.5));
    for (name, dim_half, floor_half) in [("huge-plane", 1.5, 1e4), ("huge-dim-light", 1e3, 1.5)] {
        let runs = run_scene(name, &two_lights_scene(name, 0.05, 1e-30, dim_half, floor_half));
        assert_agrees(name, "pm vs pt", runs[1].mean, runs[0].mean);
        assert_agrees(name, "mis vs pt", runs[2].mean, runs[0].mean);
        for (what, a, b) in [("pm", &runs[1], &small[1]), ("mis", &runs[2], &small[2])] {
            let rel = (a.mean.mean / b.mean.mean - 1.0).abs();
            assert!(rel < 0.05, "{name}: {what} mean {:.5e} vs the small scene's {:.5e}", a.mean.mean, b.mean.mean);
        }
    }
}

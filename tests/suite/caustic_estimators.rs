//! The paper's effect (method.md §4, "expected behaviour") on the two scenes of `tests/data/`, against
//! their committed `pt` references (8,192 spp, seed 1; made by `scripts/make-test-references`, see
//! `tests/data/README.md`).
//!
//! - `glossy-mirror`: a mirror throws a 0.5 × 0.5 light onto a floor that is 90 % GGX (α = 0.06); the
//!   camera sees the light's mirror image in the glossy floor (L-S-G-E). There q₂ ≫ q₁, so `mis` hands
//!   those paths to BSDF sampling and loses the photon map's blotches: its RMSE is far below `pm`'s.
//! - `mirror-ceiling`: a mirror ceiling throws the light onto diffuse walls and floor only (L-S-D-E).
//!   There q₂ = cos/π ≪ q₁, so `mis` is `pm` up to tiny weights.
//!
//! All renders use the scene files' settings (32 resp. 16 spp, 100,000 photons, k = 20 resp. 50) with
//! seed 3; each image is rendered once and shared by the tests (they run on the test harness's threads,
//! the renders on rayon's pool).
//!
//! Measured with the CLI for seeds 2, 3, 4 (whole-image RMSE against the reference, ratio = mean over the
//! caustic region / the reference's):
//!
//! | scene | estimator | RMSE (s = 2, 3, 4) | region mean ratio (s = 2, 3, 4) |
//! |---|---|---|---|
//! | glossy-mirror | pt  | 0.328, 0.323, 0.328 | 1.009, 0.990, 0.994 |
//! | glossy-mirror | pm  | 0.514, 0.434, 0.443 | 1.159, 1.049, 0.981 |
//! | glossy-mirror | mis | 0.253, 0.234, 0.243 | 1.054, 1.008, 0.966 |
//! | mirror-ceiling | pt  | 0.216, 0.209 (s = 2, 3) | 0.993, 0.990 |
//! | mirror-ceiling | pm  | 0.0800, 0.0720 | 1.004, 1.020 |
//! | mirror-ceiling | mis | 0.0800, 0.0720 | 1.004, 1.020 |
//!
//! (An earlier, lost version of this test measured mis 1.77 vs pm 5.89 on another scene.)

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use caustica::accel::BackendKind;
use caustica::film::{read_exr, Image};
use caustica::photon::PhotonBudget;
use caustica::render::{render_image, RenderSettings, RenderedImage};
use caustica::report::metrics::{region_metrics, Metrics, Region};
use caustica::scene::{Estimator, Scene};

const SEED: u64 = 3;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

struct SceneRenders {
    reference: Image,
    pt: RenderedImage,
    pm: RenderedImage,
    mis: RenderedImage,
}

fn render_all(name: &str) -> SceneRenders {
    let scene = Scene::load(&data(&format!("{name}.toml"))).expect("test scene loads");
    let reference = read_exr(data(&format!("{name}-ref.exr"))).expect("reference image");
    let render = |estimator| {
        let mut s = RenderSettings::from_scene(&scene);
        s.seed = SEED;
        s.estimator = estimator;
        let r = render_image(&scene, BackendKind::Embree, &s).expect("render");
        eprintln!("{name} {estimator:?}: {:.2} s, {} photons emitted, {} stored", r.seconds, r.stats.photons_emitted, r.stats.photons_stored);
        r
    };
    SceneRenders { reference, pt: render(Estimator::Pt), pm: render(Estimator::Pm), mis: render(Estimator::Mis) }
}

fn glossy() -> &'static SceneRenders {
    static R: OnceLock<SceneRenders> = OnceLock::new();
    R.get_or_init(|| render_all("glossy-mirror"))
}

fn diffuse() -> &'static SceneRenders {
    static R: OnceLock<SceneRenders> = OnceLock::new();
    R.get_or_init(|| render_all("mirror-ceiling"))
}

fn metrics(image: &Image, reference: &Image, region: &Region) -> Metrics {
    let m = region_metrics(image, reference, region, 16).expect("metrics");
    assert_eq!(m.nan_count + m.inf_count, 0, "non-finite pixels");
    m
}

fn whole(img: &Image) -> Region {
    Region::whole(img.width(), img.height())
}

/// On the glossy receiver `mis` beats `pm` clearly at the same photon count (the same photon map: same
/// seed and pass). Measured mis/pm RMSE ratio over seeds 2, 3, 4: 0.49, 0.54, 0.55 (another scene
/// variant with seeds 5, 6: 0.59, 0.45); bound 0.7, i.e. ≈ 3 spreads (σ ≈ 0.05) above the mean 0.52.
/// `mis` is also better than plain `pt` at the same spp (0.72–0.74 of pt's RMSE), and the photon pass
/// ran in both photon estimators with the same N.
#[test]
fn glossy_mirror_mis_beats_pm() {
    let r = glossy();
    let region = whole(&r.reference);
    let pm = metrics(&r.pm.image, &r.reference, &region);
    let mis = metrics(&r.mis.image, &r.reference, &region);
    let pt = metrics(&r.pt.image, &r.reference, &region);
    eprintln!("glossy-mirror RMSE: pt {:.4}, pm {:.4}, mis {:.4} (mis/pm {:.3})", pt.rmse, pm.rmse, mis.rmse, mis.rmse / pm.rmse);
    assert_eq!(r.pm.stats.photons_emitted, 100_000);
    assert_eq!(r.mis.stats.photons_emitted, 100_000);
    assert_eq!(r.pm.stats.photons_stored, r.mis.stats.photons_stored, "same photon map");
    assert_eq!(r.pt.stats.photons_emitted, 0);
    assert!(mis.rmse < 0.7 * pm.rmse, "mis RMSE {} not clearly below pm's {}", mis.rmse, pm.rmse);
    assert!(mis.rmse < pt.rmse, "mis RMSE {} not below pt's {}", mis.rmse, pt.rmse);
}

/// On diffuse receivers `mis` ≈ `pm`: q₂ = cos/π ≈ 0.3 against q₁ ≈ k/(α·Ω) ≫ 1, so w₁ ≈ 1. Measured
/// RMSE(mis, pm) = 5.4·10⁻⁶ and 5.5·10⁻⁶ (seeds 2, 3) against RMSE(pm, reference) = 0.080 and 0.072,
/// a ratio of 7·10⁻⁵, before the roulette on the density estimate (method.md §3.1): its probability follows
/// the radiance a sample has collected, which the weights change a little, so a few coins fall differently
/// in the two renders — measured 3.1·10⁻⁴ against pm's 0.0278 (1.1 %) with κ = 1; 1.16·10⁻³ against 0.0292
/// (4.0 %) with κ = 2 and the floor P_min = 0.03, which put more vertices below P = 1 (the RMSEs: 0.02917 and
/// 0.02917). That difference is the coins' noise, zero in the mean. Bounds: the images differ by < 6 % of
/// pm's error (a weight that left 1 on these receivers would hand whole caustics to T2, whose paths through
/// the mirror to the small light are far noisier), and the two RMSEs by < 1 %.
#[test]
fn mirror_ceiling_mis_equals_pm() {
    let r = diffuse();
    let region = whole(&r.reference);
    let pm = metrics(&r.pm.image, &r.reference, &region);
    let mis = metrics(&r.mis.image, &r.reference, &region);
    let between = metrics(&r.mis.image, &r.pm.image, &region);
    eprintln!("mirror-ceiling RMSE: pm {:.5}, mis {:.5}, mis vs pm {:.3e}", pm.rmse, mis.rmse, between.rmse);
    assert!(r.mis.stats.photons_stored > 10_000, "too few caustic photons: {}", r.mis.stats.photons_stored);
    assert!(between.rmse < 0.06 * pm.rmse, "mis differs from pm: {} vs pm's error {}", between.rmse, pm.rmse);
    assert!(((mis.rmse - pm.rmse) / pm.rmse).abs() < 0.01, "RMSE mis {} vs pm {}", mis.rmse, pm.rmse);
    // Not trivially equal: T2 does contribute a little in mis.
    assert!(between.rmse > 0.0, "mis and pm images are bit-identical: the MIS weights never left 1");
}

/// Mean over a caustic region / the reference's, luminance.
fn region_ratio(img: &Image, reference: &Image, region: &Region) -> f64 {
    metrics(img, reference, region).luminance_ratio
}

/// All three estimators agree with the reference mean in the caustic region, within their noise plus
/// `pm`'s kernel bias. Bounds from the seed-to-seed spread of the ratio (table in the module doc; σ over
/// seeds 2–4) at ≈ 3σ:
///
/// - glossy-mirror, region = the highlight (x 40–60 %, y 50–90 %): pt σ ≈ 0.01 → ±0.04; mis σ ≈ 0.044 →
///   ±0.13; pm σ ≈ 0.09 → ±0.27. pm's kernel bias is not resolvable here (mean of three seeds 1.063,
///   within its σ/√3 = 0.05 of 1 by 1.2 σ); it is dominated by the photon blotches.
/// - mirror-ceiling, region = the floor in front (x 30–70 %, y 70–100 %): pt ±0.09: σ = 0.030 over seeds
///   2–45 (the CLI's region bias, 16 spp; mean +0.6 %, within σ/√44 of 0), for the same code with the
///   sampler's dimensions in another order σ = 0.032 (mean +0.2 %): pt finds this caustic only through the
///   mirror to the small light, and a bound of ±0.03 had held for seed 3 by luck; pm and mis ±0.05:
///   measured +0.4 % and +2.0 % (red channel, seeds 2, 3;
///   luminance +1.8 % for seed 3), i.e. a kernel bias of ≈ +1 % (k = 50 neighbours over a smoothly
///   varying caustic) plus noise.
#[test]
fn caustic_region_means_agree_with_the_reference() {
    for (r, name, spec, tol) in [
        (glossy(), "glossy-mirror", "highlight=40%,50%,60%,90%", [0.04, 0.27, 0.13]),
        (diffuse(), "mirror-ceiling", "floor=30%,70%,70%,100%", [0.09, 0.05, 0.05]),
    ] {
        let region = Region::parse(spec, r.reference.width(), r.reference.height()).unwrap();
        for ((img, est), tol) in [(&r.pt.image, "pt"), (&r.pm.image, "pm"), (&r.mis.image, "mis")].into_iter().zip(tol) {
            let ratio = region_ratio(img, &r.reference, &region);
            eprintln!("{name} {est}: region mean / reference = {ratio:.4} (bound ±{tol})");
            assert!((ratio - 1.0).abs() < tol, "{name} {est}: region mean ratio {ratio} outside 1 ± {tol}");
        }
    }
}

/// A scene without any delta BSDF has no caustic path: no photon pass runs whatever the estimator, the
/// skipped phase is reported with its reason, and `pm`/`mis` render exactly what `pt` renders.
#[test]
fn no_delta_bsdf_means_no_photon_pass() {
    let text = r#"
[integrator]
samples_per_pixel = 4
[integrator.caustics]
photons = 50000
[sensor]
fov = 40
to_world = { look_at = { origin = [0, 1, 4], target = [0, 0, 0], up = [0, 1, 0] } }
film = { width = 24, height = 16, rfilter = { type = "box" } }
[[shape]]
type = "rectangle"
to_world = [ { scale = 2 }, { rotate = { axis = [1, 0, 0], angle = -90 } } ]
bsdf = { type = "blendbsdf", weight = 0.5, bsdf_0 = { type = "diffuse", reflectance = 0.5 }, bsdf_1 = { type = "roughconductor", distribution = "ggx", alpha = 0.1 } }
[[shape]]
type = "sphere"
center = [0, 0.5, 0]
radius = 0.4
bsdf = { type = "roughconductor", alpha = 0.05 }
[[shape]]
type = "rectangle"
to_world = [ { scale = 0.3 }, { rotate = { axis = [1, 0, 0], angle = 90 } }, { translate = [0, 2, 0] } ]
emitter = { type = "area", radiance = 5 }
"#;
    let scene = Scene::from_toml_str(text, Path::new("."), Path::new("no-delta.toml")).unwrap();
    assert!(!scene.has_delta_bsdf());
    let mut images = Vec::new();
    for est in [Estimator::Pt, Estimator::Pm, Estimator::Mis] {
        for budget in [PhotonBudget::Emitted(50_000), PhotonBudget::Stored(1_000)] {
            let mut s = RenderSettings::from_scene(&scene);
            s.estimator = est;
            s.photons = budget;
            let r = render_image(&scene, BackendKind::Embree, &s).unwrap();
            assert_eq!(r.stats.photons_emitted, 0, "{est:?}");
            assert_eq!(r.stats.photons_stored, 0, "{est:?}");
            assert_eq!(r.stats.knn_queries, 0, "{est:?}: density queries without a photon map");
            let skipped = r.stats.skipped.iter().find(|p| p.phase == "caustic photon pass").unwrap_or_else(|| panic!("{est:?}: photon pass not reported as skipped: {:?}", r.stats.skipped));
            let want = if est == Estimator::Pt { "estimator pt" } else { "no delta surface" };
            assert!(skipped.reason.contains(want), "{est:?}: reason {:?}", skipped.reason);
            images.push(r.image);
        }
    }
    for img in &images[1..] {
        assert_eq!(img.pixels(), images[0].pixels(), "without caustic paths every estimator renders the pt image");
    }
    assert!(images[0].mean_luminance() > 0.0);
}

/// A caustic seen through frosted glass (method.md §1.1): a smooth glass sphere focuses a small light onto
/// the back of a rough glass screen (GGX, α 0.1) that faces the camera. The eye path's first vertex is the
/// screen seen from the front, its BSDF sample crosses the screen and reaches the light through the sphere:
/// a caustic path `L S S x` whose photons arrive on the other side of x than ωₒ, which the gather never
/// takes. T2 must take those paths whole (`w₂ = 1`), in `pm` as in `mis`. Before that rule `pm` dropped them
/// and `mis` weighted them against photons it never used: both rendered 2 % of `pt`'s image.
#[test]
fn a_caustic_through_frosted_glass_is_not_lost() {
    let text = r#"
[integrator]
samples_per_pixel = 128
[integrator.caustics]
photons = 100000
[sensor]
fov = 40
to_world = { look_at = { origin = [0, 0, 3], target = [0, 0, 0], up = [0, 1, 0] } }
film = { width = 48, height = 32, rfilter = { type = "box" } }
[[shape]]
type = "rectangle"
bsdf = { type = "roughdielectric", distribution = "ggx", alpha = 0.1 }
[[shape]]
type = "sphere"
center = [0, 0, -0.8]
radius = 0.3
bsdf = { type = "dielectric" }
[[shape]]
type = "rectangle"
to_world = [ { scale = 0.1 }, { translate = [0, 0, -2.2] } ]
emitter = { type = "area", radiance = 100 }
"#;
    let scene = crate::common::scene_from_toml("frosted.toml", text);
    let render = |estimator| {
        let mut s = RenderSettings::from_scene(&scene);
        s.estimator = estimator;
        s.seed = SEED;
        crate::common::render_with_variance(&scene, crate::common::backend(), &s)
    };
    let pt = render(Estimator::Pt);
    let pt_mean = pt.lum.whole();
    assert!(pt_mean.mean > 0.0);
    for est in [Estimator::Pm, Estimator::Mis] {
        let r = render(est);
        let m = r.lum.whole();
        let z = crate::common::z(m, pt_mean);
        assert!(
            (m.mean / pt_mean.mean - 1.0).abs() < 0.02 + 4.0 * (m.var + pt_mean.var).sqrt() / pt_mean.mean,
            "{est:?}: mean {} against pt's {} (z = {z:.2})",
            m.mean,
            pt_mean.mean
        );
    }
}

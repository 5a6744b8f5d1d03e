//! `max_depth` and the caustic photon map (method.md §2.1). A photon of m delta bounces gathered at an eye
//! vertex of depth d makes a path of d + m + 1 segments; Mitsuba's `max_depth` counts segments, and the
//! path tracer makes no longer path, so the density estimate must not either. Before the rule, `pm` and
//! `mis` counted every photon and rendered paths `pt` (and Mitsuba) leave out: +2.6–3.5 % on the whole of
//! the stokes Cornell box (max_depth 6) against Mitsuba, where `pt` matched.
//!
//! Scene `tests/data/depth-limit.toml`: the cornell-caustics box at 32 × 32. Measured with the CLI at this
//! test's 256 spp (luminance, seeds 1, 2, 3; `pt` 0.2415, 0.2413, 0.2420 over the whole image at max_depth
//! 3, and 0.1152, 0.1187, 0.1195 on the floor under the glass sphere):
//!
//! | max_depth | estimator | whole image, before → after | floor under the glass sphere, before → after |
//! |---|---|---|---|
//! | 3 | pm  | 0.2512, 0.2509, 0.2509 → 0.2422, 0.2419, 0.2420 | 0.1616, 0.1619, 0.1612 → 0.1180, 0.1182, 0.1178 |
//! | 3 | mis | 0.2507, 0.2504, 0.2504 → 0.2422, 0.2419, 0.2420 | 0.1578, 0.1582, 0.1577 → 0.1180, 0.1182, 0.1178 |
//! | 4 | pt  | 0.2697, 0.2694, 0.2703 | 0.1733, 0.1732, 0.1791 |
//! | 4 | pm  | 0.2750, 0.2748, 0.2748 → 0.2703, 0.2702, 0.2702 | 0.1847, 0.1851, 0.1849 → 0.1777, 0.1779, 0.1777 |
//! | 4 | mis | 0.2749, 0.2747, 0.2748 → 0.2703, 0.2701, 0.2702 | 0.1846, 0.1847, 0.1846 → 0.1777, 0.1775, 0.1773 |
//!
//! At max_depth 3 the glass sphere's caustic (m = 2) needs 4 segments seen directly: `pt` has none of it,
//! `pm` had it all (1.40× on that floor).
//!
//! Bounds: |z| < 4 for the mean luminance of `pm` and `mis` against `pt`, over the whole image and over the
//! floor under the glass sphere (x 16..32, y 24..32), σ from the per-pixel sample variances of both
//! renders plus a photon-map term for `pm`/`mis` (its noise is shared by all pixels, so the pixel
//! variances do not see it): 0.5 % of the whole image's mean, 2 % of the region's (the three seeds above
//! spread 0.1 % and 0.3 %).

use crate::common;

use caustica::accel::build_accel;
use caustica::photon::{longest_chain, trace_photons, PhotonBudget, MAX_DELTA_CHAIN};
use caustica::render::{photon_pass_needed, RenderSettings};
use caustica::scene::{Estimator, Scene};
use common::{backend, render_with_variance, repo_path, Stat};

const SPP: u32 = 256;

fn scene(max_depth: i32) -> Scene {
    let mut scene = Scene::load(&repo_path("tests/data/depth-limit.toml")).expect("scene loads");
    scene.integrator.max_depth = max_depth;
    scene
}

fn render(scene: &Scene, estimator: Estimator) -> common::Rendered {
    let mut s = RenderSettings::from_scene(scene);
    s.seed = 1;
    s.spp = SPP;
    s.estimator = estimator;
    render_with_variance(scene, backend(), &s)
}

#[test]
fn pm_and_mis_match_pt_under_a_depth_limit() {
    for max_depth in [3, 4] {
        let scene = scene(max_depth);
        let pt = render(&scene, Estimator::Pt).lum;
        for est in [Estimator::Pm, Estimator::Mis] {
            let r = render(&scene, est).lum;
            for (what, m, p, photon_rel) in [
                ("whole image", r.whole(), pt.whole(), 0.005),
                ("floor under the glass sphere", r.region(16, 24, 32, 32), pt.region(16, 24, 32, 32), 0.02),
            ] {
                let photon_noise = photon_rel * m.mean;
                let z = common::z(Stat { mean: m.mean, var: m.var + photon_noise * photon_noise }, p);
                eprintln!("max_depth {max_depth}, {est:?}, {what}: {:.4} vs pt {:.4} (ratio {:.4}, z = {z:+.2})", m.mean, p.mean, m.mean / p.mean);
                assert!(z.abs() < 4.0, "max_depth {max_depth}, {est:?}, {what}: mean {} vs pt {} (z = {z})", m.mean, p.mean);
            }
        }
    }
}

/// The photon pass traces no chain that fits at no eye depth (the longest at depth 1), and a chain cut by
/// max_depth is not counted as capped (no technique makes its paths); below 3 segments there is no pass.
#[test]
fn the_photon_pass_stores_only_chains_that_fit() {
    for (max_depth, longest) in [(-1, MAX_DELTA_CHAIN), (4, 2), (3, 1)] {
        let scene = scene(max_depth);
        assert_eq!(longest_chain(1, scene.integrator.max_segments()), longest);
        let accel = build_accel(backend(), &scene.geometry()).expect("accel");
        let (map, stats) = trace_photons(&scene, accel.as_ref(), PhotonBudget::Emitted(100_000), 1, 0, &|| false).expect("photon pass");
        let chains: Vec<u32> = map.tree().decoded().iter().map(|d| u32::from(d.chain)).collect();
        let (shortest, longest_stored) = (chains.iter().min().copied(), chains.iter().max().copied());
        eprintln!("max_depth {max_depth}: {} photons stored, chains {shortest:?} ..= {longest_stored:?}, {} capped", chains.len(), stats.chains_capped);
        assert_eq!(shortest, Some(1), "max_depth {max_depth}: the mirror's one-bounce photons");
        // The glass sphere's photons (2 bounces) where they fit; none longer than fits.
        assert_eq!(longest_stored.map(|m| m >= 2), Some(longest >= 2), "max_depth {max_depth}");
        assert!(longest_stored <= Some(longest), "max_depth {max_depth}: a chain of {longest_stored:?}");
        if max_depth > 0 {
            assert_eq!(stats.chains_capped, 0, "max_depth {max_depth}: chains cut by max_depth are no cap");
        }
    }
    let err = photon_pass_needed(&scene(2), Estimator::Mis).expect_err("max_depth 2 has no caustic path");
    assert!(err.contains("max_depth 2"), "{err}");
    assert!(photon_pass_needed(&scene(3), Estimator::Mis).is_ok());
}

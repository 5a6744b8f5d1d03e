//! The caustic photon pass against an analytic answer (method.md §2).
//!
//! Scene: a small one-sided square area light of radiance `Le` faces a large perfect mirror (`conductor`,
//! no Fresnel) lying in the plane y = 0; the mirror reflects it onto a 1 × 1 diffuse receiver. A photon is
//! stored only at the first non-delta hit after ≥ 1 delta bounce, so the photons on the receiver are
//! exactly the light that reached it *via the mirror* (photons hitting the receiver directly are no
//! caustic photons and are dropped). By the mirror's symmetry, that power equals the power the receiver
//! gets from the mirror image of the light (the light reflected through y = 0), with nothing in between:
//!
//! `Φ_R = Le · ∫_{A_L'} ∫_{A_R} cos θ_L' · cos θ_R / d² dA dA`,
//!
//! computed here by a deterministic midpoint quadrature in f64 (its own error is bounded in the test by
//! comparing two grid sizes: < 10⁻⁴ relative, far below the Monte Carlo noise of ~1 %). The geometry is
//! chosen so that every segment from the image light to the receiver crosses y = 0 inside the mirror and
//! passes nowhere near the real light (both asserted), so no occlusion term is needed.
//!
//! Every emitted photon carries the same power `π·A·Le/N` (cosine-weighted emission from a uniform point),
//! so the sum over the receiver is a scaled binomial; the test's σ is the sample standard deviation of that
//! sum computed from the per-photon powers over all N emitted photons (the non-stored ones count as 0).

use std::path::Path;

use caustica::accel::{build_accel, BackendKind};
use caustica::light::Light;
use caustica::math::Vec3;
use caustica::photon::{trace_photons, Photon, PhotonBudget, PhotonMap, PhotonPassStats};
use caustica::scene::Scene;

/// Radiance of the light (white).
const LE: f64 = 10.0;
/// Half edge of the light square.
const LIGHT_HALF: f64 = 0.1;
/// Half edge of the receiver square.
const RECV_HALF: f64 = 0.5;
/// Half edge of the mirror square (y = 0).
const MIRROR_HALF: f64 = 5.0;
const LIGHT_CENTER: [f64; 3] = [-1.0, 1.0, 0.0];
const RECV_CENTER: [f64; 3] = [1.5, 1.5, 0.0];

fn scene_toml() -> String {
    format!(
        r#"
[sensor]
fov = 40
to_world = {{ look_at = {{ origin = [0, 3, 6], target = [0, 0, 0], up = [0, 1, 0] }} }}
film = {{ width = 16, height = 12, rfilter = {{ type = "box" }} }}

[[shape]]   # mirror: y = 0, facing +y
type = "rectangle"
to_world = [ {{ scale = {m} }}, {{ rotate = {{ axis = [1, 0, 0], angle = -90 }} }} ]
bsdf = {{ type = "conductor", specular_reflectance = 1 }}

[[shape]]   # light: faces the origin (local +z = look_at direction)
type = "rectangle"
to_world = [ {{ scale = [{l}, {l}, 1] }}, {{ look_at = {{ origin = [{lx}, {ly}, {lz}], target = [0, 0, 0], up = [0, 0, 1] }} }} ]
bsdf = {{ type = "diffuse", reflectance = 0 }}
emitter = {{ type = "area", radiance = {le} }}

[[shape]]   # receiver: faces the origin
type = "rectangle"
to_world = [ {{ scale = [{r}, {r}, 1] }}, {{ look_at = {{ origin = [{rx}, {ry}, {rz}], target = [0, 0, 0], up = [0, 0, 1] }} }} ]
bsdf = {{ type = "diffuse", reflectance = 0.5 }}
"#,
        m = MIRROR_HALF,
        l = LIGHT_HALF,
        lx = LIGHT_CENTER[0],
        ly = LIGHT_CENTER[1],
        lz = LIGHT_CENTER[2],
        le = LE,
        r = RECV_HALF,
        rx = RECV_CENTER[0],
        ry = RECV_CENTER[1],
        rz = RECV_CENTER[2],
    )
}

fn load_scene() -> Scene {
    Scene::from_toml_str(&scene_toml(), Path::new("."), Path::new("photon_emission.toml")).expect("test scene loads")
}

/// A square in 3-D: center, unit normal, two unit edge directions, half edge.
#[derive(Clone, Copy)]
struct Square {
    c: [f64; 3],
    n: [f64; 3],
    u: [f64; 3],
    v: [f64; 3],
    half: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn axpy(a: f64, x: [f64; 3], y: [f64; 3]) -> [f64; 3] {
    [a * x[0] + y[0], a * x[1] + y[1], a * x[2] + y[2]]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The square of a `rectangle` with `look_at { origin: center, target: 0, up: +z }` (Mitsuba's frame:
/// normal = toward the target, first edge = up × dir).
fn facing_origin(center: [f64; 3], half: f64) -> Square {
    let n = normalize(sub([0.0; 3], center));
    let u = normalize(cross([0.0, 0.0, 1.0], n));
    let v = cross(n, u);
    Square { c: center, n, u, v, half }
}

/// Mirror image through y = 0.
fn mirrored(s: Square) -> Square {
    let m = |a: [f64; 3]| [a[0], -a[1], a[2]];
    Square { c: m(s.c), n: m(s.n), u: m(s.u), v: m(s.v), half: s.half }
}

/// Midpoint rule, `nl × nl` cells on the (image) light and `nr × nr` on the receiver: the power (luminance
/// units) arriving on the receiver from the image light. Asserts the no-occlusion assumptions on the way.
fn analytic_power(image: Square, recv: Square, light: Square, nl: usize, nr: usize) -> f64 {
    let cell = |s: Square, n: usize, i: usize, j: usize| {
        let a = s.half * (2.0 * (i as f64 + 0.5) / n as f64 - 1.0);
        let b = s.half * (2.0 * (j as f64 + 0.5) / n as f64 - 1.0);
        axpy(b, s.v, axpy(a, s.u, s.c))
    };
    let (da_l, da_r) = ((2.0 * image.half / nl as f64).powi(2), (2.0 * recv.half / nr as f64).powi(2));
    let mut sum = 0.0;
    for il in 0..nl {
        for jl in 0..nl {
            let pl = cell(image, nl, il, jl);
            for ir in 0..nr {
                for jr in 0..nr {
                    let pr = cell(recv, nr, ir, jr);
                    let d = sub(pr, pl);
                    let d2 = dot(d, d);
                    let w = [d[0] / d2.sqrt(), d[1] / d2.sqrt(), d[2] / d2.sqrt()];
                    let (cl, cr) = (dot(image.n, w), -dot(recv.n, w));
                    assert!(cl > 0.0 && cr > 0.0, "receiver must face the image light");
                    // Crossing of y = 0 inside the mirror, and the real light far from the reflected ray:
                    // the segment mirror → receiver lies at y ≥ 0; its closest approach to the light center
                    // must exceed the light's circumradius.
                    let t = -pl[1] / d[1];
                    let x = axpy(t, d, pl);
                    assert!(x[0].abs() < MIRROR_HALF && x[2].abs() < MIRROR_HALF, "reflection point off the mirror");
                    let seg = sub(pr, x);
                    let s = (dot(sub(light.c, x), seg) / dot(seg, seg)).clamp(0.0, 1.0);
                    let q = sub(axpy(s, seg, x), light.c);
                    assert!(dot(q, q).sqrt() > light.half * 2f64.sqrt(), "the light may occlude the reflected beam");
                    sum += cl * cr / d2 * da_l * da_r;
                }
            }
        }
    }
    LE * sum
}

/// The stored photons sorted into a canonical order (the kd-tree reorders them).
fn sorted_photons(map: &PhotonMap) -> Vec<Photon> {
    let mut v = map.tree().photons().to_vec();
    v.sort_by_key(key_of);
    v
}

fn trace(scene: &Scene, budget: PhotonBudget, seed: u64, pass: u64) -> (PhotonMap, PhotonPassStats) {
    let accel = build_accel(BackendKind::Embree, &scene.geometry()).expect("embree");
    trace_photons(scene, accel.as_ref(), budget, seed, pass, &|| false).expect("photon pass")
}

fn dist_to_plane(p: Vec3, s: Square) -> f64 {
    dot(sub([f64::from(p.x), f64::from(p.y), f64::from(p.z)], s.c), s.n).abs()
}

/// The receiver's photon power against the analytic mirror-image power.
///
/// Bound: |z| < 3.5, z = (Σ power − Φ_R)/σ_Σ with σ_Σ from the per-photon powers (see the module doc).
/// For a correct photon pass z is standard normal (K ≈ 4,800 receiver photons out of N = 200,000, so the
/// binomial is well inside its normal regime); the run is deterministic (fixed seed), measured z = +0.073
/// for seed 7 (4,961 receiver photons, σ = 1.40 % of Φ_R) (the earlier lost version of this test measured +0.87σ with another seed). A bias of
/// 5 % (≈ 3.5 σ at this N) fails.
#[test]
fn mirror_reflected_power_matches_the_image_light() {
    let scene = load_scene();
    let light = facing_origin(LIGHT_CENTER, LIGHT_HALF);
    let recv = facing_origin(RECV_CENTER, RECV_HALF);
    let image = mirrored(light);

    // The scene's light is the square assumed here.
    let lights = scene.lights.lights();
    assert_eq!(lights.len(), 1);
    let Light::Area(area) = &lights[0] else { panic!("expected an area light") };
    let a_light = (2.0 * LIGHT_HALF).powi(2);
    assert!((f64::from(area.area()) - a_light).abs() < 1e-6 * a_light, "light area {}", area.area());

    let fine = analytic_power(image, recv, light, 8, 64);
    let coarse = analytic_power(image, recv, light, 4, 32);
    assert!(((fine - coarse) / fine).abs() < 1e-4, "quadrature not converged: {fine} vs {coarse}");

    let n: u64 = 200_000;
    let (map, stats) = trace(&scene, PhotonBudget::Emitted(n), 7, 0);
    assert_eq!(stats.emitted, n, "emitted count reported");
    assert_eq!(map.emitted(), n);
    assert_eq!(stats.stored, map.tree().len() as u64, "stored count reported");
    assert!(stats.rays >= n, "every emitted photon traces ≥ 1 ray: {}", stats.rays);
    assert_eq!(stats.chains_capped, 0);
    let phi_total = std::f64::consts::PI * a_light * LE;
    assert!((f64::from(map.total_power()) - phi_total).abs() < 1e-5 * phi_total);

    // Every stored photon lies on the receiver: none on the mirror (delta), none on the light's own front
    // (the mirror sends light straight back onto it, but its material is black, `reflectance = 0`, and a
    // black surface stores no photon: `Bsdf::has_non_delta`), none elsewhere.
    let per_photon = phi_total / n as f64;
    let (mut sum, mut sum2, mut k_recv, mut k_light) = (0.0f64, 0.0f64, 0u64, 0u64);
    for p in map.tree().photons() {
        let pw = p.power();
        assert!((f64::from(pw.x) - per_photon).abs() < 1e-4 * per_photon, "photon power {pw:?} vs {per_photon}");
        assert_eq!(pw.x, pw.y);
        assert_eq!(pw.x, pw.z);
        // p_emit = Le/Φ = 1/(π·A) (the light lies inside the mirror's bounding sphere: cosine emission).
        let pdf_emit = 1.0 / (std::f64::consts::PI * a_light);
        assert!((f64::from(p.pdf_emit()) - pdf_emit).abs() < 1e-5 * pdf_emit, "stored p_emit {}", p.pdf_emit());
        if dist_to_plane(p.position(), recv) < 1e-3 {
            k_recv += 1;
            sum += f64::from(pw.x);
            sum2 += f64::from(pw.x).powi(2);
            // The incident direction points back at the image light (4.3e-5 rad direction quantisation
            // × ≤ 4.5 units of distance, plus f32 positions: 1e-3 in the light's plane is ample).
            let o = p.position();
            let o = [f64::from(o.x), f64::from(o.y), f64::from(o.z)];
            let w = p.wi_world();
            let w = [f64::from(w.x), f64::from(w.y), f64::from(w.z)];
            assert!(dot(w, recv.n) > 0.0, "incident direction on the receiver's lit side");
            let t = dot(sub(image.c, o), image.n) / dot(w, image.n);
            let hit = sub(axpy(t, w, o), image.c);
            let tol = image.half + 1e-3;
            assert!(t > 0.0 && dot(hit, image.u).abs() < tol && dot(hit, image.v).abs() < tol, "photon direction does not lead back to the image light");
        } else if dist_to_plane(p.position(), light) < 1e-3 {
            k_light += 1;
        } else {
            panic!("photon stored off the receiver and the light: {:?}", p.position());
        }
    }
    assert_eq!(k_recv + k_light, stats.stored);
    assert_eq!(k_light, 0, "photons stored on the black light");
    // σ of the sum over all N emitted photons (non-stored ones are zeros): N·var(x) with the sample
    // variance of the per-photon contributions.
    let nf = n as f64;
    let var_sum = nf / (nf - 1.0) * (sum2 - sum * sum / nf);
    let sigma = var_sum.sqrt();
    let z = (sum - fine) / sigma;
    eprintln!(
        "receiver: {k_recv} photons, Σ power {sum:.6} vs analytic {fine:.6} (rel {:+.4}), σ {sigma:.6} ({:.2} %), z = {z:+.3}",
        sum / fine - 1.0,
        100.0 * sigma / fine
    );
    assert!(z.abs() < 3.5, "z = {z}");
    assert!(sigma < 0.02 * fine, "test too weak: σ/Φ = {}", sigma / fine);
}

#[test]
fn photon_pass_is_deterministic_per_seed_and_pass() {
    let scene = load_scene();
    let budget = PhotonBudget::Emitted(30_000);
    let (a, sa) = trace(&scene, budget, 3, 0);
    let (b, sb) = trace(&scene, budget, 3, 0);
    assert!(sa.stored > 100, "too few photons to compare: {}", sa.stored);
    assert_eq!(sa.stored, sb.stored);
    assert_eq!(sorted_photons(&a), sorted_photons(&b), "same seed and pass → the same photons");
    // Same order too: the tree is built from the same input in the same order.
    assert_eq!(a.tree().photons(), b.tree().photons());

    let (c, _) = trace(&scene, budget, 3, 1);
    let (d, _) = trace(&scene, budget, 4, 0);
    let base = sorted_photons(&a);
    for (other, what) in [(sorted_photons(&c), "another pass"), (sorted_photons(&d), "another seed")] {
        assert_ne!(base, other, "{what} gives the same photons");
        // Not merely reordered or shifted by one: almost no photon position is shared.
        let shared = other.iter().filter(|p| base.binary_search_by_key(&key_of(p), key_of).is_ok()).count();
        assert!(shared * 100 < other.len(), "{what}: {shared} of {} photons shared", other.len());
    }
}

fn key_of(p: &Photon) -> [u32; 8] {
    let (a, b) = (p.position(), p.wi_world());
    [a.x, a.y, a.z, b.x, b.y, b.z, p.power().x, p.pdf_emit()].map(f32::to_bits)
}

/// `PhotonBudget::Stored(m)` emits until ≥ m photons are stored; the second batch aims 5 % past the
/// missing count at the storage rate observed in the first batch (max(m, 4096) photons emitted; here
/// ≈ 2.5 % are stored), so the overshoot is 5 % plus the rate estimate's relative error 1/√s₀, s₀ the
/// first batch's stored count. Bound: 5 % + 3/√s₀ (m = 2,000: s₀ ≈ 100 → 35 %; m = 20,000: s₀ ≈ 500 →
/// 18 %). Measured (seed 11): 2,323 for m = 2,000 (+16 %), 20,946 for m = 20,000 (+4.7 %).
/// N = the emitted count is what every photon's power is divided by (checked), so the estimate stays
/// unbiased whatever batch ends the pass.
#[test]
fn stored_budget_stores_about_m() {
    let scene = load_scene();
    for (m, max_over) in [(2_000u64, 0.35), (20_000, 0.18)] {
        let (map, stats) = trace(&scene, PhotonBudget::Stored(m), 11, 0);
        eprintln!("Stored({m}): emitted {}, stored {}", stats.emitted, stats.stored);
        assert!(stats.stored >= m, "stored {} < {m}", stats.stored);
        assert!(stats.stored as f64 <= (1.0 + max_over) * m as f64, "stored {} ≫ {m}", stats.stored);
        assert_eq!(map.emitted(), stats.emitted);
        assert_eq!(map.tree().len() as u64, stats.stored);
        // Total stored power ≈ Φ · (stored/emitted) with the 1/N of the actual emitted count.
        let per_photon = std::f64::consts::PI * (2.0 * LIGHT_HALF).powi(2) * LE / stats.emitted as f64;
        let p0 = map.tree().photons()[0].power().x;
        assert!((f64::from(p0) - per_photon).abs() < 1e-4 * per_photon, "power uses N = emitted: {p0} vs {per_photon}");
    }
}

//! Where caustic photons start, and the density they start with (method.md §2, §4).
//!
//! Only a photon whose first hit is a delta surface becomes a caustic photon, so emission aims at the
//! sphere `S_δ` around the delta triangles ([`crate::scene::Scene::delta_bounds`], enlarged by 10⁻³)
//! instead of spreading photons over the whole hemisphere (issue 9 item 6, issue 13 §2):
//! - a light `j` is chosen ∝ its power `Φⱼ` (area lights `π·A·Le`, a textured one's mean `Le`: its photons
//!   carry the texture at their start; env maps `π·R²·∫Le dω`; the `constant` emitter emits no photons);
//! - **area light**: a point `y` uniform on the light (`1/A`; on an analytic shape its own `sample_area`,
//!   `light::shapes`: uniform too, except on an elliptic cylinder whose density `p_a(y)` varies), then a
//!   direction uniform in the cone that `S_δ` subtends from `y` when that cone is narrower than a
//!   hemisphere (`cos θ_max > ½`), else cosine-weighted about the normal (a light inside or near `S_δ`,
//!   e.g. a closed mirror box);
//! - **environment map**: a direction ω ∝ the map's importance distribution, then a point uniform on
//!   a disk of `S_δ`'s radius perpendicular to ω, centred on the line through `S_δ`'s centre, outside
//!   the scene's bounding sphere;
//! - **point and spot lights**: a direction uniform in the cone `S_δ` subtends from the light (uniform
//!   over the sphere when the light is inside `S_δ`), or in a spot's beam cone when that is narrower
//!   ([`crate::light::PointLight::direction_toward`]);
//! - **directional light**: its one direction, from a point uniform on the disk of the environment map's
//!   rule (radius of `S_δ`, perpendicular to the light, outside the scene).
//!
//! The density of a photon's start per unit area and projected solid angle is
//! `p_emit = (Φⱼ/Φ)·p_a(y)·p_ω(y, ω)/|cos θ_y|` (cos = 1 on the env disk). For the old emission ∝ power
//! (uniform point, cosine direction) it is the paper's `Le/Φ`; in general q₁ = `N·p_emit·|cos θ|·ΔA/α`
//! (method.md §4). A delta light's start has a Dirac factor (its point or its direction): in this measure
//! its density is infinite, `p_emit = ∞` (method.md §4.1), and no T2 path reaches it. The photon stores
//! `p_emit` (one f32), and T2 asks [`PhotonEmission::pdf_emit_area`] /
//! [`PhotonEmission::pdf_emit_env`] for the same density at the light point a path reaches, through the
//! same code ([`PhotonEmission::area_direction`]), so `w₁ + w₂ = 1` still holds. Every direction from
//! which a photon can first hit a delta triangle lies in the cone (resp. every line that can hit one
//! crosses the disk), so `p_emit > 0` wherever T1 can make a path.

use crate::light::{luminance, AnalyticShape, EmissionSample, EnvMap, Light};
use crate::math::{Frame, Vec2, Vec3};
use crate::sampling::distribution::Distribution1D;
use crate::sampling::warp::{square_to_cosine_hemisphere, square_to_uniform_cone, uniform_cone_pdf_w};
use crate::scene::Scene;
use std::f32::consts::{FRAC_1_PI, PI};

/// Relative enlargement of the delta triangles' bounding sphere (it must contain them despite rounding).
const TARGET_MARGIN: f32 = 1e-3;

/// Cone sampling is used when the cone's `cos θ_max` exceeds this (a cone smaller than a hemisphere).
const CONE_MIN_COS: f32 = 0.5;

/// The photon-emission model of a scene: light selection and the delta target.
#[derive(Clone, Debug)]
pub struct PhotonEmission {
    /// Light selection ∝ photon power (0 for lights that emit no photons).
    selection: Distribution1D,
    /// `1/A` of each area light (0 for the others): the density of its photons' starting points, except on
    /// an analytic shape whose density varies over it (an elliptic cylinder), which `area_shape` holds.
    inv_area: Vec<f32>,
    /// The analytic shape of each area light on one (`light::shapes`), asked for its density at a point.
    area_shape: Vec<Option<AnalyticShape>>,
    /// `S_δ`: centre and radius of the sphere around the delta triangles.
    target_center: Vec3,
    target_radius: f32,
    /// Distance from `S_δ`'s centre to the env disk (outside the scene's bounding sphere).
    env_distance: f32,
}

/// A photon's start: the ray, its power for N = 1 (`Le·|cos θ′|/(N·p)` with N = 1), and `p_emit`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonStart {
    pub emission: EmissionSample,
    /// RGB power × N.
    pub power_n: Vec3,
    /// Density per unit area and projected solid angle of this start (method.md §4); ∞ for a delta light
    /// (method.md §4.1).
    pub pdf_emit: f32,
}

/// How directions leave a point of an area light.
#[derive(Clone, Copy, Debug)]
pub enum AreaDirection {
    /// Uniform in the cone around `axis` (unit, from the point to `S_δ`'s centre) with `cos θ_max`.
    Cone { axis: Vec3, cos_max: f32 },
    /// Cosine-weighted about the light's normal.
    Cosine,
}

impl AreaDirection {
    /// Solid-angle density of `w` (unit) leaving a point of unit normal `n`.
    #[must_use]
    pub fn pdf_w(&self, n: Vec3, w: Vec3) -> f32 {
        match *self {
            AreaDirection::Cone { axis, cos_max } => uniform_cone_pdf_w(Vec3::new(0.0, 0.0, axis.dot(w)), cos_max),
            AreaDirection::Cosine => n.dot(w).max(0.0) * FRAC_1_PI,
        }
    }

    /// A direction and its solid-angle density, or `None` (below the light's surface, or a zero pdf).
    #[must_use]
    pub fn sample(&self, n: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
        let (w, pdf_w) = match *self {
            AreaDirection::Cone { axis, cos_max } => {
                let w = Frame::from_normal(axis).to_world(square_to_uniform_cone(u, cos_max)).normalize();
                (w, uniform_cone_pdf_w(Vec3::Z, cos_max))
            }
            AreaDirection::Cosine => {
                let local = square_to_cosine_hemisphere(u);
                (Frame::from_normal(n).to_world(local).normalize(), local.z * FRAC_1_PI)
            }
        };
        (n.dot(w) > 0.0 && pdf_w > 0.0 && pdf_w.is_finite()).then_some((w, pdf_w))
    }
}

impl PhotonEmission {
    /// The model of `scene`, or `None` if no light emits photons.
    #[must_use]
    pub fn new(scene: &Scene) -> Option<Self> {
        let (center, radius) = scene.bounds.bounding_sphere();
        let powers: Vec<f32> = scene
            .lights
            .lights()
            .iter()
            .map(|l| match l {
                Light::Area(a) => a.power(),
                Light::Env(e) => PI * radius * radius * e.integral_luminance(),
                Light::Constant { .. } => 0.0,
                Light::Point(p) => p.power(),
                Light::Directional(d) => d.power(radius),
            })
            .map(|p| if p.is_finite() && p > 0.0 { p } else { 0.0 })
            .collect();
        let selection = Distribution1D::new(&powers)?;
        let inv_area = scene
            .lights
            .lights()
            .iter()
            .map(|l| match l {
                Light::Area(a) if a.area() > 0.0 => 1.0 / a.area(),
                _ => 0.0,
            })
            .collect();
        let area_shape = scene.lights.lights().iter().map(|l| match l {
            Light::Area(a) => a.analytic_shape().cloned(),
            _ => None,
        }).collect();
        let delta = scene.delta_bounds();
        let (target_center, target_radius) = if delta.is_empty() { (center, radius) } else { delta.bounding_sphere() };
        let target_radius = (target_radius * (1.0 + TARGET_MARGIN)).max(f32::MIN_POSITIVE);
        let env_distance = radius + (target_center - center).length() + target_radius;
        Some(Self { selection, inv_area, area_shape, target_center, target_radius, env_distance })
    }

    /// Total photon power Φ (luminance) of the emitting lights.
    #[must_use]
    pub fn total_power(&self) -> f32 {
        self.selection.sum()
    }

    /// How directions leave the point `p` (unit normal `n`) of an area light: toward `S_δ` in a cone
    /// when that cone is narrower than a hemisphere, else cosine-weighted. The one rule both the
    /// sampler and T2's density use.
    #[must_use]
    pub fn area_direction(&self, p: Vec3, _n: Vec3) -> AreaDirection {
        let d = self.target_center - p;
        let dist2 = d.length_squared();
        let r2 = self.target_radius * self.target_radius;
        if dist2.is_finite() && dist2 > r2 {
            let cos_max = (1.0 - r2 / dist2).max(0.0).sqrt();
            if cos_max > CONE_MIN_COS {
                return AreaDirection::Cone { axis: d / dist2.sqrt(), cos_max };
            }
        }
        AreaDirection::Cosine
    }

    /// Samples a photon's start: `u_sel` chooses the light; the others are the light's own numbers.
    #[must_use]
    pub fn sample(&self, lights: &[Light], u_sel: f32, u_a: Vec2, u_b: Vec2, u_c: f32) -> Option<PhotonStart> {
        let (index, pmf, _) = self.selection.sample_discrete(u_sel);
        let light = &lights[index];
        let es = match light {
            Light::Area(a) => a.sample_le_with(u_a, u_c, |p, n| self.area_direction(p, n).sample(n, u_b))?,
            Light::Env(e) => e.sample_le_toward(u_a, u_b, self.target_center, self.target_radius, self.env_distance)?,
            Light::Constant { .. } => return None,
            Light::Point(p) => p.sample_le_toward(u_b, self.target_center, self.target_radius)?,
            Light::Directional(d) => d.sample_le_toward(u_a, self.target_center, self.target_radius, self.env_distance)?,
        };
        let cos = es.n.dot(es.dir).abs();
        let pdf = f64::from(pmf) * f64::from(es.pdf_a) * f64::from(es.pdf_w_dir);
        if !(pdf > 0.0 && pdf.is_finite() && cos > 0.0) || luminance(es.le) <= 0.0 {
            return None;
        }
        // Power·N = Le·|cos θ′|/p (method.md §2), p_emit = p/|cos θ′| (per projected solid angle); a delta
        // light's p_emit is ∞ (method.md §4.1: its start is a Dirac in that measure).
        let power_n = es.le * (f64::from(cos) / pdf) as f32;
        let pdf_emit = if light.is_delta() { f32::INFINITY } else { (pdf / f64::from(cos)) as f32 };
        (power_n.is_finite() && (pdf_emit.is_finite() || light.is_delta())).then_some(PhotonStart { emission: es, power_n, pdf_emit })
    }

    /// `p_emit` of a photon leaving point `p` (unit geometric normal `n`) of area light `index` in
    /// direction `w` (unit): what [`PhotonEmission::sample`] would have given it (T2, method.md §4).
    #[must_use]
    pub fn pdf_emit_area(&self, index: usize, p: Vec3, n: Vec3, w: Vec3) -> f32 {
        let inv_area = match self.area_shape.get(index) {
            Some(Some(shape)) => shape.pdf_a(p),
            _ => self.inv_area.get(index).copied().unwrap_or(0.0),
        };
        let cos = n.dot(w);
        if inv_area <= 0.0 || cos.is_nan() || cos <= 0.0 {
            return 0.0;
        }
        let pdf_w = self.area_direction(p, n).pdf_w(n, w);
        (f64::from(self.selection.pmf(index)) * f64::from(inv_area) * f64::from(pdf_w) / f64::from(cos)) as f32
    }

    /// `p_emit` of a photon of env map `index` arriving from direction `w` (unit, toward the map):
    /// selection × the map's direction pdf × `1/(π r_δ²)` (T2, method.md §4).
    #[must_use]
    pub fn pdf_emit_env(&self, index: usize, env: &EnvMap, w: Vec3) -> f32 {
        let pmf = self.selection.pmf(index);
        if pmf <= 0.0 {
            return 0.0;
        }
        let disk = f64::from(PI) * f64::from(self.target_radius) * f64::from(self.target_radius);
        (f64::from(pmf) * f64::from(env.pdf_li(w)) / disk) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;
    use std::path::Path;

    /// A small light far above a small glass sphere (cone emission), an env map (disk emission), a
    /// constant light (no photons) and a large diffuse floor.
    fn scene() -> Scene {
        let text = r#"
[sensor]
fov = 40
film = { width = 8, height = 8 }
to_world = { look_at = { origin = [0, 2, 6], target = [0, 0, 0], up = [0, 1, 0] } }

[[shape]]
type = "rectangle"
to_world = [ { scale = 3 }, { rotate = { axis = [1, 0, 0], angle = -90 } } ]
bsdf = { type = "diffuse", reflectance = 0.5 }

[[shape]]
type = "sphere"
center = [0.5, 0.5, 0]
radius = 0.5
bsdf = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }

[[shape]]   # 0.2 × 0.2 light at (-1, 4, 1), facing the sphere
type = "rectangle"
to_world = [ { scale = 0.1 }, { look_at = { origin = [-1, 4, 1], target = [0.5, 0.5, 0], up = [0, 1, 0] } } ]
bsdf = { type = "diffuse", reflectance = 0 }
emitter = { type = "area", radiance = 10000 }

[[emitter]]
type = "envmap"
filename = "scenes/assets/envmaps/studio.exr"

[[emitter]]
type = "constant"
radiance = 0.1

[[emitter]]   # outside S_δ: the cone toward it
type = "point"
position = [1, 3, 1]
intensity = 50

[[emitter]]   # a beam narrower than S_δ's cone, aimed off-centre (part of it misses the sphere)
type = "spot"
intensity = 400
cutoff_angle = 8
beam_width = 4
to_world = { look_at = { origin = [-1, 2, -1], target = [0.8, 0.5, 0], up = [0, 1, 0] } }

[[emitter]]   # a beam wider than S_δ's cone
type = "spot"
intensity = 100
cutoff_angle = 60
to_world = { look_at = { origin = [2, 1, 1], target = [0, 0, 0], up = [0, 1, 0] } }

[[emitter]]
type = "directional"
direction = [-1, -2, 0.5]
irradiance = 2
"#;
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        Scene::from_toml_str(text, root, Path::new("emission-test.toml")).expect("test scene loads")
    }

    /// Indices of the area light and of the env map.
    fn light_indices(scene: &Scene) -> (usize, usize) {
        let lights = scene.lights.lights();
        let area = lights.iter().position(|l| matches!(l, Light::Area(_))).expect("area light");
        let env = lights.iter().position(|l| matches!(l, Light::Env(_))).expect("env map");
        (area, env)
    }

    /// Indices of the delta lights (point, two spots, directional).
    fn delta_indices(scene: &Scene) -> Vec<usize> {
        let lights = scene.lights.lights();
        let v: Vec<usize> = (0..lights.len()).filter(|&i| lights[i].is_delta()).collect();
        assert_eq!(v.len(), 4, "four delta lights");
        v
    }

    fn starts(em: &PhotonEmission, scene: &Scene, n: usize) -> Vec<(usize, PhotonStart)> {
        let mut s = Sampler::for_key(11, 0, 0);
        (0..n)
            .filter_map(|_| {
                let u_sel = s.next_1d();
                let (index, _, _) = em.selection.sample_discrete(u_sel);
                em.sample(scene.lights.lights(), u_sel, s.next_2d(), s.next_2d(), s.next_1d()).map(|st| (index, st))
            })
            .collect()
    }

    /// T2's density at the start of every sampled photon is the density the photon carries (the unit
    /// test of `w₁ + w₂ = 1`: both sides evaluate one `p_emit`), and emission uses the cone here.
    #[test]
    fn t2_density_equals_the_sampled_density() {
        let scene = scene();
        let em = PhotonEmission::new(&scene).expect("lights emit photons");
        let lights = scene.lights.lights();
        let (mut area, mut env, mut delta) = (0, 0, 0);
        for (index, st) in starts(&em, &scene, 100_000) {
            let es = st.emission;
            let t2 = match &lights[index] {
                Light::Point(_) | Light::Directional(_) => {
                    // No T2 density: p_emit = ∞ (method.md §4.1); the power is Le·|cos|/p.
                    delta += 1;
                    assert_eq!(st.pdf_emit, f32::INFINITY);
                    let p = em.selection.pmf(index) * es.pdf_a * es.pdf_w_dir;
                    let expected = es.le.x * es.n.dot(es.dir).abs() / p;
                    assert!((st.power_n.x / expected - 1.0).abs() < 1e-4, "light {index}: power {} vs {expected}", st.power_n.x);
                    continue;
                }
                Light::Area(_) => {
                    area += 1;
                    assert!(matches!(em.area_direction(es.origin, es.n), AreaDirection::Cone { .. }), "the light is far from the sphere");
                    em.pdf_emit_area(index, es.origin, es.n, es.dir)
                }
                Light::Env(e) => {
                    env += 1;
                    em.pdf_emit_env(index, e, -es.dir)
                }
                Light::Constant { .. } => panic!("the constant light emits no photons"),
            };
            let rel = (t2 / st.pdf_emit - 1.0).abs();
            assert!(rel < 1e-3, "light {index}: sampled p_emit {} vs T2's {t2}", st.pdf_emit);
            // Power·N·p_emit = Le (method.md §2, §4).
            let le = es.le.x;
            assert!((st.power_n.x * st.pdf_emit / le - 1.0).abs() < 1e-4, "power {} p_emit {} Le {le}", st.power_n.x, st.pdf_emit);
        }
        assert!(area > 1000 && env > 1000 && delta > 1000, "every kind sampled: {area} area, {env} env, {delta} delta");
        // Directions that cannot reach the sphere have no density; nor does the back of the light.
        let (ia, _) = light_indices(&scene);
        let p = Vec3::new(-1.0, 4.0, 1.0);
        let n = (Vec3::new(0.5, 0.5, 0.0) - p).normalize();
        assert!(em.pdf_emit_area(ia, p, n, n) > 0.0);
        assert_eq!(em.pdf_emit_area(ia, p, n, Frame::from_normal(n).to_world(Vec3::new(0.6, 0.0, 0.8))), 0.0);
        assert_eq!(em.pdf_emit_area(ia, p, n, -n), 0.0);
    }

    /// Unbiasedness of the aimed emission: the power it sends into the delta sphere `S_δ` equals the
    /// power the unaimed emission of `Light::sample_le` (cosine from the area light, the scene-sized disk
    /// for the env map and the directional light, the sphere or the beam of point and spot lights; every
    /// start counted, misses as 0) sends into it. Both are Monte Carlo sums over
    /// n starts; z = difference / combined σ, |z| < 4 (measured below).
    #[test]
    fn aimed_emission_sends_the_same_power_into_the_delta_sphere() {
        let scene = scene();
        let em = PhotonEmission::new(&scene).expect("lights emit photons");
        let (c, r) = (em.target_center, em.target_radius);
        let hits = |o: Vec3, d: Vec3| {
            let oc = o - c;
            let b = oc.dot(d);
            b * b - (oc.length_squared() - r * r) >= 0.0 && b < 0.0
        };
        let (center, radius) = scene.bounds.bounding_sphere();
        let lights = scene.lights.lights();
        let (ia, ie) = light_indices(&scene);
        for index in [ia, ie].into_iter().chain(delta_indices(&scene)) {
            let n = 200_000u32;
            // (sum, sum of squares) of power into S_δ per start, luminance.
            let mut aimed = (0.0f64, 0.0f64);
            let mut plain = (0.0f64, 0.0f64);
            let mut s = Sampler::for_key(12, index as u64, 0);
            let pmf = f64::from(em.selection.pmf(index));
            for _ in 0..n {
                let (ua, ub, uc) = (s.next_2d(), s.next_2d(), s.next_1d());
                // The aimed sampler restricted to this light: power·pmf (p_emit includes the selection).
                let es = match &lights[index] {
                    Light::Area(a) => a.sample_le_with(ua, uc, |p, nn| em.area_direction(p, nn).sample(nn, ub)),
                    Light::Env(e) => e.sample_le_toward(ua, ub, em.target_center, em.target_radius, em.env_distance),
                    Light::Constant { .. } => None,
                    Light::Point(p) => p.sample_le_toward(ub, em.target_center, em.target_radius),
                    Light::Directional(d) => d.sample_le_toward(ua, em.target_center, em.target_radius, em.env_distance),
                };
                if let Some(es) = es.filter(|es| hits(es.origin, es.dir)) {
                    let x = f64::from(luminance(es.le)) * f64::from(es.n.dot(es.dir).abs()) / (f64::from(es.pdf_a) * f64::from(es.pdf_w_dir));
                    aimed = (aimed.0 + x, aimed.1 + x * x);
                }
                let es = lights[index].sample_le(s.next_2d(), s.next_2d(), s.next_1d(), center, radius);
                if let Some(es) = es.filter(|es| hits(es.origin, es.dir)) {
                    let x = f64::from(luminance(es.le)) * f64::from(es.n.dot(es.dir).abs()) / (f64::from(es.pdf_a) * f64::from(es.pdf_w_dir));
                    plain = (plain.0 + x, plain.1 + x * x);
                }
            }
            let nf = f64::from(n);
            let stats = |(s1, s2): (f64, f64)| (s1 / nf, ((s2 / nf - (s1 / nf).powi(2)).max(0.0) / nf).sqrt());
            let ((ma, sa), (mp, sp)) = (stats(aimed), stats(plain));
            let z = (ma - mp) / (sa * sa + sp * sp).sqrt();
            eprintln!("light {index} (pmf {pmf:.3}): aimed {ma:.5} ± {sa:.5}, plain {mp:.5} ± {sp:.5}, z = {z:+.2}");
            assert!(z.abs() < 4.0, "light {index}: z = {z}");
            // (Equal up to noise for a spot whose beam is narrower than S_δ's cone: both sample the beam.)
            assert!(sa <= 1.05 * sp, "aiming must not raise the noise: σ {sa} vs {sp}");
            assert!(sp < 0.05 * mp, "the test is too weak: σ {sp} of {mp}");
        }
    }
}

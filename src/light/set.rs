//! All the lights of a scene, with the two choices made among them: a light ∝ power (luminance, method.md
//! §2) for next-event estimation and for photon emission, and the primitive → light table that turns a
//! hit on an emissive primitive (a triangle, or an analytic shape numbered after the triangles) into its light.

use super::{Light, LightSample};
use crate::math::{Aabb, Vec2, Vec3};
use crate::sampling::distribution::Distribution1D;

/// Marker in the primitive → light table for a non-emissive triangle.
const NO_LIGHT: u32 = u32::MAX;

/// The scene's lights.
#[derive(Clone, Debug)]
pub struct LightSet {
    lights: Vec<Light>,
    /// Power Φ of each light (luminance); negative or non-finite values replaced by 0.
    powers: Vec<f32>,
    /// Selection ∝ power; `None` if no light has power.
    selection: Option<Distribution1D>,
    /// Light index of each primitive, [`NO_LIGHT`] if it does not emit.
    prim_to_light: Vec<u32>,
    /// One bit per primitive, set where `prim_to_light` names a light: every camera-path hit asks
    /// [`LightSet::light_of_prim`], and 1/32 of the table's bytes stay in cache where the table (4 bytes per
    /// triangle) missed it on mesh scenes.
    emissive: Vec<u64>,
    /// Indices of the infinite lights (environment map, constant).
    infinite: Vec<usize>,
    scene_center: Vec3,
    scene_radius: f32,
}

impl LightSet {
    /// Builds the set for a scene of `prim_count` primitives (its triangles, then its analytic shapes)
    /// bounded by `scene_bounds` (whose bounding sphere gives R for the power of infinite lights). A light whose power is negative or not finite
    /// (bad input upstream) gets power 0: it is never chosen for NEE, but still seen by rays that hit it.
    #[must_use]
    pub fn new(lights: Vec<Light>, prim_count: usize, scene_bounds: Aabb) -> LightSet {
        let (scene_center, scene_radius) = scene_bounds.bounding_sphere();
        let powers: Vec<f32> = lights
            .iter()
            .map(|l| {
                let p = l.power(scene_radius);
                if p.is_finite() && p > 0.0 {
                    p
                } else {
                    0.0
                }
            })
            .collect();
        let selection = Distribution1D::new(&powers);
        let mut prim_to_light = vec![NO_LIGHT; prim_count];
        for (index, light) in lights.iter().enumerate() {
            if let Light::Area(area) = light {
                for prim in area.prims() {
                    let prim = prim as usize;
                    debug_assert!(
                        prim < prim_count,
                        "emissive primitive {prim} outside the {prim_count} primitives"
                    );
                    if prim >= prim_to_light.len() {
                        prim_to_light.resize(prim + 1, NO_LIGHT);
                    }
                    debug_assert!(prim_to_light[prim] == NO_LIGHT, "primitive {prim} belongs to two area lights");
                    prim_to_light[prim] = index as u32;
                }
            }
        }
        let infinite = lights.iter().enumerate().filter(|(_, l)| l.is_infinite()).map(|(i, _)| i).collect();
        let mut emissive = vec![0u64; prim_to_light.len().div_ceil(64)];
        for (prim, _) in prim_to_light.iter().enumerate().filter(|(_, &l)| l != NO_LIGHT) {
            emissive[prim / 64] |= 1 << (prim % 64);
        }
        LightSet {
            lights,
            powers,
            selection,
            prim_to_light,
            emissive,
            infinite,
            scene_center,
            scene_radius,
        }
    }

    /// `true` if there are no lights.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    #[must_use]
    pub fn lights(&self) -> &[Light] {
        &self.lights
    }

    /// Whether [`LightSet::sample_li`] reads `u_select`: only with more than one light (with one, any value
    /// selects it), so a caller may spare the sampler that dimension otherwise.
    #[must_use]
    pub fn chooses_light(&self) -> bool {
        self.lights.len() > 1
    }

    /// Power Φ of light `index` (luminance, 0 for an unknown index).
    #[must_use]
    pub fn power(&self, index: usize) -> f32 {
        self.powers.get(index).copied().unwrap_or(0.0)
    }

    /// Total power Φ = Σ Φⱼ over all lights (method.md §2).
    #[must_use]
    pub fn total_power(&self) -> f32 {
        self.selection.as_ref().map_or(0.0, Distribution1D::sum)
    }

    /// Probability that NEE (or emission) chooses light `index`: Φ_index / Φ.
    #[must_use]
    pub fn selection_pmf(&self, index: usize) -> f32 {
        self.selection.as_ref().map_or(0.0, |s| s.pmf(index))
    }

    /// Centre and radius R of the scene's bounding sphere (used by the infinite lights).
    #[must_use]
    pub fn scene_sphere(&self) -> (Vec3, f32) {
        (self.scene_center, self.scene_radius)
    }

    /// NEE: chooses a light ∝ power with `u_select`, then samples it with `u`. The returned `pdf_w`
    /// includes the selection probability.
    ///
    /// The infinite lights act as one light sampled by the mixture of their strategies: when one of them is
    /// chosen, `li` is the radiance of all of them ([`LightSet::le_escaped`]) and `pdf_w` the mixture density
    /// ([`LightSet::pdf_li_escaped`]). An escaping BSDF-sampled ray is then weighted against exactly the pdf
    /// that produced this sample, so MIS stays unbiased with several infinite lights (env map + constant).
    #[must_use]
    pub fn sample_li(&self, p_ref: Vec3, u_select: f32, u: Vec2) -> Option<(usize, LightSample)> {
        let (index, pmf, _) = self.selection.as_ref()?.sample_discrete(u_select);
        let light = &self.lights[index];
        let mut ls = light.sample_li(p_ref, u)?;
        if light.is_infinite() {
            ls.li = self.le_escaped(ls.wi_world);
            ls.pdf_w = self.pdf_li_escaped(ls.wi_world);
        } else {
            ls.pdf_w *= pmf;
        }
        Some((index, ls))
    }

    /// Photon emission: chooses a light ∝ power; `(index, pmf)`. Sample it with [`Light::sample_le`] and
    /// the sphere of [`LightSet::scene_sphere`].
    #[must_use]
    pub fn sample_light_for_emission(&self, u: f32) -> Option<(usize, f32)> {
        let (index, pmf, _) = self.selection.as_ref()?.sample_discrete(u);
        Some((index, pmf))
    }

    /// Light index of an emissive primitive (triangle or analytic shape), if any.
    #[must_use]
    pub fn light_of_prim(&self, prim: u32) -> Option<usize> {
        let prim = prim as usize;
        if self.emissive.get(prim / 64).is_none_or(|bits| bits & (1 << (prim % 64)) == 0) {
            return None;
        }
        match self.prim_to_light.get(prim) {
            Some(&l) if l != NO_LIGHT => Some(l as usize),
            _ => None,
        }
    }

    /// Radiance leaving emissive primitive `prim` (triangle or analytic shape) at a point with unit geometric normal `ng` toward
    /// `w_world` (0 on the back side and for non-emissive primitives); `uv` gives the point's texture
    /// coordinates (`Scene::tex_uv`), asked only where the light's radiance is a texture.
    #[inline]
    #[must_use]
    pub fn le_area(&self, prim: u32, ng: Vec3, w_world: Vec3, uv: impl FnOnce() -> Vec2) -> Vec3 {
        match self.light_of_prim(prim).map(|i| &self.lights[i]) {
            Some(Light::Area(a)) => a.le(ng, w_world, uv),
            _ => Vec3::ZERO,
        }
    }

    /// Solid-angle pdf, including selection, with which [`LightSet::sample_li`] from `p_ref` produces the point
    /// `p_light` (unit geometric normal `n_light`) on emissive primitive `prim` (on a sphere, the density of
    /// its solid-angle sampling: `p_light` must be the first point of the sphere seen from `p_ref`, as a
    /// ray's hit is).
    #[must_use]
    pub fn pdf_li_area(&self, prim: u32, p_ref: Vec3, p_light: Vec3, n_light: Vec3) -> f32 {
        match self.light_of_prim(prim) {
            Some(i) => match &self.lights[i] {
                Light::Area(a) => self.selection_pmf(i) * a.pdf_li(p_ref, p_light, n_light),
                _ => 0.0,
            },
            None => 0.0,
        }
    }

    /// Radiance from all infinite lights (environment maps and constant) along an escaping ray.
    #[must_use]
    pub fn le_escaped(&self, dir_world: Vec3) -> Vec3 {
        self.infinite.iter().map(|&i| self.lights[i].le_escaped(dir_world)).sum()
    }

    /// Solid-angle pdf, including selection, with which [`LightSet::sample_li`] produces the escaping
    /// direction `dir_world`: the sum over the infinite lights of selection × that light's pdf.
    #[must_use]
    pub fn pdf_li_escaped(&self, dir_world: Vec3) -> f32 {
        self.infinite
            .iter()
            .map(|&i| self.selection_pmf(i) * self.lights[i].pdf_li_escaped(dir_world))
            .sum()
    }

    /// `true` if the scene has an environment map (an image; a constant light does not count).
    #[must_use]
    pub fn has_env(&self) -> bool {
        self.lights.iter().any(|l| matches!(l, Light::Env(_)))
    }
}

//! Run-time materials: a BSDF whose parameters may be driven by textures, evaluated at a hit into the
//! [`Bsdf`] the integrators and the photon pass sample (pbrt-v4's `Material::GetBxDF`; Mitsuba 3 evaluates
//! each texture inside its BSDF plugin).
//!
//! A [`Material`] is a *template* — the BSDF built from the scene file, with each textured parameter at its
//! texture's mean, which is also what Mitsuba derives sampling weights from — and its *bindings*: which
//! texturable parameter (numbered in the order [`Bsdf::visit_params`] walks them, nested bsdfs inline) takes
//! which texture. [`Material::bsdf_at`] hands out the template itself when nothing is textured (no copy, no
//! work: the integrators see no difference from constant materials), else a copy with every bound parameter
//! set from its texture at the hit and the derived factors recomputed ([`Bsdf::params_changed`]).
//!
//! What the integrators decide per material before any hit (whether it has a delta lobe, a non-delta lobe
//! that reflects anything, a choice of lobes, transmission: [`Facts`]) is decided once, on the template with
//! each textured colour at its texture's per-channel maximum and each textured number at its mean (strictly
//! between the texture's extremes when it varies, so that a blend's weight keeps both components): a
//! parameter that is nonzero somewhere counts as nonzero. A perturbed shading frame (`normalmap`, `bumpmap`:
//! [`ParamMut::Frame`], which the scene layer sets from the texture and the hit's geometry) stays the
//! template's identity there: a frame changes no lobe's presence. A hit where a texture makes the lobe black then
//! evaluates to zero, as it does in Mitsuba.

use std::borrow::Cow;

use crate::bsdf::{Bsdf, ParamMut, ParamVisitor};
use crate::props::Textured;

/// One textured parameter: its number in the walk of [`Bsdf::visit_params`] and its texture (an index the
/// caller of [`Material::bsdf_at`] resolves).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Binding {
    pub slot: u32,
    pub texture: u32,
}

/// What the integrators know of a material before a hit (module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Facts {
    pub has_delta: bool,
    pub has_non_delta: bool,
    pub chooses_lobe: bool,
    pub transmits: bool,
    /// The BSDF may be anisotropic at some hit ([`Bsdf::anisotropic`]): its shading frame's tangent follows
    /// `∂p/∂u` (`Scene::interaction`). With a textured roughness it is decided from the paths bound
    /// ([`ANISOTROPY_KEYS`]), not from the textures' values: two textures with equal ranges still differ
    /// from point to point.
    pub anisotropic: bool,
}

/// The parameters whose textures can make a BSDF anisotropic where its template is not: a roughness along
/// one axis, or principled's anisotropy.
pub const ANISOTROPY_KEYS: [&str; 3] = ["alpha_u", "alpha_v", "anisotropic"];

impl Facts {
    fn of(bsdf: &Bsdf) -> Self {
        Self {
            has_delta: bsdf.has_delta(),
            has_non_delta: bsdf.has_non_delta(),
            chooses_lobe: bsdf.chooses_lobe(),
            transmits: bsdf.transmits(),
            anisotropic: bsdf.anisotropic(),
        }
    }
}

/// Whether a texture bound at `path` (`bsdf_0.alpha_u`) can make the BSDF anisotropic.
fn binds_anisotropy(path: &str) -> bool {
    let key = path.rsplit('.').next().unwrap_or(path);
    ANISOTROPY_KEYS.contains(&key)
}


/// A material: a template BSDF and the textures bound to its parameters (module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    template: Bsdf,
    /// Sorted by slot, one per slot.
    bindings: Box<[Binding]>,
    facts: Facts,
}

/// A parameter path no texturable parameter of the BSDF has: `path` as given, and the paths it does have.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NotTexturable {
    pub path: String,
    pub texturable: Vec<String>,
}

impl Material {
    /// A material without textures.
    #[must_use]
    pub fn constant(bsdf: Bsdf) -> Self {
        let facts = Facts::of(&bsdf);
        Self { template: bsdf, bindings: Box::default(), facts }
    }

    /// `template` with the textures `bound` to its parameters, each named by its path (`reflectance`,
    /// `bsdf_0.reflectance`: the keys of [`Bsdf::visit_params`], nested keys joined by dots); `range` gives
    /// each bound texture's summary (`Texture::summary`: its maximum colour and mean number decide the
    /// [`Facts`]). A path no parameter has is an error, naming the ones it has.
    pub fn textured(template: Bsdf, bound: &[(String, u32)], range: impl Fn(u32) -> Textured) -> Result<Self, NotTexturable> {
        let mut paths = Paths::default();
        let mut walked = template.clone();
        walked.visit_params(&mut paths);
        let mut bindings = Vec::with_capacity(bound.len());
        for (path, texture) in bound {
            let Some(slot) = paths.all.iter().position(|p| p == path) else {
                return Err(NotTexturable { path: path.clone(), texturable: paths.all });
            };
            bindings.push(Binding { slot: slot as u32, texture: *texture });
        }
        bindings.sort_unstable();
        bindings.dedup_by_key(|b| b.slot);
        let mut facts = textured_facts(&template, &bindings, range);
        facts.anisotropic |= template.anisotropic() || bound.iter().any(|(path, _)| binds_anisotropy(path));
        Ok(Self { template, bindings: bindings.into_boxed_slice(), facts })
    }

    /// Decides the [`Facts`] again from `range`, the bound textures' summaries known better than when the
    /// material was made (a `mesh_attribute`'s values, read with the shapes).
    pub fn refine_facts(&mut self, range: impl Fn(u32) -> Textured) {
        if self.is_textured() {
            let anisotropic = self.facts.anisotropic;
            self.facts = textured_facts(&self.template, &self.bindings, range);
            self.facts.anisotropic |= anisotropic;
        }
    }

    /// Whether some parameter is textured.
    #[must_use]
    pub fn is_textured(&self) -> bool {
        !self.bindings.is_empty()
    }

    /// The BSDF as the scene file builds it, textured parameters at their textures' means.
    #[must_use]
    pub fn template(&self) -> &Bsdf {
        &self.template
    }

    /// The textures bound to the parameters.
    #[must_use]
    pub fn bindings(&self) -> &[Binding] {
        &self.bindings
    }

    /// What the integrators know before a hit.
    #[must_use]
    pub fn facts(&self) -> Facts {
        self.facts
    }

    /// The BSDF at a hit: the template when nothing is textured, else a copy whose bound parameters `eval`
    /// sets (called with the binding's texture and the parameter, once per binding, in slot order).
    #[inline]
    pub fn bsdf_at(&self, eval: impl FnMut(u32, ParamMut<'_>)) -> Cow<'_, Bsdf> {
        if self.bindings.is_empty() {
            return Cow::Borrowed(&self.template);
        }
        let mut bsdf = self.template.clone();
        set_bound(&mut bsdf, &self.bindings, eval);
        Cow::Owned(bsdf)
    }
}

/// The facts of `template` with `bindings`: decided with each textured parameter at the value that counts it
/// (module documentation).
fn textured_facts(template: &Bsdf, bindings: &[Binding], range: impl Fn(u32) -> Textured) -> Facts {
    let mut extreme = template.clone();
    set_bound(&mut extreme, bindings, |texture, param| {
        let r = range(texture);
        param.set(|| r.max, || r.mean_1);
    });
    Facts::of(&extreme)
}

/// Sets the parameters of `bsdf` that `bindings` name through `eval`, then lets every BSDF whose
/// parameters may have changed recompute what it derives from them (nested ones first).
fn set_bound(bsdf: &mut Bsdf, bindings: &[Binding], eval: impl FnMut(u32, ParamMut<'_>)) {
    let mut setter = Setter { bindings, next: 0, slot: 0, eval };
    bsdf.visit_params(&mut setter);
    bsdf.params_changed();
}

/// The visitor of [`set_bound`]: counts the slots and sets the bound ones.
struct Setter<'b, F> {
    bindings: &'b [Binding],
    /// Index of the next binding to meet.
    next: usize,
    /// Number of the next slot.
    slot: u32,
    eval: F,
}

impl<F: FnMut(u32, ParamMut<'_>)> ParamVisitor for Setter<'_, F> {
    fn param(&mut self, _key: &'static str, value: ParamMut<'_>) {
        if let Some(b) = self.bindings.get(self.next) {
            if b.slot == self.slot {
                (self.eval)(b.texture, value);
                self.next += 1;
            }
        }
        self.slot += 1;
    }
    fn nested(&mut self, _key: &'static str, bsdf: &mut Bsdf) {
        bsdf.visit_params(self);
        bsdf.params_changed();
    }
}

/// The visitor that lists every texturable parameter's path, in slot order.
#[derive(Default)]
struct Paths {
    prefix: Vec<&'static str>,
    all: Vec<String>,
}

impl ParamVisitor for Paths {
    fn param(&mut self, key: &'static str, _value: ParamMut<'_>) {
        let mut path: String = self.prefix.iter().flat_map(|p| [*p, "."]).collect();
        path.push_str(key);
        self.all.push(path);
    }
    fn nested(&mut self, key: &'static str, bsdf: &mut Bsdf) {
        self.prefix.push(key);
        bsdf.visit_params(self);
        self.prefix.pop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Blend, Diffuse, Plastic, TwoSided};
    use crate::math::Vec3;

    fn diffuse(r: f32) -> Bsdf {
        Bsdf::Diffuse(Diffuse { reflectance: Vec3::splat(r) })
    }

    fn range(max: f32) -> impl Fn(u32) -> Textured {
        move |_| Textured { mean: Vec3::splat(0.5 * max), mean_1: 0.5 * max, max: Vec3::splat(max), min: Vec3::ZERO }
    }

    #[test]
    fn an_untextured_material_is_its_template_without_a_copy() {
        let m = Material::constant(diffuse(0.3));
        let b = m.bsdf_at(|_, _| panic!("no texture to evaluate"));
        assert!(matches!(b, Cow::Borrowed(_)));
        assert_eq!(*b, diffuse(0.3));
    }

    #[test]
    fn nested_paths_reach_the_parameters_they_name() {
        let blend = Bsdf::Blend(Blend { weight: 0.5, bsdf_0: Box::new(diffuse(0.1)), bsdf_1: Box::new(Bsdf::TwoSided(TwoSided(Box::new(diffuse(0.2))))) });
        let bound = [("bsdf_1.bsdf.reflectance".to_string(), 7), ("weight".to_string(), 3)];
        let m = Material::textured(blend, &bound, range(1.0)).unwrap();
        assert_eq!(m.bindings(), &[Binding { slot: 0, texture: 3 }, Binding { slot: 2, texture: 7 }]);
        let b = m.bsdf_at(|texture, param| match (texture, param) {
            (3, ParamMut::Float(w)) => *w = 0.25,
            (7, ParamMut::Rgb(r)) => *r = Vec3::new(0.9, 0.8, 0.7),
            other => panic!("unexpected binding {:?}", other.0),
        });
        let Bsdf::Blend(Blend { weight, bsdf_0, bsdf_1 }) = &*b else { panic!("{b:?}") };
        assert_eq!(*weight, 0.25);
        assert_eq!(**bsdf_0, diffuse(0.1));
        assert_eq!(**bsdf_1, Bsdf::TwoSided(TwoSided(Box::new(Bsdf::Diffuse(Diffuse { reflectance: Vec3::new(0.9, 0.8, 0.7) })))));
    }

    #[test]
    fn a_path_without_a_parameter_is_refused_with_the_ones_there_are() {
        let e = Material::textured(diffuse(0.5), &[("alpha".to_string(), 0)], range(1.0)).unwrap_err();
        assert_eq!(e, NotTexturable { path: "alpha".into(), texturable: vec!["reflectance".into()] });
    }

    #[test]
    fn derived_factors_follow_the_texture_but_sampling_weights_stay_the_means() {
        let template = Plastic::new(1.5, Vec3::splat(0.5), Vec3::ONE, false);
        let m = Material::textured(Bsdf::Plastic(template), &[("diffuse_reflectance".to_string(), 0)], range(1.0)).unwrap();
        let b = m.bsdf_at(|_, p| if let ParamMut::Rgb(r) = p { *r = Vec3::splat(0.2) });
        let direct = Bsdf::Plastic(Plastic::new(1.5, Vec3::splat(0.2), Vec3::ONE, false));
        let (wo, wi) = (Vec3::new(0.3, 0.1, 0.9).normalize(), Vec3::new(-0.2, 0.4, 0.8).normalize());
        let mode = crate::bsdf::TransportMode::Radiance;
        assert_eq!(b.f(wo, wi, mode), direct.f(wo, wi, mode));
        // The lobe choice keeps the mean's weight: pdf_w differs from a plastic built at 0.2.
        assert_eq!(b.pdf_w(wo, wi), m.template().pdf_w(wo, wi));
        assert_ne!(b.pdf_w(wo, wi), direct.pdf_w(wo, wi));
    }

    #[test]
    fn facts_count_a_parameter_that_is_nonzero_somewhere() {
        // A black template (mean 0 would be wrong: the texture's maximum decides).
        let m = Material::textured(diffuse(0.0), &[("reflectance".to_string(), 0)], range(0.8)).unwrap();
        assert!(m.facts().has_non_delta);
        let black = Material::textured(diffuse(0.0), &[("reflectance".to_string(), 0)], range(0.0)).unwrap();
        assert!(!black.facts().has_non_delta);
        // A textured blend weight keeps both components: a mirror in bsdf_1 still counts as a delta lobe.
        let mirror = Bsdf::Conductor(crate::bsdf::Conductor { specular_reflectance: Vec3::ONE, eta_k: None });
        let blend = Bsdf::Blend(Blend { weight: 0.0, bsdf_0: Box::new(diffuse(0.5)), bsdf_1: Box::new(mirror) });
        assert!(!Material::constant(blend.clone()).facts().has_delta);
        let m = Material::textured(blend, &[("weight".to_string(), 0)], range(1.0)).unwrap();
        assert!(m.facts().has_delta && m.facts().has_non_delta);
    }
}

//! Surface scattering: a closed enum of BSDFs, evaluated and sampled in the local shading frame
//! (normal = +z, `crate::math::Frame`). All directions point away from the surface.
//!
//! Conventions (SmallVCM-style names; the MIS weights that rely on them: docs/method.md §4):
//! - `f(wo, wi)` is the BSDF value **without** the cosine and covers non-delta lobes only.
//! - `pdf_w(wo, wi)` is the solid-angle density with which [`Bsdf::sample`] produces `wi` through its
//!   non-delta lobes — for a blend the mixture over its components, exactly as sampled. `sample` computes the
//!   pdf it reports by calling `pdf_w` (one code path per pdf), so MIS weights
//!   computed from either side agree bit for bit.
//! - Delta lobes (smooth conductor, smooth dielectric) are only reachable through `sample`; their
//!   [`BsdfSample::pdf_w`] is the discrete probability of having chosen the lobe.
//! - One-sided reflection, as in Mitsuba 3: `Diffuse`, `Conductor`, `RoughConductor`, `Plastic`,
//!   `RoughPlastic` (and Mitsuba 0.6's `Phong` and `Ward`, as 0.6's) reflect only when
//!   `wo` and `wi` are both above the surface (+z); below, `f = 0`, `pdf_w = 0` and `sample → None`.
//!   `TwoSided` (Mitsuba's `twosided`) mirrors a configuration below the surface to +z, so its inner BSDF
//!   reflects on both sides; the inner BSDF must not transmit (the scene loader rejects dielectrics there).
//!   `Dielectric` and `RoughDielectric`: `wo.z > 0` is outside, the interior (index `eta` relative to the
//!   exterior) is −z; `RoughDielectric`'s refraction is a non-delta lobe (`f` and `pdf_w` across the surface).
//! - `Principled` (Mitsuba 3's `principled`): its diffuse, sheen and clearcoat lobes reflect from the front
//!   only, its main specular lobe on both sides; with a transmitting share (`spec_trans`) it refracts as
//!   `RoughDielectric` does (interior −z), without one nothing scatters from behind. `PrincipledThin`
//!   (`principledthin`) is a sheet: the same from either side, its transmission unbent.
//! - `NormalMap` and `BumpMap` (Mitsuba's `normalmap`, `bumpmap`) evaluate their nested BSDF in a frame
//!   perturbed at the hit (`perturbed`): the material layer sets the perturbation from a texture and the
//!   hit's geometry; they are not reciprocal (nor are Mitsuba's).
//! - Directions in the tangent plane (`wo.z == 0` or `wi.z == 0`) scatter nothing: `f = 0`, `pdf_w = 0`,
//!   `sample → None`. Nothing returns NaN for unit, finite inputs.
//!
//! **One file per BSDF type** (Mitsuba 3's one file per plugin; pbrt-v4's `Create` reading its own
//! parameters): the type, its [`Model`] (evaluation and sampling) and its `PLUGIN` — Mitsuba's name, the
//! keys it takes with their defaults and checks, read through [`crate::props::Props`] by its constructor,
//! and the scene-file snippet in its docs. The types are listed once, in the invocation of
//! `bsdf_types!` below, which generates the enum, its dispatch and [`PLUGINS`], the list the scene
//! readers (TOML and XML), `info` and the XML reader's report of unsupported plugins all read. A new BSDF
//! type is a new file and its line there.

mod at_wo;
mod blend;
mod bumpmap;
mod conductor;
mod conductor_table;
mod dielectric;
mod diffuse;
mod ior;
mod mask;
mod microfacet;
mod normalmap;
mod null;
mod params;
mod perturbed;
mod phong;
mod plastic;
mod pplastic;
mod principled;
mod principled_lobes;
mod principledthin;
mod rough_coating;
mod roughconductor;
mod roughdielectric;
mod roughplastic;
mod thindielectric;
mod twosided;
mod ward;
#[cfg(test)]
mod tests;

pub use at_wo::BsdfAtWo;
pub use params::{ParamMut, ParamVisitor};
pub use perturbed::{FrameRule, HitFrame, Perturbation, Perturbed};
pub use bumpmap::BumpMap;
pub use normalmap::NormalMap;
pub use conductor::{fresnel_conductor, fresnel_conductor_rgb};
pub use microfacet::{Microfacet, MicrofacetType};
pub use dielectric::fresnel_dielectric;
pub use blend::Blend;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use mask::Mask;
pub use null::Null;
pub use phong::Phong;
pub use plastic::Plastic;
pub use principled::{Principled, SamplingRates};
pub use principledthin::{PrincipledThin, ThinSamplingRates};
pub use roughconductor::RoughConductor;
pub use roughdielectric::RoughDielectric;
pub use pplastic::PPlastic;
pub use roughplastic::RoughPlastic;
pub use rough_coating::RoughCoating;
pub use thindielectric::ThinDielectric;
pub use twosided::TwoSided;
pub use ward::{Ward, WardVariant};

use crate::math::{Vec2, Vec3};

/// What every BSDF type implements, for inputs the dispatch of [`Bsdf`] has checked (`wo` finite and not
/// in the tangent plane; for the evaluations also `wi`): the conventions of the module documentation. The
/// defaults are those of a type without the lobe or the property: no non-delta lobe (`f = 0`, `pdf_w = 0`),
/// no choice between lobes, no delta lobe, no transmission.
pub(crate) trait Model {
    /// `f` without the cosine, non-delta lobes only: by default the `f` of [`Model::f_pdf`].
    #[inline]
    fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        self.f_pdf(wo, wi, mode).0
    }
    /// `(f, pdf_w)`, bit-identical to `(f, pdf_w)` computed apart.
    #[inline]
    fn f_pdf(&self, _wo: Vec3, _wi: Vec3, _mode: TransportMode) -> (Vec3, f32) {
        (Vec3::ZERO, 0.0)
    }
    /// Solid-angle density of sampling `wi` through the non-delta lobes.
    #[inline]
    fn pdf_w(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }
    /// One sampled direction (see [`Bsdf::sample`]).
    fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample>;
    /// Whether `sample` reads `u_lobe`.
    fn chooses_lobe(&self) -> bool {
        false
    }
    /// Any delta lobe that can be sampled.
    fn has_delta(&self) -> bool {
        false
    }
    /// Any non-delta lobe that can be sampled and reflects something (see [`Bsdf::has_non_delta`]).
    fn has_non_delta(&self) -> bool;
    /// Whether some lobe transmits.
    fn transmits(&self) -> bool {
        false
    }
    /// Whether the response turns with the shading frame's tangent about the normal (see
    /// [`Bsdf::anisotropic`]); by default not.
    fn anisotropic(&self) -> bool {
        false
    }
    /// The parameters a texture can drive and the nested bsdfs, in a fixed order (module `params`); by
    /// default none.
    fn visit_params(&mut self, _visitor: &mut dyn ParamVisitor) {}
    /// Recomputes what the type derives from its parameters at construction, after the material layer set
    /// some of them; by default nothing.
    fn params_changed(&mut self) {}
    /// The diffuse reflectance seen from `wo` (the `albedo` AOV; Mitsuba 3's
    /// `BSDF::eval_diffuse_reflectance`, src/render/bsdf.cpp): by default Mitsuba's rule, `π·f(wo, n)` —
    /// the BSDF lit along the normal, which is the reflectance of a Lambertian lobe and 0 for delta
    /// lobes; types with a diffuse parameter return it, as Mitsuba's `diffuse` and `plastic` do.
    fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
        self.f(wo, Vec3::Z, TransportMode::Radiance) * std::f32::consts::PI
    }
}

/// A BSDF type as the scene files name it: its name, keys (nested BSDFs among them) and constructor.
pub(crate) type Plugin = crate::props::Plugin<Bsdf, Bsdf>;

/// The closed enum of BSDFs, its dispatch to each type's [`Model`] (written once, here) and the list of
/// their [`Plugin`]s, from one list: `Variant(module::Type)`. A new BSDF type is a file (its type, its
/// `Model`, its `PLUGIN`) and its line in that list.
macro_rules! bsdf_types {
    ($($variant:ident($module:ident::$ty:ident),)*) => {
        /// A BSDF (conventions: the module documentation above). Parameters are validated by the
        /// constructors of the types (`PLUGIN`); the evaluation routines stay NaN-free for any finite
        /// parameters.
        #[derive(Clone, Debug, PartialEq)]
        pub enum Bsdf {
            $($variant($module::$ty),)*
        }

        /// Every BSDF type, in the order of the enum.
        pub(crate) const PLUGINS: &[&Plugin] = &[$(&$module::PLUGIN,)*];

        impl Bsdf {
            /// The Mitsuba plugin name of the BSDF's type.
            #[must_use]
            pub fn type_name(&self) -> &'static str {
                match self {
                    $(Bsdf::$variant(_) => $module::PLUGIN.name,)*
                }
            }

        }

        /// Static dispatch of every [`Model`] method to the variant's type (each arm a direct call, inlined).
        impl Model for Bsdf {
            #[inline]
            fn f(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
                match self { $(Bsdf::$variant(m) => m.f(wo, wi, mode),)* }
            }
            #[inline]
            fn f_pdf(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
                match self { $(Bsdf::$variant(m) => m.f_pdf(wo, wi, mode),)* }
            }
            #[inline]
            fn pdf_w(&self, wo: Vec3, wi: Vec3) -> f32 {
                match self { $(Bsdf::$variant(m) => m.pdf_w(wo, wi),)* }
            }
            #[inline]
            fn sample(&self, wo: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
                match self { $(Bsdf::$variant(m) => m.sample(wo, u_lobe, u_dir, mode),)* }
            }
            fn chooses_lobe(&self) -> bool {
                match self { $(Bsdf::$variant(m) => m.chooses_lobe(),)* }
            }
            fn has_delta(&self) -> bool {
                match self { $(Bsdf::$variant(m) => m.has_delta(),)* }
            }
            fn has_non_delta(&self) -> bool {
                match self { $(Bsdf::$variant(m) => m.has_non_delta(),)* }
            }
            fn transmits(&self) -> bool {
                match self { $(Bsdf::$variant(m) => m.transmits(),)* }
            }
            fn anisotropic(&self) -> bool {
                match self { $(Bsdf::$variant(m) => m.anisotropic(),)* }
            }
            fn visit_params(&mut self, visitor: &mut dyn ParamVisitor) {
                match self { $(Bsdf::$variant(m) => m.visit_params(visitor),)* }
            }
            fn params_changed(&mut self) {
                match self { $(Bsdf::$variant(m) => m.params_changed(),)* }
            }
            fn diffuse_reflectance(&self, wo: Vec3) -> Vec3 {
                match self { $(Bsdf::$variant(m) => m.diffuse_reflectance(wo),)* }
            }
        }
    };
}

bsdf_types! {
    Diffuse(diffuse::Diffuse),
    Conductor(conductor::Conductor),
    RoughConductor(roughconductor::RoughConductor),
    Dielectric(dielectric::Dielectric),
    RoughDielectric(roughdielectric::RoughDielectric),
    ThinDielectric(thindielectric::ThinDielectric),
    Plastic(plastic::Plastic),
    RoughPlastic(roughplastic::RoughPlastic),
    PPlastic(pplastic::PPlastic),
    Principled(principled::Principled),
    PrincipledThin(principledthin::PrincipledThin),
    Blend(blend::Blend),
    TwoSided(twosided::TwoSided),
    Mask(mask::Mask),
    Null(null::Null),
    NormalMap(normalmap::NormalMap),
    BumpMap(bumpmap::BumpMap),
    Phong(phong::Phong),
    Ward(ward::Ward),
}

/// The plugin of the BSDF type Mitsuba names `name`.
#[must_use]
pub(crate) fn plugin(name: &str) -> Option<&'static Plugin> {
    crate::props::find(PLUGINS, name)
}

/// The configuration mirrored through the tangent plane.
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

/// Which quantity a path carries: radiance (eye paths) or importance (photons). They differ only in
/// the `1/η²` scaling of radiance refracted through a dielectric (Veach 1997 §5.2; pbrt-v4 §9.5.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// One sampled scattering direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi_local: Vec3,
    /// f·|cos θi| / pdf for non-delta samples; the delta lobe's throughput / its selection probability for delta.
    pub weight: Vec3,
    /// Solid-angle pdf of the whole sampler for non-delta samples (mixture pdf for a blend: the same value
    /// `pdf_w()` returns). For delta samples: the discrete probability of having chosen that delta lobe.
    pub pdf_w: f32,
    pub delta: bool,
    /// The lobe of `null` or of a `mask`'s transparent part (`null::pass_through`): the ray goes on
    /// unchanged and nothing scattered (Mitsuba's `BSDFFlags::Null`; `hide_emitters` reads it).
    pub pass_through: bool,
}

/// The largest f32 below 1: remapped uniform numbers are clamped to it to stay in `[0, 1)`.
pub(crate) const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON * 0.5;

/// Mirror direction about the normal (+z) in the local frame.
#[inline]
#[must_use]
pub(crate) fn reflect_z(w: Vec3) -> Vec3 {
    Vec3::new(-w.x, -w.y, w.z)
}

/// A usable outgoing direction: finite and not in the tangent plane.
#[inline]
#[must_use]
pub(crate) fn valid_wo(wo: Vec3) -> bool {
    wo.is_finite() && wo.z != 0.0
}

impl Bsdf {
    /// BSDF value without the cosine, non-delta lobes only (0 for pure delta BSDFs).
    #[must_use]
    pub fn f(&self, wo_local: Vec3, wi_local: Vec3, mode: TransportMode) -> Vec3 {
        if !valid_wo(wo_local) || !wi_local.is_finite() || wi_local.z == 0.0 {
            return Vec3::ZERO;
        }
        Model::f(self, wo_local, wi_local, mode)
    }

    /// `(f, pdf_w)` in one evaluation, bit-identical to `(self.f(..), self.pdf_w(..))` but sharing the
    /// work of both (GGX half vector, `D`, `G1(wo)`): for loops that need both, such as the MIS-weighted
    /// density estimate and NEE.
    #[must_use]
    pub fn f_pdf(&self, wo_local: Vec3, wi_local: Vec3, mode: TransportMode) -> (Vec3, f32) {
        checked_f_pdf(self, wo_local, wi_local, mode)
    }

    /// Solid-angle density of sampling `wi_local` through the non-delta lobes (the mixture as sampled).
    #[must_use]
    pub fn pdf_w(&self, wo_local: Vec3, wi_local: Vec3) -> f32 {
        if !valid_wo(wo_local) || !wi_local.is_finite() || wi_local.z == 0.0 {
            return 0.0;
        }
        Model::pdf_w(self, wo_local, wi_local)
    }

    /// Samples an incident direction. `u_lobe` chooses among lobes/components, `u_dir` the direction
    /// within a lobe. `None` when nothing is scattered (tangent `wo`, a sample below the horizon, …).
    #[must_use]
    pub fn sample(&self, wo_local: Vec3, u_lobe: f32, u_dir: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        if !valid_wo(wo_local) {
            return None;
        }
        let s = Model::sample(self, wo_local, u_lobe, u_dir, mode)?;
        debug_assert!(s.weight.is_finite() && s.weight.min_element() >= 0.0, "bad BSDF weight {s:?}");
        debug_assert!(s.pdf_w > 0.0 && s.pdf_w.is_finite(), "bad BSDF pdf {s:?}");
        Some(s)
    }

    /// Whether [`Bsdf::sample`] reads `u_lobe`: a choice between lobes (a dielectric's reflection or
    /// refraction, a blend's component). Where it does not, the caller may pass any value and spare the
    /// sampler a dimension (the path tracer does).
    #[must_use]
    pub fn chooses_lobe(&self) -> bool {
        Model::chooses_lobe(self)
    }

    /// Any delta lobe that can be sampled (Conductor, Dielectric, or a blend with one at non-zero weight).
    #[must_use]
    pub fn has_delta(&self) -> bool {
        Model::has_delta(self)
    }

    /// Any non-delta lobe that can be sampled and reflects something. A black lobe (`reflectance = 0`,
    /// the usual material of an area light) scatters nothing, so neither NEE, nor the density estimate, nor
    /// storing photons there can add anything: eye paths and photons treat such a surface as having no
    /// non-delta lobe (the same rule on both sides, so the chain counts of T1 and T2 agree). Photons stored
    /// on a light 10³ times the scene's size made the photon map's extent, and with it the floor of ΔA,
    /// that large (`caustic::min_delta_area`).
    #[must_use]
    pub fn has_non_delta(&self) -> bool {
        Model::has_non_delta(self)
    }

    /// Whether some lobe transmits (crosses the surface): a dielectric, alone or in a blend.
    #[must_use]
    pub fn transmits(&self) -> bool {
        Model::transmits(self)
    }

    /// Whether the response turns with the shading frame's tangent about the normal: anisotropic roughness
    /// (`alpha_u ≠ alpha_v`, principled's `anisotropic > 0`), alone or in a blend, two-sided or masked BSDF.
    /// Such a BSDF is evaluated in Mitsuba's shading frame, whose tangent follows `∂p/∂u`
    /// (`Scene::interaction`); for every other BSDF the tangent's direction changes nothing. (A normal or bump
    /// map builds its own frame from `∂p/∂u`, whatever it wraps.)
    #[must_use]
    pub fn anisotropic(&self) -> bool {
        Model::anisotropic(self)
    }

    /// Walks the parameters a texture can drive and the nested bsdfs (module `params`).
    pub fn visit_params(&mut self, visitor: &mut dyn ParamVisitor) {
        Model::visit_params(self, visitor);
    }

    /// Recomputes what the BSDF derives from its parameters, after some were set through
    /// [`Bsdf::visit_params`] (nested bsdfs first).
    pub fn params_changed(&mut self) {
        Model::params_changed(self);
    }

    /// The diffuse reflectance seen from `wo_local` ([`Model::diffuse_reflectance`]; 0 for an unusable `wo`):
    /// the `albedo` AOV the denoiser reads.
    #[must_use]
    pub fn diffuse_reflectance(&self, wo_local: Vec3) -> Vec3 {
        if !valid_wo(wo_local) {
            return Vec3::ZERO;
        }
        Model::diffuse_reflectance(self, wo_local)
    }
}

/// [`Model::f_pdf`] behind the checks of [`Bsdf::f_pdf`]: `(0, 0)` for an unusable `wo` or `wi`.
#[inline]
fn checked_f_pdf(m: &(impl Model + ?Sized), wo: Vec3, wi: Vec3, mode: TransportMode) -> (Vec3, f32) {
    if !valid_wo(wo) || !wi.is_finite() || wi.z == 0.0 {
        return (Vec3::ZERO, 0.0);
    }
    m.f_pdf(wo, wi, mode)
}

/// Completes a non-delta sample whose direction `wi` was drawn by the sampler of `m`: the pdf is
/// `m`'s `pdf_w` and the weight `f·|cos θi| / pdf_w`, both from one `f_pdf` (bit-identical to `f` and
/// `pdf_w` apart, one evaluation instead of two).
fn non_delta_sample(m: &impl Model, wo: Vec3, wi: Vec3, mode: TransportMode) -> Option<BsdfSample> {
    let (f, pdf_w) = checked_f_pdf(m, wo, wi, mode);
    if !(pdf_w > 0.0 && pdf_w.is_finite()) {
        return None;
    }
    let weight = f * (wi.z.abs() / pdf_w);
    weight.is_finite().then_some(BsdfSample {
        wi_local: wi,
        weight,
        pdf_w,
        delta: false,
        pass_through: false,
    })
}

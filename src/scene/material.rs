//! Materials: `[bsdf.<name>]` tables and inline `bsdf = { ... }` tables → [`Bsdf`] values, with Mitsuba's
//! parameter names and defaults, range checks, and named references (cycles rejected).
//!
//! | type | keys (default) |
//! |---|---|
//! | `diffuse` | `reflectance` (0.5) |
//! | `conductor` | `specular_reflectance` (1), `material` ("none" = perfect mirror, or a named metal) or `eta` + `k` (both) |
//! | `roughconductor` | `alpha` (0.1), `distribution` (`"beckmann"`, Mitsuba's default, or `"ggx"`), `sample_visible` (true), and the conductor's keys |
//! | `dielectric` | `int_ior` (1.5046, "bk7"), `ext_ior` (1.000277, "air"): numbers or Mitsuba's IOR names |
//! | `blendbsdf` | `weight` (0.5), `bsdf_0`, `bsdf_1` (names or inline tables; result (1−w)·bsdf_0 + w·bsdf_1) |
//! | `twosided` | `bsdf` (a name or inline table of a non-transmitting bsdf; reflects on both sides) |
//!
//! Colours are one number (gray) or `[r, g, b]`; reflectances must lie in [0, 1]. Reflecting materials are
//! one-sided, as in Mitsuba: they reflect light arriving on the side the shading normal points to, and are
//! black from behind unless wrapped in `twosided`. Named metals (`material = "Au"`, ...) are the RGB
//! `eta`/`k` of Mitsuba's tables (`crate::bsdf::CONDUCTORS`, with their sources). Shapes without a `bsdf`
//! get Mitsuba's default, diffuse with reflectance 0.5, or black diffuse when the shape emits (as Mitsuba).

use std::collections::{BTreeMap, HashMap};

use super::desc::{BsdfDesc, BsdfRef, BsdfType, Ior};
use super::error::{ErrorContext, SceneError};
use super::plugins::{check_keys, Role};
use super::spans::join_key;
use crate::bsdf::{Bsdf, Microfacet, MicrofacetType, CONDUCTORS};
use crate::math::Vec3;

/// Mitsuba's named indices of refraction (`mitsuba/render/ior.h`).
const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", 1.000277),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", 1.5046),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// Deepest chain of named bsdfs referring to each other (blends of blends ...).
const MAX_NESTING: usize = 64;

/// Mitsuba's default material for shapes without a bsdf.
pub(crate) const DEFAULT_BSDF: Bsdf = Bsdf::Diffuse {
    reflectance: Vec3::splat(0.5),
};

/// Mitsuba's default material for an emitting shape without a bsdf: black diffuse (`Shape::Shape`,
/// src/render/shape.cpp: "reflectance" 0 when the shape has an emitter).
pub(crate) const DEFAULT_EMITTER_BSDF: Bsdf = Bsdf::Diffuse {
    reflectance: Vec3::ZERO,
};

/// Resolves bsdf references and hands out material indices: one per referenced named bsdf, one per inline
/// table, and one shared index for the default material.
pub(crate) struct Materials<'a> {
    named: &'a BTreeMap<String, BsdfDesc>,
    resolved: HashMap<String, Bsdf>,
    index_of_name: HashMap<String, u32>,
    default_index: Option<u32>,
    default_emitter_index: Option<u32>,
    pub(crate) bsdfs: Vec<Bsdf>,
}

impl<'a> Materials<'a> {
    /// Validates every `[bsdf.<name>]` table (used or not).
    pub(crate) fn new(ctx: &ErrorContext, named: &'a BTreeMap<String, BsdfDesc>) -> Result<Self, SceneError> {
        let mut m = Self {
            named,
            resolved: HashMap::new(),
            index_of_name: HashMap::new(),
            default_index: None,
            default_emitter_index: None,
            bsdfs: Vec::new(),
        };
        for name in named.keys() {
            m.resolve_name(ctx, &join_key("bsdf", name), name, &mut Vec::new())?;
        }
        Ok(m)
    }

    /// The material index for a shape's `bsdf` (at `key`), or, when absent, the default material of a
    /// shape that is `emitting` or not.
    pub(crate) fn index_for(&mut self, ctx: &ErrorContext, key: &str, r: Option<&BsdfRef>, emitting: bool) -> Result<u32, SceneError> {
        match r {
            None => {
                let (slot, bsdf) = if emitting {
                    (self.default_emitter_index, DEFAULT_EMITTER_BSDF)
                } else {
                    (self.default_index, DEFAULT_BSDF)
                };
                if let Some(i) = slot {
                    return Ok(i);
                }
                self.bsdfs.push(bsdf);
                let i = (self.bsdfs.len() - 1) as u32;
                *(if emitting { &mut self.default_emitter_index } else { &mut self.default_index }) = Some(i);
                Ok(i)
            }
            Some(BsdfRef::Name(name)) => {
                if let Some(&i) = self.index_of_name.get(name) {
                    return Ok(i);
                }
                let bsdf = self.resolve_name(ctx, key, name, &mut Vec::new())?;
                self.bsdfs.push(bsdf);
                let i = (self.bsdfs.len() - 1) as u32;
                self.index_of_name.insert(name.clone(), i);
                Ok(i)
            }
            Some(BsdfRef::Inline(desc)) => {
                let bsdf = self.resolve_desc(ctx, key, desc, &mut Vec::new())?;
                self.bsdfs.push(bsdf);
                Ok((self.bsdfs.len() - 1) as u32)
            }
        }
    }

    /// The bsdf named `name`, referenced at `key`; `stack` holds the names being resolved (cycle check).
    fn resolve_name(&mut self, ctx: &ErrorContext, key: &str, name: &str, stack: &mut Vec<String>) -> Result<Bsdf, SceneError> {
        if let Some(b) = self.resolved.get(name) {
            return Ok(b.clone());
        }
        let Some(desc) = self.named.get(name) else {
            let known: Vec<&str> = self.named.keys().map(String::as_str).collect();
            let known = if known.is_empty() {
                "none are defined".to_string()
            } else {
                format!("defined: {}", known.join(", "))
            };
            return Err(ctx.key_error(
                key,
                format!("unknown bsdf `{name}` (named bsdfs are [bsdf.<name>] tables; {known})"),
            ));
        };
        if stack.len() >= MAX_NESTING {
            return Err(ctx.key_error(key, format!("named bsdfs nest deeper than {MAX_NESTING} levels")));
        }
        if stack.iter().any(|s| s == name) {
            stack.push(name.to_string());
            return Err(ctx.key_error(key, format!("bsdf references form a cycle: {}", stack.join(" → "))));
        }
        stack.push(name.to_string());
        let bsdf = self.resolve_desc(ctx, &join_key("bsdf", name), desc, stack)?;
        stack.pop();
        self.resolved.insert(name.to_string(), bsdf.clone());
        Ok(bsdf)
    }

    fn resolve_ref(&mut self, ctx: &ErrorContext, key: &str, r: &BsdfRef, stack: &mut Vec<String>) -> Result<Bsdf, SceneError> {
        match r {
            BsdfRef::Name(name) => self.resolve_name(ctx, key, name, stack),
            BsdfRef::Inline(desc) => self.resolve_desc(ctx, key, desc, stack),
        }
    }

    fn resolve_desc(&mut self, ctx: &ErrorContext, key: &str, d: &BsdfDesc, stack: &mut Vec<String>) -> Result<Bsdf, SceneError> {
        let present = [
            ("reflectance", d.reflectance.is_some()),
            ("specular_reflectance", d.specular_reflectance.is_some()),
            ("eta", d.eta.is_some()),
            ("k", d.k.is_some()),
            ("material", d.material.is_some()),
            ("alpha", d.alpha.is_some()),
            ("distribution", d.distribution.is_some()),
            ("sample_visible", d.sample_visible.is_some()),
            ("int_ior", d.int_ior.is_some()),
            ("ext_ior", d.ext_ior.is_some()),
            ("weight", d.weight.is_some()),
            ("bsdf_0", d.bsdf_0.is_some()),
            ("bsdf_1", d.bsdf_1.is_some()),
            ("bsdf", d.bsdf.is_some()),
        ];
        check_keys(ctx, key, Role::Bsdf, d.kind.name(), &present)?;
        let k = |name: &str| join_key(key, name);
        Ok(match d.kind {
            BsdfType::Diffuse => {
                let reflectance = d
                    .reflectance
                    .map_or(Ok(Vec3::splat(0.5)), |c| ctx.reflectance(&k("reflectance"), c.0))?;
                Bsdf::Diffuse { reflectance }
            }
            BsdfType::Conductor | BsdfType::RoughConductor => {
                let specular_reflectance = d
                    .specular_reflectance
                    .map_or(Ok(Vec3::ONE), |c| ctx.reflectance(&k("specular_reflectance"), c.0))?;
                let eta_k = match (d.eta, d.k) {
                    (None, None) => named_conductor(ctx, &k("material"), d.material.as_deref())?,
                    (Some(_), _) | (_, Some(_)) if d.material.is_some() => {
                        return Err(ctx.key_error(&k("material"), "give either `material` or `eta` and `k`, not both"))
                    }
                    (Some(eta), Some(kk)) => {
                        let eta = ctx.finite3(&k("eta"), eta.0)?;
                        if eta.min_element() <= 0.0 {
                            return Err(ctx.key_error(&k("eta"), format!("every component of eta must be > 0, got {eta}")));
                        }
                        let kk = ctx.finite3(&k("k"), kk.0)?;
                        if kk.min_element() < 0.0 {
                            return Err(ctx.key_error(&k("k"), format!("every component of k must be ≥ 0, got {kk}")));
                        }
                        Some((eta, kk))
                    }
                    (Some(_), None) => return Err(ctx.key_error(&k("eta"), "give both `eta` and `k`, or neither (perfect mirror)")),
                    (None, Some(_)) => return Err(ctx.key_error(&k("k"), "give both `eta` and `k`, or neither (perfect mirror)")),
                };
                if d.kind == BsdfType::Conductor {
                    Bsdf::Conductor {
                        specular_reflectance,
                        eta_k,
                    }
                } else {
                    let kind = match d.distribution.as_deref() {
                        None | Some("beckmann") => MicrofacetType::Beckmann,
                        Some("ggx") => MicrofacetType::Ggx,
                        Some(other) => {
                            return Err(ctx.key_error(
                                &k("distribution"),
                                format!("unknown distribution {other:?} (\"beckmann\", the default, or \"ggx\")"),
                            ))
                        }
                    };
                    let alpha = d.alpha.map_or(Ok(0.1), |a| ctx.positive(&k("alpha"), a, "the roughness alpha"))?;
                    Bsdf::RoughConductor {
                        distribution: Microfacet {
                            kind,
                            alpha,
                            sample_visible: d.sample_visible.unwrap_or(true),
                        },
                        specular_reflectance,
                        eta_k,
                    }
                }
            }
            BsdfType::Dielectric => {
                let int_ior = ior(ctx, &k("int_ior"), d.int_ior.as_ref(), 1.5046)?;
                let ext_ior = ior(ctx, &k("ext_ior"), d.ext_ior.as_ref(), 1.000277)?;
                Bsdf::Dielectric { eta: int_ior / ext_ior }
            }
            BsdfType::BlendBsdf => {
                let weight = d
                    .weight
                    .map_or(Ok(0.5), |w| ctx.in_range(&k("weight"), w, 0.0, 1.0, "the blend weight"))?;
                let (Some(b0), Some(b1)) = (&d.bsdf_0, &d.bsdf_1) else {
                    let missing = if d.bsdf_0.is_none() { "bsdf_0" } else { "bsdf_1" };
                    return Err(ctx.key_error(key, format!("blendbsdf needs `bsdf_0` and `bsdf_1`; `{missing}` is missing")));
                };
                let bsdf_0 = Box::new(self.resolve_ref(ctx, &k("bsdf_0"), b0, stack)?);
                let bsdf_1 = Box::new(self.resolve_ref(ctx, &k("bsdf_1"), b1, stack)?);
                Bsdf::Blend { weight, bsdf_0, bsdf_1 }
            }
            BsdfType::TwoSided => {
                let Some(inner) = &d.bsdf else {
                    return Err(ctx.key_error(key, "twosided needs `bsdf` (the bsdf used on both sides)"));
                };
                let inner = self.resolve_ref(ctx, &k("bsdf"), inner, stack)?;
                if inner.transmits() {
                    return Err(ctx.key_error(&k("bsdf"), "twosided cannot hold a transmitting bsdf (dielectric), as in Mitsuba"));
                }
                Bsdf::TwoSided(Box::new(inner))
            }
        })
    }
}

/// `eta`/`k` of Mitsuba's named conductor `name` (at `key`); `None` (perfect mirror) for "none" or absent.
fn named_conductor(ctx: &ErrorContext, key: &str, name: Option<&str>) -> Result<Option<(Vec3, Vec3)>, SceneError> {
    match name {
        None | Some("none") => Ok(None),
        Some(name) => CONDUCTORS
            .iter()
            .find(|(n, _, _)| *n == name)
            .map(|(_, eta, k)| Some((Vec3::from_array(*eta), Vec3::from_array(*k))))
            .ok_or_else(|| {
                let names: Vec<&str> = CONDUCTORS.iter().map(|(n, _, _)| *n).collect();
                ctx.key_error(key, format!("unknown conductor {name:?}; known: none, {}", names.join(", ")))
            }),
    }
}

/// An index of refraction at `key`: a positive finite number or a name from Mitsuba's table.
fn ior(ctx: &ErrorContext, key: &str, v: Option<&Ior>, default: f32) -> Result<f32, SceneError> {
    match v {
        None => Ok(default),
        Some(Ior::Value(x)) => ctx.positive(key, *x, "an index of refraction"),
        Some(Ior::Name(name)) => IOR_TABLE
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|&(_, x)| x)
            .ok_or_else(|| {
                let names: Vec<&str> = IOR_TABLE.iter().map(|(n, _)| *n).collect();
                ctx.key_error(key, format!("unknown IOR name {name:?}; known: {}", names.join(", ")))
            }),
    }
}

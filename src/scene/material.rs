//! Materials: `[bsdf.<name>]` tables and inline `bsdf = { ... }` tables → [`Bsdf`] values. The reader
//! knows no BSDF type: it finds the type's plugin by its name (`crate::bsdf::PLUGINS`: each type's keys,
//! defaults and checks live in its own file), refuses keys the type does not take, resolves the nested
//! bsdfs the type names (references by name, cycles rejected, or inline tables) and hands the rest to the
//! type's constructor, whose errors it places at their keys. It also hands out material indices and gives
//! shapes without a `bsdf` Mitsuba's default: diffuse with reflectance 0.5, or black diffuse when the shape
//! emits.
//!
//! Reflecting materials are one-sided, as in Mitsuba: they reflect light arriving on the side the shading
//! normal points to, and are black from behind unless wrapped in `twosided`.

use std::cell::RefCell;
use std::rc::Rc;
use std::collections::{BTreeMap, HashMap};

use super::desc::{PluginDesc, BsdfRef};
use super::error::{ErrorContext, SceneError};
use super::plugins::{self, Role};
use super::spans::join_key;
use super::textures::Textures;
use crate::bsdf::{self, Bsdf, Diffuse};
use crate::material::Material;
use crate::texture::Texture;
use crate::math::Vec3;

/// Deepest chain of named bsdfs referring to each other (blends of blends ...).
const MAX_NESTING: usize = 64;

/// Mitsuba's default material for shapes without a bsdf.
pub(crate) const DEFAULT_BSDF: Bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::splat(0.5) });

/// Mitsuba's default material for an emitting shape without a bsdf: black diffuse (`Shape::Shape`,
/// src/render/shape.cpp: "reflectance" 0 when the shape has an emitter).
pub(crate) const DEFAULT_EMITTER_BSDF: Bsdf = Bsdf::Diffuse(Diffuse { reflectance: Vec3::ZERO });

/// A bsdf as read, before its material is made: the BSDF and the textures bound to its parameters, each by
/// its path relative to this bsdf (`crate::material::Material::textured`).
#[derive(Clone)]
struct Read {
    bsdf: Bsdf,
    bound: Vec<(String, u32)>,
}

impl Read {
    fn constant(bsdf: Bsdf) -> Self {
        Self { bsdf, bound: Vec::new() }
    }
}

/// Resolves bsdf references and hands out material indices: one per referenced named bsdf, one per inline
/// table, and one shared index for the default material.
pub(crate) struct Materials<'a> {
    named: &'a BTreeMap<String, PluginDesc>,
    resolved: HashMap<String, Read>,
    index_of_name: HashMap<String, u32>,
    default_index: Option<u32>,
    default_emitter_index: Option<u32>,
    /// Each material as read, with the key of the table it was read at.
    read: Vec<(String, Read)>,
    /// Behind a cell: the constructor of a bsdf resolves its nested bsdfs and its textures through two
    /// callbacks, both of which may load textures.
    textures: Rc<RefCell<Textures<'a>>>,
}

impl<'a> Materials<'a> {
    /// Validates every `[bsdf.<name>]` table (used or not); the named textures are `textures`.
    pub(crate) fn new(ctx: &ErrorContext, named: &'a BTreeMap<String, PluginDesc>, textures: Textures<'a>) -> Result<Self, SceneError> {
        let mut m = Self {
            named,
            resolved: HashMap::new(),
            index_of_name: HashMap::new(),
            default_index: None,
            default_emitter_index: None,
            read: Vec::new(),
            textures: Rc::new(RefCell::new(textures)),
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
                let i = self.push(key, Read::constant(bsdf));
                *(if emitting { &mut self.default_emitter_index } else { &mut self.default_index }) = Some(i);
                Ok(i)
            }
            Some(BsdfRef::Name(name)) => {
                if let Some(&i) = self.index_of_name.get(name) {
                    return Ok(i);
                }
                let read = self.resolve_name(ctx, key, name, &mut Vec::new())?;
                let i = self.push(&join_key("bsdf", name), read);
                self.index_of_name.insert(name.clone(), i);
                Ok(i)
            }
            Some(BsdfRef::Inline(desc)) => {
                let read = self.resolve_desc(ctx, key, desc, &mut Vec::new())?;
                Ok(self.push(key, read))
            }
        }
    }

    /// A texture on a property outside the materials (an area emitter's `radiance`), read by the materials'
    /// loader: an image a material and a light both use is decoded once. It is among the textures `finish`
    /// returns.
    pub(crate) fn texture(&mut self, ctx: &ErrorContext, at: &str, value: &toml::Value) -> Result<Texture, SceneError> {
        let mut textures = self.textures.borrow_mut();
        let (index, _) = textures.resolve(ctx, at, value)?;
        Ok(textures.get(index).clone())
    }

    fn push(&mut self, key: &str, read: Read) -> u32 {
        self.read.push((key.to_string(), read));
        (self.read.len() - 1) as u32
    }

    /// The materials, in the order of their indices, the textures they use and the bytes of those textures'
    /// images. A textured path that the BSDF type cannot texture is an error at that key.
    pub(crate) fn finish(self, ctx: &ErrorContext) -> Result<(Vec<Material>, Vec<Texture>, u64), SceneError> {
        let (textures, image_bytes) = Rc::into_inner(self.textures).expect("no bsdf is being read").into_inner().finish();
        let mut materials = Vec::with_capacity(self.read.len());
        for (key, Read { bsdf, bound }) in self.read {
            let kind = bsdf.type_name();
            let m = Material::textured(bsdf, &bound, |t| textures[t as usize].summary())
            .map_err(|e| {
                let list = if e.texturable.is_empty() { "none".to_string() } else { e.texturable.join(", ") };
                ctx.key_error(&join_key(&key, &e.path), format!("caustica's {kind} cannot take a texture here (the properties it can texture: {list})"))
            })?;
            materials.push(m);
        }
        Ok((materials, textures, image_bytes))
    }

    /// The bsdf named `name`, referenced at `key`; `stack` holds the names being resolved (cycle check).
    fn resolve_name(&mut self, ctx: &ErrorContext, key: &str, name: &str, stack: &mut Vec<String>) -> Result<Read, SceneError> {
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
        let read = self.resolve_desc(ctx, &join_key("bsdf", name), desc, stack)?;
        stack.pop();
        self.resolved.insert(name.to_string(), read.clone());
        Ok(read)
    }

    fn resolve_ref(&mut self, ctx: &ErrorContext, key: &str, r: &BsdfRef, stack: &mut Vec<String>) -> Result<Read, SceneError> {
        match r {
            BsdfRef::Name(name) => self.resolve_name(ctx, key, name, stack),
            BsdfRef::Inline(desc) => self.resolve_desc(ctx, key, desc, stack),
        }
    }

    /// The bsdf of table `d` at `key`, built by its type's constructor, with its textures and those of its
    /// nested bsdfs (their paths prefixed with the nested key).
    fn resolve_desc(&mut self, ctx: &ErrorContext, key: &str, d: &PluginDesc, stack: &mut Vec<String>) -> Result<Read, SceneError> {
        let textures = Rc::clone(&self.textures);
        let mut bound = Vec::new();
        let mut nested_bound = Vec::new();
        let bsdf = plugins::build_textured(
            ctx,
            key,
            Role::Bsdf,
            bsdf::PLUGINS,
            d,
            |at, value| {
                let r = BsdfRef::from_value(value).map_err(|m| ctx.key_error(at, m))?;
                let nested_key = at.rsplit('.').next().unwrap_or(at).to_string();
                let read = self.resolve_ref(ctx, at, &r, stack)?;
                nested_bound.extend(read.bound.into_iter().map(|(path, t)| (format!("{nested_key}.{path}"), t)));
                Ok(read.bsdf)
            },
            |at, k, value| {
                let (index, seen) = textures.borrow_mut().resolve(ctx, at, value)?;
                bound.push((k.to_string(), index));
                Ok(seen)
            },
        )?;
        bound.extend(nested_bound);
        Ok(Read { bsdf, bound })
    }
}

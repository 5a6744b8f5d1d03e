//! Textures as the scene files give them, read for the material reader (`material`) and an area emitter's
//! `radiance` (`build`, through the same loader): a property whose value is a texture, inline or by the
//! name of a `[texture.<name>]` table.
//!
//! ```toml
//! [texture.wood]
//! type = "bitmap"
//! filename = "textures/wood.jpg"          # relative to the scene file
//! to_uv = { scale = [4, 4, 1] }           # a to_world-style transform of (u, v); Mitsuba's `to_uv`
//!
//! [bsdf.floor]
//! type = "diffuse"
//! reflectance = { texture = "wood" }      # a named texture
//!
//! [bsdf.tiles]
//! type = "diffuse"
//! reflectance = { type = "checkerboard", color0 = 0.2, color1 = 0.8 }   # an inline one
//!
//! [[shape]]
//! type = "rectangle"
//! emitter = { type = "area", radiance = { type = "bitmap", filename = "sky.exr" } }   # a textured light
//! ```
//!
//! Mitsuba XML's `<texture>` elements and `<ref>`s to them become the same tables (`xml::convert`). Each
//! texture the materials and lights use is loaded once (a named one however many properties use it; an
//! image file once however many textures name it, `texture::ImageCache`); a named texture nothing uses is
//! checked but not loaded. Its keys, defaults and checks are the texture type's own (`crate::texture::PLUGINS`);
//! `to_uv` is read here, by the transform rules of every `to_world` (`transform`), and its 2-D part kept
//! as Mitsuba keeps it (`Transform4f::extract`: rows and columns x, y and the translation).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use serde::Deserialize;

use super::desc::{PluginDesc, ToWorld};
use super::error::{ErrorContext, SceneError};
use super::plugins::{self, Role};
use super::spans::join_key;
use super::transform::to_world_matrix;
use crate::math::{Mat3, Vec3};
use crate::props::Textured;
use crate::texture::{self, ImageCache, Texture, TextureSpec};

/// The textures the materials use, and what the reader needs to load more.
pub(crate) struct Textures<'a> {
    named: &'a BTreeMap<String, PluginDesc>,
    base_dir: &'a Path,
    cache: ImageCache,
    index_of_name: HashMap<String, u32>,
    textures: Vec<Texture>,
}

impl<'a> Textures<'a> {
    /// Checks every `[texture.<name>]` table's type and keys (used or not); loads nothing yet.
    pub(crate) fn new(ctx: &ErrorContext, named: &'a BTreeMap<String, PluginDesc>, base_dir: &'a Path) -> Result<Self, SceneError> {
        for (name, d) in named {
            spec(ctx, &join_key("texture", name), d)?;
        }
        Ok(Self { named, base_dir, cache: ImageCache::default(), index_of_name: HashMap::new(), textures: Vec::new() })
    }

    /// The texture `value` at key path `at` describes (module documentation): its index among the
    /// loaded textures and what a plugin's constructor sees of it.
    pub(crate) fn resolve(&mut self, ctx: &ErrorContext, at: &str, value: &toml::Value) -> Result<(u32, Textured), SceneError> {
        let table = value.as_table().expect("props::is_texture holds a table");
        let index = match table.get("texture") {
            Some(name) => {
                let (Some(name), 1) = (name.as_str(), table.len()) else {
                    return Err(ctx.key_error(at, "a reference to a texture is `{ texture = \"<name>\" }`, with nothing beside the name"));
                };
                match self.index_of_name.get(name) {
                    Some(&i) => i,
                    None => {
                        let Some(d) = self.named.get(name) else {
                            let known: Vec<&str> = self.named.keys().map(String::as_str).collect();
                            let known = if known.is_empty() { "none are defined".to_string() } else { format!("defined: {}", known.join(", ")) };
                            return Err(ctx.key_error(&join_key(at, "texture"), format!("unknown texture `{name}` (named textures are [texture.<name>] tables; {known})")));
                        };
                        let i = self.load(ctx, &join_key("texture", name), d)?;
                        self.index_of_name.insert(name.to_string(), i);
                        i
                    }
                }
            }
            None => {
                let d = PluginDesc::from_table(table.clone()).map_err(|m| ctx.key_error(at, m))?;
                self.load(ctx, at, &d)?
            }
        };
        Ok((index, self.textures[index as usize].summary()))
    }

    /// Loads the texture `d` at `key` describes.
    fn load(&mut self, ctx: &ErrorContext, key: &str, d: &PluginDesc) -> Result<u32, SceneError> {
        let (spec, to_uv) = spec(ctx, key, d)?;
        let texture = spec.load(self.base_dir, &mut self.cache).map_err(|e| ctx.key_error(&join_key(key, "filename"), e.to_string()))?;
        self.textures.push(texture.with_to_uv(to_uv));
        Ok((self.textures.len() - 1) as u32)
    }

    /// Loaded texture `index`.
    pub(crate) fn get(&self, index: u32) -> &Texture {
        &self.textures[index as usize]
    }

    /// The loaded textures, in the order of their indices, and the bytes their images' texels take (each
    /// image once, however many textures read it).
    pub(crate) fn finish(self) -> (Vec<Texture>, u64) {
        let bytes = self.cache.memory_bytes();
        (self.textures, bytes)
    }
}

/// The texture's description, checked by its type, and its `to_uv` (identity when absent).
fn spec(ctx: &ErrorContext, key: &str, d: &PluginDesc) -> Result<(TextureSpec, Mat3), SceneError> {
    let spec = plugins::build(ctx, key, Role::Texture, texture::PLUGINS, d, |_, _| Ok(()))?;
    let to_uv = match d.props.get("to_uv") {
        None => Mat3::IDENTITY,
        Some(v) => {
            let at = join_key(key, "to_uv");
            let to_world = ToWorld::deserialize(v.clone()).map_err(|e| ctx.key_error(&at, e.to_string()))?;
            let m = to_world_matrix(ctx, &at, Some(&to_world))?;
            // Mitsuba's `extract`: the x and y rows and columns and the translation.
            Mat3::from_cols(Vec3::new(m.x_axis.x, m.x_axis.y, 0.0), Vec3::new(m.y_axis.x, m.y_axis.y, 0.0), Vec3::new(m.w_axis.x, m.w_axis.y, 1.0))
        }
    };
    Ok((spec, to_uv))
}

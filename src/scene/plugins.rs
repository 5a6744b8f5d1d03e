//! The plugin types caustica renders and the keys each takes, behind the key checks of both scene formats
//! (a key that does not apply to its plugin's type is an error naming the type's keys) and behind the XML
//! reader's report of everything a scene uses that caustica cannot render (`xml::unsupported`). Each role's
//! types are listed where their values are defined, one file per type with its keys, defaults, checks and
//! constructor (`crate::bsdf::PLUGINS`, `crate::shape::PLUGINS`, `crate::emitter::PLUGINS`,
//! `crate::film::filter::PLUGINS`, `crate::texture::PLUGINS`, `crate::camera::PLUGINS`), and built by [`build`].
//!
//! Keys keep Mitsuba's property names, so the same names serve the TOML tables and the XML properties.

use super::error::{ErrorContext, SceneError};
use super::spans::join_key;
use super::desc::PluginDesc;
use crate::bsdf;
use crate::camera;
use crate::emitter;
use crate::shape;
use crate::film::filter;
use crate::texture;
use crate::props::{self, Plugin, Props, Textured};

/// What kind of plugin a type is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Role {
    Bsdf,
    Shape,
    Emitter,
    RFilter,
    Texture,
    Sensor,
}

impl Role {
    /// The role's name in messages, and its XML tag.
    pub(crate) fn name(self) -> &'static str {
        match self {
            Role::Bsdf => "bsdf",
            Role::Shape => "shape",
            Role::Emitter => "emitter",
            Role::RFilter => "rfilter",
            Role::Texture => "texture",
            Role::Sensor => "sensor",
        }
    }

    /// Keys every type of the role takes beside `type` and its own.
    fn common(self) -> &'static [&'static str] {
        match self {
            Role::Shape => shape::COMMON_KEYS,
            Role::Sensor => camera::COMMON_KEYS,
            Role::Bsdf | Role::Emitter | Role::RFilter | Role::Texture => &[],
        }
    }
}

/// Every key type `name` of `role` takes (the role's common keys, then its own); `None` for an unknown type.
pub(crate) fn keys(role: Role, name: &str) -> Option<Vec<&'static str>> {
    // Mitsuba's instancing shapes (`scene::instances`): a group has only its shapes, an instance its
    // transform (and the `<ref>` to its group).
    match (role, name) {
        (Role::Shape, super::instances::SHAPEGROUP) => return Some(Vec::new()),
        (Role::Shape, super::instances::INSTANCE) => return Some(vec!["to_world"]),
        _ => {}
    }
    let own = match role {
        Role::Bsdf => bsdf::plugin(name)?.keys,
        Role::RFilter => props::find(filter::PLUGINS, name)?.keys,
        Role::Texture => props::find(texture::PLUGINS, name)?.keys,
        Role::Shape => props::find(shape::PLUGINS, name)?.keys,
        Role::Emitter => emitter::plugin(name)?.keys,
        Role::Sensor => props::find(camera::PLUGINS, name)?.keys,
    };
    Some(role.common().iter().chain(own.iter()).copied().collect())
}

/// The key rule: the first key of `given` that type `name` of `role` does not take is an error at
/// `key.<that key>`, naming the type's keys.
pub(crate) fn check_given_keys(ctx: &ErrorContext, key: &str, role: Role, name: &str, given: &[&str]) -> Result<(), SceneError> {
    let allowed = keys(role, name).unwrap_or_default();
    match given.iter().find(|k| !allowed.contains(k)) {
        None => Ok(()),
        Some(k) => Err(ctx.key_error(&join_key(key, k), not_applicable(k, role.name(), name, &allowed))),
    }
}

/// Builds the plugin of `role` that table `d` at `key` describes: finds its type among `plugins`, refuses
/// keys the type does not take, resolves its nested plugins (`resolve(key path, value)`, in the order of
/// the type's `nested`), runs its constructor and places the constructor's errors at their keys.
pub(crate) fn build<T, C>(
    ctx: &ErrorContext,
    key: &str,
    role: Role,
    plugins: &[&Plugin<T, C>],
    d: &PluginDesc,
    resolve: impl FnMut(&str, &toml::Value) -> Result<C, SceneError>,
) -> Result<T, SceneError> {
    build_textured(ctx, key, role, plugins, d, resolve, |at, _, _| Err(ctx.key_error(at, format!("a {} takes no texture", role.name()))))
}

/// [`build`] for a plugin whose properties may be textures (`props::is_texture`): `texture(key path, key,
/// value)` resolves each one (in the order of the table) before the constructor runs.
pub(crate) fn build_textured<'d, T, C>(
    ctx: &ErrorContext,
    key: &str,
    role: Role,
    plugins: &[&Plugin<T, C>],
    d: &'d PluginDesc,
    mut resolve: impl FnMut(&str, &toml::Value) -> Result<C, SceneError>,
    mut texture: impl FnMut(&str, &'d str, &'d toml::Value) -> Result<Textured, SceneError>,
) -> Result<T, SceneError> {
    let Some(plugin) = props::find(plugins, &d.kind) else {
        let names: Vec<&str> = plugins.iter().map(|p| p.name).collect();
        let message = format!("unknown {} type `{}` (caustica's: {})", role.name(), d.kind, names.join(", "));
        return Err(ctx.key_error(&join_key(key, "type"), message));
    };
    let given: Vec<&str> = d.props.keys().map(String::as_str).collect();
    check_given_keys(ctx, key, role, plugin.name, &given)?;
    let mut nested = Vec::new();
    for &k in plugin.nested {
        if let Some(value) = d.props.get(k) {
            nested.push((k, resolve(&join_key(key, k), value)?));
        }
    }
    let mut textured = Vec::new();
    for (k, value) in &d.props {
        if !plugin.nested.contains(&k.as_str()) && props::is_texture(value) {
            textured.push((k.as_str(), texture(&join_key(key, k), k, value)?));
        }
    }
    (plugin.build)(Props::new(&d.props, plugin.keys, nested).with_textures(textured)).map_err(|e| ctx.prop_error(key, e))
}

/// How every scene reader says that key `key` does not apply to type `kind` of `role` (whose keys are
/// `allowed`).
pub(crate) fn not_applicable(key: &str, role: &str, kind: &str, allowed: &[&str]) -> String {
    let list = if allowed.is_empty() { "none".to_string() } else { allowed.join(", ") };
    format!("`{key}` does not apply to {role} type `{kind}` (its keys: {list})")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_type_is_listed_once_with_its_keys() {
        fn names<T, C>(plugins: &[&Plugin<T, C>]) -> Vec<&'static str> {
            plugins.iter().map(|p| p.name).collect()
        }
        for list in [names(bsdf::PLUGINS), names(shape::PLUGINS), names(emitter::PLUGINS), names(filter::PLUGINS), names(texture::PLUGINS), names(camera::PLUGINS)] {
            for (i, n) in list.iter().enumerate() {
                assert!(!list[..i].contains(n), "{n} twice");
            }
        }
        assert_eq!(keys(Role::Shape, "ply").unwrap(), ["to_world", "bsdf", "emitter", "flip_normals", "filename", "face_normals", "flip_tex_coords"]);
        assert_eq!(keys(Role::Emitter, "spot").unwrap(), ["intensity", "cutoff_angle", "beam_width", "texture", "to_world"]);
        assert_eq!(keys(Role::Bsdf, "hair"), None);
        assert_eq!(keys(Role::Shape, "shapegroup"), Some(Vec::new()));
        assert_eq!(keys(Role::Shape, "instance"), Some(vec!["to_world"]));
        assert_eq!(keys(Role::Shape, "bsplinecurve"), None);
        assert_eq!(keys(Role::RFilter, "lanczos").unwrap(), ["lobes"]);
        assert_eq!(keys(Role::Bsdf, "blendbsdf").unwrap(), ["weight", "bsdf_0", "bsdf_1"]);
    }
}

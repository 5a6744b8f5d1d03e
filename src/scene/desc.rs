//! The scene file as written: serde types mirroring the TOML, with `deny_unknown_fields` everywhere.
//! Values are checked for range and consistency later (in `build`, `material`, `transform`), where the key
//! path of every value is known; this module only decides what shapes of TOML are accepted.
//!
//! Values that accept two forms (a colour as a number or `[r, g, b]`; a bsdf as a name or an inline table;
//! `to_world` as one table or a list) have hand-written visitors instead of `#[serde(untagged)]`, so that
//! the deserialiser keeps streaming from the document and every error keeps the span of its key.

use std::collections::BTreeMap;
use std::fmt;

use serde::de::value::{MapAccessDeserializer, SeqAccessDeserializer};
use serde::de::{Deserialize, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};
use serde::Deserialize as DeriveDeserialize;

use super::settings::{defaults, CausticsSettings, Estimator};
use crate::math::Vec3;

#[derive(Debug, DeriveDeserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneFile {
    #[serde(default)]
    pub integrator: IntegratorDesc,
    /// Absent: Mitsuba 0.6's default camera, made to see every shape (`build`).
    pub sensor: Option<SensorDesc>,
    #[serde(default)]
    pub bsdf: BTreeMap<String, PluginDesc>,
    /// Named textures, referenced from a property as `{ texture = "<name>" }` (`scene::textures`).
    #[serde(default)]
    pub texture: BTreeMap<String, PluginDesc>,
    #[serde(default)]
    pub shape: Vec<ShapeDesc>,
    /// Mitsuba's `shapegroup`s by id: shapes placed only by `instance` shapes (module `instances`).
    #[serde(default)]
    pub shapegroup: BTreeMap<String, ShapegroupDesc>,
    /// Emitters that stand alone (`crate::emitter`); area emitters are a shape's `emitter`.
    #[serde(default)]
    pub emitter: Vec<PluginDesc>,
}

/// A `[shapegroup.<id>]` table: its shapes, in the group's object space.
#[derive(Debug, DeriveDeserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ShapegroupDesc {
    #[serde(default)]
    pub shape: Vec<ShapeDesc>,
}

#[derive(Debug, DeriveDeserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct IntegratorDesc {
    pub max_depth: i32,
    pub rr_depth: u32,
    pub samples_per_pixel: u32,
    pub seed: u64,
    pub hide_emitters: bool,
    pub caustics: Option<CausticsDesc>,
    /// `name:type,…` (`scene::aov`).
    pub aovs: Option<String>,
}

impl Default for IntegratorDesc {
    fn default() -> Self {
        Self {
            max_depth: defaults::MAX_DEPTH,
            rr_depth: defaults::RR_DEPTH,
            samples_per_pixel: defaults::SAMPLES_PER_PIXEL,
            seed: defaults::SEED,
            hide_emitters: defaults::HIDE_EMITTERS,
            caustics: None,
            aovs: None,
        }
    }
}

#[derive(Debug, DeriveDeserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct CausticsDesc {
    pub estimator: Estimator,
    pub photons: Option<u64>,
    pub caustic_photons: Option<u64>,
    pub knn: u32,
    pub max_radius: Option<f32>,
}

/// A key left out of the table takes the default of [`CausticsSettings`] (the one place it is written).
impl Default for CausticsDesc {
    fn default() -> Self {
        let CausticsSettings { estimator, photons, caustic_photons, knn, max_radius } = CausticsSettings::default();
        Self { estimator, photons, caustic_photons, knn, max_radius }
    }
}

/// The `[sensor]` table: the keys every sensor takes (`crate::camera::COMMON_KEYS`), read here, and the sensor
/// type's own table (`crate::camera`: its type reads its keys); `type` defaults to
/// `crate::camera::DEFAULT_TYPE`.
#[derive(Debug)]
pub(crate) struct SensorDesc {
    pub plugin: PluginDesc,
    pub to_world: Option<ToWorld>,
    pub film: FilmDesc,
}

impl<'de> Deserialize<'de> for SensorDesc {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = SensorDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a sensor table")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<SensorDesc, A::Error> {
                let (mut to_world, mut film) = (None, None);
                let mut own = toml::Table::new();
                while let Some(key) = map.next_key::<String>()? {
                    match key.as_str() {
                        "to_world" => to_world = Some(map.next_value()?),
                        "film" => film = Some(map.next_value()?),
                        _ => {
                            own.insert(key, map.next_value()?);
                        }
                    }
                }
                own.entry("type").or_insert_with(|| crate::camera::DEFAULT_TYPE.into());
                let plugin = PluginDesc::from_table(own).map_err(A::Error::custom)?;
                Ok(SensorDesc { plugin, to_world, film: film.unwrap_or_default() })
            }
        }
        deserializer.deserialize_map(V)
    }
}

#[derive(Debug, DeriveDeserialize)]
#[serde(deny_unknown_fields, default)]
pub(crate) struct FilmDesc {
    pub width: u32,
    pub height: u32,
    pub crop: Option<[u32; 4]>,
    /// The pixel reconstruction filter; none: [`crate::film::PixelFilter::default`] (Mitsuba's Gaussian).
    pub rfilter: Option<PluginDesc>,
}

impl Default for FilmDesc {
    /// Mitsuba's `hdrfilm` default size.
    fn default() -> Self {
        Self {
            width: 768,
            height: 576,
            crop: None,
            rfilter: None,
        }
    }
}

/// A plugin's table (a bsdf, a shape, an emitter, a filter, a texture): its `type` and its other keys, which the type's own constructor
/// reads (`crate::props::Plugin`, found and checked by `plugins::build`).
#[derive(Debug)]
pub(crate) struct PluginDesc {
    pub kind: String,
    pub props: toml::Table,
}

impl PluginDesc {
    /// The table's `type` and the rest of it.
    pub(crate) fn from_table(mut props: toml::Table) -> Result<Self, String> {
        match props.remove("type") {
            Some(toml::Value::String(kind)) => Ok(Self { kind, props }),
            Some(other) => Err(format!("invalid type: {}, expected the type's name (a string)", other.type_str())),
            None => Err("missing field `type`".into()),
        }
    }
}

impl<'de> Deserialize<'de> for PluginDesc {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        PluginDesc::from_table(toml::Table::deserialize(deserializer)?).map_err(D::Error::custom)
    }
}

/// A `[[shape]]` table: the keys every shape takes (`crate::shape::COMMON_KEYS`), read here as they stream
/// from the document so that an error inside one keeps its exact place, and the shape type's own table
/// (`crate::shape`: its type reads its keys).
#[derive(Debug)]
pub(crate) struct ShapeDesc {
    pub plugin: PluginDesc,
    pub to_world: Option<ToWorld>,
    pub bsdf: Option<BsdfRef>,
    /// An area emitter's table (`crate::emitter`).
    pub emitter: Option<toml::Table>,
    pub flip_normals: Option<bool>,
}

impl<'de> Deserialize<'de> for ShapeDesc {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ShapeDesc;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a shape table")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<ShapeDesc, A::Error> {
                let (mut to_world, mut bsdf, mut emitter, mut flip_normals) = (None, None, None, None);
                let mut own = toml::Table::new();
                while let Some(key) = map.next_key::<String>()? {
                    match key.as_str() {
                        "to_world" => to_world = Some(map.next_value()?),
                        "bsdf" => bsdf = Some(map.next_value()?),
                        "emitter" => emitter = Some(map.next_value()?),
                        "flip_normals" => flip_normals = Some(map.next_value()?),
                        _ => {
                            own.insert(key, map.next_value()?);
                        }
                    }
                }
                let plugin = PluginDesc::from_table(own).map_err(A::Error::custom)?;
                Ok(ShapeDesc { plugin, to_world, bsdf, emitter, flip_normals })
            }
        }
        deserializer.deserialize_map(V)
    }
}

/// A bsdf given by the name of a `[bsdf.<name>]` table or inline.
#[derive(Debug)]
pub(crate) enum BsdfRef {
    Name(String),
    Inline(Box<PluginDesc>),
}

impl<'de> Deserialize<'de> for BsdfRef {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = BsdfRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("the name of a [bsdf.<name>] table or an inline bsdf table")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<BsdfRef, E> {
                Ok(BsdfRef::Name(v.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<BsdfRef, A::Error> {
                PluginDesc::deserialize(MapAccessDeserializer::new(map)).map(|d| BsdfRef::Inline(Box::new(d)))
            }
        }
        deserializer.deserialize_any(V)
    }
}

impl BsdfRef {
    /// A nested bsdf as a plugin's key holds it (a blend's `bsdf_0`, ...): a name or a table.
    pub(crate) fn from_value(value: &toml::Value) -> Result<Self, String> {
        match value {
            toml::Value::String(name) => Ok(BsdfRef::Name(name.clone())),
            toml::Value::Table(t) => PluginDesc::from_table(t.clone()).map(|d| BsdfRef::Inline(Box::new(d))),
            other => Err(format!("invalid type: {}, expected the name of a [bsdf.<name>] table or an inline bsdf table", other.type_str())),
        }
    }
}

/// Reads a number or an array of exactly three numbers (`scale`).
struct NumberOrTriple(&'static str);

impl<'de> Visitor<'de> for NumberOrTriple {
    type Value = Vec3;
    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "{}", self.0)
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }
    fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }
    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Vec3, E> {
        Ok(Vec3::splat(v as f32))
    }
    fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Vec3, A::Error> {
        let v = Vec::<f32>::deserialize(SeqAccessDeserializer::new(seq))?;
        match v.as_slice() {
            [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
            _ => Err(A::Error::invalid_length(v.len(), &self)),
        }
    }
}

/// `scale = s` (uniform) or `scale = [sx, sy, sz]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ScaleDesc(pub Vec3);

impl<'de> Deserialize<'de> for ScaleDesc {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer
            .deserialize_any(NumberOrTriple("a number or an array [sx, sy, sz]"))
            .map(ScaleDesc)
    }
}

#[derive(Debug, DeriveDeserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RotateDesc {
    pub axis: [f32; 3],
    /// Degrees, counter-clockwise about `axis` (right-handed), as Mitsuba.
    pub angle: f32,
}

#[derive(Debug, DeriveDeserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct LookAtDesc {
    pub origin: [f32; 3],
    pub target: [f32; 3],
    pub up: [f32; 3],
}

/// One element of a `to_world`: exactly one of its keys must be present (checked in `transform`).
#[derive(Debug, Default, DeriveDeserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct TransformOp {
    pub translate: Option<[f32; 3]>,
    pub rotate: Option<RotateDesc>,
    pub scale: Option<ScaleDesc>,
    pub look_at: Option<LookAtDesc>,
    pub matrix: Option<Vec<f32>>,
}

/// `to_world`: one transform table or a list of them (the first listed is applied first).
#[derive(Debug)]
pub(crate) enum ToWorld {
    One(TransformOp),
    List(Vec<TransformOp>),
}

impl<'de> Deserialize<'de> for ToWorld {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = ToWorld;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a transform table (translate, rotate, scale, look_at or matrix) or a list of them")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<ToWorld, A::Error> {
                TransformOp::deserialize(MapAccessDeserializer::new(map)).map(ToWorld::One)
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<ToWorld, A::Error> {
                Vec::<TransformOp>::deserialize(SeqAccessDeserializer::new(seq)).map(ToWorld::List)
            }
        }
        deserializer.deserialize_any(V)
    }
}

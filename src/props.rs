//! A plugin's properties as written, read by the plugin's own constructor: Mitsuba 3's `Properties`
//! (src/core/properties.cpp) and pbrt-v4's `ParameterDictionary`. Each plugin type lists its keys once, in
//! its own file, and reads each one with its default and its check through a getter here; the scene
//! readers (TOML and Mitsuba XML, whose properties arrive as the same TOML table) only find the plugin by
//! its type name, refuse keys it does not list and resolve the nested plugins it names.
//!
//! The getters are the one place each kind of value is checked (finite numbers, ranges, reflectances,
//! radiances), also for values outside plugins (`scene::validate` calls the same checks). An error names
//! the key relative to the plugin ([`PropError`]); the scene reader adds the plugin's key path, file and
//! line.

use std::fmt;

use toml::{Table, Value};

use crate::math::Vec3;

/// A value a plugin cannot use: its key (relative to the plugin; `""` = the plugin itself) and why.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PropError {
    pub key: String,
    pub message: String,
}

impl PropError {
    pub(crate) fn new(key: &str, message: impl Into<String>) -> Self {
        Self { key: key.to_string(), message: message.into() }
    }
}

impl fmt::Display for PropError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.key, self.message)
    }
}

/// A plugin type as the scene files name it: Mitsuba's plugin name, the keys it takes (those whose values are
/// nested plugins of kind `C` listed again in `nested`, which the scene reader resolves first), and its
/// constructor, which reads each key with its default and its check. Each role keeps the list of its
/// types where its values are defined (`crate::bsdf::PLUGINS`, `crate::film::filter::PLUGINS`).
pub struct Plugin<T, C = ()> {
    pub name: &'static str,
    pub keys: &'static [&'static str],
    pub nested: &'static [&'static str],
    pub build: fn(Props<'_, C>) -> Result<T, PropError>,
}

/// The plugin named `name` among `plugins`.
pub fn find<'p, T, C>(plugins: &[&'p Plugin<T, C>], name: &str) -> Option<&'p Plugin<T, C>> {
    plugins.iter().copied().find(|p| p.name == name)
}

/// One plugin's properties: its table (without `type`), the nested plugins of kind `C` the scene reader
/// resolved for it (a blend's `bsdf_0`, ...) and the keys whose values are textures.
pub struct Props<'a, C> {
    table: &'a Table,
    /// The keys the plugin type takes (its list, for the debug check that a getter reads only those).
    keys: &'static [&'static str],
    nested: Vec<(&'a str, C)>,
    textured: Vec<(&'a str, Textured)>,
}

/// What a plugin's constructor sees of a key whose value is a texture (`crate::material` binds the texture
/// itself to the parameter): the colour and number getters return its mean, which is also what Mitsuba
/// derives sampling weights from, after checking the texture's range as they check a constant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Textured {
    /// Per-channel mean of the texture's colour.
    pub mean: Vec3,
    /// Mean of its number (`eval_1`).
    pub mean_1: f32,
    /// Per-channel maximum of its colour.
    pub max: Vec3,
    /// Per-channel minimum of its colour.
    pub min: Vec3,
}

/// Whether a property's value describes a texture rather than a constant: a table with a `type` (an inline
/// texture) or a `texture` (a reference to a named one) key.
#[must_use]
pub fn is_texture(v: &Value) -> bool {
    v.as_table().is_some_and(|t| t.contains_key("type") || t.contains_key("texture"))
}

/// A number, or a name from a table of named values (Mitsuba's IOR names, conductor names).
#[derive(Clone, Debug, PartialEq)]
pub enum NumberOrName<'a> {
    Number(f32),
    Name(&'a str),
}

impl<'a, C> Props<'a, C> {
    /// `table`'s keys must all be among `keys` (the scene reader checks that first, naming the type's keys).
    pub(crate) fn new(table: &'a Table, keys: &'static [&'static str], nested: Vec<(&'a str, C)>) -> Self {
        Self { table, keys, nested, textured: Vec::new() }
    }

    /// The same with the keys whose values are the textures `textured` (the scene reader resolved them).
    pub(crate) fn with_textures(mut self, textured: Vec<(&'a str, Textured)>) -> Self {
        self.textured = textured;
        self
    }

    /// The value at `key`, if given; a texture is an error for getters that take constants only.
    fn get(&self, key: &str) -> Option<&'a Value> {
        debug_assert!(self.keys.contains(&key), "the plugin reads `{key}`, which its key list does not name");
        self.table.get(key)
    }

    /// The texture at `key`, if its value is one.
    fn texture(&self, key: &str) -> Option<&Textured> {
        self.textured.iter().find(|(k, _)| *k == key).map(|(_, t)| t)
    }

    /// The value at `key` for a getter that takes no texture: a texture there is an error.
    fn constant(&self, key: &str) -> Result<Option<&'a Value>, PropError> {
        match self.texture(key) {
            Some(_) => Err(PropError::new(key, "this property cannot be a texture")),
            None => Ok(self.get(key)),
        }
    }

    /// A number given as a texture: its mean, checked by `check`.
    fn textured_number(&self, key: &str, check: impl Fn(f32) -> Result<f32, String>) -> Option<Result<f32, PropError>> {
        self.texture(key).map(|t| check(t.mean_1).map_err(|m| PropError::new(key, format!("the texture's mean: {m}"))))
    }

    /// A colour given as a texture: its mean, once its minimum, maximum and mean pass `check`.
    fn textured_colour(&self, key: &str, check: impl Fn(Vec3) -> Result<Vec3, String>) -> Option<Result<Vec3, PropError>> {
        self.texture(key).map(|t| {
            check(t.min).map_err(|m| PropError::new(key, format!("the texture's minimum: {m}")))?;
            check(t.max).map_err(|m| PropError::new(key, format!("the texture's maximum: {m}")))?;
            check(t.mean).map_err(|m| PropError::new(key, format!("the texture's mean: {m}")))
        })
    }

    /// Checks that `key` holds a texture, for a parameter only a texture can give (a normal map): absent or
    /// a constant is an error naming `what`.
    pub fn require_texture(&self, key: &str, what: &str) -> Result<(), PropError> {
        if self.texture(key).is_some() {
            return Ok(());
        }
        Err(PropError::new(key, match self.get(key) {
            None => format!("missing: {what}"),
            Some(_) => format!("must be a texture ({what}), not a constant"),
        }))
    }

    /// Whether `key` is given as a texture (Mitsuba's `principled` tells a texture from the number 0).
    #[must_use]
    pub fn is_textured(&self, key: &str) -> bool {
        self.texture(key).is_some()
    }

    /// Whether `key` is given.
    #[must_use]
    pub fn has(&self, key: &str) -> bool {
        self.get(key).is_some()
    }

    /// The nested plugin at `key`, resolved by the scene reader; `None` when the key is absent.
    pub fn take_nested(&mut self, key: &str) -> Option<C> {
        debug_assert!(self.keys.contains(&key), "the plugin reads `{key}`, which its key list does not name");
        let i = self.nested.iter().position(|(k, _)| *k == key)?;
        Some(self.nested.swap_remove(i).1)
    }

    /// A finite number, or `default` when absent.
    pub fn float_or(&self, key: &str, default: f32) -> Result<f32, PropError> {
        if let Some(t) = self.textured_number(key, finite) {
            return t;
        }
        self.get(key).map_or(Ok(default), |v| number(v).and_then(finite).map_err(|m| PropError::new(key, m)))
    }

    /// A finite number > 0 (`what` names it in the message), or `default` when absent.
    pub fn positive_or(&self, key: &str, default: f32, what: &str) -> Result<f32, PropError> {
        if let Some(t) = self.textured_number(key, |x| positive(x, what)) {
            return t;
        }
        match self.get(key) {
            None => Ok(default),
            Some(v) => number(v).and_then(|x| positive(x, what)).map_err(|m| PropError::new(key, m)),
        }
    }

    /// A finite number in `[lo, hi]` (`what` names it), or `default` when absent.
    pub fn in_range_or(&self, key: &str, default: f32, lo: f32, hi: f32, what: &str) -> Result<f32, PropError> {
        if let Some(t) = self.textured_number(key, |x| in_range(x, lo, hi, what)) {
            return t;
        }
        match self.get(key) {
            None => Ok(default),
            Some(v) => number(v).and_then(|x| in_range(x, lo, hi, what)).map_err(|m| PropError::new(key, m)),
        }
    }

    /// Three finite numbers written as one (gray) or `[r, g, b]`.
    pub fn colour(&self, key: &str) -> Result<Option<Vec3>, PropError> {
        if let Some(t) = self.textured_colour(key, finite3) {
            return t.map(Some);
        }
        self.get(key).map(|v| colour(v).and_then(finite3).map_err(|m| PropError::new(key, m))).transpose()
    }

    /// A point or a direction: an array of three finite numbers, if given.
    pub fn vec3(&self, key: &str) -> Result<Option<Vec3>, PropError> {
        const EXPECTED: &str = "an array of three numbers [x, y, z]";
        let Some(v) = self.constant(key)? else { return Ok(None) };
        let read = || match v {
            Value::Array(a) if a.len() == 3 => {
                let mut c = [0.0; 3];
                for (i, x) in a.iter().enumerate() {
                    c[i] = number(x).map_err(|_| format!("component {i}: {}", invalid_type(x, "a number")))?;
                }
                finite3(Vec3::from_array(c))
            }
            Value::Array(a) => Err(format!("invalid length {}, expected {EXPECTED}", a.len())),
            _ => Err(invalid_type(v, EXPECTED)),
        };
        read().map(Some).map_err(|m| PropError::new(key, m))
    }

    /// An RGB reflectance (each component in [0, 1]), or `default` when absent.
    pub fn reflectance_or(&self, key: &str, default: Vec3) -> Result<Vec3, PropError> {
        if let Some(t) = self.textured_colour(key, reflectance) {
            return t;
        }
        self.get(key).map_or(Ok(default), |v| colour(v).and_then(reflectance).map_err(|m| PropError::new(key, m)))
    }

    /// A value Mitsuba reads with a bounded `get_texture` (src/core/properties.cpp, `get_texture_impl`), or
    /// `default` when absent: a number is Mitsuba's `uniform` texture, which has no bound (finite here: the
    /// parameter it drives checks its own range), an RGB colour its `srgb`, which must be a reflectance.
    pub fn texture_value_or(&self, key: &str, default: Vec3) -> Result<Vec3, PropError> {
        match self.get(key) {
            Some(v @ (Value::Float(_) | Value::Integer(_))) if self.texture(key).is_none() => {
                number(v).and_then(finite).map(Vec3::splat).map_err(|m| PropError::new(key, m))
            }
            _ => self.reflectance_or(key, default),
        }
    }

    /// The per-channel maximum of the colour at `key` when it is a texture (a constant's maximum is its
    /// value, which the caller has): what Mitsuba 0.6's `ensureEnergyConservation` reads (`getMaximum`).
    #[must_use]
    pub fn texture_max(&self, key: &str) -> Option<Vec3> {
        self.texture(key).map(|t| t.max)
    }

    /// An RGB radiance (each component finite and ≥ 0), or `default` when absent.
    pub fn radiance_or(&self, key: &str, default: Vec3) -> Result<Vec3, PropError> {
        if let Some(t) = self.textured_colour(key, radiance) {
            return t;
        }
        self.get(key).map_or(Ok(default), |v| colour(v).and_then(radiance).map_err(|m| PropError::new(key, m)))
    }

    /// A non-negative integer, or `default` when absent.
    pub fn u32_or(&self, key: &str, default: u32) -> Result<u32, PropError> {
        match self.constant(key)? {
            None => Ok(default),
            Some(Value::Integer(i)) => u32::try_from(*i).map_err(|_| PropError::new(key, format!("{i} is not an integer in [0, {}]", u32::MAX))),
            Some(v) => Err(PropError::new(key, invalid_type(v, "an integer"))),
        }
    }

    /// A string, if given.
    pub fn string(&self, key: &str) -> Result<Option<&'a str>, PropError> {
        match self.constant(key)? {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(PropError::new(key, invalid_type(v, "a string"))),
        }
    }

    /// A boolean, or `default` when absent.
    pub fn bool_or(&self, key: &str, default: bool) -> Result<bool, PropError> {
        match self.constant(key)? {
            None => Ok(default),
            Some(Value::Boolean(b)) => Ok(*b),
            Some(v) => Err(PropError::new(key, invalid_type(v, "a boolean"))),
        }
    }

    /// A number or a name (checked by the caller against its table of names), if given.
    pub fn number_or_name(&self, key: &str) -> Result<Option<NumberOrName<'a>>, PropError> {
        match self.constant(key)? {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(NumberOrName::Name(s))),
            Some(v) => number(v).map(|x| Some(NumberOrName::Number(x))).map_err(|m| PropError::new(key, m)),
        }
    }
}

/// How a TOML value's type is named in messages.
fn type_name(v: &Value) -> String {
    match v {
        Value::String(s) => format!("string {}", shown(s)),
        Value::Integer(i) => format!("integer `{i}`"),
        Value::Float(x) => format!("floating point `{x}`"),
        Value::Boolean(b) => format!("boolean `{b}`"),
        Value::Datetime(_) => "a date".into(),
        Value::Array(_) => "an array".into(),
        Value::Table(_) => "a table".into(),
    }
}

/// Characters of a value written in a scene file that messages echo: a value can be megabytes long (a
/// hostile or broken file), and a message shows enough of it to find it.
pub(crate) const SHOWN_CHARS: usize = 80;

/// A value written in a scene file as messages show it: quoted (as `{:?}` quotes it), and when longer than
/// [`SHOWN_CHARS`] characters cut there, with its length: `"0.5 0.5 0.5 …"… (20971520 bytes)`. Every
/// message that echoes a value, name or attribute of a scene file uses it, or [`cut`] where it is not
/// quoted.
pub(crate) fn shown(value: &str) -> String {
    match value.char_indices().nth(SHOWN_CHARS) {
        None => format!("{value:?}"),
        Some((end, _)) => format!("{:?}… ({} bytes)", &value[..end], value.len()),
    }
}

/// [`shown`] unquoted: a tag, a file name or a name between backticks.
pub(crate) fn cut(value: &str) -> std::borrow::Cow<'_, str> {
    match value.char_indices().nth(SHOWN_CHARS) {
        None => std::borrow::Cow::Borrowed(value),
        Some((end, _)) => std::borrow::Cow::Owned(format!("{}… ({} bytes)", &value[..end], value.len())),
    }
}

/// The message for a value of the wrong type (worded as serde's, which the rest of a scene file gets).
fn invalid_type(v: &Value, expected: &str) -> String {
    format!("invalid type: {}, expected {expected}", type_name(v))
}

/// A number (TOML integer or float) as f32.
fn number(v: &Value) -> Result<f32, String> {
    match v {
        Value::Float(x) => Ok(*x as f32),
        Value::Integer(i) => Ok(*i as f32),
        _ => Err(invalid_type(v, "a number")),
    }
}

/// One number (gray) or an array of exactly three.
fn colour(v: &Value) -> Result<Vec3, String> {
    const EXPECTED: &str = "a number (gray) or an array [r, g, b]";
    match v {
        Value::Float(_) | Value::Integer(_) => number(v).map(Vec3::splat),
        Value::Array(a) if a.len() == 3 => {
            let mut c = [0.0; 3];
            for (i, x) in a.iter().enumerate() {
                c[i] = number(x).map_err(|_| format!("component {i}: {}", invalid_type(x, "a number")))?;
            }
            Ok(Vec3::from_array(c))
        }
        Value::Array(a) => Err(format!("invalid length {}, expected {EXPECTED}", a.len())),
        _ => Err(invalid_type(v, EXPECTED)),
    }
}

/// Why a number is not acceptable as a finite value (`None` if it is finite).
fn non_finite(v: f32) -> Option<&'static str> {
    if v.is_nan() {
        Some("is NaN")
    } else if v.is_infinite() {
        Some("is infinite")
    } else {
        None
    }
}

/// A finite number.
pub(crate) fn finite(v: f32) -> Result<f32, String> {
    match non_finite(v) {
        Some(why) => Err(format!("the value {why}; it must be a finite number")),
        None => Ok(v),
    }
}

/// A finite number > 0 (`what` names it).
pub(crate) fn positive(v: f32, what: &str) -> Result<f32, String> {
    finite(v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{what} must be > 0, got {v}"))
    }
}

/// A finite number in `[lo, hi]` (`what` names it).
pub(crate) fn in_range(v: f32, lo: f32, hi: f32, what: &str) -> Result<f32, String> {
    finite(v)?;
    if (lo..=hi).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{what} must be in [{lo}, {hi}], got {v}"))
    }
}

/// Three finite numbers.
pub(crate) fn finite3(v: Vec3) -> Result<Vec3, String> {
    for i in 0..3 {
        if let Some(why) = non_finite(v[i]) {
            return Err(format!("component {i} {why}; it must be a finite number"));
        }
    }
    Ok(v)
}

/// An RGB reflectance: every component finite and in [0, 1].
pub(crate) fn reflectance(v: Vec3) -> Result<Vec3, String> {
    for i in 0..3 {
        let c = v[i];
        let why = match non_finite(c) {
            Some(why) => why.to_string(),
            None if c < 0.0 => format!("is negative ({c})"),
            None if c > 1.0 => format!("is {c} > 1 (a reflectance above 1 creates energy)"),
            None => continue,
        };
        return Err(format!("reflectance component {i} {why}; each component must be in [0, 1]"));
    }
    Ok(v)
}

/// An RGB radiance: every component finite and ≥ 0.
pub(crate) fn radiance(v: Vec3) -> Result<Vec3, String> {
    for i in 0..3 {
        let c = v[i];
        let why = match non_finite(c) {
            Some(why) => why.to_string(),
            None if c < 0.0 => format!("is negative ({c})"),
            None => continue,
        };
        return Err(format!("radiance component {i} {why}; each component must be finite and ≥ 0"));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(text: &str) -> Table {
        text.parse().unwrap()
    }

    #[test]
    fn getters_read_defaults_values_and_name_the_key_of_a_bad_one() {
        let t = table("a = 2\nc = [0.1, 0.2, 0.3]\ns = \"x\"\nb = true\nbad = \"red\"\nshort = [1, 2]\nhigh = 1.5");
        const KEYS: &[&str] = &["a", "c", "s", "b", "bad", "short", "high", "absent"];
        let p: Props<'_, ()> = Props::new(&t, KEYS, Vec::new());
        assert_eq!(p.float_or("a", 0.0), Ok(2.0));
        assert_eq!(p.float_or("absent", 0.25), Ok(0.25));
        assert_eq!(p.colour("c"), Ok(Some(Vec3::new(0.1, 0.2, 0.3))));
        assert_eq!(p.reflectance_or("a", Vec3::ZERO).unwrap_err().message, "reflectance component 0 is 2 > 1 (a reflectance above 1 creates energy); each component must be in [0, 1]");
        assert_eq!(p.string("s"), Ok(Some("x")));
        assert_eq!(p.bool_or("b", false), Ok(true));
        let e = p.colour("bad").unwrap_err();
        assert_eq!((e.key.as_str(), e.message.as_str()), ("bad", "invalid type: string \"red\", expected a number (gray) or an array [r, g, b]"));
        assert!(p.colour("short").unwrap_err().message.starts_with("invalid length 2"));
        assert_eq!(p.in_range_or("high", 0.5, 0.0, 1.0, "the weight").unwrap_err().message, "the weight must be in [0, 1], got 1.5");
        assert_eq!(p.positive_or("absent", 0.1, "alpha"), Ok(0.1));
        assert_eq!(p.number_or_name("s"), Ok(Some(NumberOrName::Name("x"))));
        assert_eq!(p.number_or_name("a"), Ok(Some(NumberOrName::Number(2.0))));
    }

    #[test]
    fn long_strings_are_cut_in_messages() {
        let long = "y".repeat(100_000);
        let t = table(&format!("s = \"{long}\""));
        let p: Props<'_, ()> = Props::new(&t, &["s"], Vec::new());
        let m = p.float_or("s", 0.0).unwrap_err().message;
        assert!(m.len() < 200, "{m}");
    }

    #[test]
    fn nested_plugins_are_taken_once() {
        let t = table("");
        let mut p = Props::new(&t, &["inner"], vec![("inner", 7)]);
        assert_eq!(p.take_nested("inner"), Some(7));
        assert_eq!(p.take_nested("inner"), None);
    }
}

//! Property elements (`<float name="alpha" value="0.1"/>`, `<rgb …>`, `<point …>`, ...) → TOML values of
//! the scene description. Lists of numbers are separated by commas and/or spaces, as in Mitsuba. `<spectrum>`
//! is read by [`spectrum`](super::spectrum), as the RGB colour Mitsuba's RGB variants make of it, which depends
//! on the plugin that reads it.

use toml::Value;

use super::spectrum;
use super::tree::Element;
use super::super::error::{shown, SceneError};

/// The tags of property elements.
pub(crate) const PROPERTY_TAGS: &[&str] = &["float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector"];

/// The numbers of a list such as `"0.8, 0.1 0.1"`.
pub(crate) fn numbers(el: &Element, attr: &str, text: &str) -> Result<Vec<f64>, SceneError> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f64>().map_err(|_| el.error(format!("attribute `{attr}`: {} is not a number", shown(s)))))
        .collect()
}

/// Exactly `n` numbers in attribute `attr`.
pub(crate) fn numbers_n(el: &Element, attr: &str, n: usize) -> Result<Vec<f64>, SceneError> {
    let v = numbers(el, attr, el.required(attr)?)?;
    if v.len() == n {
        Ok(v)
    } else {
        Err(el.error(format!("attribute `{attr}` needs {n} numbers, got {}", v.len())))
    }
}

/// One number in attribute `attr`, or `default` when the attribute is absent.
pub(crate) fn number_or(el: &Element, attr: &str, default: f64) -> Result<f64, SceneError> {
    match el.attr(attr) {
        None => Ok(default),
        Some(_) => Ok(numbers_n(el, attr, 1)?[0]),
    }
}

/// `[x, y, z]` from the attributes `x`, `y`, `z` (each defaulting to `default`) or from `value`.
pub(crate) fn xyz(el: &Element, default: f64) -> Result<[f64; 3], SceneError> {
    if el.attr("value").is_some() {
        if ["x", "y", "z"].iter().any(|a| el.attr(a).is_some()) {
            return Err(el.error("give either `value` or `x`, `y`, `z`, not both"));
        }
        let v = numbers_n(el, "value", 3)?;
        return Ok([v[0], v[1], v[2]]);
    }
    Ok([number_or(el, "x", default)?, number_or(el, "y", default)?, number_or(el, "z", default)?])
}

pub(crate) fn float_array(v: &[f64]) -> Value {
    Value::Array(v.iter().map(|&x| Value::Float(x)).collect())
}

/// The value of a property element (its tag is one of [`PROPERTY_TAGS`]) of `plugin` (the element it is
/// nested in: a spectrum's colour depends on the plugin and property, [`spectrum::ColourUse`]).
pub(crate) fn property_value(el: &Element, plugin: &Element) -> Result<Value, SceneError> {
    if el.tag == "spectrum" {
        return spectrum::property_value(el, plugin);
    }
    let point = matches!(el.tag.as_str(), "point" | "vector");
    el.check_attrs(if point { &["name", "value", "x", "y", "z"] } else { &["name", "value"] })?;
    if point {
        return Ok(float_array(&xyz(el, 0.0)?));
    }
    let text = el.required("value")?.trim();
    Ok(match el.tag.as_str() {
        "float" => Value::Float(numbers_n(el, "value", 1)?[0]),
        "integer" => Value::Integer(
            text.parse::<i64>().map_err(|_| el.error(format!("attribute `value`: {} is not an integer", shown(text))))?,
        ),
        // Any case, as Mitsuba (`string::iequals`, src/core/parser.cpp): Blender's exporter writes "False".
        "boolean" => Value::Boolean(if text.eq_ignore_ascii_case("true") {
            true
        } else if text.eq_ignore_ascii_case("false") {
            false
        } else {
            return Err(el.error(format!("attribute `value`: {} is not true or false", shown(text))));
        }),
        "string" => Value::String(text.to_string()),
        "rgb" => {
            let v = numbers(el, "value", text)?;
            match v.len() {
                1 => Value::Float(v[0]),
                3 => float_array(&v),
                n => return Err(el.error(format!("an rgb value needs 1 or 3 numbers, got {n}"))),
            }
        }
        _ => return Err(el.error("not a property element")),
    })
}

//! The scene description (`desc`, as the TOML table a scene file deserialises from) → Mitsuba 3 XML text,
//! the inverse of `convert`: what this writes, `read_str` reads back into the same description (numbers
//! are written in Rust's shortest round-trip form, transforms as their list of operations), so a TOML →
//! XML → TOML conversion builds the same scene, bit for bit.
//!
//! Written explicitly because Mitsuba's default differs from caustica's: the sample count (Mitsuba 4,
//! caustica [`defaults::SAMPLES_PER_PIXEL`]). The reconstruction filter is written when the scene names
//! one (both renderers default to the same Gaussian). caustica-only settings keep their documented forms:
//! the caustic photon map's settings as the path integrator's `caustics_*` properties, a sphere's `rings`
//! and `segments`. Mitsuba refuses both (it rejects properties no plugin reads); a scene without them is
//! written as plain Mitsuba 3.
//!
//! The description must come from a scene that builds (`convert_scene` builds it first), so every key is
//! one the format knows; a key this writer does not know is an error, never dropped.

use std::fmt::Write as _;

use toml::{Table, Value};

use super::super::settings::defaults;

/// The XML tag of a property whose TOML value does not tell it: integers (TOML numbers are read as floats
/// elsewhere), points and vectors (arrays of three are colours otherwise). Every other key is written by
/// its value's type (a number: `<float>`, three numbers: `<rgb>`, a string: `<string>`, a boolean:
/// `<boolean>`), so a new plugin's keys need no row here unless they are one of these.
fn tag_of(key: &str) -> Option<&'static str> {
    Some(match key {
        // `year`, `month`, `day`: a sunsky's date.
        "width" | "height" | "rings" | "segments" | "shape_index" | "lobes" | "year" | "month" | "day" => "integer",
        "center" | "position" | "p0" | "p1" => "point",
        // `rawconstant`'s three raw values: Mitsuba takes a `<vector>` (or a `<float>`), not an `<rgb>`.
        "direction" | "value" | "sun_direction" => "vector",
        _ => return None,
    })
}

/// A number in the shortest form that reads back to the same f64.
fn num(v: &Value) -> Option<String> {
    match v {
        Value::Integer(i) => Some(i.to_string()),
        // Whole numbers without ".0", as integers are written (so TOML `3` and `3.0` write alike).
        Value::Float(f) if f.fract() == 0.0 && f.abs() < 1e15 => Some(if f.is_sign_negative() && *f == 0.0 { "-0".into() } else { format!("{}", *f as i64) }),
        Value::Float(f) => Some(format!("{f:?}")),
        _ => None,
    }
}

fn nums(v: &Value) -> Option<String> {
    match v {
        Value::Array(a) => a.iter().map(num).collect::<Option<Vec<_>>>().map(|v| v.join(", ")),
        _ => num(v),
    }
}

/// XML-escapes an attribute value.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
}

struct Writer {
    out: String,
    depth: usize,
}

type Result<T> = std::result::Result<T, String>;

impl Writer {
    fn line(&mut self, s: &str) {
        let _ = writeln!(self.out, "{}{s}", "    ".repeat(self.depth));
    }

    fn open(&mut self, s: &str) {
        self.line(s);
        self.depth += 1;
    }

    fn close(&mut self, tag: &str) {
        self.depth -= 1;
        self.line(&format!("</{tag}>"));
    }

    /// A property element `name` = `v` (key path `at` for errors).
    fn property(&mut self, at: &str, name: &str, v: &Value) -> Result<()> {
        let bad = || format!("{at}.{name}: the value {v} cannot be written as Mitsuba XML");
        let n = esc(name);
        let text = match (tag_of(name), v) {
            (Some("integer"), Value::Integer(_)) => format!("<integer name=\"{n}\" value=\"{}\"/>", num(v).ok_or_else(bad)?),
            (Some(tag @ ("point" | "vector")), Value::Array(_)) => format!("<{tag} name=\"{n}\" value=\"{}\"/>", nums(v).ok_or_else(bad)?),
            (None, Value::Array(_)) => format!("<rgb name=\"{n}\" value=\"{}\"/>", nums(v).ok_or_else(bad)?),
            (None, Value::Float(_) | Value::Integer(_)) => format!("<float name=\"{n}\" value=\"{}\"/>", num(v).ok_or_else(bad)?),
            (None, Value::String(s)) => format!("<string name=\"{n}\" value=\"{}\"/>", esc(s)),
            (None, Value::Boolean(b)) => format!("<boolean name=\"{n}\" value=\"{b}\"/>"),
            _ => return Err(bad()),
        };
        self.line(&text);
        Ok(())
    }

    /// `<transform name="…">` (`to_world`, `to_uv`) with the operations in the order listed (the first
    /// applied first).
    fn transform(&mut self, at: &str, name: &str, v: &Value) -> Result<()> {
        let ops: Vec<&Value> = match v {
            Value::Array(a) => a.iter().collect(),
            one => vec![one],
        };
        self.open(&format!("<transform name=\"{}\">", esc(name)));
        for op in ops {
            let Some((kind, x)) = op.as_table().and_then(|t| t.iter().next()) else { return Err(format!("{at}.{name}: not a transform table")) };
            let bad = || format!("{at}.{name}: cannot write {kind} = {x}");
            let text = match kind.as_str() {
                "translate" => format!("<translate value=\"{}\"/>", nums(x).ok_or_else(bad)?),
                "scale" => {
                    // A uniform scale as one number, however it was given (`20` and `[20, 20, 20]`).
                    let x = match x.as_array().map(Vec::as_slice) {
                        Some([a, b, c]) if a == b && b == c => a,
                        _ => x,
                    };
                    format!("<scale value=\"{}\"/>", nums(x).ok_or_else(bad)?)
                }
                "matrix" => format!("<matrix value=\"{}\"/>", nums(x).ok_or_else(bad)?),
                "rotate" => {
                    let t = x.as_table().ok_or_else(bad)?;
                    let axis = t.get("axis").and_then(nums).ok_or_else(bad)?;
                    let angle = t.get("angle").and_then(num).ok_or_else(bad)?;
                    format!("<rotate value=\"{axis}\" angle=\"{angle}\"/>")
                }
                "look_at" => {
                    let t = x.as_table().ok_or_else(bad)?;
                    let get = |k: &str| t.get(k).and_then(nums).ok_or_else(bad);
                    format!("<lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>", get("origin")?, get("target")?, get("up")?)
                }
                _ => return Err(bad()),
            };
            self.line(&text);
        }
        self.close("transform");
        Ok(())
    }

    /// The properties and transform of a plugin table, skipping `type` and the keys in `skip`.
    fn body(&mut self, at: &str, t: &Table, skip: &[&str]) -> Result<()> {
        for (k, v) in t {
            if k == "type" || skip.contains(&k.as_str()) {
                continue;
            }
            if k == "to_world" || k == "to_uv" {
                self.transform(at, k, v)?;
            } else if let Some(t) = v.as_table().filter(|_| crate::props::is_texture(v)) {
                self.texture(&format!("{at}.{k}"), t, Some(k), None)?;
            } else {
                self.property(at, k, v)?;
            }
        }
        Ok(())
    }

    /// A texture: a reference to a named one (`{ texture = "<name>" }`), or an inline plugin, on the
    /// property `name` or, with an `id`, at the top level.
    fn texture(&mut self, at: &str, t: &Table, name: Option<&str>, id: Option<&str>) -> Result<()> {
        let name = name.map(|n| format!(" name=\"{}\"", esc(n))).unwrap_or_default();
        if let Some(reference) = t.get("texture") {
            let reference = reference.as_str().ok_or_else(|| format!("{at}.texture: not a name"))?;
            self.line(&format!("<ref{name} id=\"{}\"/>", esc(reference)));
            return Ok(());
        }
        let id = id.map(|i| format!(" id=\"{}\"", esc(i))).unwrap_or_default();
        self.open(&format!("<texture type=\"{}\"{name}{id}>", esc(Self::kind(at, t)?)));
        self.body(at, t, &[])?;
        self.close("texture");
        Ok(())
    }

    fn kind<'a>(at: &str, t: &'a Table) -> Result<&'a str> {
        t.get("type").and_then(Value::as_str).ok_or_else(|| format!("{at}: no type"))
    }

    /// A BSDF: a reference to a named one, or an inline plugin (`id` for a named one).
    fn bsdf(&mut self, at: &str, v: &Value, id: Option<&str>) -> Result<()> {
        match v {
            Value::String(name) => {
                self.line(&format!("<ref id=\"{}\"/>", esc(name)));
                Ok(())
            }
            Value::Table(t) => {
                let kind = Self::kind(at, t)?;
                let id = id.map(|i| format!(" id=\"{}\"", esc(i))).unwrap_or_default();
                self.open(&format!("<bsdf type=\"{}\"{id}>", esc(kind)));
                self.body(at, t, &["bsdf", "bsdf_0", "bsdf_1"])?;
                for slot in ["bsdf", "bsdf_0", "bsdf_1"] {
                    if let Some(inner) = t.get(slot) {
                        self.bsdf(&format!("{at}.{slot}"), inner, None)?;
                    }
                }
                self.close("bsdf");
                Ok(())
            }
            _ => Err(format!("{at}: not a bsdf")),
        }
    }

    fn integrator(&mut self, t: Option<&Table>) -> Result<()> {
        // AOVs: Mitsuba's `aov` integrator around the path tracer.
        let aovs = t.and_then(|t| t.get("aovs")).and_then(Value::as_str);
        if let Some(aovs) = aovs {
            self.open("<integrator type=\"aov\">");
            self.line(&format!("<string name=\"aovs\" value=\"{}\"/>", esc(aovs)));
        }
        self.open("<integrator type=\"path\">");
        if let Some(t) = t {
            for k in ["max_depth", "rr_depth"] {
                if let Some(v) = t.get(k) {
                    self.line(&format!("<integer name=\"{k}\" value=\"{}\"/>", num(v).ok_or_else(|| format!("integrator.{k}"))?));
                }
            }
            if let Some(v) = t.get("hide_emitters") {
                let hide = v.as_bool().ok_or_else(|| "integrator.hide_emitters".to_string())?;
                self.line(&format!("<boolean name=\"hide_emitters\" value=\"{hide}\"/>"));
            }
            if let Some(c) = t.get("caustics").and_then(Value::as_table) {
                for (k, v) in c {
                    let line = match (k.as_str(), v) {
                        ("estimator", Value::String(s)) => format!("<string name=\"caustics_estimator\" value=\"{}\"/>", esc(s)),
                        ("photons" | "caustic_photons" | "knn", Value::Integer(i)) => format!("<integer name=\"caustics_{k}\" value=\"{i}\"/>"),
                        ("max_radius", _) => format!("<float name=\"caustics_max_radius\" value=\"{}\"/>", num(v).ok_or_else(|| "integrator.caustics.max_radius".to_string())?),
                        _ => return Err(format!("integrator.caustics.{k}: no Mitsuba XML property for this key")),
                    };
                    self.line(&line);
                }
            }
        }
        self.close("integrator");
        if aovs.is_some() {
            self.close("integrator");
        }
        Ok(())
    }

    fn sensor(&mut self, t: &Table, integrator: Option<&Table>) -> Result<()> {
        let kind = t.get("type").and_then(Value::as_str).unwrap_or("perspective");
        self.open(&format!("<sensor type=\"{}\">", esc(kind)));
        self.body("sensor", t, &["film"])?;
        self.open("<sampler type=\"independent\">");
        let get = |k: &str| integrator.and_then(|i| i.get(k)).and_then(num);
        let spp = get("samples_per_pixel").unwrap_or_else(|| defaults::SAMPLES_PER_PIXEL.to_string());
        self.line(&format!("<integer name=\"sample_count\" value=\"{spp}\"/>"));
        if let Some(seed) = get("seed") {
            self.line(&format!("<integer name=\"seed\" value=\"{seed}\"/>"));
        }
        self.close("sampler");
        self.open("<film type=\"hdrfilm\">");
        if let Some(film) = t.get("film").and_then(Value::as_table) {
            self.body("sensor.film", film, &["crop", "rfilter"])?;
            if let Some(Value::Array(c)) = film.get("crop") {
                let c: Vec<i64> = c.iter().filter_map(Value::as_integer).collect();
                let [x0, y0, x1, y1] = c[..] else { return Err("sensor.film.crop: needs four integers".into()) };
                for (k, v) in [("crop_offset_x", x0), ("crop_offset_y", y0), ("crop_width", x1 - x0), ("crop_height", y1 - y0)] {
                    self.line(&format!("<integer name=\"{k}\" value=\"{v}\"/>"));
                }
            }
        }
        // No rfilter: Mitsuba's default (a Gaussian) is caustica's too, so none is written.
        if let Some(f) = t.get("film").and_then(Value::as_table).and_then(|f| f.get("rfilter")).and_then(Value::as_table) {
            let kind = f.get("type").and_then(Value::as_str).ok_or("sensor.film.rfilter: needs a type")?;
            self.open(&format!("<rfilter type=\"{}\">", esc(kind)));
            self.body("sensor.film.rfilter", f, &["type"])?;
            self.close("rfilter");
        }
        self.close("film");
        self.close("sensor");
        Ok(())
    }
}

impl Writer {
    /// A `<shape>` at key path `at`: its properties, BSDF and area emitter; an instance's `shapegroup` as
    /// the `<ref>` Mitsuba reads.
    fn shape(&mut self, at: &str, s: &Value) -> std::result::Result<(), String> {
        let t = s.as_table().ok_or_else(|| format!("{at}: not a table"))?;
        self.open(&format!("<shape type=\"{}\">", esc(Writer::kind(at, t)?)));
        self.body(at, t, &["bsdf", "emitter", "shapegroup"])?;
        if let Some(id) = t.get("shapegroup") {
            let id = id.as_str().ok_or_else(|| format!("{at}.shapegroup: not a string"))?;
            self.line(&format!("<ref id=\"{}\"/>", esc(id)));
        }
        if let Some(b) = t.get("bsdf") {
            self.bsdf(&format!("{at}.bsdf"), b, None)?;
        }
        if let Some(e) = t.get("emitter").and_then(Value::as_table) {
            let eat = format!("{at}.emitter");
            self.open(&format!("<emitter type=\"{}\">", esc(Writer::kind(&eat, e)?)));
            self.body(&eat, e, &[])?;
            self.close("emitter");
        }
        self.close("shape");
        Ok(())
    }
}

/// Mitsuba 3 XML text of the scene description `doc`; `source` names where it came from (a comment).
pub(crate) fn to_xml(doc: &Table, source: &str) -> std::result::Result<String, String> {
    let mut w = Writer { out: String::new(), depth: 0 };
    w.line("<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    w.line(&format!("<!-- written by caustica convert from {} -->", esc(source).replace("--", "- -")));
    w.open("<scene version=\"3.0.0\">");
    let integrator = doc.get("integrator").and_then(Value::as_table);
    w.integrator(integrator)?;
    let sensor = doc.get("sensor").and_then(Value::as_table).ok_or("a scene needs [sensor]")?;
    w.sensor(sensor, integrator)?;
    if let Some(textures) = doc.get("texture").and_then(Value::as_table) {
        for (name, t) in textures {
            let at = format!("texture.{name}");
            w.texture(&at, t.as_table().ok_or_else(|| format!("{at}: not a table"))?, None, Some(name))?;
        }
    }
    if let Some(bsdfs) = doc.get("bsdf").and_then(Value::as_table) {
        for (name, b) in bsdfs {
            w.bsdf(&format!("bsdf.{name}"), b, Some(name))?;
        }
    }
    // Shapegroups before the instances that refer to them (`scene::instances`).
    if let Some(groups) = doc.get("shapegroup").and_then(Value::as_table) {
        for (id, g) in groups {
            let at = format!("shapegroup.{id}");
            w.open(&format!("<shape type=\"shapegroup\" id=\"{}\">", esc(id)));
            for (i, s) in g.get("shape").and_then(Value::as_array).map_or(&[][..], Vec::as_slice).iter().enumerate() {
                w.shape(&format!("{at}.shape[{i}]"), s)?;
            }
            w.close("shape");
        }
    }
    for (i, s) in doc.get("shape").and_then(Value::as_array).map_or(&[][..], Vec::as_slice).iter().enumerate() {
        w.shape(&format!("shape[{i}]"), s)?;
    }
    for (i, e) in doc.get("emitter").and_then(Value::as_array).map_or(&[][..], Vec::as_slice).iter().enumerate() {
        let at = format!("emitter[{i}]");
        let t = e.as_table().ok_or_else(|| format!("{at}: not a table"))?;
        w.open(&format!("<emitter type=\"{}\">", esc(Writer::kind(&at, t)?)));
        w.body(&at, t, &[])?;
        w.close("emitter");
    }
    w.close("scene");
    Ok(w.out)
}

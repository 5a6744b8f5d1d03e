//! The element tree (includes resolved, parameters substituted) → the scene description as a TOML
//! table, the same one a TOML scene file deserialises from (`desc`), plus the place of every key.
//!
//! Properties keep their Mitsuba names, which are the description's keys; the deserialiser then rejects
//! unknown properties and wrong value types (`deny_unknown_fields`), and the builder checks ranges and
//! which keys apply to which type, all reported at the XML element through [`Places`]. Only the
//! structure is translated here: nested plugins, `<ref>`, `id`s, transforms, the film's crop window, the
//! sampler (→ `integrator.samples_per_pixel`/`seed`) and the `caustics_*` extension properties.

use std::collections::HashMap;

use toml::{Table, Value};

use super::ignored;
use super::integrators::{self, Reading};
use super::places::{Place, Places};
use super::tree::{Element, SearchPath};
use super::super::note::{NoteKind, SceneNote};
use super::values::{self, float_array, numbers, numbers_n, xyz, PROPERTY_TAGS};
use super::super::desc::FilmDesc;
use super::super::error::{cut, shown, SceneError};
use super::super::instances::{INSTANCE, SHAPEGROUP};
use super::super::spans::{join_index, join_key};

/// Mitsuba's sampler types: caustica uses its own deterministic sampler for each (the expected image
/// does not depend on the sampling pattern).
pub(crate) const SAMPLER_TYPES: &[&str] = &["independent", "stratified", "multijitter", "orthogonal", "ldsampler"];

/// Prefix of the integrator properties that set `[integrator.caustics]` (caustica's extension).
pub(crate) const CAUSTICS_PREFIX: &str = "caustics_";

/// The attributes of a plugin element.
const PLUGIN_ATTRS: &[&str] = &["type", "id", "name"];

/// How the XML reader treats what the scene names but caustica does not have.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ConvertOptions {
    /// An integrator that caustica does not have is replaced by its path tracer (with a note) instead of
    /// refused: the command line chose the estimator (`--estimator`).
    pub replace_integrator: bool,
}

/// The scene description and the places of its keys; what was read but changes nothing, or was
/// replaced, is in the notes.
pub(crate) fn convert(
    root: &Element,
    search: &SearchPath,
    options: ConvertOptions,
) -> Result<(Table, Places, Vec<SceneNote>), SceneError> {
    let mut c = Converter {
        places: Places::new(root),
        ids: HashMap::new(),
        search,
        options,
        notes: Vec::new(),
        named_bsdfs: Table::new(),
        named_textures: Table::new(),
        integrator: Table::new(),
        sensor: None,
        shapes: Vec::new(),
        emitters: Vec::new(),
        shapegroups: Table::new(),
        integrator_seen: false,
        sampler_seen: false,
        anonymous: HashMap::new(),
    };
    c.collect_ids(root)?;
    for el in &root.children {
        match el.tag.as_str() {
            "integrator" => c.integrator(el)?,
            "sensor" => c.sensor(el)?,
            "bsdf" => {
                let name = match el.attr("id") {
                    Some(id) => id.to_string(),
                    None => c.anonymous_name(el),
                };
                c.named_bsdf(el, &name)?;
            }
            "shape" if el.attr("type") == Some(SHAPEGROUP) => c.shapegroup(el)?,
            "shape" => c.shape(el)?,
            // A texture without an id is still checked (as Mitsuba instantiates it), though nothing uses it.
            "texture" => match el.attr("id") {
                Some(id) => c.named_texture(el, id)?,
                None => {
                    let name = (1..).map(|k| if k == 1 { format!("texture_line_{}", el.line) } else { format!("texture_line_{}_{k}", el.line) });
                    let name = name.into_iter().find(|n| !c.ids.contains_key(n.as_str()) && !c.named_textures.contains_key(n)).expect("a free name");
                    c.named_texture(el, &name)?;
                }
            },
            // An area emitter with an id is attached to the shapes that refer to it (Mitsuba: a surface
            // emitter joins the scene through its shape).
            "emitter" if el.attr("id").is_some() && el.attr("type") == Some("area") => {}
            "emitter" => c.emitter(el)?,
            // Films, samplers and filters with an id are read where a sensor or film refers to them.
            "film" | "sampler" | "rfilter" if el.attr("id").is_some() => {}
            "film" | "sampler" | "rfilter" => c.push_note(NoteKind::Ignored, el, "outside a <sensor> and without an id, it is not used (as in Mitsuba)".into()),
            _ => return Err(unsupported(el, root)),
        }
    }
    let mut doc = Table::new();
    if !c.integrator.is_empty() {
        doc.insert("integrator".into(), Value::Table(c.integrator));
    }
    if let Some(sensor) = c.sensor {
        doc.insert("sensor".into(), Value::Table(sensor));
    }
    if !c.named_bsdfs.is_empty() {
        doc.insert("bsdf".into(), Value::Table(c.named_bsdfs));
    }
    if !c.named_textures.is_empty() {
        doc.insert("texture".into(), Value::Table(c.named_textures));
    }
    if !c.shapes.is_empty() {
        doc.insert("shape".into(), Value::Array(c.shapes));
    }
    if !c.emitters.is_empty() {
        doc.insert("emitter".into(), Value::Array(c.emitters));
    }
    if !c.shapegroups.is_empty() {
        doc.insert("shapegroup".into(), Value::Table(c.shapegroups));
    }
    Ok((doc, c.places, c.notes))
}

fn unsupported(el: &Element, parent: &Element) -> SceneError {
    el.error(format!("<{}> is not supported inside {}", cut(&el.tag), parent.label()))
}

struct Converter<'a> {
    places: Places,
    /// Every element with an `id`.
    ids: HashMap<&'a str, &'a Element>,
    /// Where relative file names are looked for.
    search: &'a SearchPath,
    options: ConvertOptions,
    notes: Vec<SceneNote>,
    named_bsdfs: Table,
    named_textures: Table,
    integrator: Table,
    sensor: Option<Table>,
    shapes: Vec<Value>,
    /// `[shapegroup.<id>]` tables (`scene::instances`).
    shapegroups: Table,
    emitters: Vec<Value>,
    integrator_seen: bool,
    sampler_seen: bool,
    /// Line → how many top-level `<bsdf>`s without an id on that line (of any file) were named.
    anonymous: HashMap<usize, usize>,
}

impl<'a> Converter<'a> {
    fn collect_ids(&mut self, el: &'a Element) -> Result<(), SceneError> {
        for child in &el.children {
            if child.tag != "ref" {
                if let Some(id) = child.attr("id") {
                    if self.ids.insert(id, child).is_some() {
                        return Err(child.error(format!("id {} is used twice", shown(id))));
                    }
                }
            }
            self.collect_ids(child)?;
        }
        Ok(())
    }

    /// The name of a top-level `<bsdf>` without an id: `bsdf_line_<line>`, with `_2`, `_3` … for the
    /// second and later on that line (in included files, or on one line) and past any id the scene uses.
    fn anonymous_name(&mut self, el: &Element) -> String {
        let base = format!("bsdf_line_{}", el.line);
        let seen = self.anonymous.entry(el.line).or_insert(0);
        loop {
            *seen += 1;
            let name = if *seen == 1 { base.clone() } else { format!("{base}_{seen}") };
            if !self.ids.contains_key(name.as_str()) && !self.named_bsdfs.contains_key(&name) {
                return name;
            }
        }
    }

    /// A note about element `el`, read differently from what it names.
    fn note(&mut self, el: &Element, message: impl Into<String>) {
        self.push_note(NoteKind::Reading, el, message.into());
    }

    /// A note that property element `el` of `plugin` changes no image (`why`), and is left out.
    fn note_ignored(&mut self, plugin: &Element, el: &Element, why: &str) {
        self.push_note(NoteKind::Ignored, el, format!("property of {} ignored: {why}", plugin.label()));
    }

    /// Whether property `name` (element `child`) of `plugin` changes no image (`ignored`): then its value
    /// is still checked, and it is noted and left out.
    fn skip_ignored(&mut self, plugin: &Element, child: &Element, name: &str) -> Result<bool, SceneError> {
        let Some(why) = ignored::why(plugin, name) else {
            return Ok(false);
        };
        values::property_value(child, plugin)?;
        self.note_ignored(plugin, child, why);
        Ok(true)
    }

    fn push_note(&mut self, kind: NoteKind, el: &Element, message: String) {
        self.notes.push(SceneNote { kind, file: el.file.as_ref().clone(), line: el.line, message: format!("{}: {message}", el.label()) });
    }

    /// The element `<ref id="…">` refers to, which must have tag `tag`.
    fn referenced(&self, r: &Element, tag: &str) -> Result<&'a Element, SceneError> {
        r.check_attrs(&["id", "name"])?;
        let id = r.required("id")?;
        match self.ids.get(id) {
            Some(el) if el.tag == tag => Ok(el),
            Some(el) => Err(r.error(format!("refers to a <{}>; a <{tag}> is expected here", el.tag))),
            None => Err(r.error(format!("no element has id {}", shown(id)))),
        }
    }

    /// `child` itself, or the element it refers to when it is a `<ref>` to a `<tag>`.
    fn deref(&self, child: &'a Element, tag: &str) -> Result<&'a Element, SceneError> {
        if child.tag == "ref" {
            self.referenced(child, tag)
        } else {
            Ok(child)
        }
    }

    /// Inserts property `name` = `value` into `table` (at key path `key`), written by `child` of `plugin`.
    fn put(&mut self, table: &mut Table, key: &str, plugin: &Element, child: &Element, name: &str, value: Value) -> Result<(), SceneError> {
        if table.contains_key(name) {
            return Err(child.error(format!("property {} of {} is given twice", shown(name), plugin.label())));
        }
        self.places.insert(&join_key(key, name), Place::property(plugin, child, name));
        table.insert(name.to_string(), value);
        Ok(())
    }

    /// A property element or a `<transform>` of `plugin` → `table`; `Ok(false)` for other elements. A
    /// property that changes no image in caustica is noted and left out (`ignored`); a `filename` is
    /// looked for along the search path.
    fn property_or_transform(&mut self, plugin: &Element, child: &Element, key: &str, table: &mut Table) -> Result<bool, SceneError> {
        if PROPERTY_TAGS.contains(&child.tag.as_str()) {
            let name = child.required("name")?;
            if self.skip_ignored(plugin, child, name)? {
                return Ok(true);
            }
            let mut value = values::property_value(child, plugin)?;
            if let (Value::String(written), "filename") = (&value, name) {
                value = Value::String(self.resolve_file(child, written));
            }
            self.put(table, key, plugin, child, name, value)?;
            Ok(true)
        } else if child.tag == "transform" {
            let name = child.required("name")?;
            let value = self.transform(child, &join_key(key, name))?;
            self.put(table, key, plugin, child, name, value)?;
            Ok(true)
        } else {
            Ok(false)
        }
    }

    /// The file name `written` in `el` as the description holds it: relative to the scene's directory
    /// (where the builder looks), or absolute, after looking along the search path (`<path>`) and in the
    /// directory of `el`'s own file. A name found nowhere stays as written (the builder names it).
    fn resolve_file(&self, el: &Element, written: &str) -> String {
        let own_dir = el.file.parent();
        let Some(found) = self.search.resolve(written, own_dir) else {
            return written.to_string();
        };
        match found.strip_prefix(self.search.base_dir()) {
            Ok(relative) => relative.to_string_lossy().into_owned(),
            Err(_) => std::path::absolute(&found).unwrap_or(found).to_string_lossy().into_owned(),
        }
    }

    /// A new plugin table with its `type`.
    fn plugin_table(&mut self, el: &Element, key: &str) -> Result<Table, SceneError> {
        el.check_attrs(PLUGIN_ATTRS)?;
        let kind = el.required("type")?;
        // (Its `type` key is located at the plugin's place too, as a key below it: no entry of its own.)
        self.places.insert(key, Place::plugin(el));
        let mut t = Table::new();
        t.insert("type".into(), Value::String(kind.to_string()));
        Ok(t)
    }

    fn integrator(&mut self, el: &'a Element) -> Result<(), SceneError> {
        if std::mem::replace(&mut self.integrator_seen, true) {
            return Err(el.error("a second <integrator>"));
        }
        el.check_attrs(PLUGIN_ATTRS)?;
        let kind = el.required("type")?;
        match integrators::reading(kind) {
            Reading::Path { max_depth } => {
                if kind != "path" {
                    self.note(el, format!("read as caustica's path tracer ({})", integrators::why(kind)));
                }
                self.path_integrator(el, max_depth)
            }
            Reading::Inner => {
                let inner = el.children.iter().find(|c| c.tag == "integrator");
                let Some(inner) = inner else {
                    return Err(el.error(format!("integrator {} without a nested <integrator> renders no image caustica can make", shown(kind))));
                };
                for child in el.children.iter().filter(|c| c.tag != "integrator") {
                    // Mitsuba's `aov` integrator: its `aovs` are written beside the image (`scene::aov`).
                    if kind == "aov" && child.attr("name") == Some("aovs") && PROPERTY_TAGS.contains(&child.tag.as_str()) {
                        let value = values::property_value(child, el)?;
                        let mut table = std::mem::take(&mut self.integrator);
                        self.put(&mut table, "integrator", el, child, "aovs", value)?;
                        self.integrator = table;
                        continue;
                    }
                    self.note_ignored(el, child, "caustica renders the image of the nested integrator only");
                }
                if kind != "aov" {
                    self.note(el, "its nested integrator is rendered (the extra channels are not written)");
                }
                self.integrator_seen = false;
                self.integrator(inner)
            }
            Reading::Refused(why) if !self.options.replace_integrator => Err(el.error(format!(
                "integrator type {} is not supported: {why}; `--estimator pt|pm|mis` on the command line replaces it by caustica's path tracer",
                shown(kind)
            ))),
            Reading::Refused(_) => {
                self.note(el, "replaced by caustica's path tracer with its default settings (--estimator)");
                Ok(())
            }
        }
    }

    /// The properties of an integrator read as `path` (`max_depth`: the depth its type implies).
    fn path_integrator(&mut self, el: &Element, max_depth: Option<i64>) -> Result<(), SceneError> {
        self.places.insert("integrator", Place::plugin(el));
        let mut table = std::mem::take(&mut self.integrator);
        if let Some(depth) = max_depth {
            table.insert("max_depth".into(), Value::Integer(depth));
        }
        let mut caustics = Table::new();
        for child in &el.children {
            if !PROPERTY_TAGS.contains(&child.tag.as_str()) {
                return Err(unsupported(child, el));
            }
            let name = child.required("name")?;
            if self.skip_ignored(el, child, name)? {
                continue;
            }
            let value = values::property_value(child, el)?;
            if let Some(rest) = name.strip_prefix(CAUSTICS_PREFIX) {
                self.places.insert("integrator.caustics", Place::plugin(el));
                self.put(&mut caustics, "integrator.caustics", el, child, rest, value)?;
                // The error names the XML property, not the description's key.
                self.places.insert(&join_key("integrator.caustics", rest), Place::property(el, child, name));
            } else if matches!(name, "samples_per_pixel" | "seed" | "caustics") {
                return Err(child.error(format!(
                    "unknown property {} of {} (the sample count and seed are the <sampler>'s sample_count and seed)",
                    shown(name),
                    el.label()
                )));
            } else if max_depth.is_some() && name == "max_depth" {
                return Err(child.error(format!("{} has no property \"max_depth\" (its depth is fixed)", el.label())));
            } else {
                self.put(&mut table, "integrator", el, child, name, value)?;
            }
        }
        if !caustics.is_empty() {
            table.insert("caustics".into(), Value::Table(caustics));
        }
        self.integrator = table;
        Ok(())
    }

    fn sensor(&mut self, el: &'a Element) -> Result<(), SceneError> {
        if self.sensor.is_some() {
            return Err(el.error("a second <sensor> (caustica renders one camera)"));
        }
        let key = "sensor";
        let mut table = self.plugin_table(el, key)?;
        let mut film_seen = false;
        for child in &el.children {
            if self.property_or_transform(el, child, key, &mut table)? {
                continue;
            }
            let tag = match child.tag.as_str() {
                "ref" => self.ids.get(child.attr("id").unwrap_or_default()).map_or("ref", |r| r.tag.as_str()),
                tag => tag,
            };
            match tag {
                "film" if film_seen => return Err(child.error(format!("{} has a second film", el.label()))),
                "film" => {
                    film_seen = true;
                    let film = self.film(self.deref(child, "film")?)?;
                    table.insert("film".into(), Value::Table(film));
                }
                "sampler" => self.sampler(self.deref(child, "sampler")?)?,
                _ if child.tag == "ref" => {
                    self.referenced(child, "film")?;
                }
                _ => return Err(unsupported(child, el)),
            }
        }
        self.sensor = Some(table);
        Ok(())
    }

    fn film(&mut self, el: &'a Element) -> Result<Table, SceneError> {
        let key = "sensor.film";
        el.check_attrs(PLUGIN_ATTRS)?;
        let kind = el.required("type")?;
        if kind != "hdrfilm" {
            return Err(el.error(format!("film type {} is not supported (only \"hdrfilm\")", shown(kind))));
        }
        self.places.insert(key, Place::plugin(el));
        let mut table = Table::new();
        let mut crop: [Option<(i64, &Element)>; 4] = [None; 4];
        const CROP: [&str; 4] = ["crop_offset_x", "crop_offset_y", "crop_width", "crop_height"];
        let mut rfilter_seen = false;
        for child in &el.children {
            let is_rfilter = child.tag == "rfilter" || (child.tag == "ref" && self.deref(child, "rfilter").is_ok());
            if is_rfilter && !rfilter_seen {
                rfilter_seen = true;
                table.insert("rfilter".into(), Value::Table(rfilter(self, self.deref(child, "rfilter")?)?));
                continue;
            }
            let name = child.attr("name").unwrap_or_default();
            if let Some(i) = CROP.iter().position(|c| *c == name) {
                let Value::Integer(v) = values::property_value(child, el)? else {
                    return Err(child.error(format!("{name} must be an <integer>")));
                };
                if crop[i].replace((v, child)).is_some() {
                    return Err(child.error(format!("property {} of {} is given twice", shown(name), el.label())));
                }
                continue;
            }
            if !self.property_or_transform(el, child, key, &mut table)? {
                return Err(unsupported(child, el));
            }
        }
        if let Some((_, first)) = crop.iter().flatten().next() {
            let defaults = FilmDesc::default();
            let size = |name: &str, default: u32| match table.get(name) {
                Some(Value::Integer(v)) => *v,
                _ => i64::from(default),
            };
            let (w, h) = (size("width", defaults.width), size("height", defaults.height));
            let get = |i: usize, default: i64| crop[i].map_or(default, |(v, _)| v);
            let (x0, y0) = (get(0, 0), get(1, 0));
            let (x1, y1) = (x0.saturating_add(get(2, w - x0)), y0.saturating_add(get(3, h - y0)));
            let name = first.attr("name").unwrap_or_default();
            self.places.insert(&join_key(key, "crop"), Place::property(el, first, name));
            table.insert("crop".into(), Value::Array([x0, y0, x1, y1].map(Value::Integer).to_vec()));
        }
        Ok(table)
    }

    fn sampler(&mut self, el: &Element) -> Result<(), SceneError> {
        if std::mem::replace(&mut self.sampler_seen, true) {
            return Err(el.error("a second <sampler>"));
        }
        el.check_attrs(PLUGIN_ATTRS)?;
        let kind = el.required("type")?;
        if !SAMPLER_TYPES.contains(&kind) {
            return Err(el.error(format!("sampler type {} is not supported (one of {})", shown(kind), SAMPLER_TYPES.join(", "))));
        }
        let mut table = std::mem::take(&mut self.integrator);
        for child in &el.children {
            if !PROPERTY_TAGS.contains(&child.tag.as_str()) {
                return Err(unsupported(child, el));
            }
            let name = child.required("name")?;
            if self.skip_ignored(el, child, name)? {
                continue;
            }
            let target = match name {
                "sample_count" => "samples_per_pixel",
                "seed" => "seed",
                _ => {
                    return Err(child.error(format!(
                        "unknown property {} of {} (caustica reads sample_count and seed)",
                        shown(name),
                        el.label()
                    )))
                }
            };
            let value = values::property_value(child, el)?;
            self.put(&mut table, "integrator", el, child, target, value)?;
            self.places.insert(&join_key("integrator", target), Place::property(el, child, name));
        }
        self.integrator = table;
        Ok(())
    }

    /// A `<bsdf>` with an `id` (at the top level or nested) becomes the named bsdf `bsdf.<id>`.
    fn named_bsdf(&mut self, el: &Element, name: &str) -> Result<(), SceneError> {
        if self.named_bsdfs.contains_key(name) {
            return Err(el.error(format!("a second bsdf named {}", shown(name))));
        }
        let key = join_key("bsdf", name);
        let table = self.bsdf_table(el, &key)?;
        self.named_bsdfs.insert(name.to_string(), Value::Table(table));
        Ok(())
    }

    /// A nested `<bsdf>` or `<ref>` at key path `key`: an inline table, or the name of a named bsdf.
    fn bsdf_value(&mut self, el: &Element, key: &str) -> Result<Value, SceneError> {
        self.places.insert(key, Place::plugin(el));
        if el.tag == "ref" {
            el.check_attrs(&["id", "name"])?;
            let id = el.required("id")?;
            return match self.ids.get(id).map(|e| e.tag.as_str()) {
                Some("bsdf") => Ok(Value::String(id.to_string())),
                Some(tag) => Err(el.error(format!("refers to a <{tag}>; only BSDFs can be referenced here"))),
                None => Err(el.error(format!("no element has id {}", shown(id)))),
            };
        }
        if let Some(id) = el.attr("id") {
            self.named_bsdf(el, id)?;
            return Ok(Value::String(id.to_string()));
        }
        Ok(Value::Table(self.bsdf_table(el, key)?))
    }

    fn bsdf_table(&mut self, el: &Element, key: &str) -> Result<Table, SceneError> {
        let mut table = self.plugin_table(el, key)?;
        // The keys of the nested bsdfs, in the order they are given: the type's own list (`bsdf::PLUGINS`).
        let nested: &[&str] = el.attr("type").and_then(crate::bsdf::plugin).map_or(&[], |p| p.nested);
        let mut n = 0;
        for child in &el.children {
            if self.property_or_transform(el, child, key, &mut table)? {
                continue;
            }
            if self.texture_property(el, child, key, &mut table)? {
                continue;
            }
            if !matches!(child.tag.as_str(), "bsdf" | "ref") {
                return Err(unsupported(child, el));
            }
            let Some(slot) = nested.get(n) else {
                let msg = match nested.len() {
                    0 => format!("{} has no nested BSDF", el.label()),
                    1 => format!("{} takes one nested BSDF (different BSDFs on the two sides are not supported)", el.label()),
                    k => format!("{} takes {k} nested BSDFs", el.label()),
                };
                return Err(child.error(msg));
            };
            n += 1;
            let value = self.bsdf_value(child, &join_key(key, slot))?;
            table.insert((*slot).to_string(), value);
        }
        Ok(table)
    }

    /// A `<texture>` with an `id` (at the top level or on a property) becomes the named texture
    /// `texture.<id>`.
    fn named_texture(&mut self, el: &Element, id: &str) -> Result<(), SceneError> {
        if self.named_textures.contains_key(id) {
            return Err(el.error(format!("a second texture named {}", shown(id))));
        }
        let table = self.leaf_plugin(el, &join_key("texture", id))?;
        self.named_textures.insert(id.to_string(), Value::Table(table));
        Ok(())
    }

    /// A texture on a property at key path `key`: `<texture>` inline (a table with its `type`), or a
    /// `<ref>` to, or a `<texture>` with, an id (`{ texture = "<id>" }`, `scene::textures`).
    fn texture_value(&mut self, el: &Element, key: &str) -> Result<Value, SceneError> {
        self.places.insert(key, Place::plugin(el));
        let reference = |id: &str| Value::Table(Table::from_iter([("texture".to_string(), Value::String(id.to_string()))]));
        if el.tag == "ref" {
            let id = self.referenced(el, "texture")?.required("id")?;
            return Ok(reference(id));
        }
        if let Some(id) = el.attr("id") {
            self.named_texture(el, id)?;
            return Ok(reference(id));
        }
        let mut table = self.plugin_table(el, key)?;
        for child in &el.children {
            if !self.property_or_transform(el, child, key, &mut table)? {
                return Err(unsupported(child, el));
            }
        }
        Ok(Value::Table(table))
    }

    fn shape(&mut self, el: &'a Element) -> Result<(), SceneError> {
        let key = join_index("shape", self.shapes.len());
        let table = self.shape_table(el, &key)?;
        self.shapes.push(Value::Table(table));
        Ok(())
    }

    /// `<shape type="shapegroup" id="…">` and its shapes → `[shapegroup.<id>]` (`scene::instances`; Mitsuba's
    /// `ShapeGroup` refuses nested groups, instances and emitters in it, which the builder reports at the
    /// shape's key, placed here).
    fn shapegroup(&mut self, el: &'a Element) -> Result<(), SceneError> {
        el.check_attrs(PLUGIN_ATTRS)?;
        let id = el.required("id")?;
        let key = join_key("shapegroup", id);
        self.places.insert(&key, Place::plugin(el));
        let mut shapes = Vec::new();
        for child in &el.children {
            let child = self.deref(child, "shape")?;
            if child.tag != "shape" {
                return Err(unsupported(child, el));
            }
            let shape_key = join_index(&join_key(&key, "shape"), shapes.len());
            let table = if child.attr("type") == Some(SHAPEGROUP) {
                // Kept for the builder's error at its key (Mitsuba: "Nested ShapeGroup is not permitted").
                self.plugin_table(child, &shape_key)?
            } else {
                self.shape_table(child, &shape_key)?
            };
            shapes.push(Value::Table(table));
        }
        self.shapegroups.insert(id.to_string(), Value::Table(Table::from_iter([("shape".to_string(), Value::Array(shapes))])));
        Ok(())
    }

    /// A shape's table at `key`: its properties, transform, BSDF and area emitter, or, for an instance, the
    /// id of the shapegroup its `<ref>` names (`shapegroup = "<id>"`).
    fn shape_table(&mut self, el: &'a Element, key: &str) -> Result<Table, SceneError> {
        let key = key.to_string();
        let mut table = self.plugin_table(el, &key)?;
        for child in &el.children {
            if self.property_or_transform(el, child, &key, &mut table)? {
                continue;
            }
            if el.attr("type") == Some(INSTANCE) && child.tag == "ref" {
                let group = self.referenced(child, "shape")?;
                if group.attr("type") != Some(SHAPEGROUP) {
                    return Err(child.error("an instance refers to a shapegroup (Mitsuba: \"Only a shapegroup can be specified in an instance.\")"));
                }
                if table.contains_key("shapegroup") {
                    return Err(child.error("an instance places one shapegroup (Mitsuba: \"Only a single shapegroup can be specified per instance.\")"));
                }
                let id = group.required("id")?;
                self.places.insert(&join_key(&key, "shapegroup"), Place::plugin(child));
                table.insert("shapegroup".into(), Value::String(id.to_string()));
                continue;
            }
            let tag = match child.tag.as_str() {
                "ref" => self.ids.get(child.attr("id").unwrap_or_default()).map_or("bsdf", |r| r.tag.as_str()),
                tag => tag,
            };
            let slot = match tag {
                "bsdf" => "bsdf",
                "emitter" => "emitter",
                _ if child.tag == "ref" => {
                    return Err(child.error(format!("refers to a <{tag}>; a shape refers to a <bsdf> or an <emitter>")))
                }
                _ => return Err(unsupported(child, el)),
            };
            if table.contains_key(slot) {
                return Err(child.error(format!("{} has a second {slot}", el.label())));
            }
            let slot_key = join_key(&key, slot);
            let value = if slot == "bsdf" {
                self.bsdf_value(child, &slot_key)?
            } else {
                Value::Table(self.emitter_table(self.deref(child, "emitter")?, &slot_key)?)
            };
            table.insert(slot.into(), value);
        }
        Ok(table)
    }

    fn emitter(&mut self, el: &Element) -> Result<(), SceneError> {
        let key = join_index("emitter", self.emitters.len());
        let table = self.emitter_table(el, &key)?;
        self.emitters.push(Value::Table(table));
        Ok(())
    }

    /// An emitter: properties, a transform, and textures on properties (an area emitter's `radiance`:
    /// `<texture name="radiance">` or a `<ref name="radiance">` to one; the unsupported report refuses
    /// them elsewhere).
    fn emitter_table(&mut self, el: &Element, key: &str) -> Result<Table, SceneError> {
        let mut table = self.plugin_table(el, key)?;
        for child in &el.children {
            if self.property_or_transform(el, child, key, &mut table)? {
                continue;
            }
            if !self.texture_property(el, child, key, &mut table)? {
                return Err(unsupported(child, el));
            }
        }
        Ok(table)
    }

    /// A `<texture>` child of `el`, or a `<ref>` to one, put in `table` under its `name`; `false` for any
    /// other child.
    fn texture_property(&mut self, el: &Element, child: &Element, key: &str, table: &mut Table) -> Result<bool, SceneError> {
        let refers_to_texture = child.tag == "ref" && child.attr("id").and_then(|id| self.ids.get(id)).is_some_and(|r| r.tag == "texture");
        if child.tag != "texture" && !refers_to_texture {
            return Ok(false);
        }
        let name = match texture_key(el.attr("type").unwrap_or_default(), child.attr("name")) {
            Some(name) => name,
            None => child.required("name")?,
        };
        let value = self.texture_value(child, &join_key(key, name))?;
        self.put(table, key, el, child, name, value)?;
        Ok(true)
    }

    /// A plugin with properties and transforms but no nested plugins (textures).
    fn leaf_plugin(&mut self, el: &Element, key: &str) -> Result<Table, SceneError> {
        let mut table = self.plugin_table(el, key)?;
        for child in &el.children {
            if !self.property_or_transform(el, child, key, &mut table)? {
                return Err(unsupported(child, el));
            }
        }
        Ok(table)
    }

    /// `<transform>`: its operations in the order written (the first is applied first, as `to_world`
    /// lists in the description).
    fn transform(&mut self, el: &Element, key: &str) -> Result<Value, SceneError> {
        el.check_attrs(&["name"])?;
        let mut ops = Vec::new();
        for (i, op) in el.children.iter().enumerate() {
            let op_key = join_index(key, i);
            self.places.insert(&op_key, Place::plugin(op));
            let mut t = Table::new();
            match op.tag.as_str() {
                "translate" => {
                    op.check_attrs(&["x", "y", "z", "value"])?;
                    t.insert("translate".into(), float_array(&xyz(op, 0.0)?));
                }
                "rotate" => {
                    op.check_attrs(&["x", "y", "z", "value", "angle"])?;
                    let mut r = Table::new();
                    r.insert("axis".into(), float_array(&xyz(op, 0.0)?));
                    r.insert("angle".into(), Value::Float(numbers_n(op, "angle", 1)?[0]));
                    t.insert("rotate".into(), Value::Table(r));
                }
                "scale" => {
                    op.check_attrs(&["x", "y", "z", "value"])?;
                    let s = match op.attr("value") {
                        Some(v) if numbers(op, "value", v)?.len() == 1 && ["x", "y", "z"].iter().all(|a| op.attr(a).is_none()) => {
                            let s = numbers(op, "value", v)?[0];
                            [s, s, s]
                        }
                        _ => xyz(op, 1.0)?,
                    };
                    t.insert("scale".into(), float_array(&s));
                }
                "matrix" => {
                    op.check_attrs(&["value"])?;
                    let v = numbers(op, "value", op.required("value")?)?;
                    let m = match v.len() {
                        16 => v,
                        // A 3×3 matrix: the linear part, no translation.
                        9 => vec![v[0], v[1], v[2], 0.0, v[3], v[4], v[5], 0.0, v[6], v[7], v[8], 0.0, 0.0, 0.0, 0.0, 1.0],
                        n => return Err(op.error(format!("a matrix needs 16 (or 9) numbers, got {n}"))),
                    };
                    t.insert("matrix".into(), float_array(&m));
                }
                "lookat" => {
                    op.check_attrs(&["origin", "target", "up"])?;
                    let mut l = Table::new();
                    for a in ["origin", "target", "up"] {
                        l.insert(a.into(), float_array(&numbers_n(op, a, 3)?));
                    }
                    t.insert("look_at".into(), Value::Table(l));
                }
                _ => return Err(unsupported(op, el)),
            }
            ops.push(Value::Table(t));
        }
        Ok(Value::Array(ops))
    }
}

/// `<rfilter type="…">` with its properties → `sensor.film.rfilter` (its types and parameters are checked
/// by the deserialiser and `build`, reported at the element through the places recorded here).
fn rfilter(c: &mut Converter, el: &Element) -> Result<Table, SceneError> {
    let key = "sensor.film.rfilter";
    let mut table = c.plugin_table(el, key)?;
    for child in &el.children {
        if !PROPERTY_TAGS.contains(&child.tag.as_str()) {
            return Err(unsupported(child, el));
        }
        let name = child.required("name")?;
        let value = values::property_value(child, el)?;
        c.put(&mut table, key, el, child, name, value)?;
    }
    Ok(table)
}

/// The key a `<texture>` (or a `<ref>` to one) nested in a `<bsdf type="kind">` is read at: its `name`, except
/// in a `bumpmap`, whose one texture Mitsuba takes under any name (or none), read at `texture`.
pub(super) fn texture_key<'a>(kind: &str, name: Option<&'a str>) -> Option<&'a str> {
    if kind == "bumpmap" {
        Some("texture")
    } else {
        name
    }
}

//! Where each key of the scene description came from in the XML files: errors found later (by the
//! description's deserialiser or the scene builder, which speak of key paths such as
//! `shape[2].bsdf.alpha`) are reported at the file, line and plugin/property that wrote the key.

use std::collections::HashMap;
use std::path::PathBuf;
use std::rc::Rc;

use super::tree::Element;
use super::super::error::shown;

/// An XML element that wrote a key, and how errors name it.
#[derive(Clone, Debug)]
pub(crate) struct Place {
    file: Rc<PathBuf>,
    line: usize,
    label: String,
}

impl Place {
    /// The plugin element `el` itself.
    pub(crate) fn plugin(el: &Element) -> Self {
        Self { file: el.file.clone(), line: el.line, label: el.label() }
    }

    /// Property `name` of plugin `plugin`, written by element `el`.
    pub(crate) fn property(plugin: &Element, el: &Element, name: &str) -> Self {
        Self { file: el.file.clone(), line: el.line, label: format!("{} property {}", plugin.label(), shown(name)) }
    }
}

/// Key path → place, with the `<scene>` element for keys written nowhere (a missing `<sensor>`).
#[derive(Clone, Debug)]
pub(crate) struct Places {
    map: HashMap<String, Place>,
    root: Place,
}

impl Places {
    pub(crate) fn new(scene: &Element) -> Self {
        Self { map: HashMap::new(), root: Place::plugin(scene) }
    }

    pub(crate) fn insert(&mut self, key: &str, place: Place) {
        self.map.insert(key.to_string(), place);
    }

    /// The file, label and line of `key`: its own place, else that of the nearest enclosing key.
    pub(crate) fn locate(&self, key: &str) -> (PathBuf, String, usize) {
        let mut k = key;
        let place = loop {
            if let Some(p) = self.map.get(k) {
                break p;
            }
            match parent(k) {
                Some(p) => k = p,
                None => break &self.root,
            }
        };
        (place.file.as_ref().clone(), place.label.clone(), place.line)
    }
}

/// The enclosing key path: `a.b[2]` → `a.b`, `a."x.y"` → `a`, `a` → `` ; `None` for the empty path.
fn parent(key: &str) -> Option<&str> {
    if key.is_empty() {
        return None;
    }
    let cut = if key.ends_with(']') {
        key.rfind('[')
    } else if key.ends_with('"') {
        // A quoted segment: its opening quote is the first quote after the last `."` or at the start.
        key[..key.len() - 1].rfind(".\"").or(if key.starts_with('"') { Some(0) } else { None })
    } else {
        key.rfind('.')
    };
    Some(cut.map_or("", |c| &key[..c]))
}

#[cfg(test)]
mod tests {
    use super::parent;

    #[test]
    fn parents_of_key_paths() {
        assert_eq!(parent("shape[2].bsdf.alpha"), Some("shape[2].bsdf"));
        assert_eq!(parent("shape[2]"), Some("shape"));
        assert_eq!(parent("bsdf.\"my.mat\""), Some("bsdf"));
        assert_eq!(parent("\"a.b\""), Some(""));
        assert_eq!(parent("sensor"), Some(""));
        assert_eq!(parent(""), None);
    }
}

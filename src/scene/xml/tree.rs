//! The XML files as an owned element tree: every element keeps its file and line (for errors), and
//! `<include filename="…"/>` elements are replaced by the children of the included file's `<scene>`.

use std::path::{Path, PathBuf};
use std::rc::Rc;

use super::super::error::SceneError;

/// Deepest chain of files including each other (a cycle is reported when it is exceeded).
const MAX_INCLUDE_DEPTH: usize = 32;

/// One XML element with its attributes (in document order) and child elements.
#[derive(Clone, Debug)]
pub(crate) struct Element {
    pub tag: String,
    pub attrs: Vec<(String, String)>,
    pub children: Vec<Element>,
    pub file: Rc<PathBuf>,
    pub line: usize,
}

impl Element {
    /// The value of attribute `name`, if present.
    pub(crate) fn attr(&self, name: &str) -> Option<&str> {
        self.attrs.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_str())
    }

    /// How the element is named in errors: `<bsdf type="diffuse" id="white">`, `<float name="alpha">`.
    pub(crate) fn label(&self) -> String {
        let mut s = format!("<{}", self.tag);
        for a in ["type", "id", "name"] {
            if let Some(v) = self.attr(a) {
                s.push_str(&format!(" {a}=\"{v}\""));
            }
        }
        s.push('>');
        s
    }

    /// An error about this element.
    pub(crate) fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError::Key {
            file: self.file.as_ref().clone(),
            key: self.label(),
            line: Some(self.line),
            message: message.into(),
        }
    }

    /// Rejects attributes other than `allowed`.
    pub(crate) fn check_attrs(&self, allowed: &[&str]) -> Result<(), SceneError> {
        match self.attrs.iter().find(|(n, _)| !allowed.contains(&n.as_str())) {
            Some((n, _)) => Err(self.error(format!(
                "unknown attribute `{n}` (the attributes of <{}>: {})",
                self.tag,
                allowed.join(", ")
            ))),
            None => Ok(()),
        }
    }

    /// The value of a required attribute.
    pub(crate) fn required(&self, name: &str) -> Result<&str, SceneError> {
        self.attr(name).ok_or_else(|| self.error(format!("<{}> needs the attribute `{name}`", self.tag)))
    }
}

/// Parses `text` (named `path` in errors) and resolves its includes; relative include names are relative
/// to `base_dir` (the directory of the scene file given, as Mitsuba resolves them).
pub(crate) fn parse_scene(text: &str, path: &Path, base_dir: &Path, depth: usize) -> Result<Element, SceneError> {
    let file = Rc::new(path.to_path_buf());
    let doc = roxmltree::Document::parse(text).map_err(|e| SceneError::XmlSyntax {
        file: path.to_path_buf(),
        line: e.pos().row as usize,
        column: e.pos().col as usize,
        message: e.to_string(),
    })?;
    let mut root = owned(&doc, doc.root_element(), &file)?;
    if root.tag != "scene" {
        return Err(root.error("the root element must be <scene version=\"3.0.0\">"));
    }
    root.check_attrs(&["version"])?;
    // Each file by its own version: Mitsuba 0.x files are upgraded to 3.x before their includes are spliced.
    super::upgrade::upgrade_file(&mut root)?;
    let children = std::mem::take(&mut root.children);
    for child in children {
        if child.tag == "include" {
            child.check_attrs(&["filename"])?;
            if depth >= MAX_INCLUDE_DEPTH {
                return Err(child.error(format!("includes nested deeper than {MAX_INCLUDE_DEPTH} files (a cycle?)")));
            }
            let name = base_dir.join(child.required("filename")?);
            let text = std::fs::read_to_string(&name).map_err(|e| child.error(format!("cannot read {}: {e}", name.display())))?;
            let included = parse_scene(&text, &name, base_dir, depth + 1)?;
            root.children.extend(included.children);
        } else {
            root.children.push(child);
        }
    }
    Ok(root)
}

/// The element and its descendants as owned [`Element`]s; text other than whitespace is an error.
fn owned(doc: &roxmltree::Document, node: roxmltree::Node, file: &Rc<PathBuf>) -> Result<Element, SceneError> {
    let mut el = Element {
        tag: node.tag_name().name().to_string(),
        attrs: node.attributes().map(|a| (a.name().to_string(), a.value().to_string())).collect(),
        children: Vec::new(),
        file: Rc::clone(file),
        line: doc.text_pos_at(node.range().start).row as usize,
    };
    for child in node.children() {
        if child.is_element() {
            el.children.push(owned(doc, child, file)?);
        } else if child.is_text() && child.text().is_some_and(|t| !t.trim().is_empty()) {
            return Err(el.error("text inside an element is not part of Mitsuba's format (values go in `value` attributes)"));
        }
    }
    Ok(el)
}

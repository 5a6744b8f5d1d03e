//! The XML files as an owned element tree: every element keeps its file and line (for errors),
//! `<include filename="…"/>` elements are replaced by the children of the included file's `<scene>`, and
//! `<path value="…"/>` elements become the [`SearchPath`] relative file names are looked for along.

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

/// Where relative file names are looked for, as Mitsuba 3's file resolver does (`FileResolver`,
/// `src/core/parser.cpp`, tags `<path>` and `<include>`): the directories of `<path value="…"/>`
/// elements, the latest first, then the directory of the scene file given.
#[derive(Clone, Debug)]
pub(crate) struct SearchPath {
    dirs: Vec<PathBuf>,
}

impl SearchPath {
    /// The search path of a scene file in directory `base_dir`.
    pub(crate) fn new(base_dir: &Path) -> Self {
        Self { dirs: vec![base_dir.to_path_buf()] }
    }

    /// The directory of the scene file given (looked in last).
    pub(crate) fn base_dir(&self) -> &Path {
        self.dirs.last().map_or(Path::new(""), PathBuf::as_path)
    }

    /// The directories, for errors.
    fn describe(&self) -> String {
        self.dirs.iter().map(|d| format!("{:?}", d.display().to_string())).collect::<Vec<_>>().join(", ")
    }

    /// Looks in `dir` before every directory already listed.
    fn prepend(&mut self, dir: PathBuf) {
        self.dirs.insert(0, dir);
    }

    /// The first `dir/name` that exists, looking in the listed directories and then in `fallback` (the
    /// directory of the file that names it: Mitsuba itself would not look there for a mesh named in an
    /// included file, caustica does); `None` when none exists. An absolute name is returned as it is.
    pub(crate) fn resolve(&self, name: &str, fallback: Option<&Path>) -> Option<PathBuf> {
        let name = Path::new(name);
        if name.is_absolute() {
            return Some(name.to_path_buf());
        }
        self.dirs.iter().map(PathBuf::as_path).chain(fallback).map(|d| d.join(name)).find(|p| p.exists())
    }
}

/// Parses `text` (named `path` in errors) and resolves its includes and `<path>` elements: an include is
/// looked for in the including file's directory, then along `search` (the `<path>`s seen so far), as
/// Mitsuba does; the `<path>`s of the scene file given (`depth` 0) stay in `search` for the file names
/// of its plugins (Mitsuba resolves those after parsing), those of an included file apply to its own
/// includes only.
pub(crate) fn parse_scene(text: &str, path: &Path, search: &mut SearchPath, depth: usize) -> Result<Element, SceneError> {
    let file = Rc::new(path.to_path_buf());
    let text = comments_as_mitsuba_reads_them(text);
    let doc = roxmltree::Document::parse(&text).map_err(|e| SceneError::XmlSyntax {
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
    let dir = path.parent().unwrap_or_else(|| Path::new(""));
    let children = std::mem::take(&mut root.children);
    for child in children {
        match child.tag.as_str() {
            "include" => {
                child.check_attrs(&["filename", "name"])?;
                if depth >= MAX_INCLUDE_DEPTH {
                    return Err(child.error(format!("includes nested deeper than {MAX_INCLUDE_DEPTH} files (a cycle?)")));
                }
                let written = child.required("filename")?;
                let mut inner = search.clone();
                inner.prepend(dir.to_path_buf());
                let name = inner.resolve(written, None).ok_or_else(|| {
                    child.error(format!("included file {written:?} not found (looked in {})", inner.describe()))
                })?;
                let text = std::fs::read_to_string(&name).map_err(|e| child.error(format!("cannot read {}: {e}", name.display())))?;
                let included = parse_scene(&text, &name, &mut inner, depth + 1)?;
                root.children.extend(included.children);
            }
            "path" => {
                child.check_attrs(&["value"])?;
                let value = child.required("value")?;
                // Mitsuba: relative to the file's directory, else along the search path.
                let own = dir.join(value);
                let found = if own.is_dir() { Some(own) } else { search.resolve(value, None).filter(|p| p.is_dir()) };
                let found = found.ok_or_else(|| child.error(format!("<path>: folder {value:?} not found")))?;
                search.prepend(found);
            }
            _ => root.children.push(child),
        }
    }
    Ok(root)
}

/// `text` with the dashes inside comments blanked, so that a comment containing `--` (which XML forbids,
/// and Mitsuba's parser, pugixml, accepts) parses; every byte keeps its position, so lines and columns in
/// errors stay those of the file.
fn comments_as_mitsuba_reads_them(text: &str) -> std::borrow::Cow<'_, str> {
    let Some(mut start) = text.find("<!--") else {
        return std::borrow::Cow::Borrowed(text);
    };
    let mut out = text.as_bytes().to_vec();
    loop {
        let body = start + 4;
        let Some(len) = text[body..].find("-->") else { break };
        for b in &mut out[body..body + len] {
            if *b == b'-' {
                *b = b' ';
            }
        }
        match text[body + len + 3..].find("<!--") {
            Some(next) => start = body + len + 3 + next,
            None => break,
        }
    }
    // Only ASCII dashes were replaced by ASCII spaces: still UTF-8.
    std::borrow::Cow::Owned(String::from_utf8(out).expect("dashes replaced by spaces keep UTF-8"))
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

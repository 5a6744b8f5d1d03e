//! The XML files as an owned element tree: every element keeps its file and line (for errors),
//! `<include filename="…"/>` elements are replaced by the children of the included file's `<scene>`, and
//! `<path value="…"/>` elements become the [`SearchPath`] relative file names are looked for along.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use super::bounds::{self, Excess, Includes, Link, MAX_ATTRIBUTES, MAX_DEPTH, MAX_INCLUDE_DEPTH};
use super::params::Params;
use super::super::error::{cut, cut_message, shown, SceneError};

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
        let mut s = format!("<{}", cut(&self.tag));
        for a in ["type", "id", "name"] {
            if let Some(v) = self.attr(a) {
                s.push_str(&format!(" {a}={}", shown(v)));
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
                "unknown attribute `{}` (the attributes of <{}>: {})",
                cut(n),
                cut(&self.tag),
                allowed.join(", ")
            ))),
            None => Ok(()),
        }
    }

    /// The value of a required attribute.
    pub(crate) fn required(&self, name: &str) -> Result<&str, SceneError> {
        self.attr(name).ok_or_else(|| self.error(format!("<{}> needs the attribute `{name}`", cut(&self.tag))))
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

/// Reads the scene file `text` (named `path` in errors) into its element tree: includes spliced,
/// parameters (`-D` values `cli`, `<default>`s) substituted, each file upgraded by its own version; the
/// `<path>`s of the file stay in `search` for the file names of its plugins.
pub(crate) fn read_tree(text: &str, path: &Path, search: &mut SearchPath, cli: &BTreeMap<String, String>) -> Result<Element, SceneError> {
    let mut reading = Reading { params: Params::new(cli), includes: Includes::default() };
    let root = parse_scene(text, path, search, &mut reading)?;
    reading.params.check_cli(path)?;
    Ok(root)
}

/// What reading one scene carries from file to file: the parameters declared so far and the includes.
struct Reading {
    params: Params,
    includes: Includes,
}

/// Parses `text` (named `path` in errors) and resolves its includes and `<path>` elements: an include is
/// looked for in the including file's directory, then along `search` (the `<path>`s seen so far), as
/// Mitsuba does; the `<path>`s of the scene file given (include depth 0) stay in `search` for the file
/// names of its plugins (Mitsuba resolves those after parsing), those of an included file apply to its
/// own includes only. Elements are read, and their parameters substituted, in document order.
fn parse_scene(text: &str, path: &Path, search: &mut SearchPath, reading: &mut Reading) -> Result<Element, SceneError> {
    let file = Rc::new(path.to_path_buf());
    let text = comments_as_mitsuba_reads_them(text);
    let lines = Lines::new(&text);
    if let Some(excess) = bounds::scan(&text) {
        let (pos, tag, message) = match excess {
            Excess::Attributes { pos, tag, count } => {
                (pos, tag, format!("{count} attributes; an element has at most {MAX_ATTRIBUTES} (Mitsuba's take at most 5)"))
            }
            Excess::Depth { pos, tag } => (pos, tag, depth_message()),
            Excess::Prefixed { pos, tag } => (pos, tag, prefixed_message()),
            Excess::Namespace { pos, tag, attr } => (pos, tag, namespace_message(attr)),
        };
        return Err(SceneError::Key { file: path.to_path_buf(), key: format!("<{}>", cut(tag)), line: Some(lines.row(pos)), message });
    }
    let doc = roxmltree::Document::parse(&text).map_err(|e| SceneError::XmlSyntax {
        file: path.to_path_buf(),
        line: e.pos().row as usize,
        column: e.pos().col as usize,
        message: cut_message(&e.to_string()),
    })?;
    let builder = Builder { file: &file, lines: &lines };
    let node = doc.root_element();
    let mut root = builder.element(node, 1, &mut reading.params)?;
    if root.tag != "scene" {
        return Err(root.error("the root element must be <scene version=\"3.0.0\">"));
    }
    root.check_attrs(&["version"])?;
    let dir = path.parent().unwrap_or_else(|| Path::new(""));
    // The children of included files, in the order of the <include>s, spliced after the upgrade.
    let mut included = Vec::new();
    for child_node in node.children() {
        // One child at a time: an include's parameters hold for the elements after it.
        let Some(child) = builder.subtree(&root, child_node, 2, &mut reading.params)? else { continue };
        match child.tag.as_str() {
            "include" => {
                child.check_attrs(&["filename", "name"])?;
                let written = child.required("filename")?;
                let mut inner = search.clone();
                inner.prepend(dir.to_path_buf());
                let name = inner.resolve(written, None).ok_or_else(|| {
                    child.error(format!("included file {} not found (looked in {})", shown(written), inner.describe()))
                })?;
                let link = Link { file: Rc::clone(&file), line: child.line, included: name.clone() };
                if reading.includes.depth() >= MAX_INCLUDE_DEPTH {
                    let chain = reading.includes.describe(Some(&link));
                    return Err(child.error(format!("includes nested deeper than {MAX_INCLUDE_DEPTH} files (a cycle?): {chain}")));
                }
                let text = reading.includes.read(&name, &link).map_err(|message| child.error(message))?;
                reading.includes.enter(link);
                let inner_root = parse_scene(&text, &name, &mut inner, reading)?;
                reading.includes.leave();
                included.push(inner_root.children);
                root.children.push(child);
            }
            "path" => {
                child.check_attrs(&["value"])?;
                let value = child.required("value")?;
                // Mitsuba: relative to the file's directory, else along the search path.
                let own = dir.join(value);
                let found = if own.is_dir() { Some(own) } else { search.resolve(value, None).filter(|p| p.is_dir()) };
                let found = found.ok_or_else(|| child.error(format!("<path>: folder {} not found", shown(value))))?;
                search.prepend(found);
            }
            _ => root.children.push(child),
        }
    }
    // Each file by its own version: Mitsuba 0.x files are upgraded to 3.x before their includes are spliced.
    super::upgrade::upgrade_file(&mut root)?;
    let mut included = included.into_iter();
    let children = std::mem::take(&mut root.children);
    for child in children {
        if child.tag == "include" {
            root.children.extend(included.next().unwrap_or_default());
        } else {
            root.children.push(child);
        }
    }
    Ok(root)
}

fn depth_message() -> String {
    format!("elements nested more than {MAX_DEPTH} deep (<scene> is level 1; Mitsuba's scenes nest a few levels)")
}

/// Mitsuba 3.9.1 reads `<m:float>` as a tag it does not have ("encountered an unsupported XML element").
fn prefixed_message() -> String {
    "not an element of Mitsuba's format (Mitsuba's parser knows no XML namespaces: a prefixed tag is an element it does not have)".to_string()
}

/// Mitsuba 3.9.1 reads `xmlns:m="…"` as an attribute no element takes ("unexpected attribute").
fn namespace_message(attr: &str) -> String {
    format!("unknown attribute `{}` (Mitsuba's parser knows no XML namespaces: no element takes it)", cut(attr))
}

/// The line of each byte offset of a text (the XML parser's own lookup scans the text from its start
/// each time, which made reading quadratic in the number of elements).
struct Lines(Vec<usize>);

impl Lines {
    fn new(text: &str) -> Self {
        Self(std::iter::once(0).chain(text.bytes().enumerate().filter(|&(_, b)| b == b'\n').map(|(i, _)| i + 1)).collect())
    }

    /// The line (from 1) of byte offset `pos`.
    fn row(&self, pos: usize) -> usize {
        self.0.partition_point(|&start| start <= pos)
    }
}

/// Builds the owned elements of one file.
struct Builder<'a> {
    file: &'a Rc<PathBuf>,
    lines: &'a Lines,
}

impl Builder<'_> {
    /// The element `node` at nesting level `depth` without its children, its attributes substituted.
    /// Mitsuba's parser (pugixml) knows no namespaces: a prefixed tag is an element it does not have, and
    /// `xmlns` declarations are attributes that no element takes; both are refused here too.
    fn element(&self, node: roxmltree::Node, depth: usize, params: &mut Params) -> Result<Element, SceneError> {
        let qualified = |namespace: Option<&str>, local: &str| match namespace.map(|uri| node.lookup_prefix(uri)) {
            Some(Some(prefix)) if !prefix.is_empty() => format!("{prefix}:{local}"),
            _ => local.to_string(),
        };
        let mut el = Element {
            tag: qualified(node.tag_name().namespace(), node.tag_name().name()),
            attrs: node.attributes().map(|a| (qualified(a.namespace(), a.name()), a.value().to_string())).collect(),
            children: Vec::new(),
            file: Rc::clone(self.file),
            line: self.lines.row(node.range().start),
        };
        // `bounds::scan` found these before the parser ran; this keeps the bounds should it have stopped early.
        if depth > MAX_DEPTH {
            return Err(el.error(depth_message()));
        }
        if el.tag.contains(':') {
            return Err(el.error(prefixed_message()));
        }
        if let Some(ns) = node.namespaces().find(|ns| ns.name() != Some("xml")) {
            let attr = ns.name().map_or_else(|| "xmlns".to_string(), |p| format!("xmlns:{p}"));
            return Err(el.error(namespace_message(&attr)));
        }
        params.substitute(&mut el)?;
        Ok(el)
    }

    /// The child elements of `parent` (element `node`, its children at level `depth`) in document order,
    /// each with its descendants (see [`Builder::subtree`]).
    fn children(&self, parent: &Element, node: roxmltree::Node, depth: usize, params: &mut Params) -> Result<Vec<Element>, SceneError> {
        let mut children = Vec::new();
        for child in node.children() {
            children.extend(self.subtree(parent, child, depth, params)?);
        }
        Ok(children)
    }

    /// The child `node` (at level `depth`) of `parent` with its descendants, when it is an element but a
    /// `<default>` (which declares its parameter; one in a `<transform>` stays, to be refused). Text other
    /// than whitespace is an error.
    fn subtree(&self, parent: &Element, node: roxmltree::Node, depth: usize, params: &mut Params) -> Result<Option<Element>, SceneError> {
        if node.is_text() && node.text().is_some_and(|t| !t.trim().is_empty()) {
            return Err(parent.error("text inside an element is not part of Mitsuba's format (values go in `value` attributes)"));
        }
        if !node.is_element() {
            return Ok(None);
        }
        let mut el = self.element(node, depth, params)?;
        el.children = self.children(&el, node, depth + 1, params)?;
        if el.tag == "default" && parent.tag != "transform" {
            params.declare(&el)?;
            return Ok(None);
        }
        Ok(Some(el))
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("caustica-tree-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("tmp dir");
        d
    }

    /// The tree of `body` in a 3.0.0 scene with the `-D` values `cli`, written back compactly.
    fn read(body: &str, cli: &[(&str, &str)], d: &Path) -> Result<String, String> {
        let cli: BTreeMap<String, String> = cli.iter().map(|(n, v)| (n.to_string(), v.to_string())).collect();
        let text = format!("<scene version=\"3.0.0\">{body}</scene>");
        let root = read_tree(&text, &d.join("main.xml"), &mut SearchPath::new(d), &cli).map_err(|e| e.to_string())?;
        fn show(el: &Element) -> String {
            let attrs: String = el.attrs.iter().map(|(n, v)| format!(" {n}=\"{v}\"")).collect();
            format!("<{}{attrs}>{}", el.tag, el.children.iter().map(show).collect::<String>())
        }
        Ok(root.children.iter().map(show).collect())
    }

    #[test]
    fn nesting_is_bounded_with_the_file_and_line() {
        let d = dir("depth");
        let deep = |n: usize| format!("\n<shape type=\"cube\">{}{}</shape>", "<a>".repeat(n), "</a>".repeat(n));
        assert!(read(&deep(MAX_DEPTH - 2), &[], &d).is_ok());
        let e = read(&deep(MAX_DEPTH - 1), &[], &d).unwrap_err();
        assert!(e.contains("main.xml:2: <a>: elements nested more than 64 deep"), "{e}");
        let e = read(&deep(100_000), &[], &d).unwrap_err();
        assert!(e.contains("main.xml:2: <a>: elements nested more than 64 deep"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }

    /// Mitsuba 3.9.1: parameters are substituted in document order, the first value of a name wins (`-D`
    /// before any `<default>`), a `<default>` may be nested and may use earlier parameters, and an
    /// include's file name is substituted too.
    #[test]
    fn parameters_are_substituted_in_document_order_as_mitsuba_does() {
        let d = dir("params");
        let ok = |body: &str, cli: &[(&str, &str)]| read(body, cli, &d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ok("<default name=\"r\" value=\"1\"/><default name=\"r\" value=\"2\"/><float name=\"a\" value=\"$r\"/>", &[]), "<float name=\"a\" value=\"1\">");
        assert_eq!(ok("<default name=\"r\" value=\"1\"/><float name=\"a\" value=\"$r\"/>", &[("r", "3")]), "<float name=\"a\" value=\"3\">");
        assert_eq!(
            ok("<default name=\"a\" value=\"2\"/><shape type=\"sphere\"><default name=\"r\" value=\"$a$a\"/><float name=\"radius\" value=\"$r\"/></shape>", &[]),
            "<shape type=\"sphere\"><float name=\"radius\" value=\"22\">"
        );
        let e = read("<float name=\"a\" value=\"$r\"/><default name=\"r\" value=\"1\"/>", &[], &d).unwrap_err();
        assert!(e.contains("main.xml:1: <float name=\"a\">: attribute `value`: $r is not defined"), "{e}");
        // A <default> in a <transform> is not one (Mitsuba: "unexpected <default> element inside <transform>").
        assert_eq!(ok("<transform name=\"t\"><default name=\"r\" value=\"1\"/></transform>", &[]), "<transform name=\"t\"><default name=\"r\" value=\"1\">");
        std::fs::write(d.join("part_b.xml"), "<scene version=\"3.0.0\"><default name=\"w\" value=\"5\"/><bsdf type=\"diffuse\"/></scene>").expect("write");
        assert_eq!(ok("<default name=\"p\" value=\"b\"/><include filename=\"part_$p.xml\"/><float name=\"x\" value=\"$w\"/>", &[]), "<bsdf type=\"diffuse\"><float name=\"x\" value=\"5\">");
        let e = read("<default name=\"r\" value=\"1\"/>", &[("q", "1")], &d).unwrap_err();
        assert!(e.contains("-D q: the scene has no <default name=\"q\"> and no $q"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }

    /// Mitsuba 3.9.1 knows no XML namespaces: `<m:float xmlns:m="…">` is an element it does not have, an
    /// `xmlns` an attribute no element takes.
    #[test]
    fn namespaces_are_refused_as_mitsuba_refuses_them() {
        let d = dir("ns");
        let e = read("\n<shape type=\"sphere\"><m:float xmlns:m=\"http://x\" name=\"radius\" value=\"2\"/></shape>", &[], &d).unwrap_err();
        assert!(e.contains("main.xml:2: <m:float>: not an element of Mitsuba's format"), "{e}");
        let e = read("<float xmlns:m=\"http://x\" name=\"radius\" value=\"2\"/>", &[], &d).unwrap_err();
        assert!(e.contains("main.xml:1: <float>: unknown attribute `xmlns:m`"), "{e}");
        // `xml:` is the one prefix XML binds without a declaration: its attributes keep their prefix
        // (and are refused later, as no element takes them).
        let out = read("<float xml:lang=\"en\" name=\"radius\" value=\"2\"/>", &[], &d).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(out, "<float xml:lang=\"en\" name=\"radius\" value=\"2\">");
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn includes_are_regular_files_and_their_chain_is_named() {
        let d = dir("includes");
        let e = read("\n<include filename=\"/dev/zero\"/>", &[], &d).unwrap_err();
        assert!(e.contains("main.xml:2: <include>: /dev/zero is not a regular file"), "{e}");
        std::fs::write(d.join("a.xml"), "<scene version=\"3.0.0\">\n<include filename=\"a.xml\"/></scene>").expect("write");
        let e = read("<include filename=\"a.xml\"/>", &[], &d).unwrap_err();
        assert!(e.contains("a.xml:2: <include>: includes nested deeper than 32 files (a cycle?)") && e.contains("main.xml:1 includes"), "{e}");
        std::fs::remove_dir_all(&d).ok();
    }
}

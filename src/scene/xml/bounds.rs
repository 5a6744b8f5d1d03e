//! The bounds on what the XML reader reads, so that no file, however written, can crash, hang or exhaust
//! the machine (issue 40): how deep elements nest, how many attributes one element has, and how many and
//! how large the included files are. Each bound is far above what a Mitsuba scene needs and is named in
//! the error that enforces it:
//!
//! ```xml
//! <scene version="3.0.0">                        <!-- nesting level 1 … at most MAX_DEPTH -->
//!     <include filename="materials.xml"/>         <!-- a regular file of at most MAX_INCLUDE_BYTES;
//!                                                      MAX_INCLUDES inclusions and MAX_INCLUDED_BYTES in all -->
//!     <shape type="obj" id="a">                   <!-- at most MAX_ATTRIBUTES attributes -->
//! </scene>
//! ```
//!
//! The scene file named on the command line (TOML or XML) is read by the same rule as one included file
//! ([`read_regular`] with [`MAX_INCLUDE_BYTES`]).
//!
//! Mitsuba 3.9.1 bounds only the depth of includes (15, `ParserConfig::max_include_depth`,
//! include/mitsuba/core/parser.h); its parser (`parse_xml_node`, src/core/parser.cpp) recurses once per
//! nesting level, so a deep enough file overflows its stack.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::rc::Rc;

/// How deep elements may nest, `<scene>` being level 1. Mitsuba scenes nest a handful of levels
/// (`<scene>`, `<shape>`, a few nested `<bsdf>`s, `<texture>`, `<transform>`, `<translate>`); the
/// readers after this one (the scene description goes through TOML, whose parser allows keys 80 deep)
/// recurse once per level, so the bound keeps every later stage within its limits and the stack.
pub(crate) const MAX_DEPTH: usize = 64;

/// Attributes of one element. Mitsuba's elements take at most five (`<rotate x y z angle>`, `<point
/// name x y z>`); the XML parser checks an element's attributes for duplicates pairwise, so the count
/// must be bounded before it runs (100,000 attributes took 15 s).
pub(crate) const MAX_ATTRIBUTES: usize = 32;

/// Deepest chain of files including each other (a cycle is reported when it is exceeded). Mitsuba 3
/// allows 15; caustica keeps its former bound of 32 so that no file it read is refused now.
pub(crate) const MAX_INCLUDE_DEPTH: usize = 32;

/// Inclusions in one scene, every `<include>` counted (the same file twice counts twice): real scenes
/// include a few files, an exporter writing one file per object a few thousand. It stops an include
/// bomb (26 files each including the next twice make 2²⁶ inclusions within the depth bound) at once.
pub(crate) const MAX_INCLUDES: usize = 10_000;

/// Size of one included file. The largest Mitsuba scene files (inline meshes and matrices written by
/// exporters) are tens of MB; the bound keeps one include from filling memory (`/proc` files, a file
/// still growing) and is checked on the bytes read, not only on the size the file system states.
pub(crate) const MAX_INCLUDE_BYTES: u64 = 256 << 20;

/// Size of all included files together: the parsed tree takes a few times the text, so this keeps a
/// scene's text within a few GB of memory however its includes repeat.
pub(crate) const MAX_INCLUDED_BYTES: u64 = 512 << 20;

/// One `<include>` on the chain from the scene file to the file being read: the including file and line,
/// and the file it names.
#[derive(Clone, Debug)]
pub(crate) struct Link {
    pub file: Rc<PathBuf>,
    pub line: usize,
    pub included: PathBuf,
}

/// The includes read so far, and the chain of includes being read.
#[derive(Debug, Default)]
pub(crate) struct Includes {
    count: usize,
    bytes: u64,
    chain: Vec<Link>,
}

impl Includes {
    /// How deep the chain is (0 while reading the scene file given).
    pub(crate) fn depth(&self) -> usize {
        self.chain.len()
    }

    pub(crate) fn enter(&mut self, link: Link) {
        self.chain.push(link);
    }

    pub(crate) fn leave(&mut self) {
        self.chain.pop();
    }

    /// The chain with `next`, for errors: `scene.xml:5 includes a.xml, a.xml:1 includes b.xml`.
    pub(crate) fn describe(&self, next: Option<&Link>) -> String {
        let links = self.chain.iter().chain(next).map(|l| format!("{}:{} includes {}", l.file.display(), l.line, l.included.display()));
        links.collect::<Vec<_>>().join(", ")
    }

    /// The text of the file `path` named by the include `link`: refused unless it is a regular file (a
    /// device such as /dev/zero would be read without end, a FIFO would wait for a writer), and read with
    /// the bounds on one file and on all included text. The error is a message for the `<include>`.
    pub(crate) fn read(&mut self, path: &Path, link: &Link) -> Result<String, String> {
        self.count += 1;
        if self.count > MAX_INCLUDES {
            return Err(format!(
                "more than {MAX_INCLUDES} inclusions in one scene (each <include> counts, repeats too; an include bomb?): {}",
                self.describe(Some(link))
            ));
        }
        let limit = MAX_INCLUDE_BYTES.min(MAX_INCLUDED_BYTES - self.bytes);
        match read_regular(path, limit) {
            Ok(text) => {
                self.bytes += text.len() as u64;
                Ok(text)
            }
            Err(Unreadable::Io(e)) => Err(format!("cannot read {}: {e}", path.display())),
            Err(e @ (Unreadable::Directory | Unreadable::NotRegular)) => Err(format!("{} is {e}; an included file must be a regular file", path.display())),
            Err(Unreadable::TooLarge { bytes }) if bytes > MAX_INCLUDE_BYTES => {
                Err(format!("{} is larger than {} MiB, the bound on one included file", path.display(), MAX_INCLUDE_BYTES >> 20))
            }
            Err(Unreadable::TooLarge { bytes }) => Err(format!(
                "{} ({bytes} bytes) would take the included text over {} MiB in all: {}",
                path.display(),
                MAX_INCLUDED_BYTES >> 20,
                self.describe(Some(link))
            )),
        }
    }
}

/// Why [`read_regular`] did not read a file.
#[derive(Debug, thiserror::Error)]
pub(crate) enum Unreadable {
    #[error("{0}")]
    Io(std::io::Error),
    #[error("a directory")]
    Directory,
    #[error("not a regular file (a device, FIFO or socket)")]
    NotRegular,
    /// At least `bytes` bytes (the size the file system states, or the bytes read past the limit).
    #[error("larger than the bound on it ({bytes} bytes or more)")]
    TooLarge { bytes: u64 },
}

/// The text (UTF-8) of the file at `path`, read only if it is a regular file (a device such as /dev/zero
/// would be read without end, a FIFO would wait for a writer) of at most `limit` bytes, checked on the
/// size stated and on the bytes read (a file still growing, `/proc`). The rule for included files and for
/// the scene file given.
pub(crate) fn read_regular(path: &Path, limit: u64) -> Result<String, Unreadable> {
    let meta = std::fs::metadata(path).map_err(Unreadable::Io)?;
    if meta.is_dir() {
        return Err(Unreadable::Directory);
    }
    if !meta.is_file() {
        return Err(Unreadable::NotRegular);
    }
    if meta.len() > limit {
        return Err(Unreadable::TooLarge { bytes: meta.len() });
    }
    let file = std::fs::File::open(path).map_err(Unreadable::Io)?;
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit + 1).read_to_end(&mut bytes).map_err(Unreadable::Io)?;
    if bytes.len() as u64 > limit {
        return Err(Unreadable::TooLarge { bytes: bytes.len() as u64 });
    }
    String::from_utf8(bytes).map_err(|_| Unreadable::Io(std::io::Error::new(std::io::ErrorKind::InvalidData, "stream did not contain valid UTF-8")))
}

/// What [`scan`] found first: an element (its byte offset and tag) that is too crowded, too deep, or
/// written with XML namespaces, which Mitsuba's parser does not know (a prefixed tag is an element it
/// does not have, an `xmlns` declaration an attribute that no element takes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Excess<'a> {
    Attributes { pos: usize, tag: &'a str, count: usize },
    Depth { pos: usize, tag: &'a str },
    Prefixed { pos: usize, tag: &'a str },
    Namespace { pos: usize, tag: &'a str, attr: &'a str },
}

/// Checks the start tags of `text` against [`MAX_ATTRIBUTES`] and [`MAX_DEPTH`], and for namespaces,
/// before the XML parser builds its tree (whose duplicate-attribute and namespace checks are quadratic in
/// the attributes of an element and the namespaces in scope). It skips comments, CDATA sections,
/// processing instructions and quoted values, stops at a DTD (which the XML parser refuses) and at
/// anything malformed (which the parser reports). Linear in the text.
pub(crate) fn scan(text: &str) -> Option<Excess<'_>> {
    let b = text.as_bytes();
    let find = |from: usize, pat: &str| text.get(from..).and_then(|t| t.find(pat)).map(|p| from + p);
    let mut depth = 0_usize;
    let mut i = 0;
    while let Some(lt) = find(i, "<") {
        let rest = &text[lt..];
        i = if rest.starts_with("<!--") {
            find(lt + 4, "-->")? + 3
        } else if rest.starts_with("<![CDATA[") {
            find(lt + 9, "]]>")? + 3
        } else if rest.starts_with("<?") {
            find(lt + 2, "?>")? + 2
        } else if rest.starts_with("<!") {
            return None;
        } else if rest.starts_with("</") {
            depth = depth.saturating_sub(1);
            find(lt, ">")? + 1
        } else {
            let name_end = rest[1..].find(|c: char| c.is_whitespace() || c == '/' || c == '>').map_or(rest.len(), |p| p + 1);
            let tag = &rest[1..name_end];
            if tag.contains(':') {
                return Some(Excess::Prefixed { pos: lt, tag });
            }
            let mut j = lt + name_end;
            let (mut count, mut name_start) = (0, j);
            loop {
                match b.get(j)? {
                    b'>' => break,
                    b'=' => {
                        count += 1;
                        let attr = text[name_start..j].trim();
                        if attr == "xmlns" || attr.starts_with("xmlns:") {
                            return Some(Excess::Namespace { pos: lt, tag, attr });
                        }
                    }
                    q @ (b'"' | b'\'') => {
                        j = text[j + 1..].find(*q as char).map(|p| j + 1 + p)?;
                        name_start = j + 1;
                    }
                    b'<' => return None,
                    _ => {}
                }
                j += 1;
            }
            if count > MAX_ATTRIBUTES {
                return Some(Excess::Attributes { pos: lt, tag, count });
            }
            if b[j - 1] != b'/' {
                depth += 1;
                if depth > MAX_DEPTH {
                    return Some(Excess::Depth { pos: lt, tag });
                }
            }
            j + 1
        };
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn crowded_deep_and_namespaced_elements_are_found_outside_comments_and_values() {
        let many = |n: usize| (0..n).map(|i| format!(" a{i}=\"{i}\"")).collect::<String>();
        let ok = format!("<scene{}><!-- <x{}> --><![CDATA[<y{}>]]><?pi <z{}>?><a v='>{}'/></scene>", many(32), many(40), many(40), many(40), many(40));
        assert_eq!(scan(&ok), None);
        let text = format!("<scene>\n<b/><shape type=\"a>b\"{}/></scene>", many(32));
        assert_eq!(scan(&text), Some(Excess::Attributes { pos: 12, tag: "shape", count: 33 }));
        let deep = |n: usize| format!("<scene>{}{}</scene>", "<a><b/>".repeat(n), "</a>".repeat(n));
        assert_eq!(scan(&deep(MAX_DEPTH - 1)), None);
        assert_eq!(scan(&deep(MAX_DEPTH)), Some(Excess::Depth { pos: 7 + 7 * (MAX_DEPTH - 1), tag: "a" }));
        assert_eq!(scan("<scene><m:float/></scene>"), Some(Excess::Prefixed { pos: 7, tag: "m:float" }));
        let ns = "<scene><float name='a' xmlns:m = 'x'/></scene>";
        assert_eq!(scan(ns), Some(Excess::Namespace { pos: 7, tag: "float", attr: "xmlns:m" }));
        assert_eq!(scan("<scene xmlns=\"x\"/>"), Some(Excess::Namespace { pos: 0, tag: "scene", attr: "xmlns" }));
        // Malformed text and DTDs are left to the parser.
        assert_eq!(scan(&format!("<a x=\"{}", many(40))), None);
        assert_eq!(scan(&format!("<!DOCTYPE a><a{}/>", many(40))), None);
    }

    #[test]
    fn includes_must_be_regular_files_within_the_bounds() {
        let mut includes = Includes::default();
        let link = Link { file: Rc::new(PathBuf::from("scene.xml")), line: 3, included: PathBuf::from("/dev/zero") };
        let e = includes.read(Path::new("/dev/zero"), &link).unwrap_err();
        assert!(e.contains("/dev/zero is not a regular file"), "{e}");
        let e = includes.read(Path::new("/"), &link).unwrap_err();
        assert!(e.contains("is a directory"), "{e}");
        includes.count = MAX_INCLUDES;
        includes.enter(link.clone());
        let e = includes.read(Path::new("/dev/zero"), &link).unwrap_err();
        assert!(e.contains("more than 10000 inclusions") && e.contains("scene.xml:3 includes /dev/zero, scene.xml:3 includes"), "{e}");
    }
}

//! Maps byte spans of a TOML document to key paths (`shape[3].bsdf.reflectance`) and back to line numbers,
//! so that every scene error can name the key it is about.
//!
//! The document is read a second time into a generic tree whose keys and values carry their spans
//! (`toml::Spanned`); a span reported by the typed deserialiser is then attributed to the innermost key or
//! value that encloses it.

use std::ops::Range;

use serde::de::{Deserialize, Deserializer, MapAccess, SeqAccess, Visitor};

/// One key or array element of the document: its path, the span of its value and (for table keys) of the key.
#[derive(Clone, Debug)]
struct Entry {
    path: String,
    value_span: Option<Range<usize>>,
    key_span: Option<Range<usize>>,
}

/// All keys and array elements of a document with their spans, plus the line starts of the text.
#[derive(Clone, Debug, Default)]
pub(crate) struct SpanIndex {
    entries: Vec<Entry>,
    line_starts: Vec<usize>,
}

// The private protocol by which `toml` hands out spans (`serde_spanned`'s `Spanned`): a struct with these
// names is deserialised as a map {start, end, value} when the deserialiser knows the span, and as the plain
// value otherwise (dotted keys such as `to_world.look_at` have no span of their own). `toml::Spanned` fails in
// the second case, so the index reads both forms itself.
const SPANNED_NAME: &str = "$__serde_spanned_private_Spanned";
const SPANNED_START: &str = "$__serde_spanned_private_start";
const SPANNED_END: &str = "$__serde_spanned_private_end";
const SPANNED_VALUE: &str = "$__serde_spanned_private_value";
const SPANNED_FIELDS: &[&str] = &[SPANNED_START, SPANNED_END, SPANNED_VALUE];

/// A generic TOML value whose keys and values carry their spans when the parser knows them.
enum Node {
    Leaf,
    Table(Vec<(SKey, SNode)>),
    Array(Vec<SNode>),
}

/// A table key and its span.
struct SKey {
    name: String,
    span: Option<Range<usize>>,
}

/// A value and its span.
struct SNode {
    span: Option<Range<usize>>,
    node: Node,
}

/// A value read without asking for its span (the inside of a spanned value).
struct AnyNode(Node);

impl<'de> Deserialize<'de> for AnyNode {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        deserializer.deserialize_any(NodeVisitor).map(AnyNode)
    }
}

impl<'de> Deserialize<'de> for SKey {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct KeyVisitor;
        impl<'de> Visitor<'de> for KeyVisitor {
            type Value = SKey;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a key")
            }
            fn visit_str<E>(self, v: &str) -> Result<SKey, E> {
                Ok(SKey {
                    name: v.to_string(),
                    span: None,
                })
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<SKey, A::Error> {
                let (span, name) = read_spanned::<A, String>(&mut map)?;
                Ok(SKey { name, span: Some(span) })
            }
        }
        deserializer.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, KeyVisitor)
    }
}

/// Reads the three entries of a spanned value whose first key has not been consumed yet.
fn read_spanned<'de, A: MapAccess<'de>, T: Deserialize<'de>>(map: &mut A) -> Result<(Range<usize>, T), A::Error> {
    use serde::de::Error;
    let mut start = None;
    let mut end = None;
    let mut value = None;
    while let Some(key) = map.next_key::<String>()? {
        match key.as_str() {
            SPANNED_START => start = Some(map.next_value::<usize>()?),
            SPANNED_END => end = Some(map.next_value::<usize>()?),
            SPANNED_VALUE => value = Some(map.next_value::<T>()?),
            other => return Err(A::Error::custom(format!("unexpected key {other} in a spanned value"))),
        }
    }
    match (start, end, value) {
        (Some(s), Some(e), Some(v)) => Ok((s..e, v)),
        _ => Err(A::Error::custom("incomplete spanned value")),
    }
}

impl<'de> Deserialize<'de> for SNode {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct SNodeVisitor;
        impl<'de> Visitor<'de> for SNodeVisitor {
            type Value = SNode;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("any TOML value")
            }
            fn visit_bool<E>(self, _: bool) -> Result<SNode, E> {
                Ok(SNode {
                    span: None,
                    node: Node::Leaf,
                })
            }
            fn visit_i64<E>(self, _: i64) -> Result<SNode, E> {
                Ok(SNode {
                    span: None,
                    node: Node::Leaf,
                })
            }
            fn visit_u64<E>(self, _: u64) -> Result<SNode, E> {
                Ok(SNode {
                    span: None,
                    node: Node::Leaf,
                })
            }
            fn visit_f64<E>(self, _: f64) -> Result<SNode, E> {
                Ok(SNode {
                    span: None,
                    node: Node::Leaf,
                })
            }
            fn visit_str<E>(self, _: &str) -> Result<SNode, E> {
                Ok(SNode {
                    span: None,
                    node: Node::Leaf,
                })
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<SNode, A::Error> {
                NodeVisitor.visit_seq(seq).map(|node| SNode { span: None, node })
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<SNode, A::Error> {
                // Either the spanned protocol (first key `start`) or a plain table without a span.
                let Some(first) = map.next_key::<SKey>()? else {
                    return Ok(SNode {
                        span: None,
                        node: Node::Table(Vec::new()),
                    });
                };
                if first.name == SPANNED_START {
                    let start = map.next_value::<usize>()?;
                    let (span, AnyNode(node)) = read_spanned_rest::<A>(&mut map, start)?;
                    return Ok(SNode { span: Some(span), node });
                }
                let mut items = vec![(first, map.next_value::<SNode>()?)];
                while let Some(key) = map.next_key::<SKey>()? {
                    items.push((key, map.next_value::<SNode>()?));
                }
                Ok(SNode {
                    span: None,
                    node: Node::Table(items),
                })
            }
        }
        deserializer.deserialize_struct(SPANNED_NAME, SPANNED_FIELDS, SNodeVisitor)
    }
}

/// Reads `end` and `value` of a spanned value whose `start` was already read.
fn read_spanned_rest<'de, A: MapAccess<'de>>(map: &mut A, start: usize) -> Result<(Range<usize>, AnyNode), A::Error> {
    use serde::de::Error;
    let mut end = None;
    let mut value = None;
    while let Some(key) = map.next_key::<String>()? {
        match key.as_str() {
            SPANNED_END => end = Some(map.next_value::<usize>()?),
            SPANNED_VALUE => value = Some(map.next_value::<AnyNode>()?),
            other => return Err(A::Error::custom(format!("unexpected key {other} in a spanned value"))),
        }
    }
    match (end, value) {
        (Some(e), Some(v)) => Ok((start..e, v)),
        _ => Err(A::Error::custom("incomplete spanned value")),
    }
}

struct NodeVisitor;

impl<'de> Visitor<'de> for NodeVisitor {
    type Value = Node;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("any TOML value")
    }
    fn visit_bool<E>(self, _: bool) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_i64<E>(self, _: i64) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_u64<E>(self, _: u64) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_f64<E>(self, _: f64) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_str<E>(self, _: &str) -> Result<Node, E> {
        Ok(Node::Leaf)
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Node, A::Error> {
        let mut items = Vec::new();
        while let Some(item) = seq.next_element::<SNode>()? {
            items.push(item);
        }
        Ok(Node::Array(items))
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Node, A::Error> {
        let mut items = Vec::new();
        while let Some(key) = map.next_key::<SKey>()? {
            let value = map.next_value::<SNode>()?;
            items.push((key, value));
        }
        Ok(Node::Table(items))
    }
}

/// `name` as it would be written in a key path: bare if it is a bare TOML key, quoted otherwise.
pub(crate) fn key_segment(name: &str) -> String {
    if !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-') {
        name.to_string()
    } else {
        format!("{name:?}")
    }
}

/// Joins a parent path and a key (`a` + `b` → `a.b`; `` + `b` → `b`).
pub(crate) fn join_key(parent: &str, key: &str) -> String {
    if parent.is_empty() {
        key_segment(key)
    } else {
        format!("{parent}.{}", key_segment(key))
    }
}

/// Joins a parent path and an array index (`a` + 3 → `a[3]`).
pub(crate) fn join_index(parent: &str, index: usize) -> String {
    format!("{parent}[{index}]")
}

impl SpanIndex {
    /// Indexes `text`. A document the generic reader cannot walk (it should not happen for valid TOML)
    /// gives an index without entries: errors then carry line numbers but no key paths.
    pub(crate) fn new(text: &str) -> Self {
        let mut index = Self::lines_only(text);
        if let Ok(AnyNode(Node::Table(items))) = toml::from_str::<AnyNode>(text) {
            index.add_table("", items);
        }
        index
    }

    /// An index of the line starts only (for documents that are not valid TOML).
    pub(crate) fn lines_only(text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.char_indices().filter(|&(_, c)| c == '\n').map(|(i, _)| i + 1));
        Self {
            entries: Vec::new(),
            line_starts,
        }
    }

    fn add_table(&mut self, parent: &str, items: Vec<(SKey, SNode)>) {
        for (key, value) in items {
            let path = join_key(parent, &key.name);
            self.entries.push(Entry {
                path: path.clone(),
                value_span: value.span,
                key_span: key.span,
            });
            self.add_node(&path, value.node);
        }
    }

    fn add_node(&mut self, path: &str, node: Node) {
        match node {
            Node::Leaf => {}
            Node::Table(items) => self.add_table(path, items),
            Node::Array(items) => {
                for (i, item) in items.into_iter().enumerate() {
                    let item_path = join_index(path, i);
                    self.entries.push(Entry {
                        path: item_path.clone(),
                        value_span: item.span,
                        key_span: None,
                    });
                    self.add_node(&item_path, item.node);
                }
            }
        }
    }

    /// The key path of the innermost key or value enclosing `span` (`None` if it is outside every key).
    pub(crate) fn path_at(&self, span: &Range<usize>) -> Option<String> {
        // toml reports errors about the document root (a missing top-level key) with an empty span at the
        // start; an empty span only matches an identical one.
        let encloses = |r: &Range<usize>| {
            if span.is_empty() {
                r == span
            } else {
                r.start <= span.start && span.end <= r.end
            }
        };
        let mut best: Option<(&Entry, usize)> = None;
        for e in &self.entries {
            for r in e.key_span.iter().chain(e.value_span.iter()) {
                if encloses(r) {
                    let len = r.end - r.start;
                    let better = match best {
                        None => true,
                        Some((b, blen)) => len < blen || (len == blen && e.path.len() > b.path.len()),
                    };
                    if better {
                        best = Some((e, len));
                    }
                }
            }
        }
        best.map(|(e, _)| e.path.clone())
    }

    /// 1-based line and column of byte offset `offset`.
    pub(crate) fn line_col(&self, offset: usize) -> (usize, usize) {
        let line = self.line_starts.partition_point(|&s| s <= offset).max(1);
        (line, offset - self.line_starts[line - 1] + 1)
    }

    /// 1-based line where `path` is written (its key, or its value for array elements), if it is in the file.
    pub(crate) fn line_of(&self, path: &str) -> Option<usize> {
        let e = self.entries.iter().find(|e| e.path == path)?;
        let start = e.key_span.as_ref().or(e.value_span.as_ref())?.start;
        Some(self.line_col(start).0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = r#"
[integrator]
spp = 3
[sensor]
film = { width = 2, crop = [1, 2, 3, 4] }
to_world.look_at.origin = [0, 0, 1]

[bsdf."my mat"]
type = "diffuse"

[[shape]]
type = "rectangle"
to_world = [ { rotate = { axis = [1,0,0], angle = -90 } }, { translate = [0,-1,0] } ]

[[shape]]
type = "sphere"
bsdf = { type = "diffuse", reflectance = [1, 2, 3] }
[shape.emitter]
type = "area"
"#;

    fn span_of(needle: &str) -> Range<usize> {
        let start = TEXT.find(needle).expect("needle in text");
        start..start + needle.len()
    }

    #[test]
    fn spans_map_to_key_paths_and_lines() {
        let idx = SpanIndex::new(TEXT);
        let path = |needle: &str| idx.path_at(&span_of(needle));
        assert_eq!(path("[1, 2, 3]").as_deref(), Some("shape[1].bsdf.reflectance"));
        assert_eq!(path("crop").as_deref(), Some("sensor.film.crop"));
        assert_eq!(path("3, 4]").as_deref(), Some("sensor.film.crop"));
        assert_eq!(path("[0, 0, 1]").as_deref(), Some("sensor.to_world.look_at.origin"));
        assert_eq!(path("-90").as_deref(), Some("shape[0].to_world[0].rotate.angle"));
        assert_eq!(path("[0,-1,0]").as_deref(), Some("shape[0].to_world[1].translate"));
        assert_eq!(path("\"area\"").as_deref(), Some("shape[1].emitter.type"));
        assert_eq!(path("\"diffuse\"").as_deref(), Some("bsdf.\"my mat\".type"));
        assert_eq!(idx.path_at(&(0..0)), None);
        assert_eq!(idx.line_of("shape[1].emitter.type"), Some(19));
        assert_eq!(idx.line_of("sensor.to_world.look_at.origin"), Some(6));
        assert_eq!(idx.line_of("shape[0]"), Some(11));
        assert_eq!(idx.line_of("nope"), None);
        assert_eq!(idx.line_col(0), (1, 1));
        assert_eq!(idx.line_col(TEXT.find("spp").unwrap()), (3, 1));
    }
}

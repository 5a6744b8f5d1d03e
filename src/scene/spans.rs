//! Maps byte spans of a TOML document to key paths (`shape[3].bsdf.reflectance`) and back to line numbers,
//! so that every scene error can name the key it is about.
//!
//! The document is read a second time by `toml_edit` (the parser under `toml`), whose keys and values
//! carry their spans; a span reported by the typed deserialiser is then attributed to the innermost key or
//! value that encloses it. That second reading is the slowest step of loading a large TOML scene, and only
//! an error needs it: a scene being built holds a [`SpanIndex::deferred`] index, read at its first question.

use std::ops::Range;
use std::sync::{Arc, OnceLock};

use toml_edit::{ImDocument, Item, TableLike, Value};

/// One key or array element of the document: its path, the span of its value and (for table keys) of the key.
#[derive(Clone, Debug)]
struct Entry {
    path: String,
    value_span: Option<Range<usize>>,
    key_span: Option<Range<usize>>,
}

/// All keys and array elements of a document with their spans, plus the line starts of the text.
#[derive(Clone, Debug, Default)]
struct Index {
    entries: Vec<Entry>,
    line_starts: Vec<usize>,
}

/// The [`Index`] of a document, made when it is built or at its first question ([`SpanIndex::deferred`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct SpanIndex {
    /// The text a deferred index reads when first asked (`None`: the index is made).
    text: Option<Arc<str>>,
    index: OnceLock<Index>,
}

/// Appends `name` as it would be written in a key path: bare if it is a bare TOML key, quoted otherwise.
fn push_segment(s: &mut String, name: &str) {
    if !name.is_empty() && name.bytes().all(|c| c.is_ascii_alphanumeric() || c == b'_' || c == b'-') {
        s.push_str(name);
    } else {
        use std::fmt::Write;
        let _ = write!(s, "{name:?}");
    }
}

/// Joins a parent path and a key (`a` + `b` → `a.b`; `` + `b` → `b`). (One allocation: the XML reader
/// makes a path for every key of every element.)
pub(crate) fn join_key(parent: &str, key: &str) -> String {
    let mut s = String::with_capacity(parent.len() + 1 + key.len());
    if !parent.is_empty() {
        s.push_str(parent);
        s.push('.');
    }
    push_segment(&mut s, key);
    s
}

/// Joins a parent path and an array index (`a` + 3 → `a[3]`).
pub(crate) fn join_index(parent: &str, index: usize) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(parent.len() + 8);
    let _ = write!(s, "{parent}[{index}]");
    s
}

impl SpanIndex {
    /// Indexes `text`. A document the generic reader cannot walk (it should not happen for valid TOML)
    /// gives an index without entries: errors then carry line numbers but no key paths.
    pub(crate) fn new(text: &str) -> Self {
        Self::made(Index::new(text))
    }

    /// The index of `text`, made when it is first asked (a copy of the text waits until then): what an
    /// error needs, at no cost to a scene without one.
    pub(crate) fn deferred(text: &str) -> Self {
        Self { text: Some(Arc::from(text)), index: OnceLock::new() }
    }

    /// An index of the line starts only (for documents that are not valid TOML).
    pub(crate) fn lines_only(text: &str) -> Self {
        Self::made(Index::lines_only(text))
    }

    fn made(index: Index) -> Self {
        Self { text: None, index: OnceLock::from(index) }
    }

    fn index(&self) -> &Index {
        self.index.get_or_init(|| self.text.as_deref().map(Index::new).unwrap_or_default())
    }

    /// The key path of the innermost key or value enclosing `span` (`None` if it is outside every key).
    pub(crate) fn path_at(&self, span: &Range<usize>) -> Option<String> {
        self.index().path_at(span)
    }

    /// 1-based line and column of byte offset `offset`.
    pub(crate) fn line_col(&self, offset: usize) -> (usize, usize) {
        self.index().line_col(offset)
    }

    /// 1-based line where `path` is written (its key, or its value for array elements), if it is in the file.
    pub(crate) fn line_of(&self, path: &str) -> Option<usize> {
        self.index().line_of(path)
    }
}

impl Index {
    fn new(text: &str) -> Self {
        let mut index = Self::lines_only(text);
        if let Ok(doc) = ImDocument::parse(text) {
            index.add_table("", doc.as_table());
        }
        index
    }

    fn lines_only(text: &str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.char_indices().filter(|&(_, c)| c == '\n').map(|(i, _)| i + 1));
        Self {
            entries: Vec::new(),
            line_starts,
        }
    }

    /// The keys of a table (`[table]`, inline `{ … }` or implicit `a.b = …`) and what is below them.
    fn add_table(&mut self, parent: &str, table: &dyn TableLike) {
        for (name, item) in table.iter() {
            let path = join_key(parent, name);
            let key_span = table.get_key_value(name).and_then(|(key, _)| key.span());
            self.entries.push(Entry { path: path.clone(), value_span: item.span(), key_span });
            self.add_item(&path, item);
        }
    }

    fn add_item(&mut self, path: &str, item: &Item) {
        match item {
            Item::None => {}
            Item::Value(value) => self.add_value(path, value),
            Item::Table(table) => self.add_table(path, table),
            Item::ArrayOfTables(tables) => {
                for (i, table) in tables.iter().enumerate() {
                    let item_path = join_index(path, i);
                    self.entries.push(Entry { path: item_path.clone(), value_span: table.span(), key_span: None });
                    self.add_table(&item_path, table);
                }
            }
        }
    }

    fn add_value(&mut self, path: &str, value: &Value) {
        match value {
            Value::Array(items) => {
                for (i, item) in items.iter().enumerate() {
                    let item_path = join_index(path, i);
                    self.entries.push(Entry { path: item_path.clone(), value_span: item.span(), key_span: None });
                    self.add_value(&item_path, item);
                }
            }
            Value::InlineTable(table) => self.add_table(path, table),
            _ => {}
        }
    }

    /// The key path of the innermost key or value enclosing `span` (`None` if it is outside every key).
    fn path_at(&self, span: &Range<usize>) -> Option<String> {
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
    fn line_col(&self, offset: usize) -> (usize, usize) {
        let line = self.line_starts.partition_point(|&s| s <= offset).max(1);
        (line, offset - self.line_starts[line - 1] + 1)
    }

    /// 1-based line where `path` is written (its key, or its value for array elements), if it is in the file.
    fn line_of(&self, path: &str) -> Option<usize> {
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

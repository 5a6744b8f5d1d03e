//! [`SceneError`]: every way a scene file can be rejected. Each error names the scene file, the key path
//! inside it (`shape[3].bsdf.reflectance`, `sensor.fov`) with its line when known, and the problem.

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

use super::spans::SpanIndex;
use super::xml::unsupported::Unsupported;
use super::xml::Places;

/// Why a scene file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The scene file itself cannot be read.
    #[error("{}: cannot read the scene file: {source}", file.display())]
    Read { file: PathBuf, source: std::io::Error },
    /// The file is not valid TOML.
    #[error("{}:{line}:{column}: TOML syntax error: {}", file.display(), Message(message))]
    Syntax {
        file: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    /// The file is not well-formed XML.
    #[error("{}:{line}:{column}: XML syntax error: {}", file.display(), Message(message))]
    XmlSyntax {
        file: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    /// A key is unknown, missing, of the wrong type, or has a value out of range; or a reference to a named
    /// material does not resolve.
    #[error("{}{}: {}: {}", file.display(), Line(*line), KeyPath(key), Message(message))]
    Key {
        file: PathBuf,
        key: String,
        line: Option<usize>,
        message: String,
    },
    /// A file the scene refers to (mesh, environment map) does not exist.
    #[error("{}{}: {}: file not found: {}", file.display(), Line(*line), KeyPath(key), cut(&missing.display().to_string()))]
    MissingFile {
        file: PathBuf,
        key: String,
        line: Option<usize>,
        missing: PathBuf,
    },
    /// The scene uses plugins, properties or tags caustica cannot render: all of them, each at its place.
    #[error("{}: the scene uses {} thing{} caustica cannot render:{}", file.display(), items.len(), if items.len() == 1 { "" } else { "s" }, UnsupportedList(items))]
    Unsupported { file: PathBuf, items: Vec<Unsupported> },
    /// A file the scene refers to exists but cannot be loaded.
    #[error("{}{}: {}: cannot load {}: {}", file.display(), Line(*line), KeyPath(key), cut(&asset.display().to_string()), Message(message))]
    Asset {
        file: PathBuf,
        key: String,
        line: Option<usize>,
        asset: PathBuf,
        message: String,
    },
}

/// The items of [`SceneError::Unsupported`], one per line.
struct UnsupportedList<'a>(&'a [Unsupported]);

impl fmt::Display for UnsupportedList<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for item in self.0 {
            write!(f, "\n  {item}")?;
        }
        Ok(())
    }
}

impl SceneError {
    /// The scene file the error is about.
    #[must_use]
    pub fn file(&self) -> &Path {
        match self {
            SceneError::Read { file, .. }
            | SceneError::Syntax { file, .. }
            | SceneError::XmlSyntax { file, .. }
            | SceneError::Key { file, .. }
            | SceneError::MissingFile { file, .. }
            | SceneError::Asset { file, .. }
            | SceneError::Unsupported { file, .. } => file,
        }
    }

    /// The key path the error is about (`""` = the top level), if the error is about a key.
    #[must_use]
    pub fn key(&self) -> Option<&str> {
        match self {
            SceneError::Key { key, .. } | SceneError::MissingFile { key, .. } | SceneError::Asset { key, .. } => Some(key),
            SceneError::Read { .. } | SceneError::Syntax { .. } | SceneError::XmlSyntax { .. } | SceneError::Unsupported { .. } => None,
        }
    }
}

pub(crate) use crate::props::{cut, shown, SHOWN_CHARS};

/// A message of another parser (XML, TOML), which may echo a value of any length, cut as [`shown`] cuts
/// values: its beginning and end are kept, the middle of a long one is left out.
pub(crate) fn cut_message(message: &str) -> String {
    cut_middle(message, 2 * SHOWN_CHARS, SHOWN_CHARS).into_owned()
}

/// Characters kept at the beginning and the end of a message: what every message of a [`SceneError`] is
/// cut to when displayed, should a value have been echoed without [`shown`].
const MESSAGE_HEAD: usize = 1400;
const MESSAGE_TAIL: usize = 500;

/// `text` with its middle left out when it is longer than `head + tail` characters (and a note of how
/// much is left out in its place).
fn cut_middle(text: &str, head: usize, tail: usize) -> std::borrow::Cow<'_, str> {
    let chars = text.chars().count();
    if chars <= 2 * (head + tail) {
        return std::borrow::Cow::Borrowed(text);
    }
    let start = text.char_indices().nth(head).map_or(text.len(), |(i, _)| i);
    let end = text.char_indices().nth(chars - tail).map_or(text.len(), |(i, _)| i);
    std::borrow::Cow::Owned(format!("{} …({} bytes left out)… {}", &text[..start], end - start, &text[end..]))
}

/// A message as errors display it: cut by [`cut_middle`] to [`MESSAGE_HEAD`] and [`MESSAGE_TAIL`].
struct Message<'a>(&'a str);

impl fmt::Display for Message<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&cut_middle(self.0, MESSAGE_HEAD, MESSAGE_TAIL))
    }
}

/// The TOML parser's message for tables, arrays or dotted keys nested past its limit, with what it means.
fn nesting_explained(message: String) -> String {
    if message.ends_with("recursion limit exceeded") {
        format!("{message} (tables, arrays or dotted keys nested more than the TOML parser's 80 levels)")
    } else {
        message
    }
}

/// Formats `:line` when the line is known.
struct Line(Option<usize>);

impl fmt::Display for Line {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(line) => write!(f, ":{line}"),
            None => Ok(()),
        }
    }
}

/// Formats a key path, naming the empty path.
struct KeyPath<'a>(&'a str);

impl fmt::Display for KeyPath<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0.is_empty() {
            f.write_str("(top level)")
        } else {
            f.write_str(self.0)
        }
    }
}

/// What every error constructor needs: the file name and the document's span index, and for a
/// description read from Mitsuba XML the places of its keys (errors then name the XML file, line and
/// plugin or property instead of the key path).
pub(crate) struct ErrorContext {
    pub(crate) file: PathBuf,
    pub(crate) spans: SpanIndex,
    pub(crate) places: Option<Places>,
}

impl ErrorContext {
    /// The file, the name and the line of `key` in errors.
    fn locate(&self, key: &str) -> (PathBuf, String, Option<usize>) {
        match &self.places {
            Some(places) => {
                let (file, label, line) = places.locate(key);
                (file, label, Some(line))
            }
            None => (self.file.clone(), key.to_string(), self.spans.line_of(key)),
        }
    }

    /// A [`SceneError::Key`] about `key`.
    pub(crate) fn key_error(&self, key: &str, message: impl Into<String>) -> SceneError {
        let (file, key, line) = self.locate(key);
        SceneError::Key { file, key, line, message: message.into() }
    }

    pub(crate) fn missing_file(&self, key: &str, missing: &Path) -> SceneError {
        let (file, key, line) = self.locate(key);
        SceneError::MissingFile { file, key, line, missing: missing.to_path_buf() }
    }

    pub(crate) fn asset_error(&self, key: &str, asset: &Path, message: impl Into<String>) -> SceneError {
        let (file, key, line) = self.locate(key);
        SceneError::Asset { file, key, line, asset: asset.to_path_buf(), message: message.into() }
    }

    /// Converts an error of the typed deserialiser: its span names the key, its message the problem.
    pub(crate) fn toml_error(&self, error: &toml::de::Error) -> SceneError {
        let span: Option<Range<usize>> = error.span();
        let key = span.as_ref().and_then(|s| self.spans.path_at(s)).unwrap_or_default();
        let message = cut_message(error.message().trim());
        if self.places.is_some() {
            return self.key_error(&key, message);
        }
        let line = span.as_ref().map(|s| self.spans.line_col(s.start).0);
        SceneError::Key { file: self.file.clone(), key, line, message }
    }

    /// Converts a syntax error of the TOML parser.
    pub(crate) fn syntax(&self, error: &toml::de::Error) -> SceneError {
        let (line, column) = error.span().map_or((1, 1), |s| self.spans.line_col(s.start));
        SceneError::Syntax {
            file: self.file.clone(),
            line,
            column,
            message: nesting_explained(cut_message(error.message().trim())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_values_and_messages_are_cut() {
        assert_eq!(shown("a\"b"), "\"a\\\"b\"");
        let long = "x".repeat(20 << 20);
        let s = shown(&long);
        assert_eq!(s, format!("\"{}\"… (20971520 bytes)", "x".repeat(SHOWN_CHARS)));
        let m = cut_message(&format!("invalid value {long} here"));
        assert!(m.len() < 400 && m.starts_with("invalid value xx") && m.ends_with("xx here") && m.contains("bytes left out"), "{m}");
        assert_eq!(cut_message("short"), "short");
        // Every message is cut when displayed, should a value have been echoed whole.
        let e = SceneError::Key { file: "a.toml".into(), key: "k".into(), line: Some(3), message: format!("got {long}!") };
        let shown = e.to_string();
        assert!(shown.len() < 2000 && shown.starts_with("a.toml:3: k: got xxx") && shown.ends_with("xx!"), "{}", &shown[..100]);
    }
}

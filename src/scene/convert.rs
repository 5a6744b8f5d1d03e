//! `caustica convert`: a scene file in one format → the same scene description written in the other
//! (Mitsuba 3 XML ↔ TOML). The input is built first (the same checks as a render: a scene that does not
//! load is not converted), then its description is written: as TOML text, or as Mitsuba XML by
//! `xml::write`. Relative file names (meshes, maps) are rewritten relative to the output's directory.
//! XML-only structure does not survive into TOML: `<include>`s are spliced in and `$name` parameters
//! replaced by their values (defaults or `-D`).

use std::collections::BTreeMap;
use std::path::{Component, Path, PathBuf};

use toml::{Table, Value};

use super::error::SceneError;
use super::{is_xml, Scene};

/// The text of the scene at `input` converted to the format of `output` (`.xml`: Mitsuba 3 XML, else
/// TOML), with file names relative to `output`'s directory; `params` are `-D` values of an XML input.
pub fn convert_scene(input: &Path, output: &Path, params: &BTreeMap<String, String>) -> Result<String, SceneError> {
    let text = super::read_scene_file(input)?;
    let in_dir = input.parent().unwrap_or_else(|| Path::new("."));
    // Build it (every check of a render), then take its description.
    Scene::load_with_params(input, params)?;
    let mut doc = if is_xml(input) {
        super::xml::read_str(&text, input, in_dir, params, super::xml::ConvertOptions::default())?.0
    } else {
        toml::from_str::<Table>(&text).map_err(|e| key_error(input, &format!("cannot parse: {e}")))?
    };
    let out_dir = output.parent().unwrap_or_else(|| Path::new("."));
    rebase_filenames(&mut doc, in_dir, out_dir);
    let source = input.file_name().map_or_else(|| input.display().to_string(), |n| n.to_string_lossy().into_owned());
    if is_xml(output) {
        super::xml::write::to_xml(&doc, &source).map_err(|m| key_error(input, &m))
    } else {
        let body = toml::to_string_pretty(&doc).map_err(|e| key_error(input, &format!("cannot be written as TOML: {e}")))?;
        Ok(format!("# written by caustica convert from {source}\n{body}"))
    }
}

fn key_error(file: &Path, message: &str) -> SceneError {
    SceneError::Key { file: file.to_path_buf(), key: String::new(), line: None, message: message.to_string() }
}

/// Rewrites every relative `filename` of the document (shapes, emitters, textures, wherever they nest) from
/// `from` to `to` (directories).
fn rebase_filenames(doc: &mut Table, from: &Path, to: &Path) {
    for (key, value) in doc.iter_mut() {
        match value {
            Value::String(f) if key == "filename" && Path::new(f.as_str()).is_relative() => {
                *f = relative_to(&absolute(&from.join(f.as_str())), &absolute(to)).to_string_lossy().replace('\\', "/");
            }
            Value::Table(t) => rebase_filenames(t, from, to),
            Value::Array(items) => {
                for t in items.iter_mut().filter_map(Value::as_table_mut) {
                    rebase_filenames(t, from, to);
                }
            }
            _ => {}
        }
    }
}

/// `p` made absolute (against the current directory) with `.` and `..` resolved lexically.
fn absolute(p: &Path) -> PathBuf {
    let p = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// The path of `target` relative to the directory `base` (both absolute, normalised).
fn relative_to(target: &Path, base: &Path) -> PathBuf {
    let (t, b): (Vec<_>, Vec<_>) = (target.components().collect(), base.components().collect());
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths() {
        assert_eq!(relative_to(Path::new("/a/b/m.obj"), Path::new("/a/b")), PathBuf::from("m.obj"));
        assert_eq!(relative_to(Path::new("/a/b/m.obj"), Path::new("/a/c/d")), PathBuf::from("../../b/m.obj"));
        assert_eq!(absolute(Path::new("/a/b/../c/./m.obj")), PathBuf::from("/a/c/m.obj"));
    }
}

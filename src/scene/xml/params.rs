//! Scene parameters: `<default name="spp" value="64"/>` declares `$spp` with a default value, `-D spp=16`
//! on the command line overrides it (Mitsuba's flag), and every `$name` in an attribute value is replaced
//! by the parameter's value:
//!
//! ```xml
//! <default name="spp" value="64"/>
//! <default name="mesh" value="bunny"/>
//! <include filename="$mesh.xml"/>                       <!-- an include's file name too -->
//! <integer name="sample_count" value="$spp"/>
//! <string name="note" value="costs \$5"/>               <!-- \$ is a dollar sign -->
//! ```
//!
//! **Mitsuba 3.9.1's rules** (`parse_xml_node`, `substitute_parameters` and the `<default>` case, in
//! src/core/parser.cpp), which the tree builder applies as it reads the files, in document order:
//! - every attribute of every element is substituted when the element is reached, includes and the
//!   `<default>`s themselves included; a `$name` before the `<default>` that declares it is undefined;
//! - a `<default>` may stand anywhere (but in a `<transform>`), also in an included file, and holds for
//!   the elements after it; the first value of a name wins: a second `<default>` of a name, or one of a
//!   name given with `-D`, is ignored;
//! - at a `$`, the longest parameter name the text goes on with is replaced (`$sppx` with only `spp`
//!   declared reads `64x`); a `$` that goes on with none is an error, and `\$` stands for `$`.
//!
//! Unlike Mitsuba, a value put in by substitution is not searched for further `$` (Mitsuba's result there
//! depends on the lengths of the names), a parameter name must be an identifier (letters, digits, `_`),
//! and a `-D` that names no `<default>` and no `$` reference is an error, not a warning (a misspelt flag
//! would otherwise be ignored).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use super::tree::Element;
use super::super::error::{cut, shown, SceneError};

/// The parameters declared so far: a trie over their names, so that the longest name at a `$` is found
/// in time linear in its length however many parameters there are.
#[derive(Debug, Default)]
pub(crate) struct Params {
    entries: Vec<Entry>,
    /// (node, byte) → node; node 0 is the root.
    edges: HashMap<(u32, u8), u32>,
    /// Node → the entry whose name ends there.
    ends: HashMap<u32, usize>,
    nodes: u32,
}

#[derive(Debug)]
struct Entry {
    name: String,
    value: String,
    /// Given with `-D`.
    cli: bool,
    /// Named by a `<default>` (also when `-D` gave its value).
    declared: bool,
    used: bool,
}

impl Params {
    /// The parameters given on the command line (`-D name=value`).
    pub(crate) fn new(cli: &BTreeMap<String, String>) -> Self {
        let mut params = Self::default();
        for (name, value) in cli {
            params.insert(name, value, true);
        }
        params
    }

    fn find(&self, name: &str) -> Option<usize> {
        let mut node = 0;
        for b in name.bytes() {
            node = *self.edges.get(&(node, b))?;
        }
        self.ends.get(&node).copied()
    }

    fn insert(&mut self, name: &str, value: &str, cli: bool) {
        let mut node = 0;
        for b in name.bytes() {
            node = match self.edges.get(&(node, b)) {
                Some(&next) => next,
                None => {
                    self.nodes += 1;
                    self.edges.insert((node, b), self.nodes);
                    self.nodes
                }
            };
        }
        self.ends.insert(node, self.entries.len());
        self.entries.push(Entry { name: name.to_string(), value: value.to_string(), cli, declared: !cli, used: false });
    }

    /// A `<default name="…" value="…"/>` (its attributes already substituted): declares the parameter
    /// unless it has a value already.
    pub(crate) fn declare(&mut self, el: &Element) -> Result<(), SceneError> {
        el.check_attrs(&["name", "value"])?;
        let name = el.required("name")?;
        let value = el.required("value")?;
        if let Some(child) = el.children.first() {
            return Err(child.error("<default> has no child elements"));
        }
        if !is_identifier(name) {
            return Err(el.error(format!("parameter name {} is not an identifier (letters, digits, _)", shown(name))));
        }
        match self.find(name) {
            Some(i) => self.entries[i].declared = true,
            None => self.insert(name, value, false),
        }
        Ok(())
    }

    /// Substitutes the parameters in every attribute value of `el` (not its children).
    pub(crate) fn substitute(&mut self, el: &mut Element) -> Result<(), SceneError> {
        for i in 0..el.attrs.len() {
            if el.attrs[i].1.contains('$') {
                let replaced = self.substitute_str(&el.attrs[i].1).map_err(|name| {
                    let what = if name.is_empty() {
                        "a `$` names no parameter (`\\$` is a dollar sign)".to_string()
                    } else {
                        format!("{} is not defined (no <default name=\"…\" value=…> before it and no -D …=…)", cut(&format!("${name}")))
                    };
                    el.error(format!("attribute `{}`: {what}", el.attrs[i].0))
                })?;
                el.attrs[i].1 = replaced;
            }
        }
        Ok(())
    }

    /// `text` with every `$name` replaced; `Err(name)` (the identifier after the `$`) for a `$` that goes
    /// on with no parameter's name.
    fn substitute_str(&mut self, text: &str) -> Result<String, String> {
        let bytes = text.as_bytes();
        let mut out = String::with_capacity(text.len());
        let mut copied = 0;
        let mut at = 0;
        while let Some(pos) = text[at..].find('$').map(|p| at + p) {
            if pos > 0 && bytes[pos - 1] == b'\\' {
                out.push_str(&text[copied..pos - 1]);
                out.push('$');
                copied = pos + 1;
                at = pos + 1;
                continue;
            }
            let run = text[pos + 1..].find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).map_or(text.len(), |l| pos + 1 + l);
            let (mut node, mut longest) = (0, None);
            for (k, b) in bytes[pos + 1..run].iter().enumerate() {
                match self.edges.get(&(node, *b)) {
                    Some(&next) => node = next,
                    None => break,
                }
                if let Some(&entry) = self.ends.get(&node) {
                    longest = Some((entry, pos + 2 + k));
                }
            }
            let Some((entry, end)) = longest else {
                return Err(text[pos + 1..run].to_string());
            };
            out.push_str(&text[copied..pos]);
            out.push_str(&self.entries[entry].value);
            self.entries[entry].used = true;
            copied = end;
            at = end;
        }
        out.push_str(&text[copied..]);
        Ok(out)
    }

    /// After the whole scene is read: a `-D` that named no `<default>` and no `$` reference is an error.
    pub(crate) fn check_cli(&self, scene_file: &Path) -> Result<(), SceneError> {
        match self.entries.iter().find(|e| e.cli && !e.declared && !e.used) {
            Some(e) => Err(SceneError::Key {
                file: scene_file.to_path_buf(),
                key: format!("-D {}", e.name),
                line: None,
                message: format!("the scene has no <default name=\"{}\"> and no ${}", e.name, e.name),
            }),
            None => Ok(()),
        }
    }
}

fn is_identifier(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(pairs: &[(&str, &str)]) -> Params {
        let mut p = Params::default();
        for (n, v) in pairs {
            p.insert(n, v, false);
        }
        p
    }

    #[test]
    fn dollar_references_are_replaced_and_undefined_ones_named() {
        let mut p = params(&[("spp", "16"), ("s", "x")]);
        assert_eq!(p.substitute_str("$spp").unwrap(), "16");
        assert_eq!(p.substitute_str("a/$s.obj").unwrap(), "a/x.obj");
        assert_eq!(p.substitute_str("$nope"), Err("nope".to_string()));
        // Mitsuba: a `$` followed by no parameter name is undefined, `\$` is a dollar sign.
        assert_eq!(p.substitute_str("cost $ 5"), Err(String::new()));
        assert_eq!(p.substitute_str("cost \\$5 \\$spp $s"), Ok("cost $5 $spp x".to_string()));
        assert!(p.entries.iter().all(|e| e.used));
    }

    /// Mitsuba replaces the longest name the text goes on with: `$sppx` is `$spp` then `x`.
    #[test]
    fn the_longest_name_at_a_dollar_is_replaced() {
        let mut p = params(&[("sp", "A"), ("spp", "B"), ("sppxy", "C")]);
        assert_eq!(p.substitute_str("$sppx").unwrap(), "Bx");
        assert_eq!(p.substitute_str("$sppxy$spp$sp$s").err(), Some("s".to_string()));
        assert_eq!(p.substitute_str("$sppxy,$spp,$sp,$spq").unwrap(), "C,B,A,Aq");
    }
}

//! Scene parameters: `<default name="spp" value="64"/>` declares `$spp` with a default value, `-D spp=16`
//! on the command line overrides it (Mitsuba's flag), and every `$name` in an attribute value is replaced
//! by the parameter's value. A `$name` that is neither declared nor given is an error, and so is a `-D`
//! that names no `<default>` and no `$` reference (a misspelt flag would otherwise be ignored).

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

use super::tree::Element;
use super::super::error::SceneError;

/// Removes the `<default>` elements of `root` and substitutes the parameters everywhere below it.
pub(crate) fn substitute(root: &mut Element, cli: &BTreeMap<String, String>, scene_file: &Path) -> Result<(), SceneError> {
    let mut values: BTreeMap<String, String> = BTreeMap::new();
    let mut declared = BTreeSet::new();
    let children = std::mem::take(&mut root.children);
    for child in children {
        if child.tag == "default" {
            child.check_attrs(&["name", "value"])?;
            let name = child.required("name")?.to_string();
            let value = child.required("value")?.to_string();
            if !is_identifier(&name) {
                return Err(child.error(format!("parameter name {name:?} is not an identifier (letters, digits, _)")));
            }
            declared.insert(name.clone());
            values.entry(name).or_insert(value);
        } else {
            root.children.push(child);
        }
    }
    for (name, value) in cli {
        values.insert(name.clone(), value.clone());
    }
    let mut used = BTreeSet::new();
    substitute_element(root, &values, &mut used)?;
    if let Some(name) = cli.keys().find(|n| !declared.contains(*n) && !used.contains(*n)) {
        return Err(SceneError::Key {
            file: scene_file.to_path_buf(),
            key: format!("-D {name}"),
            line: None,
            message: format!("the scene has no <default name=\"{name}\"> and no ${name}"),
        });
    }
    Ok(())
}

fn substitute_element(el: &mut Element, values: &BTreeMap<String, String>, used: &mut BTreeSet<String>) -> Result<(), SceneError> {
    for i in 0..el.attrs.len() {
        if el.attrs[i].1.contains('$') {
            let replaced = substitute_str(&el.attrs[i].1, values, used).map_err(|name| {
                el.error(format!(
                    "attribute `{}`: ${name} is not defined (no <default name=\"{name}\" value=…> and no -D {name}=…)",
                    el.attrs[i].0
                ))
            })?;
            el.attrs[i].1 = replaced;
        }
    }
    for child in &mut el.children {
        substitute_element(child, values, used)?;
    }
    Ok(())
}

/// `text` with every `$identifier` replaced; `Err(name)` for an undefined one. A `$` not followed by an
/// identifier stays as written.
fn substitute_str(text: &str, values: &BTreeMap<String, String>, used: &mut BTreeSet<String>) -> Result<String, String> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(pos) = rest.find('$') {
        out.push_str(&rest[..pos]);
        let after = &rest[pos + 1..];
        let len = after.find(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).unwrap_or(after.len());
        let name = &after[..len];
        if name.is_empty() {
            out.push('$');
        } else {
            let value = values.get(name).ok_or_else(|| name.to_string())?;
            used.insert(name.to_string());
            out.push_str(value);
        }
        rest = &after[len..];
    }
    out.push_str(rest);
    Ok(out)
}

fn is_identifier(name: &str) -> bool {
    !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dollar_references_are_replaced_and_undefined_ones_named() {
        let values: BTreeMap<String, String> = [("spp".to_string(), "16".to_string()), ("s".to_string(), "x".to_string())].into();
        let mut used = BTreeSet::new();
        assert_eq!(substitute_str("$spp", &values, &mut used).unwrap(), "16");
        assert_eq!(substitute_str("a/$s.obj and $", &values, &mut used).unwrap(), "a/x.obj and $");
        assert_eq!(substitute_str("$nope", &values, &mut used), Err("nope".to_string()));
        assert_eq!(used.len(), 2);
    }
}

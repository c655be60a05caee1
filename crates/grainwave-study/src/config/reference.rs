//! The config reference (`docs/config.md`), generated from the key definitions themselves: the
//! raw config structs' JSON schemas (doc comments, defaults, types).
//!
//! Convention: a key's doc comment ends its first paragraph with the unit in brackets, e.g.
//! `Normal stiffness k_n [force/length].`; dimensionless keys carry no brackets.

use serde_json::Value;

/// One documented key.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyDoc {
    /// Dotted path (`[]` marks an array of tables).
    pub path: String,
    /// Type in words.
    pub kind: String,
    /// Default value (TOML syntax), empty when required or none.
    pub default: String,
    /// Whether the key must be given.
    pub required: bool,
    /// Unit, from the trailing `[...]` of the doc comment.
    pub unit: String,
    /// Description.
    pub doc: String,
}

/// A section of the reference: a table of keys.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    /// Table path (empty for the top level).
    pub path: String,
    /// Description of the table.
    pub doc: String,
    /// Its keys.
    pub keys: Vec<KeyDoc>,
}

/// Splits a doc comment into (description, unit).
pub fn split_unit(doc: &str) -> (String, String) {
    let first = doc.split("\n\n").next().unwrap_or("").trim();
    let rest: Vec<&str> = doc.split("\n\n").skip(1).collect();
    let (text, unit) = match (first.rfind('['), first.ends_with("].") || first.ends_with(']')) {
        (Some(open), true) => {
            let close = first.rfind(']').unwrap();
            let unit = first[open + 1..close].to_string();
            let text = format!("{}{}", first[..open].trim_end(), if first.ends_with('.') { "." } else { "" });
            (text, unit)
        }
        _ => (first.to_string(), String::new()),
    };
    let mut full = text.replace('\n', " ");
    for r in rest {
        full.push(' ');
        full.push_str(&r.replace('\n', " "));
    }
    (full, unit)
}

fn resolve<'a>(v: &'a Value, root: &'a Value) -> &'a Value {
    if let Some(r) = v.get("$ref").and_then(Value::as_str) {
        let name = r.rsplit('/').next().unwrap_or("");
        if let Some(d) = root.get("$defs").and_then(|d| d.get(name)) {
            return resolve(d, root);
        }
    }
    v
}

/// The non-null alternative of an `Option<T>` schema, if it is one.
fn strip_null<'a>(v: &'a Value, root: &'a Value) -> (&'a Value, bool) {
    for key in ["anyOf", "oneOf"] {
        if let Some(alts) = v.get(key).and_then(Value::as_array) {
            let non_null: Vec<&Value> = alts.iter().filter(|a| a.get("type").and_then(Value::as_str) != Some("null")).collect();
            if non_null.len() == 1 && alts.len() == 2 {
                return (resolve(non_null[0], root), true);
            }
        }
    }
    if let Some(types) = v.get("type").and_then(Value::as_array) {
        if types.iter().any(|t| t == "null") {
            return (v, true);
        }
    }
    (v, false)
}

fn is_table(v: &Value) -> bool {
    v.get("properties").is_some() && v.get("type").and_then(Value::as_str) == Some("object")
}

fn kind_of(v: &Value, root: &Value) -> String {
    let v = resolve(v, root);
    if let Some(vals) = v.get("enum").and_then(Value::as_array) {
        return format!("one of {}", vals.iter().map(|x| format!("`{}`", x.as_str().unwrap_or(&x.to_string()))).collect::<Vec<_>>().join(", "));
    }
    for key in ["oneOf", "anyOf"] {
        if let Some(alts) = v.get(key).and_then(Value::as_array) {
            let consts: Vec<String> = alts.iter().filter_map(|a| a.get("const").and_then(Value::as_str).map(|c| format!("`{c}`"))).collect();
            if consts.len() == alts.len() {
                return format!("one of {}", consts.join(", "));
            }
            let parts: Vec<String> = alts
                .iter()
                .map(|a| {
                    let a = resolve(a, root);
                    if let Some(props) = a.get("properties") {
                        if let Some(tag) = props.get("type").and_then(|t| t.get("const")).and_then(Value::as_str) {
                            let fields: Vec<&str> = props.as_object().unwrap().keys().filter(|k| *k != "type").map(String::as_str).collect();
                            return format!("{{ type = \"{tag}\", {} }}", fields.join(", "));
                        }
                        if let Some(tag) = props.get("distribution").and_then(|t| t.get("const")).and_then(Value::as_str) {
                            let fields: Vec<&str> = props.as_object().unwrap().keys().filter(|k| *k != "distribution").map(String::as_str).collect();
                            return format!("{{ distribution = \"{tag}\", {} }}", fields.join(", "));
                        }
                        // a contact-law family table: `law` names the law, the other keys are its own
                        if let Some(tag) = props.get("law").and_then(|t| t.get("const")).and_then(Value::as_str) {
                            let fields: Vec<&str> = props.as_object().unwrap().keys().filter(|k| *k != "law").map(String::as_str).collect();
                            return if fields.is_empty() { format!("{{ law = \"{tag}\" }}") } else { format!("{{ law = \"{tag}\", {} }}", fields.join(", ")) };
                        }
                    }
                    kind_of(a, root)
                })
                .collect();
            return parts.join(" or ");
        }
    }
    match v.get("type") {
        Some(Value::String(t)) => match t.as_str() {
            "number" => "number".into(),
            "integer" => "integer".into(),
            "boolean" => "boolean".into(),
            "string" => "string".into(),
            "array" => match v.get("items") {
                Some(items) => format!("list of {}", kind_of(items, root)),
                None => "list".into(),
            },
            "object" => "table".into(),
            other => other.into(),
        },
        Some(Value::Array(ts)) => {
            let non_null: Vec<&str> = ts.iter().filter_map(Value::as_str).filter(|t| *t != "null").collect();
            if non_null == ["array"] {
                match v.get("items") {
                    Some(items) => format!("list of {}", kind_of(items, root)),
                    None => "list".into(),
                }
            } else {
                non_null.join(" or ")
            }
        }
        _ => "value".into(),
    }
}

fn toml_literal(v: &Value) -> String {
    match v {
        Value::Null => String::new(),
        Value::String(s) => format!("\"{s}\""),
        Value::Number(n) => n.to_string(),
        Value::Bool(b) => b.to_string(),
        Value::Array(a) => format!("[{}]", a.iter().map(toml_literal).collect::<Vec<_>>().join(", ")),
        Value::Object(o) => {
            let parts: Vec<String> = o.iter().filter(|(_, v)| !v.is_null()).map(|(k, v)| format!("{k} = {}", toml_literal(v))).collect();
            format!("{{ {} }}", parts.join(", "))
        }
    }
}

/// Sections of the reference of the config whose schema is `root`.
pub fn sections(root: &Value) -> Vec<Section> {
    let mut out = Vec::new();
    let (doc, _) = split_unit(root.get("description").and_then(Value::as_str).unwrap_or(""));
    collect(root, root, "", doc, &mut out);
    out
}

fn collect(table: &Value, root: &Value, path: &str, doc: String, out: &mut Vec<Section>) {
    let table = resolve(table, root);
    let required: Vec<&str> =
        table.get("required").and_then(Value::as_array).map(|a| a.iter().filter_map(Value::as_str).collect()).unwrap_or_default();
    let mut keys = Vec::new();
    let mut subtables = Vec::new();
    if let Some(props) = table.get("properties").and_then(Value::as_object) {
        for (name, prop) in props {
            let full = if path.is_empty() { name.clone() } else { format!("{path}.{name}") };
            let description = prop
                .get("description")
                .and_then(Value::as_str)
                .or_else(|| resolve(prop, root).get("description").and_then(Value::as_str))
                .unwrap_or("");
            let (text, unit) = split_unit(description);
            let (inner, optional) = strip_null(resolve(prop, root), root);
            let inner = resolve(inner, root);
            let is_required = required.contains(&name.as_str());
            if is_table(inner) {
                subtables.push((full, text, inner.clone()));
                continue;
            }
            if inner.get("type").and_then(Value::as_str) == Some("array") {
                if let Some(items) = inner.get("items") {
                    let items = resolve(items, root);
                    if is_table(items) {
                        subtables.push((format!("{full}[]"), text, items.clone()));
                        continue;
                    }
                }
            }
            let default = prop.get("default").map(toml_literal).unwrap_or_default();
            let mut kind = kind_of(inner, root);
            if optional && !is_required {
                kind = format!("{kind} (optional)");
            }
            keys.push(KeyDoc { path: full, kind, default, required: is_required && !optional, unit, doc: text });
        }
    }
    out.push(Section { path: path.to_string(), doc, keys });
    for (p, d, t) in subtables {
        collect(&t, root, &p, d, out);
    }
}

/// Renders the sections of one experiment as Markdown.
pub fn markdown(title: &str, intro: &str, sections: &[Section]) -> String {
    let mut s = format!("## {title}\n\n{intro}\n\n");
    for sec in sections {
        if sec.keys.is_empty() {
            continue;
        }
        if sec.path.is_empty() {
            s.push_str("### Top level\n\n");
        } else {
            s.push_str(&format!("### `[{}]`\n\n", sec.path));
        }
        if !sec.doc.is_empty() {
            s.push_str(&format!("{}\n\n", sec.doc));
        }
        s.push_str("| key | type | default | unit | description |\n|---|---|---|---|---|\n");
        for k in &sec.keys {
            let name = k.path.rsplit('.').next().unwrap_or(&k.path);
            let default = if k.required { "**required**".to_string() } else if k.default.is_empty() { "—".into() } else { format!("`{}`", k.default) };
            s.push_str(&format!(
                "| `{name}` | {} | {default} | {} | {} |\n",
                k.kind.replace('|', "\\|"),
                if k.unit.is_empty() { "—".into() } else { k.unit.clone() },
                k.doc.replace('|', "\\|")
            ));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_are_split_from_docs() {
        assert_eq!(split_unit("Normal stiffness k_n [force/length]."), ("Normal stiffness k_n.".into(), "force/length".into()));
        assert_eq!(split_unit("Friction coefficient."), ("Friction coefficient.".into(), String::new()));
        assert_eq!(split_unit("Size [length].\n\nMore text."), ("Size. More text.".into(), "length".into()));
    }
}

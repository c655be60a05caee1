//! Config files: TOML → raw serde struct → validated spec, with errors that point at the file,
//! line and column of the offending key.
//!
//! Each key is defined once, as a field of a raw config struct: its doc comment is the key's
//! documentation (ending with its unit in brackets, e.g. `[length]`), its serde default is the
//! default, its type is the type. Parsing refuses unknown keys (with a "did you mean" when a key
//! is close to a known one) and wrong types; validation refuses out-of-range values and
//! inconsistent combinations. Every error is a [`ConfigError`] carrying the file, line, column,
//! key path, the value and what is allowed. The reference `docs/config.md` is generated from the
//! same definitions ([`reference`]).

pub mod reference;
pub mod values;

pub use values::{Axis, TimeFunctionConfig, VectorConfig};

use grainwave_core::CoreError;
use serde::de::DeserializeOwned;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;

/// Largest config file read, in bytes (16 MiB; the configs of `examples/` are a few kB).
pub const MAX_CONFIG_BYTES: u64 = 16 << 20;

/// The text of a config and the name it is reported under.
#[derive(Clone, Debug)]
pub struct ConfigSource {
    /// Name shown in errors (the file path, or e.g. "embedded demo config").
    pub name: String,
    /// The TOML text.
    pub text: Arc<String>,
}

impl ConfigSource {
    /// Reads a config file of at most [`MAX_CONFIG_BYTES`] (a pipe such as `<(sed … a.toml)` is
    /// fine; `/dev/zero` is refused after that many bytes instead of filling the memory).
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        let refuse = |message: String| ConfigError {
            file: path.display().to_string(),
            line: 0,
            column: 0,
            key: None,
            message,
            span: None,
            text: Arc::new(String::new()),
        };
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| std::io::Read::read_to_end(&mut std::io::Read::take(f, MAX_CONFIG_BYTES + 1), &mut bytes))
            .map_err(|e| refuse(format!("cannot read the config file: {e}")))?;
        if bytes.len() as u64 > MAX_CONFIG_BYTES {
            return Err(refuse(format!(
                "the config file is longer than {} MiB (allowed: a config of at most {MAX_CONFIG_BYTES} bytes; data such as packings goes in the files a config names)",
                MAX_CONFIG_BYTES >> 20
            )));
        }
        let text = String::from_utf8(bytes).map_err(|_| refuse("cannot read the config file: stream did not contain valid UTF-8".into()))?;
        Ok(ConfigSource { name: path.display().to_string(), text: Arc::new(text) })
    }

    /// A config given as text.
    pub fn from_text(name: impl Into<String>, text: impl Into<String>) -> Self {
        ConfigSource { name: name.into(), text: Arc::new(text.into()) }
    }

    /// Parses the text into the raw struct `T`; errors carry positions and suggestions.
    pub fn parse<T: DeserializeOwned>(&self) -> Result<T, ConfigError> {
        // the common case first: one parse; the document (for the positions and the better
        // messages of the errors) only when that fails
        let first = match toml::from_str::<T>(&self.text) {
            Ok(v) => return Ok(v),
            Err(e) => e,
        };
        let doc = toml_edit::Document::parse(self.text.as_str()).map_err(|e| {
            let mut message = e.message().trim_end().to_string();
            // the parser's "duplicate key" names nothing: quote the line that repeats it
            if message.contains("duplicate key") && !message.contains('`') {
                if let Some(at) = e.span().map(|s| s.start.min(self.text.len())) {
                    let start = self.text[..at].rfind('\n').map_or(0, |k| k + 1);
                    let end = self.text[at..].find('\n').map_or(self.text.len(), |k| at + k);
                    message = format!("duplicate key: `{}` repeats a key or table given earlier (each may appear once)", clip(self.text[start..end].trim(), 100));
                }
            }
            self.error_at_span(e.span(), None, message)
        })?;
        let mut span = first.span();
        // an unknown key of a table read as a tagged enum (`law = "…"`, e.g. `[contact.normal]`)
        // is reported at the whole table: point at the key itself
        if let (Some(s), Some(bad)) = (span.clone(), first.message().strip_prefix("unknown field `").and_then(|r| r.split('`').next())) {
            if let Some(at) = key_line_in(&self.text, s, bad) {
                span = Some(at..at + bad.len());
            }
        }
        let key = span.as_ref().and_then(|s| key_at(&doc, s.start));
        Err(self.error_at_span(span, key, improve_message(first.message())))
    }

    /// An error about the value of key `path` (e.g. `contact.friction`, `walls[1].mass`).
    /// The position is that of the value, or of the deepest part of the path present in the file
    /// (a key left at its default has no position of its own).
    pub fn error_at_key(&self, path: &str, message: impl Into<String>) -> ConfigError {
        let span = toml_edit::Document::parse(self.text.as_str()).ok().and_then(|doc| locate(&doc, path));
        self.error_at_span(span, Some(path.to_string()), message.into())
    }

    /// Converts an engine error into a config error at the key it names.
    pub fn error_from_core(&self, e: &CoreError) -> ConfigError {
        match e {
            CoreError::InvalidParameter { field, .. } => {
                // fields may carry a note in parentheses, e.g. "grains.radius (grain id 3)"
                let path = field.split(" (").next().unwrap_or(field).to_string();
                self.error_at_key(&path, e.to_string())
            }
            CoreError::UnknownName { what, .. } => {
                let path = what.split("key `").nth(1).and_then(|s| s.split('`').next()).map(str::to_string);
                match path {
                    Some(p) => self.error_at_key(&p, e.to_string()),
                    None => self.error_at_span(None, None, e.to_string()),
                }
            }
            other => {
                // inconsistent set-ups name their keys in backquotes: point at the first one found
                let text = other.to_string();
                let first_key = text.split('`').skip(1).step_by(2).find(|k| {
                    toml_edit::Document::parse(self.text.as_str()).ok().and_then(|doc| locate_exact(&doc, k)).is_some()
                });
                match first_key.map(str::to_string) {
                    Some(k) => self.error_at_key(&k, text),
                    None => self.error_at_span(None, None, text),
                }
            }
        }
    }

    fn error_at_span(&self, span: Option<Range<usize>>, key: Option<String>, message: String) -> ConfigError {
        let (line, column) = span.as_ref().map(|s| line_column(&self.text, s.start)).unwrap_or((0, 0));
        // a message quotes values from the file: keep it readable whatever their size, and
        // harmless for the terminal whatever their characters
        let message = escape_controls(&clip_keeping_lines(&compact_numbers(&message), 5 * MAX_ECHO_CHARS), true);
        let key = key.map(|k| clip(&k, MAX_ECHO_CHARS));
        ConfigError { file: escape_controls(&self.name, false), line, column, key, message, span, text: self.text.clone() }
    }
}

/// A config error: where, which key, what is wrong and what is allowed.
#[derive(Debug, Clone)]
pub struct ConfigError {
    /// File name.
    pub file: String,
    /// 1-based line (0 when unknown).
    pub line: usize,
    /// 1-based column (0 when unknown).
    pub column: usize,
    /// Key path, e.g. `contact.friction`.
    pub key: Option<String>,
    /// What is wrong (names the value and what is allowed).
    pub message: String,
    /// Byte range in the file.
    pub span: Option<Range<usize>>,
    /// The file's text (for rendering).
    pub text: Arc<String>,
}

impl std::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.column)?;
        }
        if let Some(k) = &self.key {
            write!(f, ": key `{k}`")?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ConfigError {}

impl miette::Diagnostic for ConfigError {
    fn code<'a>(&'a self) -> Option<Box<dyn std::fmt::Display + 'a>> {
        Some(Box::new("grainwave::config"))
    }
    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        // the excerpt shows whole lines, the span's and one line either side: leave it out when
        // one of them is too long to quote (a 4 MB value next to the error) or holds control
        // characters (escape sequences would act on the terminal)
        let long_line = self.span.as_ref().is_some_and(|s| {
            let text = self.text.as_str();
            let at = s.start.min(text.len());
            let to = s.end.clamp(at, text.len());
            // back to the start of the line before, on to the end of the line after
            let mut start = text[..at].rfind('\n').map_or(0, |k| k + 1);
            if start > 0 {
                start = text[..start - 1].rfind('\n').map_or(0, |k| k + 1);
            }
            let mut end = text[to..].find('\n').map_or(text.len(), |k| to + k);
            if end < text.len() {
                end = text[end + 1..].find('\n').map_or(text.len(), |k| end + 1 + k);
            }
            s.end.saturating_sub(s.start) > 2 * MAX_ECHO_CHARS
                || text[start..end].split('\n').any(|l| l.len() > 2 * MAX_ECHO_CHARS || l.chars().any(|c| c.is_control() && c != '\t' && c != '\r'))
        });
        if self.span.is_some() && !long_line {
            Some(self.text.as_ref() as &String)
        } else {
            None
        }
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = miette::LabeledSpan> + '_>> {
        let span = self.span.clone()?;
        let label = match &self.key {
            Some(k) => format!("`{k}`"),
            None => "here".to_string(),
        };
        let len = span.end.saturating_sub(span.start).max(1);
        Some(Box::new(std::iter::once(miette::LabeledSpan::new(Some(label), span.start, len))))
    }
}

/// Checks that `v` (the value of `key`) is a finite number > 0.
pub fn positive(src: &ConfigSource, key: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(src.error_at_key(key, format!("{v} (allowed: a finite number > 0)")))
    }
}

/// Checks that `v` (the value of `key`) is a finite number ≥ 0.
pub fn non_negative(src: &ConfigSource, key: &str, v: f64) -> Result<(), ConfigError> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(src.error_at_key(key, format!("{v} (allowed: a finite number ≥ 0)")))
    }
}

/// `#[serde(with = "crate::config::toml_text")]`: stores a config as TOML text inside binary
/// checkpoints (its tagged enums and "number or table" values need a self-describing format).
pub mod toml_text {
    use serde::de::DeserializeOwned;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// Serializes `c` as its TOML text.
    pub fn serialize<S: Serializer, T: Serialize>(c: &T, s: S) -> Result<S::Ok, S::Error> {
        toml::to_string(c).map_err(serde::ser::Error::custom)?.serialize(s)
    }

    /// Parses the TOML text written by [`serialize`].
    pub fn deserialize<'de, D: Deserializer<'de>, T: DeserializeOwned>(d: D) -> Result<T, D::Error> {
        let text = String::deserialize(d)?;
        toml::from_str(&text).map_err(serde::de::Error::custom)
    }
}

/// Checks the shape of every value of the file against the JSON schema of its config struct:
/// an array where a table is expected (`pulse = []` for `[pulse]`), or a table where a number,
/// text or boolean is expected (`[samples]`), is refused at its key. Serde alone would accept
/// the first (an empty sequence fills a struct with its defaults) and name no key for the second.
pub fn check_shapes(src: &ConfigSource, schema: &serde_json::Value) -> Result<(), ConfigError> {
    use serde_json::Value as J;
    fn resolve<'a>(v: &'a J, root: &'a J) -> &'a J {
        if let Some(r) = v.get("$ref").and_then(J::as_str) {
            let name = r.rsplit('/').next().unwrap_or("");
            if let Some(d) = root.get("$defs").and_then(|d| d.get(name)) {
                return resolve(d, root);
            }
        }
        v
    }
    /// The JSON types a schema allows (empty: unknown / anything).
    fn types<'a>(v: &'a J, root: &'a J) -> Vec<&'a str> {
        let v = resolve(v, root);
        let mut out = Vec::new();
        match v.get("type") {
            Some(J::String(t)) => out.push(t.as_str()),
            Some(J::Array(ts)) => out.extend(ts.iter().filter_map(J::as_str)),
            _ => {}
        }
        for key in ["anyOf", "oneOf"] {
            if let Some(alts) = v.get(key).and_then(J::as_array) {
                for a in alts {
                    let t = types(a, root);
                    if t.is_empty() {
                        return Vec::new();
                    }
                    out.extend(t);
                }
            }
        }
        if out.is_empty() && v.get("properties").is_some() {
            out.push("object");
        }
        out
    }
    /// The resolved alternatives of an `anyOf`/`oneOf` schema (empty for other schemas).
    fn alternatives<'a>(v: &'a J, root: &'a J) -> Vec<&'a J> {
        ["anyOf", "oneOf"].iter().filter_map(|k| v.get(*k).and_then(J::as_array)).flatten().map(|a| resolve(a, root)).collect()
    }
    /// The table alternative of `v` that table `t` is: the only one, or the one whose tag
    /// property (a constant, or an enum of one value) has `t`'s value.
    fn table_alternative<'a>(v: &'a J, root: &'a J, t: &toml::Table) -> Option<&'a J> {
        let tables: Vec<&J> = alternatives(v, root).into_iter().filter(|a| a.get("properties").is_some()).collect();
        if tables.len() == 1 {
            return Some(tables[0]);
        }
        tables.into_iter().find(|a| {
            a["properties"].as_object().is_some_and(|props| {
                props.iter().any(|(k, p)| {
                    let p = resolve(p, root);
                    let tag = p.get("const").or_else(|| p.get("enum").and_then(J::as_array).filter(|e| e.len() == 1).and_then(|e| e.first()));
                    matches!((tag, t.get(k)), (Some(J::String(c)), Some(toml::Value::String(x))) if c == x)
                })
            })
        })
    }
    fn walk(src: &ConfigSource, value: &toml::Value, schema: &J, root: &J, path: &str) -> Result<(), ConfigError> {
        let allowed = types(schema, root);
        let s = resolve(schema, root);
        // NaN is no key's value (every comparison with it is false, so a range check lets it
        // through, and the run then never converges or stops where it should)
        if let toml::Value::Float(x) = value {
            if x.is_nan() && !path.is_empty() {
                return Err(src.error_at_key(path, "nan (allowed: a number; NaN is not a value of any key)"));
            }
        }
        if !allowed.is_empty() {
            let scalar = ["number", "integer", "string", "boolean"];
            if let toml::Value::Array(_) = value {
                if !allowed.contains(&"array") && allowed.contains(&"object") {
                    return Err(src.error_at_key(path, format!("an array, but `{path}` is a table (allowed: a `[{path}]` section with its keys, or `{path} = {{ … }}`)")));
                }
            }
            if let toml::Value::Table(_) = value {
                if !allowed.contains(&"object") && allowed.iter().any(|t| scalar.contains(t) || *t == "array") {
                    let what = allowed.iter().filter(|t| **t != "null").cloned().collect::<Vec<_>>().join(" or ");
                    return Err(src.error_at_key(path, format!("a table, but `{path}` is a value (allowed: {what}, written `{path} = …`)")));
                }
            }
            // a scalar of another kind than the key's (serde would say "invalid type: string
            // \"x\", expected f64" at the section header, naming no key)
            let what = || {
                let words: Vec<&str> = allowed
                    .iter()
                    .filter_map(|t| match *t {
                        "number" => Some("a number"),
                        "integer" => Some("a whole number"),
                        "string" => Some("text"),
                        "boolean" => Some("true or false"),
                        "array" => Some("a list"),
                        "object" => Some("a table"),
                        _ => None,
                    })
                    .collect();
                words.join(" or ")
            };
            let shown = || clip(&value.to_string(), MAX_ECHO_CHARS);
            let wrong = match value {
                toml::Value::String(_) => (!allowed.contains(&"string")).then(|| format!("text {}", shown())),
                toml::Value::Boolean(_) => (!allowed.contains(&"boolean")).then(|| format!("`{}`", shown())),
                toml::Value::Integer(_) => (!allowed.contains(&"integer") && !allowed.contains(&"number")).then(|| format!("the number {}", shown())),
                toml::Value::Float(_) if !allowed.contains(&"number") => {
                    Some(format!("{} {}", if allowed.contains(&"integer") { "the fractional number" } else { "the number" }, shown()))
                }
                _ => None,
            };
            if let Some(found) = wrong {
                return Err(src.error_at_key(path, format!("{found}, but `{path}` takes {} (written `{path} = …`)", what())));
            }
        }
        // an optional section or a tagged choice (`anyOf`/`oneOf` of tables): walk into the
        // alternative that the value is, so that its keys are checked too
        let s = match value {
            toml::Value::Table(t) if s.get("properties").is_none() => table_alternative(s, root, t).unwrap_or(s),
            toml::Value::Array(_) if s.get("items").is_none() => {
                alternatives(s, root).into_iter().find(|a| a.get("items").is_some()).unwrap_or(s)
            }
            _ => s,
        };
        match value {
            toml::Value::Table(t) => {
                if let Some(props) = s.get("properties").and_then(J::as_object) {
                    for (k, v) in t {
                        if let Some(sub) = props.get(k) {
                            let p = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
                            walk(src, v, sub, root, &p)?;
                        }
                    }
                }
            }
            toml::Value::Array(a) => {
                // a list of fixed length (`[k_n, k_t]`): serde reads the first values and drops
                // the rest without a word; refuse a list of another length at its key
                let min = s.get("minItems").and_then(J::as_u64);
                let max = s.get("maxItems").and_then(J::as_u64);
                let n = a.len() as u64;
                if min.is_some_and(|m| n < m) || max.is_some_and(|m| n > m) {
                    let allowed = match (min, max) {
                        (Some(lo), Some(hi)) if lo == hi => format!("exactly {lo}"),
                        (Some(lo), Some(hi)) => format!("{lo} to {hi}"),
                        (Some(lo), None) => format!("at least {lo}"),
                        (None, Some(hi)) => format!("at most {hi}"),
                        (None, None) => unreachable!("a bound was broken"),
                    };
                    return Err(src.error_at_key(path, format!("a list of {n} values (allowed: {allowed} values)")));
                }
                if let Some(items) = s.get("items") {
                    for (i, v) in a.iter().enumerate() {
                        walk(src, v, items, root, &format!("{path}[{i}]"))?;
                    }
                }
            }
            _ => {}
        }
        Ok(())
    }
    let table: toml::Table = src.parse()?;
    walk(src, &toml::Value::Table(table), schema, schema, "")
}

/// Longest quotation of a value from the file in an error message [characters].
pub const MAX_ECHO_CHARS: usize = 200;

/// `text` cut to `max` characters, with a note of how much was left out, and its control
/// characters escaped ([`escape_controls`]).
pub fn clip(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        None => escape_controls(text, false),
        Some((cut, _)) => format!("{}… ({} more bytes)", escape_controls(&text[..cut], false), text.len() - cut),
    }
}

/// `text` with its control characters written as escapes (`\u{1b}`, `\u{7}`, and `\n`, `\t`,
/// `\r`): a message quotes text from a file, and raw escape sequences would recolour the
/// terminal or set its title. Line breaks are kept when `keep_newlines` (a message of several
/// lines) and escaped otherwise (a quoted name or value).
pub fn escape_controls(text: &str, keep_newlines: bool) -> String {
    if !text.chars().any(|c| c.is_control() && !(keep_newlines && c == '\n')) {
        return text.to_string();
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        match c {
            '\n' if keep_newlines => out.push(c),
            c if c.is_control() => out.extend(c.escape_default()),
            c => out.push(c),
        }
    }
    out
}

/// [`clip`] without escaping the line breaks of a message of several lines (the other control
/// characters are escaped by the caller).
fn clip_keeping_lines(text: &str, max: usize) -> String {
    match text.char_indices().nth(max) {
        None => text.to_string(),
        Some((cut, _)) => format!("{}… ({} more bytes)", &text[..cut], text.len() - cut),
    }
}

/// Longest number written out in full in a message [characters]; longer ones are rewritten in
/// exponent form.
const MAX_NUMBER_CHARS: usize = 24;

/// `text` with every decimal number longer than 24 characters rewritten in exponent form:
/// Rust writes `1e308` as 309 digits and `5e-324` as 326 characters in `{}`, which buries a
/// message; `{:e}` gives `1e308` and `5e-324` (the same value: the shortest form that reads back
/// to the same `f64`). Shorter numbers, and digit runs that are not numbers, are left alone.
pub fn compact_numbers(text: &str) -> String {
    let bytes = text.as_bytes();
    let mut out = String::with_capacity(text.len());
    let mut k = 0;
    while k < bytes.len() {
        let starts_number = bytes[k].is_ascii_digit() || (bytes[k] == b'-' && bytes.get(k + 1).is_some_and(u8::is_ascii_digit));
        let after_word = k > 0 && (bytes[k - 1].is_ascii_alphanumeric() || bytes[k - 1] == b'_');
        if starts_number && !after_word {
            let mut end = k + 1;
            while end < bytes.len() && (bytes[end].is_ascii_digit() || bytes[end] == b'.') {
                end += 1;
            }
            let run = &text[k..end];
            match run.parse::<f64>() {
                Ok(v) if run.len() > MAX_NUMBER_CHARS && v.is_finite() => out.push_str(&format!("{v:e}")),
                _ => out.push_str(run),
            }
            k = end;
        } else {
            let c = text[k..].chars().next().expect("k is on a char boundary");
            out.push(c);
            k += c.len_utf8();
        }
    }
    out
}

/// 1-based line and column (in characters) of byte offset `at`.
pub fn line_column(text: &str, at: usize) -> (usize, usize) {
    let at = at.min(text.len());
    let before = &text[..at];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().map(|l| l.chars().count()).unwrap_or(0) + 1;
    (line, col)
}

/// Byte offset of the key `key` written at the start of a line (`key = …`) in the table that
/// `within` reports (its span, or its header and the lines up to the next header), if exactly
/// one line there does so.
fn key_line_in(text: &str, within: Range<usize>, key: &str) -> Option<usize> {
    let start = within.start.min(text.len());
    let after_first = text[start..].find('\n').map_or(text.len(), |k| start + k + 1);
    let next_header = text[after_first..].find("\n[").map_or(text.len(), |k| after_first + k + 1);
    let end = within.end.min(text.len()).max(next_header);
    let region = text.get(start..end)?;
    let mut found = None;
    let mut offset = start;
    for line in region.split_inclusive('\n') {
        let indent = line.len() - line.trim_start().len();
        let rest = &line[indent..];
        if rest.strip_prefix(key).is_some_and(|r| r.trim_start().starts_with('=')) {
            if found.is_some() {
                return None;
            }
            found = Some(offset + indent);
        }
        offset += line.len();
    }
    found
}

/// Adds a "did you mean" to serde's unknown-field and unknown-variant messages.
fn improve_message(msg: &str) -> String {
    for (marker, what) in [("unknown field `", "key"), ("unknown variant `", "value")] {
        if let Some(rest) = msg.strip_prefix(marker) {
            let bad = clip(rest.split('`').next().unwrap_or(""), MAX_ECHO_CHARS);
            let bad = bad.as_str();
            let candidates: Vec<&str> = msg.split('`').skip(3).step_by(2).collect();
            let mut out = format!("unknown {what} `{bad}`");
            if let Some(best) = did_you_mean(bad, &candidates) {
                out.push_str(&format!(" — did you mean `{best}`?"));
            }
            if !candidates.is_empty() {
                out.push_str(&format!(" (allowed: {})", candidates.join(", ")));
            }
            return out;
        }
    }
    msg.trim_end_matches('\n').to_string()
}

/// The candidate closest to `word`, if it is close enough to be a likely typo.
pub fn did_you_mean<'a>(word: &str, candidates: &[&'a str]) -> Option<&'a str> {
    candidates
        .iter()
        .map(|c| (strsim::normalized_damerau_levenshtein(word, c), *c))
        .filter(|(score, _)| *score >= 0.6)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
}

/// One step of a key path.
enum Segment<'a> {
    Key(&'a str),
    Index(usize),
}

fn segments(path: &str) -> Vec<Segment<'_>> {
    let mut out = Vec::new();
    for part in path.split('.') {
        let mut rest = part;
        if let Some(b) = rest.find('[') {
            if b > 0 {
                out.push(Segment::Key(&rest[..b]));
            }
            rest = &rest[b..];
            while let Some(stripped) = rest.strip_prefix('[') {
                let close = stripped.find(']').unwrap_or(stripped.len());
                if let Ok(k) = stripped[..close].parse() {
                    out.push(Segment::Index(k));
                }
                rest = stripped.get(close + 1..).unwrap_or("");
            }
        } else {
            out.push(Segment::Key(rest));
        }
    }
    out
}

/// Span of the value at `path`, or of the deepest existing key on the way.
fn locate(doc: &toml_edit::Document<&str>, path: &str) -> Option<Range<usize>> {
    walk(doc, path).1
}

/// Span of the value at `path` only if the whole path exists in the file.
fn locate_exact(doc: &toml_edit::Document<&str>, path: &str) -> Option<Range<usize>> {
    let (complete, span) = walk(doc, path);
    if complete {
        span
    } else {
        None
    }
}

fn walk(doc: &toml_edit::Document<&str>, path: &str) -> (bool, Option<Range<usize>>) {
    let mut item: &toml_edit::Item = doc.as_item();
    let mut best: Option<Range<usize>> = None;
    for seg in segments(path) {
        let (next, key_span) = match (&seg, item) {
            (Segment::Key(k), toml_edit::Item::Table(t)) => (t.get(k), t.key(k).and_then(|k| k.span())),
            (Segment::Key(k), toml_edit::Item::Value(toml_edit::Value::InlineTable(t))) => (item.get(*k), t.key(k).and_then(|k| k.span())),
            (Segment::Index(i), _) => (item.get(*i), None),
            _ => (None, None),
        };
        match next {
            None => return (false, best),
            Some(n) => {
                let span = match n {
                    toml_edit::Item::Value(v) => v.span(),
                    toml_edit::Item::Table(t) => t.span().or(key_span.clone()),
                    toml_edit::Item::ArrayOfTables(a) => a.span().or(key_span.clone()),
                    toml_edit::Item::None => None,
                };
                if span.is_some() {
                    best = span;
                } else if key_span.is_some() {
                    best = key_span;
                }
                item = n;
            }
        }
    }
    (true, best)
}

/// Dotted path of the innermost key whose key or value contains byte offset `at`.
fn key_at(doc: &toml_edit::Document<&str>, at: usize) -> Option<String> {
    fn visit(item: &toml_edit::Item, prefix: &str, at: usize, best: &mut Option<(usize, String)>) {
        let consider = |span: Option<Range<usize>>, path: &str, best: &mut Option<(usize, String)>| {
            if let Some(s) = span {
                if s.start <= at && at <= s.end {
                    let width = s.end - s.start;
                    if best.as_ref().is_none_or(|(w, _)| width <= *w) {
                        *best = Some((width, path.to_string()));
                    }
                }
            }
        };
        let join = |k: &str| if prefix.is_empty() { k.to_string() } else { format!("{prefix}.{k}") };
        match item {
            toml_edit::Item::Table(t) => {
                for (k, v) in t.iter() {
                    let path = join(k);
                    if let Some(key) = t.key(k) {
                        consider(key.span(), &path, best);
                    }
                    visit(v, &path, at, best);
                }
            }
            toml_edit::Item::ArrayOfTables(a) => {
                for (i, t) in a.iter().enumerate() {
                    let path = format!("{prefix}[{i}]");
                    consider(t.span(), &path, best);
                    for (k, v) in t.iter() {
                        let p = format!("{path}.{k}");
                        if let Some(key) = t.key(k) {
                            consider(key.span(), &p, best);
                        }
                        visit(v, &p, at, best);
                    }
                }
            }
            toml_edit::Item::Value(v) => {
                consider(v.span(), prefix, best);
                match v {
                    toml_edit::Value::InlineTable(t) => {
                        for (k, v) in t.iter() {
                            let path = join(k);
                            if let Some(key) = t.key(k) {
                                consider(key.span(), &path, best);
                            }
                            visit(&toml_edit::Item::Value(v.clone()), &path, at, best);
                        }
                    }
                    toml_edit::Value::Array(a) => {
                        for (i, v) in a.iter().enumerate() {
                            visit(&toml_edit::Item::Value(v.clone()), &format!("{prefix}[{i}]"), at, best);
                        }
                    }
                    _ => {}
                }
            }
            toml_edit::Item::None => {}
        }
    }
    let mut best = None;
    visit(doc.as_item(), "", at, &mut best);
    best.map(|(_, p)| p).filter(|p| !p.is_empty())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extreme_numbers_are_written_in_exponent_form() {
        let huge = format!("{}", 1e308_f64);
        let tiny = format!("{}", 5e-324_f64);
        assert_eq!(huge.len(), 309);
        let m = compact_numbers(&format!("{huge} (allowed: < 1), {tiny}, -{huge}, 0.25, 4294967296, v1.2.3, x{huge}"));
        assert!(m.starts_with("1e308 (allowed: < 1), 5e-324, -1e308, 0.25, 4294967296, v1.2.3, x1000"), "{m}");
        // a config error quoting such a value stays short
        let src = ConfigSource::from_text("t.toml", "a = 1e308\n");
        let e = src.error_at_key("a", format!("{} (allowed: a finite number < 1)", 1e308_f64));
        assert!(e.message.starts_with("1e308 (allowed"), "{}", e.message);
    }

    #[test]
    fn quotes_are_clipped_and_control_characters_escaped() {
        assert_eq!(escape_controls("a\u{1b}[31mb\u{7}", false), "a\\u{1b}[31mb\\u{7}");
        assert_eq!(escape_controls("one\ntwo\tx", true), "one\ntwo\\tx");
        assert_eq!(escape_controls("one\ntwo", false), "one\\ntwo");
        let c = clip(&format!("\u{1b}{}", "k".repeat(1000)), 10);
        assert!(c.starts_with("\\u{1b}kkkkkkkkk… (991 more bytes)"), "{c}");
        // a config error escapes and clips its key, and leaves out an excerpt with a control
        // character or a long line near the error
        let src = ConfigSource::from_text("t.toml", format!("a = \"{}\"\nb = 1\n\"\u{1b}x\" = 2\n", "u".repeat(5000)));
        let e = src.error_at_key("\u{1b}x", "unknown key `\u{1b}x`");
        assert!(!e.to_string().contains('\u{1b}') && e.to_string().contains("\\u{1b}x"), "{e}");
        assert!(miette::Diagnostic::source_code(&e).is_none());
        let e = src.error_at_key("b", "bad");
        assert!(miette::Diagnostic::source_code(&e).is_none(), "the 5000-byte line before `b` would be quoted");
        let src = ConfigSource::from_text("t.toml", "a = 1\nb = 2\nc = 3\n");
        assert!(miette::Diagnostic::source_code(&src.error_at_key("b", "bad")).is_some());
    }

    #[test]
    fn nan_and_lists_of_another_fixed_length_are_refused_at_their_key() {
        #[derive(serde::Deserialize, schemars::JsonSchema)]
        #[allow(dead_code)]
        struct T {
            pair: [f64; 2],
            x: f64,
            list: Vec<f64>,
        }
        let schema = serde_json::to_value(schemars::schema_for!(T)).unwrap();
        let ok = ConfigSource::from_text("t.toml", "pair = [1.0, 2.0]\nx = inf\nlist = [1.0, 2.0, 3.0]\n");
        check_shapes(&ok, &schema).unwrap();
        let long = ConfigSource::from_text("t.toml", "pair = [1.0, 2.0, 3.0]\nx = 1.0\nlist = []\n");
        let e = check_shapes(&long, &schema).unwrap_err();
        assert_eq!(e.key.as_deref(), Some("pair"));
        assert!(e.message.contains("a list of 3 values (allowed: exactly 2 values)"), "{e}");
        let nan = ConfigSource::from_text("t.toml", "pair = [1.0, 2.0]\nx = 1.0\nlist = [1.0, nan]\n");
        let e = check_shapes(&nan, &schema).unwrap_err();
        assert_eq!(e.key.as_deref(), Some("list[1]"));
        assert!(e.message.starts_with("nan (allowed: a number"), "{e}");
    }

    #[test]
    fn positions_and_paths() {
        let src = ConfigSource::from_text("t.toml", "a = 1\n[contact]\npreset = \"x\"\nfriction = -1\n[[walls]]\nname = \"w\"\nmass = 2\n");
        let e = src.error_at_key("contact.friction", "bad");
        assert_eq!((e.line, e.column), (4, 12));
        let e = src.error_at_key("walls[0].mass", "bad");
        assert_eq!((e.line, e.column), (7, 8));
        // a key left at its default points at its table
        let e = src.error_at_key("contact.restitution", "bad");
        assert_eq!(e.line, 2);
        assert!(e.to_string().starts_with("t.toml:2:"), "{e}");
        assert_eq!(did_you_mean("frction", &["friction", "preset"]), Some("friction"));
        assert_eq!(did_you_mean("zzz", &["friction", "preset"]), None);
    }
}

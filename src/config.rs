//! Configuration files and `--set` overrides, for every `*Config` in the crate.
//!
//! Every stage's settings are a serde struct with `Default`; a whole run nests them
//! ([`crate::pipeline::Config`]). This module reads them from TOML and applies
//! `section.key=value` overrides generically:
//!
//! - [`from_toml_str`] parses a file onto the defaults: a table that sets some keys of a
//!   nested section keeps the other keys at *that section's* defaults in its parent (the
//!   planemap stage's photo settings are not the photo module's), and a bad key or value is
//!   reported with the file and the line;
//! - [`with_overrides`] applies `--set` overrides, naming the key on any error;
//! - [`describe`] prints the defaults as TOML with each key's documentation (meaning, unit,
//!   range), which `planemap config --defaults` shows.

use serde::de::DeserializeOwned;
use serde::Serialize;
use thiserror::Error;

/// Errors of reading a configuration or applying overrides. Each names where the bad value
/// came from: the file and line, or the `--set` override.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum ConfigError {
    /// A TOML file (or string) that does not parse or does not fit the settings.
    #[error("{origin}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Parse {
        /// The file (or "overrides").
        origin: String,
        /// 1-based line of the error, when known.
        line: Option<usize>,
        /// What was wrong.
        message: String,
    },
    /// A `--set` override that cannot be applied.
    #[error("--set {override_text}: {message}")]
    Override {
        /// The override as given.
        override_text: String,
        /// What was wrong.
        message: String,
    },
    /// The settings cannot be written as TOML (a bug, not user input).
    #[error("cannot serialise the configuration: {0}")]
    Serialise(String),
}

fn to_value<T: Serialize>(value: &T) -> Result<toml::Value, ConfigError> {
    toml::Value::try_from(value).map_err(|e| ConfigError::Serialise(e.to_string()))
}

fn from_value<T: DeserializeOwned>(value: toml::Value) -> Result<T, toml::de::Error> {
    // Through text, so that the deserialiser is the one that reads files.
    let text = toml::to_string(&value).unwrap_or_default();
    toml::from_str(&text)
}

/// Copies every key of `patch` into `base`, descending into tables present in both.
fn merge(base: &mut toml::Value, patch: toml::Value) {
    match (base, patch) {
        (toml::Value::Table(b), toml::Value::Table(p)) => {
            for (k, v) in p {
                match b.get_mut(&k) {
                    Some(slot) if slot.is_table() && v.is_table() => merge(slot, v),
                    _ => {
                        b.insert(k, v);
                    }
                }
            }
        }
        (b, p) => *b = p,
    }
}

/// Parses a TOML configuration onto `T::default()`; errors name `origin` and the line.
///
/// Keys the text leaves out keep their defaults *in context*: `[planemap.photo]` with one
/// key keeps the planemap stage's other photo settings, not the photo module's.
pub fn from_toml_str<T>(text: &str, origin: &str) -> Result<T, ConfigError>
where
    T: Serialize + DeserializeOwned + Default,
{
    // Typed first, so that an unknown key or a wrong type is reported at its line.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    toml::from_str::<T>(text).map_err(|e| ConfigError::Parse {
        origin: origin.to_string(),
        line: e
            .span()
            .map(|s| text[..s.start.min(text.len())].lines().count().max(1)),
        message: e.message().to_string(),
    })?;
    let patch: toml::Value = toml::from_str(text).map_err(|e| ConfigError::Parse {
        origin: origin.to_string(),
        line: None,
        message: e.message().to_string(),
    })?;
    let mut root = to_value(&T::default())?;
    merge(&mut root, patch);
    from_value(root).map_err(|e| ConfigError::Parse {
        origin: origin.to_string(),
        line: None,
        message: e.message().to_string(),
    })
}

/// The value of an override: TOML syntax (`0.5`, `true`, `"text"`, `[1, 2]`), or a bare
/// string such as a path. Something that starts like a number but is not a valid TOML value
/// (an integer beyond i64, `1.2.3`) is an error rather than a string.
fn parse_override_value(value: &str) -> Result<toml::Value, String> {
    let value = value.trim();
    match toml::from_str::<toml::Table>(&format!("v = {value}")) {
        Ok(mut t) => Ok(t.remove("v").unwrap_or(toml::Value::String(value.into()))),
        Err(e) => {
            let numeric = value
                .trim_start_matches(['+', '-'])
                .starts_with(|c: char| c.is_ascii_digit());
            if numeric {
                Err(format!(
                    "{value:?} is not a valid number (integers must fit in 64-bit signed; {})",
                    e.message().trim()
                ))
            } else {
                Ok(toml::Value::String(value.to_string()))
            }
        }
    }
}

/// Applies `section.key=value` overrides (value in TOML syntax; bare words are strings) to
/// `value`, e.g. `planemap.lambda=0.5`. Unknown keys, values of the wrong type and values
/// that do not parse are errors naming the override.
pub fn with_overrides<T>(value: &T, overrides: &[String]) -> Result<T, ConfigError>
where
    T: Serialize + DeserializeOwned,
{
    let mut root = to_value(value)?;
    for ov in overrides {
        let bad = |message: String| ConfigError::Override {
            override_text: ov.clone(),
            message,
        };
        let (key, value) = ov
            .split_once('=')
            .ok_or_else(|| bad("expected section.key=value".into()))?;
        let parsed = parse_override_value(value).map_err(bad)?;
        let parts: Vec<&str> = key.trim().split('.').collect();
        if parts.iter().any(|p| p.is_empty()) {
            return Err(bad(format!("{key:?} is not a dotted key")));
        }
        let mut node = &mut root;
        for (i, part) in parts.iter().enumerate() {
            let table = node
                .as_table_mut()
                .ok_or_else(|| bad(format!("{:?} is not a section", parts[..i].join("."))))?;
            if i + 1 == parts.len() {
                table.insert(part.to_string(), parsed.clone());
                break;
            }
            node = table
                .entry(part.to_string())
                .or_insert_with(|| toml::Value::Table(Default::default()));
        }
        // Checked one at a time, so that the error names this override.
        from_value::<T>(root.clone()).map_err(|e| bad(e.message().trim().to_string()))?;
    }
    from_value(root).map_err(|e| ConfigError::Override {
        override_text: overrides.join(" "),
        message: e.message().trim().to_string(),
    })
}

/// Documentation of one configuration key, as `planemap config --defaults` prints it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyDoc {
    /// Dotted key, e.g. `planemap.lambda`.
    pub key: &'static str,
    /// The field's doc comment (meaning, unit, range, why).
    pub doc: &'static str,
}

include!(concat!(env!("OUT_DIR"), "/config_docs.rs"));

/// `value` as TOML, each key preceded by its documentation from `docs` (matched by dotted
/// key under `prefix`) as `#` comments: the annotated defaults file.
pub fn describe<T: Serialize>(
    value: &T,
    docs: &[KeyDoc],
    prefix: &str,
) -> Result<String, ConfigError> {
    let root = to_value(value)?;
    let mut out = String::new();
    let table = root
        .as_table()
        .ok_or_else(|| ConfigError::Serialise("the configuration is not a table".into()))?;
    describe_table(table, prefix, docs, &mut out);
    Ok(out)
}

fn doc_comment(out: &mut String, doc: &str) {
    for line in doc.lines() {
        if line.trim().is_empty() {
            out.push_str("#\n");
        } else {
            out.push_str("# ");
            out.push_str(line.trim_end());
            out.push('\n');
        }
    }
}

fn describe_table(table: &toml::Table, path: &str, docs: &[KeyDoc], out: &mut String) {
    let dotted = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    let find = |key: &str| docs.iter().find(|d| d.key == key).map(|d| d.doc);
    // Plain values first (TOML requires them before the sub-tables), then sub-tables.
    for (k, v) in table.iter().filter(|(_, v)| !v.is_table()) {
        let key = dotted(k);
        if let Some(doc) = find(&key) {
            doc_comment(out, doc);
        }
        let mut one = toml::Table::new();
        one.insert(k.clone(), v.clone());
        out.push_str(&toml::to_string(&one).unwrap_or_default());
        out.push('\n');
    }
    for (k, v) in table.iter() {
        if let toml::Value::Table(sub) = v {
            let key = dotted(k);
            if let Some(doc) = find(&key) {
                doc_comment(out, doc);
            }
            out.push_str(&format!("[{key}]\n\n"));
            describe_table(sub, &key, docs, out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct Inner {
        a: f64,
        b: u32,
        path: Option<String>,
    }
    impl Default for Inner {
        fn default() -> Self {
            Inner {
                a: 1.0,
                b: 2,
                path: None,
            }
        }
    }
    #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
    #[serde(default, deny_unknown_fields)]
    struct Outer {
        x: u64,
        inner: Inner,
    }
    impl Default for Outer {
        fn default() -> Self {
            // The parent sets a default of its own for the nested section.
            Outer {
                x: 3,
                inner: Inner {
                    a: 0.15,
                    ..Inner::default()
                },
            }
        }
    }

    #[test]
    fn a_partial_section_keeps_its_parents_defaults() {
        let cfg: Outer = from_toml_str("[inner]\nb = 7\n", "f.toml").unwrap();
        assert_eq!(cfg.inner.a, 0.15, "the parent's default, not Inner's 1.0");
        assert_eq!(cfg.inner.b, 7);
        assert_eq!(cfg.x, 3);
        let bom: Outer = from_toml_str("\u{feff}x = 4\n", "f.toml").unwrap();
        assert_eq!(bom.x, 4);
    }

    #[test]
    fn file_errors_name_the_line() {
        let err = from_toml_str::<Outer>("x = 1\n\n[inner]\nnope = 2\n", "f.toml").unwrap_err();
        // toml reports an unknown key at its table's header.
        assert!(err.to_string().starts_with("f.toml:3: "), "{err}");
        assert!(err.to_string().contains("nope"), "{err}");
        let err = from_toml_str::<Outer>("x = \"a\"\n", "f.toml").unwrap_err();
        assert!(err.to_string().starts_with("f.toml:1: "), "{err}");
    }

    #[test]
    fn overrides_set_nested_and_absent_optional_keys() {
        let base = Outer::default();
        let cfg = with_overrides(
            &base,
            &[
                "inner.b=9".into(),
                "x=5".into(),
                "inner.path=/tmp/model.bin".into(),
            ],
        )
        .unwrap();
        assert_eq!(cfg.inner.b, 9);
        assert_eq!(cfg.x, 5);
        assert_eq!(cfg.inner.path.as_deref(), Some("/tmp/model.bin"));
        assert_eq!(cfg.inner.a, 0.15);
    }

    #[test]
    fn override_errors_name_the_override() {
        let base = Outer::default();
        let err = |ov: &str| {
            with_overrides(&base, &[ov.to_string()])
                .unwrap_err()
                .to_string()
        };
        let e = err("inner.nope=1");
        assert!(
            e.starts_with("--set inner.nope=1: ") && e.contains("nope"),
            "{e}"
        );
        let e = err("inner.b=\"seven\"");
        assert!(e.starts_with("--set inner.b=\"seven\": "), "{e}");
        assert!(!e.contains("line"), "no internal line numbers: {e}");
        let e = err("x=18446744073709551615");
        assert!(e.contains("not a valid number"), "{e}");
        let e = err("x");
        assert!(e.contains("section.key=value"), "{e}");
        let e = err("x.y=1");
        assert!(e.contains("\"x\" is not a section"), "{e}");
    }

    #[test]
    fn describe_annotates_keys_and_round_trips() {
        let docs = [
            KeyDoc {
                key: "x",
                doc: "The x count.",
            },
            KeyDoc {
                key: "inner.a",
                doc: "Weight a, in [0, 1].\n\nWhy: because.",
            },
        ];
        let text = describe(&Outer::default(), &docs, "").unwrap();
        assert!(text.contains("# The x count.\nx = 3\n"), "{text}");
        assert!(
            text.contains("# Weight a, in [0, 1].\n#\n# Why: because.\na = 0.15\n"),
            "{text}"
        );
        let back: Outer = from_toml_str(&text, "described").unwrap();
        assert_eq!(back, Outer::default());
    }
}

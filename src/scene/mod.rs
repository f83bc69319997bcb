//! Scenes: the TOML files a user writes, their schema, presets, `--set` overrides and
//! validation. Everything a scene gets wrong is reported with the file, the key and what
//! was expected.

mod expect;
pub mod keys;
pub mod presets_table;
mod schema;
mod validate;

pub use expect::ExpectSpec;
pub use schema::*;

use std::path::{Path, PathBuf};

/// Something wrong with a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{file}: cannot read: {source}")]
    Read {
        /// The scene file.
        file: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Syntax, unknown key or wrong type: the TOML message carries line, column and key.
    #[error("{file}: {message}")]
    Parse {
        /// The scene file.
        file: PathBuf,
        /// The TOML reader's message (line, column and key).
        message: String,
    },
    /// A value outside its key's rule.
    #[error("{file}: `{key}` = {value}: expected {expected}")]
    Invalid {
        /// The scene file.
        file: PathBuf,
        /// The dotted key.
        key: String,
        /// The value found.
        value: String,
        /// What was expected.
        expected: String,
    },
    /// A `--set` argument that cannot be applied.
    #[error("--set {arg}: {message}")]
    Override {
        /// The `--set` argument.
        arg: String,
        /// What is wrong with it.
        message: String,
    },
}

/// A scene value that failed validation (before the file name is known).
#[derive(Debug, Clone)]
pub struct Invalid {
    /// The dotted key.
    pub key: String,
    /// The value found.
    pub value: String,
    /// What was expected.
    pub expected: String,
}

impl Scene {
    /// Reads, overrides (`key=value` pairs, TOML values; bare words are strings) and
    /// validates a scene file.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Read {
            file: path.to_owned(),
            source,
        })?;
        Scene::from_toml(&text, path, overrides)
    }

    /// As [`Scene::load`], from text; `path` is used in messages only.
    pub fn from_toml(text: &str, path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
        // Parse the file on its own first so that its errors carry its own line numbers.
        let mut scene: Scene = toml::from_str(text).map_err(|e| SceneError::Parse {
            file: path.to_owned(),
            message: e.to_string().trim_end().to_string(),
        })?;
        if !overrides.is_empty() {
            let mut table: toml::Table = toml::from_str(text).map_err(|e| SceneError::Parse {
                file: path.to_owned(),
                message: e.to_string(),
            })?;
            let base = table.clone();
            for arg in overrides {
                apply_override(&mut table, arg)?;
            }
            scene = Scene::deserialize_table(table).map_err(|message| {
                // Name the override at fault: the first that fails on the file alone.
                let culprit = overrides.iter().find(|arg| {
                    let mut t = base.clone();
                    apply_override(&mut t, arg).is_ok() && Scene::deserialize_table(t).is_err()
                });
                SceneError::Override {
                    arg: culprit.cloned().unwrap_or_else(|| overrides.join(" ")),
                    message,
                }
            })?;
        }
        scene.validate().map_err(|bad| SceneError::Invalid {
            file: path.to_owned(),
            key: bad.key,
            value: bad.value,
            expected: bad.expected,
        })?;
        Ok(scene)
    }

    fn deserialize_table(table: toml::Table) -> Result<Scene, String> {
        let text = toml::to_string(&table).map_err(|e| e.to_string())?;
        toml::from_str(&text).map_err(|e: toml::de::Error| e.message().to_string())
    }

    /// The scene as TOML text (what a run actually used, overrides included).
    pub fn to_toml(&self) -> String {
        toml::to_string(self).unwrap_or_else(|e| format!("# scene not serialisable: {e}\n"))
    }
}

/// Parses `a.b.c=value` and sets it in the table. The key must name a known scene key:
/// unknown keys are caught when the table is deserialised.
fn apply_override(table: &mut toml::Table, arg: &str) -> Result<(), SceneError> {
    let err = |message: &str| SceneError::Override {
        arg: arg.to_string(),
        message: message.to_string(),
    };
    let (key, raw) = arg
        .split_once('=')
        .ok_or_else(|| err("expected KEY=VALUE, for example controller.kp_num=-2"))?;
    let key = key.trim();
    let raw = raw.trim();
    if key.is_empty() || key.split('.').any(|p| p.is_empty()) {
        return Err(err(
            "the key is empty; expected a dotted scene key like motor.resistance_ohm",
        ));
    }
    let value = parse_value(raw);
    let parts: Vec<&str> = key.split('.').collect();
    let mut cur = table;
    for part in &parts[..parts.len() - 1] {
        let entry = cur
            .entry(part.to_string())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cur = entry
            .as_table_mut()
            .ok_or_else(|| err(&format!("`{part}` is not a section")))?;
    }
    cur.insert(parts[parts.len() - 1].to_string(), value);
    Ok(())
}

/// A TOML value from a command-line string: numbers, booleans, arrays as TOML; anything
/// else is a plain string.
pub fn parse_value(raw: &str) -> toml::Value {
    let wrapped = format!("v = {raw}");
    match toml::from_str::<toml::Table>(&wrapped) {
        Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(raw.into())),
        Err(_) => toml::Value::String(raw.to_string()),
    }
}

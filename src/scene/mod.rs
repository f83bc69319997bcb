//! Scenes: the TOML files a user writes, their schema, presets, `--set` overrides and
//! validation. Everything a scene gets wrong is reported with the file, the key and what
//! was expected.

mod expect;
mod features;
pub mod inert;
pub mod keys;
mod origin;
pub mod plausibility;
pub mod presets_table;
pub mod robot;
mod schema;
mod validate;

pub use expect::ExpectSpec;
pub use features::Features;
pub use origin::Origin;
pub use schema::*;

use std::path::{Path, PathBuf};

/// A scene table (the file with its overrides) that is no scene.
#[derive(Debug, thiserror::Error)]
enum TableError {
    /// The table could not be written back as text.
    #[error("{0}")]
    Write(toml::ser::Error),
    /// The text is no scene (the message without the regenerated text's position).
    #[error("{}", .0.message())]
    Read(toml::de::Error),
}

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
    /// A value outside its key's rule, or at odds with another key.
    #[error("{origin}: `{key}` = {value}: expected {expected}")]
    Invalid {
        /// Where the value came from: `--set`, the file's line, or the default.
        origin: Origin,
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

/// What a file that does not parse as a scene is instead, where it is plainly something
/// else (a recording, a rig, a bag), said instead of the TOML reader's complaint.
fn not_a_scene(text: &str, path: &Path) -> Option<String> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let head = text.trim_start();
    if head.starts_with("# agvsim-recording") || ext == "csv" {
        return Some(
            "this is a recording (CSV), not a scene: a scene is a TOML file (scenes/*.toml, or `agvsim new`); a recording goes to --recording".into(),
        );
    }
    if matches!(
        ext.as_str(),
        "mcap" | "db3" | "bag" | "wpilog" | "mat" | "json"
    ) {
        return Some(format!(
            "this is a .{ext} file, not a scene: a scene is a TOML file (scenes/*.toml, or `agvsim new`); `agvsim import` converts logs"
        ));
    }
    None
}

/// A scene that loaded, with its plausibility warnings.
#[derive(Debug)]
pub struct Checked {
    /// The scene.
    pub scene: Scene,
    /// Values that do not fit the rest of the scene, with where each came from.
    pub warnings: Vec<(Origin, plausibility::Warning)>,
}

impl Checked {
    /// The warnings, one `warning: ORIGIN: ...` line each.
    pub fn render_warnings(&self) -> String {
        self.render_warnings_except(|_| false)
    }

    /// The warnings but those on keys `unused` says the command at hand never reads.
    pub fn render_warnings_except(&self, unused: impl Fn(&str) -> bool) -> String {
        self.warnings
            .iter()
            .filter(|(_, w)| !unused(w.key))
            .map(|(o, w)| format!("warning: {o}: {w}\n"))
            .collect()
    }
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

/// Largest scene file read, bytes: a wire of a kilometre at centimetre spacing is about
/// 2 MB; beyond this a file is a mistake (or hostile), not a floor.
pub const MAX_SCENE_BYTES: usize = 8 << 20;

/// A parser's message with each line cut to 200 characters and at most 20 lines: a
/// message quoting a 200 kB line (a deeply nested value) stays readable.
fn clipped(message: &str) -> String {
    let mut out: Vec<String> = message
        .lines()
        .take(20)
        .map(|l| {
            if l.chars().count() > 200 {
                format!("{}...", l.chars().take(200).collect::<String>())
            } else {
                l.to_string()
            }
        })
        .collect();
    if message.lines().count() > 20 {
        out.push("...".into());
    }
    out.join("\n")
}

/// A scene file's text: a regular file of at most [`MAX_SCENE_BYTES`].
pub fn read_scene_text(path: &Path) -> Result<String, SceneError> {
    match std::fs::metadata(path) {
        Ok(m) if m.is_file() && m.len() > MAX_SCENE_BYTES as u64 => {
            return Err(SceneError::Parse {
                file: path.to_owned(),
                message: format!(
                    "{} bytes, more than the {MAX_SCENE_BYTES} a scene may hold (a wire or floor of millions of points? resample it to centimetres)",
                    m.len()
                ),
            })
        }
        _ => {}
    }
    crate::output::read_text_bounded(path, MAX_SCENE_BYTES as u64 + 1).map_err(|source| {
        SceneError::Read {
            file: path.to_owned(),
            source,
        }
    })
}

impl Scene {
    /// Top speed on the drive wheels at a supply voltage, m/s: the motors' no-load speed
    /// there ([`crate::model::motor::MotorParams::no_load_speed_rad_s`]) through the gear
    /// to the wheel radius (no slip, no load).
    pub fn top_speed_m_s(&self, supply_v: f64) -> f64 {
        self.motor.no_load_speed_rad_s(supply_v) / self.gearbox.ratio * self.wheel.radius_m
    }

    /// Reads, overrides (`key=value` pairs, TOML values; bare words are strings) and
    /// validates a scene file.
    pub fn load(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
        let text = read_scene_text(path)?;
        Scene::from_toml(&text, path, overrides)
    }

    /// As [`Scene::load`], with the plausibility warnings of the result, each with where
    /// its value came from.
    pub fn load_checked(path: &Path, overrides: &[String]) -> Result<Checked, SceneError> {
        let text = read_scene_text(path)?;
        Scene::checked_from_toml(&text, path, overrides)
    }

    /// As [`Scene::load_checked`], from text; `path` is used in messages only.
    pub fn checked_from_toml(
        text: &str,
        path: &Path,
        overrides: &[String],
    ) -> Result<Checked, SceneError> {
        let scene = Scene::from_toml(text, path, overrides)?;
        let warnings = plausibility::warnings(&scene)
            .into_iter()
            .map(|w| (origin::origin_of(w.key, text, path, overrides), w))
            .collect();
        Ok(Checked { scene, warnings })
    }

    /// As [`Scene::load`], from text; `path` is used in messages only.
    pub fn from_toml(text: &str, path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
        if text.len() > MAX_SCENE_BYTES {
            return Err(SceneError::Parse {
                file: path.to_owned(),
                message: format!(
                    "{} bytes, more than the {MAX_SCENE_BYTES} a scene may hold (a wire or floor of millions of points? resample it to centimetres)",
                    text.len()
                ),
            });
        }
        // Parse the file on its own first so that its errors carry its own line numbers.
        let mut scene: Scene = toml::from_str(text).map_err(|e| SceneError::Parse {
            file: path.to_owned(),
            message: not_a_scene(text, path).unwrap_or_else(|| clipped(e.to_string().trim_end())),
        })?;
        for arg in overrides {
            check_override(arg)?;
        }
        if !overrides.is_empty() {
            let mut table: toml::Table = toml::from_str(text).map_err(|e| SceneError::Parse {
                file: path.to_owned(),
                message: e.to_string(),
            })?;
            let base = table.clone();
            for arg in overrides {
                apply_override(&mut table, arg)?;
            }
            scene = Scene::deserialize_table(table).map_err(|e| {
                // Name the override at fault: the first that fails on the file alone.
                let culprit = overrides.iter().find(|arg| {
                    let mut t = base.clone();
                    apply_override(&mut t, arg).is_ok() && Scene::deserialize_table(t).is_err()
                });
                SceneError::Override {
                    arg: culprit.cloned().unwrap_or_else(|| overrides.join(" ")),
                    message: e.to_string(),
                }
            })?;
        }
        scene.validate().map_err(|bad| SceneError::Invalid {
            origin: origin::origin_of(&bad.key, text, path, overrides),
            key: bad.key,
            value: bad.value,
            expected: bad.expected,
        })?;
        Ok(scene)
    }

    fn deserialize_table(table: toml::Table) -> Result<Scene, TableError> {
        let text = toml::to_string(&table).map_err(TableError::Write)?;
        toml::from_str(&text).map_err(TableError::Read)
    }

    /// The scene as TOML text (what a run actually used, overrides included).
    pub fn to_toml(&self) -> String {
        toml::to_string(self)
            .map(|t| crate::numtext::toml_short_floats(&t))
            .unwrap_or_else(|e| format!("# scene not serialisable: {e}\n"))
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

/// A TOML value from a command-line string: numbers, booleans, arrays as TOML; a number
/// TOML cannot hold as an integer (`10000000000000000000`) as a float; anything else is a
/// plain string.
pub fn parse_value(raw: &str) -> toml::Value {
    let wrapped = format!("v = {raw}");
    match toml::from_str::<toml::Table>(&wrapped) {
        Ok(mut t) => t.remove("v").unwrap_or(toml::Value::String(raw.into())),
        Err(_) => match raw.trim().parse::<f64>() {
            Ok(v) => toml::Value::Float(v),
            Err(_) => toml::Value::String(raw.to_string()),
        },
    }
}

/// A `--set` of a numeric key checked on its own, before the scene is assembled: a
/// number (in the key's unit) within the key's rule, so that its error names the `--set`,
/// the value typed and the range, before any check that ties keys together.
fn check_override(arg: &str) -> Result<(), SceneError> {
    let Some((key, raw)) = arg.split_once('=') else {
        return Ok(()); // apply_override explains the form
    };
    let (key, raw) = (key.trim(), raw.trim());
    let Some(k) = keys::table().find(key) else {
        return Ok(()); // an unknown key is named when the table is read
    };
    let Some(allowed) = k.allowed() else {
        return Ok(());
    };
    let expected = keys::expected_with_unit(allowed.expected(), k.unit);
    let invalid = |value: String| SceneError::Invalid {
        origin: Origin::Set(arg.to_string()),
        key: key.to_string(),
        value,
        expected: expected.clone(),
    };
    let number = match parse_value(raw) {
        toml::Value::Integer(i) => i as f64,
        toml::Value::Float(v) => v,
        toml::Value::String(s) => return Err(invalid(format!("the text {s:?}"))),
        other => return Err(invalid(format!("{} `{raw}`", other.type_str()))),
    };
    if allowed.is_integer() && number.fract() != 0.0 {
        return Err(invalid(raw.to_string()));
    }
    if !allowed.admits(number) {
        return Err(invalid(keys::with_unit(raw, k.unit)));
    }
    Ok(())
}

//! Reading a rig file: its TOML checked key by key against the key table, each refusal
//! naming the file, the line and what was expected.

use super::keys;
use super::{Rig, RigError, RigKind, Stated, UNCERTAINTY_SECTION};
use std::path::Path;

impl Rig {
    /// Reads and checks a rig file.
    pub fn load(path: &Path) -> Result<Rig, RigError> {
        let text = crate::output::read_text_bounded(path, crate::output::MAX_CONFIG_BYTES)
            .map_err(|source| RigError::Read {
                file: path.to_owned(),
                source,
            })?;
        Rig::parse(&text, path)
    }

    /// Parses and checks a rig file; `path` is used in messages.
    pub fn parse(text: &str, path: &Path) -> Result<Rig, RigError> {
        // A leading UTF-8 byte-order mark (as some editors write) is not TOML.
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let invalid = |message: String| RigError::Invalid {
            file: path.to_owned(),
            message,
        };
        let table: toml::Table = toml::from_str(text).map_err(|e| {
            let mut msg = e.message().to_string();
            if let Some(span) = e.span() {
                let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
                msg = format!("line {line}: {msg}");
            }
            invalid(msg)
        })?;
        // The kind as named, checked once every value is read (so that its error comes
        // where a missing kind's does).
        let mut kind_name: Option<&str> = None;
        let mut rig = Rig::new(RigKind::DriveAxis);
        for (name, value) in &table {
            match (name.as_str(), value) {
                ("rig", toml::Value::String(k)) => kind_name = Some(k),
                ("motion", toml::Value::String(m)) => rig.motion = Some(m.clone()),
                ("rig" | "motion", other) => {
                    return Err(invalid(format!(
                        "{}`{name}` = {other}: expected a quoted name",
                        at_line(text, None, name)
                    )))
                }
                (UNCERTAINTY_SECTION, toml::Value::Table(entries)) => {
                    rig.read_uncertainties(path, text, "", entries)?;
                }
                (section, toml::Value::Table(entries)) => {
                    for (key, v) in entries {
                        rig.read_value(path, text, section, key, v)?;
                    }
                }
                (other, _) => {
                    return Err(invalid(format!(
                        "{}unknown key `{other}`: a rig has `rig`, `motion` and sections {}",
                        at_line(text, None, other),
                        keys::sections().join(", ")
                    )))
                }
            }
        }
        rig.rig = match kind_name {
            None | Some("") => {
                return Err(invalid(format!(
                    "no `rig = \"...\"`: expected the rig kind, one of {}",
                    RigKind::names()
                )))
            }
            Some(name) => RigKind::from_name(name).ok_or_else(|| {
                invalid(format!(
                    "rig = \"{name}\": expected one of {}",
                    RigKind::names()
                ))
            })?,
        };
        rig.check(path)?;
        Ok(rig)
    }

    /// Takes one `[section] key = value` of a file, refusing a key the rig format does not
    /// have or a value of the wrong type, with its line.
    fn read_value(
        &mut self,
        file: &Path,
        text: &str,
        section: &str,
        key: &str,
        v: &toml::Value,
    ) -> Result<(), RigError> {
        let invalid = |message: String| RigError::invalid(file, message);
        let dotted = format!("{section}.{key}");
        let line = at_line(text, Some(section), key);
        let Some(k) = keys::find(&dotted) else {
            let known = keys::in_section(section);
            return Err(invalid(if known.is_empty() {
                format!(
                    "{line}unknown section `[{section}]`: a rig has {}",
                    keys::sections().join(", ")
                )
            } else {
                format!(
                    "{line}unknown key `{dotted}`: [{section}] takes {}",
                    known.join(", ")
                )
            }));
        };
        let stated = match (k.takes.allowed(), v) {
            (Some(_), toml::Value::Float(x)) => Stated::Number(*x),
            (Some(_), toml::Value::Integer(i)) => Stated::Number(*i as f64),
            (None, toml::Value::String(t)) => Stated::Text(t.clone()),
            (Some(_), other) => {
                return Err(invalid(format!(
                    "{line}`{dotted}` = {other}: expected a number{}",
                    in_unit(k.unit)
                )))
            }
            (None, other) => {
                return Err(invalid(format!(
                    "{line}`{dotted}` = {other}: expected a quoted name ({})",
                    k.takes.text()
                )))
            }
        };
        self.state(k, stated);
        Ok(())
    }

    /// Takes `[uncertainty_pct]`'s entries: each a numeric rig key (written quoted,
    /// `"chassis.mass_kg" = 50`, or as dotted keys, which TOML nests under `prefix`) with
    /// a percentage greater than zero.
    fn read_uncertainties(
        &mut self,
        file: &Path,
        text: &str,
        prefix: &str,
        entries: &toml::Table,
    ) -> Result<(), RigError> {
        let invalid = |message: String| RigError::invalid(file, message);
        for (name, v) in entries {
            let dotted = if prefix.is_empty() {
                name.clone()
            } else {
                format!("{prefix}.{name}")
            };
            let line = at_line(text, Some(UNCERTAINTY_SECTION), name);
            let pct = match v {
                toml::Value::Table(inner) => {
                    self.read_uncertainties(file, text, &dotted, inner)?;
                    continue;
                }
                toml::Value::Float(x) => *x,
                toml::Value::Integer(i) => *i as f64,
                other => {
                    return Err(invalid(format!(
                        "{line}`{UNCERTAINTY_SECTION}.\"{dotted}\"` = {other}: expected a number, one standard deviation in percent of the belief"
                    )))
                }
            };
            let k = keys::find(&dotted)
                .filter(|k| k.takes.allowed().is_some())
                .ok_or_else(|| {
                    invalid(format!(
                        "{line}[{UNCERTAINTY_SECTION}] `{dotted}`: not a numeric rig key; it takes the keys of the rig's values, e.g. \"chassis.mass_kg\" = 50"
                    ))
                })?;
            if !(pct.is_finite() && pct > 0.0) {
                return Err(invalid(format!(
                    "{line}[{UNCERTAINTY_SECTION}] `{dotted}` = {pct}: expected a percentage greater than zero"
                )));
            }
            self.state_uncertainty(k.order, pct);
        }
        Ok(())
    }

    /// Checks the motion and every stated number against its key's rule.
    fn check(&self, file: &Path) -> Result<(), RigError> {
        let invalid = |message: String| RigError::invalid(file, message);
        match self.motion.as_deref() {
            None | Some("rotary") | Some("linear") => {}
            Some(m) => {
                return Err(invalid(format!(
                    "motion = \"{m}\": expected \"rotary\" or \"linear\""
                )))
            }
        }
        for (k, v) in self.stated() {
            if let (Stated::Number(x), Some(rule)) = (v, k.takes.allowed()) {
                if !rule.admits(*x) {
                    return Err(invalid(format!(
                        "`{}` = {x}: expected {}{}",
                        k.key,
                        rule.expected(),
                        in_unit(k.unit)
                    )));
                }
            }
        }
        Ok(())
    }
}

/// "line N: " for a key of a rig's text (in `section`, or at the top), if it is found.
fn at_line(text: &str, section: Option<&str>, key: &str) -> String {
    let mut current: Option<String> = None;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(name) = t.strip_prefix('[').and_then(|r| r.split(']').next()) {
            current = Some(name.trim().to_string());
            continue;
        }
        let here = t
            .split('=')
            .next()
            .map(|k| k.trim().trim_matches('"'))
            .unwrap_or("");
        if here == key && current.as_deref() == section {
            return format!("line {}: ", i + 1);
        }
    }
    String::new()
}

/// ", in UNIT" for a key with a unit.
fn in_unit(unit: &str) -> String {
    if unit.is_empty() {
        String::new()
    } else {
        format!(", in {unit}")
    }
}

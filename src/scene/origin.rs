//! Where a scene value came from: a `--set` the user typed, a line of the scene file, or
//! the default (the thesis machine's) because the file leaves the key out. Errors and
//! warnings name it so that a user mends the right thing.

use std::path::{Path, PathBuf};

/// The source of one scene value.
#[derive(Debug, Clone, PartialEq)]
pub enum Origin {
    /// A line of the scene file (`None`: the file does not set the key, so the value is
    /// the default).
    File {
        /// The scene file.
        file: PathBuf,
        /// Its 1-based line, if the file sets the key.
        line: Option<usize>,
    },
    /// A `--set KEY=VALUE` argument (as typed).
    Set(String),
    /// A command's own option that sets a scene key (`--duration 1e19` sets
    /// `sim.duration_s`): the option and its value as typed.
    Flag(String),
}

impl std::fmt::Display for Origin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Origin::File {
                file,
                line: Some(l),
            } => write!(f, "{}:{l}", file.display()),
            Origin::File { file, line: None } => {
                write!(f, "{} (key not in the file: its default)", file.display())
            }
            Origin::Set(arg) => write!(f, "--set {arg}"),
            Origin::Flag(flag) => write!(f, "{flag}"),
        }
    }
}

/// Where `key` (dotted; `a / b` names several, the first that is set wins) got its value:
/// the last `--set` of it, else the file's line that sets it, else its default.
pub fn origin_of(key: &str, text: &str, file: &Path, overrides: &[String]) -> Origin {
    let keys: Vec<&str> = key.split(" / ").map(str::trim).collect();
    for k in &keys {
        if let Some(arg) = overrides
            .iter()
            .rev()
            .find(|a| a.split_once('=').is_some_and(|(name, _)| name.trim() == *k))
        {
            return Origin::Set(arg.clone());
        }
    }
    let line = keys.iter().find_map(|k| key_line(text, k));
    Origin::File {
        file: file.to_owned(),
        line,
    }
}

/// The 1-based line of a TOML text that sets dotted `key`, if one does: a `name = value`
/// line under its `[section]` header, or a dotted name under a parent header.
pub fn key_line(text: &str, key: &str) -> Option<usize> {
    let mut section = String::new();
    // Each array of tables' count so far: `[[obstacles]]` the second time is
    // `obstacles[1]`.
    let mut arrays: std::collections::BTreeMap<String, usize> = Default::default();
    for (i, raw) in text.lines().enumerate() {
        let line = strip_comment(raw).trim();
        if let Some(header) = line.strip_prefix("[[") {
            let name = unquote_path(header.trim_end_matches("]]"));
            let n = arrays.entry(name.clone()).or_insert(0);
            section = format!("{name}[{n}]");
            *n += 1;
            continue;
        }
        if let Some(header) = line.strip_prefix('[') {
            section = unquote_path(header.trim_end_matches(']'));
            continue;
        }
        let Some((name, _)) = line.split_once('=') else {
            continue;
        };
        let name = unquote_path(name);
        let full = if section.is_empty() {
            name
        } else {
            format!("{section}.{name}")
        };
        if full == key {
            return Some(i + 1);
        }
    }
    None
}

/// A TOML line without its comment (a `#` outside a string).
fn strip_comment(line: &str) -> &str {
    let mut quoted = false;
    for (i, c) in line.char_indices() {
        match c {
            '"' => quoted = !quoted,
            '#' if !quoted => return &line[..i],
            _ => {}
        }
    }
    line
}

/// A dotted TOML name with its parts' quotes and spaces removed.
fn unquote_path(name: &str) -> String {
    name.split('.')
        .map(|p| p.trim().trim_matches('"').trim_matches('\''))
        .collect::<Vec<_>>()
        .join(".")
}

#[cfg(test)]
mod tests {
    use super::*;

    const TEXT: &str = "description = \"a # not a comment\"\n\
                        [battery]\n\
                        open_circuit_V = 12.0 # a 12 V pack\n\
                        \n\
                        [controller.swing_away]\n\
                        correction = 0.3\n\
                        [[obstacles]]\n\
                        radius_m = 1.0\n\
                        [chassis]\n\
                        \"mass_kg\" = 60\n";

    #[test]
    fn a_key_is_found_on_its_line_under_its_section() {
        assert_eq!(key_line(TEXT, "description"), Some(1));
        let tables = "[[obstacles]]\ncenter_m = [1, 0]\n\n[[obstacles]]\nangle_rad = nan\n";
        assert_eq!(key_line(tables, "obstacles[1].angle_rad"), Some(5));
        assert_eq!(key_line(tables, "obstacles[0].center_m"), Some(2));
        assert_eq!(key_line(tables, "obstacles[0].angle_rad"), None);
        assert_eq!(key_line(TEXT, "battery.open_circuit_V"), Some(3));
        assert_eq!(key_line(TEXT, "controller.swing_away.correction"), Some(6));
        assert_eq!(key_line(TEXT, "chassis.mass_kg"), Some(10));
        assert_eq!(key_line(TEXT, "obstacles.radius_m"), None);
        assert_eq!(key_line(TEXT, "battery.drive_limit_V"), None);
    }

    #[test]
    fn the_last_set_wins_over_the_file() {
        let f = Path::new("s.toml");
        let set = [
            "battery.open_circuit_V=24".to_string(),
            "battery.open_circuit_V = 48".into(),
        ];
        assert_eq!(
            origin_of("battery.open_circuit_V", TEXT, f, &set),
            Origin::Set("battery.open_circuit_V = 48".into())
        );
        assert_eq!(
            origin_of("battery.open_circuit_V", TEXT, f, &[]).to_string(),
            "s.toml:3"
        );
        assert_eq!(
            origin_of("chassis.cg_x_m / chassis.mass_kg", TEXT, f, &[]).to_string(),
            "s.toml:10"
        );
        assert!(origin_of("motor.resistance_ohm", TEXT, f, &[])
            .to_string()
            .contains("its default"));
    }
}

//! A batch's recordings: every `*.csv` of a folder (each with `NAME.rig.toml` beside it
//! when there is one), or the lines of a list file (`recording.csv [rig.toml]`, paths
//! relative to the list; a name in double quotes may hold spaces and `#`; a `#` that
//! starts a word starts a comment), in name order.

use std::path::{Path, PathBuf};

use super::BatchError;

/// One recording of a batch.
#[derive(Debug, Clone, PartialEq)]
pub struct Item {
    /// Its name: the recording's file stem with anything but letters, digits, `.`, `-`
    /// and `_` replaced, so that its result files stay inside the output folder.
    pub name: String,
    /// The recording.
    pub recording: PathBuf,
    /// Its rig (diagnose), if it has one.
    pub rig: Option<PathBuf>,
    /// The recording as the folder or list names it.
    pub shown: String,
}

fn item(recording: PathBuf, rig: Option<PathBuf>, shown: String) -> Item {
    let stem = recording
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    Item {
        name: crate::output::safe_file_stem(&stem),
        recording,
        rig,
        shown,
    }
}

/// The rig beside a recording (`NAME.rig.toml`), if there is one.
fn rig_beside(recording: &Path) -> Option<PathBuf> {
    let stem = recording.file_stem()?.to_string_lossy().into_owned();
    let rig = recording.with_file_name(format!("{stem}.rig.toml"));
    rig.is_file().then_some(rig)
}

/// A list file's word opened with a quote and never closed (the word as far as it went).
#[derive(Debug, PartialEq, thiserror::Error)]
#[error("`\"{0}`: a quoted name without its closing quote")]
pub struct UnclosedQuote(String);

/// The words of a list file's line: separated by white space, a word in double quotes
/// may hold spaces and `#`; a `#` that starts a word starts a comment.
fn list_words(line: &str) -> Result<Vec<String>, UnclosedQuote> {
    let mut words = Vec::new();
    let mut chars = line.chars().peekable();
    loop {
        while chars.next_if(|c| c.is_whitespace()).is_some() {}
        match chars.peek() {
            None | Some('#') => return Ok(words),
            Some('"') => {
                chars.next();
                let mut word = String::new();
                let mut closed = false;
                for c in chars.by_ref() {
                    if c == '"' {
                        closed = true;
                        break;
                    }
                    word.push(c);
                }
                if !closed {
                    return Err(UnclosedQuote(word));
                }
                words.push(word);
            }
            Some(_) => {
                let mut word = String::new();
                while let Some(c) = chars.next_if(|c| !c.is_whitespace()) {
                    word.push(c);
                }
                words.push(word);
            }
        }
    }
}

/// The recordings of a folder or list file, each with its rig (`rig`, when given, for
/// all), sorted by name; two recordings of one name are refused.
pub fn find_items(source: &Path, rig: Option<&Path>) -> Result<Vec<Item>, BatchError> {
    let err = |message: String| BatchError::Items {
        path: source.to_owned(),
        message,
    };
    let mut items = if source.is_dir() {
        let mut found = Vec::new();
        let entries = std::fs::read_dir(source).map_err(|e| err(e.to_string()))?;
        for e in entries {
            let p = e.map_err(|e| err(e.to_string()))?.path();
            if p.extension().is_some_and(|x| x == "csv") && p.is_file() {
                let shown = p
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .into_owned();
                let r = rig.map(Path::to_path_buf).or_else(|| rig_beside(&p));
                found.push(item(p, r, shown));
            }
        }
        found
    } else {
        let text = crate::output::read_text_bounded(source, crate::output::MAX_CONFIG_BYTES)
            .map_err(|e| err(format!("cannot read: {e}")))?;
        // A UTF-8 byte-order mark, as some editors write, is not part of the first name.
        let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
        let base = source.parent().unwrap_or(Path::new(""));
        let mut found = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let words = list_words(line).map_err(|m| err(format!("line {}: {m}", i + 1)))?;
            if words.is_empty() {
                continue;
            }
            let words: Vec<&str> = words.iter().map(String::as_str).collect();
            if words.len() > 2 {
                return Err(err(format!(
                    "line {}: expected `recording.csv [rig.toml]`, found {} words",
                    i + 1,
                    words.len()
                )));
            }
            let p = base.join(words[0]);
            if !p.is_file() {
                return Err(err(format!(
                    "line {}: {} is not a file",
                    i + 1,
                    p.display()
                )));
            }
            let r = match words.get(1) {
                Some(w) => Some(base.join(w)),
                None => rig.map(Path::to_path_buf).or_else(|| rig_beside(&p)),
            };
            found.push(item(p, r, words[0].to_string()));
        }
        found
    };
    if items.is_empty() {
        return Err(err("no recordings (*.csv) found".into()));
    }
    items.sort_by(|a, b| a.name.cmp(&b.name));
    if let Some(w) = items.windows(2).find(|w| w[0].name == w[1].name) {
        return Err(err(format!(
            "two recordings named {} ({} and {}); results are kept by name",
            w[0].name, w[0].shown, w[1].shown
        )));
    }
    Ok(items)
}

#[cfg(test)]
mod tests {
    use super::list_words;

    #[test]
    fn list_lines_hold_quoted_names_with_spaces_and_hashes_and_comments() {
        assert_eq!(
            list_words("  a.csv  b.rig.toml # two"),
            Ok(vec!["a.csv".into(), "b.rig.toml".into()])
        );
        assert_eq!(
            list_words(r#""run #3 left.csv" "my rig.toml""#),
            Ok(vec!["run #3 left.csv".into(), "my rig.toml".into()])
        );
        assert_eq!(list_words("# only a comment"), Ok(vec![]));
        assert_eq!(list_words("a#b.csv"), Ok(vec!["a#b.csv".into()]));
        assert!(list_words(r#""open.csv"#).is_err());
    }
}

//! The layout `docs/architecture.md` describes holds in the source: no module uses one on
//! a floor above its own (the floors are read from the document's table, so the two
//! cannot drift apart), the top-level modules use each other in no circle, `main.rs` only
//! dispatches, and library functions return typed errors.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Each top-level module's floor, from the table in `docs/architecture.md`
/// (`| 2. the machine | `scene`, `world`, `sim` | ... |`).
fn floors() -> BTreeMap<String, u32> {
    let doc = std::fs::read_to_string("docs/architecture.md").unwrap();
    let mut floors = BTreeMap::new();
    for line in doc.lines() {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 4 {
            continue;
        }
        let Some((n, _)) = cells[1].split_once(". ") else {
            continue;
        };
        let Ok(floor) = n.parse::<u32>() else {
            continue;
        };
        for module in cells[2].split(',') {
            floors.insert(module.trim().trim_matches('`').to_string(), floor);
        }
    }
    floors
}

/// Every library source file (not the binary's) with its top-level module and its text
/// before any `#[cfg(test)]` (tests may reach anywhere), comment lines left out.
fn library_sources() -> Vec<(PathBuf, String, String)> {
    let binary = [
        "main.rs",
        "cli_args.rs",
        "cli_progress.rs",
        "cli_sweep.rs",
        "lib.rs",
    ];
    let mut out = Vec::new();
    let mut stack = vec![PathBuf::from("src")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
                continue;
            }
            let rel = path.strip_prefix("src").unwrap();
            if path.extension().is_none_or(|e| e != "rs")
                || binary.iter().any(|b| Path::new(b) == rel)
            {
                continue;
            }
            let top = rel
                .components()
                .next()
                .unwrap()
                .as_os_str()
                .to_string_lossy()
                .trim_end_matches(".rs")
                .to_string();
            let text = std::fs::read_to_string(&path).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap();
            let code: String = code
                .lines()
                .filter(|l| !l.trim_start().starts_with("//"))
                .collect::<Vec<_>>()
                .join("\n");
            out.push((path, top, code));
        }
    }
    out.sort();
    out
}

/// The top-level modules a text names as `crate::MODULE`.
fn uses(code: &str) -> BTreeSet<String> {
    code.match_indices("crate::")
        .map(|(i, _)| {
            code[i + 7..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect()
        })
        .collect()
}

#[test]
fn every_library_module_has_a_floor_and_uses_none_above_it() {
    let floors = floors();
    assert!(
        floors.len() > 20 && floors.get("sim") == Some(&2),
        "the table was not read: {floors:?}"
    );
    let mut upward = Vec::new();
    for (path, top, code) in library_sources() {
        let Some(&mine) = floors.get(&top) else {
            panic!(
                "{}: module `{top}` is on no floor of docs/architecture.md",
                path.display()
            );
        };
        for used in uses(&code) {
            if let Some(&theirs) = floors.get(&used) {
                if theirs > mine {
                    upward.push(format!(
                        "{} (`{top}`, floor {mine}) uses `{used}` (floor {theirs})",
                        path.display()
                    ));
                }
            }
        }
    }
    assert!(upward.is_empty(), "arrows up:\n{}", upward.join("\n"));
}

#[test]
fn the_top_level_modules_use_each_other_in_no_circle() {
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    let floors = floors();
    for (_, top, code) in library_sources() {
        let used: Vec<String> = uses(&code)
            .into_iter()
            .filter(|u| *u != top && floors.contains_key(u))
            .collect();
        edges.entry(top).or_default().extend(used);
    }
    // A module reaches itself through the others: a circle.
    for start in edges.keys() {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<&String> = edges[start].iter().collect();
        while let Some(m) = todo.pop() {
            assert!(m != start, "`{start}` reaches itself: {edges:?}");
            if seen.insert(m.clone()) {
                todo.extend(edges.get(m).into_iter().flatten());
            }
        }
    }
}

#[test]
fn main_only_parses_and_dispatches() {
    let main = std::fs::read_to_string("src/main.rs").unwrap();
    let lines = main.lines().count();
    assert!(lines <= 120, "src/main.rs has {lines} lines");
}

/// Whether `line` names a `Result` whose error type is `String`.
fn result_of_string(line: &str) -> bool {
    let mut rest = line;
    while let Some(i) = rest.find("Result<") {
        rest = &rest[i + 7..];
        let (mut depth, mut last_arg_start) = (1, 0);
        for (k, c) in rest.char_indices() {
            match c {
                '<' | '(' | '[' => depth += 1,
                ')' | ']' => depth -= 1,
                ',' if depth == 1 => last_arg_start = k + 1,
                '>' => {
                    depth -= 1;
                    if depth == 0 {
                        if rest[last_arg_start..k].trim() == "String" && last_arg_start > 0 {
                            return true;
                        }
                        break;
                    }
                }
                _ => {}
            }
        }
    }
    false
}

/// Library functions say what went wrong in a type; a message in a `String` is for clap's
/// value parsers (`commands/flags.rs`, `FromStr` of a name typed on the command line), for
/// a sweep run's failure (kept as the text `results.csv` holds and `sweep merge` reads
/// back) and for the importers' parsers still to be typed, named here so that the list
/// only shrinks.
#[test]
fn library_errors_are_typed() {
    assert!(result_of_string("fn f() -> Result<(), String> {"));
    assert!(result_of_string(
        "pub outcome: Result<Vec<(u8, f64)>, String>,"
    ));
    assert!(!result_of_string(
        "-> Result<BTreeMap<i64, String>, SqliteRead> {"
    ));
    assert!(!result_of_string("-> Result<String, Error> {"));
    let text_allowed = ["src/commands/flags.rs"];
    let mut found = Vec::new();
    for (path, _, code) in library_sources() {
        let p = path.to_string_lossy().replace('\\', "/");
        if text_allowed.contains(&p.as_str()) {
            continue;
        }
        for (n, line) in code.lines().enumerate() {
            if result_of_string(line) && !line.contains("fn from_str(") {
                found.push(format!("{p}:{}: {}", n + 1, line.trim()));
            }
        }
    }
    assert!(found.is_empty(), "untyped errors:\n{}", found.join("\n"));
}

/// A line with its string and character literals emptied and its comment cut, so that
/// only the code's own braces are left to count.
fn braces_of(line: &str) -> String {
    let mut out = String::new();
    let mut chars = line.chars().peekable();
    let mut in_string = false;
    while let Some(c) = chars.next() {
        match (in_string, c) {
            (true, '\\') => {
                chars.next();
            }
            (true, '"') => in_string = false,
            (true, _) => {}
            (false, '"') => in_string = true,
            (false, '/') if chars.peek() == Some(&'/') => break,
            // A character literal ('{'), not a lifetime ('a).
            (false, '\'') => {
                let rest: String = chars.clone().take(3).collect();
                if rest.starts_with('\\') {
                    for x in chars.by_ref() {
                        if x == '\'' {
                            break;
                        }
                    }
                } else if rest.chars().nth(1) == Some('\'') {
                    chars.next();
                    chars.next();
                }
            }
            (false, '{' | '}') => out.push(c),
            _ => {}
        }
    }
    out
}

/// Each function of a text over `limit` lines (its signature to its closing brace,
/// comment lines left out): `(name, first line, lines)`.
fn long_functions(code: &str, limit: usize) -> Vec<(String, usize, usize)> {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let words: Vec<&str> = line.split_whitespace().collect();
        let Some(at) = words.iter().position(|w| *w == "fn") else {
            continue;
        };
        let before_ok = words[..at]
            .iter()
            .all(|w| w.starts_with("pub") || ["const", "async", "unsafe", "extern"].contains(w));
        if !before_ok || at + 1 >= words.len() {
            continue;
        }
        let name: String = words[at + 1]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let (mut depth, mut opened) = (0i64, false);
        for (j, l) in lines.iter().enumerate().skip(i) {
            let b = braces_of(l);
            if !opened && b.is_empty() && l.trim_end().ends_with(';') {
                break; // a declaration without a body
            }
            for c in b.chars() {
                depth += if c == '{' { 1 } else { -1 };
                opened = true;
            }
            if opened && depth == 0 {
                if j - i + 1 > limit {
                    out.push((name.clone(), i + 1, j - i + 1));
                }
                break;
            }
        }
    }
    out
}

#[test]
fn no_library_function_is_over_100_lines() {
    // The counter finds a long function (a known-good check of itself).
    let long = format!(
        "pub(crate) fn f(x: u8) -> u8 {{\n{}    x\n}}\nfn g() {{ let s = \"}}\"; }}\n",
        "    let _ = '{';\n".repeat(120)
    );
    assert_eq!(long_functions(&long, 100), [("f".to_string(), 1, 123)]);
    let mut found = Vec::new();
    for (path, _, code) in library_sources() {
        for (name, line, n) in long_functions(&code, 100) {
            found.push(format!(
                "{}: `{name}` (line {line} without comments): {n} lines",
                path.display()
            ));
        }
    }
    assert!(
        found.is_empty(),
        "functions a reader cannot take in at once; split each into its named steps:\n{}",
        found.join("\n")
    );
}

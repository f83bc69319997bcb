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

/// Every library source file (not the binary's) with its top-level module and its whole
/// text without the items under `#[cfg(test)]` (tests may reach anywhere), comment lines
/// left out.
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
            let code: String = without_test_items(&text)
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

/// A source text without each item marked `#[cfg(test)]`: the attribute and the item
/// after it (to its `;`, or to the brace that closes its body); the code after such an
/// item stays.
fn without_test_items(text: &str) -> String {
    let mut out = Vec::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        if line.trim() != "#[cfg(test)]" {
            out.push(line);
            continue;
        }
        let mut depth = 0i64;
        let mut opened = false;
        for item in lines.by_ref() {
            for b in braces_of(item).chars() {
                depth += if b == '{' { 1 } else { -1 };
                opened = true;
            }
            let code = item.split("//").next().unwrap_or("").trim_end();
            if (opened && depth == 0) || (!opened && code.ends_with(';')) {
                break;
            }
        }
    }
    out.join("\n")
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

/// The module path of a library file: `src/import/ros2/cdr.rs` is `import::ros2::cdr`,
/// `src/import/ros2/mod.rs` is `import::ros2`.
fn module_path(path: &Path) -> Vec<String> {
    let rel = path.strip_prefix("src").unwrap().with_extension("");
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    if parts.last().is_some_and(|p| p == "mod") {
        parts.pop();
    }
    parts
}

/// The first name of each path a `use` or expression names after `prefix` in `code`
/// (`super::{a, b::c}` names `a` and `b`; `super::d::e` names `d`), with the module
/// path the prefix stands for: `(base, first name)`.
fn named_after(code: &str, prefix: &str) -> Vec<String> {
    let mut out = Vec::new();
    for (i, _) in code.match_indices(prefix) {
        let before = code[..i].chars().next_back();
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let rest = &code[i + prefix.len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // The top-level items of the group.
            let mut depth = 0;
            let mut item = String::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => {
                        out.push(std::mem::take(&mut item));
                        continue;
                    }
                    _ => {}
                }
                item.push(c);
            }
            out.push(item);
        } else {
            out.push(rest.to_string());
        }
    }
    out.into_iter()
        .map(|s| {
            s.trim()
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect::<String>()
        })
        .filter(|s| !s.is_empty())
        .collect()
}

/// Each library file's uses of its sibling modules (the files and folders beside it in
/// its folder), named as `super::NAME` or by the whole path `crate::...::NAME`; and, at
/// each folder above its own, the uses by whole path of that folder's other modules,
/// counted as uses by the subfolder it is in (`import/ros2/open.rs` naming
/// `crate::import::ros1::read` is a use of `ros1` by `ros2` in `import`). A folder's
/// `mod.rs` counts only at the folders above: it is the face of its own parts.
fn sibling_uses() -> BTreeMap<Vec<String>, BTreeMap<String, BTreeSet<String>>> {
    let files: Vec<(PathBuf, String)> = library_sources()
        .into_iter()
        .map(|(p, _, code)| (p, code))
        .collect();
    let modules: BTreeSet<Vec<String>> = files.iter().map(|(p, _)| module_path(p)).collect();
    // folder -> module in it -> the siblings it uses
    let mut edges: BTreeMap<Vec<String>, BTreeMap<String, BTreeSet<String>>> = BTreeMap::new();
    for (path, code) in &files {
        let face = path.file_name().is_some_and(|n| n == "mod.rs");
        let me = module_path(path);
        // The folders that hold this file: its own (unless it is a face), then each above
        // but the crate's root (the top-level modules have a test of their own).
        let own = me.len() - 1;
        for depth in (1..=own).rev() {
            let (folder, name) = (&me[..depth], &me[depth]);
            let mut used = BTreeSet::new();
            if depth == own && !face {
                used.extend(named_after(code, "super::"));
            }
            used.extend(named_after(
                code,
                &format!("crate::{}::", folder.join("::")),
            ));
            used.retain(|u| {
                u != name && {
                    let mut m = folder.to_vec();
                    m.push(u.clone());
                    modules.contains(&m)
                }
            });
            edges
                .entry(folder.to_vec())
                .or_default()
                .entry(name.clone())
                .or_default()
                .extend(used);
        }
    }
    edges
}

#[test]
fn the_files_of_a_folder_use_each_other_in_no_circle() {
    let edges = sibling_uses();
    // The reader of uses finds a sibling through a brace group (a known-good check).
    assert_eq!(
        named_after("use super::{a, b::{c, d}};", "super::"),
        ["a", "b"]
    );
    assert!(
        edges[&vec!["commands".to_string()]]["calibrate"].contains("flags"),
        "the sibling uses were not read: {edges:?}"
    );
    assert!(
        edges[&vec!["import".to_string()]]["ros2"].contains("ros1"),
        "a subfolder's files' uses were not counted as the subfolder's: {:?}",
        edges[&vec!["import".to_string()]]
    );
    let mut circles = Vec::new();
    for (folder, modules) in &edges {
        for start in modules.keys() {
            let mut seen = BTreeSet::new();
            let mut todo: Vec<(&String, Vec<&String>)> =
                modules[start].iter().map(|m| (m, vec![m])).collect();
            while let Some((m, way)) = todo.pop() {
                if m == start {
                    let names: Vec<&str> = way.iter().map(|s| s.as_str()).collect();
                    circles.push(format!(
                        "{}: {start} -> {}",
                        folder.join("/"),
                        names.join(" -> ")
                    ));
                    break;
                }
                if seen.insert(m.clone()) {
                    for next in modules.get(m).into_iter().flatten() {
                        let mut w = way.clone();
                        w.push(next);
                        todo.push((next, w));
                    }
                }
            }
        }
    }
    assert!(
        circles.is_empty(),
        "files that use each other in a circle (move what both need into a file of its own):\n{}",
        circles.join("\n")
    );
}

//! The documented commands run, and print what the documents say they print.
//!
//! Every ```` ```console ```` block of `README.md` and `docs/*.md` is a session: lines
//! `$ agvsim ARGS` are commands, the lines after one are its expected standard output.
//! An expected line matches an output line exactly, except that `[..]` inside it matches
//! any text and a line `...` matches any number of lines (so an example can show the lines
//! that matter). Each document runs in its own scratch folder holding the repository's
//! `scenes/` and `data/`, so its commands use the paths a user types from a checkout, and
//! its later commands see what its earlier ones wrote (`runs/...`).

use std::path::{Path, PathBuf};
use std::process::Command;

/// One documented command and the output it is said to print.
struct Step {
    file: String,
    line: usize,
    args: Vec<String>,
    expected: Vec<String>,
}

/// Splits a command line as a shell would for the documents' plain arguments (no quotes
/// with spaces are used in them).
fn words(s: &str) -> Vec<String> {
    s.split_whitespace().map(str::to_string).collect()
}

/// The sessions of one document, in order.
fn steps(path: &Path) -> Vec<Step> {
    let text = std::fs::read_to_string(path).unwrap();
    let file = path.display().to_string();
    let mut out: Vec<Step> = Vec::new();
    let mut in_console = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            in_console = !in_console && line.trim() == "```console";
            continue;
        }
        if !in_console {
            continue;
        }
        if let Some(cmd) = line.strip_prefix("$ agvsim ") {
            out.push(Step {
                file: file.clone(),
                line: i + 1,
                args: words(cmd),
                expected: vec![],
            });
        } else if let Some(step) = out.last_mut() {
            step.expected.push(line.to_string());
        } else {
            panic!(
                "{file}:{}: a console block must start with `$ agvsim ...`",
                i + 1
            );
        }
    }
    out
}

/// Whether one output line matches one expected line (`[..]`: any text). Trailing spaces
/// are not compared: editors strip them from documents.
fn line_matches(expected: &str, actual: &str) -> bool {
    let (expected, actual) = (expected.trim_end(), actual.trim_end());
    let parts: Vec<&str> = expected.split("[..]").collect();
    if parts.len() == 1 {
        return expected == actual;
    }
    let mut rest = actual;
    for (k, p) in parts.iter().enumerate() {
        if k == 0 {
            let Some(r) = rest.strip_prefix(p) else {
                return false;
            };
            rest = r;
        } else if k == parts.len() - 1 {
            return rest.ends_with(p);
        } else {
            let Some(at) = rest.find(p) else {
                return false;
            };
            rest = &rest[at + p.len()..];
        }
    }
    true
}

/// Whether the output lines match the expected ones (`...`: any number of lines).
fn matches(expected: &[String], actual: &[&str]) -> bool {
    match expected.split_first() {
        None => actual.is_empty(),
        Some((e, rest)) if e == "..." => (0..=actual.len()).any(|k| matches(rest, &actual[k..])),
        Some((e, rest)) => {
            !actual.is_empty() && line_matches(e, actual[0]) && matches(rest, &actual[1..])
        }
    }
}

/// A scratch folder with the repository's `scenes/` and `data/` in it.
fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("docs-{name}"));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    for dir in ["scenes", "data"] {
        copy_dir(&repo.join(dir), &d.join(dir));
    }
    d
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let target = to.join(e.file_name());
        if e.file_type().unwrap().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// Runs every session of one document; returns the mismatches, described.
fn check(doc: &Path) -> Vec<String> {
    let steps = steps(doc);
    if steps.is_empty() {
        return vec![];
    }
    let name = doc.file_stem().unwrap().to_string_lossy().to_string();
    let dir = scratch(&name);
    let mut failures = vec![];
    for s in &steps {
        let out = Command::new(env!("CARGO_BIN_EXE_agvsim"))
            .args(&s.args)
            .current_dir(&dir)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        let lines: Vec<&str> = stdout.lines().collect();
        if !out.status.success() {
            failures.push(format!(
                "{}:{}: `agvsim {}` failed:\n{}",
                s.file,
                s.line,
                s.args.join(" "),
                String::from_utf8_lossy(&out.stderr)
            ));
        } else if !matches(&s.expected, &lines) {
            failures.push(format!(
                "{}:{}: `agvsim {}` printed\n{stdout}\nwhere the document says\n{}",
                s.file,
                s.line,
                s.args.join(" "),
                s.expected.join("\n")
            ));
        }
    }
    failures
}

fn documents() -> Vec<PathBuf> {
    let mut docs = vec![PathBuf::from("README.md")];
    let mut more: Vec<PathBuf> = std::fs::read_dir("docs")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md"))
        .collect();
    more.sort();
    docs.extend(more);
    docs
}

#[test]
fn the_matcher_takes_wildcards_and_refuses_a_difference() {
    let exp = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
    assert!(matches(&exp(&["a", "...", "d"]), &["a", "b", "c", "d"]));
    assert!(matches(&exp(&["a [..] c"]), &["a b c"]));
    assert!(!matches(&exp(&["a", "d"]), &["a", "b", "d"]));
    assert!(!matches(&exp(&["fit 98.33 %"]), &["fit 98.34 %"]));
    assert!(!matches(&exp(&["a"]), &["a", "b"]));
}

/// Every document's console sessions print what the document shows.
#[test]
fn documented_commands_print_what_the_documents_show() {
    let docs = documents();
    let n: usize = docs.iter().map(|d| steps(d).len()).sum();
    assert!(n >= 6, "only {n} documented commands found");
    let failures: Vec<String> = std::thread::scope(|s| {
        let handles: Vec<_> = docs.iter().map(|d| s.spawn(move || check(d))).collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap())
            .collect()
    });
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// User documents name only what a checkout has: no development folders beside it.
#[test]
fn documents_send_users_only_to_files_the_repository_ships() {
    for d in documents() {
        let text = std::fs::read_to_string(&d).unwrap();
        for (i, line) in text.lines().enumerate() {
            assert!(
                !line.contains("../shared") && !line.contains("shared/spec"),
                "{}:{}: {line}",
                d.display(),
                i + 1
            );
        }
    }
}

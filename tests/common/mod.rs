//! Helpers the test binaries share (`mod common;` in each).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Output;

/// A fresh, empty scratch folder for one test: inside cargo's folder for test files,
/// named after the test binary and `name`, so binaries running at once never share one.
pub fn tmp(name: &str) -> PathBuf {
    let d =
        Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{}-{name}", env!("CARGO_CRATE_NAME")));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A command's standard output then its standard error, as text.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

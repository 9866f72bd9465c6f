//! Tests that need what a clean machine may lack: the corpus of real programs beside the
//! project (`../shared/corpus`), headless Chromium, Python 3.11.
//!
//! A test that cannot run says so where a user sees it: a line on the test process's own
//! standard error, which the test harness does not capture (it captures `eprintln!`, not
//! writes to the stream), so `cargo test` shows it above the test's `ok`:
//!
//! ```text
//! skipped: corpus_round_trip: ../shared/corpus is not there (clone the corpus beside the project to run it)
//! ```
//!
//! A test that runs without it, with less to read, says `skipped in part:`.
//! `.ci/run` counts these lines in its summary. In CI (`CI` set and not `false` or `0`, as
//! `.ci/run` sets it) nothing may be skipped: the test fails instead, naming what is missing.
//!
//! Included by path (`#[path = "common/skip.rs"] mod skip;`) in test files that do not use
//! `common`, and as `common::skip` in those that do.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};

/// Whether this run is CI, where a missing corpus, browser or interpreter is a failure.
pub fn ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "false" && v != "0")
}

/// Report that the running test cannot run: `what` is missing, `how` says how to get it.
/// Panics in CI.
pub fn skip(what: &str, how: &str) {
    report("skipped", what, how);
}

/// Report that part of the running test cannot run (it runs the rest). Panics in CI.
pub fn skip_part(what: &str, how: &str) {
    report("skipped in part", what, how);
}

fn report(label: &str, what: &str, how: &str) {
    let thread = std::thread::current();
    let test = thread.name().unwrap_or("a test");
    assert!(
        !ci(),
        "{what}, and CI runs every test: {how} (CI is set; unset it to skip this test)"
    );
    // Straight to the stream: `eprintln!` would be captured with the test's output.
    let _ = writeln!(std::io::stderr(), "{label}: {test}: {what} ({how})");
}

/// `../shared/corpus`, the real programs the corpus tests read, or `None` (reported as a
/// skip) when it is not there.
pub fn corpus() -> Option<PathBuf> {
    corpus_path("")
}

/// A file or directory under `../shared/corpus`, or `None` (reported as a skip).
pub fn corpus_path(under: &str) -> Option<PathBuf> {
    corpus_for(under, skip)
}

/// `corpus_path` for a test that runs without the corpus too (with less to read): a
/// missing corpus is reported as a partial skip.
pub fn corpus_part(under: &str) -> Option<PathBuf> {
    corpus_for(under, skip_part)
}

fn corpus_for(under: &str, report: fn(&str, &str)) -> Option<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/corpus");
    let path = if under.is_empty() {
        root.clone()
    } else {
        root.join(under)
    };
    if path.exists() {
        return Some(path);
    }
    if root.is_dir() {
        // The corpus is there without this file: that is a broken corpus, not a skip.
        panic!("{} is not in the corpus", path.display());
    }
    report(
        "../shared/corpus is not there",
        "clone the corpus of real programs beside the project to run it",
    );
    None
}

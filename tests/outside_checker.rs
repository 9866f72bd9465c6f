//! The independent outside checker (`tools/checker.py`) against the nccomp binary.
//!
//! The checker implements the machine and error model of the contract
//! (`model.md`) on its own, in pure Python, from the contract's text only. Here it
//! generates random AC trunnion machines, error files and five-axis programs, runs this
//! crate's `nccomp compensate` on them and evaluates every programmed pose of the result
//! with its own model: a misreading of the contract on either side shows up as a
//! residual. Reported as skipped (common/skip.rs) where no Python 3.11+ is available.

use std::path::Path;
use std::process::Command;

#[path = "common/skip.rs"]
mod skip;

/// Seeds and program length: the random programs turn their rotary axes by up to hundreds
/// of degrees per block, so the default path tolerance inserts thousands of blocks; four
/// programs of 200 blocks keep the test under a minute with a debug build. The held-out
/// run (more seeds, release build) is in docs/nc-support.md.
const SEEDS: &str = "1-4";
const BLOCKS: &str = "200";

fn python() -> Option<&'static str> {
    // tomllib is the only part of the standard library the checker needs from 3.11 on.
    let probe = Command::new("python3")
        .args(["-c", "import tomllib"])
        .output()
        .ok()?;
    probe.status.success().then_some("python3")
}

fn roundtrip(extra: &[&str]) {
    let Some(python) = python() else {
        skip::skip(
            "python3 (3.11 or newer, with tomllib) is not there",
            "install Python 3.11 or newer to run the outside checker",
        );
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let output = Command::new(python)
        .arg(root.join("tools").join("checker.py"))
        .arg("roundtrip")
        .args(extra)
        .arg("--nccomp")
        .arg(env!("CARGO_BIN_EXE_nccomp"))
        .current_dir(root)
        .output()
        .expect("run tools/checker.py");
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    println!("{stdout}");
    if !stderr.is_empty() {
        eprintln!("{stderr}");
    }
    assert!(
        output.status.success(),
        "the outside checker rejects nccomp's output ({}):\n{stdout}\n{stderr}",
        output.status
    );
    assert!(stdout.contains("verdict: PASS"), "{stdout}");
}

/// Default settings: block ends within 1 µm / 10 µrad, and every compensated segment
/// (inserted pieces included) within 1.5 µm of the nominal path at its quarter points.
#[test]
fn outside_checker_roundtrip_passes_on_the_path() {
    roundtrip(&["--seeds", SEEDS, "--blocks", BLOCKS, "--path-tol", "1.5"]);
}

/// `--tolerance off`: one block out for every block in, block ends still exact (the path
/// is only reported).
#[test]
fn outside_checker_roundtrip_passes_one_to_one() {
    roundtrip(&[
        "--seeds",
        "5-7",
        "--blocks",
        "150",
        "--path-tol",
        "0",
        "--one-to-one",
        "--nccomp-arg=--tolerance=off",
    ]);
}

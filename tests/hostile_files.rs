//! Hostile machine and error files on the command line (issue 22, items 1, 5 and 6): a
//! number out of its documented range, a file too large, a machine whose axes cannot set
//! the tool's pose. Each is refused with exit code 2 and a message at `file:line:column`
//! that says what was expected, before any output is written; none panics.

mod common;
use common::cli::{nccomp, scratch, stderr};

use std::path::{Path, PathBuf};

const M: &str = "fixtures/ac_trunnion.machine.toml";
const E: &str = "fixtures/ac_trunnion.errors.toml";
const PROGRAM: &str = "fixtures/ac_trunnion_g91.nc";

fn fixture(name: &str) -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join(name)).unwrap()
}

/// A copy of a fixture with `from` replaced by `to` (which must be there), in `dir`.
fn edited(dir: &Path, fixture_name: &str, from: &str, to: &str) -> PathBuf {
    let text = fixture(fixture_name);
    assert!(text.contains(from), "{from:?} is not in {fixture_name}");
    let name = Path::new(fixture_name).file_name().unwrap();
    let path = dir.join(name);
    std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
    path
}

/// `compensate` with `machine` and `errors` into `dir/out.nc`: the exit code and the
/// message, and the output must not exist.
fn refused(dir: &Path, machine: &str, errors: &str) -> String {
    let out_path = dir.join("out.nc");
    let out = nccomp(&[
        "compensate",
        "-m",
        machine,
        "-e",
        errors,
        PROGRAM,
        "-o",
        out_path.to_str().unwrap(),
    ]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!out_path.exists(), "an output was written: {err}");
    err
}

/// The ` --> file:line:column` line of a rendered error.
fn place(err: &str) -> &str {
    err.lines()
        .find_map(|l| l.trim_start().strip_prefix("--> "))
        .unwrap_or_else(|| panic!("no place in: {err}"))
}

/// The 1-based line and column of the first `needle` in `text`.
fn position(text: &str, needle: &str) -> (usize, usize) {
    let at = text.find(needle).unwrap();
    let line = text[..at].matches('\n').count() + 1;
    let column = at - text[..at].rfind('\n').map_or(0, |i| i + 1) + 1;
    (line, column)
}

#[test]
fn error_values_beyond_their_range_are_refused_at_the_value() {
    let dir = scratch("error-ranges");
    // The file is in mm and degrees: an angle error within ±0.1 rad is ±5.72958°.
    let huge = edited(&dir, E, "EC0Y = 0.0455", "EC0Y = 1e300");
    let err = refused(&dir, M, huge.to_str().unwrap());
    let (line, col) = position(&fixture(E), "0.0455");
    assert_eq!(place(&err), format!("{}:{line}:{col}", huge.display()));
    assert!(
        err.contains("`EC0Y` is 1e300: expected a number within ±5.72958 deg"),
        "{err}"
    );
    // A table value, in a series: the element is pointed at.
    let table = edited(&dir, E, "EBX = [0.0062, 0.0093]", "EBX = [0.0062, 1e200]");
    let err = refused(&dir, M, table.to_str().unwrap());
    let (line, _) = position(&fixture(E), "EBX = [");
    let col = "EBX = [0.0062, ".len() + 1;
    assert_eq!(place(&err), format!("{}:{line}:{col}", table.display()));
    assert!(
        err.contains(
            "an element of the series `EBX` is 1e200: expected a number within ±5.72958 deg"
        ),
        "{err}"
    );
    // A length error beyond 10 mm, in µm.
    let um = dir.join("um.errors.toml");
    std::fs::write(&um, "length_unit = \"um\"\n[location.C]\nEX0C = 20000\n").unwrap();
    let err = refused(&dir, M, um.to_str().unwrap());
    assert_eq!(place(&err), format!("{}:3:8", um.display()));
    assert!(
        err.contains("`EX0C` is 20000: expected a number within ±10000 um"),
        "{err}"
    );
    // Table positions are positions of the axis: ±100000 mm.
    let positions = edited(
        &dir,
        E,
        "positions = [-50.0, 50.0]",
        "positions = [-50.0, 1e300]",
    );
    let err = refused(&dir, M, positions.to_str().unwrap());
    assert!(
        err.contains("an element of `positions` is 1e300: expected a number within ±100000 mm"),
        "{err}"
    );
}

#[test]
fn machine_numbers_beyond_their_range_are_refused_at_the_number() {
    let dir = scratch("machine-ranges");
    let text = fixture(M);
    // A direction that overflows its length is no "zero vector": the component is named.
    let direction = edited(
        &dir,
        M,
        "direction = [-1, 0, 0]",
        "direction = [1e308, 1e308, 0]",
    );
    let err = refused(&dir, direction.to_str().unwrap(), E);
    let (line, col) = position(&text, "direction = [-1, 0, 0]");
    let col = col + "direction = [".len();
    assert_eq!(place(&err), format!("{}:{line}:{col}", direction.display()));
    assert!(
        err.contains("an element of `direction` is 1e308: expected a number within ±1000000"),
        "{err}"
    );
    assert!(!err.contains("zero vector"), "{err}");
    // The resolution: from 1e-6 to 0.1 (1e300 would round every correction away).
    let coarse = edited(&dir, M, "linear = 0.0001", "linear = 1e300");
    let err = refused(&dir, coarse.to_str().unwrap(), E);
    let (line, col) = position(&text, "0.0001");
    assert_eq!(place(&err), format!("{}:{line}:{col}", coarse.display()));
    assert!(
        err.contains("resolution `linear` is 1e300: expected a number from 0.000001 to 0.1 mm"),
        "{err}"
    );
    let fine = edited(&dir, M, "rotary = 0.0001", "rotary = 0");
    let err = refused(&dir, fine.to_str().unwrap(), E);
    assert!(
        err.contains("resolution `rotary` is 0: expected a number from 0.000001 to 0.1 degrees"),
        "{err}"
    );
    // Points, travels and tool lengths: ±100000 mm (or degrees).
    for (from, to, says) in [
        (
            "point = [0, 0, -100]",
            "point = [0, 0, -1e200]",
            "an element of `point` is -1e200: expected a number within ±100000 mm",
        ),
        (
            "travel = [-120, 30]",
            "travel = [-1e9, 30]",
            "an element of `travel` is -1e9: expected a number within ±100000 degrees",
        ),
        (
            "length = 95.3",
            "length = 9e99",
            "tool `length` is 9e99: expected a number within ±100000 mm",
        ),
    ] {
        let file = edited(&dir, M, from, to);
        let err = refused(&dir, file.to_str().unwrap(), E);
        assert!(err.contains(says), "{to}: {err}");
        let (line, _) = position(&text, from);
        assert!(
            place(&err).starts_with(&format!("{}:{line}:", file.display())),
            "{err}"
        );
    }
}

#[test]
fn rotary_axes_that_cannot_set_the_tool_direction_are_refused_when_loaded() {
    let dir = scratch("parallel");
    let text = fixture(M);
    // C on the A axis's direction, exactly and 1e-9 rad off: the direction has one degree
    // of freedom, not two.
    for c in ["[-1, 0, 0]", "[-1, 1e-9, 0]", "[1, 0.01, 0]"] {
        let machine = edited(
            &dir,
            M,
            "direction = [0, 0, -1]",
            &format!("direction = {c}"),
        );
        let err = refused(&dir, machine.to_str().unwrap(), E);
        let (line, col) = position(&text, "\"C\"]");
        assert_eq!(
            place(&err),
            format!("{}:{line}:{col}", machine.display()),
            "{c}"
        );
        assert!(
            err.contains("rotary axes A and C are ")
                && err.contains("° from parallel: the tool direction needs two rotary axes that are not parallel; expected their directions at least 1° apart"),
            "{c}: {err}"
        );
        assert!(!err.contains("correction of axis"), "{err}");
    }
    // 2° apart is a machine (an odd one): it loads.
    let tilted = edited(
        &dir,
        M,
        "direction = [0, 0, -1]",
        "direction = [-1, 0.0349, 0]",
    );
    let zero = dir.join("zero.errors.toml");
    std::fs::write(&zero, "length_unit = \"mm\"\n").unwrap();
    let empty = dir.join("empty.nc");
    std::fs::write(&empty, "").unwrap();
    let out = nccomp(&[
        "compensate",
        "-q",
        "-m",
        tilted.to_str().unwrap(),
        "-e",
        zero.to_str().unwrap(),
        "-o",
        dir.join("ok.nc").to_str().unwrap(),
        empty.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn linear_axes_that_cannot_move_the_tip_in_three_directions_are_refused() {
    let dir = scratch("coplanar");
    let text = fixture(M);
    // Z in the plane of X and Y.
    let flat = edited(&dir, M, "direction = [0, 0, 1]", "direction = [1, 1, 1e-9]");
    let err = refused(&dir, flat.to_str().unwrap(), E);
    let (line, col) = position(&text, "\"Z\"]");
    assert_eq!(place(&err), format!("{}:{line}:{col}", flat.display()));
    assert!(
        err.contains("linear axes Y, X and Z lie in one plane (within 1°)"),
        "{err}"
    );
}

#[test]
fn a_file_over_the_size_limit_is_refused_before_it_is_read() {
    let dir = scratch("large");
    // One byte over 512 KiB, of a file that would load: refused by its size alone.
    let big = dir.join("big.errors.toml");
    let mut text = String::from("length_unit = \"um\"\n# ");
    text.push_str(&"x".repeat((1 << 19) + 1 - text.len() - 1));
    text.push('\n');
    assert_eq!(text.len(), (1 << 19) + 1);
    std::fs::write(&big, &text).unwrap();
    let err = refused(&dir, M, big.to_str().unwrap());
    assert_eq!(place(&err), format!("{}:1:1", big.display()));
    assert!(
        err.contains("the error file is 524289 bytes: expected at most 524288 bytes (512 KiB)"),
        "{err}"
    );
    // At the limit it is read.
    std::fs::write(&big, text.replacen("# x", "# ", 1)).unwrap();
    let out = nccomp(&[
        "compensate",
        "-q",
        "-m",
        M,
        "-e",
        big.to_str().unwrap(),
        "-o",
        dir.join("ok.nc").to_str().unwrap(),
        PROGRAM,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // A device that never ends is refused once the limit is passed, not read forever.
    let err = refused(&dir, "/dev/zero", E);
    assert!(
        err.contains("the machine file is more than 524288 bytes: expected at most 524288 bytes"),
        "{err}"
    );
}

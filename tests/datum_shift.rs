//! Datum shifts without a work offset table (`[work_offsets]`): ISO's G52, Heidenhain's
//! `CYCL DEF 7` outside a tilted plane and Sinumerik's `TRANS`/`ATRANS` follow one rule.
//! Without the table program zero is not followed, so each is refused with its place and
//! reason, never dropped (corrections for the unshifted pose) nor passed past the travel.

use nccomp::compensate::{Compensator, Options};
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use std::path::Path;

fn ac_fixture() -> (Machine, ErrorModel) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = machine_file::load(&dir.join("ac_trunnion.machine.toml")).unwrap();
    let e = error_file::load(&dir.join("ac_trunnion.errors.toml"), &m).unwrap();
    assert!(m.work_offsets.is_none());
    (m, e)
}

fn run(name: &str, program: &str) -> Result<String, String> {
    let (m, e) = ac_fixture();
    let comp = Compensator::new(&m, &e, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), name, &mut out)
        .map(|_| String::from_utf8(out).unwrap())
        .map_err(|e| e.to_string())
}

#[test]
fn a_datum_shift_without_a_work_offset_table_is_refused_in_every_dialect() {
    for (name, program, needle) in [
        (
            "p.nc",
            "G90 G21\nG52 X100.\nG0 X0 Y0 Z50. A0 C0\n",
            "p.nc:2:1: G52 cannot be compensated",
        ),
        (
            "p.h",
            "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z S5000\n2 CYCL DEF 7.0 DATUM SHIFT\n3 CYCL DEF 7.1 X+100\n4 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n5 L X+10 R0 F500\n6 END PGM P MM\n",
            "p.h:5:5: a datum shift (CYCL DEF 7, TRANS/ATRANS) of X100 Y0 Z0 is in force outside a tilted working plane, and the machine file has no [work_offsets]",
        ),
        (
            "p.mpf",
            "G90 G710\nTRANS X100\nG0 X0 Y0 Z50 A0 C0\nG1 X10 F500\n",
            "p.mpf:3:4: a datum shift (CYCL DEF 7, TRANS/ATRANS) of X100 Y0 Z0 is in force outside a tilted working plane",
        ),
        (
            "p.mpf",
            "G90 G710\nATRANS Y-20\nG0 X0 Y0 Z50 A0 C0\n",
            "p.mpf:3:4: a datum shift (CYCL DEF 7, TRANS/ATRANS) of X0 Y-20 Z0",
        ),
        // Far past the travel: refused all the same, not written.
        (
            "p.mpf",
            "G90 G710\nTRANS X999999\nG0 X0 Y0 Z50 A0 C0\n",
            "p.mpf:3:4: a datum shift (CYCL DEF 7, TRANS/ATRANS) of X999999 Y0 Z0",
        ),
    ] {
        let err = run(name, program).unwrap_err();
        assert!(err.contains(needle), "{program}: {err}");
    }
}

#[test]
fn a_cancelled_shift_and_a_shift_under_a_plane_pass() {
    // Cancelled before the first move: compensated as usual.
    let out = run(
        "p.mpf",
        "G90 G710\nTRANS X100\nTRANS\nG0 X20 Y10 Z50 A0 C0\n",
    )
    .unwrap();
    assert_ne!(out.lines().nth(3), Some("G0 X20 Y10 Z50 A0 C0"), "{out}");
    let out = run(
        "p.h",
        "0 BEGIN PGM P MM\n1 CYCL DEF 7.0 DATUM SHIFT\n2 CYCL DEF 7.1 X+100\n3 CYCL DEF 7.1 X+0\n4 L X+20 Y+10 Z+50 A+0 C+0 R0 FMAX\n5 END PGM P MM\n",
    )
    .unwrap();
    assert_ne!(
        out.lines().nth(4),
        Some("4 L X+20 Y+10 Z+50 A+0 C+0 R0 FMAX"),
        "{out}"
    );
    // The shift is the origin of a tilted plane set after it (the fixtures' style).
    let out = run(
        "p.h",
        "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z S5000\n2 L X+0 Y+0 Z+100 A+0 C+0 R0 FMAX\n3 CYCL DEF 7.0 DATUM SHIFT\n4 CYCL DEF 7.1 X+20\n5 PLANE SPATIAL SPA-30 SPB+0 SPC+45 TURN FMAX SEQ- TABLE ROT\n6 L X+10 Y+5 Z+50 R0 FMAX\n7 END PGM P MM\n",
    );
    assert!(out.is_ok(), "{out:?}");
}

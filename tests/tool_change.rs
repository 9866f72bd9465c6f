//! Tool changes and tool lengths, in the three dialects: what a change moves (the machine
//! file's `[tool] change_moves`, default the tool axis Z) is unknown after it, as after
//! G28; and a tool's length comes from the tool called, by number or by name, never from
//! a default.

use nccomp::compensate::{Compensator, Options};
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use std::path::Path;

fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}

/// The AC trunnion's machine file with `extra` added to its `[tool]` table.
fn machine(extra: &str) -> (Machine, ErrorModel) {
    fixture("ac_trunnion", extra)
}

/// A fixture machine with `extra` added to its `[tool]` table, and its errors.
fn fixture(name: &str, extra: &str) -> (Machine, ErrorModel) {
    let path = fixtures().join(format!("{name}.machine.toml"));
    let text = std::fs::read_to_string(&path).unwrap();
    let text = text.replace("[tool]\n", &format!("[tool]\n{extra}\n"));
    let m = machine_file::parse(&text, "m.toml").unwrap();
    let e = error_file::load(&fixtures().join(format!("{name}.errors.toml")), &m).unwrap();
    (m, e)
}

fn run(m: &Machine, e: &ErrorModel, name: &str, program: &str) -> Result<String, String> {
    let comp = Compensator::new(m, e, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), name, &mut out)
        .map(|_| String::from_utf8(out).unwrap())
        .map_err(|e| e.to_string())
}

// ---------------------------------------------------------------------------------------
// Case 5: a tool change moves the tool axis.

#[test]
fn a_tool_change_leaves_z_unknown_in_every_dialect() {
    let (m, e) = machine("");
    // The rapid after the change runs at the change height: it passes as written (no Z
    // word added), the next block that sets Z is compensated again.
    let cases = [
        (
            "p.nc",
            "G90 G21\nG0 X0 Y0 Z50. A0 C0\nT2 M6\nG0 X100. Y0\nG0 Z10.\nG1 X90. F500.\n",
            [3, 4],
        ),
        (
            "p.mpf",
            "G90 G710\nG0 X0 Y0 Z50 A0 C0\nT2 M6\nG0 X100 Y0\nG0 Z10\nG1 X90 F500\n",
            [3, 4],
        ),
        (
            "p.mpf",
            "G90 G710\nG0 X0 Y0 Z50 A0 C0\nT=\"MILL\" M6\nG0 X100 Y0\nG0 Z10\nG1 X90 F500\n",
            [3, 4],
        ),
        (
            "p.h",
            "0 BEGIN PGM P MM\n1 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n2 TOOL CALL 2 Z S5000\n3 L X+100 Y+0 R0 FMAX\n4 L Z+10 R0 FMAX\n5 L X+90 R0 F500\n6 END PGM P MM\n",
            [3, 4],
        ),
    ];
    for (name, program, [rapid, next]) in cases {
        let (m, e) = if program.contains("MILL") {
            machine("named_lengths = { \"MILL\" = 110.0 }")
        } else {
            (m.clone(), e.clone())
        };
        let out = run(&m, &e, name, program).unwrap_or_else(|err| panic!("{program}: {err}"));
        let (lin, lout): (Vec<&str>, Vec<&str>) =
            (program.lines().collect(), out.lines().collect());
        assert_eq!(
            lin[rapid], lout[rapid],
            "{name}: the rapid after the change\n{out}"
        );
        assert_ne!(lin[next], lout[next], "{name}: Z is set again\n{out}");
    }
    // A feed move while Z stands at the change position is refused, located.
    for (name, program, needle) in [
        (
            "p.nc",
            "G90 G21\nG0 X0 Y0 Z50. A0 C0\nT2 M6\nG1 X100. Y0 F500.\n",
            "p.nc:4:4: a feed move while axis Z stands where the program has not set it",
        ),
        (
            "p.mpf",
            "G90 G710\nG0 X0 Y0 Z50 A0 C0\nT2 M6\nG1 X100 Y0 F500\n",
            "p.mpf:4:4: a feed move while axis Z stands where the program has not set it",
        ),
        (
            "p.h",
            "0 BEGIN PGM P MM\n1 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n2 TOOL CALL 2 Z S5000\n3 L X+100 Y+0 R0 F500\n4 END PGM P MM\n",
            "p.h:4:5: a feed move while axis Z stands where the program has not set it",
        ),
    ] {
        let err = run(&m, &e, name, program).unwrap_err();
        assert!(err.contains(needle), "{name}: {err}");
    }
    // Axis words with M6 in one block: where the control takes them is its own rule.
    let err = run(&m, &e, "p.nc", "G0 X0 Y0 Z50. A0 C0\nT2 M6 G0 X10.\n").unwrap_err();
    assert!(
        err.contains("p.nc:2:10: axis words with a tool change (M6) cannot be compensated"),
        "{err}"
    );
}

#[test]
fn change_moves_in_the_machine_file_says_what_a_tool_change_moves() {
    // `[]`: the change moves nothing, and the blocks after it are compensated.
    let (m, e) = machine("change_moves = []");
    let program = "G90 G21\nG0 X0 Y0 Z50. A0 C0\nT2 M6\nG0 X100. Y0\nG1 X90. F500.\n";
    let out = run(&m, &e, "p.nc", program).unwrap();
    assert_ne!(out.lines().nth(3), Some("G0 X100. Y0"), "{out}");
    // X and Z: both unknown after it.
    let (m, e) = machine("change_moves = [\"X\", \"Z\"]");
    let program = "G90 G21\nG0 X0 Y0 Z50. A0 C0\nT2 M6\nG0 Y10. Z40.\nG1 Z30. F500.\n";
    let err = run(&m, &e, "p.nc", program).unwrap_err();
    assert!(
        err.contains("p.nc:5:4: a feed move while axis X stands where the program has not set it"),
        "{err}"
    );
    // An axis the machine does not have is named where it stands.
    let text = std::fs::read_to_string(fixtures().join("ac_trunnion.machine.toml")).unwrap();
    let text = text.replace("[tool]\n", "[tool]\nchange_moves = [\"W\"]\n");
    let err = machine_file::parse(&text, "m.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`W` in `change_moves` of [tool] is not an axis of this machine"),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------
// Case 12: a tool's length is the called tool's.

#[test]
fn a_tool_called_by_name_takes_its_own_length_or_is_refused() {
    // Without a length for the name, the call is refused where it stands.
    let (m, e) = machine("");
    for (name, program, needle) in [
        (
            "p.h",
            "0 BEGIN PGM P MM\n1 TOOL CALL \"BALL D10\" Z S5000\n2 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n3 END PGM P MM\n",
            "p.h:2:13: tool \"BALL D10\" has no length in the machine file",
        ),
        (
            "p.mpf",
            "G90 G710\nT=\"BALL D10\" M6\nD1\nG0 X0 Y0 Z50 A0 C0\n",
            "p.mpf:3:1: D1 takes the length of tool \"BALL D10\", which has none in the machine file",
        ),
        (
            "p.h",
            "0 BEGIN PGM P MM\n1 TOOL CALL 7 Z S5000\n2 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n3 END PGM P MM\n",
            "p.h:2:13: tool 7 has no length in the machine file",
        ),
        (
            "p.mpf",
            "G90 G710\nT7 M6\nD1\nG0 X0 Y0 Z50 A0 C0\n",
            "p.mpf:3:1: D1 takes the length of tool T7, which has none in the machine file",
        ),
        (
            "p.mpf",
            "G90 G710\nD1\nG0 X0 Y0 Z50 A0 C0\n",
            "p.mpf:3:4: the length of the tool in the spindle is not known here",
        ),
    ] {
        let err = run(&m, &e, name, program).unwrap_err();
        assert!(err.contains(needle), "{program}: {err}");
    }
    // D1 before any T: a machine move passes (it does not depend on the length).
    let program = "G90 G710\nSUPA G0 Z0 D1\nT1 M6\nD1\nG0 X0 Y0 Z50 A0 C0\n";
    assert!(run(&m, &e, "p.mpf", program).is_ok());
    // With one, each named tool gets its own: the same pose with a tilted spindle (whose
    // tilt moves the tip by the length times it) with two names of different lengths is
    // written differently, and like the numbered tool of that length.
    let (m, _) = machine("named_lengths = { \"BALL D10\" = 120.0, \"END D6\" = 95.3 }");
    let e = error_file::parse(
        "[motion.Z]\npositions = [-100.0, 400.0]\nEAZ = [300.0, 300.0]\nEBZ = [-200.0, -200.0]\n",
        "e.toml",
        &m,
    )
    .unwrap();
    // In a tilted plane (the rotary axes stand where the control turns them) the tilt
    // is left, and the tip words depend on the length.
    let tnc = |tool: &str| {
        let program = format!(
            "0 BEGIN PGM P MM\n1 TOOL CALL {tool} Z S5000\n2 L X+0 Y+0 Z+100 A+0 C+0 R0 FMAX\n3 PLANE SPATIAL SPA-30 SPB+0 SPC+45 TURN FMAX SEQ- TABLE ROT\n4 L X+20 Y+10 Z+50 R0 FMAX\n5 END PGM P MM\n"
        );
        let out = run(&m, &e, "p.h", &program).unwrap();
        out.lines().skip(2).collect::<Vec<_>>().join("\n")
    };
    assert_ne!(tnc("\"BALL D10\""), tnc("\"END D6\""));
    assert_eq!(tnc("\"BALL D10\""), tnc("2"));
    assert_eq!(tnc("\"END D6\""), tnc("1"));
    let mpf = |tool: &str| {
        let program = format!(
            "G90 G710\n{tool} M6\nD1\nG0 X0 Y0 Z100 A0 C0\nCYCLE800(1,\"TABLE\",0,57,0,0,0,-30,0,45,0,0,0,-1,100,1)\nG0 X20 Y10 Z50\n"
        );
        let out = run(&m, &e, "p.mpf", &program).unwrap();
        out.lines().skip(2).collect::<Vec<_>>().join("\n")
    };
    assert_ne!(mpf("T=\"BALL D10\""), mpf("T=\"END D6\""));
    assert_eq!(mpf("T=\"BALL D10\""), mpf("T2"));
    assert_eq!(mpf("T=\"END D6\""), mpf("T1"));
}

#[test]
fn named_lengths_are_read_from_the_machine_file() {
    let (m, _) = machine("named_lengths = { \"BALL D10\" = 120.0 }");
    assert_eq!(m.tool.named_lengths.get("BALL D10"), Some(&120.0));
    let text = std::fs::read_to_string(fixtures().join("ac_trunnion.machine.toml")).unwrap();
    let text = text.replace("[tool]\n", "[tool]\nnamed_lengths = { \"X\" = \"long\" }\n");
    let err = machine_file::parse(&text, "m.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("the length of tool \"X\""), "{err}");
}

// ---------------------------------------------------------------------------------------
// Case 17: a length change at rest moves the nominal tip, not the machine.

#[test]
fn a_feed_move_right_after_a_length_change_at_rest_is_refused() {
    let (m, e) = machine("change_moves = []");
    for (name, program, needle) in [
        (
            "p.nc",
            "G90 G21\nG0 X0 Y0 Z50. A-10. C0\nG43 H2\nG1 X10. F500.\n",
            "p.nc:4:4: a feed move right after the tool length changed with the axes standing",
        ),
        (
            "p.mpf",
            "G90 G710\nT1 M6\nD1\nG0 X0 Y0 Z50 A-10 C0\nD0\nG1 X10 F500\n",
            "p.mpf:6:4: a feed move right after the tool length changed with the axes standing",
        ),
        (
            "p.h",
            "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z S5000\n2 L X+0 Y+0 Z+50 A-10 C+0 R0 FMAX\n3 TOOL CALL 2 Z S5000\n4 L X+10 R0 F500\n5 END PGM P MM\n",
            "p.h:5:5: a feed move right after the tool length changed with the axes standing",
        ),
    ] {
        let err = run(&m, &e, name, program).unwrap_err();
        assert!(err.contains(needle), "{program}: {err}");
    }
    // A rapid after the change positions the tool: the feed move after it is compensated.
    for (name, program) in [
        (
            "p.nc",
            "G90 G21\nG0 X0 Y0 Z50. A-10. C0\nG43 H2\nG0 X0 Y0 Z40.\nG1 X10. F500.\n",
        ),
        (
            "p.h",
            "0 BEGIN PGM P MM\n1 TOOL CALL 1 Z S5000\n2 L X+0 Y+0 Z+50 A-10 C+0 R0 FMAX\n3 TOOL CALL 2 Z S5000\n4 L Z+40 R0 FMAX\n5 L X+10 R0 F500\n6 END PGM P MM\n",
        ),
    ] {
        let out = run(&m, &e, name, program).unwrap_or_else(|err| panic!("{program}: {err}"));
        assert_ne!(out, program);
    }
}

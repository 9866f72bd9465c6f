//! Sinumerik 840D programs: the fixtures pinned as snapshots, the Fusion 840D program of
//! `../shared/corpus/cam` (when it is there), what a user types, and each refusal located
//! with its reason. The contract itself (block ends, mid-path, holes) is evaluated
//! independently in `sinumerik_contract.rs`.

mod common;
use common::cli::{nccomp, scratch, stderr, stdout};

use nccomp::compensate::{Compensator, Options, Summary};
use nccomp::kinematics::path::PathTolerance;
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use std::path::{Path, PathBuf};

const M: &str = "fixtures/ac_trunnion.machine.toml";
const E: &str = "fixtures/ac_trunnion.errors.toml";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn load(machine: &str, errors: &str) -> (Machine, ErrorModel) {
    let m = machine_file::load(&root().join(machine)).unwrap();
    let e = error_file::load(&root().join(errors), &m).unwrap();
    (m, e)
}

/// The options `nccomp compensate` runs with by default.
fn cli_options() -> Options {
    Options {
        path: Some(PathTolerance {
            position: 0.001,
            direction: 10e-6,
            ..PathTolerance::default()
        }),
        ..Options::default()
    }
}

fn run(m: &Machine, e: &ErrorModel, src: &[u8], name: &str) -> Result<(String, Summary), String> {
    let mut out = Vec::new();
    Compensator::new(m, e, cli_options())
        .unwrap()
        .run(src, name, &mut out)
        .map(|s| (String::from_utf8(out).unwrap(), s))
        .map_err(|e| e.to_string())
}

fn snapshot(program: &str) -> String {
    let (m, e) = load(M, E);
    let src = std::fs::read(root().join("fixtures").join(program)).unwrap();
    let (out, summary) = run(&m, &e, &src, program).unwrap();
    // What nccomp writes it reads again, and the zero model gives the program back.
    run(&m, &e, out.as_bytes(), program).unwrap();
    let (same, zero) = run(&m, &ErrorModel::zero(&m), &src, program).unwrap();
    assert!(zero.zero_model);
    assert_eq!(
        same.as_bytes(),
        &src[..],
        "{program}: the zero model changed it"
    );
    format!("{summary}\n----\n{out}")
}

#[test]
fn snapshot_840d_traori() {
    insta::assert_snapshot!(snapshot("840d_ac_trunnion_traori.mpf"));
}

#[test]
fn snapshot_840d_swivel_with_drilling() {
    insta::assert_snapshot!(snapshot("840d_ac_trunnion_swivel.mpf"));
}

#[test]
fn snapshot_840d_variables() {
    insta::assert_snapshot!(snapshot("840d_variables.mpf"));
}

/// Fusion's 840D program (DEF REAL home variables, SUPA home moves with D0/D1, a named
/// tool, `CYCLE800()`, three-axis cutting in G54) compensates on the machine file written
/// for it; the zero model gives it back byte for byte, and nccomp reads its output again.
#[test]
fn the_fusion_840d_program_compensates() {
    let Some(path) = common::skip::corpus_path("cam/fusion_840d_CAM_TEST.MPF") else {
        return;
    };
    let src = std::fs::read(&path).unwrap();
    assert_eq!(
        nccomp::nc::Dialect::detect(&src),
        nccomp::nc::Dialect::Sinumerik
    );
    let (m, e) = load(
        "fixtures/corpus/fusion_840d_ac.machine.toml",
        "fixtures/corpus/dmu85_ac.errors.toml",
    );
    let (same, zero) = run(&m, &ErrorModel::zero(&m), &src, "fusion").unwrap();
    assert!(zero.zero_model);
    assert_eq!(same.as_bytes(), &src[..]);
    let (out, summary) = run(&m, &e, &src, "fusion").unwrap();
    eprintln!("{summary}");
    assert!(summary.words_changed > 1000, "{summary}");
    assert!(summary.before_position.value > 1e-3, "{summary}");
    assert!(summary.after_position.value < 1e-4, "{summary}");
    // Every line is there, in order: the program's own lines are kept or changed in
    // place, inserted ones come between.
    let kept: Vec<&str> = out.lines().collect();
    for line in String::from_utf8(src.clone()).unwrap().lines() {
        let number = line.split_whitespace().next().unwrap();
        assert!(
            kept.iter()
                .any(|l| l.split_whitespace().next() == Some(number)),
            "{number}"
        );
    }
    // The variable words keep their text where nothing changes: the home block's Z.
    assert!(out.contains("N80 SUPA G0 Z=_Z_HOME D0"), "{out}");
    run(&m, &e, out.as_bytes(), "fusion.out").unwrap();
}

#[test]
fn the_command_line_reads_a_sinumerik_program_and_checks_it() {
    let dir = scratch("840d");
    let out_path = dir.join("swivel.mpf");
    let program = "fixtures/840d_ac_trunnion_swivel.mpf";
    let out = nccomp(&[
        "compensate",
        "-m",
        M,
        "-e",
        E,
        program,
        "-o",
        out_path.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let written = std::fs::read_to_string(&out_path).unwrap();
    assert!(written.contains("MCALL CYCLE81(30,-0.00"), "{written}");
    // --check against the file just written: up to date.
    let check = nccomp(&[
        "compensate",
        "-m",
        M,
        "-e",
        E,
        program,
        "--check",
        "--expected",
        out_path.to_str().unwrap(),
    ]);
    assert!(check.status.success(), "{}", stderr(&check));
    // `check`, the CI gate, on the three fixtures. The AC trunnion's exaggerated errors
    // leave direction errors the pass cannot remove above the default --max-angle (100
    // µrad): up to 159 µrad at singular poses (C along the tool, held) and 229 µrad in the
    // swivelled plane (its rotary axes stand where the control turns them). This test is
    // about reading the programs, so it judges the direction at 300 µrad.
    let gate = nccomp(&[
        "check",
        "-m",
        M,
        "-e",
        E,
        "--max-angle",
        "300",
        "fixtures/840d_ac_trunnion_traori.mpf",
        "fixtures/840d_ac_trunnion_swivel.mpf",
        "fixtures/840d_variables.mpf",
    ]);
    assert!(gate.status.success(), "{}{}", stdout(&gate), stderr(&gate));
    // The language given on the command line: the same output.
    let given = nccomp(&[
        "compensate",
        "-m",
        M,
        "-e",
        E,
        "--dialect",
        "sinumerik",
        "-q",
        program,
    ]);
    assert!(given.status.success(), "{}", stderr(&given));
    assert_eq!(stdout(&given), written);
    // A `.mpf` file is a Sinumerik program whatever its text: its L word is a subprogram
    // call (refused), not a word G-code would pass over.
    let plain = dir.join("plain.MPF");
    std::fs::write(&plain, "N10 G0 X0 Y0 Z50 A0 C0\nN20 L100\nN30 M30\n").unwrap();
    let out = nccomp(&["check", "-m", M, "-e", E, plain.to_str().unwrap()]);
    assert!(!out.status.success());
    let text = format!("{}{}", stdout(&out), stderr(&out));
    assert!(
        text.contains("plain.MPF:2:5") && text.contains("subprogram calls"),
        "{text}"
    );
}

/// A block nccomp does not follow is refused where it stands, with what was expected; the
/// block before it is read.
#[test]
fn what_is_not_followed_is_refused_with_its_place_and_reason() {
    let (m, e) = load(M, E);
    let head = "N10 G17 G710 G90 G94\nN20 T1 D1 M6\nN30 G54\nN40 G0 X0 Y0 Z50 A0 C0\n";
    let mut wrong = Vec::new();
    for (block, col, what) in [
        ("N50 G41 G1 X10", 5, "tool radius compensation"),
        ("N50 G1 X=R7", 8, "X is given by `R7`"),
        ("N50 G1 X=SIN(30)", 8, "X is given by `SIN(30)`"),
        (
            "N50 CYCLE800(1,\"T\",0,192,0,0,0,0,0,0,0,0,0,-1,100,1)",
            22,
            "not the axis-by-axis mode",
        ),
        (
            "N50 CYCLE800(1,\"T\",0,57,0,0,0,-30,0,0,0,0,0,2,100,1)",
            45,
            "_DIR is 2",
        ),
        ("N50 CYCLE800(1,\"T\",20,57)", 20, "_ST is 20"),
        ("N50 G1 C=DC(350)", 8, "turns from 0 to -10"),
        ("N50 G2 X10 Y10 AR=90", 16, "opening angle"),
        ("N50 GOTOF END", 5, "control flow"),
        ("N50 G1 X10 A3=0 B3=0 C3=1", 12, "outside TRAORI"),
        ("N50 H2", 5, "auxiliary functions"),
        ("N50 L100", 5, "subprogram calls"),
        ("N50 CYCLE81(10,0,1,-5)", 5, "called once"),
        ("N50 MCALL CYCLE81(10,0,1,-5,5)", 11, "both depths"),
        ("N50 $P_UIFR[1]=CTRANS(X,10)", 5, "system variables"),
        ("N50 G500", 5, "G500"),
        ("N50 TRANS X10 G1", 15, "expected X, Y, Z only"),
        ("N50 TRANS X99999999 Y5", 11, "X in TRANS is out of range"),
        ("N50 WAITM(1)", 5, "not a Sinumerik instruction"),
        ("N50 G1 X=IC(5)", 8, "other distance mode"),
    ] {
        let program = format!("{head}{block}\nN60 M30\n");
        let err = run(&m, &e, program.as_bytes(), "p.mpf").unwrap_err();
        if !(err.contains(&format!("p.mpf:5:{col}:")) && err.contains(what)) {
            wrong.push(format!("{block}: {err}"));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
    // Under a frame and under TRAORI.
    for (program, place, what) in [
        (
            format!(
                "{head}N50 TRANS X5\nN60 CYCLE800(1,\"T\",0,57,0,0,0,-30,0,0,0,0,0,-1,100,1)\n"
            ),
            "p.mpf:6:5:",
            "programmable frame in force",
        ),
        (
            // The turn moved the tip by the nominal angles: a cut from there starts off
            // the corrected pose.
            format!(
                "{head}N50 CYCLE800(0,\"T\",0,57,0,0,0,-30,0,0,0,0,0,-1,100,1)\nN60 G1 X10 F100\n"
            ),
            "p.mpf:6:8:",
            "a feed move right after the rotary axes turned",
        ),
        (
            format!("{head}N50 TRAORI\nN60 CYCLE800()\n"),
            "p.mpf:6:5:",
            "CYCLE800 under TRAORI",
        ),
        (
            format!("{head}N50 TRAORI\nN60 G1 X1 D0\n"),
            "p.mpf:6:11:",
            "tool offset under TRAORI",
        ),
        (
            format!("{head}N50 TRAORI\nN60 G1 X1 A3=0 B3=0 C3=1 A-5\n"),
            "p.mpf:6:11:",
            "rotary axis words in one block",
        ),
    ] {
        let err = run(&m, &e, program.as_bytes(), "p.mpf").unwrap_err();
        assert!(
            err.contains(place) && err.contains(what),
            "{program}: {err}"
        );
    }
}

/// Variables: DEF's values (0 until assigned), assignments over others, expressions in
/// words; a corrected word is written as a number, an uncorrected one keeps its text.
#[test]
fn variables_are_evaluated_and_corrected_words_written_as_numbers() {
    let (m, e) = load(M, E);
    let program = "N10 DEF REAL _A, _B=2.5\nN20 DEF INT _N\nN30 R5=_B*4 _A=R5-_N\nN40 G17 G710 G90 G94 T1 D1\nN50 G0 X=_A Y=(R5+_B)/2 Z=50 A0 C0 F=_NOT_SET\n";
    let (out, _) = run(&m, &e, program.as_bytes(), "v.mpf").unwrap();
    let last = out.lines().last().unwrap();
    // _A = 10, Y = 6.25: corrected, so written as numbers near them.
    let number = |key: &str| -> f64 {
        let at = last.find(key).unwrap() + key.len();
        last[at..]
            .split_whitespace()
            .next()
            .unwrap()
            .parse()
            .unwrap()
    };
    assert!((number("X=") - 10.0).abs() < 0.05, "{last}");
    assert!((number("Y=") - 6.25).abs() < 0.05, "{last}");
    assert!(last.contains("F=_NOT_SET"), "{last}");
    // The same block read as plain numbers is compensated the same way.
    let plain = "N10 G17 G710 G90 G94 T1 D1\nN20 G0 X10 Y6.25 Z50 A0 C0\n";
    let (out2, _) = run(&m, &e, plain.as_bytes(), "p.mpf").unwrap();
    let words = |l: &str| -> Vec<String> {
        l.split_whitespace()
            .filter(|w| w.starts_with(['X', 'Y', 'Z', 'A', 'C']))
            .map(|w| w.replace('=', ""))
            .collect()
    };
    assert_eq!(words(last), words(out2.lines().last().unwrap()));
}

#[test]
fn a_sinumerik_file_keeps_every_byte_it_does_not_change() {
    let (m, _) = load(M, E);
    let zero = ErrorModel::zero(&m);
    let src = "%_N_PART_MPF\r\n;$PATH=/_N_MPF_DIR\r\nN10 DEF REAL _Z=50 ; home\r\n/N20 G0 X=1 y=2 Z=_Z A=DC(0) MSG(\"A; B\")\r\nN30 M30";
    let (out, _) = run(&m, &zero, src.as_bytes(), "k.mpf").unwrap();
    assert_eq!(out, src);
    assert!(Path::new(env!("CARGO_MANIFEST_DIR")).is_dir());
}

#[test]
fn snapshot_840d_swivel_arcs() {
    insta::assert_snapshot!(snapshot("840d_ac_trunnion_swivel_arcs.mpf"));
}

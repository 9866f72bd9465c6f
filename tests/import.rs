//! `nccomp errors convert`: ISG CSV tables and Etalon exchange files become error files
//! that the loader reads back with the same numbers (names mapped onto ISO 230 names,
//! mm and rad kept, signs unchanged unless reversed), and bad input is refused at its
//! place with what was expected.

use nccomp::import::{self, Format, Options};
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn ac_trunnion() -> Machine {
    machine_file::load(Path::new("fixtures/ac_trunnion.machine.toml")).unwrap()
}

/// Convert `text` for `machine` and load the result with the error-file loader.
fn convert(text: &str, machine: &Machine, options: &Options) -> (import::Converted, ErrorModel) {
    let converted = import::convert(text, "in.txt", Some(machine), options)
        .unwrap_or_else(|e| panic!("{}", e.render()));
    let model = error_file::parse(&converted.toml, "out.toml", machine)
        .unwrap_or_else(|e| panic!("{}\n{}", e.render(), converted.toml));
    (converted, model)
}

fn axis(machine: &Machine, name: &str) -> usize {
    machine.axis_index(name).unwrap()
}

/// A table of `positions` and `columns` (name, values) in ISG CSV.
fn isg_table(argument: &str, positions: &[f64], columns: &[(&str, Vec<f64>)]) -> String {
    let mut t = argument.to_string();
    for (name, _) in columns {
        t += &format!("\t{name}");
    }
    t.push('\n');
    for (k, p) in positions.iter().enumerate() {
        t += &format!("{p}");
        for (_, v) in columns {
            t += &format!("\t{}", v[k]);
        }
        t.push('\n');
    }
    t
}

#[test]
fn isg_csv_tables_keep_their_numbers() {
    let m = ac_trunnion();
    let x = [-400.0, -100.0, 250.0, 400.0];
    let exx = vec![0.0, 0.0021, 0.0038, -0.0069];
    let eyx = vec![0.001, 0.0012, -0.002, 0.0011];
    let ebx = vec![0.0, 1.0e-5, 2.25e-5, 3.0e-5];
    let c = [0.0, 90.0, 180.0, 270.0, 360.0];
    let ecc = vec![0.0, 1.2e-5, 2.0e-5, 9.0e-6, 0.0];
    let text = format!(
        "// position errors\nC0Y  X0C  Y0C  A0C  B0C  C0C  Y0A  B0A\n\
         4.55e-5  0.0023  0.0085  9.95e-5  -9.6e-5  1.5e-5  0.0059  8.4e-5\n#\n{}#\n{}",
        isg_table(
            "X",
            &x,
            &[
                ("EXX", exx.clone()),
                ("EYX", eyx.clone()),
                ("EBX", ebx.clone())
            ]
        ),
        isg_table("C", &c, &[("ECC", ecc.clone())]),
    );
    let (converted, model) = convert(&text, &m, &Options::default());
    assert_eq!(converted.format, Format::IsgCsv);
    assert!(
        converted
            .toml
            .contains("length_unit = \"mm\"\nangle_unit = \"rad\"")
    );
    // Position-independent terms: squareness, location shifts (mm), tilts and zero (rad).
    let y = &model.axes[axis(&m, "Y")];
    assert_eq!(y.squareness.as_slice(), &[0.0, 0.0, 4.55e-5]);
    let ce = &model.axes[axis(&m, "C")];
    assert_eq!(ce.location_shift.as_slice(), &[0.0023, 0.0085, 0.0]);
    assert_eq!(ce.location_tilt.as_slice(), &[9.95e-5, -9.6e-5, 0.0]);
    assert_eq!(ce.zero, 1.5e-5);
    let a = &model.axes[axis(&m, "A")];
    assert_eq!(a.location_shift.as_slice(), &[0.0, 0.0059, 0.0]);
    assert_eq!(a.location_tilt.as_slice(), &[0.0, 8.4e-5, 0.0]);
    // Error motions: the same positions and values, in the columns of their names.
    let t = model.axes[axis(&m, "X")].motion.as_ref().unwrap();
    assert_eq!(t.positions, x);
    assert_eq!(t.values[0].as_deref(), Some(&exx[..]));
    assert_eq!(t.values[1].as_deref(), Some(&eyx[..]));
    assert_eq!(t.values[4].as_deref(), Some(&ebx[..]));
    assert!(t.values[2].is_none() && t.values[3].is_none() && t.values[5].is_none());
    assert!(!t.periodic);
    let t = ce.motion.as_ref().unwrap();
    assert_eq!(t.positions, c);
    assert_eq!(t.values[5].as_deref(), Some(&ecc[..]));
    assert!(t.periodic);
    assert!(converted.notes.is_empty(), "{:?}", converted.notes);
}

#[test]
fn etalon_sections_keep_their_numbers_and_grids_are_merged_exactly() {
    let m = ac_trunnion();
    let text = "// Etalon\n[C0Y]\nVALUE = 0.000045500000\n[X0C]\nVALUE = 0.0023\n\
                [EC0C]\nVALUE = -0.00002\n\
                [EXX]\nGridpoints = {\n  -400.0 0.0\n   0.0 0.0038\n  400.0 0.0069\n}  // end\n\
                [EBX]\nGridpoints = {\n  -300.0 0.0000048\n  -100.0 0.0000145\n  100.0 0.000022\n  \
                500.0 0.00003\n}\n\
                [EXY]\nGridpoints = {\n -280.0 -0.001358635132\n -270.0 -0.000240680764\n}\n";
    let (converted, model) = convert(text, &m, &Options::default());
    assert_eq!(converted.format, Format::Etalon);
    assert_eq!(model.axes[axis(&m, "Y")].squareness.z, 4.55e-5);
    assert_eq!(model.axes[axis(&m, "C")].location_shift.x, 0.0023);
    assert_eq!(model.axes[axis(&m, "C")].zero, -2e-5);
    let y = model.axes[axis(&m, "Y")].motion.as_ref().unwrap();
    assert_eq!(y.positions, [-280.0, -270.0]);
    assert_eq!(
        y.values[0].as_deref(),
        Some(&[-0.001358635132, -0.000240680764][..])
    );
    // EXX and EBX of X were given on different grids: one table on the union, which reads
    // back as the same functions (each given point, and held beyond each one's ends).
    let x = model.axes[axis(&m, "X")].motion.as_ref().unwrap();
    assert_eq!(x.positions.len(), 7);
    let cases = [
        (
            0,
            vec![
                (-400.0, 0.0),
                (0.0, 0.0038),
                (400.0, 0.0069),
                (-200.0, 0.0019),
                (500.0, 0.0069),
            ],
        ),
        (
            4,
            vec![
                (-300.0, 0.0000048),
                (-100.0, 0.0000145),
                (100.0, 0.000022),
                (500.0, 0.00003),
                (-400.0, 0.0000048),
                (0.0, (0.0000145 + 0.000022) / 2.0),
            ],
        ),
    ];
    for (c, points) in cases {
        for (p, v) in points {
            let got = x.sample(p).values[c];
            assert!(
                (got - v).abs() < 1e-18,
                "component {c} at {p}: {got} vs {v}"
            );
        }
    }
    assert_eq!(converted.notes.len(), 2, "{:?}", converted.notes);
    assert!(converted.notes[0].contains("resampled"));
}

#[test]
fn reverse_changes_the_sign_of_error_motions_only() {
    let m = ac_trunnion();
    let text = "C0Y X0C\n0.00001 0.002\n#\nX EXX EBX\n-10 0.001 0.00002\n10 -0.003 0\n";
    let (_, plain) = convert(text, &m, &Options::default());
    let options = Options {
        reverse: vec!["X".into()],
        ..Options::default()
    };
    let (converted, flipped) = convert(text, &m, &options);
    let x = axis(&m, "X");
    let (p, f) = (
        plain.axes[x].motion.as_ref().unwrap(),
        flipped.axes[x].motion.as_ref().unwrap(),
    );
    assert_eq!(p.positions, f.positions);
    for c in [0, 4] {
        let (a, b) = (p.values[c].as_ref().unwrap(), f.values[c].as_ref().unwrap());
        assert!(a.iter().zip(b).all(|(a, b)| *a == -*b), "{a:?} {b:?}");
    }
    assert!(!converted.toml.contains("-0.0,") && !converted.toml.contains("-0.0]"));
    // Squareness and location are lines, the same whichever body moves.
    let y = axis(&m, "Y");
    assert_eq!(plain.axes[y].squareness, flipped.axes[y].squareness);
    let c = axis(&m, "C");
    assert_eq!(plain.axes[c].location_shift, flipped.axes[c].location_shift);
    let e = import::convert(
        text,
        "in.csv",
        Some(&m),
        &Options {
            reverse: vec!["Q".into()],
            ..Options::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("--reverse Q: no such axis"), "{e}");
}

#[test]
fn without_a_machine_the_iso_axes_are_used_and_zero_meaningless_terms_are_skipped() {
    let text = "X0X Y0X C0Y X0C\n0 0.0 0.00002 0.001\n#\nB EXB\n0 0.001\n90 0.002\n";
    let c = import::convert(text, "in.csv", None, &Options::default()).unwrap();
    assert!(
        c.toml.contains("[motion.B]\npositions = [0.0, 90.0]"),
        "{}",
        c.toml
    );
    assert!(c.toml.contains("[location.C]\nEX0C = 0.001"), "{}", c.toml);
    assert!(c.toml.contains("EC0Y = 0.00002"));
    assert_eq!(c.notes.len(), 2, "{:?}", c.notes);
    assert!(
        c.notes[0].starts_with("in.csv:1: `X0X` skipped"),
        "{}",
        c.notes[0]
    );
    // But on the AC trunnion there is no B axis.
    let e = import::convert(text, "in.csv", Some(&ac_trunnion()), &Options::default())
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("in.csv:4:3: `EXB` is an error of axis B"),
        "{e}"
    );
}

#[test]
fn the_format_is_detected_from_the_content() {
    assert_eq!(Format::detect("// c\n\n[C0B]\nVALUE = 1\n"), Format::Etalon);
    assert_eq!(Format::detect("  [EXY] // x\n"), Format::Etalon);
    assert_eq!(Format::detect("// [no]\nX EXX\n0 0\n"), Format::IsgCsv);
    assert_eq!(Format::detect(""), Format::IsgCsv);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Any table of a linear and a rotary axis comes back from the loader exactly.
    #[test]
    fn isg_tables_round_trip_exactly(
        steps in prop::collection::vec(0.001f64..200.0, 1..12),
        start in -500.0f64..0.0,
        values in prop::collection::vec(-0.05f64..0.05, 12),
        angles in prop::collection::vec(-1e-3f64..1e-3, 12),
        constant in -1e-3f64..1e-3,
    ) {
        let m = ac_trunnion();
        let mut x = vec![start];
        for s in &steps {
            x.push(x[x.len() - 1] + s);
        }
        x.dedup();
        let n = x.len();
        let eyx = values[..n].to_vec();
        let ecx = angles[..n].to_vec();
        let text = format!(
            "EC0Y\n{constant}\n#\n{}",
            isg_table("X", &x, &[("EYX", eyx.clone()), ("ECX", ecx.clone())])
        );
        let (_, model) = convert(&text, &m, &Options::default());
        let t = model.axes[axis(&m, "X")].motion.clone().unwrap();
        prop_assert_eq!(&t.positions, &x);
        prop_assert_eq!(t.values[1].as_deref(), Some(&eyx[..]));
        prop_assert_eq!(t.values[5].as_deref(), Some(&ecx[..]));
        prop_assert_eq!(model.axes[axis(&m, "Y")].squareness.z, constant);
    }
}

/// The message for bad input `text`, which must start with `in.txt:LINE:COL: ` and
/// contain `fragment`.
fn refused(format: Format, text: &str, place: &str, fragment: &str) {
    let options = Options {
        format: Some(format),
        ..Options::default()
    };
    let e = match import::convert(text, "in.txt", Some(&ac_trunnion()), &options) {
        Ok(c) => panic!("{text:?} was converted:\n{}", c.toml),
        Err(e) => e.to_string(),
    };
    assert!(
        e.starts_with(&format!("in.txt:{place}: ")) && e.contains(fragment),
        "{text:?}: {e}"
    );
}

#[test]
fn bad_isg_csv_is_refused_at_its_place() {
    let f = Format::IsgCsv;
    refused(f, "", "1:1", "no table");
    refused(f, "// only a comment\n", "1:1", "no table");
    refused(f, "X EXX\n", "1:6", "a header without rows");
    refused(
        f,
        "X EXX\n0 0.1\n0 0.2\n",
        "3:1",
        "X = 0 follows X = 0: expected the argument to increase strictly",
    );
    refused(
        f,
        "X EXX\n0 abc\n",
        "2:3",
        "`abc` is not a number: expected the value of `EXX`",
    );
    refused(
        f,
        "X EXX\n0 0.1 // ok\n1 NaN\n",
        "3:3",
        "`NaN` is not a number",
    );
    refused(
        f,
        "X EXX EYX\n0 0.1\n",
        "2:6",
        "2 values in this row: expected 3, one per column",
    );
    refused(
        f,
        "X EXX\n0 0.1 0.2\n",
        "2:7",
        "3 values in this row: expected 2",
    );
    refused(f, "Z X EXX\n0 0 0\n", "1:3", "a second argument `X`");
    refused(
        f,
        "X C0Y\n0 1\n",
        "1:3",
        "`C0Y` is a position error, one value: it cannot depend on X",
    );
    refused(f, "EXX\n0.1\n", "1:1", "expected the argument column X");
    refused(
        f,
        "X EYY\n0 1\n",
        "1:3",
        "`EYY` is a function of the position of axis Y, but this table's argument is X",
    );
    refused(f, "X EQX\n0 1\n", "1:3", "unknown column `EQX`");
    refused(
        f,
        "X EXXX\n0 1\n",
        "1:3",
        "`EXXX` is a function of the position of axis XX",
    );
    refused(
        f,
        "X EXx\n0 1\n",
        "1:3",
        "unknown column `EXx`: did you mean `EXX`?",
    );
    refused(
        f,
        "0.1 0.2\n",
        "1:1",
        "a number where the header was expected",
    );
    refused(
        f,
        "C0Y X0C\n0.1 0.2\n0.1 0.2\n",
        "3:1",
        "a second row of position errors",
    );
    refused(
        f,
        "PXA Y0C\n1 2\n",
        "1:1",
        "ISG kinematic parameter (the centre of rotation",
    );
    refused(f, "X\n1\n", "1:1", "names no error parameter");
    refused(f, "X0X\n0.5\n", "1:1", "`X0X` cannot be converted");
    refused(f, "Z0C\n0.5\n", "1:1", "meaningless");
    refused(
        f,
        "X EXX\n0 1\n#\nX EXX\n0 1\n",
        "4:3",
        "given a second time (first at line 1)",
    );
    refused(
        f,
        "C0Y\n1\n#\nEC0Y\n1\n",
        "4:1",
        "`EC0Y` (EC0Y) is given a second time",
    );
    refused(f, "C EXC\n0 0\n370 0\n", "1:3", "span 370°");
    refused(f, "C EXC\n0 0.1\n360 0.2\n", "1:3", "expected equal values");
    refused(
        f,
        "X0B\n0.1\n",
        "1:1",
        "`X0B` is an error of axis B, which the machine does not have",
    );
}

#[test]
fn bad_etalon_files_are_refused_at_their_place() {
    let f = Format::Etalon;
    refused(f, "// nothing\n", "1:1", "no section");
    refused(f, "VALUE = 1\n", "1:1", "text before the first section");
    refused(f, "[C0Y\nVALUE = 1\n", "1:5", "without `]`");
    refused(f, "[FOO]\nVALUE = 1\n", "1:2", "unknown section [FOO]");
    refused(
        f,
        "[C0Y]\nVALUE = x1\n",
        "2:9",
        "`x1` is not a number: expected the value of C0Y",
    );
    refused(f, "[C0Y]\nVALUE\n", "2:1", "expected `KEY = value`");
    refused(
        f,
        "[C0Y]\nGridpoints = {\n0 1\n}\n",
        "2:1",
        "is a position error, one value",
    );
    refused(
        f,
        "[EXY]\nVALUE = 1\n",
        "2:1",
        "expected `Gridpoints = { ... }`, not a single VALUE",
    );
    refused(f, "[EXY]\nGridpoints = {\n0 1\n", "2:14", "not closed");
    refused(f, "[EXY]\nGridpoints = [\n", "2:14", "expected `{`");
    refused(
        f,
        "[EXY]\nGridpoints = {\n0 1 2\n}\n",
        "3:5",
        "3 numbers in this record: expected two",
    );
    refused(
        f,
        "[EXY]\nGridpoints = {\n  7\n}\n",
        "3:3",
        "1 number in this record",
    );
    refused(
        f,
        "[EXY]\nGridpoints = {\n1 1\n0 2\n}\n",
        "4:1",
        "position 0 follows 1",
    );
    refused(
        f,
        "[EXY]\nGridpoints = {\n1 y\n}\n",
        "3:3",
        "`y` is not a number: expected the value",
    );
    refused(
        f,
        "[EXY]\nGridpoints = {\n}\n",
        "2:14",
        "an empty Gridpoints list",
    );
    refused(
        f,
        "[EXY]\nGridpoints = {\n0 1\n} x\n",
        "4:3",
        "`x` after `}`",
    );
    refused(
        f,
        "[EXY]\nFoo = 1\n",
        "2:1",
        "unknown key `Foo` in section [EXY]",
    );
    refused(
        f,
        "[C0Y]\n[X0C]\nVALUE = 1\n",
        "1:2",
        "section [C0Y] has no value",
    );
    refused(
        f,
        "[C0Y]\nVALUE = 1\nVALUE = 2\n",
        "3:1",
        "has its value already",
    );
    refused(
        f,
        "[C0Y]\nVALUE = 1\n[C0Y]\nVALUE = 2\n",
        "3:2",
        "given a second time (first at line 1)",
    );
    refused(
        f,
        "[EXA]\nGridpoints = {\n-200 1\n200 1\n}\n",
        "1:2",
        "span 400°",
    );
}

// ----------------------------------------------------------------------- command line

fn nccomp(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(args)
        .output()
        .unwrap()
}

fn scratch(dir: &Path, name: &str) -> String {
    dir.join(name).to_str().unwrap().to_string()
}

#[test]
fn cli_converts_both_formats_into_files_that_compensate() {
    let dir = tempfile::tempdir().unwrap();
    for (input, marker) in [
        ("fixtures/import/ac_trunnion.isg.csv", "ISG_CSV"),
        ("fixtures/import/ac_trunnion.etalon.txt", "Etalon exchange"),
    ] {
        let out = scratch(dir.path(), "errors.toml");
        let r = nccomp(&["errors", "convert", input, "-o", &out]);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert!(r.status.success(), "{stderr}");
        assert!(stderr.contains(marker), "{stderr}");
        let program = scratch(dir.path(), "out.nc");
        let r = nccomp(&[
            "compensate",
            "--machine",
            "fixtures/ac_trunnion.machine.toml",
            "--errors",
            &out,
            "fixtures/feature_workpiece.nc",
            "-o",
            &program,
        ]);
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        let original = std::fs::read("fixtures/feature_workpiece.nc").unwrap();
        assert_ne!(std::fs::read(&program).unwrap(), original);
    }
    // Standard output without -o; the machine check; --from overrides detection.
    let r = nccomp(&[
        "errors",
        "convert",
        "fixtures/import/ac_trunnion.etalon.txt",
        "--machine",
        "fixtures/ac_trunnion.machine.toml",
    ]);
    assert!(r.status.success());
    assert!(String::from_utf8_lossy(&r.stdout).contains("[motion.X]"));
    let r = nccomp(&[
        "errors",
        "convert",
        "fixtures/import/ac_trunnion.isg.csv",
        "--from",
        "etalon",
    ]);
    assert_eq!(r.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.starts_with(
            "error: text before the first section: expected a section header such as [C0B]\n --> fixtures/import/ac_trunnion.isg.csv:8:1\n"
        ),
        "{stderr}"
    );
}

#[test]
fn cli_bad_input_exits_2_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let input = scratch(dir.path(), "bad.csv");
    std::fs::write(&input, "X EXX\n0 0.1\n1 zero\n").unwrap();
    let out: PathBuf = dir.path().join("errors.toml");
    let r = nccomp(&["errors", "convert", &input, "-o", out.to_str().unwrap()]);
    assert_eq!(r.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(
        stderr.starts_with(&format!(
            "error: `zero` is not a number: expected the value of `EXX` (mm for lengths, rad for angles)\n --> {input}:3:3\n"
        )),
        "{stderr}"
    );
    // The carets under the word.
    assert!(stderr.contains("\n3 | 1 zero\n  |   ^^^^\n"), "{stderr}");
    assert!(!out.exists());
    let r = nccomp(&["errors", "convert", "no/such/file.csv"]);
    assert_eq!(r.status.code(), Some(2));
}

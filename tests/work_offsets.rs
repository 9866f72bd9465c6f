//! Work offsets: a program switching G54–G57, two of them set by G10 L2, with a G52 shift,
//! checked against an independent model of the controller: the machine position of a block
//! is its words plus the offset in force (the machine file's table or the program's G10,
//! plus G52), and the real machine, evaluated with the error model there, must put the tip
//! where the programmed words put it on the nominal machine.

use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use std::collections::BTreeMap;
use std::path::Path;

/// The head-head fixture with an offset table: the geometry is given in G54's program zero.
const TABLE: &str = r#"
[work_offsets]
geometry = "G54"
G54 = { X = -300.0, Y = -180.0, Z = -400.0 }
G55 = { X = -200.0, Y = -180.0, Z = -400.0 }
"#;

/// Error motions of X and Y along their travel (µm, µrad): the errors at G55 … G57 differ
/// from those at G54, so a pass that did not follow the offsets would miss.
const MOTIONS: &str = r#"
[motion.X]
positions = [-500.0, -250.0, 0.0, 250.0, 500.0]
EXX = [-6.0, -2.0, 0.0, 3.0, 7.0]
EYX = [1.0, 2.5, 0.0, -2.0, 1.5]
ECX = [-20.0, -5.0, 0.0, 12.0, 25.0]

[motion.Y]
positions = [-400.0, 0.0, 400.0]
EYY = [4.0, 0.0, -5.0]
EAY = [15.0, 0.0, -10.0]
"#;

fn setup() -> (Machine, ErrorModel) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let text = std::fs::read_to_string(root.join("head_head.machine.toml")).unwrap() + TABLE;
    let machine = machine_file::parse(&text, "head_head_offsets.machine.toml").unwrap();
    let errors = std::fs::read_to_string(root.join("head_head.errors.toml")).unwrap() + MOTIONS;
    let errors = error_file::parse(&errors, "head_head_offsets.errors.toml", &machine).unwrap();
    (machine, errors)
}

fn program() -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    std::fs::read_to_string(root.join("head_head_offsets.nc")).unwrap()
}

fn compensate(machine: &Machine, errors: &ErrorModel, program: &str) -> Result<String, String> {
    let comp = Compensator::new(machine, errors, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out)
        .map(|s| format!("{s}\n----\n{}", String::from_utf8(out).unwrap()))
        .map_err(|e| e.to_string())
}

/// Every block end (by N number, the last written block of each): the machine axes
/// [X, Y, Z, C, A] relative to G54's zero (the geometry's), as the controller runs the
/// words.
fn machine_positions(program: &str) -> BTreeMap<u64, [f64; 5]> {
    let mut table: BTreeMap<u32, [f64; 3]> = BTreeMap::new();
    table.insert(54, [-300.0, -180.0, -400.0]);
    table.insert(55, [-200.0, -180.0, -400.0]);
    let mut active = 54;
    let mut local = [0.0; 3];
    // Program words (in the active zero) as last programmed.
    let mut words = [0.0; 5];
    let mut out = BTreeMap::new();
    for line in program.lines() {
        let body = line.split('(').next().unwrap();
        let mut n = 0;
        let mut codes = Vec::new();
        let mut given: BTreeMap<char, f64> = BTreeMap::new();
        for w in body.split_whitespace() {
            if w == "%" {
                continue;
            }
            let (letter, value) = (w.chars().next().unwrap(), &w[1..]);
            match letter {
                'N' => n = value.parse().unwrap(),
                'G' => codes.push(value.parse::<f64>().unwrap()),
                _ => {
                    given.insert(letter, value.parse().unwrap());
                }
            }
        }
        let zero = |active: u32, local: [f64; 3]| {
            let v = table[&active];
            let g = table[&54];
            [
                v[0] + local[0] - g[0],
                v[1] + local[1] - g[1],
                v[2] + local[2] - g[2],
            ]
        };
        let before = zero(active, local);
        if codes.contains(&10.0) {
            let p = given[&'P'] as u32;
            table.insert(53 + p, [given[&'X'], given[&'Y'], given[&'Z']]);
            continue;
        }
        if codes.contains(&52.0) {
            for (c, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
                if let Some(x) = given.get(&l) {
                    local[c] = *x;
                }
            }
        }
        for g in [54.0, 55.0, 56.0, 57.0] {
            if codes.contains(&g) {
                active = g as u32;
            }
        }
        let after = zero(active, local);
        // The axes stay where they are: their words in the new zero change.
        for c in 0..3 {
            words[c] += before[c] - after[c];
        }
        if codes.contains(&52.0) {
            continue;
        }
        let mut moved = false;
        for (k, l) in ['X', 'Y', 'Z', 'C', 'A'].into_iter().enumerate() {
            if let Some(x) = given.get(&l) {
                words[k] = *x;
                moved = true;
            }
        }
        if moved {
            let mut q = words;
            for c in 0..3 {
                q[c] += after[c];
            }
            out.insert(n, q);
        }
    }
    out
}

#[test]
fn a_program_switching_work_offsets_lands_every_block() {
    let (machine, errors) = setup();
    let program = program();
    let written = compensate(&machine, &errors, &program).unwrap();
    let written = written.split("\n----\n").nth(1).unwrap();
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let length = machine.tool.lengths[&1];
    let vars = |q: [f64; 5]| -> Vec<f64> {
        kin.axes()
            .iter()
            .map(|&i| match machine.axes[i].name.as_str() {
                "X" => q[0],
                "Y" => q[1],
                "Z" => q[2],
                "C" => q[3],
                _ => q[4],
            })
            .collect()
    };
    let nominal = machine_positions(&program);
    let real = machine_positions(written);
    assert_eq!(
        nominal.keys().collect::<Vec<_>>(),
        real.keys().collect::<Vec<_>>()
    );
    let (mut worst, mut worst0) = (0.0f64, 0.0f64);
    for (n, q) in &nominal {
        // Before G43 (N50) the tool length is the reference's.
        let l = if *n < 60 { machine.tool.length } else { length };
        let target = kin.pose(Model::Nominal, &vars(*q), l).0.p;
        let reached = kin.pose(Model::Actual, &vars(real[n]), l).0.p;
        let uncompensated = kin.pose(Model::Actual, &vars(*q), l).0.p;
        worst = worst.max((reached - target).norm());
        worst0 = worst0.max((uncompensated - target).norm());
    }
    eprintln!(
        "block ends within {:.3} µm (as programmed {:.3} µm)",
        worst * 1e3,
        worst0 * 1e3
    );
    // The offsets put G56 and G57 100 and 300 mm from G54: the errors differ there.
    assert!(worst0 > 5e-3, "{worst0}");
    assert!(worst < 1.5e-4, "{worst}\n{written}");
}

#[test]
fn the_offsets_program_is_pinned() {
    let (machine, errors) = setup();
    insta::assert_snapshot!(compensate(&machine, &errors, &program()).unwrap());
}

#[test]
fn with_the_zero_model_it_comes_back_unchanged() {
    let (machine, _) = setup();
    let program = program();
    let comp = Compensator::new(&machine, &ErrorModel::zero(&machine), Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), program);
}

#[test]
fn offsets_whose_values_are_not_known_are_refused_where_a_block_moves() {
    let (machine, errors) = setup();
    for (program, at, says) in [
        (
            "G21 G90\nG56\nG0 X0 Y0 Z50.\n",
            "p.nc:3:1",
            "the machine file's [work_offsets] does not give G56",
        ),
        (
            "G21 G90\nG10 L2 P3 X10.\n",
            "p.nc:2:1",
            "G10 leaves Y of G56 as it was",
        ),
        (
            "G21 G90\nG10 L11 P1 R-1.\n",
            "p.nc:2:1",
            "G10 L11 cannot be compensated: it sets data other than work offsets",
        ),
        (
            "G21 G90\nG10 L2 P1 C10.\n",
            "p.nc:2:11",
            "C words in G10 cannot be compensated",
        ),
        (
            "G21 G90\nG55 G43.4 H1\nG0 X0 Y0 Z50. C0 A0\n",
            "p.nc:3:",
            "with a program zero other than the machine file's geometry zero",
        ),
    ] {
        let err = compensate(&machine, &errors, program).unwrap_err();
        assert!(err.contains(at), "{err}");
        assert!(err.contains(says), "{err}");
    }
    // Without a table the one-offset rule stands.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let plain = machine_file::load(&root.join("head_head.machine.toml")).unwrap();
    let err = compensate(&plain, &errors, "G54 G0 X0\nG55 G0 X0\n").unwrap_err();
    assert!(
        err.contains("p.nc:2:1: G55 switches the work offset"),
        "{err}"
    );
}

/// The written program's machine axes [X, Y, Z, C, A] (geometry zero G54) after each line
/// that moves, read as a control reads it: G90 words in the active offset (G54 or G57 of
/// `table`), G91 words a travel from where the axes stand, whatever offset is active.
fn run_words(program: &str, table: &BTreeMap<u32, [f64; 3]>) -> Vec<[f64; 5]> {
    let mut q = [0.0; 5];
    let (mut incremental, mut active) = (false, 54u32);
    let mut ends = Vec::new();
    for line in program.lines() {
        let mut given: Vec<(usize, f64)> = Vec::new();
        for w in line.split_whitespace() {
            let (letter, value) = (w.as_bytes()[0], &w[1..]);
            let Ok(v) = value.parse::<f64>() else {
                continue;
            };
            match letter {
                b'G' if v == 90.0 => incremental = false,
                b'G' if v == 91.0 => incremental = true,
                b'G' if (54.0..=59.0).contains(&v) => active = v as u32,
                b'X' | b'Y' | b'Z' | b'C' | b'A' => {
                    given.push((b"XYZCA".iter().position(|&l| l == letter).unwrap(), v))
                }
                _ => {}
            }
        }
        if given.is_empty() {
            continue;
        }
        for (k, v) in given {
            if incremental {
                q[k] += v;
            } else {
                q[k] = v + if k < 3 {
                    table[&active][k] - table[&54][k]
                } else {
                    0.0
                };
            }
        }
        ends.push(q);
    }
    ends
}

/// Issue 34, case 14: in G91 a switch of work offset moves nothing; the increments after
/// it are travels from where the axes stand (they were written from the old offset's
/// position, 360 mm off).
#[test]
fn an_increment_after_a_work_offset_change_travels_from_where_the_axes_stand() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let text = std::fs::read_to_string(root.join("head_head.machine.toml")).unwrap()
        + "\n[work_offsets]\ngeometry = \"G54\"\nG54 = { X = -300.0, Y = -180.0, Z = -400.0 }\nG57 = { X = 60.0, Y = -180.0, Z = -410.0 }\n";
    let machine = machine_file::parse(&text, "head_head_g57.machine.toml").unwrap();
    let errors = std::fs::read_to_string(root.join("head_head.errors.toml")).unwrap() + MOTIONS;
    let errors = error_file::parse(&errors, "head_head_g57.errors.toml", &machine).unwrap();
    let table: BTreeMap<u32, [f64; 3]> =
        [(54, [-300.0, -180.0, -400.0]), (57, [60.0, -180.0, -410.0])]
            .into_iter()
            .collect();
    let program = "G21 G90\nG54 G0 X0 Y0 Z100. C0 A0\nG91\nG57 G0 Z50.\nX10. Y10.\n";
    let written = compensate(&machine, &errors, program).unwrap();
    let written = written.split("\n----\n").nth(1).unwrap();
    let nominal = run_words(program, &table);
    let real = run_words(written, &table);
    assert_eq!(nominal.len(), real.len(), "{written}");
    assert_eq!(nominal[2], [10.0, 10.0, 150.0, 0.0, 0.0]);
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let vars = |q: [f64; 5]| -> Vec<f64> {
        kin.axes()
            .iter()
            .map(|&i| q["XYZCA".find(machine.axes[i].name.as_str()).unwrap()])
            .collect()
    };
    let l = machine.tool.length;
    for (target, reached) in nominal.iter().zip(&real) {
        let target_p = kin.pose(Model::Nominal, &vars(*target), l).0.p;
        let reached_p = kin.pose(Model::Actual, &vars(*reached), l).0.p;
        let off = (reached_p - target_p).norm();
        assert!(off < 1e-3, "{written}\n{target:?}: {off} mm off");
    }
}

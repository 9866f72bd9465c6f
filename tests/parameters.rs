//! A macro-parameter program: parameters set to constants are used in axis words, a feed
//! keeps its parameter, an optional assignment makes its value unknown. An independent
//! reading (its own substitution of the constants) of the program and of what nccomp
//! writes shows every block end on the real machine where the programmed words put it on
//! the nominal machine.

use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{ErrorModel, error_file, machine_file};
use std::collections::BTreeMap;
use std::path::Path;

/// The axis values [X, Y, Z, C, A] at the end of every line that moves, the parameters
/// replaced by the constants assigned before it.
fn ends(program: &str) -> BTreeMap<usize, [f64; 5]> {
    let mut params: BTreeMap<String, f64> = BTreeMap::new();
    let mut q = [0.0; 5];
    let mut out = BTreeMap::new();
    for (k, line) in program.lines().enumerate() {
        let body = line.split('(').next().unwrap().trim();
        if let Some(rest) = body.strip_prefix('#') {
            let (name, value) = rest.split_once('=').unwrap();
            match value.trim().parse::<f64>() {
                Ok(v) => params.insert(name.trim().to_lowercase(), v),
                Err(_) => params.remove(&name.trim().to_lowercase()),
            };
            continue;
        }
        let mut moved = false;
        for w in body.split_whitespace() {
            let letter = w.chars().next().unwrap();
            let Some(k) = "XYZCA".find(letter) else {
                continue;
            };
            let text = &w[1..];
            q[k] = match text.strip_prefix('#') {
                Some(name) => params[&name.to_lowercase()],
                None => text.parse().unwrap(),
            };
            moved = true;
        }
        if moved {
            out.insert(k + 1, q);
        }
    }
    out
}

#[test]
fn constants_in_words_are_evaluated_and_corrected_words_written_as_numbers() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("head_head.machine.toml")).unwrap();
    let errors = error_file::load(&root.join("head_head.errors.toml"), &machine).unwrap();
    let program = std::fs::read_to_string(root.join("head_head_macro.nc")).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    insta::assert_snapshot!(format!("{summary}\n----\n{written}"));
    // The assignments and the feed's parameter are kept; X#100 is corrected.
    for kept in ["#100 = 25.", "#<feed> = 400", "F#<feed>", "G4 P#7"] {
        assert!(written.contains(kept), "{kept}\n{written}");
    }
    assert!(!written.contains("X#100"), "{written}");
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let vars = |q: [f64; 5]| -> Vec<f64> {
        kin.axes()
            .iter()
            .map(|&i| q["XYZCA".find(machine.axes[i].name.as_str()).unwrap()])
            .collect()
    };
    let (nominal, real) = (ends(&program), ends(&written));
    assert_eq!(
        nominal.keys().collect::<Vec<_>>(),
        real.keys().collect::<Vec<_>>()
    );
    let mut worst = 0.0f64;
    for (line, q) in &nominal {
        let l = if *line < 10 {
            machine.tool.length
        } else {
            machine.tool.lengths[&1]
        };
        let target = kin.pose(Model::Nominal, &vars(*q), l).0.p;
        let reached = kin.pose(Model::Actual, &vars(real[line]), l).0.p;
        worst = worst.max((reached - target).norm());
    }
    assert!(worst < 1.5e-4, "{worst}\n{written}");
    // The zero model: byte for byte.
    let zero = Compensator::new(&machine, &ErrorModel::zero(&machine), Options::default()).unwrap();
    let mut out = Vec::new();
    zero.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), program);
}

#[test]
fn values_known_only_at_run_time_are_refused_where_they_are_used() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("head_head.machine.toml")).unwrap();
    let errors = error_file::load(&root.join("head_head.errors.toml"), &machine).unwrap();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    for (program, at, says) in [
        (
            "G0 X0 Y0 Z50. C0 A0\nG1 X#5021\n",
            "p.nc:2:4",
            "X is given by a parameter, #5021, which the program never sets (a system variable, or one set by an operator, a probing cycle or another program): its value is decided at run time",
        ),
        (
            "#1=[2*3]\nG0 X#1\n",
            "p.nc:2:4",
            "X is given by a parameter, #1, which the program sets to an expression or another parameter, not a constant",
        ),
        (
            "/#1=5.\nG0 X#1\n",
            "p.nc:2:4",
            "X is given by a parameter, #1",
        ),
        ("#5221=-100.\n", "p.nc:1:1", "offset variables"),
        (
            "G0 X0 Y0 Z50. C0 A0\nIF[#1005EQ0]GOTO10\n",
            "p.nc:2:1",
            "a macro branch (IF … GOTO / THEN) cannot be compensated: which blocks run depends on #1005, which the program never sets",
        ),
        (
            "G0 X0 Y0 Z50. C0 A0\nG90 G10 L11 P#4120 R-1.0\n",
            "p.nc:2:5",
            "G10 cannot be compensated: data setting (G10) writes the controller's offsets from #4120, which the program never sets",
        ),
        (
            "G0 X0 Y0 Z50. C0 A0\nG43 Z50.\n",
            "p.nc:2:1",
            "which tool that is, and so where the tip is, is decided at run time",
        ),
    ] {
        let mut out = Vec::new();
        let err = comp
            .run(program.as_bytes(), "p.nc", &mut out)
            .unwrap_err()
            .to_string();
        assert!(err.contains(at), "{err}");
        assert!(err.contains(says), "{err}");
    }
}

//! The compensation pass end to end in the library: programs in, programs out, and an
//! independent evaluation of what the output makes the erroneous machine do.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{ErrorModel, Machine};

fn machine() -> Machine {
    let mut m = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    m.axes[3].travel = Some([-120.0, 30.0]);
    m
}

/// A five-axis G0/G1 program like the outside checker's: N numbers, comments, modal axis
/// words, starting at A0 C0.
fn random_program(rng: &mut Lcg, blocks: usize) -> String {
    let mut s =
        String::from("%\n(RANDOM FIVE-AXIS TEST)\nN10 G21 G90 G17\nN20 G0 X0 Y0 Z50. A0 C0\n");
    let mut q = [0.0, 0.0, 50.0, 0.0, 0.0];
    for i in 0..blocks {
        let mut words = Vec::new();
        for (k, letter) in ["X", "Y", "Z", "A", "C"].iter().enumerate() {
            if rng.next() < 0.6 || i == 0 {
                q[k] = match k {
                    0 | 1 => rng.sym(150.0),
                    2 => 20.0 + rng.next() * 100.0,
                    3 => -100.0 + rng.next() * 125.0,
                    _ => rng.sym(180.0),
                };
                // Sometimes land exactly on A = 0 (singular), sometimes near it.
                if k == 3 && rng.next() < 0.15 {
                    q[k] = rng.sym(2.0).round();
                }
                words.push(format!("{letter}{:.3}", q[k]));
            }
        }
        if words.is_empty() {
            words.push(format!("X{:.3}", q[0]));
        }
        let g = if i % 7 == 0 {
            "G0 "
        } else if i % 7 == 1 {
            "G1 "
        } else {
            ""
        };
        let comment = if i % 11 == 0 { " (PASS)" } else { "" };
        s.push_str(&format!(
            "N{} {g}{}{comment}\n",
            30 + 10 * i,
            words.join(" ")
        ));
    }
    s.push_str("N99999 M30\n%\n");
    s
}

/// Read axis values block by block the simple way: every line's X Y Z A C words update a
/// modal state; one state per line.
fn axis_states(program: &str) -> Vec<[f64; 5]> {
    let mut q = [0.0; 5];
    let mut out = Vec::new();
    for line in program.lines() {
        let clean: String = {
            let mut depth = 0;
            line.chars()
                .filter(|&c| {
                    if c == '(' {
                        depth += 1;
                    }
                    let keep = depth == 0;
                    if c == ')' {
                        depth -= 1;
                    }
                    keep
                })
                .collect()
        };
        for word in clean.split_whitespace() {
            let (letter, value) = word.split_at(1);
            if let (Some(k), Ok(v)) = ("XYZAC".find(letter), value.parse::<f64>()) {
                q[k] = v;
            }
        }
        out.push(q);
    }
    out
}

#[test]
fn every_programmed_pose_is_reached() {
    let machine = machine();
    for seed in 1..=8u64 {
        let mut rng = Lcg(seed);
        let errors = random_errors(&machine, &mut rng);
        let program = random_program(&mut rng, 300);
        let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
        let mut out = Vec::new();
        let summary = comp.run(program.as_bytes(), "random.nc", &mut out).unwrap();
        let out = String::from_utf8(out).unwrap();
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        let nominal = axis_states(&program);
        let actual = axis_states(&out);
        assert_eq!(nominal.len(), actual.len(), "no block goes missing");
        let (mut worst_before, mut worst_after) = (0.0f64, 0.0f64);
        let moves: Vec<bool> = program
            .lines()
            .map(|l| {
                l.split('(')
                    .next()
                    .unwrap()
                    .split_whitespace()
                    .any(|w| "XYZAC".contains(&w[..1]))
            })
            .collect();
        for (line, (qn, qa)) in nominal.iter().zip(&actual).enumerate() {
            if !moves[line] {
                continue;
            }
            let (target, _) = kin.pose(Model::Nominal, qn, 0.0);
            let (before, _) = kin.pose(Model::Actual, qn, 0.0);
            let (reached, _) = kin.pose(Model::Actual, qa, 0.0);
            let (dp, dd) = reached.deviation(&target);
            worst_before = worst_before.max(before.deviation(&target).0);
            worst_after = worst_after.max(dp);
            assert!(
                dp < 1e-3,
                "seed {seed} line {}: tip off by {dp} mm",
                line + 1
            );
            let singular = qn[3].abs() < 3.0;
            if singular {
                assert_eq!(
                    qa[4],
                    qn[4],
                    "seed {seed} line {}: C must not swing at A = {}",
                    line + 1,
                    qn[3]
                );
            } else {
                assert!(
                    dd < 10e-6,
                    "seed {seed} line {}: direction off by {dd} rad",
                    line + 1
                );
            }
        }
        assert!(
            worst_before > 5e-3,
            "the errors matter before compensation ({worst_before})"
        );
        assert!(worst_after < 1e-3);
        assert!(summary.words_changed > 0);
        assert!((summary.after_position.value - worst_after).abs() < 1e-9);
    }
}

#[test]
fn zero_model_gives_the_program_back_byte_for_byte() {
    let machine = machine();
    let program = random_program(&mut Lcg(42), 50).replace('\n', "\r\n");
    let comp = Compensator::new(&machine, &ErrorModel::zero(&machine), Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    assert_eq!(out, program.as_bytes());
}

fn compensate(program: &str) -> Result<String, String> {
    let machine = machine();
    let errors = random_errors(&machine, &mut Lcg(7));
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out)
        .map(|_| String::from_utf8(out).unwrap())
        .map_err(|e| e.to_string())
}

#[test]
fn unchanged_bytes_stay_and_missing_axes_are_added() {
    let out = compensate(
        "N5 G0 X0 Y0 Z0 A0 C0\r\nn10 g1 x100.5 (keep) y 20\r\nN20 G0 Z50\r\n/N30 X10\r\n; end",
    )
    .unwrap();
    let lines: Vec<&str> = out.split("\r\n").collect();
    assert_eq!(lines.len(), 5);
    // Lowercase stays lowercase, the comment and the space after `y` stay.
    assert!(lines[1].starts_with("n10 g1 x100.5"), "{}", lines[1]);
    assert!(lines[1].contains(" (keep) y 20"), "{}", lines[1]);
    // Axes the block left out but that must move are added, in the block's style.
    assert!(
        lines[1].contains(" z") && lines[1].contains(" a"),
        "{}",
        lines[1]
    );
    assert!(lines[3].starts_with("/N30 X10."), "{}", lines[3]);
    assert_eq!(lines[4], "; end");
}

#[test]
fn no_word_is_added_for_an_axis_the_program_has_not_set() {
    // Z, A and C stand where the operator left them: a Z word here would move the tool
    // to a height the program never asked for. A rapid passes as it is ...
    let program = "G21 G90\nG0 X100.5 Y20.\nX50.\n";
    let out = compensate(program).unwrap();
    assert_eq!(out, program);
    // ... and a feed move, whose real path is not known, is refused.
    let err = compensate("G21 G90\nG1 X100.5 Y20. F500.\nX50.\n").unwrap_err();
    assert!(
        err.contains(
            "p.nc:2:4: a feed move while axis X, Y, Z, A, C stands where the program has not set it"
        ),
        "{err}"
    );
    // Once set, an axis takes its share of the correction.
    let out = compensate("G21 G90\nG0 X0 Y0 Z50. A-30. C10.\nG1 X100.5 Y20. F500.\n").unwrap();
    let last = out.lines().nth(2).unwrap();
    assert!(last.contains('Z') && last.contains('A'), "{out}");
}

#[test]
fn unsupported_blocks_are_errors_with_line_and_column() {
    for (program, needle) in [
        (
            "G0 X10 Y0 Z5 A-20 C0\nG2 X20 Y10 I5 J0\n",
            "p.nc:2:1: this arc cannot be compensated: its end is not on its circle",
        ),
        ("G92 X0\n", "p.nc:1:1: G92 cannot be compensated"),
        ("G1 X[#1+2]\n", "p.nc:1:4: X is given by an expression"),
        ("G1 X#5\n", "p.nc:1:4: X is given by a parameter"),
        ("G43.1 Z2\n", "p.nc:1:1: G43.1 cannot be compensated"),
        (
            "G0 X0 Y0 Z5 A0 C0\nG81 X1 Y1 Z-2 R1 A5\n",
            "p.nc:2:18: A words in a canned cycle cannot be compensated",
        ),
        ("G1 X1 U3\n", "p.nc:1:7: U is not an axis"),
        (
            "o100 sub\nG1 X1\no100 endsub\n",
            "p.nc:1:1: O-word control flow",
        ),
        ("G1 X1 X2\n", "p.nc:1:7: X appears twice"),
        ("M98 P100\n", "p.nc:1:1: M98 cannot be compensated"),
    ] {
        let err = compensate(program).unwrap_err();
        assert!(err.contains(needle), "{program:?}: {err}");
    }
    // An expression nested 400,000 deep is refused, not read down the stack.
    let deep = format!("G1 B{}1{}\n", "[".repeat(400_000), "]".repeat(400_000));
    let err = compensate(&deep).unwrap_err();
    let head: String = err.chars().take(300).collect();
    assert!(
        err.contains("p.nc:1:4: B is given by an expression nccomp does not evaluate"),
        "{head}"
    );
    assert!(err.contains("nested more than 64 deep"), "{head}");
    // One that is constant is evaluated.
    let out = compensate("G0 X[10+2.5] Y0 Z5 A-20 C0\n").unwrap();
    assert!(out.starts_with("G0 X12.5"), "{out}");
}

#[test]
fn inch_programs_are_compensated_in_inch() {
    let out = compensate("G20 G0 X4.0 Y2.0 Z1.0 A-20.0 C30.0\n").unwrap();
    // Inch words get inch resolution (6 decimals for 0.0001 mm).
    let x = out.split_whitespace().find(|w| w.starts_with('X')).unwrap();
    assert_eq!(x.split('.').nth(1).unwrap().len(), 6, "{out}");
    let value: f64 = x[1..].parse().unwrap();
    assert!((value - 4.0).abs() < 0.01 && value != 4.0, "{out}");
}

fn compensate_with(
    program: &str,
    options: Options,
) -> Result<(String, nccomp::compensate::Summary), String> {
    let machine = machine();
    let errors = random_errors(&machine, &mut Lcg(7));
    let comp = Compensator::new(&machine, &errors, options).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out)
        .map(|s| (String::from_utf8(out).unwrap(), s))
        .map_err(|e| e.to_string())
}

#[test]
fn an_axis_at_its_travel_limit_is_held_there_and_the_tip_still_lands() {
    // A is programmed exactly at its limit of −120°: a correction past it is not written.
    let program = "G0 X10 Y20 Z30 A-120 C45\nG1 X50 A-119.99995\n";
    let (out, summary) = compensate_with(program, Options::default()).unwrap();
    let machine = machine();
    let errors = random_errors(&machine, &mut Lcg(7));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    for (qn, qa) in axis_states(program).iter().zip(axis_states(&out)) {
        assert!(qa[3] >= -120.0, "{out}");
        let (target, _) = kin.pose(Model::Nominal, qn, 0.0);
        let (reached, _) = kin.pose(Model::Actual, &qa, 0.0);
        assert!(reached.deviation(&target).0 < 1e-3, "{out}");
    }
    assert!(
        !summary.at_limit.is_empty() || out.lines().next().unwrap().contains("A-120 "),
        "{out}"
    );
    // A program that itself leaves the travel is refused.
    let err = compensate_with("G0 X10 A-125\n", Options::default()).unwrap_err();
    assert!(
        err.contains("p.nc:1:8: axis A is programmed to -125.0000, outside its travel"),
        "{err}"
    );
}

#[test]
fn optional_blocks_never_change_what_the_program_does_with_block_delete_on() {
    // Line 3 would need an X word only because of the optional line 2: refused.
    let err = compensate_with(
        "G0 X0 Y0 Z50 A-30 C0\n/G1 X20\nG1 Y20\n",
        Options::default(),
    )
    .unwrap_err();
    assert!(
        err.contains("p.nc:3:4:") && err.contains("optional block (/) at line 2"),
        "{err}"
    );
    // Programming the axis again makes it certain.
    let (out, _) = compensate_with(
        "G0 X0 Y0 Z50 A-30 C0\n/G1 X20\nG1 X20 Y20\n",
        Options::default(),
    )
    .unwrap();
    assert_eq!(out.lines().count(), 3);
}

#[test]
fn held_axes_are_not_reported_as_singular() {
    let options = Options {
        hold: vec!["C".into()],
        ..Options::default()
    };
    let (out, summary) = compensate_with("G0 X10 Y20 Z30 A-40 C45\n", options).unwrap();
    assert!(
        out.contains("C45\n") || out.contains("C45 "),
        "C keeps its value: {out}"
    );
    assert_eq!(summary.singular_blocks, 0);
    // The direction error C would have fixed is reported, not hidden.
    assert!(
        summary.after_direction.value > 1e-6,
        "{}",
        summary.after_direction.value
    );
}

#[test]
fn holding_every_axis_leaves_the_program_as_it_is() {
    let m = machine();
    let errors = random_errors(&m, &mut Lcg(5));
    let options = Options {
        hold: ["X", "Y", "Z", "A", "C"].map(String::from).to_vec(),
        ..Options::default()
    };
    let comp = Compensator::new(&m, &errors, options).unwrap();
    let program = "G21 G90\nG0 X1. Y1. Z50. A-10. C20.\nG1 X10. F100.\n";
    let mut out = Vec::new();
    let summary = comp.run(program.as_bytes(), "p.nc", &mut out).unwrap();
    assert_eq!(String::from_utf8(out).unwrap(), program);
    // Nothing could be corrected: the error is reported as it is.
    assert!(summary.after_position.value > 1e-3, "{summary}");
}

/// A rotary word is written to 0.001° on this machine: at 100 mm from the axis that alone
/// moves the tip by up to 0.9 µm. The linear axes take it up, so every block end is within
/// the linear words' rounding (0.1 µm), as on a machine with finer rotary words.
#[test]
fn the_linear_axes_take_up_the_rounding_of_the_rotary_words() {
    let mut machine = machine();
    machine.resolution.rotary = 0.001;
    for seed in 1..=4u64 {
        let mut rng = Lcg(seed);
        let errors = random_errors(&machine, &mut rng);
        let program = random_program(&mut rng, 200);
        let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
        let mut out = Vec::new();
        comp.run(program.as_bytes(), "random.nc", &mut out).unwrap();
        let out = String::from_utf8(out).unwrap();
        let kin = Kinematics::new(&machine, &errors, 0).unwrap();
        let mut worst = 0.0f64;
        let moves = program.lines().map(|l| {
            l.split('(')
                .next()
                .unwrap()
                .split_whitespace()
                .any(|w| "XYZAC".contains(&w[..1]))
        });
        let states = axis_states(&program).into_iter().zip(axis_states(&out));
        for ((qn, qa), _) in states.zip(moves).filter(|(_, m)| *m) {
            let (qn, qa) = (&qn, &qa);
            let (target, _) = kin.pose(Model::Nominal, qn, 0.0);
            let (reached, _) = kin.pose(Model::Actual, qa, 0.0);
            worst = worst.max((reached.p - target.p).norm());
        }
        // √3 · 0.05 µm of linear rounding, and a little for the rotary words' effect on the
        // error model itself.
        assert!(worst < 1.0e-4, "seed {seed}: a block end is {worst} mm off");
    }
}

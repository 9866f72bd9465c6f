//! The modal state of the compensation pass: G90/G91 distance modes, machine-coordinate
//! moves (G53) and reference returns (G28/G30) that leave axes at unknown positions, and
//! feed modes. Each output is checked with this file's own small interpreter (exact
//! decimal arithmetic, its own reading of G90/G91/G20/G53/G28) and the model evaluated at
//! the values the output makes the machine go to.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nccomp::compensate::{Compensator, Options, Summary};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{ErrorModel, Machine, MotionTable, error_file, machine_file};
use std::path::Path;

fn machine() -> Machine {
    let mut m = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    m.axes[3].travel = Some([-120.0, 30.0]);
    m
}

fn run(machine: &Machine, errors: &ErrorModel, program: &str) -> Result<(String, Summary), String> {
    let comp = Compensator::new(machine, errors, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "p.nc", &mut out)
        .map(|s| (String::from_utf8(out).unwrap(), s))
        .map_err(|e| e.to_string())
}

/// With paper-sized random errors (seed 7).
fn compensate(program: &str) -> Result<(String, Summary), String> {
    let m = machine();
    run(&m, &random_errors(&m, &mut Lcg(7)), program)
}

// ---------------------------------------------------------------------------------------
// An interpreter of this test's own: exact positions in units of 1e-12 mm or degree.
// ---------------------------------------------------------------------------------------

const UNIT: f64 = 1e12;
const LETTERS: &str = "XYZAC";

/// A number's text as units (inch converted exactly for linear axes).
fn units(text: &str, inch: bool) -> i128 {
    let (negative, t) = match text.as_bytes()[0] {
        b'-' => (true, &text[1..]),
        b'+' => (false, &text[1..]),
        _ => (false, text),
    };
    let (int, frac) = t.split_once('.').unwrap_or((t, ""));
    assert!(frac.len() <= 11, "{text}: too many decimals for the test");
    let digits = format!("{}{frac}", if int.is_empty() { "0" } else { int });
    let mut u: i128 = digits.parse::<i128>().unwrap() * 10i128.pow(12 - frac.len() as u32);
    if inch {
        u = u * 254 / 10;
    }
    if negative { -u } else { u }
}

/// The words of a line (comments and a block delete `/` removed): (letter, number text).
fn words(line: &str) -> Vec<(char, String)> {
    let mut clean = String::new();
    let mut depth = 0;
    for c in line.chars() {
        if c == ';' && depth == 0 {
            break;
        }
        if c == '(' {
            depth += 1;
        }
        if depth == 0 && c != '/' && c != '%' {
            clean.push(c);
        }
        if c == ')' {
            depth -= 1;
        }
    }
    let mut out = Vec::new();
    let mut chars = clean.chars().peekable();
    while let Some(c) = chars.next() {
        if !c.is_ascii_alphabetic() {
            continue;
        }
        while chars.peek() == Some(&' ') {
            chars.next();
        }
        let mut number = String::new();
        while let Some(&d) = chars.peek() {
            if d.is_ascii_digit() || d == '.' || d == '-' || d == '+' {
                number.push(d);
                chars.next();
            } else {
                break;
            }
        }
        out.push((c.to_ascii_uppercase(), number));
    }
    out
}

/// What the test's interpreter makes of one line.
#[derive(Debug, Clone, PartialEq)]
struct Row {
    /// Axis positions after the line (units); meaningful where `known`.
    q: [i128; 5],
    known: [bool; 5],
    /// The line is a G0/G1 move with axis words.
    moves: bool,
    /// The line is G53 or G28/G30.
    special: bool,
}

fn interpret(program: &str) -> Vec<Row> {
    let (mut q, mut known) = ([0i128; 5], [true; 5]);
    let (mut inch, mut incremental) = (false, false);
    let mut rows = Vec::new();
    for line in program.lines() {
        let words = words(line);
        let g: Vec<i64> = words
            .iter()
            .filter(|(l, _)| *l == 'G')
            .map(|(_, n)| (n.parse::<f64>().unwrap() * 10.0).round() as i64)
            .collect();
        for &code in &g {
            match code {
                200 => inch = true,
                210 => inch = false,
                900 => incremental = false,
                910 => incremental = true,
                _ => {}
            }
        }
        let axes: Vec<(usize, &String)> = words
            .iter()
            .filter_map(|(l, n)| LETTERS.find(*l).map(|k| (k, n)))
            .collect();
        let home = g.contains(&280) || g.contains(&300);
        let special = home || g.contains(&530);
        if special {
            for &(k, _) in &axes {
                known[k] = false;
            }
            if home && axes.is_empty() {
                known = [false; 5];
            }
        } else {
            for &(k, n) in &axes {
                let u = units(n, inch && k < 3);
                if incremental {
                    q[k] += u;
                } else {
                    q[k] = u;
                    known[k] = true;
                }
            }
        }
        rows.push(Row {
            q,
            known,
            moves: !special && !axes.is_empty(),
            special,
        });
    }
    rows
}

fn to_f64(q: &[i128; 5]) -> [f64; 5] {
    q.map(|u| u as f64 / UNIT)
}

/// What the model says of an output, block by block.
#[derive(Debug, Default)]
struct Checked {
    poses: usize,
    singular: usize,
    untouched: usize,
    worst_before: f64,
    worst_tip: f64,
    worst_direction: f64,
}

/// Evaluate every programmed pose of `output` against `input`: the tip within 1 µm and
/// the direction within 10 µrad, except at singular poses (A within 3° of 0), where C
/// keeps its programmed value exactly. G53/G28/G30 blocks and blocks with an unknown axis
/// must be left byte for byte.
fn check(machine: &Machine, errors: &ErrorModel, input: &str, output: &str) -> Checked {
    let kin = Kinematics::new(machine, errors, 0).unwrap();
    let length = machine.tool.length;
    let (rin, rout) = (interpret(input), interpret(output));
    let (lin, lout): (Vec<&str>, Vec<&str>) = (input.lines().collect(), output.lines().collect());
    assert_eq!(rin.len(), rout.len(), "no line goes missing");
    let mut c = Checked::default();
    for (i, (n, a)) in rin.iter().zip(&rout).enumerate() {
        let line = i + 1;
        assert_eq!(n.known, a.known, "line {line}: {}", lout[i]);
        if n.special || (n.moves && n.known.contains(&false)) {
            assert_eq!(lin[i], lout[i], "line {line}: must be left as it is");
            c.untouched += 1;
            continue;
        }
        if !n.moves {
            continue;
        }
        let (qn, qa) = (to_f64(&n.q), to_f64(&a.q));
        let (target, _) = kin.pose(Model::Nominal, &qn, length);
        let (before, _) = kin.pose(Model::Actual, &qn, length);
        let (reached, _) = kin.pose(Model::Actual, &qa, length);
        let (dp, dd) = reached.deviation(&target);
        c.poses += 1;
        c.worst_before = c.worst_before.max(before.deviation(&target).0);
        c.worst_tip = c.worst_tip.max(dp);
        assert!(
            dp < 1e-3,
            "line {line}: tip off by {dp} mm: {} -> {}",
            lin[i],
            lout[i]
        );
        if qn[3].abs() < 3.0 {
            c.singular += 1;
            assert_eq!(
                a.q[4], n.q[4],
                "line {line}: C must not change at A = {}: {} -> {}",
                qn[3], lin[i], lout[i]
            );
        } else {
            c.worst_direction = c.worst_direction.max(dd);
            assert!(
                dd < 10e-6,
                "line {line}: direction off by {dd} rad: {} -> {}",
                lin[i],
                lout[i]
            );
        }
    }
    c
}

// ---------------------------------------------------------------------------------------
// Programs
// ---------------------------------------------------------------------------------------

/// A number of 1e-4 steps with 4 decimals.
fn fmt4(k: i64) -> String {
    let sign = if k < 0 { "-" } else { "" };
    let a = k.unsigned_abs();
    format!("{sign}{}.{:04}", a / 10_000, a % 10_000)
}

/// A random five-axis trajectory (positions in 1e-4 steps), as the same program twice:
/// in G90 and in G91 (each G91 word the difference of the G90 words).
fn trajectory(rng: &mut Lcg, blocks: usize) -> (String, String) {
    let head = "%\n(RANDOM TRAJECTORY)\nN10 G21 G90 G17\nN20 G0 X0 Y0 Z50. A-30. C0\n";
    let (mut g90, mut g91) = (head.to_string(), format!("{head}N25 G91\n"));
    g90.push_str("N25\n");
    let mut q: [i64; 5] = [0, 0, 500_000, -300_000, 0];
    for i in 0..blocks {
        let (mut w90, mut w91) = (Vec::new(), Vec::new());
        for (k, letter) in LETTERS.chars().enumerate() {
            if rng.next() >= 0.5 && !(i == 0 && k == 0) {
                continue;
            }
            let small = rng.next() < 0.3;
            let next = if small {
                q[k] + (rng.sym(200.0)) as i64
            } else {
                let x = match k {
                    0 | 1 => rng.sym(150.0),
                    2 => 20.0 + rng.next() * 100.0,
                    3 if rng.next() < 0.15 => rng.sym(2.0).round(),
                    3 => -100.0 + rng.next() * 125.0,
                    _ => rng.sym(400.0),
                };
                (x * 1e4).round() as i64
            };
            let next = if k == 3 {
                next.clamp(-1_000_000, 250_000)
            } else {
                next
            };
            w90.push(format!("{letter}{}", fmt4(next)));
            w91.push(format!("{letter}{}", fmt4(next - q[k])));
            q[k] = next;
        }
        if w90.is_empty() {
            continue;
        }
        let g = if i % 5 == 0 { "G1 " } else { "" };
        g90.push_str(&format!("N{} {g}{}\n", 30 + i, w90.join(" ")));
        g91.push_str(&format!("N{} {g}{}\n", 30 + i, w91.join(" ")));
    }
    g90.push_str("M30\n%\n");
    g91.push_str("M30\n%\n");
    (g90, g91)
}

/// A program that switches between G90 and G91 and between mm and inch as it goes, with
/// words of 3 decimals (mm) and 4 (inch).
fn mixed_program(rng: &mut Lcg, blocks: usize) -> String {
    let mut s = String::from("%\n(MIXED MODES)\nN10 G21 G90 G17\nN20 G0 X0 Y0 Z50. A-20. C0\n");
    // The program's own position, mm and degrees.
    let mut q = [0.0, 0.0, 50.0, -20.0, 0.0];
    let (mut inch, mut incremental) = (false, false);
    for i in 0..blocks {
        let mut words = Vec::new();
        if rng.next() < 0.08 {
            incremental = !incremental;
            words.push(if incremental { "G91" } else { "G90" }.to_string());
        }
        if rng.next() < 0.04 {
            inch = !inch;
            words.push(if inch { "G20" } else { "G21" }.to_string());
        }
        if i % 6 == 0 {
            words.push("G1".into());
        }
        for (k, letter) in LETTERS.chars().enumerate() {
            if rng.next() >= 0.5 {
                continue;
            }
            let target = match k {
                0 | 1 => rng.sym(150.0),
                2 => 20.0 + rng.next() * 100.0,
                3 if rng.next() < 0.15 => rng.sym(2.0).round(),
                3 => -100.0 + rng.next() * 125.0,
                _ => rng.sym(360.0),
            };
            let linear_inch = inch && k < 3;
            let scale = if linear_inch { 25.4 } else { 1.0 };
            let decimals = if linear_inch { 4 } else { 3 };
            let value = (if incremental { target - q[k] } else { target }) / scale;
            let text = format!("{value:.decimals$}");
            let written: f64 = text.parse::<f64>().unwrap() * scale;
            q[k] = if incremental { q[k] + written } else { written };
            words.push(format!("{letter}{text}"));
        }
        if words.is_empty() {
            continue;
        }
        // A block without axis words still switches modes.
        s.push_str(&format!("N{} {}\n", 30 + 10 * i, words.join(" ")));
    }
    s.push_str("N99999 M30\n%\n");
    s
}

// ---------------------------------------------------------------------------------------
// G91
// ---------------------------------------------------------------------------------------

#[test]
fn g91_output_lands_exactly_where_the_g90_output_does() {
    let m = machine();
    for seed in 1..=4u64 {
        let mut rng = Lcg(seed);
        let errors = random_errors(&m, &mut rng);
        let (g90, g91) = trajectory(&mut rng, 250);
        assert_eq!(interpret(&g90), interpret(&g91), "the same program twice");
        let (out90, _) = run(&m, &errors, &g90).unwrap();
        let (out91, summary) = run(&m, &errors, &g91).unwrap();
        // Block by block the written G91 increments add up to exactly the G90 positions.
        for (i, (a, b)) in interpret(&out90).iter().zip(interpret(&out91)).enumerate() {
            assert_eq!(
                a.q,
                b.q,
                "seed {seed} line {}: {} / {}",
                i + 1,
                out90.lines().nth(i).unwrap(),
                out91.lines().nth(i).unwrap()
            );
        }
        let c = check(&m, &errors, &g91, &out91);
        assert!(
            c.worst_before > 5e-3,
            "the errors matter ({})",
            c.worst_before
        );
        assert!(c.singular > 0 && c.poses > 200, "{c:?}");
        assert!(summary.words_changed > 0 && summary.words_added > 0);
        assert!((summary.after_position.value - c.worst_tip).abs() < 1e-9);
    }
}

#[test]
fn programs_switching_g90_g91_mm_and_inch_reach_every_programmed_pose() {
    let m = machine();
    for seed in 11..=16u64 {
        let mut rng = Lcg(seed);
        let errors = random_errors(&m, &mut rng);
        let program = mixed_program(&mut rng, 200);
        assert!(
            program.contains("G91") && program.contains("G20"),
            "{program}"
        );
        let (out, _) = run(&m, &errors, &program).unwrap();
        let c = check(&m, &errors, &program, &out);
        assert!(c.poses > 150 && c.worst_direction > 0.0, "{c:?}");
    }
}

/// A million incremental moves (one axis per block, in turn X, Y, Z, C) on the five-axis
/// machine: the written increments add up exactly to the rounded compensated position of
/// the last block, the one a G90 block at the same pose gets.
///
/// A debug build compensates about 2,000 five-axis blocks a second, so there the test runs
/// 5,000 blocks; `cargo test --release --test compensate_modal` runs the full million. (The
/// arithmetic alone is also checked over a million blocks in debug builds:
/// `compensate::exact::tests::a_million_increments_do_not_drift`.)
#[test]
fn a_million_incremental_moves_do_not_drift() {
    const BLOCKS: usize = if cfg!(debug_assertions) {
        5_000
    } else {
        1_000_000
    };
    let m = machine();
    let errors = random_errors(&m, &mut Lcg(3));
    let steps = ["X0.0003", "Y0.0002", "Z-0.0001", "C0.0002"];
    let mut program = String::with_capacity(BLOCKS * 9 + 64);
    program.push_str("G21 G90 G0 X-100. Y-80. Z60. A-30. C10.\nG91 G1 F500\n");
    for i in 0..BLOCKS {
        program.push_str(steps[i % 4]);
        program.push('\n');
    }
    let (out, summary) = run(&m, &errors, &program).unwrap();
    assert_eq!(summary.motion_blocks, BLOCKS + 1);
    assert!(summary.words_added > 0, "corrections change along the way");
    // The sum of everything written, exactly (and the nominal end, exactly).
    let rows = interpret(&out);
    let end = rows.last().unwrap().q;
    let nominal = interpret(&program).last().unwrap().q;
    let n = (BLOCKS / 4) as i128;
    assert_eq!(
        nominal,
        [
            units("-100", false) + n * units("0.0003", false),
            units("-80", false) + n * units("0.0002", false),
            units("60", false) - n * units("0.0001", false),
            units("-30", false),
            units("10", false) + n * units("0.0002", false)
        ]
    );
    // The same pose programmed absolutely, in one block.
    let words: Vec<String> = LETTERS
        .chars()
        .zip(nominal)
        .map(|(l, u)| format!("{l}{}", fmt4((u / 100_000_000) as i64)))
        .collect();
    let (reference, _) = run(&m, &errors, &format!("G0 {}\n", words.join(" "))).unwrap();
    assert_eq!(end, interpret(&reference)[0].q, "{reference}");
    // Every line is there, and each is a single-axis move or more.
    assert_eq!(out.lines().count(), program.lines().count());
}

/// An error model with one constant error: the Z slide is 5 µm long everywhere (EZZ).
/// Whatever the pose, the correction is Z − 0.005, so in G91 no increment changes.
fn constant_z_error(m: &Machine) -> ErrorModel {
    let mut e = ErrorModel::zero(m);
    e.axes[2].motion = Some(MotionTable {
        positions: vec![-500.0, 500.0],
        values: [None, None, Some(vec![0.005, 0.005]), None, None, None],
        periodic: false,
    });
    e
}

/// Z straightness of X (EZX) growing by 1 µm per 10 mm of X: moving X in G91 needs a Z
/// increment.
fn sloped_z_of_x(m: &Machine) -> ErrorModel {
    let mut e = ErrorModel::zero(m);
    e.axes[0].motion = Some(MotionTable {
        positions: vec![-500.0, 500.0],
        values: [None, None, Some(vec![-0.05, 0.05]), None, None, None],
        periodic: false,
    });
    e
}

#[test]
fn incremental_words_keep_their_bytes_when_their_increment_prints_the_same() {
    let m = machine();
    let program = "N1 G90 G0 X0 Y0 Z50. A0 C0\n\
                   N2 G91 G1 X10. F500\n\
                   N3 y-5 (lower case, no point)\n\
                   N4 Z-5.\n\
                   N5 A-10. C33.3\n\
                   N6 X-0.0001 Z0.00005\n\
                   N7 G90 Z40.\n\
                   N8 G91 X1.\n";
    let (out, summary) = run(&m, &constant_z_error(&m), program).unwrap();
    let expected = "N1 G90 G0 X0 Y0 Z49.9950 A0 C0\n\
                    N2 G91 G1 X10. F500\n\
                    N3 y-5 (lower case, no point)\n\
                    N4 Z-5.\n\
                    N5 A-10. C33.3\n\
                    N6 X-0.0001 Z0.00005\n\
                    N7 G90 Z39.9950\n\
                    N8 G91 X1.\n";
    assert_eq!(out, expected);
    assert_eq!((summary.words_changed, summary.words_added), (2, 0));
}

#[test]
fn an_axis_the_g91_block_omits_gets_a_word_when_its_increment_is_not_zero() {
    let m = machine();
    let errors = sloped_z_of_x(&m);
    let program = "G90 G0 X0 Y0 Z50. A-30. C0\nG91 G1 X10.\nX10.\nX-20.\nY5.\n";
    let (out, summary) = run(&m, &errors, program).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    // 1 µm of Z per 10 mm of X (the sign is the model's), written as increments that
    // return to where they started.
    let z = |line: &str| -> i128 {
        let w = words(line);
        w.iter()
            .find(|(l, _)| *l == 'Z')
            .map_or(0, |(_, n)| units(n, false))
    };
    assert!(lines[1].starts_with("G91 G1 X10. Z"), "{out}");
    assert_eq!(z(lines[1]).abs(), units("0.001", false), "{out}");
    assert_eq!(z(lines[2]), z(lines[1]), "{out}");
    assert_eq!(z(lines[3]), -2 * z(lines[1]), "{out}");
    assert_eq!(lines[4], "Y5.", "nothing to add: {out}");
    assert_eq!(summary.words_added, 3);
    let c = check(&m, &errors, program, &out);
    assert_eq!(c.poses, 5);
}

#[test]
fn an_inch_g91_program_is_compensated_in_inch() {
    let m = machine();
    let errors = random_errors(&m, &mut Lcg(7));
    let program = "G20 G90 G0 X1. Y-1. Z2. A-20. C30.\n\
                   G91 G1 X0.5 F20.\n\
                   Y0.25 C10.\n\
                   Z-0.1 A-5.\n\
                   G21 X5.\n\
                   G20 X-0.2\n";
    let (out, _) = run(&m, &errors, program).unwrap();
    let c = check(&m, &errors, program, &out);
    assert_eq!(c.poses, 6);
    // Changed inch words get inch resolution (6 decimals for 0.0001 mm).
    let x = words(out.lines().nth(1).unwrap())
        .into_iter()
        .find(|(l, _)| *l == 'X')
        .unwrap()
        .1;
    assert_eq!(x.split('.').nth(1).unwrap().len(), 6, "{out}");
}

#[test]
fn an_axis_moved_in_g91_before_the_program_set_it_stays_unknown() {
    // An increment from where the operator left the axes ends where nobody knows: a
    // rapid passes as it is, a feed move is refused.
    let program = "G91 G0 X10. Y5. Z-2. A-30. C5.\nX1.\n";
    let (out, summary) = compensate(program).unwrap();
    assert_eq!(out, program);
    assert_eq!(summary.uncompensated_blocks, 2, "{summary}");
    let err = compensate("G91 G1 X10. Y5. Z-2. A-30. C5.\nX1.\n").unwrap_err();
    assert!(
        err.contains(
            "p.nc:1:8: a feed move while axis X, Y, Z, A, C stands where the program has not set it"
        ),
        "{err}"
    );
}

// ---------------------------------------------------------------------------------------
// Block delete with G91
// ---------------------------------------------------------------------------------------

#[test]
fn optional_blocks_in_g91_are_refused_with_a_reason() {
    let start = "G0 X0 Y0 Z50. A-30. C0\n";
    for (program, needle) in [
        (
            format!("{start}G91\n/G1 X5.\n"),
            "p.nc:3:5: an optional block (/) in incremental mode (G91) cannot be compensated",
        ),
        (
            format!("{start}/G91 G1 X5.\n"),
            "p.nc:2:2: G91 in an optional block (/) cannot be compensated",
        ),
        (
            format!("{start}G91\n/G90 G1 X5.\n"),
            "p.nc:3:2: G90 in an optional block (/) cannot be compensated",
        ),
        // X's start depends on whether the optional block ran.
        (
            format!("{start}/G1 X20.\nG91 G1 X5. Y1.\n"),
            "p.nc:3:8: this incremental (G91) block moves X, but X was last set by the optional block (/) at line 2",
        ),
        (
            format!("{start}/G1 X20.\nG91 G1 Y5.\n"),
            "p.nc:3:8: this incremental (G91) block needs a corrected X, but X was last set by the optional block (/) at line 2",
        ),
    ] {
        let err = compensate(&program).unwrap_err();
        assert!(err.contains(needle), "{program:?}: {err}");
    }
    // An optional block that keeps to the mode is fine, and so is a G91 block that
    // neither moves nor corrects an axis an optional block set.
    let (out, _) = compensate(&format!("{start}/G90 G1 X5.\nG1 X5. Y2.\n")).unwrap();
    assert_eq!(out.lines().count(), 3);
    let m = machine();
    let program = format!("{start}/G1 X20.\nG91 G1 Y5.\n");
    let (out, _) = run(&m, &constant_z_error(&m), &program).unwrap();
    assert_eq!(out.lines().nth(2).unwrap(), "G91 G1 Y5.");
}

// ---------------------------------------------------------------------------------------
// G53, G28, G30: axes at unknown positions
// ---------------------------------------------------------------------------------------

#[test]
fn g53_and_g28_leave_their_axes_unknown_until_a_g90_block_programs_them() {
    let program = "G0 X-40. Y-30. Z50. A-20. C30.\n\
                   G53 G0 Z0\n\
                   G0 X-40. Y30.\n\
                   G91 Z-10.\n\
                   G90 G0 Z40.\n\
                   G1 X0 Y0 A-30. C90.\n\
                   G91 G28 Z0\n\
                   G90 G0 X20.\n\
                   Z45.\n\
                   G28\n\
                   G0 X10. Y0 Z60.\n\
                   G0 X0 Y0 Z60. A-10. C0\n\
                   G30 A0\n\
                   G0 X5.\n\
                   G0 A-10.\n";
    let (out, summary) = compensate(program).unwrap();
    let (lin, lout): (Vec<&str>, Vec<&str>) = (program.lines().collect(), out.lines().collect());
    assert_eq!(lin.len(), lout.len());
    for i in [1, 2, 3, 6, 7, 9, 10, 12, 13] {
        assert_eq!(lin[i], lout[i], "line {} is left as it is", i + 1);
    }
    for i in [0, 4, 5, 8, 11, 14] {
        assert_ne!(lin[i], lout[i], "line {} is compensated", i + 1);
    }
    // Lines 3, 4 (Z unknown: G53), 8 (Z: G28), 11 (all: G28), 14 (A: G30).
    assert_eq!(summary.uncompensated_blocks, 5, "{summary}");
    assert_eq!(summary.first_uncompensated, 3);
    assert_eq!(summary.unknown_axes, ["Z", "A", "C"]);
    assert_eq!(summary.motion_blocks, 6);
    assert!(
        summary.to_string().contains(
            "note: 5 blocks (first at line 3) were written uncompensated: axes Z, A, C were at a position nccomp does not know (at the program's start, or after G28, G30, G53, a machine move code or a tool change) until a G90 block programmed them"
        ),
        "{summary}"
    );
    let m = machine();
    let c = check(&m, &random_errors(&m, &mut Lcg(7)), program, &out);
    assert_eq!((c.poses, c.untouched), (6, 9), "{c:?}");
}

#[test]
fn harmless_reference_codes_pass_and_g92_stays_refused() {
    // G28.1/G30.1 store a position and G53 alone does nothing: the next block is
    // compensated as usual.
    let program = "G28.1\nG30.1\nG53\nG0 X10. Y20. Z30. A-40. C45.\n";
    let (out, summary) = compensate(program).unwrap();
    assert_eq!(
        out.lines().take(3).collect::<Vec<_>>(),
        ["G28.1", "G30.1", "G53"]
    );
    assert_ne!(out.lines().nth(3).unwrap(), "G0 X10. Y20. Z30. A-40. C45.");
    assert_eq!(
        (summary.motion_blocks, summary.uncompensated_blocks),
        (1, 0)
    );
    for (program, needle) in [
        ("G92 X0 Y0\n", "p.nc:1:1: G92 cannot be compensated"),
        (
            "G28.1 X10.\n",
            "p.nc:1:1: G28.1 with axis words cannot be compensated",
        ),
    ] {
        let err = compensate(program).unwrap_err();
        assert!(err.contains(needle), "{program:?}: {err}");
    }
}

#[test]
fn an_optional_block_cannot_make_an_unknown_axis_known() {
    // Z is known after the optional block only when it runs: a rapid that leaves Z there
    // ends at a pose to correct with block delete off and an unknown one with it on.
    for program in [
        "G0 X0 Y0 Z50. A-30. C0\nG28 Z0\n/G0 Z40.\nG0 X10.\nG0 Z40.\nG1 X20.\n",
        "G0 X0 Y0 Z50. A-30. C0\nG28\n/G0 Z40.\nG0 X10. Y0 A-30. C0\nG1 X20.\n",
    ] {
        let err = compensate(program).unwrap_err();
        assert!(
            err.contains("p.nc:4:")
                && err.contains(
                    "this rapid leaves axis Z where the optional block (/) at line 3 put it"
                ),
            "{program:?}: {err}"
        );
    }
    // Programmed again in a block of its own, Z is known in both states.
    let program = "G0 X0 Y0 Z50. A-30. C0\nG28 Z0\n/G0 Z40.\nG0 Z40.\nG0 X10.\nG1 X20.\n";
    let (out, summary) = compensate(program).unwrap();
    let lines: Vec<&str> = out.lines().collect();
    assert_ne!(
        lines[2], "/G0 Z40.",
        "corrected: it ends at a known pose when it runs"
    );
    assert!(lines[2].starts_with('/'), "{out}");
    assert_ne!(lines[3], "G0 Z40.");
    assert_ne!(lines[5], "G1 X20.");
    assert_eq!(summary.uncompensated_blocks, 0);
}

// ---------------------------------------------------------------------------------------
// Feed modes
// ---------------------------------------------------------------------------------------

#[test]
fn inverse_time_feed_words_are_left_byte_for_byte() {
    let program = "G21 G90 G93\n\
                   G0 X-20. Y10. Z40. A-25. C10.\n\
                   G1 X-20. Y10. Z40. A-25. C10. F120.5\n\
                   X-10. A-20. C20. F240\n\
                   X0 Y0 C35. f 95.25\n\
                   G94 X5. F800.\n\
                   G95 Y5. F0.12\n";
    let (out, summary) = compensate(program).unwrap();
    assert!(summary.words_changed > 0 && summary.motion_blocks == 6);
    let feeds = |p: &str| -> Vec<Vec<String>> {
        p.lines()
            .map(|l| {
                words(l)
                    .into_iter()
                    .filter(|(c, _)| *c == 'F')
                    .map(|(_, n)| n)
                    .collect()
            })
            .collect()
    };
    assert_eq!(feeds(&out), feeds(program));
    assert!(
        out.contains(" F120.5\n") && out.contains(" f 95.25\n"),
        "{out}"
    );
    let m = machine();
    check(&m, &random_errors(&m, &mut Lcg(7)), program, &out);
}

// ---------------------------------------------------------------------------------------
// Fixtures: snapshot, zero model, command line
// ---------------------------------------------------------------------------------------

fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}

fn ac_fixture() -> (Machine, ErrorModel) {
    let m = machine_file::load(&fixtures().join("ac_trunnion.machine.toml")).unwrap();
    let e = error_file::load(&fixtures().join("ac_trunnion.errors.toml"), &m).unwrap();
    (m, e)
}

#[test]
fn ac_trunnion_g91_demo() {
    let (m, e) = ac_fixture();
    let src = std::fs::read_to_string(fixtures().join("ac_trunnion_g91.nc")).unwrap();
    let comp = Compensator::new(&m, &e, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp
        .run(src.as_bytes(), "ac_trunnion_g91.nc", &mut out)
        .unwrap();
    let out = String::from_utf8(out).unwrap();
    let c = check(&m, &e, &src, &out);
    assert!(c.poses > 20 && c.untouched == 2, "{c:?}");
    insta::assert_snapshot!(format!("{summary}\n----\n{out}"));
}

#[test]
fn a_zero_model_gives_the_modal_fixtures_back_byte_for_byte() {
    let (m, _) = ac_fixture();
    let comp = Compensator::new(&m, &ErrorModel::zero(&m), Options::default()).unwrap();
    for name in ["ac_trunnion_g91.nc", "ac_trunnion_g28_g53.nc"] {
        let src = std::fs::read(fixtures().join(name)).unwrap();
        let mut out = Vec::new();
        comp.run(&src, name, &mut out).unwrap();
        assert_eq!(out, src, "{name}");
    }
}

#[test]
fn the_command_line_runs_a_program_with_g53_and_g28() {
    let output = std::process::Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args([
            "compensate",
            "-m",
            "fixtures/ac_trunnion.machine.toml",
            "-e",
            "fixtures/ac_trunnion.errors.toml",
            "fixtures/ac_trunnion_g28_g53.nc",
            // Lines are compared one to one below.
            "--tolerance",
            "off",
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(0), "{stderr}");
    assert!(
        stderr
            .contains("were written uncompensated: axis Z was at a position nccomp does not know"),
        "{stderr}"
    );
    let input = std::fs::read_to_string(fixtures().join("ac_trunnion_g28_g53.nc")).unwrap();
    let written = String::from_utf8(output.stdout).unwrap();
    for (a, b) in input.lines().zip(written.lines()) {
        if a.contains("G53") || a.contains("G28") {
            assert_eq!(a, b);
        }
    }
    let (m, e) = ac_fixture();
    let c = check(&m, &e, &input, &written);
    assert!(c.poses >= 6 && c.untouched >= 7, "{c:?}");
}

#[test]
fn numbers_past_any_machine_are_refused_where_they_stand() {
    let huge = "9".repeat(310);
    for (program, at, what) in [
        (
            format!("G0 X0 Y0 Z50\nG1 X{huge} F100\n"),
            "p.nc:2:4",
            "X is too large to be a number",
        ),
        (
            "G0 X0 Y0 Z50\nG1 Y-2000000\n".to_string(),
            "p.nc:2:4",
            "Y is out of range",
        ),
        (
            format!("G0 X0 Y0 Z50\nG2 X1 Y1 R{huge}\n"),
            "p.nc:2:10",
            "R is too large to be a number",
        ),
    ] {
        let err = compensate(&program).unwrap_err();
        assert!(err.contains(at) && err.contains(what), "{err}");
    }
    // Block and program numbers may be as long as a program needs.
    compensate("O80000001\nN12000000 G0 X1 Y2 Z50\n").unwrap();
}

#[test]
fn another_controls_program_is_named_not_misread() {
    // A TNC block in a G-code program (a TNC program starts with BEGIN PGM).
    let err = compensate("G0 X0 Y0 Z50\n1 L X+10 Y-5 R0 FMAX\n").unwrap_err();
    assert!(
        err.contains("p.nc:2:1: this looks like a Heidenhain TNC conversational program"),
        "{err}"
    );
    // A Sinumerik program is read as one; read as G-code (--dialect iso) it is named.
    let m = machine();
    let errors = random_errors(&m, &mut Lcg(7));
    for program in [
        "N10 DEF REAL _Z_HOME\nN20 _Z_HOME=50\nN30 G0 X0 Y0 Z=_Z_HOME\n",
        "N10 G0 X0 Y0 Z50\nN20 TRAORI\n",
    ] {
        compensate(program).unwrap();
        let iso = Options {
            dialect: Some(nccomp::nc::Dialect::Iso),
            ..Options::default()
        };
        let err = Compensator::new(&m, &errors, iso)
            .unwrap()
            .run(program.as_bytes(), "p.nc", &mut Vec::new())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("this looks like a Sinumerik program")
                && err.contains("--dialect sinumerik"),
            "{err}"
        );
    }
    // A G-code block's comment is not a dialect: LinuxCNC's (MSG, …) stays G-code.
    let err = compensate("G0 X0 Y0 Z50\nG41 (MSG, cutter comp)\n").unwrap_err();
    assert!(err.contains("G41 cannot be compensated"), "{err}");
}

#[test]
fn a_byte_order_mark_is_kept_and_cr_only_lines_are_read_as_lines() {
    // A UTF-8 BOM says how the file is encoded: the program is read after it and written
    // with it.
    let (out, summary) = compensate("\u{feff}G21 G90\nG0 X1 Y2 Z50 A0 C0\nG1 X5\n").unwrap();
    assert!(out.starts_with("\u{feff}G21 G90\n"), "{out}");
    assert_eq!(summary.motion_blocks, 2);
    // Lines ended by CR alone are lines, their endings kept.
    let (out, summary) = compensate("G21 G90\rG0 X1 Y2 Z50 A0 C0\rG1 X5\r").unwrap();
    assert_eq!(summary.motion_blocks, 2);
    assert!(
        out.starts_with("G21 G90\rG0 X") && out.ends_with('\r'),
        "{out:?}"
    );
    assert_eq!(out.matches('\r').count(), 3, "{out:?}");
    assert!(!out.contains('\n'), "{out:?}");
}

#[test]
fn smoothing_modes_pass_and_a_final_m99_ends_the_program() {
    // Fanuc's high-speed and look-ahead modes, Haas's smoothing: no block end moves.
    let program =
        "G05P10000\nG05.1 Q1\nG08 P1\nG187 P2 E0.01\nG0 X1 Y2 Z50 A0 C0\nG1 X5\nG05P0\nM99\n";
    let (out, summary) = compensate(program).unwrap();
    assert_eq!(out.lines().count(), program.lines().count());
    assert!(
        out.starts_with("G05P10000\nG05.1 Q1\nG08 P1\nG187 P2 E0.01\n"),
        "{out}"
    );
    assert!(out.ends_with("G05P0\nM99\n"), "{out}");
    assert_eq!(summary.motion_blocks, 2);
    // The same numbers with axis words are LinuxCNC's splines: refused.
    let err = compensate("G0 X0 Y0 Z50\nG5 I1 J1 P1 Q1 X5 Y5\n").unwrap_err();
    assert!(err.contains("spline interpolation"), "{err}");
    // Nothing after M99 belongs to the program that ran.
    let err = compensate("G0 X0 Y0 Z50\nM99\nG1 X5\n").unwrap_err();
    assert!(
        err.contains("p.nc:3:1: this block follows the M99 at line 2"),
        "{err}"
    );
    // Calls stay refused.
    let err = compensate("G0 X0 Y0 Z50\nM98 P1000\n").unwrap_err();
    assert!(err.contains("a subprogram call (M97/M98)"), "{err}");
}

#[test]
fn a_program_that_never_states_its_units_is_read_in_the_machine_files_and_says_so() {
    let mut m = machine();
    let errors = random_errors(&m, &mut Lcg(7));
    let program = "G0 X1. Y1. Z2. A0 C0\nG1 X1.5 F10.\n";
    let (mm, summary) = run(&m, &errors, program).unwrap();
    assert_eq!(summary.units_assumed, Some((1, "mm")));
    assert!(
        summary
            .to_string()
            .contains("before it says G20 or G21: its words were read in mm")
    );
    m.inch_default = true;
    let (inch, summary) = run(&m, &errors, program).unwrap();
    assert_eq!(summary.units_assumed, Some((1, "inch")));
    // Read in inch, the same words are corrected as G20 would have them.
    let (stated, summary) = run(&m, &errors, &format!("G20\n{program}")).unwrap();
    assert_eq!(summary.units_assumed, None);
    assert_eq!(format!("G20\n{inch}"), stated);
    assert_ne!(mm, inch);
    // The machine file's key.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let text = std::fs::read_to_string(root.join("head_head.machine.toml")).unwrap();
    let with = |units: &str| {
        text.replacen(
            "\nworkpiece_chain",
            &format!("\nunits = \"{units}\"\nworkpiece_chain"),
            1,
        )
    };
    assert!(
        machine_file::parse(&with("inch"), "m.toml")
            .unwrap()
            .inch_default
    );
    assert!(
        !machine_file::parse(&with("mm"), "m.toml")
            .unwrap()
            .inch_default
    );
    let err = machine_file::parse(&with("cm"), "m.toml")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("`cm` in `units`: expected \"mm\" or \"inch\""),
        "{err}"
    );
}

/// The C words of a program's lines, in order.
fn c_words(program: &str) -> Vec<f64> {
    program
        .lines()
        .filter_map(|l| l.split_whitespace().find_map(|w| w.strip_prefix('C')))
        .map(|c| c.parse().unwrap())
        .collect()
}

#[test]
fn a_rollover_axis_is_split_the_shortest_way_to_its_word() {
    let mut m = machine();
    m.tool.lengths.insert(1, 100.0);
    let errors = random_errors(&m, &mut Lcg(7));
    // With the path check, as the command line runs by default.
    let run = |m: &Machine, errors: &ErrorModel, program: &str| {
        let options = Options {
            path: Some(nccomp::kinematics::path::PathTolerance::default()),
            ..Options::default()
        };
        let comp = Compensator::new(m, errors, options).unwrap();
        let mut out = Vec::new();
        comp.run(program.as_bytes(), "p.nc", &mut out)
            .map(|s| (String::from_utf8(out).unwrap(), s))
            .map_err(|e| e.to_string())
    };
    // From C170 to C-170: 20° through 180 on a rollover table, 340° back through 0 on one
    // that is not.
    let program = "G21 G90\nG0 X250. Y150. Z30. A-60. C170.\nG1 C-170. F500.\nM30\n";
    let (plain, summary) = run(&m, &errors, program).unwrap();
    assert!(summary.moves_split > 0, "{plain}");
    let through_zero = c_words(&plain).iter().any(|c| c.abs() < 90.0);
    assert!(through_zero, "{plain}");
    m.axes[4].rollover = true;
    let (rolled, summary) = run(&m, &errors, program).unwrap();
    assert!(summary.moves_split > 0, "{rolled}");
    let words = c_words(&rolled);
    // Every piece lies on the 20° between 170 and 190 (= -170): the control, taking each
    // word modulo 360 the shortest way, turns through 180.
    for c in &words[1..words.len() - 1] {
        let from_180 = (c - 180.0) - 360.0 * ((c - 180.0) / 360.0).round();
        assert!(from_180.abs() <= 10.0 + 1e-3, "{c}\n{rolled}");
    }
    assert!((words[words.len() - 1] + 170.0).abs() < 0.1, "{rolled}");
    // Exactly half a turn: the way is the control's choice.
    let err = run(
        &m,
        &errors,
        "G21 G90\nG0 X20. Y10. Z30. A-30. C0\nG1 C180. F500.\n",
    )
    .unwrap_err();
    assert!(err.contains("p.nc:3:4"), "{err}");
    assert!(err.contains("by exactly half a turn"), "{err}");
    // Under TCP the path nccomp follows turns in proportion: a half turn or more is refused.
    let err = run(
        &m,
        &errors,
        "G21 G90\nG0 X20. Y10. Z30. A-30. C170.\nG43.4 H1\nG0 X20. Y10. Z30. A-30. C170.\nG1 X20. Y10. Z30. A-30. C-170. F500.\n",
    )
    .unwrap_err();
    assert!(err.contains("p.nc:5:"), "{err}");
    assert!(
        err.contains("rollover axis C turns half a turn or more"),
        "{err}"
    );
}

#[test]
fn rollover_is_for_rotary_axes_without_travel() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let text = std::fs::read_to_string(root.join("ac_trunnion.machine.toml")).unwrap();
    let with = |axis: &str, value: &str| {
        text.replacen(
            &format!("[axes.{axis}]\n"),
            &format!("[axes.{axis}]\nrollover = {value}\n"),
            1,
        )
    };
    let m = machine_file::parse(&with("C", "true"), "m.toml").unwrap();
    assert!(m.axes.iter().find(|a| a.name == "C").unwrap().rollover);
    for (axis, value, says) in [
        (
            "A",
            "true",
            "`rollover` is for rotary axes without a `travel`",
        ),
        (
            "X",
            "true",
            "`rollover` is for rotary axes without a `travel`",
        ),
        ("C", "\"yes\"", "`rollover`: expected true"),
    ] {
        let err = machine_file::parse(&with(axis, value), "m.toml")
            .unwrap_err()
            .to_string();
        assert!(err.contains(says), "{err}");
        assert!(err.contains("m.toml:"), "{err}");
    }
}

/// A G91 block after an arc adds to the arc's end (its end words), not to where the arc
/// started.
#[test]
fn a_g91_block_after_an_arc_starts_at_the_arcs_end() {
    let (m, e) = ac_fixture();
    let head =
        "G17 G21 G90 G94\nG0 X10 Y20 Z50 A0 C0\nG1 Z-2.5 F300\nX30 Y20 A-15 C30\nG2 X40 Y30 R10\n";
    let (g90, _) = run(&m, &e, &format!("{head}G1 X45 Y27\nM30\n")).unwrap();
    let (g91, _) = run(&m, &e, &format!("{head}G91 G1 X5 Y-3\nG90\nM30\n")).unwrap();
    let value = |line: &str, letter: char| -> f64 {
        line.split_whitespace()
            .find_map(|w| w.strip_prefix(letter))
            .unwrap()
            .parse()
            .unwrap()
    };
    let (arc, abs, inc) = (
        g90.lines().nth(4).unwrap(),
        g90.lines().nth(5).unwrap(),
        g91.lines().nth(5).unwrap(),
    );
    assert_eq!(arc, g91.lines().nth(4).unwrap());
    for letter in ['X', 'Y'] {
        let reached = value(arc, letter) + value(inc, letter);
        assert!(
            (reached - value(abs, letter)).abs() < 1e-9,
            "{letter}: {arc} + {inc} reaches {reached}, the G90 program {abs}"
        );
    }
}

//! The turning–milling centre (fixtures/mill_turn.*, paper 004): random turning and milling
//! programs are compensated and every block end of the result is evaluated on the machine
//! with its errors, through `nccomp::kinematics` with the tool chain the block ran in.
//!
//! Turning is checked without nccomp's turning poses: the tip is evaluated (milling
//! kinematics) at three spindle angles, and the circle through the three points is the
//! circle the tip turns on the part. Its radius and the position of its centre along the
//! spindle must be the programmed ones within 1 µm.

use nalgebra::Vector3;
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use nccomp::nc::{self, TokenKind, Value};
use proptest::prelude::*;
use std::path::Path;

fn mill_turn() -> (Machine, ErrorModel) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = machine_file::load(&root.join("mill_turn.machine.toml")).unwrap();
    let e = error_file::load(&root.join("mill_turn.errors.toml"), &m).unwrap();
    (m, e)
}

/// Where a program has put every machine axis, block by block: a small interpreter of the
/// words the generated programs use (G7/G8, T, X Y Z B C in G90), written independently
/// of nccomp's pass.
struct Interpreter<'m> {
    machine: &'m Machine,
    chain: usize,
    diameter: bool,
    /// By machine axis.
    q: Vec<f64>,
}

impl<'m> Interpreter<'m> {
    fn new(machine: &'m Machine) -> Self {
        Interpreter {
            machine,
            chain: 0,
            diameter: false,
            q: vec![0.0; machine.axes.len()],
        }
    }

    /// Follow one line; true if it has axis words.
    fn line(&mut self, content: &[u8]) -> bool {
        let mut tokens = Vec::new();
        nc::parse_line(content, &mut tokens);
        let mut moves = false;
        let mut words = Vec::new();
        for t in &tokens {
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            let Value::Number { value, .. } = w.value else {
                continue;
            };
            match w.letter {
                b'G' if value == 7.0 => self.diameter = true,
                b'G' if value == 8.0 => self.diameter = false,
                b'T' if value > 0.0 => {
                    self.chain = self.machine.chain_of_tool(value as u32).unwrap()
                }
                b'X' | b'Y' | b'Z' | b'B' | b'C' => words.push((w.letter as char, value)),
                _ => {}
            }
        }
        let chain = &self.machine.tool_chains[self.chain];
        for (letter, value) in words {
            let axis = self
                .machine
                .workpiece_chain
                .iter()
                .chain(&chain.axes)
                .copied()
                .find(|&i| self.machine.axes[i].word == letter)
                .unwrap();
            self.q[axis] = if letter == 'X' && self.diameter {
                value / 2.0
            } else {
                value
            };
            moves = true;
        }
        moves
    }
}

/// The circle through three points: centre and radius.
fn circle(p: [Vector3<f64>; 3]) -> (Vector3<f64>, f64) {
    let (a, b) = (p[1] - p[0], p[2] - p[0]);
    let n = a.cross(&b);
    let centre =
        p[0] + (b * a.norm_squared() - a * b.norm_squared()).cross(&n) / (2.0 * n.norm_squared());
    (centre, (p[0] - centre).norm())
}

/// Compensate `program` one block out for one block in, and return (nominal, written)
/// interpreters' axis values and chain at every line that moves.
fn run(machine: &Machine, errors: &ErrorModel, program: &str) -> Vec<(usize, Vec<f64>, Vec<f64>)> {
    let comp = Compensator::new(machine, errors, Options::default()).unwrap();
    let mut out = Vec::new();
    if let Err(e) = comp.run(program.as_bytes(), "p.nc", &mut out) {
        panic!("{}\n{program}", e.render());
    }
    let (mut nominal, mut written) = (Interpreter::new(machine), Interpreter::new(machine));
    let mut ends = Vec::new();
    let input: Vec<_> = nc::lines(program.as_bytes()).collect();
    let output: Vec<_> = nc::lines(&out).collect();
    assert_eq!(input.len(), output.len(), "one block out for one block in");
    for (a, b) in input.iter().zip(&output) {
        let moves = nominal.line(a.content);
        written.line(b.content);
        assert_eq!(nominal.chain, written.chain);
        if moves {
            ends.push((nominal.chain, nominal.q.clone(), written.q.clone()));
        }
    }
    ends
}

/// The values of `kin`'s variables from values by machine axis.
fn values(kin: &Kinematics, q: &[f64]) -> Vec<f64> {
    kin.axes().iter().map(|&i| q[i]).collect()
}

/// A turning move: rapid or not, X as a radius (written as the mode wants), Z.
#[derive(Debug, Clone)]
enum Turn {
    Move {
        feed: bool,
        x: Option<f64>,
        z: Option<f64>,
    },
    Turret,
    Mode,
}

fn turn_step() -> impl Strategy<Value = Turn> {
    prop_oneof![
        8 => (any::<bool>(), proptest::option::of(1.0..60.0f64), proptest::option::of(-100.0..5.0f64))
            .prop_map(|(feed, x, z)| Turn::Move { feed, x, z }),
        1 => Just(Turn::Turret),
        1 => Just(Turn::Mode),
    ]
}

/// A turning program from the steps: the spindle turns from the start; after a change of
/// turret the first move gives both X and Z (the new turret's place is not known before).
fn turning_program(start_lower: bool, start_diameter: bool, steps: &[Turn]) -> String {
    let mut lower = start_lower;
    let mut diameter = start_diameter;
    let mut s = format!(
        "G21 G90 G18 {}\nT{}\nG0 X40. Z5. S900 M3\n",
        if diameter { "G7" } else { "G8" },
        if lower { 11 } else { 1 }
    );
    if diameter {
        s = s.replace("X40.", "X80.");
    }
    let mut need_both = false;
    for step in steps {
        match step {
            Turn::Turret => {
                lower = !lower;
                s += &format!("T{}\n", if lower { 12 } else { 2 });
                need_both = true;
            }
            Turn::Mode => {
                diameter = !diameter;
                s += if diameter { "G7\n" } else { "G8\n" };
            }
            Turn::Move { feed, x, z } => {
                let (x, z) = if need_both {
                    (Some(x.unwrap_or(30.0)), Some(z.unwrap_or(2.0)))
                } else {
                    (*x, *z)
                };
                if x.is_none() && z.is_none() {
                    continue;
                }
                // After a turret change the first move positions the new turret in the
                // air: a feed move from where it stands is refused.
                let first = need_both;
                need_both = false;
                s += if *feed && !first { "G1" } else { "G0" };
                if let Some(x) = x {
                    s += &format!(" X{:.3}", if diameter { 2.0 * x } else { x });
                }
                if let Some(z) = z {
                    s += &format!(" Z{z:.3}");
                }
                s += if *feed { " F0.2\n" } else { "\n" };
            }
        }
    }
    s + "M5\nM30\n"
}

/// Every block end of a compensated turning program turns the programmed radius at the
/// programmed place along the spindle, within 1 µm.
fn check_turning(
    machine: &Machine,
    errors: &ErrorModel,
    program: &str,
) -> Result<(), TestCaseError> {
    let zero = ErrorModel::zero(machine);
    let spindle = machine.lathe.unwrap().spindle;
    let ends = run(machine, errors, program);
    prop_assert!(!ends.is_empty());
    for (chain, nominal, written) in ends {
        let ideal = Kinematics::new(machine, &zero, chain).unwrap();
        let real = Kinematics::new(machine, errors, chain).unwrap();
        let p = ideal
            .pose(Model::Nominal, &values(&ideal, &nominal), 0.0)
            .0
            .p;
        let (radius, along) = (p.x.hypot(p.y), p.z);
        let mut points = [Vector3::zeros(); 3];
        for (k, point) in points.iter_mut().enumerate() {
            let mut q = written.clone();
            q[spindle] = 120.0 * k as f64 + 17.0;
            *point = real.pose(Model::Actual, &values(&real, &q), 0.0).0.p;
        }
        let (centre, r) = circle(points);
        prop_assert!(
            (r - radius).abs() < 1e-3 && (centre.z - along).abs() < 1e-3,
            "chain {chain}: radius {r} for {radius}, centre at z {} for {along}\n{program}",
            centre.z
        );
    }
    Ok(())
}

/// A milling move on the upper turret: every word optional.
fn mill_step() -> impl Strategy<Value = [Option<f64>; 5]> {
    [
        proptest::option::of(-30.0..60.0f64),
        proptest::option::of(-40.0..40.0f64),
        proptest::option::of(-100.0..50.0f64),
        proptest::option::of(-20.0..120.0f64),
        proptest::option::of(-180.0..180.0f64),
    ]
}

fn milling_program(steps: &[[Option<f64>; 5]]) -> String {
    let mut s = String::from("G21 G90 G17\nT5\nM19\nG0 X10. Y0. Z20. B30. C0.\n");
    for step in steps {
        if step.iter().all(Option::is_none) {
            continue;
        }
        s += "G1";
        for (letter, value) in "XYZBC".chars().zip(step) {
            if let Some(v) = value {
                s += &format!(" {letter}{v:.3}");
            }
        }
        s += " F500\n";
    }
    s + "M30\n"
}

/// Every block end of a compensated milling program puts the tip where the program does
/// (within 1 µm) and, away from B0 where the tool lies along C, the tool direction too (to
/// the rotary axes' resolution).
fn check_milling(
    machine: &Machine,
    errors: &ErrorModel,
    program: &str,
) -> Result<(), TestCaseError> {
    let zero = ErrorModel::zero(machine);
    let b = machine.axis_index("B").unwrap();
    let ends = run(machine, errors, program);
    prop_assert!(!ends.is_empty());
    for (chain, nominal, written) in ends {
        let ideal = Kinematics::new(machine, &zero, chain).unwrap();
        let real = Kinematics::new(machine, errors, chain).unwrap();
        let (target, _) = ideal.pose(Model::Nominal, &values(&ideal, &nominal), 0.0);
        let (actual, _) = real.pose(Model::Actual, &values(&real, &written), 0.0);
        let (dp, dd) = actual.deviation(&target);
        prop_assert!(dp < 1e-3, "tip {} µm off\n{program}", dp * 1e3);
        // B and C are written to 0.0001° (1.7 µrad).
        if nominal[b].abs() > 5.0 {
            prop_assert!(dd < 2e-6, "direction {} µrad off\n{program}", dd * 1e6);
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn compensated_turning_programs_turn_the_programmed_part(
        start_lower in any::<bool>(),
        start_diameter in any::<bool>(),
        steps in proptest::collection::vec(turn_step(), 1..25),
    ) {
        let (m, e) = mill_turn();
        check_turning(&m, &e, &turning_program(start_lower, start_diameter, &steps))?;
    }

    #[test]
    fn compensated_milling_programs_reach_every_programmed_pose(
        steps in proptest::collection::vec(mill_step(), 1..25),
    ) {
        let (m, e) = mill_turn();
        check_milling(&m, &e, &milling_program(&steps))?;
    }
}

#[test]
fn the_fixture_programs_pass_the_same_checks() {
    let (m, e) = mill_turn();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let turning = std::fs::read_to_string(root.join("mill_turn_turning.nc")).unwrap();
    // The arc is kept as an arc; its end is checked like any block end.
    check_turning(&m, &e, &turning).unwrap();
    let milling = std::fs::read_to_string(root.join("mill_turn_milling.nc")).unwrap();
    check_milling(&m, &e, &milling).unwrap();
}

/// Compensate `program` on the mill-turn centre: the output and its summary, or the
/// rendered errors.
fn compensate(program: &str) -> Result<(String, String), String> {
    let (m, e) = mill_turn();
    let comp = Compensator::new(&m, &e, Options::default()).unwrap();
    let mut out = Vec::new();
    match comp.run(program.as_bytes(), "p.nc", &mut out) {
        Ok(summary) => Ok((String::from_utf8(out).unwrap(), summary.to_string())),
        Err(e) => Err(e.to_string()),
    }
}

/// The number of the `letter` word of every line (`None` where it has none).
fn words(text: &str, letter: char) -> Vec<Option<f64>> {
    text.lines()
        .map(|l| {
            let at = l.find(letter)?;
            let rest = &l[at + 1..];
            let end = rest.find(' ').unwrap_or(rest.len());
            rest[..end].parse().ok()
        })
        .collect()
}

#[test]
fn diameter_words_are_written_as_twice_the_compensated_radius() {
    let radius = "G18 G8\nT1\nM3\nG0 X31.5 Z2.\nG1 Z-40.\nX-0.4\nG0 X12.25 Z-7.5\n";
    let diameter = "G18 G7\nT1\nM3\nG0 X63. Z2.\nG1 Z-40.\nX-0.8\nG0 X24.5 Z-7.5\n";
    let (r, _) = compensate(radius).unwrap();
    let (d, _) = compensate(diameter).unwrap();
    let (xr, xd) = (words(&r, 'X'), words(&d, 'X'));
    let mut compared = 0;
    for (line, (r, d)) in xr.iter().zip(&xd).enumerate() {
        match (r, d) {
            (Some(r), Some(d)) => {
                // The radius and the diameter are each rounded to 0.0001.
                assert!(
                    (d / 2.0 - r).abs() <= 0.5e-4 + 1e-9,
                    "line {line}: diameter {d} for radius {r}"
                );
                compared += 1;
            }
            (None, None) => {}
            _ => panic!("line {line}: X in one mode only:\n{r:?}\n{d:?}"),
        }
    }
    assert_eq!(compared, 4);
    // Z words do not depend on the mode, and X words are compensated, not copied.
    assert_eq!(words(&r, 'Z'), words(&d, 'Z'));
    let programmed = [63.0, 63.0, -0.8, 24.5];
    let written: Vec<f64> = xd.iter().flatten().copied().collect();
    assert!(
        written
            .iter()
            .zip(programmed)
            .all(|(w, x)| (w - x).abs() > 1e-4),
        "{d}"
    );
}

#[test]
fn incremental_diameter_words_land_exactly_on_the_absolute_ones() {
    let absolute = "G18 G7\nT1\nM3\nG0 X60. Z2.\nG1 X50. Z-18.\nX40.\nZ-33.5\nX60.05\n";
    let incremental = "G18 G7\nT1\nM3\nG0 X60. Z2.\nG91\nG1 X-10. Z-20.\nX-10.\nZ-15.5\nX20.05\n";
    let (a, _) = compensate(absolute).unwrap();
    let (i, _) = compensate(incremental).unwrap();
    let (xa, za) = (words(&a, 'X'), words(&a, 'Z'));
    let (xi, zi) = (words(&i, 'X'), words(&i, 'Z'));
    let (mut x, mut z) = (xi[3].unwrap(), zi[3].unwrap());
    assert_eq!((Some(x), Some(z)), (xa[3], za[3]));
    for k in 4..8 {
        x += xi[k + 1].unwrap_or(0.0);
        z += zi[k + 1].unwrap_or(0.0);
        let (ax, az) = (xa[k].unwrap_or(x), za[k].unwrap_or(z));
        assert!(
            (x - ax).abs() < 1e-9 && (z - az).abs() < 1e-9,
            "block {k}: {x} {z} against {ax} {az}\n{a}\n{i}"
        );
    }
}

#[test]
fn a_new_turret_starts_unknown_and_an_old_one_where_it_was_left() {
    let program = "G18 G8\nT1\nM3\nG0 X30. Z2.\nT11\nG0 Z-10.\nX35.\nG1 X20.\nT1\nZ-5.\nM30\n";
    let (out, summary) = compensate(program).unwrap();
    let (input, output): (Vec<&str>, Vec<&str>) =
        (program.lines().collect(), out.lines().collect());
    // Line 6: only Z of the lower turret is programmed, X2 is where the program never said.
    assert_eq!(output[5], input[5]);
    assert!(summary.contains("1 block (first at line 6) was written uncompensated: axis X2 was at a position nccomp does not know (at the program's start, or after G28, G30, G53, a machine move code, M19 or a change of tool chain)"), "{summary}");
    assert!(
        summary.contains("tool chains used: upper, lower"),
        "{summary}"
    );
    // From line 7 on both are known; back on the upper turret X1 is where line 4 left it.
    for k in [6, 7, 9] {
        assert_ne!(output[k], input[k], "line {}", k + 1);
    }
}

#[test]
fn the_spindle_is_an_axis_only_once_positioned() {
    let program = "G17\nT5\nM19\nG0 X10. Y5. Z5.\nG0 X10. Y5. Z5. C0.\nG1 Z-2. F100\nM30\n";
    let (out, summary) = compensate(program).unwrap();
    let (input, output): (Vec<&str>, Vec<&str>) =
        (program.lines().collect(), out.lines().collect());
    // After M19 the spindle's angle is not known until a C word gives it.
    assert_eq!(output[3], input[3]);
    assert!(
        summary.contains("axis C was at a position nccomp does not know"),
        "{summary}"
    );
    assert_ne!(output[4], input[4]);
    assert_ne!(output[5], input[5]);
    assert!(!summary.contains("as turning"), "{summary}");
}

#[test]
fn what_cannot_be_turned_or_switched_is_refused_at_its_place() {
    let refused = |program: &str, place: &str, phrase: &str| {
        let e = compensate(program).expect_err(program);
        assert!(e.starts_with(place) && e.contains(phrase), "{program}: {e}");
    };
    refused(
        "G18\nM3\nG0 X30. Z2.\nG1 C90.\n",
        "p.nc:4:4:",
        "C positions the spindle, but it turns (M3/M4 at line 2)",
    );
    refused("G18\nT9 M6\n", "p.nc:2:1:", "T9 selects no tool chain");
    refused(
        "G18\nM3\nG0 X30. Z2.\n/T11\n",
        "p.nc:4:2:",
        "T11 in an optional block (/) cannot be compensated",
    );
    refused(
        "G18\nM3\nG0 X30. Z2.\n/M5\n",
        "p.nc:4:2:",
        "M5 in an optional block (/)",
    );
    // Diameter mode needs a lathe.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let e = error_file::load(&root.join("ac_trunnion.errors.toml"), &m).unwrap();
    let comp = Compensator::new(&m, &e, Options::default()).unwrap();
    let err = comp
        .run(b"G21 G7\nG1 X10.\n", "p.nc", &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("p.nc:1:5:") && err.contains("needs a [lathe] table"),
        "{err}"
    );
}

//! G68 X Y R in G17: the program's X, Y turned about a centre. The words under it are
//! written so that the controller's rotation of them commands the corrected axes; checked
//! against an independent evaluation of the rotation on a three-axis mill.

use nalgebra::{Rotation2, Vector2};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{error_file, machine_file};
use std::path::Path;

const PROGRAM: &str = "G21 G90 G17
G0 X0 Y0 Z10
G68 X20 Y10 R30
G1 X40 Y10 Z-1 F500
X40 Y30
X20 Y30 Z-1.5
Y10
G69
G0 X0 Y0 Z10
M30
";

/// The machine positions the controller commands for a program's X Y Z words, block by
/// block (None for a block that does not move).
fn commanded(program: &str) -> Vec<Option<[f64; 3]>> {
    let (mut w, mut rotation) = ([0.0; 3], None::<(Vector2<f64>, Rotation2<f64>)>);
    program
        .lines()
        .map(|line| {
            let mut moved = false;
            let mut g68 = false;
            let (mut centre, mut angle) = (Vector2::zeros(), 0.0);
            for word in line.split_whitespace() {
                let value = || word[1..].parse::<f64>().unwrap();
                match (&word[..1], word) {
                    (_, "G68") => g68 = true,
                    (_, "G69") => rotation = None,
                    ("X", _) if g68 => centre.x = value(),
                    ("Y", _) if g68 => centre.y = value(),
                    ("R", _) => angle = value(),
                    ("X", _) => (w[0], moved) = (value(), true),
                    ("Y", _) => (w[1], moved) = (value(), true),
                    ("Z", _) => (w[2], moved) = (value(), true),
                    _ => {}
                }
            }
            if g68 {
                rotation = Some((centre, Rotation2::new(angle.to_radians())));
            }
            moved.then(|| match rotation {
                Some((c, r)) => {
                    let p = c + r * (Vector2::new(w[0], w[1]) - c);
                    [p.x, p.y, w[2]]
                }
                None => w,
            })
        })
        .collect()
}

fn setup() -> (nccomp::model::Machine, nccomp::model::ErrorModel) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures/corpus");
    let machine = machine_file::load(&root.join("centroid_mill.machine.toml")).unwrap();
    let errors = error_file::load(&root.join("centroid_mill.errors.toml"), &machine).unwrap();
    (machine, errors)
}

#[test]
fn words_under_a_rotation_command_the_corrected_axes() {
    let (machine, errors) = setup();
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let comp = Compensator::new(
        &machine,
        &errors,
        Options {
            path: None,
            ..Options::default()
        },
    )
    .unwrap();
    let mut out = Vec::new();
    comp.run(PROGRAM.as_bytes(), "rot.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    assert_eq!(
        written.lines().count(),
        PROGRAM.lines().count(),
        "{written}"
    );
    let (mut worst, mut before) = (0.0f64, 0.0f64);
    for (k, (meant, told)) in commanded(PROGRAM)
        .iter()
        .zip(commanded(&written))
        .enumerate()
    {
        let (Some(meant), Some(told)) = (meant, told) else {
            continue;
        };
        // The first move's X, Y are the machine's unset home: the model assumed 0 there.
        if k < 2 {
            continue;
        }
        let (nominal, _) = kin.pose(Model::Nominal, meant, 0.0);
        let (reached, _) = kin.pose(Model::Actual, &told, 0.0);
        let (as_programmed, _) = kin.pose(Model::Actual, meant, 0.0);
        worst = worst.max((reached.p - nominal.p).norm());
        before = before.max((as_programmed.p - nominal.p).norm());
    }
    assert!(worst < 1e-4, "{:.3} µm off: {written}", worst * 1e3);
    assert!(
        before > 1e-3,
        "the check can fail: {:.3} µm uncorrected",
        before * 1e3
    );
    // The words under the rotation changed, in the rotated frame.
    assert!(written.contains("G68 X20 Y10 R30\n"), "{written}");
    assert!(!written.contains("\nX40 Y30\n"), "{written}");
    // With the path check the program compensates too (straight moves under the rotation).
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    comp.run(PROGRAM.as_bytes(), "rot.nc", &mut Vec::new())
        .unwrap();
}

#[test]
fn rotations_nccomp_does_not_follow_are_refused() {
    let (machine, errors) = setup();
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    for (program, at, what) in [
        (
            "G0 X0 Y0 Z10\nG68 X1 Y1\n",
            "p.nc:2:1: G68 cannot be compensated: without R",
            "no R",
        ),
        (
            "G0 X0 Y0 Z10\nG68 R30\n",
            "p.nc:2:1: G68 cannot be compensated: without X and Y",
            "no centre",
        ),
        (
            "G0 X0 Y0 Z10\nG68 X0 Y0 I0 J0 K1 R30\n",
            "p.nc:2:11: G68 cannot be compensated: with I, J, K",
            "3-D",
        ),
        (
            "G0 X0 Y0 Z10\nG18 G68 X0 Y0 R30\n",
            "p.nc:2:5: G68 cannot be compensated: only a rotation in the G17 plane",
            "G18",
        ),
        (
            "G0 X0 Y0 Z10\nG91 G68 X0 Y0 R30\n",
            "p.nc:2:5: G68 cannot be compensated: in G91",
            "G91",
        ),
        (
            "G0 X0 Y0 Z10\nG68 X0 Y0 R30\nG68 X1 Y1 R10\n",
            "p.nc:3:1: G68 cannot be compensated: a rotation under",
            "twice",
        ),
        (
            "G0 X0 Y0 Z10\nG68 X0 Y0 R30\nG53.1\n",
            "p.nc:3:1: G53.1 under a coordinate rotation (G68)",
            "G53.1",
        ),
    ] {
        let err = comp
            .run(program.as_bytes(), "p.nc", &mut Vec::new())
            .unwrap_err()
            .to_string();
        assert!(err.contains(at), "{what}: {err}");
    }
}

/// Issue 34, case 14: after G69 the axes stand where the rotation put them; a G91 word
/// travels from there (not from the last words before the rotation ended).
#[test]
fn an_increment_after_g69_travels_from_where_the_axes_stand() {
    let (machine, errors) = setup();
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let program = "G21 G90 G17\nG0 X0 Y0 Z10\nG68 X0 Y0 R90\nG0 X10 Y5\nG69\nG91 G0 X5\n";
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "rot.nc", &mut out).unwrap();
    let written = String::from_utf8(out).unwrap();
    let lines: Vec<&str> = written.lines().collect();
    assert_eq!(lines.len(), 6, "{written}");
    // The written G90 part as the controller rotates it, then the increments added.
    let head = lines[..5].join("\n");
    let mut at = commanded(&head)[3].unwrap();
    for word in lines[5].split_whitespace() {
        if let Some(k) = "XYZ".find(&word[..1]) {
            at[k] += word[1..].parse::<f64>().unwrap();
        }
    }
    // The rotation put the axes at X-5 Y10: the increment takes X to 0.
    let target = kin.pose(Model::Nominal, &[0.0, 10.0, 10.0], 0.0).0.p;
    let reached = kin.pose(Model::Actual, &at, 0.0).0.p;
    let off = (reached - target).norm();
    assert!(off < 1e-3, "{written}\n{off} mm off");
}

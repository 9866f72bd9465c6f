//! Arcs: replaced by compensated straight pieces that put the tool on the nominal arc.

mod common;

use common::{Lcg, ac_trunnion, random_errors};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model, SolveOptions};

fn words(line: &str, q: &mut [f64; 5]) {
    for word in line.split('(').next().unwrap().split_whitespace() {
        if let Some(k) = "XYZAC".find(&word[..1]) {
            q[k] = word[1..].parse().unwrap();
        }
    }
}

/// Each case: plane code, the two plane axes (indices into X Y Z A C), the third linear
/// axis, a program, the arc's centre and radius in the plane.
#[test]
fn arcs_in_every_plane_land_on_their_nominal_circle() {
    let machine = ac_trunnion([0.0, 0.0, -100.0], [0.0, 0.0, 0.0]);
    let errors = random_errors(&machine, &mut Lcg(29));
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let cases = [
        (
            "G17",
            (0, 1),
            "G0 X30 Y0 Z20 A-30 C20\nG17 G3 X0 Y30 I-30 J0 F400\n",
            (0.0, 0.0),
            30.0,
        ),
        (
            "G18",
            (2, 0),
            "G0 X0 Y5 Z40 A-30 C20\nG18 G2 X20 Z20 I0 K-20 F400\n",
            (20.0, 0.0),
            20.0,
        ),
        (
            "G19",
            (1, 2),
            "G0 X5 Y-25 Z30 A-30 C20\nG19 G3 Y25 Z30 R25 F400\n",
            (0.0, 30.0),
            25.0,
        ),
    ];
    for (plane, (ia, ib), program, centre, radius) in cases {
        let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
        let mut out = Vec::new();
        let summary = comp.run(program.as_bytes(), "arc.nc", &mut out).unwrap();
        let out = String::from_utf8(out).unwrap();
        assert_eq!(summary.arcs, 1, "{plane}");
        assert!(
            summary.arc_blocks_added > 20,
            "{plane}: {}",
            summary.arc_blocks_added
        );
        assert!(
            !out.contains('I') && !out.contains('R') && !out.contains("G2") && !out.contains("G3"),
            "{out}"
        );
        let mut q = [0.0; 5];
        let mut guess = [0.0, 0.0, 0.0, -30.0, 20.0];
        for (i, line) in out.lines().enumerate() {
            words(line, &mut q);
            if i == 0 {
                continue;
            }
            let (reached, _) = kin.pose(Model::Actual, &q, 0.0);
            // Where the nominal machine would have to be to put the tool there.
            let sol = kin.tcp_axes_with_rotaries(&reached.p, &guess, 0.0, &SolveOptions::default());
            guess = sol.q[..5].try_into().unwrap();
            let (a, b) = (sol.q[ia] - centre.0, sol.q[ib] - centre.1);
            let off = ((a * a + b * b).sqrt() - radius).abs();
            assert!(off < 1e-3, "{plane} {line}: {off} mm off the arc");
        }
    }
}

/// Compensate on the AC trunnion fixture with a path tolerance so tight (10 nm) that no
/// arc can be kept: the straight pieces are what these tests look at.
fn compensate_fixture(program: &str) -> Result<String, String> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = nccomp::model::machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let e = nccomp::model::error_file::load(&root.join("ac_trunnion.errors.toml"), &m).unwrap();
    let options = Options {
        path: Some(nccomp::kinematics::path::PathTolerance {
            position: 1e-5,
            ..Default::default()
        }),
        ..Options::default()
    };
    let comp = Compensator::new(&m, &e, options).unwrap();
    let mut out = Vec::new();
    comp.run(program.as_bytes(), "a.nc", &mut out)
        .map(|_| String::from_utf8(out).unwrap())
        .map_err(|e| e.to_string())
}

#[test]
fn the_first_piece_carries_the_arcs_modal_words() {
    // G20 on the arc's own line must already hold for its first piece.
    let out =
        compensate_fixture("G21 G0 X10 Y0 Z2 A0 C0\nN40 G20 G3 X0 Y0.3937 I-0.3937 J0 F30.\n")
            .unwrap();
    let first_piece = out.lines().nth(1).unwrap();
    assert!(
        first_piece.contains("G20") && first_piece.contains(" G1 "),
        "{first_piece}"
    );
    assert!(first_piece.contains("F30."), "{first_piece}");
}

#[test]
fn arcs_are_refused_where_a_g1_would_be() {
    let err = compensate_fixture("G0 X400. Y-100. Z10. A0 C0\nG3 X500. Y0 I0 J100.\n").unwrap_err();
    assert!(
        err.contains("a.nc:2:1:") && err.contains("outside its travel"),
        "{err}"
    );
    let err = compensate_fixture("G0 X10 Y0 Z2 A0 C0\nG2 X0 Y-10 I-10 J0 M8\n").unwrap_err();
    assert!(err.contains("M or T word"), "{err}");
    let err = compensate_fixture("G0 X10 Y0 Z2 A0 C0\nG93 G2 X0 Y-10 I-10 J0\n").unwrap_err();
    assert!(err.contains("G93"), "{err}");
}

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

//! The twin: identification accuracy and the closed loop (issue 5).

use nccomp::identify::cutting;
use nccomp::identify::plan::Plan;
use nccomp::identify::simulate::{self, Rng, Terms};
use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, Machine, machine_file};

fn setup() -> (Machine, Plan, String, Vec<cutting::Cut>) {
    let machine = machine_file::load("fixtures/ac_trunnion.machine.toml".as_ref()).unwrap();
    let plan = Plan::load("fixtures/feature_workpiece.plan.toml".as_ref()).unwrap();
    let program = std::fs::read_to_string("fixtures/feature_workpiece.nc").unwrap();
    let kin = Kinematics::new(&machine, &ErrorModel::zero(&machine), 0).unwrap();
    let cuts = cutting::cuts(&kin, &machine, &plan, &program);
    (machine, plan, program, cuts)
}

/// Largest miss beyond the tolerance (10% or 0.5 um / 5 urad), as a share of the tolerance.
fn worst(names: &[String], got: &[f64], want: &[f64]) -> (f64, String) {
    let mut w = (0.0, String::new());
    for i in 0..names.len() {
        let abs: f64 = if nccomp::identify::separate::is_angle(&names[i]) {
            5e-6
        } else {
            5e-4
        };
        let tol = abs.max(0.1 * want[i].abs());
        let share = (got[i] - want[i]).abs() / tol;
        if share > w.0 {
            w = (
                share,
                format!("{}: got {:.3e}, truth {:.3e}", names[i], got[i], want[i]),
            );
        }
    }
    w
}

fn run(quasi: &Terms, dynamic: &Terms, noise: f64, seed: u64) -> (f64, String, f64, String) {
    let (machine, plan, program, cuts) = setup();
    let m = simulate::cut_and_measure(
        &machine, &plan, &program, &cuts, quasi, dynamic, noise, seed,
    )
    .unwrap();
    let dec = simulate::decoupling(&machine, &plan, &cuts).unwrap();
    let id = simulate::identify(&dec, &plan, &m.on_machine, &m.cmm).unwrap();
    let (q, qs) = worst(&id.model.names, &id.model.quasi_static, &quasi.values);
    let (d, ds) = worst(&id.model.names, &id.model.dynamic, &dynamic.values);
    eprintln!("unobserved {:?}", dec.unobserved());
    for v in dec.null_space(1e-9) {
        eprintln!("null: {v:.3?}");
    }
    eprintln!(
        "conditioning {:?}; quasi {q:.2} ({qs}); dynamic {d:.2} ({ds})",
        id.conditioning
    );
    (q, qs, d, ds)
}

#[test]
#[ignore = "open: the plan leaves 4 combinations unobservable (straightness slopes vs squareness/yaw and the A-axis shifts); see docs/identify.md"]
fn noise_free_identification_recovers_the_paper_errors() {
    let (_, plan, _, _) = setup();
    let (quasi, dynamic) = simulate::paper_terms(&plan, &mut Rng::new(1));
    let (q, qs, d, ds) = run(&quasi, &dynamic, 0.0, 1);
    assert!(q < 0.05 && d < 0.05, "{qs}; {ds}");
}

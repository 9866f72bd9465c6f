//! The measurement plan, the twin's error files and the measurement CSV files (issue 5).

use nccomp::identify::measure;
use nccomp::identify::params::Params;
use nccomp::identify::plan::Plan;
use nccomp::identify::simulate::{self, Rng};
use nccomp::model::machine_file;
use nccomp::workpiece::FeatureWorkpiece;

const PLAN: &str = "fixtures/feature_workpiece.plan.toml";

fn shipped() -> (String, Plan) {
    let text = std::fs::read_to_string(PLAN).unwrap();
    let plan = Plan::parse(&text, PLAN).unwrap();
    (text, plan)
}

/// Regenerate with `NCCOMP_WRITE_FIXTURES=1 cargo test --test identify_plan`.
fn check_fixture(path: &str, generated: &str) {
    if std::env::var_os("NCCOMP_WRITE_FIXTURES").is_some() {
        std::fs::write(path, generated).unwrap();
    }
    let committed = std::fs::read_to_string(path).unwrap();
    assert!(
        committed == generated,
        "{path} is stale: run NCCOMP_WRITE_FIXTURES=1 cargo test --test identify_plan"
    );
}

#[test]
fn shipped_plan_is_the_generated_one() {
    let generated = Plan::feature_workpiece(&FeatureWorkpiece::default(), 3.0);
    check_fixture(PLAN, &generated.to_toml());
    let (_, plan) = shipped();
    assert_eq!(plan, generated);
    assert_eq!(plan.features.len(), 10);
}

#[test]
fn shipped_twin_errors_are_the_papers() {
    // The twin's machine: paper 000's quasi-static and dynamic columns (tables 2–3) on
    // the plan's terms, with seeded random straightness.
    let machine = machine_file::load("fixtures/ac_trunnion.machine.toml".as_ref()).unwrap();
    let (_, plan) = shipped();
    let params = Params::new(&plan, &machine).unwrap();
    let (quasi, dynamic) = simulate::paper_values(&params, &mut Rng::new(1));
    let title = "the twin's machine: paper 000 tables 2-3 and seeded random straightness";
    check_fixture(
        "fixtures/feature_workpiece.quasi_static.toml",
        &params.error_toml(&machine, &quasi, &format!("Quasi-static errors of {title}")),
    );
    check_fixture(
        "fixtures/feature_workpiece.dynamic.toml",
        &params.error_toml(&machine, &dynamic, &format!("Dynamic errors of {title}")),
    );
    // EC0Y is S_yx's quasi-static 0.0295 degrees.
    let j = params.names.iter().position(|n| n == "EC0Y").unwrap();
    assert!((quasi[j] - 0.0295f64.to_radians()).abs() < 1e-12);
}

#[test]
fn plan_errors_name_file_line_and_column() {
    let (text, _) = shipped();
    let bad = text.replacen("tool_radius", "tool_radios", 1);
    let e = Plan::parse(&bad, "p.toml").unwrap_err().to_string();
    assert!(e.starts_with("p.toml:"), "{e}");
    assert!(e.contains("tool_radios"), "{e}");
    let empty = "tool_radius = 3.0\ntool = 1\n[[feature]]\nname = \"c\"\npoints = []\n";
    let e = Plan::parse(empty, "p.toml").unwrap_err().to_string();
    assert!(e.starts_with("p.toml:4:8:"), "{e}");
    assert!(e.contains("has no points"), "{e}");
    let twice = text.replacen("\"BX002\"", "\"BX001\"", 1);
    let e = Plan::parse(&twice, "p.toml").unwrap_err().to_string();
    let line = text.lines().position(|l| l.contains("\"BX002\"")).unwrap() + 1;
    assert!(e.starts_with(&format!("p.toml:{line}:")), "{e}");
    assert!(e.contains("used twice"), "{e}");
    let flat = text.replacen(
        "normal = [0.0, -1.0, 0.0] }",
        "normal = [0.0, 0.0, 0.0] }",
        1,
    );
    let e = Plan::parse(&flat, "p.toml").unwrap_err().to_string();
    assert!(e.contains("non-zero normal"), "{e}");
}

#[test]
fn plan_terms_are_checked_against_the_machine() {
    let machine = machine_file::load("fixtures/ac_trunnion.machine.toml".as_ref()).unwrap();
    let (text, _) = shipped();
    for (from, to, expect) in [
        ("\"EC0Y\"", "\"EX0Y\"", "squareness"),
        ("\"EC0Y\"", "\"EC0Q\"", "no axis Q"),
        ("\"EC0Y\"", "\"EC0Y@5\"", "drop `@`"),
        ("\"EBX@50\"", "\"EBX@fifty\"", "not a position"),
        ("\"EZY\"", "\"EZX\"", "twice"),
    ] {
        let plan = Plan::parse(&text.replacen(from, to, 1), "p.toml").unwrap();
        let e = Params::new(&plan, &machine).unwrap_err();
        assert!(e.message.contains(expect), "{to}: {}", e.message);
        assert_eq!(format!("\"{}\"", e.term), to);
    }
}

fn nominal_csv(plan: &Plan) -> String {
    let points = plan
        .points()
        .map(|p| (p.id.clone(), nalgebra::Vector3::from(p.at)))
        .collect();
    measure::to_csv(plan, &points)
}

#[test]
fn csv_round_trip_and_errors() {
    let (_, plan) = shipped();
    let csv = nominal_csv(&plan);
    let pts = measure::parse(&csv, "m.csv", &plan).unwrap();
    assert_eq!(pts.len(), plan.points().count());

    let lines: Vec<&str> = csv.lines().collect();
    let first = lines[2].split(',').next().unwrap().to_string();
    let id_col = first.len() + 2;
    // An unknown point: line 3, column of the id.
    let mut l = lines.clone();
    let row = l[2].replacen("BX002", "BX999", 1);
    l[2] = &row;
    let e = measure::parse(&l.join("\n"), "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(&format!("m.csv:3:{id_col}:")), "{e}");
    assert!(e.contains("BX999"), "{e}");
    // Wrong feature.
    let mut l = lines.clone();
    let other = plan.features[1].name.clone();
    let row = l[2].replacen(&first, &other, 1);
    l[2] = &row;
    let e = measure::parse(&l.join("\n"), "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("m.csv:3:1:") && e.contains(&format!("belongs to feature `{first}`")),
        "{e}"
    );
    // A bad number.
    let mut l = lines.clone();
    let row = l[4].replacen(",5.000000", ",5.0x", 1);
    l[4] = &row;
    let e = measure::parse(&l.join("\n"), "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("m.csv:5:") && e.contains("not a number"),
        "{e}"
    );
    // Twice.
    let mut l = lines.clone();
    l.insert(3, lines[2]);
    let e = measure::parse(&l.join("\n"), "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("m.csv:4:") && e.contains("twice"), "{e}");
    // Missing.
    let mut l = lines.clone();
    l.remove(5);
    let e = measure::parse(&l.join("\n"), "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("m.csv:") && e.contains("missing: BX005"),
        "{e}"
    );
    // Header.
    let e = measure::parse("a,b\n", "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("m.csv:1:1:"), "{e}");
}

#[test]
fn error_file_is_the_model_the_identification_used() {
    // What `identify` writes, read back as `compensate` reads it, is the model the
    // decoupling and the twin evaluate, everywhere on the tables and beyond.
    use nccomp::kinematics::{Kinematics, Model};
    use nccomp::model::error_file;
    let machine = machine_file::load("fixtures/ac_trunnion.machine.toml".as_ref()).unwrap();
    let (_, plan) = shipped();
    let params = Params::new(&plan, &machine).unwrap();
    let mut rng = Rng::new(3);
    let values = simulate::random_values(&params, &mut rng, 0.005, 100e-6);
    let text = params.error_toml(&machine, &values, "round trip");
    let read = error_file::parse(&text, "e.toml", &machine).unwrap();
    let direct = Kinematics::new(&machine, &params.model(&machine, &values), 0).unwrap();
    let file = Kinematics::new(&machine, &read, 0).unwrap();
    for k in 0..200 {
        let u = |rng: &mut Rng, lo: f64, hi: f64| lo + (hi - lo) * rng.uniform();
        let q = [
            u(&mut rng, -120.0, 120.0),
            u(&mut rng, -120.0, 120.0),
            u(&mut rng, -50.0, 50.0),
            u(&mut rng, -100.0, 20.0),
            u(&mut rng, -180.0, 180.0),
        ];
        let (a, _) = direct.pose(Model::Actual, &q, 95.3);
        let (b, _) = file.pose(Model::Actual, &q, 95.3);
        // The file rounds to 1e-4 µm and µrad.
        assert!(
            (a.p - b.p).norm() < 1e-6,
            "{k}: {q:?} {:e}",
            (a.p - b.p).norm()
        );
        assert!((a.o - b.o).norm() < 1e-9, "{k}: {q:?}");
    }
    // And a term moves the machine: the model is not empty.
    let (nominal, _) = direct.pose(Model::Nominal, &[10.0, 20.0, 0.0, -30.0, 40.0], 95.3);
    let (actual, _) = direct.pose(Model::Actual, &[10.0, 20.0, 0.0, -30.0, 40.0], 95.3);
    assert!((nominal.p - actual.p).norm() > 1e-3);
}

#[test]
fn csv_quotes_feature_names_with_commas() {
    let (_, mut plan) = shipped();
    plan.features[0].name = "walls, \"X\"".into();
    let csv = nominal_csv(&plan);
    assert!(
        csv.lines()
            .nth(1)
            .unwrap()
            .starts_with("\"walls, \"\"X\"\"\",BX001,")
    );
    assert_eq!(
        measure::parse(&csv, "m.csv", &plan).unwrap().len(),
        plan.points().count()
    );
    // A bad number after a quoted comma is still found at its column.
    let bad = csv.replacen(",-97.500000,", ",-97.5q,", 1);
    let e = measure::parse(&bad, "m.csv", &plan)
        .unwrap_err()
        .to_string();
    let col = "\"walls, \"\"X\"\"\",BX001,".len() + 1;
    assert!(e.starts_with(&format!("m.csv:2:{col}:")), "{e}");
}

//! The measurement plan and the measurement CSV files (issue 5, steps 1).

use nccomp::identify::measure;
use nccomp::identify::plan::Plan;
use nccomp::workpiece::FeatureWorkpiece;

fn shipped() -> (String, Plan) {
    let text = std::fs::read_to_string("fixtures/feature_workpiece.plan.toml").unwrap();
    let plan = Plan::parse(&text, "fixtures/feature_workpiece.plan.toml").unwrap();
    (text, plan)
}

#[test]
fn shipped_plan_is_the_generated_one() {
    let generated = Plan::feature_workpiece(&FeatureWorkpiece::default(), 3.0);
    if std::env::var_os("NCCOMP_WRITE_PLAN").is_some() {
        std::fs::write("fixtures/feature_workpiece.plan.toml", generated.to_toml()).unwrap();
    }
    let (_, plan) = shipped();
    assert_eq!(plan, generated);
    assert_eq!(plan.features.len(), 6);
}

#[test]
fn plan_errors_name_file_line_and_column() {
    let (text, _) = shipped();
    let bad = text.replacen("tool_radius", "tool_radios", 1);
    let e = Plan::parse(&bad, "p.toml").unwrap_err().to_string();
    assert!(e.starts_with("p.toml:"), "{e}");
    assert!(e.contains("tool_radios"), "{e}");
    let few = "tool_radius = 3.0\ntool = 1\n[[feature]]\nname = \"c\"\nkind = \"circle\"\naxis = \"C\"\nidentifies = []\nreference = [0.0, 0.0, 0.0]\npoints = [{ id = \"a\", at = [1.0, 0.0, 0.0], normal = [1.0, 0.0, 0.0], tool = [0.0, 0.0, 1.0] }]\n";
    let e = Plan::parse(few, "p.toml").unwrap_err().to_string();
    assert!(e.starts_with("p.toml:4:"), "{e}");
    assert!(e.contains("at least 6"), "{e}");
}

fn nominal_csv(plan: &Plan) -> String {
    let points = plan
        .features
        .iter()
        .flat_map(|f| f.points.iter())
        .map(|p| (p.id.clone(), nalgebra::Vector3::from(p.at)))
        .collect();
    measure::to_csv(plan, &points)
}

#[test]
fn csv_round_trip_and_errors() {
    let (_, plan) = shipped();
    let csv = nominal_csv(&plan);
    let pts = measure::parse(&csv, "m.csv", &plan).unwrap();
    assert_eq!(pts.len(), 2 * 10 + 2 * 15 + 2 * 72);

    let lines: Vec<&str> = csv.lines().collect();
    // An unknown point: line 3, column of the id.
    let mut l = lines.clone();
    let row = l[2].replacen("XS02", "XS99", 1);
    l[2] = &row;
    let e = measure::parse(&l.join("\n"), "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("m.csv:3:16:"), "{e}");
    assert!(e.contains("XS99"), "{e}");
    // Wrong feature.
    let mut l = lines.clone();
    let row = l[2].replacen("x_straightness", "y_straightness", 1);
    l[2] = &row;
    let e = measure::parse(&l.join("\n"), "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("m.csv:3:1:") && e.contains("belongs to feature `x_straightness`"),
        "{e}"
    );
    // A bad number.
    let mut l = lines.clone();
    let row = l[4].replacen(",5.00000", ",5.0x", 1);
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
        e.starts_with("m.csv:") && e.contains("missing: XS05"),
        "{e}"
    );
    // Header.
    let e = measure::parse("a,b\n", "m.csv", &plan)
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("m.csv:1:1:"), "{e}");
}

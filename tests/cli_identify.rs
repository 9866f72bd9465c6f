//! What a user types: `nccomp simulate-cut` and `nccomp identify`, their exit codes,
//! messages and files (issue 5).

mod common;
use common::cli::{nccomp, scratch};

use std::path::Path;
use std::process::Output;

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn s(p: &Path) -> String {
    p.to_str().unwrap().to_string()
}

const MACHINE: &str = "fixtures/ac_trunnion.machine.toml";
const PLAN: &str = "fixtures/feature_workpiece.plan.toml";
const PROGRAM: &str = "fixtures/feature_workpiece.nc";

/// The value of `name = ...` in an error file.
fn value(errors: &str, name: &str) -> f64 {
    let line = errors
        .lines()
        .find(|l| l.starts_with(&format!("{name} = ")))
        .unwrap_or_else(|| panic!("no {name} in\n{errors}"));
    line.split('=').nth(1).unwrap().trim().parse().unwrap()
}

#[test]
fn simulated_cut_identified_and_compensated() {
    let dir = scratch("flow");
    let (a, b, e) = (dir.join("a.csv"), dir.join("b.csv"), dir.join("e.toml"));
    let out = nccomp(&[
        "simulate-cut",
        "-m",
        MACHINE,
        "--plan",
        PLAN,
        "--program",
        PROGRAM,
        "--errors",
        "fixtures/feature_workpiece.quasi_static.toml",
        "--dynamic",
        "fixtures/feature_workpiece.dynamic.toml",
        "--on-machine",
        &s(&a),
        "--cmm",
        &s(&b),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let summary = text(&out.stdout);
    assert!(summary.contains("cylinder (C alone)"), "{summary}");
    let cmm = std::fs::read_to_string(&b).unwrap();
    assert!(cmm.starts_with("feature,id,x,y,z\n"));
    assert_eq!(cmm.lines().count(), 1 + 2728);

    let out = nccomp(&[
        "identify",
        "-m",
        MACHINE,
        "--plan",
        PLAN,
        "--program",
        PROGRAM,
        "--on-machine",
        &s(&a),
        "--cmm",
        &s(&b),
        "-o",
        &s(&e),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let table = text(&out.stdout);
    let row = table.lines().find(|l| l.starts_with("EC0Y")).unwrap();
    assert!(row.contains("S_yx") && row.ends_with("µrad"), "{row}");
    // The quasi-static part by default: the paper's S_yx 0.0295° = 514.9 µrad.
    let errors = std::fs::read_to_string(&e).unwrap();
    assert!((value(&errors, "EC0Y") - 514.872).abs() < 5.0, "{errors}");
    assert!((value(&errors, "EX0C") - 5.6).abs() < 0.5, "{errors}");

    // `compensate` reads it.
    let comp = dir.join("comp.nc");
    let out = nccomp(&[
        "compensate",
        "-m",
        MACHINE,
        "-e",
        &s(&e),
        PROGRAM,
        "-o",
        &s(&comp),
        "-q",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(std::fs::read_to_string(&comp).unwrap().len() > 1000);
}

/// Eight points of the cylinder, cut by C alone.
fn cylinder_plan(radius: f64) -> String {
    let mut points = String::new();
    for k in 0..8 {
        let a = (45.0 * f64::from(k)).to_radians();
        let (x, y) = (a.sin(), -a.cos());
        let r = if k == 5 { radius } else { 25.0 };
        points.push_str(&format!(
            "  {{ id = \"C{k}\", at = [{:.6}, {:.6}, 50.0], normal = [{x:.9}, {y:.9}, 0.0] }},\n",
            r * x,
            r * y
        ));
    }
    format!(
        "tool_radius = 3.0\ntool = 1\n\n[[feature]]\nname = \"cylinder\"\nidentifies = [\"EX0C\", \"EY0C\"]\npoints = [\n{points}]\n"
    )
}

#[test]
fn part_chooses_what_goes_into_the_error_file() {
    let dir = scratch("part");
    let plan = write(&dir, "plan.toml", &cylinder_plan(25.0));
    let quasi = write(&dir, "q.toml", "[location.C]\nEX0C = 5.6\nEY0C = 6.0\n");
    let dynamic = write(&dir, "d.toml", "[location.C]\nEX0C = -3.3\nEY0C = 2.5\n");
    let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
    let out = nccomp(&[
        "simulate-cut",
        "-m",
        MACHINE,
        "--plan",
        &plan,
        "--program",
        PROGRAM,
        "-e",
        &quasi,
        "--dynamic",
        &dynamic,
        "--noise",
        "0",
        "--on-machine",
        &s(&a),
        "--cmm",
        &s(&b),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    for (part, x, y) in [
        ("quasi-static", 5.6, 6.0),
        ("dynamic", -3.3, 2.5),
        ("total", 2.3, 8.5),
    ] {
        let e = dir.join(format!("{part}.toml"));
        let out = nccomp(&[
            "identify",
            "-m",
            MACHINE,
            "--plan",
            &plan,
            "--program",
            PROGRAM,
            "--on-machine",
            &s(&a),
            "--cmm",
            &s(&b),
            "--part",
            part,
            "-o",
            &s(&e),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let errors = std::fs::read_to_string(&e).unwrap();
        assert!(
            (value(&errors, "EX0C") - x).abs() < 0.02,
            "{part}: {errors}"
        );
        assert!(
            (value(&errors, "EY0C") - y).abs() < 0.02,
            "{part}: {errors}"
        );
    }
}

#[test]
fn bad_inputs_name_file_line_and_column() {
    let dir = scratch("bad");
    let plan_text = cylinder_plan(25.0);
    let plan = write(&dir, "plan.toml", &plan_text);
    let quasi = write(&dir, "q.toml", "[location.C]\nEX0C = 5.6\n");
    let (a, b) = (dir.join("a.csv"), dir.join("b.csv"));
    let simulate = |plan: &str, errors: &str, noise: &str| {
        nccomp(&[
            "simulate-cut",
            "-m",
            MACHINE,
            "--plan",
            plan,
            "--program",
            PROGRAM,
            "-e",
            errors,
            "--noise",
            noise,
            "--on-machine",
            &s(&a),
            "--cmm",
            &s(&b),
        ])
    };
    assert!(simulate(&plan, &quasi, "0.5").status.success());
    let identify = |plan: &str, cmm: &str| {
        nccomp(&[
            "identify",
            "-m",
            MACHINE,
            "--plan",
            plan,
            "--program",
            PROGRAM,
            "--on-machine",
            &s(&a),
            "--cmm",
            cmm,
        ])
    };
    // Rendered rustc-style: `error: message`, then ` --> file:line:column` where there is
    // a place (`place` is `file:line:column:`, `file:` or empty).
    let fails = |out: Output, place: &str, words: &str| {
        assert_eq!(out.status.code(), Some(2), "{}", text(&out.stderr));
        let e = text(&out.stderr);
        assert!(e.starts_with("error: ") && e.contains(words), "{e}");
        if let Some(place) = place.strip_suffix(':') {
            assert!(e.contains(&format!("--> {place}")), "{place}: {e}");
        }
    };
    // A measurement that does not read.
    let cmm = std::fs::read_to_string(&b).unwrap();
    let row = cmm.lines().nth(3).unwrap();
    let x = row.split(',').nth(2).unwrap();
    let bad = write(
        &dir,
        "bad.csv",
        &cmm.replacen(row, &row.replacen(x, "1.2.3", 1), 1),
    );
    let col = row.find(x).unwrap() + 1;
    fails(
        identify(&plan, &bad),
        &format!("{bad}:4:{col}:"),
        "`1.2.3` is not a number",
    );
    // A point left out.
    let short = write(&dir, "short.csv", &cmm.replacen(&format!("{row}\n"), "", 1));
    fails(identify(&plan, &short), &format!("{short}:"), "missing: C2");
    // A term the machine does not have.
    let typo = write(
        &dir,
        "typo.toml",
        &plan_text.replacen("\"EY0C\"", "\"EY0Q\"", 1),
    );
    let line = |text: &str, what: &str| text.lines().position(|l| l.contains(what)).unwrap() + 1;
    let at = format!("{typo}:{}:23:", line(&plan_text, "identifies"));
    fails(identify(&typo, &s(&b)), &at, "no axis Q");
    // Terms the points cannot tell apart: the tilts of C from one ring of the cylinder.
    let both = plan_text.replacen("\"EY0C\"]", "\"EY0C\", \"EA0C\", \"EB0C\"]", 1);
    let tilts = write(&dir, "tilts.toml", &both);
    let at = format!("{tilts}:{}:31:", line(&plan_text, "identifies"));
    fails(
        identify(&tilts, &s(&b)),
        &at,
        "cannot tell these terms apart",
    );
    // A point the program does not cut.
    let off = write(&dir, "off.toml", &cylinder_plan(26.0));
    let at = format!("{off}:{}:", line(&plan_text, "\"C5\""));
    fails(simulate(&off, &quasi, "0.5"), &at, "`C5`");
    // An error file with an unknown term.
    let unknown = write(&dir, "u.toml", "[location.C]\nEX0Q = 5.6\n");
    fails(
        simulate(&plan, &unknown, "0.5"),
        &format!("{unknown}:2:1:"),
        "EX0Q",
    );
    // Noise must be a standard deviation.
    fails(simulate(&plan, &quasi, "-1"), "", "--noise -1");
}

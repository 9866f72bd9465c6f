//! What a user types: `nccomp sensitivity ...` and `nccomp tolerance ...`.

mod common;
use common::cli::{nccomp, scratch, stderr, stdout};

const M: &str = "fixtures/grinder.machine.toml";
const B: &str = "fixtures/grinder.budget.toml";

#[test]
fn sensitivity_prints_the_parameter_study() {
    let out = nccomp(&["sensitivity", "-m", M, "--at", "X=50,Y=45,Z=5"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.starts_with("Parameter study at X=50 Y=45 Z=5"),
        "{text}"
    );
    assert!(text.contains("EZZ   1 µm"), "{text}");
    // Other units, a few terms, worst case over a grid.
    let out = nccomp(&[
        "sensitivity",
        "-m",
        M,
        "--terms",
        "EBX,EZZ",
        "--unit-length",
        "2",
        "--unit-angle",
        "1",
        "--grid",
        "2",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(text.contains("worst case over 8 poses"), "{text}");
    assert!(
        text.contains("EZZ   2 µm") && text.contains("EBX   1 µrad"),
        "{text}"
    );
    assert!(text.contains("3.50e-04"), "{text}"); // 1 µrad over 350 mm
}

#[test]
fn sensitivity_with_a_budget_ranks_writes_json_and_an_svg() {
    let dir = scratch("json");
    let svg = dir.join("ranking.svg");
    let out = nccomp(&[
        "sensitivity",
        "-m",
        M,
        "-b",
        B,
        "--samples",
        "64",
        "--format",
        "json",
        "--svg",
        svg.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let json: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(json["study"]["rows"].as_array().unwrap().len(), 21);
    assert_eq!(json["study"]["mode"], "worst_case");
    let key: Vec<&str> = json["ranking"]["key"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_str().unwrap())
        .collect();
    assert_eq!(key, ["EZZ", "EBX", "EZY", "EZX", "EAY", "EAX"]);
    assert_eq!(json["ranking"]["sobol"]["samples"], 64);
    let chart = std::fs::read_to_string(&svg).unwrap();
    assert!(chart.starts_with("<svg") && chart.contains("EZZ *"));

    // CSV: the study's block, an empty line, the ranking's block.
    let out = nccomp(&[
        "sensitivity",
        "-m",
        M,
        "-b",
        B,
        "--samples",
        "16",
        "--format",
        "csv",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    let blocks: Vec<&str> = text.split("\n\n").collect();
    assert_eq!(blocks.len(), 2, "{text}");
    assert!(blocks[0].starts_with("term,unit,unit_label,pose,exact_dx"));
    assert!(blocks[1].starts_with("term,unit,level1,level2,level3,anova_rank"));
    assert_eq!(blocks[0].lines().count(), 22);
    assert!(
        blocks[1]
            .lines()
            .nth(1)
            .unwrap()
            .starts_with("EZZ,mm,0.005,0.009,0.013,1,")
    );
}

#[test]
fn tolerance_prints_the_design() {
    let out = nccomp(&["tolerance", "-m", M, "-b", B]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.starts_with("Tolerance design along [0, 0, 1]"),
        "{text}"
    );
    assert!(
        text.contains("QC (objective)") && text.contains("EB0Z"),
        "{text}"
    );
    let out = nccomp(&["tolerance", "-m", M, "-b", B, "--format", "json"]);
    let json: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    let start = json["tolerance"]["start"]["qc"].as_f64().unwrap();
    let optimum = json["tolerance"]["optimum"]["qc"].as_f64().unwrap();
    assert!(optimum < start);
    // Another direction: the error along -X (a side wall) weighs other terms.
    let out = nccomp(&["tolerance", "-m", M, "-b", B, "--direction", "-1,0,0"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).starts_with("Tolerance design along [-1, 0, 0]"));
    assert!(json.get("study").is_none());
    let out = nccomp(&["tolerance", "-m", M, "-b", B, "--format", "csv"]);
    assert!(stdout(&out).starts_with("term,unit,curve,length_mm,lower,upper"));
}

#[test]
fn bad_input_exits_2_with_the_place() {
    let dir = scratch("bad");
    let bad = dir.join("bad.budget.toml");
    std::fs::write(&bad, "[ranges]\nEZX = [1, 2]\nEZQ = [1, 2]\n").unwrap();
    let out = nccomp(&["sensitivity", "-m", M, "-b", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.starts_with("error: `EZQ`: the machine has no axis Q"),
        "{err}"
    );
    assert!(
        err.contains("bad.budget.toml:3:1\n  |\n3 | EZQ = [1, 2]\n  | ^^^\n"),
        "{err}"
    );

    // A budget without [tolerance] cannot be designed.
    let out = nccomp(&["tolerance", "-m", M, "-b", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    std::fs::write(&bad, "[ranges]\nEZX = [1, 2]\n").unwrap();
    let out = nccomp(&["tolerance", "-m", M, "-b", bad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("no [tolerance] table"),
        "{}",
        stderr(&out)
    );

    for args in [
        vec!["sensitivity", "-m", M, "--svg", "x.svg"],
        vec!["sensitivity", "-m", M, "--at", "Q=1"],
        vec!["sensitivity", "-m", M, "--terms", "EA0X"],
        vec!["sensitivity", "-m", M, "--unit-angle", "0"],
        vec!["sensitivity", "-m", M, "--direction", "0,0,0", "-b", B],
        vec!["sensitivity", "-m", M, "--direction", "0,1", "-b", B],
        vec!["sensitivity", "-m", M, "--tool-chain", "upper"],
        vec!["sensitivity", "-m", "fixtures/none.toml"],
    ] {
        let out = nccomp(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(!stderr(&out).is_empty());
    }
}

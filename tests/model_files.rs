//! Machine files and error files: the fixtures load, units convert, and every kind of bad
//! input is reported at its place (`path:line:col`) with what was expected.

use nalgebra::Vector3;
use nccomp::model::{AxisKind, ErrorModel, Machine, error_file, machine_file};
use std::path::{Path, PathBuf};

const MACHINES: [&str; 6] = [
    "ac_trunnion",
    "bc_trunnion",
    "head_head",
    "grinder",
    "mill_turn",
    "lathe",
];

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

fn load_pair(machine: &str) -> (Machine, ErrorModel) {
    let m = machine_file::load(&fixture(&format!("{machine}.machine.toml")))
        .unwrap_or_else(|e| panic!("{}", e.render()));
    let e = error_file::load(&fixture(&format!("{machine}.errors.toml")), &m)
        .unwrap_or_else(|e| panic!("{}", e.render()));
    (m, e)
}

fn ac() -> Machine {
    load_pair("ac_trunnion").0
}

/// The message of a machine file that must fail.
fn machine_error(text: &str) -> String {
    match machine_file::parse(text, "m.toml") {
        Ok(m) => panic!("accepted: {m:?}"),
        Err(e) => e.to_string(),
    }
}

/// The message of an error file (for the AC trunnion) that must fail.
fn errors_error(text: &str) -> String {
    errors_error_for(&ac(), text)
}

fn errors_error_for(machine: &Machine, text: &str) -> String {
    match error_file::parse(text, "e.toml", machine) {
        Ok(m) => panic!("accepted: {m:?}"),
        Err(e) => e.to_string(),
    }
}

fn errors_ok(text: &str) -> ErrorModel {
    error_file::parse(text, "e.toml", &ac()).unwrap_or_else(|e| panic!("{}", e.render()))
}

/// `message` starts with `place` (`file:line:col:`) and contains every phrase.
#[track_caller]
fn assert_diag(message: &str, place: &str, phrases: &[&str]) {
    assert!(
        message.starts_with(&format!("{place}: ")),
        "expected a message at {place}, got: {message}"
    );
    for p in phrases {
        assert!(message.contains(p), "expected {p:?} in: {message}");
    }
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + a.abs().max(b.abs()))
}

// ---------------------------------------------------------------------------------------
// Fixtures

#[test]
fn every_fixture_pair_loads() {
    for m in MACHINES {
        let (machine, errors) = load_pair(m);
        assert_eq!(errors.axes.len(), machine.axes.len(), "{m}");
        assert!(!errors.is_zero(), "{m}: the fixture errors are all zero");
        for axis in &machine.axes {
            assert!((axis.direction.norm() - 1.0).abs() < 1e-15, "{m}");
        }
        for e in &errors.axes {
            if let Some(t) = &e.motion {
                for s in t.values.iter().flatten() {
                    assert_eq!(s.len(), t.positions.len(), "{m}");
                }
            }
        }
    }
}

#[test]
fn ac_trunnion_is_the_papers_machine() {
    let (m, e) = load_pair("ac_trunnion");
    let names: Vec<&str> = m.axes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["X", "Y", "Z", "A", "C"]);
    let idx = |n: &str| m.axis_index(n).unwrap();
    assert_eq!(m.workpiece_chain, [idx("Y"), idx("X"), idx("A"), idx("C")]);
    assert_eq!(m.tool_chains.len(), 1);
    assert_eq!(m.tool_chains[0].name, "tool");
    assert_eq!(m.tool_chains[0].axes, [idx("Z")]);
    let a = &m.axes[idx("A")];
    assert_eq!(a.kind, AxisKind::Rotary);
    assert_eq!(a.direction, Vector3::new(-1.0, 0.0, 0.0));
    assert_eq!(a.point, Vector3::new(0.0, 0.0, -100.0));
    assert_eq!(a.travel, Some([-120.0, 30.0]));
    assert_eq!(m.axes[idx("C")].travel, None);
    assert_eq!(m.axes[idx("X")].travel, Some([-442.5, 442.5]));
    assert_eq!(m.tool.lengths.get(&1), Some(&95.3));

    let deg = std::f64::consts::PI / 180.0;
    assert!(close(e.axes[idx("Y")].squareness.z, 0.0455 * deg));
    let c = &e.axes[idx("C")];
    assert!(close(c.location_shift.x, 0.0023) && close(c.location_shift.y, 0.0085));
    assert!(close(c.location_tilt.x, 0.0057 * deg) && close(c.location_tilt.y, -0.0055 * deg));
    let a = &e.axes[idx("A")];
    assert_eq!(a.location_shift.x, 0.0);
    assert!(close(a.location_shift.y, 0.0059) && close(a.location_shift.z, 0.0081));
    assert!(close(a.location_tilt.y, 0.0048 * deg) && close(a.location_tilt.z, 0.0079 * deg));
    let t = e.axes[idx("X")].motion.as_ref().unwrap();
    assert_eq!(t.positions, [-50.0, 50.0]);
    assert!(!t.periodic);
    let ebx = t.values[4].as_ref().unwrap();
    assert!(close(ebx[0], 0.0062 * deg) && close(ebx[1], 0.0093 * deg));
    let ecx = t.values[5].as_ref().unwrap();
    assert!(close(ecx[0], 0.0349 * deg) && close(ecx[1], 0.0447 * deg));
    assert!(t.values[..4].iter().all(Option::is_none));
}

#[test]
fn mill_turn_has_named_tool_chains_and_words() {
    let (m, e) = load_pair("mill_turn");
    let names: Vec<&str> = m.tool_chains.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(names, ["upper", "lower"]);
    let axis = |n: &str| &m.axes[m.axis_index(n).unwrap()];
    let chain = |c: usize| -> Vec<&str> {
        m.tool_chains[c]
            .axes
            .iter()
            .map(|&i| m.axes[i].name.as_str())
            .collect()
    };
    assert_eq!(chain(0), ["Z1", "X1", "Y1", "B"]);
    assert_eq!(chain(1), ["Z2", "X2"]);
    assert_eq!(m.tool_chains[0].tools, [1, 2, 3, 4, 5, 6, 7, 8]);
    assert_eq!(m.chain_of_tool(11), Some(1));
    assert_eq!(m.chain_of_tool(9), None);
    let lathe = m.lathe.unwrap();
    assert_eq!(m.axes[lathe.spindle].name, "C");
    assert!(!lathe.diameter);
    assert_eq!(axis("X2").word, 'X');
    assert_eq!(axis("Z1").word, 'Z');
    assert_eq!(axis("C").word, 'C');
    assert_eq!(axis("X2").direction, Vector3::new(-1.0, 0.0, 0.0));
    let arcsec = std::f64::consts::PI / (180.0 * 3600.0);
    let z1 = &e.axes[m.axis_index("Z1").unwrap()];
    assert!(close(z1.squareness.y, 3.0 * arcsec));
    let t = e.axes[m.axis_index("X2").unwrap()].motion.as_ref().unwrap();
    assert!(close(t.values[0].as_ref().unwrap()[2], -3.5e-3));
}

#[test]
fn rotary_motion_tables_are_periodic() {
    let (m, e) = load_pair("head_head");
    let c = e.axes[m.axis_index("C").unwrap()].motion.as_ref().unwrap();
    assert!(c.periodic);
    assert_eq!(c.positions, [0.0, 90.0, 180.0, 270.0]);
    let (m, e) = load_pair("grinder");
    let x = e.axes[m.axis_index("X").unwrap()].motion.as_ref().unwrap();
    assert!(!x.periodic);
    assert!(
        x.values.iter().all(Option::is_some),
        "all six error motions of X"
    );
    // The paper's 21 errors: 6 error motions of each axis and 3 squareness terms.
    let motions: usize = e
        .axes
        .iter()
        .filter_map(|a| a.motion.as_ref())
        .map(|t| t.values.iter().flatten().count())
        .sum();
    let squareness: usize = e
        .axes
        .iter()
        .map(|a| a.squareness.iter().filter(|&&s| s != 0.0).count())
        .sum();
    assert_eq!((motions, squareness), (18, 3));
}

#[test]
fn bc_trunnion_tables_are_in_table_coordinates() {
    let (m, e) = load_pair("bc_trunnion");
    let x = m.axis_index("X").unwrap();
    assert_eq!(m.axes[x].table_offset, 300.0);
    let t = e.axes[x].motion.as_ref().unwrap();
    assert_eq!(t.positions, [0.0, 150.0, 300.0, 450.0, 600.0]);
    let b = &e.axes[m.axis_index("B").unwrap()];
    assert!(close(b.zero, 20e-6));
    assert!(close(b.location_shift.x, 4e-3) && close(b.location_shift.z, -6e-3));
    assert_eq!(m.resolution.linear, 0.001);
}

// ---------------------------------------------------------------------------------------
// Machine files that load

const SMALL: &str = "\
workpiece_chain = [\"X\"]
tool_chain = [\"Z\"]

[axes.X]
kind = \"linear\"
direction = [-2, 0, 0]

[axes.Z]
kind = \"linear\"
direction = [0, 0, 1]
";

#[test]
fn small_machine_defaults() {
    let m = machine_file::parse(SMALL, "m.toml").unwrap();
    assert_eq!(m.name, None);
    assert_eq!(
        m.axes[0].direction,
        Vector3::new(-1.0, 0.0, 0.0),
        "normalized"
    );
    assert_eq!(m.axes[0].word, 'X');
    assert_eq!(m.axes[0].point, Vector3::zeros());
    assert_eq!(m.axes[0].travel, None);
    assert_eq!(m.axes[0].table_offset, 0.0);
    assert_eq!(m.resolution.linear, 0.0001);
    assert_eq!(m.resolution.rotary, 0.0001);
    assert_eq!(m.tool.length, 0.0);
    assert!(m.tool.lengths.is_empty());
    assert_eq!(m.tool_chains[0].name, "tool");
}

#[test]
fn an_empty_chain_is_fine() {
    let text = SMALL.replace("workpiece_chain = [\"X\"]", "workpiece_chain = []");
    let text = text.replace("tool_chain = [\"Z\"]", "tool_chain = [\"X\", \"Z\"]");
    let m = machine_file::parse(&text, "m.toml").unwrap();
    assert!(m.workpiece_chain.is_empty());
    assert_eq!(m.tool_chains[0].axes, [0, 1]);
}

// ---------------------------------------------------------------------------------------
// Machine files that fail, one test per kind of problem

#[test]
fn machine_toml_syntax_error() {
    let msg = machine_error("workpiece_chain = [\"X\"\ntool_chain = [\"Z\"]\n");
    assert!(msg.starts_with("m.toml:"), "{msg}");
    assert!(msg.contains("invalid TOML"), "{msg}");
    let msg = machine_error("name = \"a\"\nname = \"b\"\n");
    assert_diag(&msg, "m.toml:2:1", &["invalid TOML", "duplicate key"]);
}

#[test]
fn machine_unknown_keys() {
    let msg = machine_error(&format!("nmae = \"x\"\n{SMALL}"));
    assert_diag(
        &msg,
        "m.toml:1:1",
        &["unknown key `nmae`", "did you mean `name`?"],
    );
    let msg = machine_error(&SMALL.replace("direction = [-2", "dirction = [-2"));
    assert_diag(
        &msg,
        "m.toml:6:1",
        &[
            "unknown key `dirction` in [axes.X]",
            "did you mean `direction`?",
            "`kind`",
        ],
    );
    let msg = machine_error(&format!(
        "{SMALL}\n[tool]\nlength = 1\nlenghts = {{ 1 = 2 }}\n"
    ));
    assert_diag(
        &msg,
        "m.toml:14:1",
        &["unknown key `lenghts` in [tool]", "`lengths`"],
    );
    let msg = machine_error(&format!(
        "resolution = {{ linear = 1, angular = 1 }}\n{SMALL}"
    ));
    assert_diag(&msg, "m.toml:1:28", &["unknown key `angular`", "`rotary`"]);
}

#[test]
fn machine_wrong_types() {
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "\"-X\""));
    assert_diag(
        &msg,
        "m.toml:6:13",
        &["`direction`", "expected an array of numbers", "string"],
    );
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0]"));
    assert_diag(&msg, "m.toml:6:13", &["expected three"]);
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, \"0\", 0]"));
    assert_diag(&msg, "m.toml:6:18", &["expected a number, found a string"]);
    let msg = machine_error(&SMALL.replace(
        "kind = \"linear\"\ndirection = [-2",
        "kind = 1\ndirection = [-2",
    ));
    assert_diag(&msg, "m.toml:5:8", &["`kind`", "expected a string"]);
    let msg = machine_error(&SMALL.replace(
        "\"linear\"\ndirection = [-2",
        "\"prismatic\"\ndirection = [-2",
    ));
    assert_diag(
        &msg,
        "m.toml:5:8",
        &["unknown axis kind `prismatic`", "\"linear\" or \"rotary\""],
    );
    let msg = machine_error(&SMALL.replace("tool_chain = [\"Z\"]", "tool_chain = \"Z\""));
    assert_diag(
        &msg,
        "m.toml:2:14",
        &["tool_chain", "expected an array of axis names"],
    );
    let msg = machine_error(&format!("name = 5\n{SMALL}"));
    assert_diag(
        &msg,
        "m.toml:1:8",
        &["`name`", "expected a string, found an integer"],
    );
}

#[test]
fn machine_missing_keys() {
    let msg = machine_error(&SMALL.replace(
        "kind = \"linear\"\ndirection = [-2, 0, 0]\n",
        "direction = [-2, 0, 0]\n",
    ));
    assert_diag(
        &msg,
        "m.toml:4:1",
        &["[axes.X] has no `kind`", "\"linear\""],
    );
    let msg = machine_error(&SMALL.replace("direction = [-2, 0, 0]\n", ""));
    assert_diag(&msg, "m.toml:4:1", &["[axes.X] has no `direction`"]);
}

#[test]
fn machine_non_finite_numbers() {
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0, 0]\ntravel = [nan, 10]"));
    assert_diag(&msg, "m.toml:7:11", &["`nan` is not a finite number"]);
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0, 0]\ntable_offset = -inf"));
    assert_diag(&msg, "m.toml:7:16", &["`-inf` is not a finite number"]);
}

#[test]
fn machine_axis_in_chain_not_defined() {
    let msg = machine_error(&SMALL.replace("tool_chain = [\"Z\"]", "tool_chain = [\"Z\", \"Q\"]"));
    assert_diag(
        &msg,
        "m.toml:2:20",
        &[
            "axis `Q` in tool_chain is not defined",
            "the defined axes are X, Z",
        ],
    );
    let msg = machine_error(&SMALL.replace("tool_chain = [\"Z\"]", "tool_chain = [\"z\"]"));
    assert_diag(&msg, "m.toml:2:15", &["axis `z`", "did you mean Z?"]);
}

#[test]
fn machine_axis_in_two_chains_or_twice() {
    let msg = machine_error(&SMALL.replace("tool_chain = [\"Z\"]", "tool_chain = [\"Z\", \"X\"]"));
    assert_diag(
        &msg,
        "m.toml:2:20",
        &[
            "axis X is named in tool_chain but is already in workpiece_chain",
            "exactly one chain",
        ],
    );
    let msg = machine_error(&SMALL.replace("tool_chain = [\"Z\"]", "tool_chain = [\"Z\", \"Z\"]"));
    assert_diag(
        &msg,
        "m.toml:2:20",
        &["axis Z is named again in tool_chain"],
    );
}

#[test]
fn machine_axis_in_no_chain() {
    let msg = machine_error(&format!(
        "{SMALL}\n[axes.Y]\nkind = \"linear\"\ndirection = [0, 1, 0]\n"
    ));
    assert_diag(&msg, "m.toml:12:7", &["axis Y is defined but in no chain"]);
}

#[test]
fn machine_same_word_twice() {
    let text = format!(
        "{}\n[axes.X2]\nkind = \"linear\"\nword = \"X\"\ndirection = [1, 0, 0]\n",
        SMALL.replace("tool_chain = [\"Z\"]", "tool_chain = [\"Z\", \"X2\"]")
    );
    let msg = machine_error(&text);
    assert_diag(
        &msg,
        "m.toml:2:20",
        &["axes X and X2 are both driven by program word X"],
    );
    // Two tool chains may use the same words: only one is active at a time.
    let (m, _) = load_pair("mill_turn");
    assert_eq!(m.axes[m.axis_index("Z2").unwrap()].word, 'Z');
}

#[test]
fn machine_axis_names_and_words() {
    let msg = machine_error(&format!(
        "{SMALL}\n[axes.X2]\nkind = \"linear\"\ndirection = [1, 0, 0]\n"
    ));
    assert_diag(
        &msg,
        "m.toml:12:1",
        &["axis X2", "expected `word = \"...\"`"],
    );
    let msg = machine_error(&format!(
        "{SMALL}\n[axes.x3]\nkind = \"linear\"\ndirection = [1, 0, 0]\n"
    ));
    assert_diag(&msg, "m.toml:12:7", &["axis name `x3`", "uppercase"]);
    let msg = machine_error(&format!(
        "{SMALL}\n[axes.Q]\nkind = \"linear\"\ndirection = [1, 0, 0]\n"
    ));
    assert_diag(&msg, "m.toml:12:7", &["Q is not a program axis word"]);
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0, 0]\nword = \"XY\""));
    assert_diag(&msg, "m.toml:7:8", &["expected one program letter"]);
}

#[test]
fn machine_travel_min_not_below_max() {
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0, 0]\ntravel = [100, -100]"));
    assert_diag(
        &msg,
        "m.toml:7:10",
        &["`travel = [100, -100]`", "expected min < max"],
    );
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0, 0]\ntravel = [5, 5]"));
    assert_diag(&msg, "m.toml:7:10", &["expected min < max"]);
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0, 0]\ntravel = [5]"));
    assert_diag(&msg, "m.toml:7:10", &["expected two"]);
}

#[test]
fn machine_resolution_outside_its_range() {
    let msg = machine_error(&format!(
        "resolution = {{ linear = 0.0, rotary = 0.001 }}\n{SMALL}"
    ));
    assert_diag(
        &msg,
        "m.toml:1:25",
        &[
            "resolution `linear` is 0.0",
            "expected a number from 0.000001 to 0.1 mm",
        ],
    );
    let msg = machine_error(&format!("resolution = {{ rotary = -1 }}\n{SMALL}"));
    assert_diag(
        &msg,
        "m.toml:1:25",
        &["resolution `rotary` is -1", "from 0.000001 to 0.1 degrees"],
    );
    // Absurdly coarse: every corrected word would be rounded to nothing.
    let msg = machine_error(&format!("resolution = {{ linear = 1e300 }}\n{SMALL}"));
    assert_diag(
        &msg,
        "m.toml:1:25",
        &["resolution `linear` is 1e300", "0.1 mm"],
    );
}

#[test]
fn machine_point_on_linear_and_reference_point_on_rotary() {
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[-2, 0, 0]\npoint = [0, 0, 0]"));
    assert_diag(
        &msg,
        "m.toml:7:1",
        &[
            "`point` is for rotary axes",
            "X is linear",
            "`reference_point`",
        ],
    );
    let text = format!(
        "{}\n[axes.C]\nkind = \"rotary\"\ndirection = [0, 0, -1]\nreference_point = [0, 0, 0]\n",
        SMALL.replace(
            "workpiece_chain = [\"X\"]",
            "workpiece_chain = [\"X\", \"C\"]"
        )
    );
    let msg = machine_error(&text);
    assert_diag(
        &msg,
        "m.toml:15:1",
        &[
            "`reference_point` is for linear axes",
            "C is rotary",
            "`point`",
        ],
    );
}

#[test]
fn machine_rotary_without_point() {
    let text = format!(
        "{}\n[axes.C]\nkind = \"rotary\"\ndirection = [0, 0, -1]\n",
        SMALL.replace(
            "workpiece_chain = [\"X\"]",
            "workpiece_chain = [\"X\", \"C\"]"
        )
    );
    let msg = machine_error(&text);
    assert_diag(
        &msg,
        "m.toml:12:1",
        &["rotary axis C has no `point`", "point on its axis line"],
    );
}

#[test]
fn machine_zero_direction() {
    let msg = machine_error(&SMALL.replace("[-2, 0, 0]", "[0, 0.0, 0]"));
    assert_diag(&msg, "m.toml:6:13", &["zero vector", "non-zero direction"]);
}

#[test]
fn machine_without_axes() {
    let msg = machine_error("name = \"nothing\"\n");
    assert_diag(
        &msg,
        "m.toml:1:1",
        &["the machine has no axes", "workpiece_chain"],
    );
    let msg = machine_error("name = \"x\"\nworkpiece_chain = []\ntool_chain = []\n");
    assert_diag(
        &msg,
        "m.toml:2:1",
        &["the machine has no axes", "chains are all empty"],
    );
}

#[test]
fn machine_tool_chain_and_tool_chains() {
    let msg = machine_error(&format!("{SMALL}\n[tool_chains]\nupper = [\"Z\"]\n"));
    assert_diag(
        &msg,
        "m.toml:12:2",
        &["either `tool_chain = [...]`", "[tool_chains]", "not both"],
    );
    let text = SMALL.replace("tool_chain = [\"Z\"]\n", "tool_chains = {}\n");
    let msg = machine_error(&text);
    assert_diag(&msg, "m.toml:2:15", &["[tool_chains] is empty"]);
}

#[test]
fn machine_tool_lengths_by_h_number() {
    let msg = machine_error(&format!("{SMALL}\n[tool]\nlengths = {{ T1 = 95.3 }}\n"));
    assert_diag(&msg, "m.toml:13:13", &["tool length key `T1`", "H number"]);
    let m = machine_file::parse(
        &format!("{SMALL}\n[tool]\nlength = 50\nlengths = {{ 1 = 95.3, 17 = 100 }}\n"),
        "m.toml",
    )
    .unwrap();
    assert_eq!(m.tool.length, 50.0);
    assert_eq!(m.tool.lengths.get(&17), Some(&100.0));
}

#[test]
fn machine_load_reports_io_errors() {
    let e = machine_file::load(Path::new("/nonexistent/x.machine.toml")).unwrap_err();
    assert!(
        e.to_string().starts_with("/nonexistent/x.machine.toml: "),
        "{e}"
    );
    let e = error_file::load(Path::new("/nonexistent/x.errors.toml"), &ac()).unwrap_err();
    assert!(
        e.to_string().starts_with("/nonexistent/x.errors.toml: "),
        "{e}"
    );
}

// ---------------------------------------------------------------------------------------
// Error files: units

#[test]
fn units_convert_to_mm_and_rad() {
    let y = 1; // axis index of Y on the AC trunnion
    let c = 4;
    let cases = [
        ("mm", "rad", 1.0, 1.0),
        ("um", "urad", 1e-3, 1e-6),
        ("mm", "deg", 1.0, std::f64::consts::PI / 180.0),
        ("um", "arcsec", 1e-3, std::f64::consts::PI / 648_000.0),
    ];
    // Angles within 0.1 rad in every unit (the limit of an angle error).
    for (lu, au, lf, af) in cases {
        let m = errors_ok(&format!(
            "length_unit = \"{lu}\"\nangle_unit = \"{au}\"\n[squareness]\nEC0Y = 0.025\n\
             [location.C]\nEX0C = 3\n[motion.C]\npositions = [0, 180]\nEZC = [1, 2]\nECC = [0.04, 0.05]\n"
        ));
        assert!(close(m.axes[y].squareness.z, 0.025 * af), "{au}");
        assert!(close(m.axes[c].location_shift.x, 3.0 * lf), "{lu}");
        let t = m.axes[c].motion.as_ref().unwrap();
        assert_eq!(t.positions, [0.0, 180.0], "positions are not error units");
        assert!(close(t.values[2].as_ref().unwrap()[1], 2.0 * lf));
        assert!(close(t.values[5].as_ref().unwrap()[0], 0.04 * af));
        assert!(t.periodic);
    }
}

#[test]
fn default_units_are_um_and_urad() {
    let m = errors_ok("[squareness]\nEC0Y = 45.5\n[location.C]\nEY0C = 8.5\n");
    assert!(close(m.axes[1].squareness.z, 45.5e-6));
    assert!(close(m.axes[4].location_shift.y, 8.5e-3));
}

#[test]
fn units_only_is_the_zero_model() {
    let m = errors_ok("length_unit = \"mm\"\nangle_unit = \"deg\"\n");
    assert!(m.is_zero());
    assert_eq!(m, ErrorModel::zero(&ac()));
    assert!(errors_ok("").is_zero());
    assert!(errors_ok("# nothing\n").is_zero());
}

#[test]
fn unknown_units() {
    let msg = errors_error("length_unit = \"µm\"\n");
    assert_diag(
        &msg,
        "e.toml:1:15",
        &["unknown length unit", "\"mm\" or \"um\""],
    );
    let msg = errors_error("angle_unit = \"degrees\"\n");
    assert_diag(&msg, "e.toml:1:14", &["unknown angle unit", "\"deg\""]);
}

#[test]
fn zero_error_and_tilt_of_a_rotary_axis() {
    let m = errors_ok("[location.A]\nEA0A = 10\nEB0A = 20\nEC0A = 30\nEY0A = 1\nEZ0A = 2\n");
    let a = &m.axes[3];
    assert!(close(a.zero, 10e-6));
    let (t, s) = (a.location_tilt, a.location_shift);
    assert!(t.x == 0.0 && close(t.y, 20e-6) && close(t.z, 30e-6));
    assert!(s.x == 0.0 && close(s.y, 1e-3) && close(s.z, 2e-3));
}

// ---------------------------------------------------------------------------------------
// Error files that fail, one test per kind of problem

#[test]
fn errors_toml_syntax_error() {
    let msg = errors_error("[squareness]\nEC0Y = 1.2.3\n");
    assert_diag(&msg, "e.toml:2:11", &["invalid TOML"]);
}

#[test]
fn errors_unknown_top_level_key() {
    let msg = errors_error("lenght_unit = \"mm\"\n");
    assert_diag(
        &msg,
        "e.toml:1:1",
        &["unknown key `lenght_unit`", "did you mean `length_unit`?"],
    );
    let msg = errors_error("angle_unit = \"rad\"\nEC0Y = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &["unknown key `EC0Y`", "error terms go in [squareness]"],
    );
    let msg = errors_error("[squarenes]\nEC0Y = 1\n");
    assert_diag(&msg, "e.toml:1:2", &["did you mean `squareness`?"]);
}

#[test]
fn errors_unknown_axis_in_section_header() {
    let msg = errors_error("[motion.Q]\npositions = [0]\n");
    assert_diag(
        &msg,
        "e.toml:1:9",
        &["[motion.Q]", "no axis `Q`", "X, Y, Z, A or C"],
    );
    let msg = errors_error("[location.c]\nEX0C = 1\n");
    assert_diag(
        &msg,
        "e.toml:1:11",
        &["no axis `c`", "did you mean [location.C]?", "A or C"],
    );
}

#[test]
fn errors_location_of_a_linear_axis() {
    let msg = errors_error("[location.X]\nEB0X = 1\n");
    assert_diag(
        &msg,
        "e.toml:1:11",
        &[
            "location errors are for rotary axes",
            "X is linear",
            "[squareness]",
        ],
    );
}

#[test]
fn errors_misspelled_names_are_never_zero() {
    let msg = errors_error("[motion.X]\npositions = [0, 1]\nEYXX = [0, 1]\n");
    assert_diag(
        &msg,
        "e.toml:3:1",
        &[
            "unknown error name `EYXX` in [motion.X]",
            "did you mean `EYX`?",
        ],
    );
    let msg = errors_error("[motion.X]\npositions = [0, 1]\neyx = [0, 1]\n");
    assert_diag(&msg, "e.toml:3:1", &["did you mean `EYX`?"]);
    let msg = errors_error("[squareness]\nEC0YY = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &[
            "unknown error name `EC0YY`",
            "no axis `YY`",
            "did you mean `EC0Y`?",
        ],
    );
    let msg = errors_error("[location.C]\nXOC = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &[
            "unknown error name `XOC` in [location.C]",
            "expected one of EX0C, EY0C, EA0C, EB0C or EC0C",
        ],
    );
    let msg = errors_error("[motion.X]\npositions = [0, 1]\nposition = [0, 1]\n");
    assert_diag(&msg, "e.toml:3:1", &["did you mean `positions`?"]);
}

#[test]
fn errors_term_in_the_wrong_section() {
    // A location term of another rotary axis.
    let msg = errors_error("[location.A]\nEX0C = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &[
            "`EX0C` is a location error of rotary axis C",
            "belongs under [location.C], not [location.A]",
        ],
    );
    // A position-independent term of a rotary axis under [squareness].
    let msg = errors_error("[squareness]\nEB0C = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &[
            "location error of rotary axis C",
            "belongs under [location.C], not [squareness]",
        ],
    );
    // A squareness term under a location section.
    let msg = errors_error("[location.C]\nEC0Y = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &[
            "squareness term of linear axis Y",
            "belongs under [squareness]",
        ],
    );
    // An error motion of another axis inside [motion.X].
    let msg = errors_error("[motion.X]\npositions = [0, 1]\nEYZ = [0, 1]\n");
    assert_diag(
        &msg,
        "e.toml:3:1",
        &[
            "`EYZ` is an error motion of axis Z",
            "belongs under [motion.Z], not [motion.X]",
            "did you mean `EYX`?",
        ],
    );
    // An error motion given as a single value.
    let msg = errors_error("[squareness]\nEYX = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &["error motion of axis X", "[motion.X]"],
    );
    // A position-independent term inside a motion table.
    let msg = errors_error("[motion.C]\npositions = [0, 1]\nEX0C = [0, 1]\n");
    assert_diag(
        &msg,
        "e.toml:3:1",
        &[
            "location error of rotary axis C",
            "belongs under [location.C], not [motion.C]",
        ],
    );
}

#[test]
fn errors_series_length_differs_from_positions() {
    let msg = errors_error("[motion.X]\npositions = [0, 1, 2]\nEYX = [0, 1]\n");
    assert_diag(
        &msg,
        "e.toml:3:7",
        &[
            "`EYX` has 2 values: expected 3",
            "one per entry of `positions`",
        ],
    );
}

#[test]
fn errors_positions_not_strictly_increasing() {
    let msg = errors_error("[motion.X]\npositions = [0, 10, 10, 20]\nEYX = [0, 1, 2, 3]\n");
    assert_diag(
        &msg,
        "e.toml:2:21",
        &["position 10 follows 10", "strictly increasing"],
    );
    let msg = errors_error("[motion.X]\npositions = [0, -10]\n");
    assert_diag(&msg, "e.toml:2:17", &["position -10 follows 0"]);
}

#[test]
fn errors_rotary_table_over_a_revolution() {
    let msg = errors_error("[motion.C]\npositions = [-180, 0, 190]\nECC = [0, 1, 2]\n");
    assert_diag(&msg, "e.toml:2:13", &["span 370°", "at most 360°"]);
    // One revolution exactly is fine if the ends agree ...
    let m = errors_ok("[motion.C]\npositions = [0, 180, 360]\nECC = [1, 2, 1]\n");
    assert!(m.axes[4].motion.as_ref().unwrap().periodic);
    // ... and refused if they do not.
    let msg = errors_error("[motion.C]\npositions = [0, 180, 360]\nECC = [1, 2, 3]\n");
    assert_diag(
        &msg,
        "e.toml:3:14",
        &["same angle", "expected equal values"],
    );
    // A linear axis may span any length.
    errors_ok("[motion.X]\npositions = [-400, 400]\nEXX = [0, 1]\n");
}

#[test]
fn errors_empty_or_missing_positions() {
    let msg = errors_error("[motion.X]\npositions = []\n");
    assert_diag(&msg, "e.toml:2:13", &["`positions` is empty"]);
    let msg = errors_error("[motion.X]\nEYX = [0, 1]\n");
    assert_diag(&msg, "e.toml:1:1", &["[motion.X] has no `positions`"]);
}

#[test]
fn errors_meaningless_terms() {
    // A shift of a rotary axis along its own line.
    let msg = errors_error("[location.C]\nEZ0C = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &["`EZ0C` is meaningless", "own line", "EX0C and EY0C"],
    );
    let msg = errors_error("[location.A]\nEX0A = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &["`EX0A` is meaningless", "EY0A and EZ0A"],
    );
    // A squareness of a linear axis about its own direction.
    let msg = errors_error("[squareness]\nEC0Z = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &["`EC0Z` is meaningless", "EA0Z and EB0Z"],
    );
    // A length as a squareness.
    let msg = errors_error("[squareness]\nEX0Y = 1\n");
    assert_diag(
        &msg,
        "e.toml:2:1",
        &["not an error of linear axis Y", "EA0Y or EC0Y"],
    );
}

#[test]
fn errors_non_finite_numbers() {
    let msg = errors_error("[squareness]\nEC0Y = nan\n");
    assert_diag(&msg, "e.toml:2:8", &["`nan` is not a finite number"]);
    let msg = errors_error("[motion.X]\npositions = [0, 1]\nEYX = [0, +inf]\n");
    assert_diag(&msg, "e.toml:3:11", &["`+inf` is not a finite number"]);
    let msg = errors_error("[motion.X]\npositions = [0, inf]\n");
    assert_diag(&msg, "e.toml:2:17", &["`inf` is not a finite number"]);
}

#[test]
fn errors_wrong_value_shapes() {
    let msg = errors_error("[squareness]\nEC0Y = [1, 2]\n");
    assert_diag(
        &msg,
        "e.toml:2:8",
        &["position-independent term", "expected one number"],
    );
    let msg = errors_error("[motion.X]\npositions = [0, 1]\nEYX = 1\n");
    assert_diag(&msg, "e.toml:3:7", &["expected an array of numbers"]);
    let msg = errors_error("[squareness]\nEC0Y = \"1\"\n");
    assert_diag(&msg, "e.toml:2:8", &["expected a number, found a string"]);
    let msg = errors_error("squareness = 1\n");
    assert_diag(&msg, "e.toml:1:14", &["expected [squareness]"]);
}

#[test]
fn errors_use_the_machines_axis_names() {
    let (m, _) = load_pair("mill_turn");
    let msg = errors_error_for(&m, "[motion.X1]\npositions = [0, 1]\nEXX = [0, 1]\n");
    assert_diag(
        &msg,
        "e.toml:3:1",
        &["`EXX`", "no axis `X`", "did you mean `EXX1`?"],
    );
    let msg = errors_error_for(&m, "[location.X1]\nEC0X1 = 1\n");
    assert_diag(&msg, "e.toml:1:11", &["X1 is linear"]);
}

/// A small lathe: spindle C, one turret Z X (a `[tool_chains]` table with tools when
/// `chains` is given).
fn lathe_text(chains: &str, lathe: &str) -> String {
    format!(
        "workpiece_chain = [\"C\"]\n{chains}\n{lathe}\n\
         [axes.C]\nkind = \"rotary\"\ndirection = [0, 0, -1]\npoint = [0, 0, 0]\n\n\
         [axes.Z]\nkind = \"linear\"\ndirection = [0, 0, 1]\n\n\
         [axes.X]\nkind = \"linear\"\ndirection = [1, 0, 0]\n\n\
         [axes.X2]\nkind = \"linear\"\nword = \"X\"\ndirection = [-1, 0, 0]\n\n\
         [axes.Z2]\nkind = \"linear\"\nword = \"Z\"\ndirection = [0, 0, 1]\n"
    )
}

const TWO_TURRETS: &str = "[tool_chains]\nupper = [\"Z\", \"X\"]\nlower = [\"Z2\", \"X2\"]\n";

#[test]
fn tool_chains_list_their_tools_and_a_lathe_names_its_spindle() {
    let text = lathe_text(
        "[tool_chains.upper]\naxes = [\"Z\", \"X\"]\ntools = [1, 2]\n\n\
         [tool_chains.lower]\naxes = [\"Z2\", \"X2\"]\ntools = [11]\n",
        "[lathe]\nspindle = \"C\"\ndiameter = true\n",
    );
    let m = machine_file::parse(&text, "m.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(m.tool_chains[0].tools, [1, 2]);
    assert_eq!(m.chain_of_tool(11), Some(1));
    assert_eq!(m.chain_of_tool(3), None);
    let lathe = m.lathe.unwrap();
    assert_eq!(m.axes[lathe.spindle].name, "C");
    assert!(lathe.diameter);
    // Chains as plain arrays (no tools) and no [lathe]: as before.
    let m = machine_file::parse(&lathe_text(TWO_TURRETS, ""), "m.toml").unwrap();
    assert!(m.tool_chains.iter().all(|c| c.tools.is_empty()) && m.lathe.is_none());
}

#[test]
fn bad_tool_lists_are_reported_at_their_place() {
    let msg = machine_error(&lathe_text(
        "[tool_chains.upper]\naxes = [\"Z\", \"X\"]\ntools = [1, 2]\n\n\
         [tool_chains.lower]\naxes = [\"Z2\", \"X2\"]\ntools = [3, 2]\n",
        "",
    ));
    assert_diag(
        &msg,
        "m.toml:8:13",
        &["tool T2", "already selects tool chain `upper`"],
    );
    let msg = machine_error(&lathe_text(
        "[tool_chains.upper]\naxes = [\"Z\", \"X\"]\ntools = [0]\n\n\
         [tool_chains.lower]\naxes = [\"Z2\", \"X2\"]\n",
        "",
    ));
    assert_diag(
        &msg,
        "m.toml:4:10",
        &["expected a T number", "T0 selects no tool"],
    );
    let msg = machine_error(&lathe_text(
        "[tool_chains.upper]\naxis = [\"Z\", \"X\"]\n\n\
         [tool_chains.lower]\naxes = [\"Z2\", \"X2\"]\n",
        "",
    ));
    assert_diag(
        &msg,
        "m.toml:3:1",
        &[
            "unknown key `axis` in [tool_chains.upper]",
            "did you mean `axes`?",
        ],
    );
    let msg = machine_error(&lathe_text(
        "[tool_chains.upper]\ntools = [1]\n\n[tool_chains.lower]\naxes = [\"Z2\", \"X2\"]\n",
        "",
    ));
    assert_diag(&msg, "m.toml:2:1", &["[tool_chains.upper] has no `axes`"]);
}

#[test]
fn bad_lathe_tables_are_reported_at_their_place() {
    let msg = machine_error(&lathe_text(TWO_TURRETS, "[lathe]\nspindle = \"X\"\n"));
    assert_diag(
        &msg,
        "m.toml:7:11",
        &["`spindle = \"X\"`", "a rotary axis of the workpiece chain"],
    );
    let msg = machine_error(&lathe_text(TWO_TURRETS, "[lathe]\nspindle = \"S\"\n"));
    assert_diag(&msg, "m.toml:7:11", &["there is no axis S"]);
    let msg = machine_error(&lathe_text(TWO_TURRETS, "[lathe]\ndiameter = true\n"));
    assert_diag(&msg, "m.toml:6:1", &["[lathe] has no `spindle`"]);
    let msg = machine_error(&lathe_text(
        TWO_TURRETS,
        "[lathe]\nspindle = \"C\"\ndiameter = \"yes\"\n",
    ));
    assert_diag(
        &msg,
        "m.toml:8:12",
        &["`diameter`: expected true", "found a string"],
    );
    let msg = machine_error(&lathe_text(TWO_TURRETS, "[lathe]\nspindel = \"C\"\n"));
    assert_diag(&msg, "m.toml:7:1", &["unknown key `spindel` in [lathe]"]);
    // A turret without Z cannot turn.
    let msg = machine_error(
        &lathe_text(
            "[tool_chains]\nupper = [\"Z\", \"X\"]\nlower = [\"X2\"]\n",
            "[lathe]\nspindle = \"C\"\n",
        )
        .replace(
            "[axes.Z2]\nkind = \"linear\"\nword = \"Z\"\ndirection = [0, 0, 1]\n",
            "",
        ),
    );
    assert_diag(
        &msg,
        "m.toml:6:1",
        &["tool chain `lower` has no linear axis driven by Z"],
    );
}

#[test]
fn a_machine_file_names_its_own_codes() {
    let text = format!(
        "{SMALL}\n[codes]\nharmless = [\"M100\", \"G12.1\"]\ntcp_on = [\"M428\"]\ntcp_off = [\"m429\"]\n"
    );
    let m = machine_file::parse(&text, "m.toml").unwrap_or_else(|e| panic!("{}", e.render()));
    let names = |list: &[nccomp::program::CodeName]| -> Vec<String> {
        list.iter().map(ToString::to_string).collect()
    };
    assert_eq!(names(&m.codes.harmless), ["M100", "G12.1"]);
    assert_eq!(names(&m.codes.tcp_on), ["M428"]);
    assert_eq!(names(&m.codes.tcp_off), ["M429"]);
    // Without [codes] the machine names none.
    assert!(
        machine_file::parse(SMALL, "m.toml")
            .unwrap()
            .codes
            .is_empty()
    );
}

#[test]
fn a_machine_file_cannot_rename_nccomps_codes_or_name_a_code_twice() {
    let with = |codes: &str| machine_error(&format!("{SMALL}\n[codes]\n{codes}\n"));
    assert_diag(
        &with("harmless = [\"M3\"]"),
        "m.toml:13:13",
        &[
            "M3 is one of nccomp's own codes",
            "cannot give it another meaning",
        ],
    );
    assert_diag(
        &with("harmless = [\"G41\"]"),
        "m.toml:13:13",
        &["G41 is one of nccomp's own codes"],
    );
    assert_diag(
        &with("tcp_on = [\"M428\"]\ntcp_off = [\"M428\"]"),
        "m.toml:14:12",
        &["M428 is already in `tcp_on`", "each code in one list, once"],
    );
    assert_diag(
        &with("harmless = [\"X1\"]"),
        "m.toml:13:13",
        &["expected a G or M code such as \"M428\""],
    );
    assert_diag(
        &with("harmless = [428]"),
        "m.toml:13:13",
        &["expected a string"],
    );
    assert_diag(&with("tcp = [\"M428\"]"), "m.toml:13:1", &["tcp"]);
}

#[test]
fn a_machine_file_names_codes_that_send_axes_to_machine_positions() {
    let text =
        format!("{SMALL}\n[codes]\nmachine_moves = {{ M25 = [\"Z\"], M71 = [\"X\", \"Z\"] }}\n");
    let m = machine_file::parse(&text, "m.toml").unwrap_or_else(|e| panic!("{}", e.render()));
    let moves: Vec<(String, u32)> = m
        .codes
        .machine_moves
        .iter()
        .map(|(n, axes)| (n.to_string(), *axes))
        .collect();
    let bit = |c: u8| 1u32 << (c - b'A');
    assert_eq!(
        moves,
        [
            ("M25".to_string(), bit(b'Z')),
            ("M71".to_string(), bit(b'X') | bit(b'Z'))
        ]
    );
    let with = |codes: &str| machine_error(&format!("{SMALL}\n[codes]\n{codes}\n"));
    assert_diag(
        &with("machine_moves = { M25 = [\"Q\"] }"),
        "m.toml:13:26",
        &["`Q` in `machine_moves` of [codes] is not an axis of this machine"],
    );
    assert_diag(
        &with("machine_moves = { M25 = [] }"),
        "m.toml:13:25",
        &["names no axis", "belongs in `harmless`"],
    );
    assert_diag(
        &with("machine_moves = { M3 = [\"Z\"] }"),
        "m.toml:13:19",
        &["M3 is one of nccomp's own codes"],
    );
    assert_diag(
        &with("harmless = [\"M25\"]\nmachine_moves = { M25 = [\"Z\"] }"),
        "m.toml:14:19",
        &["M25 is already in `harmless`"],
    );
    assert_diag(
        &with("machine_moves = [\"M25\"]"),
        "m.toml:13:17",
        &["expected `machine_moves` of [codes], a table of codes"],
    );
}

#[test]
fn a_machine_file_states_where_a_cycle_without_r_starts() {
    let text = format!("{SMALL}\n[cycles]\nmissing_r = \"initial\"\n");
    let m = machine_file::parse(&text, "m.toml").unwrap_or_else(|e| panic!("{}", e.render()));
    assert!(m.cycle_r_initial);
    assert!(
        !machine_file::parse(SMALL, "m.toml")
            .unwrap()
            .cycle_r_initial
    );
    assert_diag(
        &machine_error(&format!("{SMALL}\n[cycles]\nmissing_r = \"r\"\n")),
        "m.toml:13:13",
        &["`r` in `missing_r` of [cycles]: expected \"initial\""],
    );
    assert_diag(
        &machine_error(&format!("{SMALL}\n[cycles]\nr = 1\n")),
        "m.toml:13:1",
        &["r"],
    );
}

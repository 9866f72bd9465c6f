//! `nccomp check` from a shop's `nccomp.toml`: every program of the library against its
//! own machine in one run (one JSON, one exit code), a program no entry claims refused,
//! options layered command line over entry over defaults, a zero model that says nothing
//! was checked, and per-job set-ups (`--setup`) that change the output exactly as the same
//! values in the machine file do.

#[path = "common/skip.rs"]
mod skip;

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn nccomp(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(args)
        .current_dir(dir)
        .env("NO_COLOR", "1")
        .output()
        .unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8(bytes.to_vec()).unwrap()
}

/// The JSON output, checked against docs/check.schema.json.
fn valid_json(out: &Output) -> Value {
    let schema: Value = serde_json::from_str(
        &std::fs::read_to_string(root().join("docs/check.schema.json")).unwrap(),
    )
    .unwrap();
    let validator = jsonschema::validator_for(&schema).unwrap();
    let doc: Value = serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("{e}: {}{}", text(&out.stdout), text(&out.stderr)));
    let errors: Vec<String> = validator
        .iter_errors(&doc)
        .map(|e| format!("{} at {}", e, e.instance_path()))
        .collect();
    assert!(errors.is_empty(), "{errors:#?}\n{doc:#}");
    doc
}

fn program<'d>(doc: &'d Value, name: &str) -> &'d Value {
    doc["programs"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["path"].as_str().unwrap().ends_with(name))
        .unwrap_or_else(|| panic!("{name} is not in {doc:#}"))
}

/// The acceptance run: the CAM programs of `../shared/corpus/cam` mapped to the machine
/// files written for them (fixtures/corpus), checked in one run from one config; a stray
/// program beside the config that no entry claims is refused (exit 2), listed with why.
#[test]
fn the_corpus_programs_are_checked_for_their_machines_in_one_run() {
    let Some(cam) = skip::corpus_path("cam") else {
        return;
    };
    let cam = std::fs::canonicalize(cam).unwrap();
    let fixtures = root().join("fixtures/corpus");
    let shop = tempfile::tempdir().unwrap();
    let mapping = [
        ("hm_dmu85_W5270NS01061A6.h", "dmu85_ac", "dmu85_ac"),
        ("hm_dmu85_W5246NS01007B10.h", "dmu85_ac", "dmu85_ac"),
        ("hm_dmu85_W5246NS01007B11.h", "dmu85_ac_b11", "dmu85_ac"),
        ("hm_dmu100p_W5270NS01001B3.h", "dmu100p_bc", "bc_head_table"),
        ("hm_trimill_W5269NS01002A1.h", "trimill_bc", "bc_head_table"),
        (
            "hm_trimill_W5269NS01002A16.h",
            "trimill_bc_a16",
            "bc_head_table",
        ),
        ("hm_dmc105v_*.h", "dmc105v", "three_axis_tnc"),
        (
            "fusion_heidenhain_contour-final-outer.h",
            "fusion_tnc_mill",
            "three_axis_tnc",
        ),
        ("makino_v22_b-c.NCD", "makino_v22", "makino_v22"),
        (
            "freecad_centroid_metric_ref.ngc",
            "centroid_mill",
            "centroid_mill",
        ),
    ];
    let mut config = String::from("[defaults]\nmax_error = 0.010\nmax_angle = 100.0\n");
    for (paths, machine, errors) in mapping {
        config += &format!(
            "\n[[programs]]\npaths = {:?}\nmachine = {:?}\nerrors = {:?}\n",
            cam.join(paths).display().to_string(),
            fixtures
                .join(format!("{machine}.machine.toml"))
                .display()
                .to_string(),
            fixtures
                .join(format!("{errors}.errors.toml"))
                .display()
                .to_string(),
        );
    }
    std::fs::write(shop.path().join("nccomp.toml"), config).unwrap();
    std::fs::create_dir(shop.path().join("other")).unwrap();
    std::fs::write(shop.path().join("other/stray.nc"), "G0 X1 Y1 Z1\nM30\n").unwrap();

    let out = nccomp(shop.path(), &["check", "--format", "json"]);
    let doc = valid_json(&out);
    assert_eq!(out.status.code(), Some(2), "{doc:#}");
    assert_eq!(doc["config"], "nccomp.toml");
    assert_eq!(doc["machine"], Value::Null);
    // The three DMC 105 V programs by one pattern, and the other nine one each.
    assert_eq!(doc["totals"]["programs"], 13, "{doc:#}");
    assert_eq!(doc["totals"]["clean"], 12, "{doc:#}");
    assert_eq!(doc["totals"]["unusable"], 1, "{doc:#}");
    for (paths, machine, errors) in mapping {
        let name = paths.trim_start_matches("hm_dmc105v_*.h");
        let p = if name.is_empty() {
            program(&doc, "hm_dmc105v_W5246NS01007A10.h")
        } else {
            program(&doc, name)
        };
        assert_eq!(p["status"], "clean", "{p:#}");
        assert_eq!(p["checked"], true);
        assert!(
            p["machine"]
                .as_str()
                .unwrap()
                .ends_with(&format!("{machine}.machine.toml"))
        );
        assert!(
            p["errors"]
                .as_str()
                .unwrap()
                .ends_with(&format!("{errors}.errors.toml"))
        );
        assert_eq!(p["thresholds"]["max_angle_urad"], 100.0);
        assert!(p["motion_blocks"].as_u64().unwrap() > 0, "{p:#}");
    }
    let stray = program(&doc, "stray.nc");
    assert_eq!(stray["status"], "unusable");
    assert_eq!(stray["machine"], Value::Null);
    assert!(
        stray["error"]
            .as_str()
            .unwrap()
            .contains("no [[programs]] entry of nccomp.toml claims"),
        "{stray:#}"
    );

    // Run from a directory below, the config is found above; people read the same.
    let out = nccomp(&shop.path().join("other"), &["check", "-q"]);
    assert_eq!(out.status.code(), Some(2));
    let human = text(&out.stdout);
    assert!(
        human.contains(
            "checked 13 programs against ../nccomp.toml: 12 clean, 0 with findings, 1 unusable"
        ),
        "{human}"
    );
}

/// A small shop of the project's own fixtures: two machines, one naming its error file.
fn fixture_shop() -> tempfile::TempDir {
    let shop = tempfile::tempdir().unwrap();
    let f = root().join("fixtures");
    let dir = shop.path();
    std::fs::create_dir_all(dir.join("machines")).unwrap();
    std::fs::create_dir_all(dir.join("ac")).unwrap();
    std::fs::create_dir_all(dir.join("hh")).unwrap();
    // The AC trunnion's machine file names its error file.
    let machine = std::fs::read_to_string(f.join("ac_trunnion.machine.toml")).unwrap();
    std::fs::write(
        dir.join("machines/ac.machine.toml"),
        format!("errors = \"ac.errors.toml\"\n{machine}"),
    )
    .unwrap();
    std::fs::copy(
        f.join("ac_trunnion.errors.toml"),
        dir.join("machines/ac.errors.toml"),
    )
    .unwrap();
    std::fs::copy(
        f.join("head_head.machine.toml"),
        dir.join("machines/hh.machine.toml"),
    )
    .unwrap();
    std::fs::copy(
        f.join("head_head.errors.toml"),
        dir.join("machines/hh.errors.toml"),
    )
    .unwrap();
    std::fs::copy(
        f.join("corpus/zero.errors.toml"),
        dir.join("machines/zero.errors.toml"),
    )
    .unwrap();
    std::fs::copy(f.join("feature_workpiece.nc"), dir.join("ac/part.nc")).unwrap();
    std::fs::copy(f.join("head_head_demo.nc"), dir.join("hh/demo.nc")).unwrap();
    std::fs::write(
        dir.join("nccomp.toml"),
        "[defaults]\nmax_angle = 100.0\n\n[[programs]]\npaths = \"ac/**/*.nc\"\nmachine = \"machines/ac.machine.toml\"\n\n[[programs]]\npaths = \"hh/*.nc\"\nmachine = \"machines/hh.machine.toml\"\nerrors = \"machines/hh.errors.toml\"\n",
    )
    .unwrap();
    shop
}

#[test]
fn a_fixture_shop_in_one_run_and_the_nearest_place_decides() {
    let shop = fixture_shop();
    let out = nccomp(shop.path(), &["check", "--format", "json"]);
    let doc = valid_json(&out);
    // The feature workpiece keeps 166 µrad of direction error at a singular pose (A0: C
    // along the tool is held): above the default --max-angle of 100 µrad, it fails.
    assert_eq!(out.status.code(), Some(1), "{doc:#}");
    let ac = program(&doc, "part.nc");
    assert!(
        ac["errors"]
            .as_str()
            .unwrap()
            .ends_with("machines/ac.errors.toml"),
        "{ac:#}"
    );
    let kinds: Vec<&Value> = ac["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| &f["kind"])
        .collect();
    assert_eq!(kinds, ["direction_error"], "{ac:#}");
    assert_eq!(program(&doc, "demo.nc")["status"], "clean");
    // The entry's max_angle over the defaults'.
    let config = std::fs::read_to_string(shop.path().join("nccomp.toml")).unwrap();
    std::fs::write(
        shop.path().join("nccomp.toml"),
        config.replace(
            "machine = \"machines/ac.machine.toml\"\n",
            "machine = \"machines/ac.machine.toml\"\nmax_angle = 200.0\n",
        ),
    )
    .unwrap();
    let out = nccomp(shop.path(), &["check", "--format", "json"]);
    let doc = valid_json(&out);
    assert_eq!(out.status.code(), Some(0), "{doc:#}");
    // The command line over the entry over the defaults: a tiny --max-angle fails both.
    let out = nccomp(
        shop.path(),
        &["check", "--format", "json", "--max-angle", "0.001"],
    );
    let doc = valid_json(&out);
    assert_eq!(out.status.code(), Some(1), "{doc:#}");
    for name in ["part.nc", "demo.nc"] {
        let p = program(&doc, name);
        assert_eq!(p["thresholds"]["max_angle_urad"], 0.001);
        assert!(
            p["findings"]
                .as_array()
                .unwrap()
                .iter()
                .any(|f| f["kind"] == "direction_error"),
            "{p:#}"
        );
    }
    // Programs given on the command line are claimed by the config too.
    let out = nccomp(shop.path(), &["check", "hh/demo.nc", "elsewhere.nc"]);
    assert_eq!(out.status.code(), Some(2));
    let human = text(&out.stdout);
    assert!(
        human.contains("no [[programs]] entry of nccomp.toml claims elsewhere.nc"),
        "{human}"
    );
    assert!(human.contains("hh/demo.nc: clean"), "{human}");
}

#[test]
fn without_a_config_or_a_machine_check_says_what_it_expected() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join(".git")).unwrap();
    let out = nccomp(dir.path(), &["check"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        text(&out.stderr).contains("no --machine and no nccomp.toml"),
        "{}",
        text(&out.stderr)
    );
}

#[test]
fn a_zero_model_says_nothing_was_checked_even_when_unread_programs_may_pass() {
    let shop = fixture_shop();
    let out = nccomp(
        shop.path(),
        &[
            "check",
            "-m",
            "machines/hh.machine.toml",
            "-e",
            "machines/zero.errors.toml",
            "--allow-unread",
            "hh/demo.nc",
        ],
    );
    assert_eq!(out.status.code(), Some(0));
    let human = text(&out.stdout);
    assert!(!human.contains("lands every pose"), "{human}");
    assert!(human.contains("nothing was checked"), "{human}");
    assert!(
        human.contains("1 not read (a zero error model): nothing was checked in it"),
        "{human}"
    );
}

/// The head-head fixture with a work offset table, and a program in G55.
const OFFSETS: &str = "\n[work_offsets]\ngeometry = \"G54\"\nG54 = { X = -300.0, Y = -180.0, Z = -400.0 }\nG55 = { X = -200.0, Y = -180.0, Z = -400.0 }\n";
const IN_G55: &str = "%\nO1 (A PART IN G55)\nG21 G90 G17 G40 G49 G80\nT1 M6\nG55 G0 X0 Y0 Z100. C0 A0\nG43 H1 Z50.\nG1 Z-1. F300.\nX40. Y20. A10.\nX60. Y0 C30.\nG0 Z50.\nM30\n%\n";

fn compensate(dir: &Path, machine: &str, extra: &[&str]) -> (Vec<u8>, String) {
    let errors = if machine.starts_with("ac") {
        "ac.errors.toml"
    } else {
        "hh.errors.toml"
    };
    let mut args = vec![
        "compensate",
        "-m",
        machine,
        "-e",
        errors,
        "part.nc",
        "-o",
        "out.nc",
    ];
    args.extend_from_slice(extra);
    let out = nccomp(dir, &args);
    assert!(out.status.success(), "{}", text(&out.stderr));
    (
        std::fs::read(dir.join("out.nc")).unwrap(),
        text(&out.stderr),
    )
}

#[test]
fn a_set_up_changes_the_output_exactly_as_the_same_values_in_the_machine_file() {
    let f = root().join("fixtures");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let machine = std::fs::read_to_string(f.join("head_head.machine.toml")).unwrap();
    std::fs::write(d.join("hh.machine.toml"), format!("{machine}{OFFSETS}")).unwrap();
    std::fs::copy(f.join("head_head.errors.toml"), d.join("hh.errors.toml")).unwrap();
    std::fs::write(d.join("part.nc"), IN_G55).unwrap();
    let (base, _) = compensate(d, "hh.machine.toml", &[]);

    // nccomp's set-up file.
    std::fs::write(
        d.join("job.toml"),
        "[work_offsets]\nG55 = { X = -212.5, Y = -171.25, Z = -395.0 }\n",
    )
    .unwrap();
    let (from_setup, summary) = compensate(d, "hh.machine.toml", &["--setup", "job.toml"]);
    assert!(
        summary
            .contains("set-up: G55 = X-212.5 Y-171.25 Z-395 (job.toml:2, over X-200 Y-180 Z-400)"),
        "{summary}"
    );
    assert!(summary.contains("verified"), "the gate passed: {summary}");
    let edited = format!("{machine}{OFFSETS}").replace(
        "G55 = { X = -200.0, Y = -180.0, Z = -400.0 }",
        "G55 = { X = -212.5, Y = -171.25, Z = -395.0 }",
    );
    std::fs::write(d.join("edited.machine.toml"), edited).unwrap();
    let (from_machine, _) = compensate(d, "edited.machine.toml", &[]);
    assert!(
        from_setup == from_machine,
        "the set-up and the machine file differ"
    );
    assert!(from_setup != base, "the set-up changed nothing");

    // LinuxCNC's parameter file gives the same G55 (5241–5243).
    std::fs::write(
        d.join("emc.var"),
        "5220\t1.000000\n5241\t-212.500000\n5242\t-171.250000\n5243\t-395.000000\n5244\t0.000000\n",
    )
    .unwrap();
    let (from_var, summary) = compensate(d, "hh.machine.toml", &["--setup", "emc.var"]);
    assert!(from_var == from_machine);
    assert!(
        summary.contains("G55 = X-212.5 Y-171.25 Z-395 (emc.var:2"),
        "{summary}"
    );

    // A bad table is refused at its place, and nothing is written.
    std::fs::remove_file(d.join("out.nc")).unwrap();
    std::fs::write(d.join("bad.var"), "5241 -212.5\n5246 90\n").unwrap();
    let out = nccomp(
        d,
        &[
            "compensate",
            "-m",
            "hh.machine.toml",
            "-e",
            "hh.errors.toml",
            "--setup",
            "bad.var",
            "part.nc",
            "-o",
            "out.nc",
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    let err = text(&out.stderr);
    assert!(
        err.contains("bad.var:2:6") && err.contains("X, Y and Z only"),
        "{err}"
    );
    assert!(!d.join("out.nc").exists());

    // The gate of `verify` takes the same set-up: the output passes with it and is
    // judged against the machine file's G55 without it.
    let (_, _) = compensate(d, "hh.machine.toml", &["--setup", "job.toml"]);
    let with = nccomp(
        d,
        &[
            "verify",
            "-m",
            "hh.machine.toml",
            "-e",
            "hh.errors.toml",
            "--setup",
            "job.toml",
            "part.nc",
            "out.nc",
        ],
    );
    assert_eq!(with.status.code(), Some(0), "{}", text(&with.stdout));
    assert!(
        text(&with.stdout).contains("set-up: G55"),
        "{}",
        text(&with.stdout)
    );
    let check = nccomp(
        d,
        &[
            "check",
            "-m",
            "hh.machine.toml",
            "-e",
            "hh.errors.toml",
            "--setup",
            "job.toml",
            "--format",
            "json",
            "part.nc",
        ],
    );
    let doc = valid_json(&check);
    assert_eq!(doc["programs"][0]["setup"][0]["name"], "G55", "{doc:#}");
    assert_eq!(doc["programs"][0]["setup"][0]["from"], "job.toml:2");
}

/// A part on the AC trunnion with tool 1: on a table machine the tool's length moves the
/// tip's correction.
const WITH_TOOL_1: &str = "%\nO1\nG21 G90 G17 G40 G49 G80\nT1 M6\nG0 X0 Y0 Z100. C0 A0\nG43 H1 Z50.\nG1 Z-1. F300.\nX40. Y20. A-10.\nX60. Y0 C30. A-30.\nG0 Z50.\nM30\n%\n";

#[test]
fn tool_lengths_from_a_tool_table_equal_the_machine_file_s() {
    let f = root().join("fixtures");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let machine = std::fs::read_to_string(f.join("ac_trunnion.machine.toml")).unwrap();
    std::fs::write(d.join("ac.machine.toml"), &machine).unwrap();
    std::fs::copy(f.join("ac_trunnion.errors.toml"), d.join("ac.errors.toml")).unwrap();
    std::fs::write(d.join("part.nc"), WITH_TOOL_1).unwrap();
    let (base, _) = compensate(d, "ac.machine.toml", &[]);
    std::fs::write(d.join("tool.tbl"), "T1 P1 Z+300.000 D10 ;end mill\n").unwrap();
    let (from_table, summary) = compensate(d, "ac.machine.toml", &["--setup", "tool.tbl"]);
    assert!(
        summary.contains("set-up: tool 1 = 300 mm (tool.tbl:1, over 95.3 mm)"),
        "{summary}"
    );
    assert!(summary.contains("verified"), "the gate passed: {summary}");
    std::fs::write(
        d.join("TOOL.T"),
        "BEGIN TOOL.T MM\nT    NAME        L          R       DL\n1    EM10        +299.5     +5      +0.5\n[END]\n",
    )
    .unwrap();
    let (from_tool_t, _) = compensate(d, "ac.machine.toml", &["--setup", "TOOL.T"]);
    assert!(from_table == from_tool_t);
    std::fs::write(
        d.join("ac-edited.machine.toml"),
        length_of_tool_1(&machine, 300.0),
    )
    .unwrap();
    let (from_machine, _) = compensate(d, "ac-edited.machine.toml", &[]);
    assert!(
        from_table == from_machine,
        "the tool table and the machine file differ"
    );
    assert!(from_table != base, "the tool table changed nothing");
}

/// The machine file with tool 1's length set to `length`.
fn length_of_tool_1(machine: &str, length: f64) -> String {
    machine
        .lines()
        .map(|l| {
            if l.trim_start().starts_with("lengths") {
                format!("lengths = {{ 1 = {length} }}")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

/// A set-up that moves the geometry's own offset (G54 here) moves the part, not the
/// machine: a program in G54 with the set-up's G54 lands where the same program in G55
/// lands with that value as the machine file's G55 (the geometry staying at the machine
/// file's G54).
#[test]
fn a_set_up_moving_the_geometry_s_offset_moves_the_part_not_the_machine() {
    let f = root().join("fixtures");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let machine = std::fs::read_to_string(f.join("head_head.machine.toml")).unwrap();
    std::fs::write(d.join("hh.machine.toml"), format!("{machine}{OFFSETS}")).unwrap();
    std::fs::copy(f.join("head_head.errors.toml"), d.join("hh.errors.toml")).unwrap();
    std::fs::write(
        d.join("job.toml"),
        "[work_offsets]\nG54 = { X = -212.5, Y = -171.25, Z = -395.0 }\n",
    )
    .unwrap();
    std::fs::write(d.join("part.nc"), IN_G55.replace("G55", "G54")).unwrap();
    let (in_g54, summary) = compensate(d, "hh.machine.toml", &["--setup", "job.toml"]);
    assert!(
        summary
            .contains("set-up: G54 = X-212.5 Y-171.25 Z-395 (job.toml:2, over X-300 Y-180 Z-400)"),
        "{summary}"
    );
    let edited = format!("{machine}{OFFSETS}").replace(
        "G55 = { X = -200.0, Y = -180.0, Z = -400.0 }",
        "G55 = { X = -212.5, Y = -171.25, Z = -395.0 }",
    );
    std::fs::write(d.join("edited.machine.toml"), edited).unwrap();
    std::fs::write(d.join("part.nc"), IN_G55).unwrap();
    let (in_g55, _) = compensate(d, "edited.machine.toml", &[]);
    assert_eq!(text(&in_g54), text(&in_g55).replace("G55", "G54"));
}

/// A TNC program's preset from the control's PRESET.PR: the row at the machine file's
/// preset writes the same program byte for byte; a row elsewhere moves program zero away
/// from where the machine's geometry is given, which the tilted plane refuses at its
/// blocks rather than guessing the geometry in the moved frame.
#[test]
fn a_tnc_preset_from_preset_pr_is_the_machine_file_s_or_refused_under_a_plane() {
    let Some(cam) = skip::corpus_path("cam") else {
        return;
    };
    let program = cam.join("hm_dmu85_W5270NS01061A6.h");
    let program = program.to_str().unwrap();
    let fixtures = root().join("fixtures/corpus");
    let machine = fixtures.join("dmu85_ac.machine.toml");
    let errors = fixtures.join("dmu85_ac.errors.toml");
    let (machine, errors) = (machine.to_str().unwrap(), errors.to_str().unwrap());
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("PRESET.PR"),
        "BEGIN PRESET.PR MM\nNR   DOC          ROT      X          Y          Z          SPC\n1    SAME         +0       -300       -250       -450       +0\n2    MOVED        +0       -310       -250       -450       +0\n[END]\n",
    )
    .unwrap();
    for row in [1, 2] {
        std::fs::write(
            d.join(format!("row{row}.toml")),
            format!("[tables]\noffsets = \"PRESET.PR\"\npreset = {row}\nbasis = {{ X = 0, Y = 0, Z = 0 }}\n"),
        )
        .unwrap();
    }
    let run = |extra: &[&str], out: &str| {
        let mut args = vec![
            "compensate",
            "-m",
            machine,
            "-e",
            errors,
            program,
            "-o",
            out,
        ];
        args.extend_from_slice(extra);
        nccomp(d, &args)
    };
    assert!(run(&[], "plain.h").status.success());
    let same = run(&["--setup", "row1.toml"], "same.h");
    assert!(same.status.success(), "{}", text(&same.stderr));
    assert!(
        text(&same.stderr).contains("set-up: G54 = X-300 Y-250 Z-450 (PRESET.PR:3"),
        "{}",
        text(&same.stderr)
    );
    assert!(std::fs::read(d.join("plain.h")).unwrap() == std::fs::read(d.join("same.h")).unwrap());
    let moved = run(&["--setup", "row2.toml"], "moved.h");
    assert_eq!(moved.status.code(), Some(2));
    let err = text(&moved.stderr);
    assert!(
        err.contains("hm_dmu85_W5270NS01061A6.h:60:6")
            && err.contains("program zero other than the machine file's geometry zero"),
        "{err}"
    );
    assert!(!d.join("moved.h").exists());
}

/// An entry whose machine file is unusable makes its programs unusable, with why; the
/// other entries' programs are still checked in the same run.
#[test]
fn an_unusable_entry_spoils_its_programs_only() {
    let shop = fixture_shop();
    let config = std::fs::read_to_string(shop.path().join("nccomp.toml")).unwrap();
    std::fs::write(
        shop.path().join("nccomp.toml"),
        config.replace("machines/hh.machine.toml", "machines/missing.machine.toml"),
    )
    .unwrap();
    let out = nccomp(
        shop.path(),
        &["check", "--format", "json", "--max-angle", "200"],
    );
    let doc = valid_json(&out);
    assert_eq!(out.status.code(), Some(2), "{doc:#}");
    let hh = program(&doc, "demo.nc");
    assert_eq!(hh["status"], "unusable");
    let why = hh["error"].as_str().unwrap();
    assert!(
        why.contains("[[programs]] entry 2 of nccomp.toml cannot be used")
            && why.contains("missing.machine.toml"),
        "{why}"
    );
    assert_eq!(program(&doc, "part.nc")["status"], "clean");
}

/// `report` takes the set-up as `compensate` does and says so.
#[test]
fn report_takes_the_set_up_too() {
    let f = root().join("fixtures");
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::copy(
        f.join("ac_trunnion.machine.toml"),
        d.join("ac.machine.toml"),
    )
    .unwrap();
    std::fs::copy(f.join("ac_trunnion.errors.toml"), d.join("ac.errors.toml")).unwrap();
    std::fs::write(d.join("part.nc"), WITH_TOOL_1).unwrap();
    std::fs::write(d.join("tool.tbl"), "T1 P1 Z+300.000\n").unwrap();
    let out = nccomp(
        d,
        &[
            "report",
            "-m",
            "ac.machine.toml",
            "-e",
            "ac.errors.toml",
            "--setup",
            "tool.tbl",
            "part.nc",
            "-o",
            "r.html",
        ],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(
        text(&out.stderr).contains("set-up: tool 1 = 300 mm (tool.tbl:1, over 95.3 mm)"),
        "{}",
        text(&out.stderr)
    );
    // An output over an input is refused before anything is written.
    let out = nccomp(
        d,
        &[
            "report",
            "-m",
            "ac.machine.toml",
            "-e",
            "ac.errors.toml",
            "--setup",
            "tool.tbl",
            "part.nc",
            "-o",
            "tool.tbl",
        ],
    );
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(
        std::fs::read_to_string(d.join("tool.tbl")).unwrap(),
        "T1 P1 Z+300.000\n"
    );
}

//! What a user types: `nccomp probe ...`, its exit codes, its messages and its files.

mod common;
use common::cli::{nccomp, scratch, stderr, stdout};

fn write(dir: &std::path::Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

const RING: &str = "fixtures/probe_ring.csv";
const MAP: &str = "fixtures/probe_map.csv";
const DEMO: &str = "fixtures/probe_demo.nc";

#[test]
fn ring_gauge_data_alone_gives_tau() {
    let out = nccomp(&["probe", "--ring", RING]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    assert!(
        text.starts_with("probe delay: τ = 12.615 ms, standard uncertainty 0.071 ms, from fixtures/probe_ring.csv: 108 points at 3 speeds in 36 directions, residual 0.50 µm; the radius grows with the speed, as on an inside surface\n"),
        "{text}"
    );
    assert!(text.contains("     100.0 mm/min:   36 points, mean radius 23.0413 mm\n"));
}

#[test]
fn demo_run_rewrites_the_program_reports_and_plots() {
    let dir = scratch("demo");
    let out_nc = dir.join("demo.comp.nc");
    let svg = dir.join("map.svg");
    let out = nccomp(&[
        "probe",
        "--ring",
        RING,
        "--map",
        MAP,
        "--surface",
        "outside",
        DEMO,
        "-o",
        out_nc.to_str().unwrap(),
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).is_empty(), "{}", stderr(&out));
    let report = stdout(&out);
    for expected in [
        "direction map fixtures/probe_map.csv: 325 directions in 10 rings (β -90° … 0°), measured at 50 mm/min\n",
        "trigger radius variation: 11.16 µm measured → 0.02 µm predicted (2 refits of the centre; it moved 0.01 µm)\n",
        "speeds: 22.90 … 76.00 mm/min (mean 50.00); the span is 11.16 µm of pre-travel at τ = 12.615 ms\n",
        "program fixtures/probe_demo.nc: 41 lines, 12 probing moves: 11 F words changed, 1 added; the original feed restored by an added F word at line 39\n",
        "ΔtR = +11.2 %\n",
        "    37   180.0  -45.0    14.142     50.00     64.00\n",
    ] {
        assert!(
            report.contains(expected),
            "missing {expected:?} in\n{report}"
        );
    }
    // Byte for byte the same but the probing F words and the restored feed.
    let before = std::fs::read_to_string(DEMO).unwrap();
    let after = std::fs::read_to_string(&out_nc).unwrap();
    let changed: Vec<(&str, &str)> = before
        .lines()
        .zip(after.lines())
        .filter(|(a, b)| a != b)
        .collect();
    assert_eq!(before.lines().count(), after.lines().count());
    assert_eq!(changed.len(), 13);
    assert_eq!(
        changed[0],
        (
            "N50 G31 X30.0000 Y0.0000 F50.",
            "N50 G31 X30.0000 Y0.0000 F23.9"
        )
    );
    assert_eq!(
        changed[2],
        ("N90 G31 X0.0000 Y30.0000", "N90 G31 X0.0000 Y30.0000 F50.8")
    );
    assert_eq!(
        changed[12],
        (
            "N340 G1 X0. Y0. (back over the bore at the modal feed)",
            "N340 G1 X0. Y0. F50. (back over the bore at the modal feed)"
        )
    );
    for (a, b) in &changed[..12] {
        let cut = |s: &str| s[..s.find(" F").unwrap_or(s.len())].to_string();
        assert_eq!(cut(a), cut(b));
    }
    let svg = std::fs::read_to_string(&svg).unwrap();
    assert!(svg.starts_with("<svg"));
    assert!(svg.contains("β = -80°") && svg.contains("predicted at the new speeds"));
    // 9 rings in each panel, plus grid circles and spokes.
    assert!(svg.matches("<polyline").count() >= 18 + 2 * 12);
}

#[test]
fn csv_format_and_program_on_standard_output() {
    let out = nccomp(&[
        "probe",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        "--format",
        "csv",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let csv = stdout(&out);
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("alpha,beta,radius,speed,new_speed,predicted_radius")
    );
    assert_eq!(lines.count(), 325);
    assert!(
        csv.contains("\n0,0,15.6639510,50,24.000,15.6694459\n"),
        "{csv}"
    );
    assert!(stderr(&out).starts_with("probe delay: τ = 12.68 ms (given)\n"));
    // The program on standard output: the report goes to standard error.
    let out = nccomp(&[
        "probe",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        DEMO,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).starts_with("%\nO0100 (PROBE"));
    assert!(stdout(&out).contains("N90 G31 X0.0000 Y30.0000 F50.8\n"));
    assert!(stderr(&out).contains("ΔtR = "));
    // -q: the program only.
    let out = nccomp(&[
        "probe",
        "-q",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        DEMO,
    ]);
    assert!(out.status.success() && stderr(&out).is_empty());
}

#[test]
fn the_machine_file_gives_the_probe_axis() {
    let out = nccomp(&[
        "probe",
        "-q",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        "--machine",
        "fixtures/head_head.machine.toml",
        DEMO,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let plain = nccomp(&[
        "probe",
        "-q",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        DEMO,
    ]);
    // At home the head points down +Z: the same program.
    assert_eq!(out.stdout, plain.stdout);
    // A horizontal probe pointing along −X (spindle towards −X): moves towards +X go away
    // from the spindle (β = −90°), but the bore's points towards −X come at the stylus
    // from below the probe's plane (β > 0), which the map does not cover. Every such move
    // is reported.
    let out = nccomp(&[
        "probe",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        "--probe-axis",
        "-1,0,0",
        DEMO,
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).starts_with("error: no speed for this probing move: direction α = 90.0°, β = 45.0° is outside the map, which covers β from -90° to 0° (extend the map or check the probe axis)\n  --> fixtures/probe_demo.nc:14:6\n"),
        "{}",
        stderr(&out)
    );
    assert_eq!(
        stderr(&out)
            .matches("no speed for this probing move")
            .count(),
        4
    );
}

#[test]
fn bad_inputs_are_located() {
    let dir = scratch("bad");
    let cases: Vec<(Vec<String>, String)> = vec![
        (
            vec![
                "--tau".into(),
                "12".into(),
                "--map".into(),
                write(&dir, "m1.csv", "alpha,beta,speed\n0,0,50\n"),
            ],
            "m1.csv:1:17: the direction map: missing column `radius` (the header names `alpha`, `beta`, `speed`; expected the columns alpha, beta, radius, speed)".into(),
        ),
        (
            vec![
                "--tau".into(),
                "12".into(),
                "--map".into(),
                write(
                    &dir,
                    "m2.csv",
                    "alpha,beta,radius,speed\n0,0,25.001,50\n120,0,25.0o2,50\n240,0,25,50\n",
                ),
            ],
            "m2.csv:3:7: `radius` is `25.0o2`, not a number".into(),
        ),
        (
            vec![
                "--tau".into(),
                "12".into(),
                "--map".into(),
                write(&dir, "m3.csv", "alpha,beta,radius,speed\n0,0,25.001,50\n"),
            ],
            "m3.csv:2:1: the direction map: too few points: 1 direction; at least 3 are needed"
                .into(),
        ),
        (
            vec![
                "--ring".into(),
                write(&dir, "r1.csv", "# ring\nspeed,radius\n50,26.01\n100,26.02\n"),
            ],
            "r1.csv:4:1: ring-gauge data: too few points to fit τ: 2 rows; at least 3 are needed, at two speeds or more".into(),
        ),
        (
            vec![
                "--ring".into(),
                write(&dir, "r2.csv", "speed,radius\n50,26.01\nfast,26.02\n100,26.03\n"),
            ],
            "r2.csv:3:1: `speed` is `fast`, not a number".into(),
        ),
        (
            vec![
                "--ring".into(),
                write(&dir, "r3.csv", "speed,radius\n50,26.01\n50,26.02\n50,26.03\n"),
            ],
            "r3.csv:4:1: ring-gauge data: every row is at 50 mm/min: τ needs radii measured at two speeds or more".into(),
        ),
        (
            vec![
                "--tau".into(),
                "12.68".into(),
                "--map".into(),
                MAP.into(),
                "--surface".into(),
                "outside".into(),
                write(&dir, "p1.nc", "G0 X0 Y0\nG31 X10 F50\nG31 X20 F50\n"),
            ],
            "p1.nc:3:5: the start of this probing move is not known: X was last moved by the probing move at line 2".into(),
        ),
    ];
    for (args, expected) in cases {
        let mut all = vec!["probe".to_string()];
        all.extend(args);
        let refs: Vec<&str> = all.iter().map(String::as_str).collect();
        let out = nccomp(&refs);
        assert_eq!(out.status.code(), Some(2), "{refs:?}");
        let err = stderr(&out);
        // `error: ` and the message (or its start), then ` --> file:line:column`.
        let (location, message) = expected.split_once(": ").unwrap();
        let mut lines = err.lines();
        let first = lines.next().unwrap_or_default();
        assert!(
            first.starts_with(&format!("error: {message}")),
            "{refs:?}\n got: {first}\nwant: {message}"
        );
        let place = lines.next().unwrap_or_default();
        let file = place.strip_prefix(" --> ").unwrap_or_default();
        assert!(
            file.starts_with(dir.to_str().unwrap()) || file.starts_with("fixtures/"),
            "{place}"
        );
        assert!(file.ends_with(&format!("/{location}")), "{place}");
        // The source line and the caret line under the place.
        assert!(err.lines().count() >= 5, "{err}");
    }
}

#[test]
fn speeds_outside_the_bounds_are_refused_and_leave_the_output_alone() {
    let dir = scratch("bounds");
    let out_nc = write(&dir, "out.nc", "old content\n");
    let out = nccomp(&[
        "probe",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        "--min-feed",
        "30",
        "--max-feed",
        "120",
        DEMO,
        "-o",
        &out_nc,
    ]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.starts_with("error: the equalisation needs 23.08 mm/min in direction α = 120.0°, β = 0.0° (map line 16), below --min-feed 30 mm/min (19 directions need less than that bound). In all it needs 23.08 … 75.89 mm/min (a span of 52.81 mm/min: a variation of 11.16 µm ÷ τ = 12.68 ms)"),
        "{err}"
    );
    assert!(
        err.contains(
            "; a --mean-feed from 56.92 to 94.11 mm/min keeps every speed within the bounds"
        ),
        "{err}"
    );
    assert_eq!(std::fs::read_to_string(&out_nc).unwrap(), "old content\n");
    // Shifting the level as suggested works.
    let out = nccomp(&[
        "probe",
        "-q",
        "--tau",
        "12.68",
        "--map",
        MAP,
        "--surface",
        "outside",
        "--min-feed",
        "30",
        "--max-feed",
        "120",
        "--mean-feed",
        "60",
        DEMO,
        "-o",
        &out_nc,
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(
        std::fs::read_to_string(&out_nc)
            .unwrap()
            .contains("N50 G31 X30.0000 Y0.0000 F34.0\n")
    );
}

#[test]
fn usage_errors() {
    let out = nccomp(&["probe"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).starts_with("error: nothing to do"),
        "{}",
        stderr(&out)
    );
    let out = nccomp(&["probe", "--map", MAP]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("give --tau MS or --ring RING.csv"));
    let out = nccomp(&["probe", "--tau", "12", "--ring", RING]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("cannot be used with"),
        "{}",
        stderr(&out)
    );
    let out = nccomp(&["probe", "--tau", "12", DEMO]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("needs a direction map"));
    let out = nccomp(&["probe", "--tau", "-3", "--map", MAP]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("--tau -3: expected a positive number"),
        "{}",
        stderr(&out)
    );
}

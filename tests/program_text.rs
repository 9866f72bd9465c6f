//! How the program's text is taken before any block is compensated (issue 34, cases 6 to
//! 9): line endings of a carriage return alone, text past the program's end, label calls
//! nested in label calls, and coordinate settings that are not moves. Each is either read
//! as the control reads it or refused with the place and the reason, never passed silently
//! wrong.

mod common;
use common::cli::{nccomp, scratch, stderr, stdout};

use nccomp::compensate::{Compensator, Options, Summary};
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use std::path::Path;

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fixtures")
        .join(name)
}

fn load(name: &str) -> (Machine, ErrorModel) {
    let m = machine_file::load(&fixture(&format!("{name}.machine.toml"))).unwrap();
    let e = error_file::load(&fixture(&format!("{name}.errors.toml")), &m).unwrap();
    (m, e)
}

/// Compensate `src` (named `name`): the output and the summary, or the rendered errors.
fn run(m: &Machine, e: &ErrorModel, src: &[u8], name: &str) -> Result<(Vec<u8>, Summary), String> {
    let comp = Compensator::new(m, e, Options::default()).unwrap();
    let mut out = Vec::new();
    comp.run(src, name, &mut out)
        .map(|s| (out, s))
        .map_err(|e| e.to_string())
}

// ---------------------------------------------------------------------------------------
// Case 9: a carriage return alone ends a line, in every dialect.

/// `src` with every line feed (and CR LF) turned into a carriage return alone.
fn cr_only(src: &[u8]) -> Vec<u8> {
    let text = String::from_utf8_lossy(src).replace("\r\n", "\n");
    text.replace('\n', "\r").into_bytes()
}

#[track_caller]
fn same_as_with_line_feeds(machine: &str, program: &str) {
    let (m, e) = load(machine);
    let lf = std::fs::read(fixture(program)).unwrap();
    let lf = String::from_utf8_lossy(&lf)
        .replace("\r\n", "\n")
        .into_bytes();
    let cr = cr_only(&lf);
    let (out_lf, sum_lf) = run(&m, &e, &lf, program).unwrap();
    let (out_cr, sum_cr) = match run(&m, &e, &cr, program) {
        Ok(r) => r,
        Err(e) => panic!("{program} with CR endings refused: {e}"),
    };
    assert!(sum_lf.motion_blocks > 0, "{program}");
    // The same blocks, the same words; only the endings differ, each kept as it was.
    assert_eq!(sum_cr.motion_blocks, sum_lf.motion_blocks, "{program}");
    assert_eq!(sum_cr.lines, sum_lf.lines, "{program}");
    assert!(
        !out_cr.contains(&b'\n'),
        "{program}: a line feed was written"
    );
    assert_eq!(
        String::from_utf8_lossy(&out_cr).replace('\r', "\n"),
        String::from_utf8_lossy(&out_lf),
        "{program}"
    );
    // Streamed, the same bytes.
    let comp = Compensator::new(&m, &e, Options::default()).unwrap();
    let mut streamed = Vec::new();
    comp.run_stream(&cr[..], program, &mut streamed, "out")
        .unwrap();
    assert_eq!(streamed, out_cr, "{program} streamed");
    // With a zero model, the input back byte for byte.
    let zero = ErrorModel::zero(&m);
    let (same, _) = run(&m, &zero, &cr, program).unwrap();
    assert_eq!(same, cr, "{program}: zero model");
    // Streamed (copied through unread, its lines counted as the pass counts them).
    let comp = Compensator::new(&m, &zero, Options::default()).unwrap();
    let mut copied = Vec::new();
    let summary = comp
        .run_stream(&cr[..], program, &mut copied, "out")
        .unwrap();
    assert_eq!(copied, cr, "{program}: zero model streamed");
    assert_eq!(
        summary.lines, sum_lf.lines,
        "{program}: zero model's line count"
    );
}

#[test]
fn carriage_returns_alone_end_lines_in_every_dialect() {
    same_as_with_line_feeds("ac_trunnion", "tnc_ac_trunnion.h");
    same_as_with_line_feeds("ac_trunnion", "ac_trunnion_tcp.nc");
    same_as_with_line_feeds("ac_trunnion", "840d_ac_trunnion_traori.mpf");
}

/// A file converted to CR LF twice (`\r\r\n`) still has one line per line: a TNC
/// cycle's continued lines (`~`) stay one block.
#[test]
fn carriage_returns_before_a_line_feed_belong_to_its_ending() {
    let (m, e) = load("ac_trunnion");
    let lf = std::fs::read(fixture("tnc_ac_trunnion.h")).unwrap();
    let lf = String::from_utf8_lossy(&lf).replace("\r\n", "\n");
    let crcrlf = lf.replace('\n', "\r\r\n");
    let (out_lf, sum_lf) = run(&m, &e, lf.as_bytes(), "p.h").unwrap();
    let (out, sum) = run(&m, &e, crcrlf.as_bytes(), "p.h").unwrap();
    assert_eq!(
        (sum.lines, sum.motion_blocks),
        (sum_lf.lines, sum_lf.motion_blocks)
    );
    assert_eq!(
        String::from_utf8_lossy(&out).replace("\r\r\n", "\n"),
        String::from_utf8_lossy(&out_lf)
    );
}

#[test]
fn a_refusal_in_a_program_with_carriage_returns_names_its_own_line() {
    let (m, e) = load("ac_trunnion");
    let src = b"G21 G90\rG0 X0 Y0 Z50 A-30 C0\rG41 D1 X10\rG40\r";
    let err = run(&m, &e, src, "p.nc").unwrap_err();
    assert!(err.contains("p.nc:3:"), "{err}");
    assert!(err.contains("G41"), "{err}");
}

// ---------------------------------------------------------------------------------------
// Case 8: labels calling labels are not run an exponential number of times.

/// A TNC program whose `LBL 1` calls `LBL 2` twenty times, `LBL 2` calls `LBL 3` twenty
/// times, … eight deep: 20^7 calls of `LBL 8` (hours) if every call were run out.
fn nested_labels() -> String {
    let mut s = String::from(
        "0 BEGIN PGM NESTED MM\n1 BLK FORM 0.1 Z X-60 Y-45 Z-30\n2 BLK FORM 0.2 X60 Y45 Z0\n\
         3 TOOL CALL 1 Z S8000\n4 L X+0 Y+0 Z+100 A+0 C+0 R0 FMAX\n5 CALL LBL 1\n\
         6 L X+10 Y+0 Z+50 R0 FMAX\n7 M30\n",
    );
    let mut n = 8;
    let mut line = |s: &mut String, text: &str| {
        s.push_str(&format!("{n} {text}\n"));
        n += 1;
    };
    for level in 1..=8 {
        line(&mut s, &format!("LBL {level}"));
        if level < 8 {
            for _ in 0..20 {
                line(&mut s, &format!("CALL LBL {}", level + 1));
            }
        } else {
            line(&mut s, "FN 0: Q1=+1");
        }
        line(&mut s, "LBL 0");
    }
    line(&mut s, "END PGM NESTED MM");
    s
}

#[test]
fn nested_label_calls_finish_compensated_or_refused_at_the_call() {
    let (m, e) = load("ac_trunnion");
    let src = nested_labels();
    assert!(src.lines().count() < 200);
    match run(&m, &e, src.as_bytes(), "nested.h") {
        // Compensated: the move after the call is there.
        Ok((out, summary)) => {
            assert!(summary.motion_blocks >= 2, "{summary}");
            assert!(String::from_utf8_lossy(&out).contains("END PGM NESTED MM"));
        }
        // Refused: at the CALL LBL of the main program, saying why.
        Err(err) => {
            assert!(err.contains("nested.h:6:3"), "{err}");
            assert!(err.contains("CALL LBL"), "{err}");
            assert!(err.contains("blocks"), "{err}");
        }
    }
    // `check` gives its report.
    let dir = scratch("nested-labels");
    let path = dir.join("nested.h");
    std::fs::write(&path, &src).unwrap();
    let out = nccomp(&[
        "check",
        "--format",
        "json",
        "-m",
        "fixtures/ac_trunnion.machine.toml",
        "-e",
        "fixtures/ac_trunnion.errors.toml",
        path.to_str().unwrap(),
    ]);
    let doc: serde_json::Value = serde_json::from_str(&stdout(&out)).unwrap();
    assert_eq!(doc["programs"].as_array().unwrap().len(), 1, "{doc:#}");
}

// ---------------------------------------------------------------------------------------
// Case 7: what follows the program's end is not compensated in the state the program
// ended in.

#[test]
fn a_subprogram_stored_after_m30_is_left_unchanged_and_named() {
    let (m, e) = load("ac_trunnion");
    let main = "%\nO1000\nG21 G90\nG0 X0 Y0 Z50. A-30. C0\nG1 X20. Y10. Z40. F500\nM30\n";
    let sub = "O1001\nG1 X5. Y5. Z45.\nG0 X0 Y0\nM99\n%\n";
    let src = format!("{main}{sub}");
    let (out, summary) = run(&m, &e, src.as_bytes(), "p.nc").unwrap();
    let out = String::from_utf8(out).unwrap();
    // The main program is compensated, the stored subprogram kept byte for byte.
    assert!(!out.starts_with(main), "{out}");
    assert!(out.ends_with(sub), "{out}");
    assert_eq!(summary.motion_blocks, 2, "{summary}");
    let text = summary.to_string();
    assert!(
        text.contains("note: 4 lines after the program's end (line 6) left unchanged"),
        "{text}"
    );

    // The same in a Sinumerik program (M2 ends it).
    let src = "G71 G90\nG0 X0 Y0 Z50 A-30 C0\nG1 X20 Y10 Z40 F500\nM2\nG1 X5 Y5 Z45\n";
    let (out, summary) = run(&m, &e, src.as_bytes(), "p.mpf").unwrap();
    let out = String::from_utf8(out).unwrap();
    assert!(out.ends_with("M2\nG1 X5 Y5 Z45\n"), "{out}");
    assert!(
        summary
            .to_string()
            .contains("note: 1 line after the program's end (line 4) left unchanged"),
        "{summary}"
    );

    // A TNC program ends at END PGM (its labels after M30 run when called).
    let tnc = std::fs::read_to_string(fixture("tnc_ac_trunnion.h")).unwrap();
    let end = tnc.lines().count();
    let src = format!("{tnc}L X+5 Y+5 Z+100 R0 FMAX\n");
    let (m_out, summary) = run(&m, &e, src.as_bytes(), "p.h").unwrap();
    assert!(
        String::from_utf8(m_out)
            .unwrap()
            .ends_with("\nL X+5 Y+5 Z+100 R0 FMAX\n")
    );
    assert!(
        summary.to_string().contains(&format!(
            "note: 1 line after the program's end (line {end}) left unchanged"
        )),
        "{summary}"
    );
    let (_, summary) = run(&m, &e, tnc.as_bytes(), "p.h").unwrap();
    assert!(!summary.to_string().contains("after the program's end"));

    // An optional end (`/M30`) does not end the program with block delete off: what
    // follows is still compensated.
    let src = "G21 G90\nG0 X0 Y0 Z50. A-30. C0\n/M30\nG1 X20. Y10. Z40. F500\nM30\n";
    let (out, summary) = run(&m, &e, src.as_bytes(), "p.nc").unwrap();
    assert_eq!(summary.motion_blocks, 2, "{summary}");
    assert!(
        !String::from_utf8(out)
            .unwrap()
            .contains("G1 X20. Y10. Z40. F500")
    );
    assert!(!summary.to_string().contains("after the program's end"));
}

#[test]
fn the_summary_of_compensate_names_lines_after_the_end() {
    let dir = scratch("after-end");
    let p = dir.join("p.nc");
    std::fs::write(
        &p,
        "G21 G90\nG0 X0 Y0 Z50. A-30. C0\nG1 X20. Y10. Z40. F500\nM30\nO1001\nG1 X5.\nM99\n",
    )
    .unwrap();
    let out = nccomp(&[
        "compensate",
        "-m",
        "fixtures/ac_trunnion.machine.toml",
        "-e",
        "fixtures/ac_trunnion.errors.toml",
        p.to_str().unwrap(),
        "-o",
        "-",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).ends_with("M30\nO1001\nG1 X5.\nM99\n"));
    assert!(
        stderr(&out).contains("note: 3 lines after the program's end (line 4) left unchanged"),
        "{}",
        stderr(&out)
    );
}

// ---------------------------------------------------------------------------------------
// Case 6: G50 on a lathe and G92 set coordinates; they move nothing.

#[test]
fn lathe_g50_and_g92_coordinate_settings_are_never_written_as_moves() {
    let (m, e) = load("lathe");
    for (setting, code) in [("G50 X8. Z4.", "G50"), ("G92 X8. Z4.", "G92")] {
        let src = format!("G18 G90 G21\nG0 X20. Z5.\n{setting}\nG1 X10. Z0 F0.2\nM30\n");
        let err = match run(&m, &e, src.as_bytes(), "p.nc") {
            Ok((out, _)) => panic!("{setting} compensated:\n{}", String::from_utf8_lossy(&out)),
            Err(err) => err,
        };
        assert!(err.contains(&format!("p.nc:3:1: {code}")), "{err}");
        assert!(err.contains("coordinate"), "{err}");
        assert!(err.contains("G54"), "{err}");
    }
    // G50 with S alone (the spindle speed limit) moves nothing and passes.
    let src = "G18 G90 G21\nG50 S2000\nG0 X20. Z5.\nG1 X10. Z0 F0.2\nM30\n";
    let (out, _) = run(&m, &e, src.as_bytes(), "p.nc").unwrap();
    assert!(String::from_utf8(out).unwrap().contains("\nG50 S2000\n"));
}

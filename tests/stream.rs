//! The streaming pass writes what the in-memory pass writes, byte for byte, and fails as it
//! does; faults of the reader and the writer come back as typed errors, never panics.

use nccomp::Error;
use nccomp::compensate::{Compensator, Options, Summary};
use nccomp::kinematics::path::PathTolerance;
use nccomp::model::{Machine, error_file, machine_file};
use proptest::prelude::*;
use std::io::{Read, Write};
use std::path::Path;

#[path = "../benches/common/program.rs"]
mod program;

fn fixture(name: &str) -> (Machine, nccomp::model::ErrorModel) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let m = machine_file::load(&root.join(format!("{name}.machine.toml"))).unwrap();
    let e = error_file::load(&root.join(format!("{name}.errors.toml")), &m).unwrap();
    (m, e)
}

/// A reader that hands out its bytes a few at a time (1 to `step` per read), so lines
/// are cut anywhere between reads.
struct Trickle<'a> {
    bytes: &'a [u8],
    step: usize,
    turn: usize,
}

impl Read for Trickle<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.turn += 1;
        let k = (1 + self.turn * 7919 % self.step)
            .min(buf.len())
            .min(self.bytes.len());
        buf[..k].copy_from_slice(&self.bytes[..k]);
        self.bytes = &self.bytes[k..];
        Ok(k)
    }
}

/// The in-memory and the streamed result: output (when the run succeeds) and summary, or
/// the rendered error.
fn both(comp: &Compensator, src: &[u8], step: usize) -> [Result<(Vec<u8>, Summary), String>; 2] {
    let mut out = Vec::new();
    // The streamed run leaves verification to its caller (the command line reads the
    // written file back): the in-memory summary's verdict is not compared.
    let memory = comp
        .run(src, "p.nc", &mut out)
        .map(|mut s| {
            s.verdict = None;
            (out, s)
        })
        .map_err(|e| e.render());
    let mut out = Vec::new();
    let input = Trickle {
        bytes: src,
        step,
        turn: 0,
    };
    let streamed = comp
        .run_stream(input, "p.nc", &mut out, "out.nc")
        .map(|s| (out, s))
        .map_err(|e| e.render());
    [memory, streamed]
}

/// The in-memory run against the streamed one, alone and with a helper thread solving
/// ahead (`comp` runs alone).
fn assert_same(comp: &Compensator, src: &[u8], step: usize, what: &str) {
    let [memory, streamed] = both(comp, src, step);
    let mut two = comp.clone();
    two.set_threads(2);
    let [_, pipelined] = both(&two, src, step);
    for (run, name) in [
        (&streamed, "streamed"),
        (&pipelined, "with a helper thread"),
    ] {
        match (&memory, run) {
            (Ok((a, sa)), Ok((b, sb))) => {
                assert!(a == b, "{what}: {name} output differs");
                assert_eq!(sa, sb, "{what}: {name}: summaries differ");
            }
            _ => assert_eq!(&memory, run, "{what}: {name}"),
        }
    }
}

fn options(split: bool) -> Options {
    Options {
        path: split.then(PathTolerance::default),
        ..Options::default()
    }
}

#[test]
fn fixtures_stream_as_they_run_in_memory() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let cases: &[(&str, &str, Option<&str>, &[&str])] = &[
        ("ac_trunnion", "feature_workpiece", None, &[]),
        ("ac_trunnion", "ac_trunnion_tcp", None, &[]),
        ("ac_trunnion", "ac_trunnion_tcp_vector", None, &[]),
        ("ac_trunnion", "ac_trunnion_g91", None, &[]),
        ("ac_trunnion", "ac_trunnion_g28_g53", None, &[]),
        ("ac_trunnion", "probe_demo", None, &[]),
        ("bc_trunnion", "bc_trunnion_demo", None, &[]),
        ("head_head", "head_head_demo", None, &[]),
        ("grinder", "grinder_demo", None, &[]),
        ("mill_turn", "mill_turn_milling", None, &[]),
        ("mill_turn", "mill_turn_turning", None, &[]),
        ("mill_turn", "mill_turn_turning", Some("lower"), &[]),
    ];
    for &(machine, name, chain, hold) in cases {
        let (m, e) = fixture(machine);
        let src = std::fs::read(root.join(format!("{name}.nc"))).unwrap();
        for split in [false, true] {
            let comp = Compensator::new(
                &m,
                &e,
                Options {
                    tool_chain: chain.map(String::from),
                    hold: hold.iter().map(|s| s.to_string()).collect(),
                    ..options(split)
                },
            )
            .unwrap();
            for step in [3, 64, 1 << 20] {
                assert_same(&comp, &src, step, &format!("{name}, split {split}"));
            }
        }
    }
}

#[test]
fn a_program_longer_than_the_read_buffer_streams_unchanged() {
    // ≈ 640 kB: the stream is cut into several chunks, at places the reader chooses.
    let src = program::program(10_000);
    let (m, e) = fixture("ac_trunnion");
    for split in [false, true] {
        let comp = Compensator::new(&m, &e, options(split)).unwrap();
        assert_same(&comp, &src, 40_000, &format!("10k blocks, split {split}"));
    }
}

#[test]
fn the_zero_model_streams_the_bytes_through() {
    let (m, _) = fixture("ac_trunnion");
    let zero = nccomp::model::ErrorModel::zero(&m);
    let comp = Compensator::new(&m, &zero, Options::default()).unwrap();
    for src in [
        &b""[..],
        b"\n",
        b"G1 X1\r\nG1 X2",
        b"\xff\xfe(binary)\r\r\n\n",
    ] {
        assert_same(&comp, src, 2, &format!("{src:?}"));
    }
    assert_same(&comp, &program::program(5_000), 9_000, "5k blocks");
}

/// Lines the pass reads: modal codes, axis words in and out of travel, arcs, comments,
/// block delete, odd bytes and line endings.
fn nc_line() -> impl Strategy<Value = String> {
    let word = prop_oneof![
        Just("G0".to_string()),
        Just("G1".to_string()),
        Just("G2".to_string()),
        Just("G3".to_string()),
        Just("G90".to_string()),
        Just("G91".to_string()),
        Just("G20".to_string()),
        Just("G21".to_string()),
        Just("G18".to_string()),
        Just("G43.4 H1".to_string()),
        Just("G49".to_string()),
        Just("G53".to_string()),
        Just("G28".to_string()),
        Just("M6 T1".to_string()),
        Just("(note)".to_string()),
        Just("#1=2".to_string()),
        Just("X[#1]".to_string()),
        (
            prop::sample::select(vec!['X', 'Y', 'Z', 'A', 'C', 'I', 'J', 'R', 'F', 'N']),
            -400.0..400.0f64,
            0usize..5
        )
            .prop_map(|(l, v, d)| format!("{l}{v:.d$}")),
    ];
    (
        prop::bool::weighted(0.05),
        prop::collection::vec(word, 0..6),
        prop::sample::select(vec!["\n", "\n", "\r\n", " \n"]),
    )
        .prop_map(|(skip, words, end)| {
            format!("{}{}{end}", if skip { "/" } else { "" }, words.join(" "))
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    #[test]
    fn random_programs_stream_as_they_run_in_memory(
        lines in prop::collection::vec(nc_line(), 0..40),
        cut_end in any::<bool>(),
        split in any::<bool>(),
        step in 1usize..50,
    ) {
        let (m, e) = fixture("ac_trunnion");
        let mut src = lines.concat().into_bytes();
        if cut_end {
            src.pop();
        }
        let comp = Compensator::new(&m, &e, options(split)).unwrap();
        assert_same(&comp, &src, step, &String::from_utf8_lossy(&src));
    }
}

/// A writer that takes `room` bytes and then fails as a full disk does.
struct FullDisk {
    room: usize,
    written: usize,
}

impl Write for FullDisk {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        if self.written >= self.room {
            return Err(std::io::Error::new(
                std::io::ErrorKind::StorageFull,
                "No space left on device",
            ));
        }
        let k = buf.len().min(self.room - self.written);
        self.written += k;
        Ok(k)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[test]
fn a_full_disk_is_an_error_naming_the_output() {
    let src = program::program(6_000);
    let (m, e) = fixture("ac_trunnion");
    let mut comp = Compensator::new(&m, &e, Options::default()).unwrap();
    let mut whole = Vec::new();
    comp.run(&src, "p.nc", &mut whole).unwrap();
    for (room, threads) in [
        (0, 1),
        (1, 2),
        (100_000, 1),
        (100_000, 2),
        (whole.len() - 1, 2),
    ] {
        comp.set_threads(threads);
        let out = FullDisk { room, written: 0 };
        match comp.run_stream(&src[..], "p.nc", out, "out.nc") {
            Err(Error::Io { path, source }) => {
                assert_eq!(path, "out.nc");
                assert_eq!(source.kind(), std::io::ErrorKind::StorageFull);
            }
            other => panic!("room {room}: expected a write error, got {other:?}"),
        }
    }
}

/// A reader that fails after `good` bytes.
struct FailingRead<'a> {
    bytes: &'a [u8],
    good: usize,
}

impl Read for FailingRead<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        if self.good == 0 {
            return Err(std::io::Error::other("input/output error"));
        }
        let k = buf.len().min(self.good).min(self.bytes.len());
        buf[..k].copy_from_slice(&self.bytes[..k]);
        self.bytes = &self.bytes[k..];
        self.good -= k;
        Ok(k)
    }
}

#[test]
fn a_read_error_is_an_error_naming_the_input() {
    let src = program::program(6_000);
    let (m, e) = fixture("ac_trunnion");
    for errors in [e.clone(), nccomp::model::ErrorModel::zero(&m)] {
        let mut comp = Compensator::new(&m, &errors, Options::default()).unwrap();
        for (good, threads) in [(0, 1), (10, 2), (300_000, 1), (300_000, 2)] {
            comp.set_threads(threads);
            let input = FailingRead { bytes: &src, good };
            match comp.run_stream(input, "p.nc", Vec::new(), "out.nc") {
                Err(Error::Io { path, source }) => {
                    assert_eq!(path, "p.nc");
                    assert_eq!(source.to_string(), "input/output error");
                }
                other => panic!("good {good}: expected a read error, got {other:?}"),
            }
        }
    }
}

#[test]
fn an_error_at_the_last_line_fails_the_run_and_stops_the_output() {
    // The last block programs A past its travel: the whole run fails with a message at
    // that line, and nothing is written after the refused block.
    let mut src = program::program(6_000);
    // Before the program's end (the blocks after M30 do not run, and pass unchanged).
    assert!(src.ends_with(b"M30\n%\n"));
    src.truncate(src.len() - b"M30\n%\n".len());
    src.extend_from_slice(b"G1 X0 Y0 Z10 A-200 C0\n");
    let lines = src.iter().filter(|&&b| b == b'\n').count();
    let (m, e) = fixture("ac_trunnion");
    let comp = Compensator::new(&m, &e, Options::default()).unwrap();
    let mut out = Vec::new();
    let err = comp
        .run_stream(&src[..], "p.nc", &mut out, "out.nc")
        .unwrap_err();
    let Error::Inputs(ds) = &err else {
        panic!("expected a refused block, got {err:?}")
    };
    assert_eq!(ds.len(), 1);
    assert_eq!(ds[0].line, lines);
    assert_eq!(ds[0].source_line, "G1 X0 Y0 Z10 A-200 C0");
    assert!(ds[0].message.contains("outside its travel"), "{}", ds[0]);
    assert!(out.len() < src.len() - 20, "the refused block was written");
}

#[test]
fn tool_changes_between_chains_stream_as_they_run_in_memory() {
    // The turning–milling centre's two turrets as a milling machine: T words switch the
    // tool chain, which the helper's prediction does not follow past the first switch.
    let (mut m, e) = fixture("mill_turn");
    m.lathe = None;
    let mut src = String::from("G21 G90 G17\nT5\nG0 X10. Y0. Z5. B0. C0.\n");
    for k in 0..600 {
        if k % 200 == 100 {
            src.push_str(if k < 400 { "T11\n" } else { "T5\n" });
        }
        let t = f64::from(k) * 0.05;
        // The lower turret has no Y axis.
        let y = if (100..500).contains(&k) {
            String::new()
        } else {
            format!(" Y{:.3}", 5.0 * t.sin())
        };
        let words = format!(
            "X{:.3}{y} Z{:.3} C{:.3}",
            20.0 + 5.0 * t.cos(),
            -1.0 - 0.005 * f64::from(k),
            0.01 * f64::from(k)
        );
        if k % 200 == 100 {
            // The new chain's axes stand where the program has not set them: a rapid
            // sets them before the next cut.
            src.push_str(&format!("G0 {words}\n"));
        }
        src.push_str(&format!("G1 {words}\n"));
    }
    for split in [false, true] {
        let comp = Compensator::new(&m, &e, options(split)).unwrap();
        let mut out = Vec::new();
        comp.run(src.as_bytes(), "p.nc", &mut out)
            .map_err(|e| e.render())
            .unwrap();
        assert_same(&comp, src.as_bytes(), 1 << 12, &format!("split {split}"));
    }
}

#[test]
fn a_line_longer_than_a_megabyte_is_refused_before_it_is_read_whole() {
    let (machine, errors) = fixture("ac_trunnion");
    let long = "X1 ".repeat(800_000);
    let program = format!("G21 G90\nG0 X1 Y2 Z50 A0 C0\n{long}\nM30\n");
    for threads in [1, 2] {
        let mut comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
        comp.set_threads(threads);
        let mut out = Vec::new();
        let err = comp
            .run_stream(program.as_bytes(), "long.nc", &mut out, "out.nc")
            .unwrap_err()
            .to_string();
        assert!(
            err.starts_with("long.nc:3:1: this line is longer than 1 MiB"),
            "{threads} threads: {err}"
        );
    }
    // In memory, too (`check`, `report`).
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();
    let err = comp
        .run(program.as_bytes(), "long.nc", &mut Vec::new())
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("long.nc:3:1: this line is longer than 1 MiB"),
        "{err}"
    );
    // The zero model reads nothing: the bytes go straight through.
    let zero = nccomp::model::ErrorModel::zero(&machine);
    let comp = Compensator::new(&machine, &zero, Options::default()).unwrap();
    let mut out = Vec::new();
    let summary = comp
        .run_stream(program.as_bytes(), "long.nc", &mut out, "out.nc")
        .unwrap();
    assert_eq!(out, program.as_bytes());
    assert_eq!(summary.lines, 4);
}

//! Fuzzing without a fuzzing engine: a deterministic mutation loop over the shipped
//! fixtures, feeding the NC parser and pass, and the machine and error file loaders, bytes
//! they were never meant to see. Nothing may panic; the parser must stay lossless.
//!
//! The suite runs a few thousand executions per target. The long run (docs/robustness.md):
//!
//!     NCCOMP_FUZZ_EXECS=1000000 cargo test --release --test fuzz -- --nocapture
//!
//! `NCCOMP_FUZZ_SEED` picks another sequence of mutations.

use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::path::PathTolerance;
use nccomp::model::{error_file, machine_file};
use std::path::Path;

/// SplitMix64: small, fast and the same everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.below(items.len())]
    }
}

fn execs(default: u64) -> u64 {
    std::env::var("NCCOMP_FUZZ_EXECS")
        .ok()
        .and_then(|v| v.replace('_', "").parse().ok())
        .unwrap_or(default)
}

fn seed() -> u64 {
    std::env::var("NCCOMP_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(0x6e63_636f_6d70)
}

/// Bytes worth inserting: what NC and TOML files are made of, and what breaks parsers.
const BYTES: &[u8] = b"0123456789.-+ \t\n\r()[]#<>%/;=\"'{},XYZABCIJKRFGMNTxyz\x00\xff\xc3";

/// Texts worth splicing in: extreme numbers and modal codes.
const PIECES: &[&str] = &[
    "1e308",
    "-1e308",
    "nan",
    "inf",
    "-0",
    "0.0000000000000000001",
    "99999999999999999999999",
    "360.00000",
    "-0.",
    ".",
    // A number too long for a float (a 400-digit word is infinite), and one just beyond
    // the largest a word may hold.
    "9999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999999",
    "1000000.1",
    "G91",
    "G20",
    "G2",
    "G3",
    "G43.4",
    "G43.5",
    "G93",
    "G28",
    "G53",
    "G18",
    "G90.1",
    "M428",
    "M128",
    "X",
    "A-120",
    "C9999",
    "R0",
    "I0J0K0",
    "[",
    "(",
    "/",
    "\r\n",
    "\u{feff}",
    "[[x]]",
    "\n[codes]\ntcp_on = [\"M428\"]\n",
    "= 0",
    "= []",
    "= -1e300",
    "= \"\"",
    "= {}",
];

/// One mutation of `data`, sometimes using bytes of `other`.
fn mutate(rng: &mut Rng, data: &mut Vec<u8>, other: &[u8]) {
    let len = data.len();
    match rng.below(8) {
        0 if len > 0 => {
            let i = rng.below(len);
            data[i] ^= 1 << rng.below(8);
        }
        1 => {
            let i = rng.below(len + 1);
            data.insert(i, *rng.pick(BYTES));
        }
        2 if len > 0 => {
            let i = rng.below(len);
            let n = 1 + rng.below(16.min(len - i));
            data.drain(i..i + n);
        }
        3 if len > 0 => {
            let i = rng.below(len);
            data[i] = *rng.pick(BYTES);
        }
        4 => {
            let i = rng.below(len + 1);
            let piece = rng.pick(PIECES).as_bytes();
            data.splice(i..i, piece.iter().copied());
        }
        5 if len > 0 => {
            // Replace a number (a run of digits and dots) with an extreme one.
            let i = rng.below(len);
            if data[i].is_ascii_digit() {
                let mut j = i;
                while j < len && (data[j].is_ascii_digit() || data[j] == b'.') {
                    j += 1;
                }
                let piece = rng.pick(&PIECES[..12]).as_bytes();
                data.splice(i..j, piece.iter().copied());
            }
        }
        6 if !other.is_empty() => {
            let i = rng.below(other.len());
            let n = 1 + rng.below(64.min(other.len() - i));
            let at = rng.below(len + 1);
            data.splice(at..at, other[i..i + n].iter().copied());
        }
        _ if len > 0 => {
            // Duplicate or drop a line.
            let i = rng.below(len);
            let start = data[..i]
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |p| p + 1);
            let end = data[i..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(len, |p| i + p + 1);
            if rng.below(2) == 0 {
                let line = data[start..end].to_vec();
                data.splice(end..end, line);
            } else {
                data.drain(start..end);
            }
        }
        _ => {}
    }
}

fn fixtures() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}

/// A few lines of one of the seeds, mutated a few times.
fn sample(rng: &mut Rng, seeds: &[Vec<u8>], lines: usize) -> Vec<u8> {
    let seed = rng.pick(seeds);
    let starts: Vec<usize> = std::iter::once(0)
        .chain(
            seed.iter()
                .enumerate()
                .filter(|&(_, &b)| b == b'\n')
                .map(|(i, _)| i + 1),
        )
        .filter(|&i| i < seed.len())
        .collect();
    let first = rng.below(starts.len().saturating_sub(lines).max(1));
    let start = starts.get(first).copied().unwrap_or(0);
    let end = starts.get(first + lines).copied().unwrap_or(seed.len());
    let mut data = seed[start..end].to_vec();
    let other = rng.pick(seeds).clone();
    for _ in 0..1 + rng.below(6) {
        mutate(rng, &mut data, &other);
    }
    data
}

#[test]
fn the_nc_parser_and_pass_survive_mutated_programs() {
    let root = fixtures();
    let mut seeds = Vec::new();
    for entry in std::fs::read_dir(&root).unwrap() {
        let path = entry.unwrap().path();
        // G-code and Sinumerik programs (mutated Sinumerik lines land in both readers).
        if path.extension().is_some_and(|e| e == "nc" || e == "mpf") {
            seeds.push(std::fs::read(&path).unwrap());
        }
    }
    seeds.sort();
    let m = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let e = error_file::load(&root.join("ac_trunnion.errors.toml"), &m).unwrap();
    let plain = Compensator::new(&m, &e, Options::default()).unwrap();
    let splitting = Compensator::new(
        &m,
        &e,
        Options {
            path: Some(PathTolerance::default()),
            allow_limit_violations: true,
            ..Options::default()
        },
    )
    .unwrap();
    // A turning–milling centre: tool chains by T word, turning and milling by spindle code.
    let mt = machine_file::load(&root.join("mill_turn.machine.toml")).unwrap();
    let mte = error_file::load(&root.join("mill_turn.errors.toml"), &mt).unwrap();
    let mill_turn = Compensator::new(&mt, &mte, Options::default()).unwrap();
    let total = execs(10_000);
    let mut rng = Rng(seed());
    let mut tokens = Vec::new();
    let mut out = Vec::new();
    let (mut compensated, mut refused) = (0u64, 0u64);
    let mut slowest = (std::time::Duration::ZERO, 0);
    // `NCCOMP_FUZZ_DUMP=<n>`: write execution n's program to `fuzz-<n>.nc`.
    let dump = std::env::var("NCCOMP_FUZZ_DUMP")
        .ok()
        .and_then(|v| v.parse::<u64>().ok());
    for exec in 0..total {
        let lines = 1 + rng.below(30);
        let data = sample(&mut rng, &seeds, lines);
        // The parser: lossless on any bytes.
        let mut back = Vec::with_capacity(data.len());
        let dialect = nccomp::nc::Dialect::detect(&data);
        for line in nccomp::nc::lines(&data) {
            dialect.parse_line(line.content, &mut tokens);
            let mut pos = 0;
            for t in &tokens {
                assert_eq!(t.span.start, pos, "exec {exec}: {data:?}");
                pos = t.span.end;
            }
            assert_eq!(pos, line.content.len(), "exec {exec}: {data:?}");
            nccomp::nc::emit_line(&line, &mut [], &mut back);
        }
        assert!(back == data, "exec {exec}: not lossless: {data:?}");
        // The pass: output or located errors, never a panic.
        out.clear();
        let comp = [&plain, &splitting, &mill_turn][(exec % 3) as usize];
        if dump == Some(exec) {
            std::fs::write(format!("fuzz-{exec}.nc"), &data).unwrap();
        }
        let started = std::time::Instant::now();
        match comp.run(&data, "fuzz.nc", &mut out) {
            Ok(_) => compensated += 1,
            Err(nccomp::Error::Inputs(ds)) => {
                assert!(ds.iter().all(|d| d.line >= 1 && d.column >= 1));
                refused += 1;
            }
            Err(other) => panic!("exec {exec}: unexpected error {other:?} for {data:?}"),
        }
        // Not a timed test: a long run reports its slowest input, for a look by hand.
        let took = started.elapsed();
        if took > slowest.0 {
            slowest = (took, exec);
        }
        if (exec + 1) % 100_000 == 0 {
            eprintln!("nc: {} executions", exec + 1);
        }
    }
    println!(
        "nc: {total} executions, {compensated} compensated, {refused} refused; slowest: execution {} ({:.2?})",
        slowest.1, slowest.0
    );
    assert_eq!(compensated + refused, total);
    assert!(compensated > total / 20 && refused > total / 100);
}

#[test]
fn the_machine_and_error_loaders_survive_mutated_files() {
    let root = fixtures();
    let names = [
        "ac_trunnion",
        "bc_trunnion",
        "head_head",
        "grinder",
        "mill_turn",
        "lathe",
    ];
    let machines: Vec<Vec<u8>> = names
        .iter()
        .map(|n| std::fs::read(root.join(format!("{n}.machine.toml"))).unwrap())
        .collect();
    let errors: Vec<Vec<u8>> = names
        .iter()
        .map(|n| std::fs::read(root.join(format!("{n}.errors.toml"))).unwrap())
        .collect();
    let program = b"G90 G21\nG0 X10 Y10 Z20 A0 B0 C0\nG1 X20 Y-5 Z10 A10 B5 C30 F500\n";
    let total = execs(3_000);
    let mut rng = Rng(seed() ^ 0x746f_6d6c);
    let (mut machines_ok, mut models_ok, mut runs) = (0u64, 0u64, 0u64);
    for exec in 0..total {
        let k = rng.below(names.len());
        let mutate_machine = rng.below(3) > 0;
        let mut machine_text = machines[k].clone();
        let mut errors_text = errors[k].clone();
        let target = if mutate_machine {
            &mut machine_text
        } else {
            &mut errors_text
        };
        let other = rng.pick(&machines).clone();
        for _ in 0..1 + rng.below(4) {
            mutate(&mut rng, target, &other);
        }
        let machine_text = String::from_utf8_lossy(&machine_text);
        let errors_text = String::from_utf8_lossy(&errors_text);
        let machine = match machine_file::parse(&machine_text, "fuzz.machine.toml") {
            Ok(m) => m,
            Err(e) => {
                assert!(!e.render().is_empty(), "exec {exec}");
                continue;
            }
        };
        machines_ok += 1;
        let model = match error_file::parse(&errors_text, "fuzz.errors.toml", &machine) {
            Ok(e) => e,
            Err(e) => {
                assert!(!e.render().is_empty(), "exec {exec}");
                continue;
            }
        };
        models_ok += 1;
        // What loads must be usable: a compensator, or a reason why not.
        for chain in 0..machine.tool_chains.len() {
            let options = Options {
                tool_chain: Some(machine.tool_chains[chain].name.clone()),
                allow_limit_violations: true,
                ..Options::default()
            };
            if let Ok(comp) = Compensator::new(&machine, &model, options) {
                let _ = comp.run(program, "fuzz.nc", &mut Vec::new());
                runs += 1;
            }
        }
    }
    println!(
        "loaders: {total} executions, {machines_ok} machines loaded, {models_ok} error models, {runs} runs"
    );
    assert!(machines_ok > total / 10 && models_ok > total / 20 && runs > 0);
}

//! Throughput with the options users run (issue 26): 300,000 random five-axis finishing
//! moves (benches/common/random.rs) on the AC trunnion with a full random calibration,
//! compensated in memory as `nccomp compensate` streams a file, with the command line's
//! default options and with each of `--threads 1` and `--tolerance off`, and with the
//! verification gate that `nccomp compensate` runs on every output (the written program
//! read back and held against the original); gcode-rs parsing the same text beside them,
//! as the anchor.
//!
//!     cargo bench --bench throughput
//!
//! Figures go to docs/performance.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::path::PathTolerance;
use nccomp::model::{error_file, machine_file};
use nccomp::nc::Dialect;
use nccomp::verify::Text;
use std::hint::black_box;
use std::path::Path;

mod common {
    pub mod random;
}

const BLOCKS: usize = 300_000;

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let errors = error_file::parse(
        &common::random::random_errors(),
        "full.errors.toml",
        &machine,
    )
    .unwrap();
    let src = common::random::random_program(BLOCKS);
    let text = std::str::from_utf8(&src).unwrap();

    let mut group = c.benchmark_group("throughput");
    group.sample_size(10);
    group.throughput(Throughput::Elements(BLOCKS as u64));
    // The command line's defaults: the path checked to 1 µm, two threads.
    for (name, threads, path) in [
        (
            "default (2 threads, tolerance 0.001)",
            2,
            Some(PathTolerance::default()),
        ),
        ("--threads 1", 1, Some(PathTolerance::default())),
        ("--tolerance off", 2, None),
        ("--threads 1 --tolerance off", 1, None),
    ] {
        let comp = Compensator::new(
            &machine,
            &errors,
            Options {
                path,
                threads,
                ..Options::default()
            },
        )
        .unwrap();
        group.bench_function(name, |b| {
            let mut out = Vec::with_capacity(src.len() * 2);
            b.iter(|| {
                out.clear();
                comp.run_stream(black_box(&src[..]), "bench.nc", &mut out, "out")
                    .unwrap()
            })
        });
    }
    // What `nccomp compensate` does with the defaults: the pass, then the gate.
    let comp = Compensator::new(
        &machine,
        &errors,
        Options {
            path: Some(PathTolerance::default()),
            threads: 2,
            ..Options::default()
        },
    )
    .unwrap();
    group.bench_function("default, verified (nccomp compensate)", |b| {
        let mut out = Vec::with_capacity(src.len() * 2);
        b.iter(|| {
            out.clear();
            comp.run_stream(black_box(&src[..]), "bench.nc", &mut out, "out")
                .unwrap();
            let verdict = comp
                .verify(
                    Text {
                        name: "bench.nc",
                        src: &src,
                    }
                    .into(),
                    Text {
                        name: "out",
                        src: &out,
                    }
                    .into(),
                    Dialect::Iso,
                )
                .unwrap();
            assert!(verdict.passed());
            verdict.moves
        })
    });
    group.bench_function("gcode-rs 0.7: parse to a Program (AST)", |b| {
        b.iter(|| gcode::parse(black_box(text)).map(|p| p.blocks.len()))
    });
    group.bench_function("gcode-rs 0.7: visitor core (no allocation)", |b| {
        b.iter(|| gcode::core::parse(black_box(text), &mut gcode::core::Noop))
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

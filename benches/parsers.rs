//! nccomp's parser beside gcode-rs (the `gcode` crate), and nccomp's identity pass beside
//! `cat`, on the benchmark program (100,000 five-axis blocks, 5.7 MB).
//!
//!     cargo bench --bench parsers
//!
//! Ratios go to docs/performance.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nccomp::compensate::{Compensator, Options};
use nccomp::model::{ErrorModel, machine_file};
use std::hint::black_box;
use std::path::Path;

mod common {
    pub mod program;
}

fn bench(c: &mut Criterion) {
    let src = common::program::program(100_000);
    let text = std::str::from_utf8(&src).unwrap();

    let mut group = c.benchmark_group("parse 100k blocks");
    group.sample_size(10);
    group.throughput(Throughput::Bytes(src.len() as u64));
    group.bench_function("nccomp: lines and tokens", |b| {
        let mut tokens = Vec::new();
        b.iter(|| {
            let mut n = 0;
            for line in nccomp::nc::lines(black_box(&src)) {
                nccomp::nc::parse_line(line.content, &mut tokens);
                n += tokens.len();
            }
            n
        })
    });
    group.bench_function("gcode-rs: visitor core (no allocation)", |b| {
        b.iter(|| gcode::core::parse(black_box(text), &mut gcode::core::Noop))
    });
    group.bench_function("gcode-rs: parse to a Program (AST)", |b| {
        b.iter(|| gcode::parse(black_box(text)).map(|p| p.blocks.len()))
    });
    group.finish();

    // Identity passes, file to file.
    let dir = tempfile::tempdir().unwrap();
    let input = dir.path().join("in.nc");
    let output = dir.path().join("out.nc");
    std::fs::write(&input, &src).unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let zero = ErrorModel::zero(&machine);
    let comp = Compensator::new(&machine, &zero, Options::default()).unwrap();

    let mut group = c.benchmark_group("identity, file to file, 100k blocks");
    group.sample_size(10);
    group.throughput(Throughput::Bytes(src.len() as u64));
    group.bench_function("cat", |b| {
        b.iter(|| {
            let out = std::fs::File::create(&output).unwrap();
            let status = std::process::Command::new("cat")
                .arg(&input)
                .stdout(out)
                .status()
                .unwrap();
            assert!(status.success());
        })
    });
    group.bench_function("nccomp: zero model (run_stream)", |b| {
        b.iter(|| {
            let inp = std::fs::File::open(&input).unwrap();
            let out = std::fs::File::create(&output).unwrap();
            comp.run_stream(inp, "in.nc", out, "out.nc").unwrap()
        })
    });
    group.bench_function("nccomp: read, tokenize and emit every line", |b| {
        let mut tokens = Vec::new();
        let mut buf = Vec::with_capacity(src.len());
        b.iter(|| {
            let bytes = std::fs::read(&input).unwrap();
            buf.clear();
            for line in nccomp::nc::lines(&bytes) {
                nccomp::nc::parse_line(line.content, &mut tokens);
                nccomp::nc::emit_line(&line, &mut [], &mut buf);
            }
            std::fs::write(&output, &buf).unwrap();
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

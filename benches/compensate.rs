//! Compensation throughput on a generated five-axis program of 100,000 blocks, and the
//! same moves as a million-block G-code and Heidenhain TNC program with the command line's
//! options.
//!
//!     cargo bench --bench compensate
//!     cargo bench --bench compensate -- dialects   # the G-code / TNC comparison only
//!
//! Figures go to docs/performance.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model, SolveOptions};
use nccomp::model::{error_file, machine_file};
use std::hint::black_box;
use std::path::Path;

mod common {
    pub mod program;
}

const BLOCKS: usize = 100_000;

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let errors = error_file::load(&root.join("ac_trunnion.errors.toml"), &machine).unwrap();
    let src = common::program::program(BLOCKS);
    let comp = Compensator::new(&machine, &errors, Options::default()).unwrap();

    let mut group = c.benchmark_group("compensate");
    group.sample_size(10);
    group.throughput(Throughput::Elements(BLOCKS as u64));
    group.bench_function("five-axis program, 100k blocks", |b| {
        let mut out = Vec::with_capacity(src.len() * 2);
        b.iter(|| {
            out.clear();
            comp.run(black_box(&src), "bench.nc", &mut out).unwrap()
        })
    });
    let splitting = Compensator::new(
        &machine,
        &errors,
        Options {
            path: Some(nccomp::kinematics::path::PathTolerance::default()),
            ..Options::default()
        },
    )
    .unwrap();
    group.bench_function("five-axis program, 100k blocks, split to 1 µm", |b| {
        let mut out = Vec::with_capacity(src.len() * 2);
        b.iter(|| {
            out.clear();
            splitting
                .run(black_box(&src), "bench.nc", &mut out)
                .unwrap()
        })
    });
    group.bench_function("parse and emit only (lines + tokens)", |b| {
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
    group.finish();

    // The parts of one block's work, per pose.
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let q = [35.0, -20.0, 12.0, -27.0, 40.0];
    let opts = SolveOptions::default();
    let mut group = c.benchmark_group("per pose");
    group.bench_function("pose (with errors)", |b| {
        b.iter(|| kin.pose(Model::Actual, black_box(&q), 95.3))
    });
    group.bench_function("pose and Jacobian", |b| {
        b.iter(|| kin.pose_and_jacobian(Model::Actual, black_box(&q), 95.3))
    });
    group.bench_function("solve (compensate one pose)", |b| {
        b.iter(|| kin.compensate(black_box(&q), 95.3, 0, &opts))
    });
    group.finish();

    // The kinematics of every block as the pass does it, without reading or writing a byte:
    // the solve with the compensation options and the pose at the written (rounded) values.
    // This is the floor under the end-to-end throughput (docs/performance.md).
    let poses = program_axes(&src);
    let solve = SolveOptions::compensation();
    let length = machine.tool.length;
    let mut group = c.benchmark_group("per block");
    group.sample_size(10);
    group.throughput(Throughput::Elements(poses.len() as u64));
    group.bench_function(
        "kinematics only: solve and the pose written, 100k blocks",
        |b| {
            b.iter(|| {
                let mut worst = 0f64;
                for q in &poses {
                    let sol = kin.compensate(black_box(q), length, 0, &solve);
                    let written = sol.q.map(|x| (x * 1e4).round() / 1e4);
                    let (after, _) = kin.pose_near(Model::Actual, &written, length, &sol.angles);
                    worst = worst.max(after.deviation(&sol.target).0);
                }
                worst
            })
        },
    );
    group.finish();

    // The same million moves as G-code and as a Heidenhain TNC program, with the options
    // of the command line (the path checked to 1 µm, two threads, streamed), side by side.
    const MILLION: usize = 1_000_000;
    let gcode = common::program::program(MILLION);
    let tnc = common::program::tnc_program(MILLION);
    let cli = Compensator::new(
        &machine,
        &errors,
        Options {
            path: Some(nccomp::kinematics::path::PathTolerance::default()),
            threads: 2,
            ..Options::default()
        },
    )
    .unwrap();
    let mut group = c.benchmark_group("dialects");
    group.sample_size(10);
    group.throughput(Throughput::Elements(MILLION as u64));
    for (name, src) in [("G-code", &gcode), ("Heidenhain TNC", &tnc)] {
        group.bench_function(format!("{name}, 1M blocks, default options"), |b| {
            let mut out = Vec::with_capacity(src.len() * 2);
            b.iter(|| {
                out.clear();
                cli.run_stream(black_box(&src[..]), "bench", &mut out, "out")
                    .unwrap()
            })
        });
    }
    group.finish();
}

/// The X Y Z A C values of the program's G1 blocks (the generator writes all five in each).
fn program_axes(src: &[u8]) -> Vec<[f64; 5]> {
    let text = std::str::from_utf8(src).unwrap();
    text.lines()
        .filter(|l| l.contains(" G1 "))
        .map(|l| {
            let mut q = [0.0; 5];
            for (k, w) in l.split(' ').skip(2).enumerate() {
                q[k] = w[1..].parse().unwrap();
            }
            q
        })
        .collect()
}

criterion_group!(benches, bench);
criterion_main!(benches);

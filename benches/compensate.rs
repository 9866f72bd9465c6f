//! Compensation throughput on a generated five-axis program of 100,000 blocks.
//!
//!     cargo bench --bench compensate
//!
//! Figures go to docs/performance.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model, SolveOptions};
use nccomp::model::{error_file, machine_file};
use std::hint::black_box;
use std::path::Path;

const BLOCKS: usize = 100_000;

/// A five-axis G1 program: a spiral over a tilted surface with A and C moving in every block,
/// modal words, N numbers, a comment every 100 blocks.
fn program() -> Vec<u8> {
    let mut s = String::from("%\nO0100 (BENCH)\nN10 G21 G90 G94\nN20 G0 X0 Y0 Z50. A0 C0\n");
    for i in 0..BLOCKS {
        let t = i as f64 / BLOCKS as f64;
        let phi = t * 400.0 * std::f64::consts::TAU;
        let r = 20.0 + 100.0 * t;
        let x = r * phi.cos();
        let y = r * phi.sin();
        let z = 10.0 + 5.0 * (phi * 0.5).sin();
        let a = -30.0 + 25.0 * (t * 50.0).sin();
        let c = (phi.to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
        if i % 100 == 0 {
            s.push_str("(PASS)\n");
        }
        s.push_str(&format!(
            "N{} G1 X{x:.4} Y{y:.4} Z{z:.4} A{a:.4} C{c:.4}\n",
            30 + i
        ));
    }
    s.push_str("M30\n%\n");
    s.into_bytes()
}

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let errors = error_file::load(&root.join("ac_trunnion.errors.toml"), &machine).unwrap();
    let src = program();
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
}

criterion_group!(benches, bench);
criterion_main!(benches);

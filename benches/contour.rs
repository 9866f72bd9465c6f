//! Contour analysis of a million-sample trace.
//!
//!     cargo bench --bench contour
//!
//! The program is the S-shaped test piece's face finished in 90 passes there and back
//! (18,103 blocks, 20.1 m of tool tip path); the trace is a simulated run of it at F1200
//! on the AC trunnion with servo lag, read every millisecond: 1,007,908 samples (20 µm
//! apart), so the program is sampled at about a million reference points too. Figures go
//! to docs/performance.md.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nccomp::contour::s_shape::{Finishing, SShape, finishing_program};
use nccomp::contour::simulate::{Servo, simulate};
use nccomp::contour::{self, trace};
use nccomp::kinematics::Kinematics;
use nccomp::model::{ErrorModel, machine_file};
use nccomp::program::moves::nominal_moves;
use std::hint::black_box;
use std::path::Path;

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let finishing = Finishing {
        passes: 90,
        step_down: 0.1,
        ..Finishing::default()
    };
    let program = finishing_program(&machine, &SShape::paper(), &finishing).unwrap();
    let (moves, chain) = nominal_moves(&machine, 0, program.as_bytes(), "bench.nc", 20).unwrap();
    let kin = &Kinematics::new(&machine, &ErrorModel::zero(&machine), chain).unwrap();
    let servo = Servo {
        sample: 0.001,
        ..Servo::paper(kin.len())
    };
    let length = machine.tool.lengths[&1];
    let mut trace = simulate(&machine, kin, &moves, length, &servo);
    trace.commanded = None;
    let samples = trace.len();
    assert!(samples >= 1_000_000, "{samples} samples");
    let csv = trace.to_csv();
    let options = contour::Options::default();
    let analysis = contour::analyse_trace(
        kin,
        &moves,
        &trace,
        ("bench.nc", program.as_bytes()),
        &options,
    )
    .unwrap();
    eprintln!(
        "{} blocks, {:.1} m of tool tip path; {samples} samples, {} reference points, step {:.4} mm, max tip error {:.3} µm",
        program.lines().count(),
        analysis.path_length / 1e3,
        analysis.reference.len(),
        analysis.step,
        analysis.summary.tip.max * 1e3
    );

    let mut group = c.benchmark_group("contour");
    group.sample_size(10);
    group.throughput(Throughput::Elements(samples as u64));
    group.bench_function("1M-sample trace, in memory", |b| {
        b.iter(|| {
            contour::analyse_trace(
                kin,
                &moves,
                black_box(&trace),
                ("bench.nc", program.as_bytes()),
                &options,
            )
            .unwrap()
        })
    });
    // What `nccomp contour` does between reading the files and writing its outputs: the
    // program followed, the CSV read, the analysis.
    group.bench_function("1M-sample trace, program and CSV text to analysis", |b| {
        b.iter(|| {
            contour::analyse(
                &machine,
                ("bench.nc", program.as_bytes()),
                ("bench.csv", black_box(csv.as_bytes())),
                &options,
            )
            .unwrap()
        })
    });
    group.bench_function("reading the 1M-sample CSV", |b| {
        b.iter(|| trace::read("bench.csv", black_box(csv.as_bytes()), &machine, kin).unwrap())
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);

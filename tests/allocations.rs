//! No allocation per block: compensating a program costs a fixed number of allocations
//! (buffers set up once, grown a few times), not one or more per block. Counted with an
//! allocator that counts every allocation of the process (this file holds one test, so
//! nothing else runs beside it).

use nccomp::compensate::{Compensator, Options, Summary};
use nccomp::kinematics::path::PathTolerance;
use nccomp::model::{error_file, machine_file};
use std::alloc::{GlobalAlloc, Layout, System};
use std::fmt::Write;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

fn count() {
    ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
}

// SAFETY: every call is passed on to the system allocator unchanged; the count is an
// atomic that needs no allocation itself.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: the caller's contract, passed on.
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        count();
        // SAFETY: as above.
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        // SAFETY: as above.
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: as above.
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// A five-axis finishing pass: small steps (0.3 mm, hundredths of a degree), every axis
/// moving in every block, so no move strays enough to be split.
fn program(blocks: usize) -> String {
    let mut out = String::from("%\nN10 G21 G90 G94\nN20 G0 X30. Y0 Z5. A-20. C-100.\n");
    for i in 0..blocks {
        let t = i as f64;
        let c = -100.0 + t * 0.01;
        let a = -20.0 + 10.0 * (t * 0.002).sin();
        let r = 30.0 + 0.002 * t;
        let (x, y) = (r * (t * 0.01).cos(), r * (t * 0.01).sin());
        let z = 5.0 + 2.0 * (t * 0.003).sin();
        let _ = writeln!(
            out,
            "N{} G1 X{x:.4} Y{y:.4} Z{z:.4} A{a:.4} C{c:.4}",
            30 + i
        );
    }
    out.push_str("M30\n%\n");
    out
}

/// Allocations of one streamed pass over `src` (the compensator made beforehand).
fn allocations(comp: &Compensator<'_>, src: &str) -> (u64, Summary) {
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    let summary = comp
        .run_stream(src.as_bytes(), "p.nc", std::io::sink(), "out.nc")
        .unwrap();
    (ALLOCATIONS.load(Ordering::Relaxed) - before, summary)
}

#[test]
fn the_pass_allocates_nothing_per_block() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fixtures");
    let machine = machine_file::load(&root.join("ac_trunnion.machine.toml")).unwrap();
    let errors = error_file::load(&root.join("ac_trunnion.errors.toml"), &machine).unwrap();
    // Both long enough for several chunks of the stream, so that the buffers have all
    // been set up by the end of the shorter one.
    let (short, long) = (program(20_000), program(80_000));
    // Without and with the path check (the default), on one thread and with the helper
    // thread that solves ahead (the default).
    for (path, threads) in [
        (None, 1),
        (Some(PathTolerance::default()), 1),
        (Some(PathTolerance::default()), 2),
    ] {
        let options = Options {
            path,
            threads,
            ..Options::default()
        };
        let comp = Compensator::new(&machine, &errors, options).unwrap();
        let (few, summary) = allocations(&comp, &short);
        let (many, long_summary) = allocations(&comp, &long);
        assert!(summary.motion_blocks > 20_000);
        assert!(long_summary.motion_blocks > 80_000);
        assert_eq!(
            long_summary.blocks_added, 0,
            "{path:?}, {threads} threads: the program was meant to need no split: {long_summary}"
        );
        assert!(long_summary.words_changed > 200_000);
        // 60,000 blocks more; a few more buffer growths for the longer stream at most.
        assert!(
            many <= few + 16,
            "{path:?}, {threads} threads: {few} allocations for 20,000 blocks, {many} for 80,000"
        );
    }
}

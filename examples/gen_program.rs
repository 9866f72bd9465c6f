//! Write the benchmark's five-axis program (benches/common/program.rs) with any number of
//! blocks, for measuring nccomp on large files:
//!
//!     cargo run --release --example gen_program -- 17000000 > big.nc   # ≈ 1 GB
//!
//! The argument is the number of G1 blocks (default 100,000); the program goes to standard
//! output. With `--tnc` after it, the same moves come as a Heidenhain TNC program (`L`
//! blocks).

#[path = "../benches/common/program.rs"]
mod program;

use std::io::Write;

fn main() -> std::process::ExitCode {
    let blocks = match std::env::args().nth(1).map(|a| a.replace('_', "").parse()) {
        None => 100_000,
        Some(Ok(n)) => n,
        Some(Err(_)) => {
            eprintln!("usage: gen_program [BLOCKS]  (a whole number of G1 blocks)");
            return std::process::ExitCode::from(2);
        }
    };
    let stdout = std::io::stdout().lock();
    let mut out = std::io::BufWriter::with_capacity(1 << 20, stdout);
    let tnc = std::env::args().nth(2).as_deref() == Some("--tnc");
    let written = if tnc {
        program::write_tnc_program(blocks, &mut out)
    } else {
        program::write_program(blocks, &mut out)
    };
    match written.and_then(|()| out.flush()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gen_program: {e}");
            std::process::ExitCode::from(1)
        }
    }
}

//! Write the benchmarks' programs with any number of blocks, for measuring nccomp on large
//! files:
//!
//!     cargo run --release --example gen_program -- 17000000 > big.nc   # ≈ 1 GB
//!     cargo run --release --example gen_program -- 300000 --random > r300k.nc
//!     cargo run --release --example gen_program -- --errors > full.errors.toml
//!
//! The argument is the number of G1 blocks (default 100,000); the program goes to standard
//! output. Without a second argument it is the five-axis spiral of benches/common/program.rs;
//! with `--tnc` the same moves as a Heidenhain TNC program (`L` blocks); with `--random`
//! the random five-axis finishing moves of benches/common/random.rs. `--errors` alone
//! writes the full random calibration of the AC trunnion that goes with `--random`.

#[path = "../benches/common/program.rs"]
mod program;
#[path = "../benches/common/random.rs"]
mod random;

use std::io::Write;

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let stdout = std::io::stdout().lock();
    let mut out = std::io::BufWriter::with_capacity(1 << 20, stdout);
    let written = if args.first().map(String::as_str) == Some("--errors") {
        out.write_all(random::random_errors().as_bytes())
    } else {
        let blocks = match args.first().map(|a| a.replace('_', "").parse()) {
            None => 100_000,
            Some(Ok(n)) => n,
            Some(Err(_)) => {
                eprintln!(
                    "usage: gen_program [BLOCKS] [--tnc | --random]  or  gen_program --errors"
                );
                return std::process::ExitCode::from(2);
            }
        };
        match args.get(1).map(String::as_str) {
            Some("--tnc") => program::write_tnc_program(blocks, &mut out),
            Some("--random") => random::write_random_program(blocks, &mut out),
            _ => program::write_program(blocks, &mut out),
        }
    };
    match written.and_then(|()| out.flush()) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("gen_program: {e}");
            std::process::ExitCode::from(1)
        }
    }
}

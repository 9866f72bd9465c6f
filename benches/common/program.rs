//! The benchmark program: a five-axis G1 spiral over a tilted surface with A and C moving in
//! every block, modal words, N numbers and a comment every 100 blocks. Shared by the
//! benchmarks and `examples/gen_program.rs` (which writes it to a file of any size).

use std::io::Write;

/// The `i`-th of `blocks` moves: X Y Z A C.
fn point(i: usize, blocks: usize) -> [f64; 5] {
    let t = i as f64 / blocks as f64;
    let phi = t * 400.0 * std::f64::consts::TAU;
    let r = 20.0 + 100.0 * t;
    let a = -30.0 + 25.0 * (t * 50.0).sin();
    let c = (phi.to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
    [
        r * phi.cos(),
        r * phi.sin(),
        10.0 + 5.0 * (phi * 0.5).sin(),
        a,
        c,
    ]
}

/// The same moves as a Heidenhain TNC program: numbered `L` blocks with signed words, a
/// `;` comment every 100 blocks.
#[allow(dead_code)]
pub fn write_tnc_program(blocks: usize, out: &mut impl Write) -> std::io::Result<()> {
    out.write_all(
        b"0 BEGIN PGM BENCH MM\n1 TOOL CALL 1 Z S8000\n2 L X+0 Y+0 Z+50 A+0 C+0 R0 FMAX\n",
    )?;
    let mut n = 3;
    for i in 0..blocks {
        let [x, y, z, a, c] = point(i, blocks);
        if i % 100 == 0 {
            writeln!(out, "{n} ; PASS")?;
            n += 1;
        }
        let feed = if i == 0 { " F1000" } else { "" };
        writeln!(
            out,
            "{n} L X{x:+.4} Y{y:+.4} Z{z:+.4} A{a:+.4} C{c:+.4}{feed}"
        )?;
        n += 1;
    }
    writeln!(out, "{n} M30\n{} END PGM BENCH MM", n + 1)
}

/// The TNC program of `blocks` moves in memory.
#[allow(dead_code)]
pub fn tnc_program(blocks: usize) -> Vec<u8> {
    let mut out = Vec::new();
    write_tnc_program(blocks, &mut out).expect("writing to memory");
    out
}

/// Write the program of `blocks` moves to `out`.
pub fn write_program(blocks: usize, out: &mut impl Write) -> std::io::Result<()> {
    out.write_all(b"%\nO0100 (BENCH)\nN10 G21 G90 G94\nN20 G0 X0 Y0 Z50. A0 C0\n")?;
    for i in 0..blocks {
        let t = i as f64 / blocks as f64;
        let phi = t * 400.0 * std::f64::consts::TAU;
        let r = 20.0 + 100.0 * t;
        let x = r * phi.cos();
        let y = r * phi.sin();
        let z = 10.0 + 5.0 * (phi * 0.5).sin();
        let a = -30.0 + 25.0 * (t * 50.0).sin();
        let c = (phi.to_degrees() + 180.0).rem_euclid(360.0) - 180.0;
        if i % 100 == 0 {
            out.write_all(b"(PASS)\n")?;
        }
        writeln!(
            out,
            "N{} G1 X{x:.4} Y{y:.4} Z{z:.4} A{a:.4} C{c:.4}",
            30 + i
        )?;
    }
    out.write_all(b"M30\n%\n")
}

/// The program of `blocks` moves in memory.
#[allow(dead_code)]
pub fn program(blocks: usize) -> Vec<u8> {
    let mut out = Vec::new();
    write_program(blocks, &mut out).expect("writing to memory");
    out
}

//! The path bound (`Kinematics::path_sag`) against the deviation sampled densely: on every
//! fixture machine with random error models of a real machine's size and ten times it, for
//! random moves from 10 µm to 20 mm and up to 10° of every rotary axis, with both ends
//! compensated (and written to the resolution), the deviation's distance from the chord
//! between its ends never exceeds the bound anywhere along the move. And a program
//! compensated with the default options: every move the bound clears at its written ends
//! stays within the tolerance along its whole length, evaluated densely from the written
//! text.

mod common;

use common::{Lcg, random, random_errors};
use nalgebra::Vector3;
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::path::PathTolerance;
use nccomp::kinematics::{Kinematics, Model, SolveOptions, angle_between};
use nccomp::model::{AxisKind, ErrorModel, Machine, error_file, machine_file};
use std::path::Path;

fn fixture(name: &str) -> Machine {
    machine_file::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures")
            .join(name),
    )
    .unwrap()
}

/// The model scaled by `k` (tables, squareness, location errors).
fn scaled(model: &ErrorModel, k: f64) -> ErrorModel {
    let mut m = model.clone();
    for a in &mut m.axes {
        if let Some(t) = &mut a.motion {
            for v in t.values.iter_mut().flatten() {
                for x in v.iter_mut() {
                    *x *= k;
                }
            }
        }
        a.squareness *= k;
        a.location_shift *= k;
        a.location_tilt *= k;
        a.zero *= k;
    }
    m
}

struct Worst {
    cleared: usize,
    tried: usize,
    /// Largest sampled chord distance over its bound, position and direction.
    ratio: (f64, f64),
}

fn check(machine: &Machine, errors: &ErrorModel, chain: usize, rng: &mut Lcg, worst: &mut Worst) {
    let kin = Kinematics::new(machine, errors, chain).unwrap();
    let n = kin.len();
    let opts = SolveOptions::compensation();
    let length = machine.tool.length;
    for _ in 0..200 {
        let step = [0.01, 0.1, 1.0, 20.0][(rng.next() * 4.0) as usize];
        let turn = [0.0, 0.2, 2.0, 10.0][(rng.next() * 4.0) as usize];
        let mut qa = [0.0; 9];
        let mut qb = [0.0; 9];
        for v in 0..n {
            let rotary = kin.kind(v) == AxisKind::Rotary;
            let axis = &machine.axes[kin.axes()[v]];
            let (lo, hi) = match axis.travel {
                Some([lo, hi]) => (lo, hi),
                None if rotary => (-180.0, 180.0),
                None => (-200.0, 200.0),
            };
            qa[v] = lo + (hi - lo) * rng.next();
            qb[v] = qa[v] + if rotary { rng.sym(turn) } else { rng.sym(step) };
        }
        let round = |x: f64| (x * 1e4).round() / 1e4;
        let sa = kin.compensate(&qa[..n], length, 0, &opts);
        let sb = kin.compensate(&qb[..n], length, 0, &opts);
        let ca: Vec<f64> = sa.q[..n].iter().map(|&x| round(x)).collect();
        let cb = &sb.q[..n];
        worst.tried += 1;
        let Some(sag) = kin.path_sag((&qa[..n], &qb[..n]), (&ca, cb), length) else {
            continue;
        };
        worst.cleared += 1;
        let deviation = |s: f64| {
            let q: Vec<f64> = (0..n).map(|v| qa[v] + (qb[v] - qa[v]) * s).collect();
            let c: Vec<f64> = (0..n).map(|v| ca[v] + (cb[v] - ca[v]) * s).collect();
            let (nom, _) = kin.pose(Model::Nominal, &q, length);
            let (real, _) = kin.pose(Model::Actual, &c, length);
            (real.p - nom.p, real.o - nom.o)
        };
        let (p0, o0) = deviation(0.0);
        let (p1, o1) = deviation(1.0);
        for i in 1..64 {
            let s = i as f64 / 64.0;
            let (p, o) = deviation(s);
            let chord = |a: Vector3<f64>, b: Vector3<f64>| a * (1.0 - s) + b * s;
            // Evaluating the two poses rounds at about 10⁻¹³ mm of a 10³ mm reach.
            let dp = (p - chord(p0, p1)).norm() - 1e-11;
            let dd = (o - chord(o0, o1)).norm() - 1e-14;
            worst.ratio.0 = worst.ratio.0.max(dp / sag.position);
            worst.ratio.1 = worst.ratio.1.max(dd / sag.direction);
            assert!(
                dp <= sag.position && dd <= sag.direction,
                "{}: move {:?} -> {:?} (written {:?} -> {:?}) strays {dp:e} mm / {dd:e} from its chord at s = {s}, bound {sag:?}",
                machine.name.as_deref().unwrap_or("?"),
                &qa[..n],
                &qb[..n],
                ca,
                cb
            );
        }
    }
}

#[test]
fn the_bound_holds_on_every_fixture_machine() {
    let mut rng = Lcg(26);
    let mut worst = Worst {
        cleared: 0,
        tried: 0,
        ratio: (0.0, 0.0),
    };
    for name in [
        "ac_trunnion.machine.toml",
        "bc_trunnion.machine.toml",
        "bc_head_table.machine.toml",
        "head_head.machine.toml",
        "grinder.machine.toml",
        "mill_turn.machine.toml",
    ] {
        let machine = fixture(name);
        for chain in 0..machine.tool_chains.len() {
            for k in [1.0, 10.0] {
                for _ in 0..3 {
                    let errors = scaled(&random_errors(&machine, &mut rng), k);
                    check(&machine, &errors, chain, &mut rng, &mut worst);
                }
            }
        }
    }
    eprintln!(
        "{} of {} moves cleared; largest sampled sag over its bound: {:.3} (position), {:.3} (direction)",
        worst.cleared, worst.tried, worst.ratio.0, worst.ratio.1
    );
    assert!(
        worst.cleared * 4 > worst.tried,
        "the bound clears too few moves to be tested"
    );
}

/// The G1 blocks of a program in the generator's form (`N… G1 X… Y… Z… A… C…`), read here
/// (not by nccomp): each with its N number, or none for a block nccomp inserted.
fn moves(text: &str) -> Vec<(Option<u64>, [f64; 5])> {
    let mut out = Vec::new();
    for line in text.lines().filter(|l| l.contains("G1 ")) {
        let mut n = None;
        let mut q = [f64::NAN; 5];
        for word in line.split_whitespace() {
            let (letter, value) = word.split_at(1);
            match letter {
                "N" => n = value.parse().ok(),
                "X" | "Y" | "Z" | "A" | "C" => {
                    let k = "XYZAC".find(letter).unwrap();
                    q[k] = value.parse().unwrap();
                }
                _ => {}
            }
        }
        out.push((n, q));
    }
    out
}

#[test]
fn moves_the_bound_clears_stay_within_the_tolerance() {
    let machine = fixture("ac_trunnion.machine.toml");
    let errors = error_file::parse(&random::random_errors(), "full.errors.toml", &machine).unwrap();
    let tolerance = PathTolerance::default();
    let comp = Compensator::new(
        &machine,
        &errors,
        Options {
            path: Some(tolerance),
            ..Options::default()
        },
    )
    .unwrap();
    let src = random::random_program(3000);
    let mut out = Vec::new();
    comp.run(&src, "random.nc", &mut out).unwrap();
    let programmed = moves(std::str::from_utf8(&src).unwrap());
    let written = moves(std::str::from_utf8(&out).unwrap());
    let kin = Kinematics::new(&machine, &errors, 0).unwrap();
    let length = machine.tool.length;
    let (mut cleared, mut checked, mut worst) = (0, 0, (0.0f64, 0.0f64));
    // Consecutive written blocks that are two programmed ones: a move nccomp did not split.
    let mut by_n = std::collections::HashMap::new();
    for (n, q) in &programmed {
        by_n.insert(n.unwrap(), *q);
    }
    for pair in written.windows(2) {
        let [(Some(na), ca), (Some(nb), cb)] = pair else {
            continue;
        };
        if nb != &(na + 1) {
            continue;
        }
        let (qa, qb) = (by_n[na], by_n[nb]);
        checked += 1;
        let at = |s: f64| {
            let q: Vec<f64> = (0..5).map(|k| qa[k] + (qb[k] - qa[k]) * s).collect();
            let c: Vec<f64> = (0..5).map(|k| ca[k] + (cb[k] - ca[k]) * s).collect();
            let (nominal, _) = kin.pose(Model::Nominal, &q, length);
            let (real, _) = kin.pose(Model::Actual, &c, length);
            (
                (real.p - nominal.p).norm(),
                angle_between(&real.o, &nominal.o),
            )
        };
        let Some(sag) = kin.path_sag((&qa, &qb), (ca, cb), length) else {
            continue;
        };
        let (p0, d0) = at(0.0);
        let (p1, d1) = at(1.0);
        if p0.max(p1) + sag.position > tolerance.position
            || (d0.max(d1) + sag.direction) * 1.001 > tolerance.direction
        {
            continue;
        }
        cleared += 1;
        for k in 1..32 {
            let (dp, dd) = at(k as f64 / 32.0);
            worst = (worst.0.max(dp), worst.1.max(dd));
            assert!(
                dp <= tolerance.position && dd <= tolerance.direction,
                "N{na} -> N{nb}: {dp} mm, {dd} rad at s = {}",
                k as f64 / 32.0
            );
        }
    }
    eprintln!(
        "{cleared} of {checked} unsplit moves cleared by the bound; along them at most {:.4} µm and {:.3} µrad",
        worst.0 * 1e3,
        worst.1 * 1e6
    );
    assert!(checked > 2900 && cleared * 10 > checked * 8);
}

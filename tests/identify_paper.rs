//! Paper 000's own numbers: its separation formulas, fed with values that its formulas
//! turn into each row's total and quasi-static error, give the dynamic column of its
//! tables 2–3 (which the paper measured, not derived here).

use nalgebra::{Rotation3, Vector3};
use nccomp::identify::separate::{Separation, offset, slope_angle, squareness, straightness, tilt};
use nccomp::identify::simulate::PAPER;

/// The paper rounds to 4 decimals.
const ROUND: f64 = 0.5e-4;

fn columns(sep: &Separation) -> (f64, f64, f64) {
    (sep.total[0], sep.quasi_static[0], sep.dynamic[0])
}

fn check(symbol: &str, got: (f64, f64, f64), total: f64, quasi: f64, dynamic: f64) {
    for (what, g, w) in [
        ("total", got.0, total),
        ("quasi-static", got.1, quasi),
        ("dynamic", got.2, dynamic),
    ] {
        assert!(
            (g - w).abs() < ROUND,
            "{symbol} {what}: {g:.5}, the paper has {w}"
        );
    }
}

#[test]
fn offsets_eqs_16_to_18() {
    // XOC, YOC, XOA, YOA (mm): x0 the nominal centre, x2 the CMM's, x1 the probe's, and
    // F = (x − x0)/cos 10°.
    let cos = 10f64.to_radians().cos();
    for (symbol, _, total, quasi, dynamic) in PAPER.iter().filter(|p| p.0.contains('O')) {
        let x0 = 12.5;
        let x2 = x0 + total * cos;
        let x1 = x2 - quasi * cos;
        let f = |x: f64| vec![offset(x, x0, 10.0)];
        let sep = Separation::new(vec![symbol.to_string()], &f(x0), &f(x1), &f(x2));
        check(symbol, columns(&sep), *total, *quasi, *dynamic);
        // Eq. 18 as printed, (2·x2 − (x0 + x1))/cos 10°, is not the table's dynamic.
        let printed = (2.0 * x2 - (x0 + x1)) / cos;
        assert!((printed - dynamic).abs() > 10.0 * ROUND, "{symbol}");
    }
}

#[test]
fn tilts_eqs_19_to_21_and_25_to_27() {
    // ε_xc, ε_yc, ε_ya, ε_za (degrees): the normals of the fitted circles, n0 nominal, n2
    // the CMM's, n1 the probe's; F = the signed tilt about the row's axis.
    let n0 = Vector3::new(0.0, -(10f64.to_radians().sin()), 10f64.to_radians().cos());
    let about = |symbol: &str| match symbol {
        "eps_xc" => Vector3::x(),
        "eps_yc" | "eps_ya" => Vector3::y(),
        _ => Vector3::z(),
    };
    for (symbol, _, total, quasi, dynamic) in PAPER
        .iter()
        .filter(|p| matches!(p.0, "eps_xc" | "eps_yc" | "eps_ya" | "eps_za"))
    {
        let axis = about(symbol);
        // A tilt of the normal about `axis` needs `axis` across it.
        let axis = (axis - n0 * n0.dot(&axis)).normalize();
        let turn = |deg: f64| Rotation3::new(axis * deg.to_radians()) * n0;
        let (n2, n1) = (turn(*total), turn(total - quasi));
        let f = |n: &Vector3<f64>| vec![tilt(n, &n0).dot(&axis).to_degrees()];
        let sep = Separation::new(vec![symbol.to_string()], &f(&n0), &f(&n1), &f(&n2));
        check(symbol, columns(&sep), *total, *quasi, *dynamic);
        // The paper's unsigned eq. 19 cannot give a negative total such as ε_yc's.
        let unsigned = (n2.dot(&n0).abs() / (n2.norm() * n0.norm()))
            .min(1.0)
            .acos();
        assert!((unsigned.to_degrees() - total.abs()).abs() < ROUND);
    }
    assert!(PAPER.iter().any(|p| p.0 == "eps_yc" && p.2 < 0.0));
}

#[test]
fn slopes_eqs_11_to_15() {
    // ε_yx and ε_zx at X = ±50 (degrees): slopes k of line fits; F = atan(k).
    for (symbol, _, total, quasi, dynamic) in PAPER.iter().filter(|p| p.0.contains("x (X")) {
        let k0 = 0.0;
        let k2 = total.to_radians().tan();
        let k1 = (total - quasi).to_radians().tan();
        let f = |k: f64| vec![slope_angle(k).to_degrees()];
        let sep = Separation::new(vec![symbol.to_string()], &f(k0), &f(k1), &f(k2));
        check(symbol, columns(&sep), *total, *quasi, *dynamic);
    }
}

#[test]
fn squareness_eqs_6_to_10() {
    // S_yx (degrees) from the slopes of an X line (k_yx) and a Y line (k_xy).
    let (_, _, total, quasi, dynamic) = PAPER.iter().find(|p| p.0 == "S_yx").copied().unwrap();
    let f = |k_yx: f64, k_xy: f64| vec![squareness(k_yx, k_xy).to_degrees()];
    let t = |deg: f64| deg.to_radians().tan();
    // Split each angle between the two lines, as a real part would.
    let cmm = f(t(0.6 * total), t(-0.4 * total));
    let probe = f(t(0.6 * (total - quasi)), t(-0.4 * (total - quasi)));
    let sep = Separation::new(vec!["S_yx".into()], &f(0.0, 0.0), &probe, &cmm);
    check("S_yx", columns(&sep), total, quasi, dynamic);
}

#[test]
fn straightness_eqs_1_to_5() {
    // The paper gives straightness only as a figure: its eqs. 1–5 on a trace.
    let cmm = [5.0, 5.002, 5.001, 4.999];
    let probe = [5.0, 5.0015, 5.0005, 5.0];
    let nominal = [5.0; 4];
    let sep = Separation::new(
        vec!["d".into(); 4],
        &straightness(&nominal),
        &straightness(&probe),
        &straightness(&cmm),
    );
    for (i, want) in [0.0, 0.002, 0.001, -0.001].iter().enumerate() {
        assert!((sep.total[i] - want).abs() < 1e-12);
        assert!((sep.dynamic[i] - (probe[i] - probe[0])).abs() < 1e-12);
    }
}

//! The least-squares fits identification is built on: exact points give exact features,
//! noisy points give features within the noise, degenerate sets are refused.

mod common;

use common::Lcg;
use nalgebra::{Point2, Point3, Rotation3, Vector3};
use nccomp::identify::fit::{FitError, circle3, line2, line3, plane};
use proptest::prelude::*;

#[allow(clippy::too_many_arguments)]
fn circle_points(
    centre: Point3<f64>,
    normal: Vector3<f64>,
    radius: f64,
    from_deg: f64,
    span_deg: f64,
    n: usize,
    noise: f64,
    rng: &mut Lcg,
) -> Vec<Point3<f64>> {
    let normal = normal.normalize();
    let helper = if normal.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = normal.cross(&helper).normalize();
    let e2 = normal.cross(&e1);
    (0..n)
        .map(|i| {
            let t = (from_deg + span_deg * i as f64 / (n - 1) as f64).to_radians();
            centre + (e1 * t.cos() + e2 * t.sin()) * radius + rng.vec(noise)
        })
        .collect()
}

#[test]
fn exact_circle_on_a_tilted_plane_far_from_the_origin() {
    let centre = Point3::new(312.5, -141.25, 87.0);
    let normal = Vector3::new(0.0, -10f64.to_radians().sin(), 10f64.to_radians().cos());
    let pts = circle_points(centre, normal, 25.0, 0.0, 360.0, 12, 0.0, &mut Lcg(1));
    let c = circle3(&pts).unwrap();
    assert!((c.centre - centre).norm() < 1e-9, "{}", c.centre);
    assert!((c.normal - normal).norm() < 1e-12 || (c.normal + normal).norm() < 1e-12);
    assert!((c.radius - 25.0).abs() < 1e-9);
    assert!(c.rms < 1e-9);
}

#[test]
fn short_arcs_still_find_the_centre() {
    // 20° of a 40 mm circle, exact: the geometric refinement lands on the true centre.
    let centre = Point3::new(10.0, 20.0, 30.0);
    let pts = circle_points(centre, Vector3::z(), 40.0, 35.0, 20.0, 9, 0.0, &mut Lcg(2));
    let c = circle3(&pts).unwrap();
    assert!((c.centre - centre).norm() < 1e-6, "{}", c.centre);
    assert!((c.radius - 40.0).abs() < 1e-6);
}

#[test]
fn noisy_circle_within_the_noise() {
    let centre = Point3::new(-5.0, 2.0, 50.0);
    let normal = Vector3::new(0.1, -0.05, 1.0);
    let mut worst: f64 = 0.0;
    for seed in 0..20 {
        let pts = circle_points(centre, normal, 25.0, 0.0, 360.0, 36, 0.0005, &mut Lcg(seed));
        let c = circle3(&pts).unwrap();
        worst = worst.max((c.centre - centre).norm());
        assert!((c.radius - 25.0).abs() < 0.0005);
        assert!(
            c.normal.angle(&normal.normalize()) < 1e-4
                || c.normal.angle(&-normal.normalize()) < 1e-4
        );
    }
    // 0.5 µm noise on 36 points: the centre to a fraction of a micron.
    assert!(worst < 0.0005, "{worst}");
}

#[test]
fn lines_and_planes() {
    let mut rng = Lcg(5);
    // A line along X at 0.0062° (paper 000's pitch), points from X = −50 to 50.
    let slope = 0.0062f64.to_radians().tan();
    let pts: Vec<Point2<f64>> = (0..11)
        .map(|i| {
            let x = -50.0 + 10.0 * i as f64;
            Point2::new(x, 3.0 + slope * x)
        })
        .collect();
    let l = line2(&pts).unwrap();
    assert!((l.slope() - slope).abs() < 1e-12);
    assert!((l.angle().to_degrees() - 0.0062).abs() < 1e-10);

    let dir = Vector3::new(1.0, 2.0, -0.5).normalize();
    let pts: Vec<Point3<f64>> = (0..20)
        .map(|i| Point3::new(4.0, 5.0, 6.0) + dir * (i as f64 * 3.0) + rng.vec(1e-4))
        .collect();
    let l = line3(&pts).unwrap();
    assert!(l.direction.angle(&dir) < 1e-5 || l.direction.angle(&-dir) < 1e-5);

    let n = Vector3::new(0.0, -0.173, 0.985).normalize();
    let e1 = n.cross(&Vector3::x()).normalize();
    let e2 = n.cross(&e1);
    let pts: Vec<Point3<f64>> = (0..25)
        .map(|i| {
            let (u, v) = ((i % 5) as f64 * 20.0 - 40.0, (i / 5) as f64 * 20.0 - 40.0);
            Point3::new(0.0, 0.0, 31.0) + e1 * u + e2 * v
        })
        .collect();
    let p = plane(&pts).unwrap();
    assert!((p.normal - n).norm() < 1e-12, "{} vs {}", p.normal, n);
    assert!(p.rms < 1e-9);
}

#[test]
fn degenerate_sets_are_refused() {
    let on_a_line: Vec<Point3<f64>> = (0..6)
        .map(|i| Point3::new(i as f64, 2.0 * i as f64, 0.0))
        .collect();
    assert!(matches!(
        circle3(&on_a_line),
        Err(FitError::Degenerate { .. })
    ));
    assert!(matches!(
        plane(&on_a_line),
        Err(FitError::Degenerate { .. })
    ));
    assert!(matches!(
        circle3(&on_a_line[..2]),
        Err(FitError::TooFewPoints {
            needed: 3,
            got: 2,
            ..
        })
    ));
    assert!(matches!(
        line2(&[Point2::new(1.0, 1.0)]),
        Err(FitError::TooFewPoints { .. })
    ));
    let same = vec![Point2::new(1.0, 1.0); 4];
    assert!(matches!(line2(&same), Err(FitError::Degenerate { .. })));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// A circle fit does not care where the part sits: any rigid motion of exact points
    /// moves the fitted centre and normal with them.
    #[test]
    fn circle_fit_follows_rigid_motions(
        rx in -3.0..3.0f64, ry in -3.0..3.0f64, rz in -3.0..3.0f64,
        tx in -500.0..500.0f64, ty in -500.0..500.0f64, tz in -500.0..500.0f64,
        radius in 5.0..100.0f64, from in 0.0..360.0f64, span in 60.0..360.0f64,
    ) {
        let pts = circle_points(Point3::origin(), Vector3::z(), radius, from, span, 10, 0.0, &mut Lcg(0));
        let rot = Rotation3::new(Vector3::new(rx, ry, rz));
        let t = Vector3::new(tx, ty, tz);
        let moved: Vec<Point3<f64>> = pts.iter().map(|p| rot * p + t).collect();
        let c = circle3(&moved).unwrap();
        prop_assert!((c.centre.coords - t).norm() < 1e-7 * (1.0 + radius));
        prop_assert!((c.radius - radius).abs() < 1e-7 * (1.0 + radius));
        let n = rot * Vector3::z();
        // Parallel either way (the sense is a convention).
        prop_assert!(c.normal.cross(&n).norm() < 1e-9);
    }
}

//! Least-squares fits of lines, planes and circles to measured points.
//!
//! All fits are orthogonal (total least squares): they minimise distances perpendicular to
//! the fitted feature, so they do not depend on how the points lie in the coordinate frame.
//! They centre the points first and work on the covariance, which keeps them well
//! conditioned for points far from the origin (a probe reports machine coordinates).

use nalgebra::{Matrix2, Matrix3, Point2, Point3, Vector2, Vector3};

/// Why a fit could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error("{feature} needs at least {needed} points, got {got}")]
    TooFewPoints {
        feature: &'static str,
        needed: usize,
        got: usize,
    },
    #[error("the points do not determine a {feature}: {why}")]
    Degenerate { feature: &'static str, why: String },
}

/// A line in the plane: a point on it (the centroid of the points) and a unit direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line2 {
    pub point: Point2<f64>,
    pub direction: Vector2<f64>,
    /// Root-mean-square distance of the points from the line.
    pub rms: f64,
}

impl Line2 {
    /// The slope dy/dx (infinite for a vertical line).
    pub fn slope(&self) -> f64 {
        self.direction.y / self.direction.x
    }

    /// The angle of the line to +X, in (−π/2, π/2].
    pub fn angle(&self) -> f64 {
        let a = self.direction.y.atan2(self.direction.x);
        if a > std::f64::consts::FRAC_PI_2 {
            a - std::f64::consts::PI
        } else if a <= -std::f64::consts::FRAC_PI_2 {
            a + std::f64::consts::PI
        } else {
            a
        }
    }
}

/// A line in space: a point on it (the centroid) and a unit direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Line3 {
    pub point: Point3<f64>,
    pub direction: Vector3<f64>,
    pub rms: f64,
}

/// A plane: a point on it (the centroid) and a unit normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    pub point: Point3<f64>,
    pub normal: Vector3<f64>,
    pub rms: f64,
}

/// A circle in space: centre, unit normal of its plane, radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle3 {
    pub centre: Point3<f64>,
    pub normal: Vector3<f64>,
    pub radius: f64,
    /// RMS distance of the points from the circle (in and out of its plane).
    pub rms: f64,
}

fn centroid3(points: &[Point3<f64>]) -> Point3<f64> {
    let sum = points
        .iter()
        .fold(Vector3::zeros(), |acc, p| acc + p.coords);
    Point3::from(sum / points.len() as f64)
}

/// Eigenvalues (ascending) and eigenvectors (as columns, same order) of the scatter matrix
/// of the points about `c`, and the size of the point set (for relative thresholds).
fn scatter3(points: &[Point3<f64>], c: &Point3<f64>) -> ([f64; 3], Matrix3<f64>, f64) {
    let mut m = Matrix3::zeros();
    for p in points {
        let d = p - c;
        m += d * d.transpose();
    }
    let eig = m.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let values = order.map(|i| eig.eigenvalues[i].max(0.0));
    let vectors = Matrix3::from_columns(&order.map(|i| eig.eigenvectors.column(i).into_owned()));
    (values, vectors, values[2])
}

/// Orthogonal line fit in the plane.
pub fn line2(points: &[Point2<f64>]) -> Result<Line2, FitError> {
    if points.len() < 2 {
        return Err(FitError::TooFewPoints {
            feature: "a line",
            needed: 2,
            got: points.len(),
        });
    }
    let n = points.len() as f64;
    let c = Point2::from(points.iter().fold(Vector2::zeros(), |a, p| a + p.coords) / n);
    let mut m = Matrix2::zeros();
    for p in points {
        let d = p - c;
        m += d * d.transpose();
    }
    let eig = m.symmetric_eigen();
    let (big, small) = if eig.eigenvalues[0] >= eig.eigenvalues[1] {
        (0, 1)
    } else {
        (1, 0)
    };
    if eig.eigenvalues[big] <= 0.0 {
        return Err(FitError::Degenerate {
            feature: "line",
            why: "all points coincide".into(),
        });
    }
    let mut direction = eig.eigenvectors.column(big).into_owned().normalize();
    // A stable sense: along +X where possible.
    if direction.x < 0.0 || (direction.x == 0.0 && direction.y < 0.0) {
        direction = -direction;
    }
    Ok(Line2 {
        point: c,
        direction,
        rms: (eig.eigenvalues[small].max(0.0) / n).sqrt(),
    })
}

/// Orthogonal line fit in space.
pub fn line3(points: &[Point3<f64>]) -> Result<Line3, FitError> {
    if points.len() < 2 {
        return Err(FitError::TooFewPoints {
            feature: "a line",
            needed: 2,
            got: points.len(),
        });
    }
    let c = centroid3(points);
    let (values, vectors, size) = scatter3(points, &c);
    if size <= 0.0 {
        return Err(FitError::Degenerate {
            feature: "line",
            why: "all points coincide".into(),
        });
    }
    let mut direction = vectors.column(2).into_owned().normalize();
    // A stable sense: its largest component positive.
    if direction[direction.iamax()] < 0.0 {
        direction = -direction;
    }
    Ok(Line3 {
        point: c,
        direction,
        rms: ((values[0] + values[1]) / points.len() as f64).sqrt(),
    })
}

/// Orthogonal plane fit. The normal points to the side of +Z (or +Y, +X when the plane
/// contains Z) so that repeated fits compare.
pub fn plane(points: &[Point3<f64>]) -> Result<Plane, FitError> {
    if points.len() < 3 {
        return Err(FitError::TooFewPoints {
            feature: "a plane",
            needed: 3,
            got: points.len(),
        });
    }
    let c = centroid3(points);
    let (values, vectors, size) = scatter3(points, &c);
    // The middle spread must be real: points along one line leave the plane undecided.
    if size <= 0.0 || values[1] <= size * 1e-12 {
        return Err(FitError::Degenerate {
            feature: "plane",
            why: "the points lie on one line".into(),
        });
    }
    let mut normal = vectors.column(0).into_owned().normalize();
    let key = if normal.z.abs() > 1e-9 {
        normal.z
    } else if normal.y.abs() > 1e-9 {
        normal.y
    } else {
        normal.x
    };
    if key < 0.0 {
        normal = -normal;
    }
    Ok(Plane {
        point: c,
        normal,
        rms: (values[0] / points.len() as f64).sqrt(),
    })
}

/// Circle fit in space: the plane first, then the circle in that plane (algebraic fit to
/// start, Gauss–Newton on the geometric distances to finish), so a short arc still gives
/// its true centre when the points are exact.
pub fn circle3(points: &[Point3<f64>]) -> Result<Circle3, FitError> {
    if points.len() < 3 {
        return Err(FitError::TooFewPoints {
            feature: "a circle",
            needed: 3,
            got: points.len(),
        });
    }
    let plane = plane(points).map_err(|e| match e {
        FitError::Degenerate { .. } => FitError::Degenerate {
            feature: "circle",
            why: "the points lie on one line".into(),
        },
        other => other,
    })?;
    // In-plane axes.
    let n = plane.normal;
    let helper = if n.x.abs() < 0.6 {
        Vector3::x()
    } else {
        Vector3::y()
    };
    let e1 = n.cross(&helper).normalize();
    let e2 = n.cross(&e1);
    let uv: Vec<Vector2<f64>> = points
        .iter()
        .map(|p| {
            let d = p - plane.point;
            Vector2::new(d.dot(&e1), d.dot(&e2))
        })
        .collect();
    let (centre, radius) = circle2(&uv)?;
    let centre3 = plane.point + e1 * centre.x + e2 * centre.y;
    let rms = (points
        .iter()
        .zip(&uv)
        .map(|(p, q)| {
            let off_plane = (p - plane.point).dot(&n);
            let in_plane = (q - centre).norm() - radius;
            off_plane * off_plane + in_plane * in_plane
        })
        .sum::<f64>()
        / points.len() as f64)
        .sqrt();
    Ok(Circle3 {
        centre: centre3,
        normal: n,
        radius,
        rms,
    })
}

/// Circle fit in the plane (points already centred near the origin): centre and radius.
pub fn circle2(points: &[Vector2<f64>]) -> Result<(Vector2<f64>, f64), FitError> {
    if points.len() < 3 {
        return Err(FitError::TooFewPoints {
            feature: "a circle",
            needed: 3,
            got: points.len(),
        });
    }
    // Algebraic (Kåsa) fit: x² + y² + D x + E y + F = 0, least squares in D, E, F.
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = Vector3::<f64>::zeros();
    for p in points {
        let row = Vector3::new(p.x, p.y, 1.0);
        ata += row * row.transpose();
        atb += row * -(p.x * p.x + p.y * p.y);
    }
    let spread = points.iter().map(|p| p.norm_squared()).fold(0.0, f64::max);
    let sol = ata
        .try_inverse()
        .filter(|inv| inv.iter().all(|v| v.is_finite()))
        .map(|inv| inv * atb)
        .filter(|s| s.iter().all(|v| v.is_finite()))
        .ok_or_else(|| FitError::Degenerate {
            feature: "circle",
            why: "the points lie on one line".into(),
        })?;
    let mut c = Vector2::new(-sol.x / 2.0, -sol.y / 2.0);
    let r2 = c.norm_squared() - sol.z;
    if r2.is_nan() || r2 <= 0.0 || c.norm_squared() > 1e8 * spread.max(1e-300) {
        return Err(FitError::Degenerate {
            feature: "circle",
            why: "the points lie (nearly) on one line".into(),
        });
    }
    let mut r = r2.sqrt();
    // Geometric refinement: minimise Σ (|p − c| − r)².
    for _ in 0..50 {
        let mut jtj = nalgebra::Matrix3::<f64>::zeros();
        let mut jtr = Vector3::<f64>::zeros();
        for p in points {
            let d = p - c;
            let dist = d.norm();
            if dist == 0.0 {
                continue;
            }
            let res = dist - r;
            let grad = Vector3::new(-d.x / dist, -d.y / dist, -1.0);
            jtj += grad * grad.transpose();
            jtr += grad * res;
        }
        let Some(step) = jtj.try_inverse().map(|inv| inv * jtr) else {
            break;
        };
        c -= Vector2::new(step.x, step.y);
        r -= step.z;
        if step.norm() < 1e-13 * (1.0 + r) {
            break;
        }
    }
    if !(r.is_finite() && r > 0.0) {
        return Err(FitError::Degenerate {
            feature: "circle",
            why: "the fit does not converge".into(),
        });
    }
    Ok((c, r))
}

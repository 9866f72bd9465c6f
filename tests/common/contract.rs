//! The contract tests' shared parts (tests/heidenhain.rs, tests/sinumerik_contract.rs): the
//! fixtures' five-axis machines in closed form, written from their machine files' geometry
//! (not nccomp's chains), the tolerances a written block end is held to, and the command
//! line's default options.

use nalgebra::{Rotation3, Vector3};
use nccomp::compensate::Options;
use nccomp::kinematics::Kinematics;
use nccomp::kinematics::path::PathTolerance;
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use std::path::{Path, PathBuf};

/// Block ends in a plane or under TCP: the tip words are rounded to 0.1 µm, so the tip is
/// off by up to half of it on each axis.
pub const END: f64 = 1.0e-4;
/// Block ends in machine axes: the rotary words are rounded too, to 0.0001°, which the
/// linear words take up only to their own rounding.
pub const END_AXES: f64 = 2.5e-4;
/// The tool direction at a block end where the rotary words are written (machine axes,
/// TCP): two rotary words rounded to 0.0001° turn it by up to 1.2 µrad.
pub const END_DIRECTION: f64 = 2.0e-6;
/// A written block is the programmed block's own line when its real tip lands this close
/// to the programmed end (the pieces inserted before it end inside the move).
pub const MATCH: f64 = 5.0e-4;
/// Samples along each written piece of a move.
pub const SAMPLES: usize = 32;
/// Below this tilt (degrees) the tool lies (nearly) along C, which cannot turn it: its
/// direction is not checked there.
pub const SINGULAR_TILT: f64 = 3.0;

pub fn rx(deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::x_axis(), deg.to_radians())
}

pub fn ry(deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::y_axis(), deg.to_radians())
}

pub fn rz(deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), deg.to_radians())
}

pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf()
}

pub fn fixture(name: &str) -> String {
    std::fs::read_to_string(root().join("fixtures").join(name)).unwrap()
}

/// `x` and `y` are the same angle (modulo a turn) within `tol` degrees.
pub fn same_angle(x: f64, y: f64, tol: f64) -> bool {
    let d = (x - y) / 360.0;
    (d - d.round()).abs() * 360.0 <= tol
}

/// The options `nccomp compensate` runs with by default (src/cli/compensate.rs:
/// `--tolerance 0.001`, `--angular-tolerance 10`).
pub fn cli_options() -> Options {
    Options {
        path: Some(PathTolerance {
            position: 0.001,
            direction: 10e-6,
            ..PathTolerance::default()
        }),
        ..Options::default()
    }
}

// ---------------------------------------------------------------------------------------
// The machines in closed form.

/// The three machines of the fixtures. Axis values are [X, Y, Z, tilt, C], the tilt being
/// A or B.
#[derive(Clone, Copy, Debug)]
pub enum Geometry {
    /// AC trunnion (fixtures/ac_trunnion.machine.toml): the table moves in X, Y (directions
    /// -X, -Y), A turns the part about -X through (0, 0, a_z), C about -Z through the
    /// origin; the spindle moves in Z.
    Trunnion { a_z: f64 },
    /// Fork head (fixtures/head_head.machine.toml): the head moves in X, Y, Z, C turns it
    /// about +Z through the origin, A tilts the spindle about +X through (0, 0, pivot).
    HeadHead { pivot: f64 },
    /// B head over a C table (fixtures/bc_head_table.machine.toml): the head moves in X,
    /// Y, Z, B swivels the spindle about +Y through (0, 0, pivot); C turns the part about
    /// -Z through the origin.
    HeadTable { pivot: f64 },
}

pub type Axes = [f64; 5];

pub struct Setup {
    pub geometry: Geometry,
    pub machine: Machine,
    pub errors: ErrorModel,
    /// The tilting axis's letter (A or B).
    pub tilt: char,
    pub tilt_travel: Option<[f64; 2]>,
}

impl Setup {
    pub fn load(machine: &str, errors: &str) -> Setup {
        let dir = root().join("fixtures");
        let machine = machine_file::load(&dir.join(format!("{machine}.machine.toml"))).unwrap();
        let errors =
            error_file::load(&dir.join(format!("{errors}.errors.toml")), &machine).unwrap();
        let axis = |n: &str| machine.axes.iter().find(|a| a.name == n);
        assert!(
            axis("C").unwrap().travel.is_none(),
            "the closed form's C turns without end"
        );
        let (geometry, tilt) = if let Some(b) = axis("B") {
            (Geometry::HeadTable { pivot: b.point.z }, 'B')
        } else if machine.workpiece_chain.is_empty() {
            (
                Geometry::HeadHead {
                    pivot: axis("A").unwrap().point.z,
                },
                'A',
            )
        } else {
            (
                Geometry::Trunnion {
                    a_z: axis("A").unwrap().point.z,
                },
                'A',
            )
        };
        let tilt_travel = axis(&tilt.to_string()).unwrap().travel;
        Setup {
            geometry,
            machine,
            errors,
            tilt,
            tilt_travel,
        }
    }

    /// The tool length beyond the machine file's reference tool.
    pub fn offset(&self, length: f64) -> f64 {
        length - self.machine.tool.length
    }

    /// The tool direction in the part frame at tilt `t` and C `c`.
    pub fn direction(&self, t: f64, c: f64) -> Vector3<f64> {
        match self.geometry {
            Geometry::Trunnion { .. } | Geometry::HeadHead { .. } => rz(c) * rx(t) * Vector3::z(),
            Geometry::HeadTable { .. } => rz(c) * ry(t) * Vector3::z(),
        }
    }

    /// The nominal tip and tool direction in the part frame at `q`.
    pub fn forward(&self, q: Axes, length: f64) -> (Vector3<f64>, Vector3<f64>) {
        let l = self.offset(length);
        let p = match self.geometry {
            Geometry::Trunnion { a_z } => {
                let a = Vector3::new(0.0, 0.0, a_z);
                let w = Vector3::new(q[0], q[1], q[2] - l);
                rz(q[4]) * (a + rx(q[3]) * (w - a))
            }
            Geometry::HeadHead { pivot } => {
                let p = Vector3::new(0.0, 0.0, pivot);
                Vector3::new(q[0], q[1], q[2])
                    + rz(q[4]) * (p + rx(q[3]) * (Vector3::new(0.0, 0.0, -l) - p))
            }
            Geometry::HeadTable { pivot } => {
                let p = Vector3::new(0.0, 0.0, pivot);
                rz(q[4])
                    * (Vector3::new(q[0], q[1], q[2])
                        + p
                        + ry(q[3]) * (Vector3::new(0.0, 0.0, -l) - p))
            }
        };
        (p, self.direction(q[3], q[4]))
    }

    /// The control's linear axes for a part-frame tip with the rotary axes at `t`, `c`.
    pub fn linear_axes(&self, tip: Vector3<f64>, t: f64, c: f64, length: f64) -> Axes {
        let l = self.offset(length);
        let w = match self.geometry {
            Geometry::Trunnion { a_z } => {
                let a = Vector3::new(0.0, 0.0, a_z);
                let w = a + rx(-t) * (rz(-c) * tip - a);
                Vector3::new(w.x, w.y, w.z + l)
            }
            Geometry::HeadHead { pivot } => {
                let p = Vector3::new(0.0, 0.0, pivot);
                tip - rz(c) * (p + rx(t) * (Vector3::new(0.0, 0.0, -l) - p))
            }
            Geometry::HeadTable { pivot } => {
                let p = Vector3::new(0.0, 0.0, pivot);
                rz(-c) * tip - p - ry(t) * (Vector3::new(0.0, 0.0, -l) - p)
            }
        };
        [w.x, w.y, w.z, t, c]
    }

    /// The variables of nccomp's kinematics in its order.
    pub fn vars(&self, kin: &Kinematics, q: Axes) -> Vec<f64> {
        kin.axes()
            .iter()
            .map(|&i| match self.machine.axes[i].name.as_str() {
                "X" => q[0],
                "Y" => q[1],
                "Z" => q[2],
                "C" => q[4],
                name if name.starts_with(self.tilt) => q[3],
                other => panic!("axis {other}"),
            })
            .collect()
    }

    /// The rotary values at which the tool points along the plane's normal `n` with the
    /// tilt at or above 0 (`positive`: Heidenhain's SEQ+, Sinumerik's _DIR +1) or at or
    /// below. The tilt is the master axis on all three machines (the head's axis nearest
    /// the tool, or the table's nearest the bed). C turns without end: the nearest turn to
    /// `c_from`, where it stands.
    pub fn plane_rotaries(&self, n: Vector3<f64>, c_from: f64, positive: bool) -> [f64; 2] {
        let t = n.z.clamp(-1.0, 1.0).acos().to_degrees();
        assert!(
            t > 1e-6,
            "a plane along C (C free, TABLE ROT) is not in these fixtures"
        );
        // (sin t sin c, -sin t cos c, cos t) about X; (sin t cos c, sin t sin c, cos t)
        // about Y.
        let c_plus = match self.tilt {
            'A' => n.x.atan2(-n.y),
            _ => n.y.atan2(n.x),
        }
        .to_degrees();
        let (t, c) = if positive {
            (t, c_plus)
        } else {
            (-t, c_plus + 180.0)
        };
        let c = c + 360.0 * ((c_from - c) / 360.0).round();
        if let Some([lo, hi]) = self.tilt_travel {
            assert!(
                (lo..=hi).contains(&t),
                "{}{t} is outside its travel",
                self.tilt
            );
        }
        [t, c]
    }
}

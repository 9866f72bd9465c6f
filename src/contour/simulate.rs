//! A trace of a simulated machine, to try the analysis on without a machine at hand.
//!
//! The interpolator runs the program's moves at their feed (the tool tip's speed on the
//! part; rapids at the rapid rate of the fastest axis), each move at constant speed, one
//! commanded position per interpolation period. Each axis follows its command as a
//! first-order servo with its own time constant: the following error is speed times
//! time constant, and where the axes' time constants differ the tool leaves the path,
//! which is the classic source of contour error. Readings are taken every sample period
//! with an optional uniform noise and rounded to the encoder resolution.

use super::trace::Trace;
use crate::kinematics::{Kinematics, MAX_AXES, Model};
use crate::model::{AxisKind, Machine};
use crate::program::moves::{NominalMove, Shape};

/// How the simulated machine behaves.
#[derive(Debug, Clone, PartialEq)]
pub struct Servo {
    /// Interpolation period and trace sample period (s).
    pub interpolation: f64,
    pub sample: f64,
    /// Time constant of each axis's servo (s), in the kinematics' variable order.
    pub lag: Vec<f64>,
    /// Rapid rate (mm/min, degrees/min for rotary axes).
    pub rapid: f64,
    /// Feed for moves before the program's first F word (mm/min).
    pub feed: f64,
    /// Amplitude of the uniform reading noise, linear (mm) and rotary (degrees).
    pub noise: (f64, f64),
    /// Encoder resolution the readings are rounded to, linear (mm) and rotary (degrees);
    /// 0 for none.
    pub resolution: (f64, f64),
    /// Seed of the noise.
    pub seed: u64,
    /// Time recorded before the first move and after the last (s).
    pub settle: f64,
}

impl Servo {
    /// A machine like paper 003's: 1 ms interpolation, a 15 ms trace, servo time constants
    /// of a few milliseconds that differ by axis, a 0.1 µm / 0.0001° encoder.
    pub fn paper(axes: usize) -> Self {
        let lags = [
            0.0080, 0.0086, 0.0075, 0.0095, 0.0102, 0.009, 0.009, 0.009, 0.009,
        ];
        Servo {
            interpolation: 0.001,
            sample: 0.015,
            lag: lags[..axes.min(MAX_AXES)].to_vec(),
            rapid: 10_000.0,
            feed: 1000.0,
            noise: (0.0002, 0.0002),
            resolution: (0.0001, 0.0001),
            seed: 3,
            settle: 0.2,
        }
    }
}

/// Run `moves` (for a tool of length `length`) on the simulated machine; the trace has the
/// commanded positions too.
pub fn simulate(
    machine: &Machine,
    kin: &Kinematics,
    moves: &[NominalMove],
    length: f64,
    servo: &Servo,
) -> Trace {
    let n = kin.len();
    let dt = servo.interpolation;
    let every = ((servo.sample / dt).round() as usize).max(1);
    // The commanded positions, tick by tick.
    let mut commanded: Vec<f64> = Vec::new();
    let mut at = [0.0; MAX_AXES];
    let mut leftover = 0.0;
    for mv in moves {
        let Some(start) = mv.start else {
            at = mv.end;
            if commanded.is_empty() {
                let ticks = (servo.settle / dt).ceil() as usize;
                for _ in 0..ticks {
                    commanded.extend_from_slice(&at[..n]);
                }
            }
            continue;
        };
        let duration = duration(kin, mv, &start, length, servo);
        // Ticks fall on multiples of dt; the move's first tick is where the last one left.
        let mut t = dt - leftover;
        while t <= duration {
            let q = mv.at(t / duration, n);
            commanded.extend_from_slice(&q[..n]);
            t += dt;
        }
        leftover = duration - (t - dt);
        at = mv.end;
    }
    let ticks = (servo.settle / dt).ceil() as usize;
    for _ in 0..ticks {
        commanded.extend_from_slice(&at[..n]);
    }
    // The servos, and the readings.
    let alpha: Vec<f64> = (0..n)
        .map(|v| {
            let lag = servo.lag.get(v).copied().unwrap_or(0.0);
            if lag > 0.0 {
                1.0 - (-dt / lag).exp()
            } else {
                1.0
            }
        })
        .collect();
    let mut actual = commanded[..n].to_vec();
    let mut rng = servo.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let mut trace = Trace {
        axes: super::trace::axis_names(machine, kin),
        commanded: Some(Vec::new()),
        ..Trace::default()
    };
    let count = commanded.len() / n;
    for tick in 0..count {
        let cmd = &commanded[tick * n..(tick + 1) * n];
        for ((x, a), c) in actual.iter_mut().zip(&alpha).zip(cmd) {
            *x += a * (c - *x);
        }
        if tick % every != 0 {
            continue;
        }
        trace.time.push(tick as f64 * dt);
        for (v, &x) in actual.iter().enumerate() {
            let linear = kin.kind(v) == AxisKind::Linear;
            let (noise, resolution) = if linear {
                (servo.noise.0, servo.resolution.0)
            } else {
                (servo.noise.1, servo.resolution.1)
            };
            // xorshift64*: uniform in [-1, 1).
            rng ^= rng >> 12;
            rng ^= rng << 25;
            rng ^= rng >> 27;
            let u =
                (rng.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 11) as f64 / (1u64 << 52) as f64 - 1.0;
            trace.actual.push(round(x + noise * u, resolution));
        }
        if let Some(c) = trace.commanded.as_mut() {
            c.extend(cmd.iter().enumerate().map(|(v, &x)| {
                let r = if kin.kind(v) == AxisKind::Linear {
                    servo.resolution.0
                } else {
                    servo.resolution.1
                };
                round(x, r)
            }));
        }
    }
    trace
}

fn round(x: f64, resolution: f64) -> f64 {
    if resolution > 0.0 {
        (x / resolution).round() * resolution
    } else {
        x
    }
}

/// How long the interpolator takes for a move (s).
fn duration(
    kin: &Kinematics,
    mv: &NominalMove,
    start: &[f64; MAX_AXES],
    length: f64,
    servo: &Servo,
) -> f64 {
    let n = kin.len();
    if mv.shape == Shape::Rapid {
        let far = (0..n)
            .map(|v| (mv.end[v] - start[v]).abs())
            .fold(0.0, f64::max);
        return far / (servo.rapid / 60.0);
    }
    // The tip's path on the part, over eight chords.
    let pose = |q: &[f64; MAX_AXES]| kin.pose(Model::Nominal, &q[..n], length).0.p;
    let mut tip = 0.0;
    let mut last = pose(start);
    for k in 1..=8 {
        let next = pose(&mv.at(f64::from(k) / 8.0, n));
        tip += (next - last).norm();
        last = next;
    }
    // A move that only turns the tool runs at the feed in degrees per minute.
    let turn = (0..n)
        .filter(|&v| kin.kind(v) == AxisKind::Rotary)
        .map(|v| (mv.end[v] - start[v]).abs())
        .fold(0.0, f64::max);
    let feed = mv.feed.unwrap_or(servo.feed) / 60.0;
    if tip > 1e-9 { tip / feed } else { turn / feed }
}

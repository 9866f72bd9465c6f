//! What a G2/G3 block's words mean: the circle from the start to the end in the modal plane
//! (G17, G18, G19), its centre given by I/J/K (incremental, or absolute after G90.1) or by a
//! radius R, the other axes in proportion.

use super::INCH;
use super::axes::{Axes, Positions};
use super::{BlockMotion, Modal};
use crate::kinematics::MAX_AXES;
use crate::nc::{Token, TokenKind, Value};
use std::f64::consts::TAU;

/// An arc in axis space: a (possibly spiral) circle in the plane of variables `va`, `vb`,
/// all other variables linear from start to end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArcPath {
    pub va: usize,
    pub vb: usize,
    pub centre: (f64, f64),
    pub r0: f64,
    pub r1: f64,
    pub th0: f64,
    /// Signed sweep (rad): clockwise negative.
    pub sweep: f64,
    pub start: [f64; MAX_AXES],
    pub end: [f64; MAX_AXES],
}

impl ArcPath {
    /// The axis values at fraction `s` of the arc.
    pub fn point(&self, s: f64, n: usize) -> [f64; MAX_AXES] {
        let mut q = [0.0; MAX_AXES];
        for (v, x) in q.iter_mut().enumerate().take(n) {
            *x = self.start[v] + (self.end[v] - self.start[v]) * s;
        }
        let th = self.th0 + self.sweep * s;
        let r = self.r0 + (self.r1 - self.r0) * s;
        q[self.va] = self.centre.0 + r * th.cos();
        q[self.vb] = self.centre.1 + r * th.sin();
        q
    }

    /// The arc from `start` to `end` about `centre`, turning the way `like` turns and by
    /// nearly as much (the same number of turns).
    pub fn through(
        like: &ArcPath,
        centre: (f64, f64),
        start: [f64; MAX_AXES],
        end: [f64; MAX_AXES],
    ) -> ArcPath {
        ArcPath::about(like, centre, start, end, |th0, th1| {
            let sweep = th1 - th0;
            sweep + TAU * ((like.sweep - sweep) / TAU).round()
        })
    }

    /// The arc from `start` to `end` about `centre` in the plane of `like`, its sweep
    /// from the start and end angles by `sweep`.
    fn about(
        like: &ArcPath,
        centre: (f64, f64),
        start: [f64; MAX_AXES],
        end: [f64; MAX_AXES],
        sweep: impl Fn(f64, f64) -> f64,
    ) -> ArcPath {
        let (va, vb) = (like.va, like.vb);
        let th0 = (start[vb] - centre.1).atan2(start[va] - centre.0);
        let th1 = (end[vb] - centre.1).atan2(end[va] - centre.0);
        ArcPath {
            va,
            vb,
            centre,
            r0: ((start[va] - centre.0).powi(2) + (start[vb] - centre.1).powi(2)).sqrt(),
            r1: ((end[va] - centre.0).powi(2) + (end[vb] - centre.1).powi(2)).sqrt(),
            th0,
            sweep: sweep(th0, th1),
            start,
            end,
        }
    }
}

impl ArcPath {
    /// The arc a control runs from `start` to `end` about `centre` in the plane of `like`,
    /// turning the way G2 (`clockwise`) or G3 commands: a sweep in [-2π, 0) for G2, in
    /// (0, 2π] for G3, ends at the same angle making a full circle (as [`circle`]).
    pub fn commanded(
        like: &ArcPath,
        centre: (f64, f64),
        start: [f64; MAX_AXES],
        end: [f64; MAX_AXES],
        clockwise: bool,
    ) -> ArcPath {
        ArcPath::about(like, centre, start, end, |th0, th1| {
            commanded_sweep(th0, th1, clockwise)
        })
    }
}

/// The signed sweep G2 (`clockwise`) or G3 commands from angle `th0` to `th1`: in
/// [-2π, 0) for G2, (0, 2π] for G3; equal angles make a full circle.
pub fn commanded_sweep(th0: f64, th1: f64, clockwise: bool) -> f64 {
    if clockwise {
        let s = -(th0 - th1).rem_euclid(TAU);
        if s == 0.0 { -TAU } else { s }
    } else {
        let s = (th1 - th0).rem_euclid(TAU);
        if s == 0.0 { TAU } else { s }
    }
}

/// The plane's two axes (as program letters, first and second) and the letters of the
/// centre words along them, for modal plane 0 (G17), 1 (G18), 2 (G19).
pub fn plane_letters(plane: u8) -> Option<([u8; 2], [u8; 2])> {
    match plane {
        0 => Some(([b'X', b'Y'], [b'I', b'J'])),
        1 => Some(([b'Z', b'X'], [b'K', b'I'])),
        2 => Some(([b'Y', b'Z'], [b'J', b'K'])),
        _ => None,
    }
}

/// The letter of the axis perpendicular to modal plane 0 (G17), 1 (G18), 2 (G19): a helix's.
pub fn plane_third(plane: u8) -> u8 {
    match plane {
        0 => b'Z',
        1 => b'Y',
        _ => b'X',
    }
}

/// An arc block's end and circle, from `start` to the end its words give (`end`: the
/// start where a word is missing), each as the plane's two coordinates and the third
/// (mm): the centre by I/J/K or R, or a TNC arc's pole (CC); a TNC polar arc's end on
/// its circle at its angle (PA, or IPA from the start, which is also its sweep, turns
/// included), and a helix's height from the start (IZ).
pub fn plane_arc(
    tokens: &[Token],
    motion: &BlockMotion,
    modal: &Modal,
    clockwise: bool,
    start: [f64; 3],
    mut end: [f64; 3],
) -> Result<([f64; 3], Circle), String> {
    let (centre, absolute) = match motion.centre {
        // A TNC arc about its CC.
        Some([a, b]) => (Centre::Offsets(Some(a), Some(b)), true),
        None => {
            let Some((_, centre_letters)) = plane_letters(modal.plane) else {
                return Err("arcs in a U/V/W plane (G17.1, G18.1, G19.1) are not supported".into());
            };
            (
                centre_words(tokens, motion, centre_letters, modal),
                modal.arc_absolute,
            )
        }
    };
    let mut turned = None;
    if let (Some((angle, incremental)), Some([ca, cb])) = (motion.polar, motion.centre) {
        // A TNC polar arc: the end on the circle through the start about CC.
        let (da, db) = (start[0] - ca, start[1] - cb);
        let r = da.hypot(db);
        let th = if incremental {
            turned = Some(angle.to_radians());
            db.atan2(da) + angle.to_radians()
        } else {
            angle.to_radians()
        };
        end[0] = ca + r * th.cos();
        end[1] = cb + r * th.sin();
    }
    if let Some(lead) = motion.lead {
        end[2] = start[2] + lead;
    }
    let mut c = circle(
        (start[0], start[1]),
        (end[0], end[1]),
        clockwise,
        centre,
        absolute,
    )?;
    if let Some(sweep) = turned {
        // IPA is the sweep itself, whole turns and all.
        c.sweep = sweep;
    }
    Ok((end, c))
}

/// A circle in a plane from `(a0, b0)` to `(a1, b1)`: centre, radii at both ends, start
/// angle and signed sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Circle {
    pub centre: (f64, f64),
    pub r0: f64,
    pub r1: f64,
    pub th0: f64,
    pub sweep: f64,
}

/// The centre words of an arc block in mm: the radius R, or the centre offsets along the
/// plane's two axes (I/J/K).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Centre {
    Radius(f64),
    Offsets(Option<f64>, Option<f64>),
}

/// The circle the controller makes of an arc from `start` to `end` (in the plane) with the
/// centre words `centre`; `Err` says why it is no arc.
pub fn circle(
    start: (f64, f64),
    end: (f64, f64),
    clockwise: bool,
    centre: Centre,
    absolute_centre: bool,
) -> Result<Circle, String> {
    let ((a0, b0), (a1, b1)) = (start, end);
    let centre = match centre {
        Centre::Radius(r) => {
            let (dx, dy) = (a1 - a0, b1 - b0);
            let d = (dx * dx + dy * dy).sqrt();
            if d == 0.0 || d > 2.0 * r.abs() + 1e-9 {
                return Err(
                    "with R the end point must differ from the start and lie within 2R of it"
                        .into(),
                );
            }
            let h = (r * r - d * d / 4.0).max(0.0).sqrt();
            // The centre to the left of the chord for a short CCW arc (or long CW).
            let left = clockwise == (r < 0.0);
            let (mx, my) = ((a0 + a1) / 2.0, (b0 + b1) / 2.0);
            let (ux, uy) = (-dy / d, dx / d);
            if left {
                (mx + ux * h, my + uy * h)
            } else {
                (mx - ux * h, my - uy * h)
            }
        }
        Centre::Offsets(None, None) => {
            return Err("it gives neither a centre (I/J/K for its plane) nor a radius (R)".into());
        }
        Centre::Offsets(i, j) => {
            let (off_a, off_b) = (i.unwrap_or(0.0), j.unwrap_or(0.0));
            if absolute_centre {
                (off_a, off_b)
            } else {
                (a0 + off_a, b0 + off_b)
            }
        }
    };
    let r0 = ((a0 - centre.0).powi(2) + (b0 - centre.1).powi(2)).sqrt();
    let r1 = ((a1 - centre.0).powi(2) + (b1 - centre.1).powi(2)).sqrt();
    let on_circle = r0 >= 1e-9 && (r0 - r1).abs() <= 0.002_f64.max(1e-6 * r0);
    if !on_circle {
        return Err(format!(
            "its end is not on its circle (radius {r0:.4} at the start, {r1:.4} at the end)"
        ));
    }
    let th0 = (b0 - centre.1).atan2(a0 - centre.0);
    let th1 = (b1 - centre.1).atan2(a1 - centre.0);
    let sweep = commanded_sweep(th0, th1, clockwise);
    Ok(Circle {
        centre,
        r0,
        r1,
        th0,
        sweep,
    })
}

/// The centre words of an arc block (`motion`'s I/J/K/R) along the plane whose centre
/// letters are `centre_letters`, in mm.
pub fn centre_words(
    tokens: &[Token],
    motion: &BlockMotion,
    centre_letters: [u8; 2],
    modal: &Modal,
) -> Centre {
    let number = |i: usize| match &tokens[i].kind {
        TokenKind::Word(w) => match w.value {
            Value::Number { value, .. } => value,
            _ => 0.0,
        },
        _ => 0.0,
    };
    let mm = |x: f64| if modal.inch { x * INCH } else { x };
    if let Some(ri) = motion.arc_words[3] {
        return Centre::Radius(mm(number(ri)));
    }
    let word = |letter: u8| {
        motion.arc_words[b"IJKR".iter().position(|&l| l == letter).unwrap_or(0)]
            .map(|i| mm(number(i)))
    };
    Centre::Offsets(word(centre_letters[0]), word(centre_letters[1]))
}

/// The arc a G2/G3 block describes from `pos` (its axis words `motion`), in axis values;
/// `Err` says why it cannot be followed. `ignored`: variables whose place does not matter
/// (a lathe's spindle while turning).
pub fn arc_path(
    axes: &Axes,
    tokens: &[Token],
    motion: &BlockMotion,
    clockwise: bool,
    pos: &Positions,
    modal: &Modal,
    ignored: u32,
) -> Result<ArcPath, String> {
    let n = axes.len();
    if pos.unknown & !ignored != 0 {
        return Err(
            "the arc starts where an axis is at a place nccomp does not know (after G28, G30, G53, a machine move code, M19 or a change of tool chain)".into(),
        );
    }
    if modal.diameter && modal.arc_absolute {
        return Err(
            "absolute arc centres (G90.1) in diameter mode (G7) are not supported (program the centre incrementally, G91.1)".into(),
        );
    }
    let Some((plane, _)) = plane_letters(modal.plane) else {
        return Err("arcs in a U/V/W plane (G17.1, G18.1, G19.1) are not supported".into());
    };
    let (Some(va), Some(vb)) = (axes.linear_of(plane[0]), axes.linear_of(plane[1])) else {
        return Err("the machine has no linear axes for this arc plane".into());
    };
    // The arc's start in its plane must be known; other axes the program never set are
    // taken at home (0), as for straight moves, and the summary says so.
    if (pos.programmed & (1 << va)) == 0 || (pos.programmed & (1 << vb)) == 0 {
        return Err("the program has not yet set where the arc starts in its plane".into());
    }
    let start = pos.nominal;
    let mut end = pos.nominal;
    for (v, x) in end.iter_mut().enumerate().take(n) {
        if let Some(i) = motion.axis_words[v]
            && let TokenKind::Word(w) = &tokens[i].kind
            && let Value::Number { value, .. } = w.value
        {
            *x = axes.unit(v, modal).to_mm(value);
        }
    }
    let third = axes.linear_of(plane_third(modal.plane));
    let at = |q: &[f64; MAX_AXES]| [q[va], q[vb], third.map_or(0.0, |v| q[v])];
    let (e, c) = plane_arc(tokens, motion, modal, clockwise, at(&start), at(&end))?;
    end[va] = e[0];
    end[vb] = e[1];
    if let Some(v) = third {
        end[v] = e[2];
    }
    Ok(ArcPath {
        va,
        vb,
        centre: c.centre,
        r0: c.r0,
        r1: c.r1,
        th0: c.th0,
        sweep: c.sweep,
        start,
        end,
    })
}

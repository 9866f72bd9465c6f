//! Heidenhain TNC conversational programs (hyperMILL's style) checked against an
//! independent model of the control: the programs are read here (not by nccomp's reader),
//! `PLANE SPATIAL` is turned into its rotation R = Rz(SPC)·Ry(SPB)·Rx(SPA) about the
//! datum of `CYCL DEF 7`, the rotary axes go where SEQ± puts them (closed form, per
//! machine) at `TURN` or at the `L A+Q120 C+Q122` block after `STAY`, X Y Z under a plane
//! are the tip in the plane's frame and under M128 / FUNCTION TCPM the tip in the part
//! frame, with the rotary words axis angles. The real machine is evaluated with the error
//! model (nccomp's chains, whose nominal form is checked here against closed forms). Every
//! block end of the written program must put the tip where the programmed block puts it on
//! the nominal machine, and the path between (moves at feed in a plane and under TCP) must
//! stay within the path tolerance.
//!
//! Also: the rotary positions nccomp reports for each plane of the hyperMILL programs of
//! `../shared/corpus/cam` (when it is there) against hyperMILL's own comments
//! (`; A-90 C270`), the compensated fixtures pinned as snapshots, and the zero model.

mod common;

use common::contract::*;
use nalgebra::{Rotation3, Vector3};
use nccomp::compensate::{Compensator, Options, Summary};
use nccomp::kinematics::{Kinematics, Model, angle_between};
use nccomp::model::{ErrorModel, error_file, machine_file};
use std::collections::HashMap;

// ---------------------------------------------------------------------------------------
// The programs, read as the control runs them.

/// A working plane: origin (the datum) and rotation in the part frame.
#[derive(Clone, Copy, Debug)]
struct Plane {
    origin: Vector3<f64>,
    r: Rotation3<f64>,
}

impl Plane {
    fn part(&self, w: Vector3<f64>) -> Vector3<f64> {
        self.origin + self.r * w
    }

    fn words(&self, p: Vector3<f64>) -> Vector3<f64> {
        self.r.inverse() * (p - self.origin)
    }
}

/// An arc in a plane's X-Y (words): from `start` to `end` about `centre`, turning by
/// `sweep` (rad, counter-clockwise positive, whole turns included), the radius and Z in
/// proportion (a helix).
#[derive(Clone, Copy, Debug)]
struct Arc {
    plane: Plane,
    start: Vector3<f64>,
    end: Vector3<f64>,
    centre: [f64; 2],
    sweep: f64,
}

impl Arc {
    /// The words at `u` ∈ [0, 1] along the arc.
    fn point(&self, u: f64) -> Vector3<f64> {
        let [cx, cy] = self.centre;
        let (a, b) = (self.start, self.end);
        let (ra, rb) = ((a.x - cx).hypot(a.y - cy), (b.x - cx).hypot(b.y - cy));
        let t = (a.y - cy).atan2(a.x - cx) + self.sweep * u;
        let r = ra + (rb - ra) * u;
        Vector3::new(cx + r * t.cos(), cy + r * t.sin(), a.z + (b.z - a.z) * u)
    }

    /// The distance of part-frame point `p` from the arc: the nearest of 2048 points along
    /// it, refined.
    fn distance(&self, p: Vector3<f64>) -> f64 {
        let at = |u: f64| (self.plane.part(self.point(u)) - p).norm();
        const GRID: usize = 2048;
        let h = 1.0 / GRID as f64;
        let best = (0..=GRID)
            .map(|j| j as f64 * h)
            .min_by(|&a, &b| at(a).total_cmp(&at(b)))
            .unwrap();
        let (mut lo, mut hi) = ((best - h).max(0.0), (best + h).min(1.0));
        let g = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..60 {
            let (x, y) = (hi - g * (hi - lo), lo + g * (hi - lo));
            if at(x) < at(y) {
                hi = y;
            } else {
                lo = x;
            }
        }
        at(0.5 * (lo + hi))
    }
}

/// The sweep from angle `a` to `b` the way DR turns (`clockwise`: DR-): at most a turn, an
/// end at the start's angle a full one.
fn dr_sweep(a: f64, b: f64, clockwise: bool) -> f64 {
    let turn = std::f64::consts::TAU;
    let d = (b - a).rem_euclid(turn);
    let full = d < 1e-9 || d > turn - 1e-9;
    match (clockwise, full) {
        (false, true) => turn,
        (false, false) => d,
        (true, true) => -turn,
        (true, false) => d - turn,
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Machine axes: the words are axis values (X Y Z plus the datum).
    Axes,
    /// In a tilted plane: X Y Z are the tip in the plane's frame, the rotary axes stand.
    Plane,
    /// Under M128 / FUNCTION TCPM: X Y Z the part-frame tip, the rotary words axis angles.
    Tcp,
    /// The control turns the rotary axes to a plane (TURN, or the block after STAY).
    Turn,
}

/// One block that moves, as the control runs it.
#[derive(Clone, Copy, Debug)]
struct Step {
    kind: Kind,
    rapid: bool,
    length: f64,
    /// The control's axis values at the start and the end.
    q0: Axes,
    q1: Axes,
    /// Under TCP: the part-frame tip at the start and the end (the rotary values are in
    /// q0, q1).
    tip0: Vector3<f64>,
    tip1: Vector3<f64>,
    /// Every axis has been set by the program (or the control's turn) at its end: where
    /// it stands is known.
    known: bool,
    /// The block calls a drilling cycle (`M99`, `CYCL CALL`): the hole it drills. The
    /// step then ends where the cycle leaves the tool (Q203 + max(Q200, Q204)).
    hole: Option<Hole>,
    /// An arc in the plane (C, CR, CP): the words along it.
    arc: Option<Arc>,
}

/// A machining cycle's definition (`CYCL DEF 200` … and its `~` lines): its number and
/// the parameters that place its motion (the feeds are not followed).
#[derive(Clone, Copy, Debug, Default)]
struct Cycle {
    number: u32,
    q200: Option<f64>,
    q201: Option<f64>,
    q202: Option<f64>,
    q203: Option<f64>,
    q204: Option<f64>,
    q208: Option<f64>,
    q210: Option<f64>,
    q211: Option<f64>,
    q214: Option<f64>,
    q223: Option<f64>,
    q239: Option<f64>,
    q335: Option<f64>,
}

impl Cycle {
    /// Set-up clearance, depth, surface and 2nd set-up clearance.
    fn levels(&self) -> [f64; 4] {
        let get = |v: Option<f64>, name: &str| v.unwrap_or_else(|| panic!("no {name}"));
        [
            get(self.q200, "Q200"),
            get(self.q201, "Q201"),
            get(self.q203, "Q203"),
            get(self.q204, "Q204"),
        ]
    }

    /// Where its motion reaches around the axis, as the control's manuals describe it:
    /// the radius and how far below the depth (mm); (0, 0) for a cycle that goes down the
    /// axis and back.
    fn around(&self) -> (f64, f64) {
        match self.number {
            // Bore milling within its nominal diameter; thread milling within the
            // thread's, its approach helix reaching below the thread's depth.
            208 => (self.q335.unwrap() / 2.0, 0.0),
            262 => (self.q335.unwrap() / 2.0, 2.0 * self.q239.unwrap().abs()),
            // A circular pocket within its diameter.
            252 => (self.q223.unwrap() / 2.0, 0.0),
            // Boring: off the wall by a fraction of a millimetre at the bottom.
            202 if self.q214.unwrap() != 0.0 => (1.0, 0.0),
            _ => (0.0, 0.0),
        }
    }

    /// The moves of a drilling cycle along the hole's axis after the call's positioning,
    /// as the TNC's cycle descriptions give them: each a level along the tool axis (above
    /// the surface Q203) and whether at FMAX, or a dwell (seconds).
    fn motion(&self) -> Vec<Motion> {
        let [q200, q201, q203, q204] = self.levels();
        let (top, end) = (q203 + q200, q203 + q200.max(q204));
        let mut moves = vec![Motion::To(top, true)];
        let dwell = |q: Option<f64>, moves: &mut Vec<Motion>| {
            if let Some(t) = q.filter(|&t| t > 0.0) {
                moves.push(Motion::Dwell(t));
            }
        };
        match self.number {
            200 => {
                // Pecks of Q202, each from the set-up clearance above the depth reached,
                // back to the set-up clearance and a dwell there between them.
                let peck = self.q202.unwrap();
                let mut reached = 0.0f64;
                loop {
                    let next = (reached + peck).min(-q201);
                    moves.push(Motion::To(q203 - next, false));
                    if next >= -q201 {
                        break;
                    }
                    moves.push(Motion::To(top, true));
                    dwell(self.q210, &mut moves);
                    moves.push(Motion::To(q203 - next + q200, true));
                    reached = next;
                }
                dwell(self.q211, &mut moves);
                moves.push(Motion::To(end, true));
            }
            201 => {
                // Out at the retraction feed to the set-up clearance, then at FMAX.
                moves.push(Motion::To(q203 + q201, false));
                dwell(self.q211, &mut moves);
                moves.push(Motion::To(top, false));
                if end > top {
                    moves.push(Motion::To(end, true));
                }
            }
            240 => {
                moves.push(Motion::To(q203 + q201, false));
                dwell(self.q211, &mut moves);
                moves.push(Motion::To(end, true));
            }
            n => panic!("cycle {n} is not written out in these fixtures"),
        }
        moves
    }
}

/// A move of a cycle along its axis: to a level (at FMAX or not), or a dwell.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Motion {
    To(f64, bool),
    Dwell(f64),
}

/// A hole a cycle call drills, in the plane's frame (in machine axes: the axis words
/// less the datum): at X, Y (the tip's when the call starts) with the definition in
/// force, the rotary axes standing and the tool length.
#[derive(Clone, Copy, Debug)]
struct Hole {
    plane: Option<Plane>,
    datum: Vector3<f64>,
    xy: [f64; 2],
    /// Where the tool stood along the hole's axis when the call positioned it.
    start: f64,
    cycle: Cycle,
    rotary: [f64; 2],
    length: f64,
}

impl Hole {
    /// The control's axis values for the tip at offset (dx, dy) from the hole's centre at
    /// `level` along its axis.
    fn at(&self, setup: &Setup, d: [f64; 2], level: f64) -> Axes {
        let w = Vector3::new(self.xy[0] + d[0], self.xy[1] + d[1], level);
        match self.plane {
            Some(plane) => {
                setup.linear_axes(plane.part(w), self.rotary[0], self.rotary[1], self.length)
            }
            None => {
                let q = self.datum + w;
                [q.x, q.y, q.z, self.rotary[0], self.rotary[1]]
            }
        }
    }

    /// The direction of the hole's axis in the part frame.
    fn axis(&self, setup: &Setup) -> Vector3<f64> {
        let a = setup.forward(self.at(setup, [0.0; 2], 0.0), self.length).0;
        let b = setup.forward(self.at(setup, [0.0; 2], 1.0), self.length).0;
        (b - a).normalize()
    }
}

/// A line of the program: its text without the block number, and what it does.
#[derive(Clone, Debug)]
struct Rec {
    /// The line's number in the file (the control runs a label's lines where it is
    /// called).
    line: usize,
    /// The line lies after the program's end: it runs only where a call runs it.
    after_end: bool,
    text: String,
    step: Option<Step>,
    /// The line is a PLANE SPATIAL.
    is_plane: bool,
    /// The line is (part of) a drilling cycle's definition.
    is_cycle: bool,
}

/// The control's state.
struct Control<'s> {
    setup: &'s Setup,
    q: Axes,
    length: f64,
    datum: Vector3<f64>,
    plane: Option<Plane>,
    /// Angles of a PLANE … STAY waiting for the `L A+Q120 C+Q122` block.
    pending: Option<[f64; 2]>,
    tcp: bool,
    /// Under TCP: the programmed part-frame tip (words are modal).
    tip: Vector3<f64>,
    ended: bool,
    /// Bit k: axis k (X Y Z tilt C) has been set.
    known: u8,
    /// Each label's lines (number, text), up to the next label.
    labels: HashMap<String, Vec<(usize, String)>>,
    /// A jump (`FN 9`–`FN 12`) the line just run takes: to this label.
    jump: Option<String>,
    /// Q parameters set with `FN 0`.
    params: HashMap<String, f64>,
    /// The drilling cycle defined last (its `~` lines fill it in).
    cycle: Option<Cycle>,
    /// The circle centre of the last `CC` (X, Y).
    pole: Option<[f64; 2]>,
}

/// Split a TNC line into its block number and the rest.
fn split_number(line: &str) -> (Option<u64>, &str) {
    let line = line.trim_end_matches('\r');
    let digits = line.bytes().take_while(u8::is_ascii_digit).count();
    if digits > 0 && line[digits..].starts_with(' ') {
        (line[..digits].parse().ok(), &line[digits + 1..])
    } else {
        (None, line)
    }
}

/// The statement of a line: its words without the comment (empty for a comment line).
fn statement(rest: &str) -> Vec<&str> {
    let body = rest.split(';').next().unwrap();
    if body.trim_start().starts_with('*') {
        return Vec::new();
    }
    body.split_whitespace().collect()
}

/// A word's letter and value text (`X-55` → ('X', "-55"), `A+Q120` → ('A', "+Q120")).
fn letter(word: &str) -> (char, &str) {
    let c = word.chars().next().unwrap();
    (c, &word[1..])
}

impl<'s> Control<'s> {
    fn new(setup: &'s Setup, program: &str) -> Self {
        // The labels after the program end: their bodies up to LBL 0.
        let mut labels = HashMap::new();
        let mut current: Option<(String, Vec<(usize, String)>)> = None;
        for (i, line) in program.lines().enumerate() {
            let words = statement(split_number(line).1);
            if words.first() == Some(&"LBL") {
                if let Some((name, body)) = current.take() {
                    labels.insert(name, body);
                }
                if words[1] != "0" {
                    current = Some((words[1].trim_matches('"').to_string(), Vec::new()));
                }
            } else if let Some((_, body)) = current.as_mut() {
                body.push((i + 1, line.to_string()));
            }
        }
        Control {
            setup,
            q: [0.0; 5],
            length: setup.machine.tool.length,
            datum: Vector3::zeros(),
            plane: None,
            pending: None,
            tcp: false,
            tip: Vector3::zeros(),
            ended: false,
            known: 0,
            labels,
            jump: None,
            params: HashMap::new(),
            cycle: None,
            pole: None,
        }
    }

    /// Run one line; the step it makes, if it moves.
    fn line(&mut self, words: &[&str], is_plane: &mut bool) -> Option<Step> {
        if words.is_empty() || self.ended {
            return None;
        }
        match words[0] {
            "BEGIN" | "END" | "BLK" => None,
            "TOOL" => {
                if words[1] == "CALL" {
                    assert!(!self.tcp && self.plane.is_none());
                    let n: u32 = words[2].parse().unwrap();
                    self.length = self.setup.machine.tool.lengths[&n];
                    for w in &words[3..] {
                        if let Some(dl) = w.strip_prefix("DL") {
                            self.length += dl.parse::<f64>().unwrap();
                        }
                    }
                }
                None
            }
            "FN" if words[1] != "0:" && !words[1].starts_with("0:") => {
                // FN 9–12: IF a OP b GOTO LBL n, on constants.
                let value = |w: &str| -> f64 {
                    let (sign, w) = match w.strip_prefix('-') {
                        Some(rest) => (-1.0, rest),
                        None => (1.0, w.trim_start_matches('+')),
                    };
                    sign * match w.strip_prefix('Q') {
                        Some(_) => self.params[w],
                        None => w.parse::<f64>().unwrap(),
                    }
                };
                assert_eq!((words[2], words[6], words[7]), ("IF", "GOTO", "LBL"));
                let (a, b) = (value(words[3]), value(words[5]));
                let taken = match (words[1], words[4]) {
                    ("9:", "EQU") => a == b,
                    ("10:", "NE") => a != b,
                    ("11:", "GT") => a > b,
                    ("12:", "LT") => a < b,
                    other => panic!("FN {other:?}"),
                };
                if taken {
                    self.jump = Some(words[8].trim_matches('"').to_string());
                }
                None
            }
            "FN" => {
                // Feed rates (FQ1): a constant assigned, nothing moved.
                let text: String = words[1..].concat();
                let (name, value) = text.strip_prefix("0:").unwrap().split_once('=').unwrap();
                self.params
                    .insert(name.to_string(), value.parse::<f64>().unwrap());
                None
            }
            "CALL" => panic!("a call is run by `run`"),
            "CYCL" if words[1] == "CALL" => {
                assert_eq!(words.len(), 2, "CYCL CALL POS/PAT is not read here");
                let q0 = self.q;
                Some(self.drill(Step {
                    kind: Kind::Plane,
                    rapid: true,
                    length: self.length,
                    q0,
                    q1: self.q,
                    tip0: Vector3::zeros(),
                    tip1: Vector3::zeros(),
                    known: self.known == 0b11111,
                    hole: None,
                    arc: None,
                }))
            }
            "CYCL" => {
                assert_eq!(words[1], "DEF");
                match words[2] {
                    // The dwell acts where it stands: it moves nothing and is never called.
                    "7.0" | "9.0" | "9.1" => {}
                    n if n.parse::<u32>().is_ok_and(
                        |n| matches!(n, 200..=209 | 240 | 241 | 251..=253 | 262..=265),
                    ) =>
                    {
                        self.cycle = Some(Cycle {
                            number: n.parse().unwrap(),
                            ..Cycle::default()
                        });
                    }
                    "7.1" | "7.2" | "7.3" => {
                        let (c, value) = letter(words[3]);
                        let k = (c as u8 - b'X') as usize;
                        let value: f64 = value.parse().unwrap();
                        match self.plane.as_mut() {
                            // In a tilted plane the shift is along the plane's axes; these
                            // programs only reset it there.
                            Some(p) => {
                                assert_eq!(value, 0.0, "a datum shift in a tilted plane");
                                let mut d = p.r.inverse() * p.origin;
                                d[k] = 0.0;
                                p.origin = p.r * d;
                                self.datum = p.origin;
                            }
                            None => self.datum[k] = value,
                        }
                    }
                    other => panic!("CYCL DEF {other}"),
                }
                None
            }
            "PLANE" => {
                assert!(!self.tcp);
                self.pending = None;
                if words[1] == "RESET" {
                    assert!(words.contains(&"STAY"));
                    self.plane = None;
                    return None;
                }
                assert_eq!(words[1], "SPATIAL");
                *is_plane = true;
                let angle = |prefix: &str| -> f64 {
                    words[2..]
                        .iter()
                        .find_map(|w| w.strip_prefix(prefix))
                        .unwrap()
                        .parse()
                        .unwrap()
                };
                let (a, b, c) = (angle("SPA"), angle("SPB"), angle("SPC"));
                let plane = Plane {
                    origin: self.datum,
                    r: rz(c) * ry(b) * rx(a),
                };
                let positive = if words.contains(&"SEQ+") {
                    true
                } else {
                    assert!(words.contains(&"SEQ-"), "SEQ+ or SEQ- in these programs");
                    false
                };
                let angles = self
                    .setup
                    .plane_rotaries(plane.r * Vector3::z(), self.q[4], positive);
                self.plane = Some(plane);
                if words.contains(&"TURN") {
                    Some(self.turn(angles))
                } else {
                    assert!(words.contains(&"STAY"));
                    self.pending = Some(angles);
                    None
                }
            }
            "FUNCTION" => {
                match (words[1], words[2]) {
                    ("TCPM", _) => {
                        assert_eq!(words[2..], ["F", "TCP", "AXIS", "POS", "PATHCTRL", "AXIS"]);
                        assert!(self.plane.is_none());
                        self.tcp_on();
                    }
                    ("RESET", "TCPM") => self.tcp = false,
                    other => panic!("FUNCTION {other:?}"),
                }
                None
            }
            "L" => self.straight(&words[1..]),
            "CC" => {
                let mut c = [None; 2];
                for w in &words[1..] {
                    let (letter, value) = letter(w);
                    let k = match letter {
                        'X' => 0,
                        'Y' => 1,
                        other => panic!("CC with {other}: poles in X-Y only here"),
                    };
                    c[k] = Some(value.parse::<f64>().unwrap());
                }
                self.pole = Some([c[0].unwrap(), c[1].unwrap()]);
                None
            }
            "C" | "CR" | "CP" => Some(self.arc(words[0], &words[1..])),
            "LBL" => None,
            w if w.starts_with('Q') && w.contains('=') => {
                // A `~` line of a cycle's definition.
                assert_eq!(words.len(), 1, "`{}`", words.join(" "));
                let (name, value) = w.split_once('=').unwrap();
                let value = match value.strip_prefix('Q') {
                    Some(_) => *self
                        .params
                        .get(value)
                        .unwrap_or_else(|| panic!("{value} is not set")),
                    None => value.parse().unwrap(),
                };
                let cycle = self.cycle.as_mut().expect("a Q line outside a definition");
                let slot = match name {
                    "Q200" => &mut cycle.q200,
                    "Q201" => &mut cycle.q201,
                    "Q202" => &mut cycle.q202,
                    "Q203" => &mut cycle.q203,
                    "Q204" => &mut cycle.q204,
                    "Q208" => &mut cycle.q208,
                    "Q210" => &mut cycle.q210,
                    "Q211" => &mut cycle.q211,
                    "Q214" => &mut cycle.q214,
                    "Q223" => &mut cycle.q223,
                    "Q239" => &mut cycle.q239,
                    "Q335" => &mut cycle.q335,
                    _ => return None,
                };
                *slot = Some(value);
                None
            }
            w if w.starts_with('M') => {
                for w in words {
                    self.m(w);
                }
                None
            }
            other => panic!("`{other}` is not read here"),
        }
    }

    fn tcp_on(&mut self) {
        self.tcp = true;
        self.tip = self.setup.forward(self.q, self.length).0 - self.datum;
    }

    fn m(&mut self, word: &str) {
        match word {
            "M3" | "M5" | "M8" | "M9" | "M126" | "M127" => {}
            "M128" => self.tcp_on(),
            "M129" => self.tcp = false,
            "M30" | "M2" => self.ended = true,
            other => panic!("{other} is not read here"),
        }
    }

    /// The cycle called at the end of `step` (which positioned X, Y at the current
    /// height): down the plane's Z (in machine axes, Z) to the bottom and back to Q203 +
    /// max(Q200, Q204), where the tool then stands.
    fn drill(&mut self, mut step: Step) -> Step {
        assert!(!self.tcp, "a cycle call under TCP");
        let cycle = self.cycle.expect("a cycle call without a definition");
        let [q200, _, q203, q204] = cycle.levels();
        let w = match self.plane {
            Some(plane) => plane.words(self.setup.forward(self.q, self.length).0),
            None => Vector3::new(self.q[0], self.q[1], self.q[2]) - self.datum,
        };
        let hole = Hole {
            plane: self.plane,
            datum: self.datum,
            xy: [w.x, w.y],
            start: w.z,
            cycle,
            rotary: [self.q[3], self.q[4]],
            length: self.length,
        };
        self.q = hole.at(self.setup, [0.0; 2], q203 + q200.max(q204));
        step.q1 = self.q;
        step.hole = Some(hole);
        step
    }

    fn turn(&mut self, [t, c]: [f64; 2]) -> Step {
        let q0 = self.q;
        self.q[3] = t;
        self.q[4] = c;
        self.known |= 0b11000;
        Step {
            kind: Kind::Turn,
            rapid: true,
            length: self.length,
            q0,
            q1: self.q,
            tip0: Vector3::zeros(),
            tip1: Vector3::zeros(),
            known: self.known == 0b11111,
            hole: None,
            arc: None,
        }
    }

    /// `C X… Y… [Z…] DR±` about the pole, `CR X… Y… R± DR±`, `CP PA…|IPA… [IZ…|Z…] DR±`
    /// about the pole: an arc in the plane's X-Y (words), Z in proportion.
    fn arc(&mut self, kind: &str, words: &[&str]) -> Step {
        // Under TCP the words are the tip on the part, from the datum; the rotary axes
        // stand.
        let plane = match self.plane {
            Some(plane) => {
                assert!(!self.tcp);
                plane
            }
            None => {
                assert!(self.tcp, "arcs in a tilted plane or under TCP only here");
                Plane {
                    origin: self.datum,
                    r: Rotation3::identity(),
                }
            }
        };
        assert!(self.pending.is_none());
        let q0 = self.q;
        let start = if self.tcp {
            self.tip
        } else {
            plane.words(self.setup.forward(self.q, self.length).0)
        };
        let mut end = start;
        let (mut clockwise, mut radius, mut polar, mut lead) = (None, None, None, None);
        for w in words {
            match *w {
                "DR+" => clockwise = Some(false),
                "DR-" => clockwise = Some(true),
                "R0" => {}
                _ if w.starts_with('F') => {}
                _ if w.starts_with("IPA") => polar = Some((w[3..].parse::<f64>().unwrap(), true)),
                _ if w.starts_with("PA") => polar = Some((w[2..].parse::<f64>().unwrap(), false)),
                _ if w.starts_with("IZ") => lead = Some(w[2..].parse::<f64>().unwrap()),
                _ if w.starts_with('R') && kind == "CR" => {
                    radius = Some(w[1..].parse::<f64>().unwrap())
                }
                _ => {
                    let (c, value) = letter(w);
                    let k = "XYZ".find(c).unwrap_or_else(|| panic!("`{w}` in an arc"));
                    end[k] = value.parse().unwrap();
                }
            }
        }
        let clockwise = clockwise.expect("DR+ or DR-");
        let centre = match kind {
            "CR" => {
                // R > 0: at most half a turn (the centre right of the chord for DR-).
                let r = radius.expect("CR's R");
                let d = (end - start).xy();
                let left = nalgebra::Vector2::new(-d.y, d.x).normalize();
                let h = (r * r - d.norm_squared() / 4.0).max(0.0).sqrt();
                let side = if clockwise == (r > 0.0) { -1.0 } else { 1.0 };
                let c = (start.xy() + end.xy()) / 2.0 + left * (side * h);
                [c.x, c.y]
            }
            _ => self.pole.expect("a pole before C and CP"),
        };
        let angle = |w: Vector3<f64>| (w.y - centre[1]).atan2(w.x - centre[0]);
        let sweep = match polar {
            Some((ipa, true)) => {
                assert_eq!(ipa < 0.0, clockwise, "IPA's sign is DR's");
                ipa.to_radians()
            }
            Some((pa, false)) => dr_sweep(angle(start), pa.to_radians(), clockwise),
            None => dr_sweep(angle(start), angle(end), clockwise),
        };
        if polar.is_some() {
            let r = (start.x - centre[0]).hypot(start.y - centre[1]);
            let t = angle(start) + sweep;
            end.x = centre[0] + r * t.cos();
            end.y = centre[1] + r * t.sin();
        }
        if let Some(dz) = lead {
            end.z = start.z + dz;
        }
        self.q = self
            .setup
            .linear_axes(plane.part(end), self.q[3], self.q[4], self.length);
        let (kind, tip0, tip1) = if self.tcp {
            self.tip = end;
            (Kind::Tcp, plane.part(start), plane.part(end))
        } else {
            (Kind::Plane, Vector3::zeros(), Vector3::zeros())
        };
        Step {
            kind,
            rapid: false,
            length: self.length,
            q0,
            q1: self.q,
            tip0,
            tip1,
            known: self.known == 0b11111,
            hole: None,
            arc: Some(Arc {
                plane,
                start,
                end,
                centre,
                sweep,
            }),
        }
    }

    fn straight(&mut self, words: &[&str]) -> Option<Step> {
        let mut axes: Vec<(char, f64)> = Vec::new();
        let mut plane_angles = false;
        let mut rapid = false;
        let mut call = false;
        let mut k = 0;
        while k < words.len() {
            let w = words[k];
            k += 1;
            match w {
                "R0" => continue,
                "FMAX" => rapid = true,
                "F" if words.get(k) == Some(&"MAX") => {
                    rapid = true;
                    k += 1;
                }
                _ if w.starts_with('F') => {}
                "M99" => call = true,
                _ if w.starts_with('M') => self.m(w),
                _ => {
                    let (c, value) = letter(w);
                    assert!("XYZABC".contains(c), "`{w}`");
                    if let Some(q) = value.strip_prefix("+Q") {
                        let expected = match c {
                            'A' => "120",
                            'B' => "121",
                            _ => "122",
                        };
                        assert_eq!(q, expected, "`{w}`");
                        plane_angles = true;
                    } else {
                        axes.push((c, value.parse().unwrap()));
                    }
                }
            }
        }
        if plane_angles {
            assert!(axes.is_empty());
            let angles = self
                .pending
                .take()
                .expect("PLANE … STAY before the Q120 block");
            return Some(self.turn(angles));
        }
        if axes.is_empty() {
            assert!(!call, "M99 without X, Y is not in these fixtures");
            return None;
        }
        let q0 = self.q;
        let index = |c: char| match c {
            'X' => 0,
            'Y' => 1,
            'Z' => 2,
            'C' => 4,
            _ => {
                assert_eq!(c, self.setup.tilt, "a rotary word of another machine");
                3
            }
        };
        for &(c, _) in &axes {
            self.known |= 1 << index(c);
        }
        if self.tcp || self.plane.is_some() {
            // Under a plane or TCP the words X Y Z give the whole tip, if they are all
            // there.
            if ['X', 'Y', 'Z']
                .iter()
                .all(|c| axes.iter().any(|(a, _)| a == c))
            {
                self.known |= 0b111;
            }
        }
        let known = self.known == 0b11111;
        let kind = if self.tcp {
            assert!(self.plane.is_none());
            let tip0 = self.tip;
            for &(c, v) in &axes {
                match index(c) {
                    k @ 0..=2 => self.tip[k] = v,
                    k => self.q[k] = v,
                }
            }
            self.q =
                self.setup
                    .linear_axes(self.datum + self.tip, self.q[3], self.q[4], self.length);
            return Some(Step {
                kind: Kind::Tcp,
                rapid,
                length: self.length,
                q0,
                q1: self.q,
                tip0: self.datum + tip0,
                tip1: self.datum + self.tip,
                known,
                hole: None,
                arc: None,
            });
        } else if let Some(plane) = self.plane {
            assert!(self.pending.is_none(), "a move before the STAY block");
            let mut w = plane.words(self.setup.forward(self.q, self.length).0);
            for &(c, v) in &axes {
                let k = index(c);
                assert!(k < 3, "rotary words under a plane");
                w[k] = v;
            }
            self.q = self
                .setup
                .linear_axes(plane.part(w), self.q[3], self.q[4], self.length);
            Kind::Plane
        } else {
            for &(c, v) in &axes {
                let k = index(c);
                self.q[k] = if k < 3 { v + self.datum[k] } else { v };
            }
            Kind::Axes
        };
        let step = Step {
            kind,
            rapid,
            length: self.length,
            q0,
            q1: self.q,
            tip0: Vector3::zeros(),
            tip1: Vector3::zeros(),
            known,
            hole: None,
            arc: None,
        };
        Some(if call { self.drill(step) } else { step })
    }
}

/// Run a program as the control does: every line, with the step it makes, in the order
/// the control runs them: a `CALL LBL` runs the label's lines (up to the next label) where
/// it stands, a jump taken in a label goes on with the label it names, a jump taken in
/// the main program skips the lines up to its label. The lines after the program's end
/// follow, marked.
fn run(setup: &Setup, program: &str) -> Vec<Rec> {
    let mut control = Control::new(setup, program);
    let mut recs = Vec::new();
    let mut skip: Option<String> = None;
    for (i, line) in program.lines().enumerate() {
        let words = statement(split_number(line).1);
        if let Some(target) = &skip {
            if words.first() == Some(&"LBL") && words[1].trim_matches('"') == target {
                skip = None;
            }
            recs.push(rec(i + 1, line, None, false, &words, false));
            continue;
        }
        let after_end = control.ended;
        run_line(&mut control, i + 1, line, after_end, &mut recs);
        if let Some(target) = control.jump.take() {
            skip = Some(target);
        }
    }
    recs
}

fn rec(
    line: usize,
    text: &str,
    step: Option<Step>,
    is_plane: bool,
    words: &[&str],
    after_end: bool,
) -> Rec {
    let is_cycle = (words.len() > 2 && words[..2] == ["CYCL", "DEF"] && words[2].starts_with('2'))
        || words
            .first()
            .is_some_and(|w| w.starts_with('Q') && w.contains('='));
    Rec {
        line,
        after_end,
        text: split_number(text).1.to_string(),
        step,
        is_plane,
        is_cycle,
    }
}

/// Run one line (a call: the label's lines after it).
fn run_line(
    control: &mut Control<'_>,
    number: usize,
    line: &str,
    after_end: bool,
    recs: &mut Vec<Rec>,
) {
    let words = statement(split_number(line).1);
    if words.first() == Some(&"CALL") && !after_end && !control.ended {
        assert_eq!(words[1], "LBL");
        recs.push(rec(number, line, None, false, &words, after_end));
        let mut label = words[2].trim_matches('"').to_string();
        let mut k = 0;
        loop {
            let body = control.labels[&label].clone();
            let Some((n, l)) = body.get(k) else {
                break;
            };
            k += 1;
            run_line(control, *n, l, false, recs);
            if let Some(target) = control.jump.take() {
                label = target;
                k = 0;
            }
        }
        return;
    }
    let mut is_plane = false;
    let step = control.line(&words, &mut is_plane);
    recs.push(rec(number, line, step, is_plane, &words, after_end));
}

// ---------------------------------------------------------------------------------------
// The contract, evaluated.

fn from_segment(p: Vector3<f64>, a: Vector3<f64>, b: Vector3<f64>) -> f64 {
    let d = b - a;
    let s = ((p - a).dot(&d) / d.norm_squared().max(1e-30)).clamp(0.0, 1.0);
    (p - (a + d * s)).norm()
}

fn lerp<const N: usize>(a: &[f64; N], b: &[f64; N], u: f64) -> [f64; N] {
    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * u)
}

/// What the evaluation measured.
#[derive(Debug, Default)]
struct Figures {
    /// Block ends checked, and the largest tip distance (mm) in planes and under TCP, and
    /// in machine axes.
    ends: usize,
    end: f64,
    end_axes: f64,
    /// The largest tool direction error (rad) at block ends whose rotary words are written
    /// (machine axes and TCP, away from C's singular pose).
    end_direction: f64,
    /// The largest tip distance from the programmed path (mm) sampled along the written
    /// moves at feed, and the most by which one exceeded the tolerance plus its floor.
    path: f64,
    path_excess: f64,
    /// Under TCP: the largest direction error along the path (rad), and its excess.
    path_direction: f64,
    path_direction_excess: f64,
    /// Blocks inserted, and moves split; blocks inserted for arcs.
    inserted: usize,
    split: usize,
    arc_inserted: usize,
    /// Holes drilled (cycle calls), the largest distance (mm) of the real tip at a hole's
    /// bottom from the programmed bottom, and at its set-up clearance from the programmed
    /// hole's axis point there; the definitions inserted before calls (copies with
    /// another Q203).
    holes: usize,
    hole_bottom: f64,
    hole_clearance: f64,
    definitions: usize,
    /// Holes written out as L moves, and the blocks among them that give back the
    /// program's feed.
    written_out: usize,
    feeds_given_back: usize,
    /// Holes of cycles that move around their axis, the largest distance of the real tip
    /// off the programmed hole's axis sampled over their reach (mm), and the largest
    /// change of the error there from the axis's at the same depth.
    around: usize,
    around_lateral: f64,
    around_change: f64,
    /// Arcs kept as arcs (and the poles inserted before them), and arcs replaced by
    /// pieces.
    arcs_kept: usize,
    poles: usize,
    arcs: usize,
    /// Where an assertion would fail: the first few.
    faults: Vec<String>,
}

impl Figures {
    fn fault(&mut self, text: String) {
        if self.faults.len() < 8 {
            self.faults.push(text);
        }
    }
}

/// The written program against the programmed one. Line by line when they have the same
/// lines (the program as programmed, to show what compensation removes); otherwise a
/// programmed move's own written line is the first that ends where it does, and the moves
/// before it are the pieces nccomp inserted.
fn evaluate(setup: &Setup, programmed: &str, written: &str) -> Figures {
    let line_by_line = programmed.lines().count() == written.lines().count();
    let kin = Kinematics::new(&setup.machine, &setup.errors, 0).unwrap();
    let tol = cli_options().path.unwrap();
    let actual = |q: Axes, length: f64| kin.pose(Model::Actual, &setup.vars(&kin, q), length).0;
    let nominal = run(setup, programmed);
    let real = run(setup, written);
    let mut f = Figures::default();
    let mut k = 0;
    for rec in &nominal {
        if rec.after_end {
            // Labels, run where they are called.
            break;
        }
        let i = rec.line - 1;
        let Some(step) = rec.step.filter(|s| s.kind != Kind::Turn) else {
            // Lines that move nothing, and the control's turns, are written unchanged (a
            // call may name a copy of its label).
            if !(rec.text.starts_with("CALL LBL ") && real[k].text.starts_with("CALL LBL ")) {
                assert_eq!(real[k].text, rec.text, "line {} is written changed", i + 1);
            }
            if let (Some(a), Some(b)) = (rec.step, real[k].step) {
                assert!(
                    (3..5).all(|j| (a.q1[j] - b.q1[j]).abs() < 1e-9),
                    "line {}: the control turns the rotary axes elsewhere",
                    i + 1
                );
            }
            k += 1;
            continue;
        };
        if !step.known {
            // Where an axis the program has not set stands is not known: nccomp keeps
            // it, and the tip is not where the words alone say.
            let w = real[k].step.expect("a written move");
            assert!(step.rapid && w.kind == step.kind, "line {}", i + 1);
            k += 1;
            continue;
        }
        let (target, target_o) = setup.forward(step.q1, step.length);
        // The written pieces of this move, then its own line.
        let mut pieces: Vec<Step> = Vec::new();
        loop {
            let w = real
                .get(k)
                .unwrap_or_else(|| panic!("line {} is missing from the output", i + 1));
            k += 1;
            if step.arc.is_some() && w.step.is_none() && w.text.starts_with("CC ") {
                // A pole inserted before a kept arc: the control takes it as the centre.
                f.poles += 1;
                continue;
            }
            if step.hole.is_some() && w.step.is_none() && w.is_cycle {
                // A copy of the definition inserted before the call: the control takes
                // it as the definition in force.
                if w.text.trim_start().starts_with("CYCL DEF") {
                    f.definitions += 1;
                }
                continue;
            }
            let s = w.step.unwrap_or_else(|| {
                panic!(
                    "line {}: the output has `{}` where the program moves",
                    i + 1,
                    w.text
                )
            });
            assert_eq!(s.kind, step.kind, "line {}: {}", i + 1, w.text);
            pieces.push(s);
            if step.hole.is_some() {
                // The call is written as one block, where the cycle ends; or, written out
                // as L moves, this is its positioning.
                break;
            }
            if line_by_line || (actual(s.q1, s.length).p - target).norm() <= MATCH {
                break;
            }
            assert!(
                !step.rapid && pieces.len() < 2000,
                "line {}: no written block ends where it does (or a rapid was split): `{}` ends {:.3} µm off",
                i + 1,
                w.text,
                (actual(s.q1, s.length).p - target).norm() * 1e3
            );
        }
        if step.arc.is_some() {
            if pieces.last().unwrap().arc.is_some() {
                assert_eq!(pieces.len(), 1, "line {}: an arc kept after pieces", i + 1);
                f.arcs_kept += 1;
            } else {
                assert!(pieces.iter().all(|p| p.arc.is_none()), "line {}", i + 1);
                f.arcs += 1;
                f.arc_inserted += pieces.len() - 1;
            }
        } else if pieces.len() > 1 {
            f.inserted += pieces.len() - 1;
            f.split += 1;
        }
        if let Some(nominal_hole) = step.hole {
            let last = *pieces.last().unwrap();
            match last.hole {
                Some(written_hole) => {
                    called_hole(setup, &kin, &nominal_hole, &written_hole, i + 1, &mut f);
                }
                None => {
                    written_out_hole(
                        setup,
                        &kin,
                        &nominal_hole,
                        &last,
                        &real,
                        &mut k,
                        i + 1,
                        &mut f,
                    );
                }
            }
            continue;
        }
        // The block end.
        let last = pieces.last().unwrap();
        let real_end = actual(last.q1, last.length);
        let off = (real_end.p - target).norm();
        f.ends += 1;
        let bound = if step.kind == Kind::Axes {
            f.end_axes = f.end_axes.max(off);
            END_AXES
        } else {
            f.end = f.end.max(off);
            END
        };
        if off > bound {
            f.fault(format!(
                "line {}: the block end is {:.3} µm off",
                i + 1,
                off * 1e3
            ));
        }
        if step.kind != Kind::Plane && step.q1[3].abs() > SINGULAR_TILT {
            let d = angle_between(&real_end.o, &target_o);
            f.end_direction = f.end_direction.max(d);
            if d > END_DIRECTION {
                f.fault(format!(
                    "line {}: the tool direction at the block end is {:.2} µrad off",
                    i + 1,
                    d * 1e6
                ));
            }
        }
        if step.rapid {
            continue;
        }
        // The path of the move at feed.
        match step.kind {
            // (An arc under TCP as one in a plane: its pieces are straight in the tip with
            // the rotary axes standing, so straight in the axes too.)
            _ if step.kind == Kind::Plane || step.arc.is_some() => {
                let a = setup.forward(step.q0, step.length).0;
                let b = target;
                for (j, piece) in pieces.iter().enumerate() {
                    // The programmed path: the line, or the arc; the written piece as the
                    // control runs it: straight (the axes in proportion), or on its arc.
                    let dev = |q: Axes| {
                        let p = actual(q, piece.length).p;
                        match &step.arc {
                            Some(arc) => arc.distance(p),
                            None => from_segment(p, a, b),
                        }
                    };
                    let along = |u: f64| match &piece.arc {
                        Some(w) => setup.linear_axes(
                            w.plane.part(w.point(u)),
                            piece.q1[3],
                            piece.q1[4],
                            piece.length,
                        ),
                        None => lerp(&piece.q0, &piece.q1, u),
                    };
                    // What the block's own ends are off (judged there) carries into
                    // its first and last piece; the ends between pieces are on the
                    // path within the tolerance like any point of it.
                    let floor = if j == 0 { dev(piece.q0) } else { 0.0 }
                        + if j + 1 == pieces.len() {
                            dev(piece.q1)
                        } else {
                            0.0
                        };
                    for m in 0..=SAMPLES {
                        let d = dev(along(m as f64 / SAMPLES as f64));
                        f.path = f.path.max(d);
                        let excess = d - (tol.position + floor);
                        f.path_excess = f.path_excess.max(excess);
                        if excess > 0.0 {
                            f.fault(format!(
                                "line {}: the path strays {:.3} µm (floor {:.3} µm)",
                                i + 1,
                                d * 1e3,
                                floor * 1e3
                            ));
                        }
                    }
                }
            }
            Kind::Tcp => {
                // The programmed path: the tip on its line, the rotary axes in
                // proportion; a written piece's place on it is where its real tip lies.
                let (n0, n1) = (step.tip0, step.tip1);
                let d = n1 - n0;
                let (r0, r1) = ([step.q0[3], step.q0[4]], [step.q1[3], step.q1[4]]);
                // (A move that only turns the tool: by its rotary values.)
                let place = |s: &Step| -> f64 {
                    if d.norm() > 1e-6 {
                        let p = actual(s.q1, s.length).p;
                        ((p - n0).dot(&d) / d.norm_squared()).clamp(0.0, 1.0)
                    } else {
                        let dr = [r1[0] - r0[0], r1[1] - r0[1]];
                        let w = [s.q1[3] - r0[0], s.q1[4] - r0[1]];
                        ((w[0] * dr[0] + w[1] * dr[1]) / (dr[0] * dr[0] + dr[1] * dr[1]))
                            .clamp(0.0, 1.0)
                    }
                };
                let at = |s: f64| {
                    let r = lerp(&r0, &r1, s);
                    (n0 + d * s, setup.direction(r[0], r[1]), r[0])
                };
                let mut s0 = 0.0;
                for (j, piece) in pieces.iter().enumerate() {
                    let s1 = if j + 1 == pieces.len() {
                        1.0
                    } else {
                        place(piece)
                    };
                    let real_at = |u: f64| {
                        let tip = piece.tip0 + (piece.tip1 - piece.tip0) * u;
                        let r = lerp(&[piece.q0[3], piece.q0[4]], &[piece.q1[3], piece.q1[4]], u);
                        actual(
                            setup.linear_axes(tip, r[0], r[1], piece.length),
                            piece.length,
                        )
                    };
                    let dev = |u: f64| {
                        let (p, o, t) = at(s0 + (s1 - s0) * u);
                        let real = real_at(u);
                        let dd = if t.abs() > SINGULAR_TILT {
                            angle_between(&real.o, &o)
                        } else {
                            0.0
                        };
                        ((real.p - p).norm(), dd)
                    };
                    // The block's own ends carry into its first and last piece; the
                    // ends between pieces are held to the tolerance like the path.
                    let (p0, d0) = if j == 0 { dev(0.0) } else { (0.0, 0.0) };
                    let (p1, d1) = if j + 1 == pieces.len() {
                        dev(1.0)
                    } else {
                        (0.0, 0.0)
                    };
                    let (floor, floor_d) = (p0 + p1, d0 + d1);
                    for m in 0..=SAMPLES {
                        let (dp, dd) = dev(m as f64 / SAMPLES as f64);
                        f.path = f.path.max(dp);
                        f.path_direction = f.path_direction.max(dd);
                        let excess = dp - (tol.position + floor);
                        let excess_d = dd - (tol.direction + floor_d);
                        f.path_excess = f.path_excess.max(excess);
                        f.path_direction_excess = f.path_direction_excess.max(excess_d);
                        if excess > 0.0 || excess_d > 0.0 {
                            f.fault(format!(
                                "line {}: the path strays {:.3} µm, {:.2} µrad (floor {:.3} µm, {:.2} µrad)",
                                i + 1,
                                dp * 1e3,
                                dd * 1e6,
                                floor * 1e3,
                                floor_d * 1e6
                            ));
                        }
                    }
                    s0 = s1;
                }
            }
            Kind::Axes | Kind::Turn | Kind::Plane => {
                // (Moves in a plane are judged above.)
                panic!(
                    "line {}: a feed move in machine axes is not in these fixtures",
                    i + 1
                )
            }
        }
    }
    assert!(
        real[k..].iter().all(|r| r.after_end),
        "the output has lines after the program's"
    );
    f
}

/// What rounding the words to the machine's resolution (0.1 µm) can add at a block end,
/// (√3/2 + 1/4) × the resolution: the floor the verification gate and the hole's axis
/// check allow beyond the tolerance.
const ROUNDING: f64 = 1.116e-4;

/// A hole written as a cycle call: the real tip at its bottom (the written X, Y and the
/// surface coordinate of the definition the control holds), and its axis at the set-up
/// clearance, against the programmed hole. A cycle that moves around its axis is sampled
/// over the disk of its reach at every depth: the real tip off the nominal hole's axis
/// there (along the axis, in the wall of a bore, it is not judged) and the change of the
/// error the motion around the axis adds. The positioning (FMAX) is not checked, nor where
/// the cycle leaves the tool.
fn called_hole(
    setup: &Setup,
    kin: &Kinematics,
    nominal: &Hole,
    written: &Hole,
    line: usize,
    f: &mut Figures,
) {
    let tol = cli_options().path.unwrap();
    let actual = |q: Axes| {
        kin.pose(Model::Actual, &setup.vars(kin, q), written.length)
            .0
            .p
    };
    let meant =
        |d: [f64; 2], level: f64| setup.forward(nominal.at(setup, d, level), nominal.length).0;
    let real = |d: [f64; 2], level: f64| actual(written.at(setup, d, level));
    let [q200, q201, q203, _] = nominal.cycle.levels();
    let [w200, w201, w203, _] = written.cycle.levels();
    assert_eq!((q200, q201), (w200, w201), "line {line}");
    let bottom = (real([0.0; 2], w203 + w201) - meant([0.0; 2], q203 + q201)).norm();
    let clearance = (real([0.0; 2], w203 + w200) - meant([0.0; 2], q203 + q200)).norm();
    f.holes += 1;
    f.hole_bottom = f.hole_bottom.max(bottom);
    f.hole_clearance = f.hole_clearance.max(clearance);
    if bottom > END {
        f.fault(format!(
            "line {line}: the hole's bottom is {:.3} µm off",
            bottom * 1e3
        ));
    }
    if clearance > tol.position {
        f.fault(format!(
            "line {line}: the hole's axis at the set-up clearance is {:.3} µm off",
            clearance * 1e3
        ));
    }
    let (radius, below) = nominal.cycle.around();
    if radius == 0.0 {
        return;
    }
    f.around += 1;
    let axis = nominal.axis(setup);
    let levels = 24;
    for j in 0..=levels {
        let s = j as f64 / levels as f64;
        let depth = (q201 - below) + s * (q200 - q201 + below);
        let (n0, r0) = (meant([0.0; 2], q203 + depth), real([0.0; 2], w203 + depth));
        for ring in [0.25, 0.5, 0.75, 1.0] {
            for a in 0..48 {
                let t = (a as f64 / 48.0) * std::f64::consts::TAU;
                let d = [ring * radius * t.cos(), ring * radius * t.sin()];
                let (n, r) = (meant(d, q203 + depth), real(d, w203 + depth));
                let dev = r - n;
                let lateral = (dev - axis * dev.dot(&axis)).norm();
                let change = ((r - r0) - (n - n0)).norm();
                f.around_lateral = f.around_lateral.max(lateral);
                f.around_change = f.around_change.max(change);
                if lateral > tol.position + ROUNDING {
                    f.fault(format!(
                        "line {line}: {:.4} mm from the hole's axis, {:.3} µm off it",
                        ring * radius,
                        lateral * 1e3
                    ));
                }
            }
        }
    }
}

/// A hole written out as L moves: the call's positioning without M99 (`positioning`, its
/// written step), then the cycle's moves as the control's manuals describe them
/// ([`Cycle::motion`]): each an L block at FMAX or at feed whose real end lies on the
/// programmed hole's axis at its level, a move at feed staying within the tolerance of the
/// programmed one between them (pieces inserted where it needs them), each dwell a
/// `CYCL DEF 9` with its seconds; and a last block that stays where the tool stands (it
/// gives back the feed the program had), where there is one. `k`: the written line after
/// the positioning, moved past the hole.
#[allow(clippy::too_many_arguments)]
fn written_out_hole(
    setup: &Setup,
    kin: &Kinematics,
    hole: &Hole,
    positioning: &Step,
    real: &[Rec],
    k: &mut usize,
    line: usize,
    f: &mut Figures,
) {
    let tol = cli_options().path.unwrap();
    let actual = |q: Axes| {
        kin.pose(Model::Actual, &setup.vars(kin, q), hole.length)
            .0
            .p
    };
    let meant = |level: f64| {
        setup
            .forward(hole.at(setup, [0.0; 2], level), hole.length)
            .0
    };
    let [q200, q201, q203, _] = hole.cycle.levels();
    assert!(!positioning.rapid || positioning.kind != Kind::Turn);
    let off = (actual(positioning.q1) - meant(hole.start)).norm();
    f.ends += 1;
    f.end = f.end.max(off);
    if off > END {
        f.fault(format!(
            "line {line}: the hole's positioning ends {:.3} µm off",
            off * 1e3
        ));
    }
    let mut from = hole.start;
    for m in hole.cycle.motion() {
        match m {
            Motion::Dwell(seconds) => {
                let a = &real[*k].text;
                let b = &real[*k + 1].text;
                assert!(
                    a.starts_with("CYCL DEF 9.0") && b.starts_with("CYCL DEF 9.1"),
                    "line {line}: expected a dwell, found `{a}` `{b}`"
                );
                let written: f64 = b.split_whitespace().last().unwrap().parse().unwrap();
                assert_eq!(written, seconds, "line {line}: `{b}`");
                *k += 2;
            }
            Motion::To(level, rapid) => {
                let (a, b) = (meant(from), meant(level));
                let mut count = 0;
                loop {
                    let w = real
                        .get(*k)
                        .unwrap_or_else(|| panic!("line {line}: the hole's moves end early"));
                    *k += 1;
                    let s = w.step.unwrap_or_else(|| {
                        panic!("line {line}: `{}` where the hole moves", w.text)
                    });
                    assert_eq!(s.rapid, rapid, "line {line}: `{}`", w.text);
                    count += 1;
                    let end = actual(s.q1);
                    if !rapid {
                        let dev = |q: Axes| from_segment(actual(q), a, b);
                        let floor = dev(s.q0) + dev(s.q1);
                        for j in 0..=SAMPLES {
                            let d = dev(lerp(&s.q0, &s.q1, j as f64 / SAMPLES as f64));
                            f.path = f.path.max(d);
                            f.path_excess = f.path_excess.max(d - (tol.position + floor));
                            if d > tol.position + floor {
                                f.fault(format!(
                                    "line {line}: `{}` strays {:.3} µm from the hole's axis",
                                    w.text,
                                    d * 1e3
                                ));
                            }
                        }
                    }
                    if (end - b).norm() <= MATCH {
                        let off = (end - b).norm();
                        f.ends += 1;
                        f.end = f.end.max(off);
                        if off > END {
                            f.fault(format!(
                                "line {line}: `{}` ends {:.3} µm off the hole's axis point",
                                w.text,
                                off * 1e3
                            ));
                        }
                        if level == q203 + q201 {
                            f.hole_bottom = f.hole_bottom.max(off);
                        }
                        if level == q203 + q200 {
                            f.hole_clearance = f.hole_clearance.max(off);
                        }
                        break;
                    }
                    assert!(
                        !rapid && count < 2000,
                        "line {line}: `{}` ends {:.3} µm off the hole's axis point",
                        w.text,
                        (end - b).norm() * 1e3
                    );
                }
                if count > 1 {
                    f.inserted += count - 1;
                    f.split += 1;
                }
                from = level;
            }
        }
    }
    // The program's feed given back: a block at feed that moves nothing.
    if let Some(s) = real.get(*k).and_then(|w| w.step)
        && !s.rapid
        && (actual(s.q1) - actual(s.q0)).norm() < 1e-9
    {
        *k += 1;
        f.feeds_given_back += 1;
    }
    f.holes += 1;
    f.written_out += 1;
}

/// The block numbers of a TNC program run on by one from the first.
fn assert_consecutive(name: &str, program: &str) {
    let mut expected: Option<u64> = None;
    for (i, line) in program.lines().enumerate() {
        let (number, rest) = split_number(line);
        let Some(n) = number else {
            // Only a cycle's continued lines go without a number.
            assert!(
                rest.starts_with(' ') || rest.is_empty(),
                "{name}:{}: no block number: {line}",
                i + 1
            );
            continue;
        };
        if let Some(e) = expected {
            assert_eq!(n, e, "{name}:{}: block numbers jump: {line}", i + 1);
        }
        expected = Some(n + 1);
    }
}

/// The comments hyperMILL writes before a PLANE: `; A-90 C270`, `; B180 C270`.
fn angle_comment(rest: &str) -> Option<Vec<(char, f64)>> {
    let text = rest.trim().strip_prefix(';')?;
    let mut angles = Vec::new();
    for w in text.split_whitespace() {
        let (c, value) = letter(w);
        if !"ABC".contains(c) {
            return None;
        }
        angles.push((c, value.parse().ok()?));
    }
    (angles.len() >= 2).then_some(angles)
}

/// A comment line that only separates (`; -------`).
fn is_separator(rest: &str) -> bool {
    rest.trim()
        .strip_prefix(';')
        .is_some_and(|t| t.chars().all(|c| c == '-' || c.is_whitespace()))
}

/// Each `PLANE SPATIAL` of a program with the angles hyperMILL's comment gives for it:
/// the nearest comment line before it, within 3 lines, the separators and the datum shift
/// (`CYCL DEF 7.x`, which hyperMILL writes between comment and PLANE) not counted; a
/// statement in between, or a comment of another form, gives none. (1-based line, angles.)
fn commented_planes(program: &str) -> Vec<(usize, Vec<(char, f64)>)> {
    let lines: Vec<&str> = program.lines().map(|l| split_number(l).1).collect();
    let mut found = Vec::new();
    for (i, rest) in lines.iter().enumerate() {
        if !rest.trim_start().starts_with("PLANE SPATIAL") {
            continue;
        }
        let mut counted = 0;
        for before in lines[..i].iter().rev() {
            let t = before.trim_start();
            if is_separator(before) || t.starts_with("CYCL DEF 7.") {
                continue;
            }
            counted += 1;
            if counted > 3 || !(t.starts_with(';') || t.starts_with('*')) {
                break;
            }
            if let Some(angles) = angle_comment(before) {
                found.push((i + 1, angles));
            }
            break;
        }
    }
    found
}

/// The rotary positions nccomp reports for the PLANE at `line`: its entry at that line
/// (TURN) or the first after it (the STAY positioning block), before the next PLANE.
fn reported_for(summary: &Summary, program: &str, line: usize) -> Option<Vec<(String, f64)>> {
    let next_plane = program
        .lines()
        .enumerate()
        .skip(line)
        .find(|(_, l)| split_number(l).1.trim_start().starts_with("PLANE"))
        .map_or(usize::MAX, |(i, _)| i + 1);
    summary
        .plane_positions
        .iter()
        .find(|(l, _)| *l >= line && *l < next_plane)
        .map(|(_, axes)| axes.clone())
}

/// Where `reported` differs from the comment's axes at its angles (modulo a turn).
fn angle_faults(what: &str, comment: &[(char, f64)], reported: &[(String, f64)]) -> Vec<String> {
    if comment.len() != reported.len() {
        return vec![format!("{what}: comment {comment:?}, nccomp {reported:?}")];
    }
    let mut faults = Vec::new();
    for (c, angle) in comment {
        match reported.iter().find(|(name, _)| name.starts_with(*c)) {
            None => faults.push(format!("{what}: nccomp turns no axis {c}: {reported:?}")),
            Some((_, value)) if !same_angle(*value, *angle, 1e-6) => faults.push(format!(
                "{what}: the comment says {c}{angle}, nccomp turns it to {value}"
            )),
            Some(_) => {}
        }
    }
    faults
}

/// `reported` holds exactly the comment's axes at its angles (modulo a turn).
fn assert_angles(what: &str, comment: &[(char, f64)], reported: &[(String, f64)]) {
    let faults = angle_faults(what, comment, reported);
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

// ---------------------------------------------------------------------------------------
// The tests.

#[test]
fn plane_angles_match_hypermill_comments() {
    let Some(cam) = common::skip::corpus_path("cam") else {
        return;
    };
    let mut checked = 0;
    let mut faults = Vec::new();
    for (program, machine, errors) in [
        ("hm_dmu85_W5270NS01061A6.h", "dmu85_ac", "dmu85_ac"),
        ("hm_dmu100p_W5270NS01001B3.h", "dmu100p_bc", "bc_head_table"),
        ("hm_trimill_W5269NS01002A1.h", "trimill_bc", "bc_head_table"),
    ] {
        let path = cam.join(program);
        assert!(path.is_file(), "{program} is not in the corpus");
        // Latin-1 comments: read bytes, look at them lossily.
        let src = std::fs::read(&path).unwrap();
        let text = String::from_utf8_lossy(&src).into_owned();
        let dir = root().join("fixtures/corpus");
        let m = machine_file::load(&dir.join(format!("{machine}.machine.toml"))).unwrap();
        let e = error_file::load(&dir.join(format!("{errors}.errors.toml")), &m).unwrap();
        let options = Options {
            max_errors: usize::MAX,
            ..cli_options()
        };
        let comp = Compensator::new(&m, &e, options).unwrap();
        let mut out = Vec::new();
        // Refused elsewhere (drilling cycles) perhaps: the planes are reported anyway.
        let (summary, refused) = comp.run_all(&src, program, &mut out);
        for d in &refused {
            eprintln!("{program}: refused: {d}");
        }
        for (line, angles) in commented_planes(&text) {
            let what = format!("{program}:{line}");
            let reported = reported_for(&summary, &text, line).unwrap_or_else(|| {
                panic!(
                    "{what}: nccomp reports no rotary positions for this PLANE: {:?}",
                    summary.plane_positions
                )
            });
            eprintln!("{what}: the comment {angles:?}, nccomp's {reported:?}");
            faults.extend(angle_faults(&what, &angles, &reported));
            checked += 1;
        }
    }
    assert!(
        checked >= 2,
        "only {checked} commented PLANE statements checked"
    );
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

/// A fixture: program, machine file, error file.
const FIXTURES: [(&str, &str, &str); 9] = [
    ("tnc_ac_trunnion.h", "ac_trunnion", "ac_trunnion"),
    ("tnc_bc_head_table.h", "bc_head_table", "bc_head_table"),
    ("tnc_head_head.h", "head_head", "head_head"),
    // Deep holes in tilted planes, written out as L moves (the paper's AC trunnion leans
    // the tool by about 140 µrad in them).
    ("tnc_ac_trunnion_holes.h", "ac_trunnion", "ac_trunnion"),
    // Bore and thread milling, boring with a disengaging move, a circular pocket,
    // reaming and single-lip deep-hole drilling.
    (
        "tnc_bc_head_table_cycles.h",
        "bc_head_table",
        "bc_head_table",
    ),
    // C, CR and CP arcs in tilted planes, helices.
    ("tnc_ac_trunnion_arcs.h", "ac_trunnion", "ac_trunnion"),
    // Labels that move (one called twice in one state, one once), a label that jumps
    // with FN 9 on a constant, jumps in the main program.
    (
        "tnc_bc_head_table_labels.h",
        "bc_head_table",
        "bc_head_table",
    ),
    // The same with the face label called from two places: a copy of it per state.
    (
        "tnc_bc_head_table_label_copies.h",
        "bc_head_table",
        "bc_head_table",
    ),
    // C, CP (a helix) and CR arcs under M128, the rotary axes standing.
    (
        "tnc_bc_head_table_tcp_arcs.h",
        "bc_head_table",
        "bc_head_table",
    ),
];

fn compensate(setup: &Setup, program: &str, name: &str) -> (String, Summary) {
    let comp = Compensator::new(&setup.machine, &setup.errors, cli_options()).unwrap();
    let mut out = Vec::new();
    let summary = comp
        .run(program.as_bytes(), name, &mut out)
        .unwrap_or_else(|e| panic!("{name} is refused: {e}"));
    (String::from_utf8(out).unwrap(), summary)
}

#[test]
fn the_closed_forms_are_the_machines_nominal_kinematics() {
    for (_, machine, errors) in FIXTURES {
        let setup = Setup::load(machine, errors);
        let kin = Kinematics::new(&setup.machine, &ErrorModel::zero(&setup.machine), 0).unwrap();
        let mut state = 11u64;
        let mut rnd = |s: f64| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (2.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 1.0) * s
        };
        let mut lengths: Vec<f64> = setup.machine.tool.lengths.values().copied().collect();
        lengths.push(setup.machine.tool.length);
        for length in lengths {
            for _ in 0..20 {
                let q = [rnd(200.0), rnd(200.0), rnd(200.0), rnd(100.0), rnd(400.0)];
                let (p, o) = setup.forward(q, length);
                let (pose, _) = kin.pose(Model::Nominal, &setup.vars(&kin, q), length);
                assert!(
                    (pose.p - p).norm() < 1e-9 && (pose.o - o).norm() < 1e-12,
                    "{machine} {q:?}"
                );
                let back = setup.linear_axes(p, q[3], q[4], length);
                assert!(
                    (0..5).all(|k| (back[k] - q[k]).abs() < 1e-9),
                    "{machine} {q:?}"
                );
                // The closed-form plane solution points the tool along the normal.
                let n = setup.direction(q[3], q[4]);
                if q[3].abs() > 1.0
                    && setup.tilt_travel.is_none_or(|[lo, hi]| {
                        (lo..=hi).contains(&q[3].abs()) && (lo..=hi).contains(&-q[3].abs())
                    })
                {
                    for positive in [true, false] {
                        let [t, c] = setup.plane_rotaries(n, q[4] + 30.0, positive);
                        assert!((setup.direction(t, c) - n).norm() < 1e-12);
                        assert_eq!(t >= 0.0, positive);
                        assert!((c - q[4] - 30.0).abs() <= 180.0 + 1e-9);
                    }
                }
            }
        }
    }
}

/// One fixture through nccomp and the independent evaluation.
fn check_fixture(program: &str, machine: &str, errors: &str) -> (Figures, Summary) {
    let setup = Setup::load(machine, errors);
    let src = fixture(program);
    let (written, summary) = compensate(&setup, &src, program);
    assert_consecutive(program, &written);
    // The rotary positions of each plane: the control's (closed form here), nccomp's
    // report, and the fixture's comment agree.
    let recs = run(&setup, &src);
    let mut planes = 0;
    for rec in &recs {
        let Some(step) = rec.step.filter(|s| s.kind == Kind::Turn) else {
            continue;
        };
        let line = rec.line;
        let (_, reported) = summary
            .plane_positions
            .iter()
            .find(|(l, _)| *l == line)
            .unwrap_or_else(|| panic!("{program}:{line}: no plane position reported"));
        let expected = [(setup.tilt, step.q1[3]), ('C', step.q1[4])];
        assert_angles(&format!("{program}:{line}"), &expected, reported);
        planes += 1;
    }
    assert_eq!(planes, summary.plane_positions.len(), "{program}");
    let commented = commented_planes(&src);
    assert_eq!(
        commented.len(),
        recs.iter().filter(|r| r.is_plane).count(),
        "{program}: a comment before every PLANE"
    );
    for (line, angles) in &commented {
        let reported = reported_for(&summary, &src, *line).unwrap();
        assert_angles(&format!("{program}:{line}"), angles, &reported);
    }
    // As programmed, the real machine misses: the evaluation can fail.
    let before = evaluate(&setup, &src, &src);
    assert!(
        before.end > 20.0 * END,
        "{program}: uncompensated block ends only {:.3} µm off",
        before.end * 1e3
    );
    let f = evaluate(&setup, &src, &written);
    eprintln!(
        "{program}: {} block ends within {:.3} µm in planes and under TCP, {:.3} µm in machine axes (as programmed {:.3} µm); direction at written rotary words within {:.2} µrad; path within {:.3} µm (tolerance {:.3} µm plus floor, worst excess {:.3} µm), direction along TCP moves within {:.2} µrad (worst excess {:.2} µrad); {} moves split, {} blocks inserted; {} planes",
        f.ends,
        f.end * 1e3,
        f.end_axes * 1e3,
        before.end * 1e3,
        f.end_direction * 1e6,
        f.path * 1e3,
        cli_options().path.unwrap().position * 1e3,
        f.path_excess * 1e3,
        f.path_direction * 1e6,
        f.path_direction_excess * 1e6,
        f.split,
        f.inserted,
        planes,
    );
    eprintln!(
        "{program}: {} holes, bottoms within {:.3} µm, axis at the set-up clearance within {:.3} µm; {} definitions inserted; {} written out as L moves ({} giving back the feed); {} moving around their axis: within {:.3} µm of it over their reach, the error changing by up to {:.3} µm from the axis's (nccomp's bound {:.3} µm)",
        f.holes,
        f.hole_bottom * 1e3,
        f.hole_clearance * 1e3,
        f.definitions,
        f.written_out,
        f.feeds_given_back,
        f.around,
        f.around_lateral * 1e3,
        f.around_change * 1e3,
        summary.around_bound.value * 1e3,
    );
    let calls = recs
        .iter()
        .filter(|r| r.step.is_some_and(|s| s.hole.is_some()))
        .count();
    assert_eq!(f.holes, calls, "{program}: every cycle call is evaluated");
    assert_eq!(
        (
            f.inserted,
            f.split,
            f.arc_inserted,
            f.arcs,
            f.arcs_kept,
            f.poles
        ),
        (
            summary.blocks_added,
            summary.moves_split,
            summary.arc_blocks_added,
            summary.arcs,
            summary.arcs_kept,
            summary.arc_poles
        ),
        "{program}: the summary counts other splits"
    );
    if f.arcs + f.arcs_kept > 0 {
        eprintln!(
            "{program}: {} arcs kept ({} poles inserted before them), {} replaced by {} pieces",
            f.arcs_kept,
            f.poles,
            f.arcs,
            f.arc_inserted + f.arcs
        );
    }
    assert!(
        f.faults.is_empty(),
        "{program}:\n{}\n{written}",
        f.faults.join("\n")
    );
    assert_eq!(f.written_out, summary.holes_written_out, "{program}");
    (f, summary)
}

#[test]
fn a_3_plus_2_program_on_the_ac_trunnion_meets_the_contract() {
    let (p, m, e) = FIXTURES[0];
    check_fixture(p, m, e);
}

#[test]
fn a_plane_and_m128_program_on_the_bc_head_table_meets_the_contract() {
    let (p, m, e) = FIXTURES[1];
    check_fixture(p, m, e);
}

#[test]
fn a_tcpm_and_plane_program_on_the_head_head_meets_the_contract() {
    let (p, m, e) = FIXTURES[2];
    check_fixture(p, m, e);
}

/// Holes in tilted planes too deep for one X, Y on the paper's AC trunnion: written out as
/// L moves, each move's end on the programmed hole's axis and the feed moves along it
/// within the tolerance, the pecks, dwells and retracts as cycles 200 and 201 make them,
/// the program's feed given back after each; the shallow centering stays a cycle call.
#[test]
fn deep_holes_in_tilted_planes_are_written_out_as_l_moves() {
    let (p, m, e) = FIXTURES[3];
    let (f, summary) = check_fixture(p, m, e);
    assert_eq!(f.holes, 6, "{summary:?}");
    assert_eq!(f.written_out, 5);
    // FQ1, in force before each hole, after each (the cycles feed at FQ3 and F300).
    assert_eq!(f.feeds_given_back, 5);
    // As one X, Y each is off its axis: the evaluation of the calls as programmed.
    let setup = Setup::load(m, e);
    let before = evaluate(&setup, &fixture(p), &fixture(p));
    assert!(before.hole_clearance > 5e-3, "{}", before.hole_clearance);
}

/// Bore milling, thread milling, boring that moves off the wall and a circular pocket on
/// the B head over a C table: compensated by centre, axis and depth; sampled over their
/// reach the real tool stays within the tolerance of the programmed hole's axis, and the
/// change of the error around the axis stays within the bound nccomp states.
#[test]
fn cycles_that_move_around_their_axis_stay_within_their_bound() {
    let (p, m, e) = FIXTURES[4];
    let (f, summary) = check_fixture(p, m, e);
    assert_eq!(f.around, summary.cycles_around, "{summary:?}");
    assert!(f.around >= 5, "{}", f.around);
    assert!(
        f.around_change <= summary.around_bound.value,
        "sampled {:.4} µm beyond the bound {:.4} µm",
        f.around_change * 1e3,
        summary.around_bound.value * 1e3
    );
    // The change is there to bound: the evaluation would see a machine without it.
    assert!(f.around_change > 1e-5, "{}", f.around_change);
}

/// C, CR and CP arcs in tilted planes (poles in the plane's frame, helices by IZ and by a
/// C with a Z end, a helix of two turns, a full circle, DR+ and DR-): kept as arcs where
/// that stays within the path tolerance (a pole of their own written before them as a CC
/// block, a C whose end needs Z written as CP … IZ), pieces otherwise.
#[test]
fn arcs_in_tilted_planes_on_the_ac_trunnion_meet_the_contract() {
    let (p, m, e) = FIXTURES[5];
    check_fixture(p, m, e);
    let setup = Setup::load(m, e);
    let (written, summary) = compensate(&setup, &fixture(p), p);
    assert!(
        summary.arcs_kept >= 3 && summary.arcs >= 3,
        "{} kept, {} replaced",
        summary.arcs_kept,
        summary.arcs
    );
    // A C whose compensated end needs Z is written as a polar helix, which every TNC
    // reads; a C that gives its Z stays a C.
    assert!(
        written
            .lines()
            .any(|l| l.contains(" CP IPA") && l.contains(" IZ")),
        "{written}"
    );
    // The evaluation sees what the control makes of a kept arc's pole: the pole nccomp
    // wrote before a C (whose end its words give), moved by 10 µm, takes the arc off its
    // path.
    let lines: Vec<&str> = written.lines().collect();
    let at = (1..lines.len() - 1)
        .find(|&i| {
            lines[i].contains(" CC ")
                && lines[i - 1].contains(" CC ")
                && lines[i + 1].contains(" C X")
        })
        .expect("a pole written before a kept C");
    let broken = moved_word(&lines, at, 'X', 0.01);
    let f = evaluate(&setup, &fixture(p), &broken);
    assert!(!f.faults.is_empty(), "a pole 10 µm off passes");
}

/// `lines` as a program, the number of the `letter` word on line `at` (0-based) moved by
/// `delta`.
fn moved_word(lines: &[&str], at: usize, letter: char, delta: f64) -> String {
    let mut out = String::new();
    for (i, l) in lines.iter().enumerate() {
        if i == at {
            let (head, rest) = l.split_once(&format!(" {letter}")).unwrap();
            let (value, tail) = rest.split_once(' ').unwrap_or((rest, ""));
            let value: f64 = value.parse().unwrap();
            out += &format!("{head} {letter}{:.4} {tail}", value + delta);
        } else {
            out += l;
        }
        out.push('\n');
    }
    out
}

/// C, CR and CP arcs under M128 with the rotary axes standing (a helix by CP … IZ and by a
/// C with a Z end): the tip follows each arc on the part; compensated as straight pieces
/// within the path tolerance, each end on the contract.
#[test]
fn arcs_under_m128_on_the_bc_head_table_meet_the_contract() {
    let (p, m, e) = FIXTURES[8];
    let (_, summary) = check_fixture(p, m, e);
    assert_eq!(summary.arcs, 4, "{summary:?}");
    // The evaluation follows the arcs: a piece moved 10 µm across the helix takes it off
    // its path.
    let setup = Setup::load(m, e);
    let (written, _) = compensate(&setup, &fixture(p), p);
    let lines: Vec<&str> = written.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.ends_with(" CC X0 Y-30"))
        .expect("the pole")
        + 40;
    let broken = moved_word(&lines, at, 'Y', 0.01);
    let f = evaluate(&setup, &fixture(p), &broken);
    assert!(
        !f.faults.is_empty(),
        "a piece 10 µm off passes: {}",
        lines[at]
    );
}

#[test]
fn with_the_zero_model_each_fixture_comes_back_byte_for_byte() {
    for (program, machine, errors) in FIXTURES {
        let mut setup = Setup::load(machine, errors);
        setup.errors = ErrorModel::zero(&setup.machine);
        let src = fixture(program);
        assert_consecutive(program, &src);
        let (out, summary) = compensate(&setup, &src, program);
        assert!(summary.zero_model, "{program}");
        assert_eq!(out, src, "{program}");
    }
}

/// The compensated fixture with its summary, as `nccomp compensate` writes it by default.
fn snapshot(index: usize) -> String {
    let (program, machine, errors) = FIXTURES[index];
    let setup = Setup::load(machine, errors);
    let (out, summary) = compensate(&setup, &fixture(program), program);
    assert_consecutive(program, &out);
    format!("{summary}\n----\n{out}")
}

#[test]
fn snapshot_tnc_ac_trunnion() {
    insta::assert_snapshot!(snapshot(0));
}

#[test]
fn snapshot_tnc_bc_head_table() {
    insta::assert_snapshot!(snapshot(1));
}

#[test]
fn snapshot_tnc_ac_trunnion_holes() {
    insta::assert_snapshot!(snapshot(3));
}

#[test]
fn snapshot_tnc_bc_head_table_cycles() {
    insta::assert_snapshot!(snapshot(4));
}

#[test]
fn snapshot_tnc_head_head() {
    insta::assert_snapshot!(snapshot(2));
}

#[test]
fn snapshot_tnc_ac_trunnion_arcs() {
    insta::assert_snapshot!(snapshot(5));
}

#[test]
fn snapshot_tnc_bc_head_table_tcp_arcs() {
    insta::assert_snapshot!(snapshot(8));
}

#[test]
fn snapshot_tnc_bc_head_table_labels() {
    insta::assert_snapshot!(snapshot(6));
}

#[test]
fn snapshot_tnc_bc_head_table_label_copies() {
    insta::assert_snapshot!(snapshot(7));
}

/// A label that moves, called from two places (its first move starts elsewhere): the
/// calls would write its body differently, so the second call gets a copy of its own,
/// `LBL "10_2"` after the label's `LBL 0`, compensated for its state, and its `CALL LBL`
/// names the copy; block numbers stay consecutive, and the evaluation runs each call's
/// label.
#[test]
fn a_label_called_in_two_states_gets_a_copy_per_state() {
    let (p, m, e) = FIXTURES[7];
    check_fixture(p, m, e);
    let setup = Setup::load(m, e);
    let (written, _) = compensate(&setup, &fixture(p), p);
    assert!(written.contains("\n41 CALL LBL 10 ; FACE\n"), "{written}");
    assert!(
        written.contains("\n46 CALL LBL \"10_2\" ; FACE\n"),
        "{written}"
    );
    assert!(
        written.contains("\n79 LBL 0\n80 LBL \"10_2\"\n81 L X-30.0061"),
        "{written}"
    );
}

/// Labels that move, run where they are called: `LBL 10` (a face in a tilted plane)
/// called twice from the same place in the same plane is written once, compensated for
/// that state, and `LBL 2` (the safe position) once for its one call; `FN 9` in a
/// called label jumps on the constant set before the call, and `FN 9` / `FN 10` in the
/// main program jump forward or go on as the Q parameters they compare say. The
/// evaluation runs the labels where the control runs them and skips what the jump skips.
#[test]
fn labels_that_move_and_constant_jumps_meet_the_contract() {
    let (p, m, e) = FIXTURES[6];
    let (f, summary) = check_fixture(p, m, e);
    assert!(f.ends >= 20, "{}", f.ends);
    let setup = Setup::load(m, e);
    let (written, _) = compensate(&setup, &fixture(p), p);
    let line = |n: usize| written.lines().nth(n).unwrap().to_string();
    // The block the jump skips is written as it stands; the body of LBL 10 is compensated.
    assert_eq!(line(44), "44 L X0 Y0 Z30 R0 FMAX");
    assert_ne!(line(70), "70 L Z2 R0 FMAX");
    assert!(summary.words_changed > 0);
}

/// The verification gate runs the label calls itself, from the written text: a
/// compensated body broken by 10 µm (a line after the program's end, which no reading
/// in file order would judge) fails `nccomp verify` at that line, for each call; and a
/// jump written to skip a move the original runs fails it too.
#[test]
fn the_gate_follows_the_calls_and_jumps_of_the_written_program() {
    let (p, m, e) = FIXTURES[6];
    let setup = Setup::load(m, e);
    let (written, _) = compensate(&setup, &fixture(p), p);
    let dir = std::env::temp_dir().join(format!("nccomp-labels-gate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let verify = |name: &str, text: &str| {
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_nccomp"))
            .args(["verify", "-m"])
            .arg(root().join(format!("fixtures/{m}.machine.toml")))
            .arg("-e")
            .arg(root().join(format!("fixtures/{e}.errors.toml")))
            .arg(root().join(format!("fixtures/{p}")))
            .arg(&path)
            .output()
            .unwrap();
        (
            out.status.code(),
            format!(
                "{}{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            ),
        )
    };
    let (code, text) = verify("good.h", &written);
    assert_eq!(code, Some(0), "{text}");
    // A body line (block 73, `L Y30` of LBL 10) 10 µm off in X.
    let broken: String = written
        .lines()
        .map(|l| {
            if let Some(rest) = l.strip_prefix("73 L X") {
                let (x, tail) = rest.split_once(' ').unwrap();
                let x: f64 = x.parse().unwrap();
                format!("73 L X{:.4} {tail}\n", x + 0.01)
            } else {
                format!("{l}\n")
            }
        })
        .collect();
    assert_ne!(broken, written);
    let (code, text) = verify("broken.h", &broken);
    assert_ne!(code, Some(0), "{text}");
    assert!(text.contains("broken.h:74"), "{text}");
    // The main program's jump taken on another condition: the move it skipped runs.
    let jumped = written.replace("FN 9: IF +Q1901 EQU +3", "FN 9: IF +Q1901 EQU +4");
    let (code, text) = verify("jumped.h", &jumped);
    assert_ne!(code, Some(0), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// What a label's calls cannot share, or a jump whose condition is not known, is refused
/// at its place: a body that two calls would write differently (another position before
/// the call) where the label also calls another (no copy is made then), naming both
/// calls; a jump on a Q parameter set nowhere; a loop back in the
/// main program.
#[test]
fn labels_and_jumps_nccomp_cannot_follow_are_refused_where_they_stand() {
    let setup = Setup::load("bc_head_table", "bc_head_table");
    let src = fixture("tnc_bc_head_table_labels.h");
    let refused = |program: &str| -> Vec<nccomp::diag::Diagnostic> {
        let comp = Compensator::new(&setup.machine, &setup.errors, cli_options()).unwrap();
        match comp.run(program.as_bytes(), "labels.h", &mut Vec::new()) {
            Err(nccomp::Error::Inputs(d)) => d,
            other => panic!("not refused: {other:?}"),
        }
    };
    // The second call from another place, and the label calls another: no copy.
    let moved = src
        .replace("42 L X-40 Y-30 Z40 R0 FMAX", "42 L X-30 Y-30 Z40 R0 FMAX")
        .replace(
            "77 L X0 Y0",
            "77 FN 9: IF +Q1900 EQU +2 GOTO LBL \"CuttingEdges2\"",
        );
    let d = refused(&moved);
    assert!(
        d[0].message.contains(
            "this line would be written differently for the call at line 42 and the call at line 47"
        ) && d[0].message.contains("this one jumps or calls"),
        "{d:?}"
    );
    assert_eq!(d[0].line, 71, "{d:?}");
    // The condition on a parameter the program never sets.
    let unset = src.replace("FN 9: IF +Q1901 EQU +3", "FN 9: IF +Q1999 EQU +3");
    let d = refused(&unset);
    assert!(
        d[0].message
            .contains("Q1999 is not set to a constant before this jump")
            && d[0].line == 44,
        "{d:?}"
    );
    // A jump back.
    let back = src.replace(
        "FN 10: IF +Q1900 NE +2 GOTO LBL 21",
        "FN 10: IF +Q1900 NE +1 GOTO LBL 20",
    );
    let d = refused(&back);
    assert!(
        d[0].message.contains("jumps back to LBL 20 at line 46") && d[0].line == 48,
        "{d:?}"
    );
}

/// A 45° swivel head (the DMU duoBLOCK of the corpus, fixtures/corpus/dmu100p_bc) turns
/// the tool horizontal at B180, the end of its swing and of its travel, where the tool's
/// tilt is stationary in B (the tool's Z component is (1 + cos B) / 2): the control's angle
/// there is exactly 180°, from wherever the axes stood before. The blocks in the plane must
/// be written for it, and so must the first block in machine axes after PLANE RESET, where
/// the rotary axes still stand there.
#[test]
fn a_plane_at_the_end_of_a_45_degree_heads_swing_is_solved_exactly() {
    let dir = root().join("fixtures");
    let m = machine_file::load(&dir.join("corpus/dmu100p_bc.machine.toml")).unwrap();
    let e = error_file::load(&dir.join("bc_head_table.errors.toml"), &m).unwrap();
    let nominal = Kinematics::new(&m, &ErrorModel::zero(&m), 0).unwrap();
    let real = Kinematics::new(&m, &e, 0).unwrap();
    let var = |name: &str| {
        nominal
            .axes()
            .iter()
            .position(|&i| m.axes[i].name == name)
            .unwrap()
    };
    let length = m.tool.length;
    let comp = Compensator::new(&m, &e, cli_options()).unwrap();
    let mut faults = Vec::new();
    // Horizontal planes: SPB90, turned about Z by SPC.
    for spc in [0.0, 37.3123] {
        // The control's solution: B180 points the tool along +Y, C270 + SPC turns it to
        // the plane's normal.
        let mut q = vec![0.0; nominal.len()];
        q[var("B")] = 180.0;
        q[var("C")] = 270.0 + spc;
        let r = rz(spc) * ry(90.0);
        let o = nominal.pose(Model::Nominal, &q, length).0.o;
        assert!((o - r * Vector3::z()).norm() < 1e-12);
        // The control's linear axes for a tip at these rotary values (the head's X, Y, Z
        // move the tip in a fixed direction each).
        let p = |q: &[f64]| nominal.pose(Model::Nominal, q, length).0.p;
        let p0 = p(&q);
        let mut columns = nalgebra::Matrix3::zeros();
        for (c, name) in ["X", "Y", "Z"].iter().enumerate() {
            let mut moved = q.clone();
            moved[var(name)] += 1.0;
            columns.set_column(c, &(p(&moved) - p0));
        }
        let inverse = columns.try_inverse().unwrap();
        // From where the axes stand before the PLANE (the travels are B 0 … 180, C 0 …
        // 360).
        for (b, c) in [(90.0, 90.0), (0.5, 0.5), (30.0, 10.0), (120.0, 300.0)] {
            let what = format!("SPC{spc} from B{b} C{c}");
            let program = format!(
                "0 BEGIN PGM P MM\n1 L B+{b} C+{c} R0 FMAX\n2 L X+0 Y+0 Z+100 R0 FMAX\n3 PLANE SPATIAL SPA0 SPB90 SPC{spc} STAY SEQ+ TABLE ROT\n4 L B+Q121 C+Q122 R0 FMAX\n5 L X+10 Y+20 Z+30 R0 FMAX\n6 L X+40 F500\n7 PLANE RESET STAY\n8 L Z+100 R0 FMAX\n9 M30\n10 END PGM P MM\n"
            );
            let mut out = Vec::new();
            let summary = comp.run(program.as_bytes(), "p.h", &mut out).unwrap();
            let written = String::from_utf8(out).unwrap();
            let (_, reported) = &summary.plane_positions[0];
            let mut words = Vector3::zeros();
            for (line, programmed) in [
                (6, Vector3::new(10.0, 20.0, 30.0)),
                (7, Vector3::new(40.0, 20.0, 30.0)),
            ] {
                let text = written.lines().nth(line - 1).unwrap();
                for w in statement(split_number(text).1) {
                    if let Some(k) = "XYZ".find(&w[..1]) {
                        words[k] = w[1..].parse().unwrap();
                    }
                }
                let x = inverse * (r * words - p0);
                let mut at = q.clone();
                for (c, name) in ["X", "Y", "Z"].iter().enumerate() {
                    at[var(name)] = x[c];
                }
                let off = (real.pose(Model::Actual, &at, length).0.p - r * programmed).norm();
                eprintln!(
                    "{what}: nccomp turns to {reported:?}; line {line} `{text}`: the real tip is {:.3} µm off",
                    off * 1e3
                );
                if off > END {
                    faults.push(format!(
                        "{what}: line {line}: the tip is {:.3} µm off",
                        off * 1e3
                    ));
                }
            }
            // After PLANE RESET the rotary axes stand where the control turned them; the
            // block in machine axes must land the tip where the program puts it.
            let mut target = q.clone();
            let x = inverse * (r * Vector3::new(40.0, 20.0, 30.0) - p0);
            for (c, name) in ["X", "Y", "Z"].iter().enumerate() {
                target[var(name)] = x[c];
            }
            target[var("Z")] = 100.0;
            let text = written.lines().nth(8).unwrap();
            let mut at = target.clone();
            for w in statement(split_number(text).1) {
                if let Some(name) = ["X", "Y", "Z", "B", "C"]
                    .iter()
                    .find(|n| w.starts_with(**n))
                {
                    at[var(name)] = w[1..].parse().unwrap();
                }
            }
            // X and Y stand where the written plane blocks put them.
            let x = inverse * (r * words - p0);
            for (c, name) in ["X", "Y"].iter().enumerate() {
                if !text.contains(name) {
                    at[var(name)] = x[c];
                }
            }
            let (want, _) = nominal.pose(Model::Nominal, &target, length);
            let (got, _) = real.pose(Model::Actual, &at, length);
            let (off, angle) = ((got.p - want.p).norm(), angle_between(&got.o, &want.o));
            eprintln!(
                "{what}: line 9 `{text}`: the real tip is {:.3} µm off, the tool {:.2} µrad",
                off * 1e3,
                angle * 1e6
            );
            // (B stands at the end of its travel, where the correction would push it
            // past: it is held, and the direction error is left.)
            if off > END_AXES {
                faults.push(format!(
                    "{what}: line 9: the tip is {:.3} µm off",
                    off * 1e3
                ));
            }
            for (name, angle) in [("B", 180.0), ("C", 270.0 + spc)] {
                let (_, value) = reported.iter().find(|(n, _)| n == name).unwrap();
                if !same_angle(*value, angle, 1e-6) {
                    faults.push(format!(
                        "{what}: nccomp turns {name} to {value}, the control to {angle}"
                    ));
                }
            }
        }
    }
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

/// PLANE EULER, VECTOR and RELATIV name the same plane as a PLANE SPATIAL: the control
/// turns the rotary axes to the same angles, and the moves in the plane come out the same.
#[test]
fn the_other_plane_forms_name_the_same_plane_as_spatial() {
    let setup = Setup::load("ac_trunnion", "ac_trunnion");
    let program = |plane: &str| {
        format!(
            "0 BEGIN PGM P MM\n1 L X+0 Y+0 Z+100 A+0 C+0 R0 FMAX\n2 CYCL DEF 7.0 DATUM SHIFT\n3 CYCL DEF 7.1 X+20\n4 CYCL DEF 7.2 Y-10\n5 CYCL DEF 7.3 Z-5\n6 {plane}\n7 L A+Q120 C+Q122 R0 FMAX\n8 L X+10 Y+5 Z+30 R0 FMAX\n9 L X+40 Y+25 Z+2 F500\n10 PLANE RESET STAY\n11 M30\n12 END PGM P MM\n"
        )
    };
    let (spatial, s_summary) = compensate(
        &setup,
        &program("PLANE SPATIAL SPA-30 SPB0 SPC45 STAY SEQ- TABLE ROT"),
        "spatial.h",
    );
    // R = Rz(45)·Rx(-30): Euler Z-X-Z (45, -30, 0); X axis (c45, s45, 0); normal
    // Rz(45)·(0, sin 30, cos 30).
    let (s45, c30) = (0.5f64.sqrt(), 0.75f64.sqrt());
    let vector = format!(
        "PLANE VECTOR BX{s45:+.12} BY{s45:+.12} BZ+0 NX{:+.12} NY{:+.12} NZ{c30:+.12} STAY SEQ- TABLE ROT",
        -0.5 * s45,
        0.5 * s45
    );
    for form in [
        "PLANE EULER EULPR45 EULNU-30 EULROT0 STAY SEQ- TABLE ROT".to_string(),
        vector,
    ] {
        let (out, summary) = compensate(&setup, &program(&form), "form.h");
        assert_eq!(summary.plane_positions.len(), 1, "{form}");
        for ((_, a), (_, b)) in summary.plane_positions[0]
            .1
            .iter()
            .zip(&s_summary.plane_positions[0].1)
        {
            assert!((a - b).abs() < 1e-6, "{form}: {a} against {b}");
        }
        let moves = |text: &str| -> Vec<String> {
            text.lines()
                .filter(|l| l.contains(" L X"))
                .map(str::to_string)
                .collect()
        };
        assert_eq!(moves(&out), moves(&spatial), "{form}");
    }
    // RELATIV turns the plane in force about its own axes: SPC45 then SPA-30 about the
    // turned X is SPATIAL SPA-30 SPB0 SPC45.
    let relativ = program("PLANE SPATIAL SPA+0 SPB+0 SPC+45 STAY SEQ- TABLE ROT").replace(
        "6 PLANE SPATIAL SPA+0 SPB+0 SPC+45 STAY SEQ- TABLE ROT\n",
        "6 PLANE SPATIAL SPA+0 SPB+0 SPC+45 STAY SEQ- TABLE ROT ; PLANE RELATIV SPA-30 follows\n6 PLANE RELATIV SPA-30 STAY SEQ- TABLE ROT\n",
    );
    let (out, summary) = compensate(&setup, &relativ, "relativ.h");
    assert_eq!(summary.plane_positions.len(), 1);
    for ((_, a), (_, b)) in summary.plane_positions[0]
        .1
        .iter()
        .zip(&s_summary.plane_positions[0].1)
    {
        assert!((a - b).abs() < 1e-6, "RELATIV: {a} against {b}");
    }
    assert!(out.contains("PLANE RELATIV SPA-30"));
}

/// The control turns the rotary axes to the plane's nominal angles with the linear axes
/// standing: the tip moves by the nominal turn, so a cut right after it would start off
/// the corrected pose. A positioning move after the turn is compensated; a feed move
/// straight after it is refused at its line, in both forms of the turn.
#[test]
fn a_feed_move_right_after_a_turn_to_the_plane_is_refused() {
    let setup = Setup::load("ac_trunnion", "ac_trunnion");
    let comp = Compensator::new(&setup.machine, &setup.errors, cli_options()).unwrap();
    for (turn, after) in [
        (
            "5 PLANE SPATIAL SPA-30 SPB0 SPC45 TURN FMAX SEQ- TABLE ROT",
            "",
        ),
        (
            "5 PLANE SPATIAL SPA-30 SPB0 SPC45 STAY SEQ- TABLE ROT",
            "6 L A+Q120 C+Q122 R0 FMAX\n",
        ),
    ] {
        let program = |first: &str| {
            format!(
                "0 BEGIN PGM P MM\n1 L X+0 Y+0 Z+100 A+0 C+0 R0 FMAX\n{turn}\n{after}{first}\n8 L X+40 Y+25 Z+2 F500\n9 PLANE RESET STAY\n10 M30\n11 END PGM P MM\n"
            )
        };
        let cut = program("7 L X+10 Y+5 Z+30 F500");
        let err = comp
            .run(cut.as_bytes(), "p.h", &mut Vec::new())
            .unwrap_err()
            .to_string();
        let line = cut.lines().position(|l| l.starts_with("7 ")).unwrap() + 1;
        assert!(
            err.contains(&format!("p.h:{line}:"))
                && err.contains(
                    "a feed move right after the rotary axes turned to the working plane"
                ),
            "{turn}: {err}"
        );
        let positioned = program("7 L X+10 Y+5 Z+30 R0 FMAX");
        comp.run(positioned.as_bytes(), "p.h", &mut Vec::new())
            .unwrap_or_else(|e| panic!("{turn}: {e}"));
    }
}

/// What nccomp cannot follow of an arc in a plane or under TCP is refused at its place,
/// saying what was expected: a pole given before the plane changed, an IPA turning the
/// other way than DR, a pole given before M128 for an arc under it, an optional arc under
/// M128 (its pieces would run or not as one block), a word a C does not take.
#[test]
fn arcs_that_cannot_be_followed_are_refused_where_they_stand() {
    let setup = Setup::load("ac_trunnion", "ac_trunnion");
    let comp = Compensator::new(&setup.machine, &setup.errors, cli_options()).unwrap();
    let head = "0 BEGIN PGM P MM\n1 L X+0 Y+0 Z+100 A+0 C+0 R0 FMAX\n";
    let plane = "3 PLANE SPATIAL SPA-30 SPB0 SPC45 TURN FMAX SEQ- TABLE ROT\n4 L X+10 Y+0 Z+2 R0 FMAX\n5 L Z+0 F500\n";
    for (body, at, says) in [
        (
            format!("2 CC X+0 Y+0\n{plane}6 C X+0 Y+10 DR+\n"),
            "p.h:7:3",
            "given in another frame",
        ),
        (
            format!("{plane}6 CC X+0 Y+0\n7 CP IPA-90 IZ-1 DR+\n"),
            "p.h:7:3",
            "expected an incremental polar angle other than 0 whose sign is the direction's",
        ),
        (
            format!("{plane}6 CC X+0 Y+0\n7 C X+0 Y+10 A+5 DR+\n"),
            "p.h:7:14",
            "expected the end's X and Y, and Z for a helix",
        ),
        (
            "2 CC X+0 Y+0\n3 M128\n4 L X+10 Y+0 Z+2 R0 FMAX\n5 C X+0 Y+10 DR+\n".to_string(),
            "p.h:6:3",
            "or tool-centre-point control was switched",
        ),
        (
            "2 M128\n3 L X+10 Y+0 Z+2 R0 FMAX\n4 CC X+0 Y+0\n/5 C X+0 Y+10 DR+\n".to_string(),
            "p.h:6:6",
            "an optional block (/) under M128 / FUNCTION TCPM cannot be compensated",
        ),
    ] {
        let program = format!("{head}{body}99 END PGM P MM\n");
        let err = comp
            .run(program.as_bytes(), "p.h", &mut Vec::new())
            .unwrap_err()
            .to_string();
        assert!(
            err.contains(&format!("{at}:")) || err.contains(&format!("{at}\n")),
            "{body}: {err}"
        );
        assert!(err.contains(says), "{body}: {err}");
    }
}

//! Sinumerik 840D programs (`fixtures/840d_*.mpf`) checked against an independent model of
//! the control, in the manner of tests/heidenhain.rs: the programs are read here (not by
//! nccomp's reader) with the semantics of /work/notes/sinumerik_semantics.md: variables and
//! expressions, `=DC/ACP/ACN/AC/IC(…)`, G90/G91, arcs with I J or CR=, TRAORI (X Y Z the
//! tip in the part frame, the rotary words axis angles, tip and rotary values interpolated
//! linearly, arcs in the part frame), CYCLE800 (R = R_axis1(_A)·R_axis2(_B)·R_axis3(_C) by
//! _MODE, origin _X0.. + R·_X1.., the rotary axes turned by _DIR in closed form, Z
//! retracted by _FR), TRANS / AROT RPL= composed under the swivel, MCALL CYCLE81 holes, and
//! SUPA. The real machine is evaluated with the error model (nccomp's chains, whose nominal
//! form is checked here against closed forms). Every block end of the written program
//! (pieces nccomp inserts included) must put the tip where the programmed block puts it on
//! the nominal machine (and under TRAORI and in machine axes the tool direction too), the
//! path between must stay within the path tolerance, each MCALL hole must have its bottom
//! where the program puts it and its axis at the set-up clearance within the tolerance,
//! and the zero model must give each program back byte for byte.
//!
//! The holes: the set-up clearance where the feed starts must be within the tolerance of
//! the programmed point there (the `MCALL CYCLE81` copies move RFP, and an absolute DP
//! with it).

mod common;

use common::contract::*;
use nalgebra::{Rotation3, Vector3};
use nccomp::compensate::{Compensator, Summary};
use nccomp::kinematics::{Kinematics, Model, angle_between};
use nccomp::model::ErrorModel;
use std::collections::HashMap;

/// The AC trunnion of the fixtures in closed form (`common::contract`), whose master axis
/// for _DIR is A, the table's axis nearest the bed.
fn ac_trunnion() -> Setup {
    let setup = Setup::load("ac_trunnion", "ac_trunnion");
    let chain: Vec<&str> = (setup.machine.workpiece_chain.iter())
        .map(|&i| setup.machine.axes[i].name.as_str())
        .collect();
    assert_eq!(chain, ["Y", "X", "A", "C"], "A is the axis nearest the bed");
    setup
}

// ---------------------------------------------------------------------------------------
// The programs, read as the control runs them.

/// A frame: origin and rotation in the part frame (G54, program zero: no work offsets in
/// the machine file).
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

#[derive(Clone, Copy, Debug, PartialEq)]
enum Kind {
    /// Machine axes: the words are axis values (plus the programmable frame's shift).
    Axes,
    /// Under a swivel (or a rotated frame): X Y Z are the tip in the frame, the rotary
    /// axes stand.
    Plane,
    /// Under TRAORI: X Y Z the part-frame tip, the rotary words axis angles.
    Tcp,
    /// CYCLE800 turns the rotary axes to a plane.
    Turn,
}

/// An arc in G17: its centre in X Y of the interpolated coordinates (the tip under
/// TRAORI, the axis values in machine axes) and its sense.
#[derive(Clone, Copy, Debug)]
struct ArcPath {
    centre: [f64; 2],
    clockwise: bool,
}

/// The point at `u` of the arc from `a` to `b` about `arc`'s centre (the radius from the
/// start's to the end's in proportion to the angle, Z in proportion too: a helix).
fn arc_point(a: Vector3<f64>, b: Vector3<f64>, arc: &ArcPath, u: f64) -> Vector3<f64> {
    let [cx, cy] = arc.centre;
    let (ra, rb) = ((a.x - cx).hypot(a.y - cy), (b.x - cx).hypot(b.y - cy));
    let (ta, tb) = ((a.y - cy).atan2(a.x - cx), (b.y - cy).atan2(b.x - cx));
    let turn = std::f64::consts::TAU;
    let mut sweep = tb - ta;
    if arc.clockwise {
        while sweep >= 0.0 {
            sweep -= turn;
        }
        while sweep < -turn {
            sweep += turn;
        }
    } else {
        while sweep <= 0.0 {
            sweep += turn;
        }
        while sweep > turn {
            sweep -= turn;
        }
    }
    let (t, r) = (ta + sweep * u, ra + (rb - ra) * u);
    Vector3::new(cx + r * t.cos(), cy + r * t.sin(), a.z + (b.z - a.z) * u)
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
    /// Under TRAORI: the part-frame tip at the start and the end (the rotary values are
    /// in q0, q1).
    tip0: Vector3<f64>,
    tip1: Vector3<f64>,
    arc: Option<ArcPath>,
    /// In a plane, an arc's frame: tip0 and tip1 are then its start and end words.
    frame: Option<Plane>,
    /// Every axis has been set by the program (or CYCLE800's turn) at its end: where it
    /// stands is known.
    known: bool,
    /// The block calls the modal cycle (MCALL): the hole it drills. The step then ends
    /// where the cycle leaves the tool (RTP).
    hole: Option<Hole>,
}

impl Step {
    /// The control's axis values at `u` ∈ [0, 1] along the block.
    fn axes_at(&self, setup: &Setup, u: f64) -> Axes {
        let lerp = |a: f64, b: f64| a + (b - a) * u;
        let (t, c) = (lerp(self.q0[3], self.q1[3]), lerp(self.q0[4], self.q1[4]));
        let along = |a: Vector3<f64>, b: Vector3<f64>| match &self.arc {
            Some(arc) => arc_point(a, b, arc, u),
            None => a + (b - a) * u,
        };
        match self.kind {
            Kind::Tcp => setup.linear_axes(along(self.tip0, self.tip1), t, c, self.length),
            Kind::Plane if self.arc.is_some() => {
                // An arc in the plane: the words on it, put in the part frame.
                let frame = self.frame.expect("an arc in a plane has its frame");
                let w = along(self.tip0, self.tip1);
                setup.linear_axes(frame.part(w), t, c, self.length)
            }
            Kind::Axes | Kind::Plane => {
                let p = along(
                    Vector3::new(self.q0[0], self.q0[1], self.q0[2]),
                    Vector3::new(self.q1[0], self.q1[1], self.q1[2]),
                );
                [p.x, p.y, p.z, t, c]
            }
            Kind::Turn => panic!("the path of a turn is not followed"),
        }
    }
}

/// `MCALL CYCLE81(RTP, RFP, SDIS, DP, DPR)`: the levels along the plane's Z.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cycle81 {
    rtp: f64,
    rfp: f64,
    sdis: f64,
    dp: Option<f64>,
    dpr: Option<f64>,
}

impl Cycle81 {
    /// The hole's bottom: DP, or RFP - DPR.
    fn depth(&self) -> f64 {
        match (self.dp, self.dpr) {
            (Some(dp), None) => dp,
            (None, Some(dpr)) => self.rfp - dpr,
            other => panic!("DP or DPR: {other:?}"),
        }
    }

    /// Where the drilling starts: RFP + SDIS.
    fn clearance(&self) -> f64 {
        self.rfp + self.sdis
    }
}

/// A hole the modal cycle drills, in the plane's frame: at X, Y (the tip's when the call
/// starts) with the cycle in force.
#[derive(Clone, Copy, Debug)]
struct Hole {
    plane: Plane,
    xy: [f64; 2],
    cycle: Cycle81,
}

/// A line of the program: its block number, its text without it, and what it does.
#[derive(Clone, Debug)]
struct Rec {
    number: Option<u64>,
    text: String,
    step: Option<Step>,
    /// The line is `MCALL CYCLE81(…)`.
    is_cycle: bool,
}

/// Split a line into its block number and the rest (`N120 G1 X5` → (120, "G1 X5")).
fn split_number(line: &str) -> (Option<u64>, &str) {
    let line = line.trim_end_matches('\r');
    if let Some(after) = line.strip_prefix('N') {
        let digits = after.bytes().take_while(u8::is_ascii_digit).count();
        if digits > 0 && (after.len() == digits || after[digits..].starts_with(' ')) {
            let rest = &after[digits..];
            return (
                after[..digits].parse().ok(),
                rest.strip_prefix(' ').unwrap_or(rest),
            );
        }
    }
    (None, line)
}

/// The tokens of a statement: runs between spaces, brackets and quoted strings keeping
/// theirs; the comment (`;` to the end) left off.
fn tokens(rest: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let (mut depth, mut quoted, mut start) = (0i32, false, None::<usize>);
    let mut end = rest.len();
    for (i, ch) in rest.char_indices() {
        if !quoted && ch == ';' {
            end = i;
            break;
        }
        if !quoted && depth == 0 && ch.is_whitespace() {
            if let Some(s) = start.take() {
                out.push(&rest[s..i]);
            }
            continue;
        }
        match ch {
            '"' => quoted = !quoted,
            '(' if !quoted => depth += 1,
            ')' if !quoted => depth -= 1,
            _ => {}
        }
        start.get_or_insert(i);
    }
    if let Some(s) = start {
        out.push(&rest[s..end]);
    }
    out
}

/// An arithmetic expression over numbers and variables: + - * / and brackets.
struct Expr<'a> {
    s: &'a [u8],
    i: usize,
    vars: &'a HashMap<String, f64>,
}

impl Expr<'_> {
    fn peek(&mut self) -> Option<u8> {
        while self.s.get(self.i) == Some(&b' ') {
            self.i += 1;
        }
        self.s.get(self.i).copied()
    }

    fn sum(&mut self) -> f64 {
        let mut v = self.product();
        while let Some(op @ (b'+' | b'-')) = self.peek() {
            self.i += 1;
            let w = self.product();
            v = if op == b'+' { v + w } else { v - w };
        }
        v
    }

    fn product(&mut self) -> f64 {
        let mut v = self.factor();
        while let Some(op @ (b'*' | b'/')) = self.peek() {
            self.i += 1;
            let w = self.factor();
            v = if op == b'*' { v * w } else { v / w };
        }
        v
    }

    fn factor(&mut self) -> f64 {
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                -self.factor()
            }
            Some(b'+') => {
                self.i += 1;
                self.factor()
            }
            Some(b'(') => {
                self.i += 1;
                let v = self.sum();
                assert_eq!(self.peek(), Some(b')'), "a bracket not closed");
                self.i += 1;
                v
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let start = self.i;
                while self
                    .s
                    .get(self.i)
                    .is_some_and(|c| c.is_ascii_digit() || *c == b'.')
                {
                    self.i += 1;
                }
                std::str::from_utf8(&self.s[start..self.i])
                    .unwrap()
                    .parse()
                    .unwrap()
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let start = self.i;
                while self
                    .s
                    .get(self.i)
                    .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
                {
                    self.i += 1;
                }
                let name = std::str::from_utf8(&self.s[start..self.i])
                    .unwrap()
                    .to_ascii_uppercase();
                *self
                    .vars
                    .get(&name)
                    .unwrap_or_else(|| panic!("{name} is not a variable set to a constant"))
            }
            other => panic!("an expression: {:?}", other.map(char::from)),
        }
    }
}

fn eval(text: &str, vars: &HashMap<String, f64>) -> f64 {
    let mut e = Expr {
        s: text.as_bytes(),
        i: 0,
        vars,
    };
    let v = e.sum();
    assert_eq!(e.peek(), None, "`{text}` is not an expression read here");
    v
}

/// How a word's value is given.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Wrap {
    Plain,
    Ac,
    Ic,
    Dc,
    Acp,
    Acn,
}

/// The value of a word after its address: `10`, `=R1+20`, `=IC(-3)`, `=DC(48)`.
fn word_value(text: &str, vars: &HashMap<String, f64>) -> (f64, Wrap) {
    let Some(e) = text.strip_prefix('=') else {
        return (
            text.parse()
                .unwrap_or_else(|_| panic!("`{text}` is not a number")),
            Wrap::Plain,
        );
    };
    for (prefix, wrap) in [
        ("DC(", Wrap::Dc),
        ("ACP(", Wrap::Acp),
        ("ACN(", Wrap::Acn),
        ("AC(", Wrap::Ac),
        ("IC(", Wrap::Ic),
    ] {
        if let Some(inner) = e.strip_prefix(prefix) {
            let inner = inner
                .strip_suffix(')')
                .expect("a wrapper around the whole value");
            return (eval(inner, vars), wrap);
        }
    }
    (eval(e, vars), Wrap::Plain)
}

/// `R1=…` or `_NAME=…`: an assignment (name, expression).
fn assignment(token: &str) -> Option<(String, &str)> {
    let (name, value) = token.split_once('=')?;
    let is_r =
        name.len() > 1 && name.starts_with('R') && name[1..].bytes().all(|c| c.is_ascii_digit());
    let is_user = name.starts_with('_')
        && name[1..]
            .bytes()
            .all(|c| c.is_ascii_alphanumeric() || c == b'_');
    (is_r || is_user).then(|| (name.to_ascii_uppercase(), value))
}

/// The comma-separated arguments of `NAME(…)`.
fn arguments<'t>(token: &'t str, name: &str) -> Option<Vec<&'t str>> {
    let inner = token.strip_prefix(name)?.strip_prefix('(')?;
    let inner = inner.strip_suffix(')').expect("a call's bracket");
    Some(if inner.trim().is_empty() {
        Vec::new()
    } else {
        inner.split(',').map(str::trim).collect()
    })
}

/// The control's state.
struct Control<'s> {
    setup: &'s Setup,
    q: Axes,
    length: f64,
    /// The tool selected with T, and the one in the spindle (M6).
    selected: Option<u32>,
    spindle: Option<u32>,
    /// G0 G1 G2 G3.
    motion: u32,
    incremental: bool,
    tcp: bool,
    /// Under TRAORI: the programmed part-frame tip (words are modal).
    tip: Vector3<f64>,
    /// CYCLE800's plane, and the programmable frame (TRANS, ROT, ...).
    swivel: Option<Plane>,
    trans: Vector3<f64>,
    rot: Rotation3<f64>,
    /// MCALL's cycle.
    mcall: Option<Cycle81>,
    ended: bool,
    /// Bit k: axis k (X Y Z A C) has been set.
    known: u8,
    vars: HashMap<String, f64>,
}

impl<'s> Control<'s> {
    fn new(setup: &'s Setup) -> Self {
        Control {
            setup,
            q: [0.0; 5],
            length: setup.machine.tool.length,
            selected: None,
            spindle: None,
            motion: 0,
            incremental: false,
            tcp: false,
            tip: Vector3::zeros(),
            swivel: None,
            trans: Vector3::zeros(),
            rot: Rotation3::identity(),
            mcall: None,
            ended: false,
            known: 0,
            vars: HashMap::new(),
        }
    }

    /// The frame X Y Z words are given in, if it is not machine axes: CYCLE800's plane with
    /// the programmable frame on top (part point = origin + R_sw·(T + R_p·w)), or a rotated
    /// programmable frame alone.
    fn frame(&self) -> Option<Plane> {
        if self.swivel.is_none() && self.rot.angle() == 0.0 {
            return None;
        }
        let sw = self.swivel.unwrap_or(Plane {
            origin: Vector3::zeros(),
            r: Rotation3::identity(),
        });
        Some(Plane {
            origin: sw.origin + sw.r * self.trans,
            r: sw.r * self.rot,
        })
    }

    /// Run one line (its tokens); the step it makes, if it moves, and whether it is an
    /// `MCALL CYCLE81(…)`.
    fn line(&mut self, toks: &[&str]) -> (Option<Step>, bool) {
        if toks.is_empty() || self.ended || toks[0].starts_with("%_N_") {
            return (None, false);
        }
        match toks[0] {
            "DEF" => {
                assert!(matches!(toks[1], "REAL" | "INT"), "DEF {}", toks[1]);
                for decl in toks[2..].concat().split(',') {
                    let (name, value) = decl.split_once('=').unwrap_or((decl, "0"));
                    let value = eval(value, &self.vars);
                    self.vars.insert(name.to_ascii_uppercase(), value);
                }
                (None, false)
            }
            "TRANS" | "ATRANS" | "ROT" | "AROT" => {
                self.programmable_frame(toks);
                (None, false)
            }
            "MCALL" => {
                if toks.len() == 1 {
                    self.mcall = None;
                    return (None, false);
                }
                assert_eq!(toks.len(), 2, "MCALL and one call");
                let args = arguments(toks[1], "CYCLE81").expect("MCALL CYCLE81 only");
                let num = |k: usize| -> Option<f64> {
                    args.get(k)
                        .filter(|a| !a.is_empty())
                        .map(|a| eval(a, &self.vars))
                };
                self.mcall = Some(Cycle81 {
                    rtp: num(0).expect("RTP"),
                    rfp: num(1).expect("RFP"),
                    sdis: num(2).expect("SDIS"),
                    dp: num(3),
                    dpr: num(4),
                });
                (None, true)
            }
            t if t.starts_with("CYCLE800(") => {
                assert_eq!(toks.len(), 1, "CYCLE800 in a block of its own");
                (self.cycle800(t), false)
            }
            t if t.starts_with("CYCLE") => panic!("{t} called once is refused"),
            _ => (self.block(toks), false),
        }
    }

    /// TRANS / ATRANS / ROT / AROT in their own block.
    fn programmable_frame(&mut self, toks: &[&str]) {
        assert!(!self.tcp, "a frame under TRAORI");
        let mut v = Vector3::zeros();
        let mut rpl = None;
        for t in &toks[1..] {
            if let Some(e) = t.strip_prefix("RPL=") {
                rpl = Some(eval(e, &self.vars));
                continue;
            }
            let k = "XYZ"
                .find(&t[..1])
                .unwrap_or_else(|| panic!("`{t}` in a frame"));
            let (value, wrap) = word_value(&t[1..], &self.vars);
            assert_eq!(wrap, Wrap::Plain);
            v[k] = value;
        }
        let rotation = |v: Vector3<f64>| match rpl {
            Some(a) => rz(a),
            None => rz(v.z) * ry(v.y) * rx(v.x),
        };
        match toks[0] {
            "TRANS" => {
                assert!(rpl.is_none());
                self.trans = v;
                self.rot = Rotation3::identity();
            }
            "ATRANS" => self.trans += self.rot * v,
            "ROT" => {
                self.trans = Vector3::zeros();
                self.rot = rotation(v);
            }
            _ => self.rot *= rotation(v),
        }
    }

    /// CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0, _Z0, _A, _B, _C, _X1, _Y1, _Z1, _DIR, …).
    fn cycle800(&mut self, token: &str) -> Option<Step> {
        assert!(!self.tcp, "CYCLE800 under TRAORI");
        let args = arguments(token, "CYCLE800").unwrap();
        if args.is_empty() || args[1].trim_matches('"') == "0" {
            self.swivel = None;
            return None;
        }
        assert!(
            self.trans == Vector3::zeros() && self.rot.angle() == 0.0,
            "CYCLE800 with TRANS/ROT in force"
        );
        let num = |k: usize| -> f64 {
            args.get(k)
                .filter(|a| !a.is_empty())
                .map_or(0.0, |a| eval(a, &self.vars))
        };
        assert_eq!(
            num(2),
            0.0,
            "an additive swivel (_ST 1) is not in these fixtures"
        );
        let mode = num(3) as u32;
        assert_eq!(mode >> 6, 0, "axis by axis only");
        let about = |bits: u32, angle: f64| match bits {
            1 => rx(angle),
            2 => ry(angle),
            3 => rz(angle),
            _ => panic!("_MODE {mode}"),
        };
        let r = about(mode & 3, num(7)) * about((mode >> 2) & 3, num(8)) * about(mode >> 4, num(9));
        let origin =
            Vector3::new(num(4), num(5), num(6)) + r * Vector3::new(num(10), num(11), num(12));
        self.swivel = Some(Plane { origin, r });
        // The retraction: the retracted axes go to the machine's own positions.
        match num(0) as i32 {
            0 => {}
            1 => self.known &= !0b100,
            2 | 4 | 5 => self.known &= !0b111,
            other => panic!("_FR {other}"),
        }
        match num(13) as i32 {
            0 => None,
            dir @ (-1 | 1) => {
                let [t, c] = self
                    .setup
                    .plane_rotaries(r * Vector3::z(), self.q[4], dir > 0);
                Some(self.turn(t, c))
            }
            other => panic!("_DIR {other}"),
        }
    }

    /// The control turns the rotary axes; the linear axes stay.
    fn turn(&mut self, t: f64, c: f64) -> Step {
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
            arc: None,
            frame: None,
            known: self.known == 0b11111,
            hole: None,
        }
    }

    fn g(&mut self, code: &str) {
        match code {
            "0" | "1" | "2" | "3" => self.motion = code.parse().unwrap(),
            "90" => self.incremental = false,
            "91" => self.incremental = true,
            // G17 (arcs in X Y), metric, feed per minute, continuous path, no cutter
            // compensation, the one work offset (program zero: no [work_offsets]).
            "17" | "71" | "710" | "94" | "64" | "40" | "54" => {}
            other => panic!("G{other} is not read here"),
        }
    }

    /// The value a linear word gives, from `current` in the same coordinates.
    fn linear(&self, current: f64, (v, wrap): (f64, Wrap)) -> f64 {
        match wrap {
            Wrap::Plain if self.incremental => current + v,
            Wrap::Plain => v,
            Wrap::Ac if !self.incremental => v,
            Wrap::Ic if self.incremental => current + v,
            other => panic!("{other:?} refused here"),
        }
    }

    /// The angle a rotary word turns axis `k` to (DC the shortest way, ACP positive, ACN
    /// negative: where the control arrives).
    fn rotary(&self, k: usize, (v, wrap): (f64, Wrap)) -> f64 {
        let current = self.q[k];
        let known = self.known & (1 << k) != 0;
        match wrap {
            Wrap::Plain if self.incremental => current + v,
            Wrap::Plain => v,
            Wrap::Ac if !self.incremental => v,
            Wrap::Ic if self.incremental => current + v,
            Wrap::Dc | Wrap::Acp | Wrap::Acn => {
                assert!(!self.incremental && known, "{wrap:?} from an unknown angle");
                let up = (v - current).rem_euclid(360.0);
                current
                    + match wrap {
                        Wrap::Dc if up > 180.0 => up - 360.0,
                        Wrap::Dc | Wrap::Acp => up,
                        _ => -(current - v).rem_euclid(360.0),
                    }
            }
            other => panic!("{other:?} refused here"),
        }
    }

    /// A block of G, M, T, D, S, F words, assignments, TRAORI/TRAFOOF/SUPA and axis words.
    fn block(&mut self, toks: &[&str]) -> Option<Step> {
        let mut words: Vec<(usize, (f64, Wrap))> = Vec::new();
        let mut centre = [None::<f64>; 2];
        let mut radius = None;
        let mut supa = false;
        for &t in toks {
            if let Some((name, e)) = assignment(t) {
                let v = eval(e, &self.vars);
                self.vars.insert(name, v);
                continue;
            }
            match t {
                "TRAORI" | "TRAORI(1)" => {
                    assert!(self.frame().is_none(), "TRAORI under a frame");
                    self.tcp = true;
                    self.tip = self.setup.forward(self.q, self.length).0;
                    continue;
                }
                "TRAFOOF" => {
                    self.tcp = false;
                    continue;
                }
                "SUPA" | "G153" | "G53" => {
                    supa = true;
                    continue;
                }
                _ if t.starts_with("MSG(") => continue,
                _ if t.starts_with("A3=") || t.starts_with("B3=") || t.starts_with("C3=") => {
                    panic!("tool vectors are not in these fixtures")
                }
                _ => {}
            }
            if let Some(r) = t.strip_prefix("CR=") {
                radius = Some(eval(r, &self.vars));
                continue;
            }
            let (address, rest) = t.split_at(1);
            match address {
                "G" => self.g(rest),
                "M" => match rest {
                    "3" | "5" | "8" | "9" => {}
                    "6" => self.spindle = self.selected,
                    "30" | "2" => self.ended = true,
                    other => panic!("M{other} is not read here"),
                },
                "T" => self.selected = Some(rest.parse().unwrap()),
                "D" => {
                    assert!(!self.tcp, "a D change under TRAORI");
                    self.length = match rest {
                        "0" => 0.0,
                        _ => {
                            let tool = &self.setup.machine.tool;
                            self.spindle
                                .and_then(|n| tool.lengths.get(&n).copied())
                                .unwrap_or(tool.length)
                        }
                    };
                }
                "S" | "F" => {}
                "X" | "Y" | "Z" | "A" | "C" => {
                    let k = "XYZAC".find(address).unwrap();
                    words.push((k, word_value(rest, &self.vars)));
                }
                "I" | "J" => {
                    let (v, wrap) = word_value(rest, &self.vars);
                    assert_eq!(wrap, Wrap::Plain, "absolute arc centres are refused");
                    centre[usize::from(address == "J")] = Some(v);
                }
                _ => panic!("`{t}` is not read here"),
            }
        }
        if words.is_empty() {
            assert!(centre == [None, None] && radius.is_none());
            return None;
        }
        let q0 = self.q;
        let rapid = self.motion == 0;
        let step = |kind, q1, known| Step {
            kind,
            rapid,
            length: self.length,
            q0,
            q1,
            tip0: Vector3::zeros(),
            tip1: Vector3::zeros(),
            arc: None,
            frame: None,
            known,
            hole: None,
        };
        if supa {
            // Machine positions: without [work_offsets] where they are in program
            // coordinates is not known.
            assert!(!self.tcp && self.frame().is_none() && self.motion < 2);
            for &(k, _) in &words {
                self.known &= !(1 << k);
            }
            return Some(step(Kind::Axes, self.q, false));
        }
        for &(k, _) in &words {
            self.known |= 1 << k;
        }
        if words.iter().filter(|(k, _)| *k < 3).count() == 3 && self.frame().is_some() {
            // In a frame the words X Y Z give the whole tip.
            self.known |= 0b111;
        }
        let known = self.known == 0b11111;
        // The start and end in the words' coordinates, and the rotary values.
        let frame = self.frame();
        let start = if self.tcp {
            self.tip
        } else if let Some(frame) = frame {
            frame.words(self.setup.forward(self.q, self.length).0)
        } else {
            Vector3::new(self.q[0], self.q[1], self.q[2]) - self.trans
        };
        let mut end = start;
        let mut rot = [self.q[3], self.q[4]];
        for &(k, value) in &words {
            if k < 3 {
                end[k] = self.linear(start[k], value);
            } else {
                assert!(frame.is_none(), "rotary words in a frame are refused");
                rot[k - 3] = self.rotary(k, value);
            }
        }
        let arc = (self.motion >= 2).then(|| {
            let clockwise = self.motion == 2;
            let centre = match (centre, radius) {
                ([Some(i), Some(j)], None) => [start.x + i, start.y + j],
                ([None, None], Some(r)) => {
                    // ≤ 180° for CR > 0: the centre to the right of the chord for G2,
                    // to the left for G3.
                    let (a, b) = (start.xy(), end.xy());
                    let chord = b - a;
                    let half = chord.norm() / 2.0;
                    let h = (r * r - half * half).max(0.0).sqrt();
                    let right = nalgebra::Vector2::new(chord.y, -chord.x) / chord.norm();
                    let side = if clockwise == (r > 0.0) { 1.0 } else { -1.0 };
                    let c = (a + b) / 2.0 + right * h * side;
                    [c.x, c.y]
                }
                other => panic!("an arc with {other:?}"),
            };
            ArcPath { centre, clockwise }
        });
        assert!(
            arc.is_some() || (centre == [None, None] && radius.is_none()),
            "I J CR without an arc"
        );
        let mut s = if self.tcp {
            self.tip = end;
            self.q = self.setup.linear_axes(end, rot[0], rot[1], self.length);
            let mut s = step(Kind::Tcp, self.q, known);
            s.tip0 = start;
            s.tip1 = end;
            s.arc = arc;
            s
        } else if let Some(frame) = frame {
            self.q = self
                .setup
                .linear_axes(frame.part(end), rot[0], rot[1], self.length);
            let mut s = step(Kind::Plane, self.q, known);
            if arc.is_some() {
                // X Y Z on the arc in the plane's frame.
                s.tip0 = start;
                s.tip1 = end;
                s.arc = arc;
                s.frame = Some(frame);
            }
            s
        } else {
            let p = end + self.trans;
            self.q = [p.x, p.y, p.z, rot[0], rot[1]];
            let mut s = step(Kind::Axes, self.q, known);
            s.arc = arc.map(|a| ArcPath {
                centre: [a.centre[0] + self.trans.x, a.centre[1] + self.trans.y],
                ..a
            });
            s
        };
        if let Some(cycle) = self.mcall {
            // The cycle at the end of the block: down the plane's Z and back to RTP.
            let frame = frame.expect("MCALL outside a plane is not in these fixtures");
            assert!(!self.tcp && s.arc.is_none());
            let w = frame.words(self.setup.forward(self.q, self.length).0);
            self.q = self.setup.linear_axes(
                frame.part(Vector3::new(w.x, w.y, cycle.rtp)),
                self.q[3],
                self.q[4],
                self.length,
            );
            s.q1 = self.q;
            s.hole = Some(Hole {
                plane: frame,
                xy: [w.x, w.y],
                cycle,
            });
        }
        Some(s)
    }
}

/// Run a program as the control does: every line, with the step it makes.
fn run(setup: &Setup, program: &str) -> Vec<Rec> {
    let mut control = Control::new(setup);
    program
        .lines()
        .map(|line| {
            let (number, rest) = split_number(line);
            let (step, is_cycle) = control.line(&tokens(rest));
            Rec {
                number,
                text: rest.to_string(),
                step,
                is_cycle,
            }
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// The contract, evaluated.

/// What the evaluation measured.
#[derive(Debug, Default)]
struct Figures {
    /// Programmed block ends checked, and the largest tip distance (mm) in planes and under
    /// TRAORI, and in machine axes.
    ends: usize,
    end: f64,
    end_axes: f64,
    /// The largest tool direction error (rad) at block ends whose rotary words are written
    /// (machine axes and TRAORI, away from C's singular cone).
    end_direction: f64,
    /// The ends of the pieces nccomp inserted: how many, the largest tip distance (mm) from
    /// the programmed path, and the direction error there (rad).
    piece_ends: usize,
    piece_end: f64,
    piece_end_direction: f64,
    /// The largest tip distance from the programmed path (mm) sampled along the written
    /// moves at feed, and the most by which one exceeded the tolerance plus its floor.
    path: f64,
    path_excess: f64,
    /// Under TRAORI and in machine axes: the largest direction error along the path (rad),
    /// and its excess.
    path_direction: f64,
    path_direction_excess: f64,
    /// Pieces across the singular cone's edge (one end held, the other corrected): their
    /// direction is what the hold leaves, and is not checked; the largest seen there.
    edge_pieces: usize,
    edge_direction: f64,
    /// Blocks inserted, and moves split; arcs replaced by straight pieces and the pieces
    /// added; arcs written as arcs.
    inserted: usize,
    split: usize,
    arcs: usize,
    arc_inserted: usize,
    arcs_kept: usize,
    /// Holes drilled (MCALL), the largest distance (mm) of the real tip at a hole's
    /// bottom from the programmed bottom, and from the programmed hole's axis (across it)
    /// at the set-up clearance and along the stroke; the `MCALL CYCLE81` copies
    /// inserted.
    holes: usize,
    hole_bottom: f64,
    hole_clearance: f64,
    hole_axis: f64,
    /// The largest distance (mm) of the real tip at the written set-up clearance from the
    /// programmed point there.
    hole_level: f64,
    definitions: usize,
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

/// Where on the programmed move `step` (its parameter, from `from` on) the real tip `p`
/// of a written piece's end lies: the nearest point of the nominal path (for a move that
/// only turns the tool, by the rotary values `rot`).
fn place(setup: &Setup, step: &Step, from: f64, p: Vector3<f64>, rot: [f64; 2]) -> f64 {
    let tip = |s: f64| setup.forward(step.axes_at(setup, s), step.length).0;
    const GRID: usize = 256;
    let grid: Vec<f64> = (0..=GRID)
        .map(|j| from + (1.0 - from) * j as f64 / GRID as f64)
        .collect();
    let travel: f64 = grid
        .windows(2)
        .map(|w| (tip(w[1]) - tip(w[0])).norm())
        .sum();
    let cost = |s: f64| {
        if travel > 1e-6 {
            (tip(s) - p).norm()
        } else {
            let q = step.axes_at(setup, s);
            (q[3] - rot[0]).hypot(q[4] - rot[1])
        }
    };
    let best = (0..=GRID)
        .min_by(|&a, &b| cost(grid[a]).total_cmp(&cost(grid[b])))
        .unwrap();
    let (mut lo, mut hi) = (grid[best.saturating_sub(1)], grid[(best + 1).min(GRID)]);
    // Golden section.
    let g = (5f64.sqrt() - 1.0) / 2.0;
    for _ in 0..80 {
        let (a, b) = (hi - g * (hi - lo), lo + g * (hi - lo));
        if cost(a) < cost(b) {
            hi = b;
        } else {
            lo = a;
        }
    }
    0.5 * (lo + hi)
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
    for (i, rec) in nominal.iter().enumerate() {
        let line = i + 1;
        let Some(step) = rec.step.filter(|s| s.kind != Kind::Turn) else {
            // Lines that move nothing, and CYCLE800's turns, are written unchanged.
            assert_eq!(real[k].text, rec.text, "line {line} is written changed");
            assert_eq!(real[k].number, rec.number, "line {line}");
            if let (Some(a), Some(b)) = (rec.step, real[k].step) {
                assert!(
                    (3..5).all(|j| (a.q1[j] - b.q1[j]).abs() < 1e-9),
                    "line {line}: the control turns the rotary axes elsewhere"
                );
            }
            k += 1;
            continue;
        };
        if !step.known {
            // Where an axis the program has not set stands is not known (SUPA without
            // work offsets): nccomp keeps the block.
            let w = &real[k];
            assert_eq!(w.text, rec.text, "line {line}: a move with an unknown axis");
            assert!(w.step.is_some_and(|s| !s.known && s.kind == step.kind));
            k += 1;
            continue;
        }
        let (target, target_o) = setup.forward(step.q1, step.length);
        // The written pieces of this move, then its own line.
        let mut pieces: Vec<Step> = Vec::new();
        loop {
            let w = real
                .get(k)
                .unwrap_or_else(|| panic!("line {line} is missing from the output"));
            k += 1;
            if step.hole.is_some() && w.step.is_none() && w.is_cycle {
                // A copy of the MCALL inserted before the hole: the cycle in force.
                assert_eq!(w.number, None, "line {line}: a numbered copy of the MCALL");
                f.definitions += 1;
                continue;
            }
            let s = w.step.unwrap_or_else(|| {
                panic!(
                    "line {line}: the output has `{}` where the program moves",
                    w.text
                )
            });
            assert_eq!(s.kind, step.kind, "line {line}: {}", w.text);
            assert!(s.known, "line {line}: {}", w.text);
            pieces.push(s);
            if step.hole.is_some() {
                // The hole's block is written as one block; where it ends is the cycle's.
                assert!(s.hole.is_some(), "line {line}: `{}` drills no hole", w.text);
                break;
            }
            if line_by_line || (actual(s.q1, s.length).p - target).norm() <= MATCH {
                assert_eq!(w.number, rec.number, "line {line}: {}", w.text);
                break;
            }
            assert!(
                !step.rapid && pieces.len() < 2000,
                "line {line}: no written block ends where it does (or a rapid was split): `{}` ends {:.3} µm off",
                w.text,
                (actual(s.q1, s.length).p - target).norm() * 1e3
            );
        }
        let own = pieces.last().unwrap();
        if step.arc.is_some() {
            if own.arc.is_some() {
                assert_eq!(pieces.len(), 1, "line {line}: an arc kept after pieces");
                f.arcs_kept += 1;
            } else {
                assert!(pieces.len() > 1, "line {line}: an arc as one straight move");
                assert!(pieces.iter().all(|p| p.arc.is_none()));
                f.arcs += 1;
                f.arc_inserted += pieces.len() - 1;
            }
        } else if pieces.len() > 1 {
            assert!(pieces.iter().all(|p| p.arc.is_none()));
            f.inserted += pieces.len() - 1;
            f.split += 1;
        }
        if let (Some(programmed_hole), Some(written_hole)) = (step.hole, own.hole) {
            // The hole: its bottom, and its axis at the set-up clearance and along the
            // stroke. The positioning (G0) is not checked, nor where the cycle leaves the
            // tool (RTP).
            let (p, w) = (programmed_hole.cycle, written_hole.cycle);
            assert_eq!(
                (p.rtp, p.sdis, p.dp.is_some(), p.dpr),
                (w.rtp, w.sdis, w.dp.is_some(), w.dpr),
                "line {line}: the copy changes more than the depth"
            );
            let tip = |h: &Hole, level: f64| h.plane.part(Vector3::new(h.xy[0], h.xy[1], level));
            let real_tip = |level: f64| {
                let q =
                    setup.linear_axes(tip(&written_hole, level), own.q1[3], own.q1[4], own.length);
                actual(q, own.length).p
            };
            let bottom = (real_tip(w.depth()) - tip(&programmed_hole, p.depth())).norm();
            // The programmed hole's axis: through its point at the set-up clearance, along
            // the plane's Z. Off it (across) and along it.
            let top = tip(&programmed_hole, p.clearance());
            let n = programmed_hole.plane.r * Vector3::z();
            let across = |at: Vector3<f64>| {
                let d = at - top;
                (d - n * d.dot(&n)).norm()
            };
            let clearance = across(real_tip(w.clearance()));
            let axis = (0..=SAMPLES)
                .map(|j| {
                    let v = j as f64 / SAMPLES as f64;
                    across(real_tip(w.clearance() + (w.depth() - w.clearance()) * v))
                })
                .fold(0.0, f64::max);
            // Where the feed starts along the axis (tests/heidenhain.rs's measure: the
            // distance from the programmed point at the set-up clearance).
            let level = (real_tip(w.clearance()) - top).norm();
            f.holes += 1;
            f.hole_bottom = f.hole_bottom.max(bottom);
            f.hole_clearance = f.hole_clearance.max(clearance);
            f.hole_axis = f.hole_axis.max(axis);
            f.hole_level = f.hole_level.max(level);
            if bottom > END {
                f.fault(format!(
                    "line {line}: the hole's bottom is {:.3} µm off",
                    bottom * 1e3
                ));
            }
            if clearance > tol.position || axis > tol.position {
                f.fault(format!(
                    "line {line}: the hole's axis is {:.3} µm off at the set-up clearance, up to {:.3} µm along the stroke",
                    clearance * 1e3,
                    axis * 1e3
                ));
            }
            if level > tol.position {
                f.fault(format!(
                    "line {line}: the set-up clearance ({}) is {:.3} µm off the programmed point ({:.3} µm along the axis)",
                    if w.dp.is_some() { "DP" } else { "DPR" },
                    level * 1e3,
                    (real_tip(w.clearance()) - top).dot(&n) * 1e3
                ));
            }
            continue;
        }
        // The block end.
        let real_end = actual(own.q1, own.length);
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
                "line {line}: the block end is {:.3} µm off",
                off * 1e3
            ));
        }
        // (Under a plane the rotary axes stand where CYCLE800 turned them: the direction
        // is not corrected there.)
        if step.kind != Kind::Plane && step.q1[3].abs() > SINGULAR_TILT {
            let d = angle_between(&real_end.o, &target_o);
            f.end_direction = f.end_direction.max(d);
            if d > END_DIRECTION {
                f.fault(format!(
                    "line {line}: the tool direction at the block end is {:.2} µrad off",
                    d * 1e6
                ));
            }
        }
        if step.rapid {
            continue;
        }
        // The path of the move at feed: each written piece against the programmed block's
        // path between the places where the piece starts and ends (under TRAORI the tip
        // on its line or arc and the rotary values in proportion, in a plane X Y Z in
        // proportion in its frame, in machine axes the axis values in proportion).
        let nominal_at = |s: f64| {
            let q = step.axes_at(setup, s);
            let (p, o) = setup.forward(q, step.length);
            (p, o, q[3])
        };
        let mut s0 = 0.0;
        for (j, piece) in pieces.iter().enumerate() {
            let last = j + 1 == pieces.len();
            let s1 = if last {
                1.0
            } else {
                place(
                    setup,
                    &step,
                    s0,
                    actual(piece.q1, piece.length).p,
                    [piece.q1[3], piece.q1[4]],
                )
            };
            // A piece across the singular cone's edge (3° of tilt): C goes from held to
            // corrected within it; nccomp swings it across with the tip kept on the path
            // and the direction left as the hold leaves it (`Kinematics::transition`; the
            // summary reports the direction error left at singular poses). Its tip is
            // held to the tolerance, its direction only measured (`edge_direction`).
            let check_direction = step.kind != Kind::Plane;
            let edge = check_direction
                && (nominal_at(s0).2.abs() > SINGULAR_TILT)
                    != (nominal_at(s1).2.abs() > SINGULAR_TILT);
            let dev = |u: f64| {
                let (p, o, t) = nominal_at(s0 + (s1 - s0) * u);
                let real = actual(piece.axes_at(setup, u), piece.length);
                let dd = if check_direction && t.abs() > SINGULAR_TILT {
                    angle_between(&real.o, &o)
                } else {
                    0.0
                };
                ((real.p - p).norm(), dd)
            };
            if !last {
                // An inserted block's end: on the programmed path, as a block end.
                let (dp, dd) = dev(1.0);
                f.piece_ends += 1;
                f.piece_end = f.piece_end.max(dp);
                let bound = if step.kind == Kind::Axes {
                    END_AXES
                } else {
                    END
                };
                if dp > bound {
                    f.fault(format!(
                        "line {line}: piece {} ends {:.3} µm off the path",
                        j + 1,
                        dp * 1e3
                    ));
                }
                if !edge {
                    f.piece_end_direction = f.piece_end_direction.max(dd);
                    if dd > END_DIRECTION {
                        f.fault(format!(
                            "line {line}: piece {} ends with the tool {:.2} µrad off",
                            j + 1,
                            dd * 1e6
                        ));
                    }
                }
            }
            let (p0, d0) = dev(0.0);
            let (p1, d1) = dev(1.0);
            let (floor, floor_d) = (p0 + p1, d0 + d1);
            if edge {
                f.edge_pieces += 1;
            }
            for m in 0..=SAMPLES {
                let (dp, dd) = dev(m as f64 / SAMPLES as f64);
                f.path = f.path.max(dp);
                let excess = dp - (tol.position + floor);
                f.path_excess = f.path_excess.max(excess);
                let excess_d = if edge {
                    f.edge_direction = f.edge_direction.max(dd);
                    0.0
                } else {
                    f.path_direction = f.path_direction.max(dd);
                    dd - (tol.direction + floor_d)
                };
                f.path_direction_excess = f.path_direction_excess.max(excess_d);
                if excess > 0.0 || excess_d > 0.0 {
                    f.fault(format!(
                        "line {line}: piece {} strays {:.3} µm, {:.2} µrad (floor {:.3} µm, {:.2} µrad)",
                        j + 1,
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
    assert_eq!(k, real.len(), "the output has lines after the program's");
    f
}

/// The block numbers of the written program never go down (inserted blocks take the
/// numbers after the block before them, arc pieces the arc's, MCALL copies none).
fn assert_numbers_rise(name: &str, program: &str) {
    let mut last = 0;
    for (i, line) in program.lines().enumerate() {
        if let (Some(n), _) = split_number(line) {
            assert!(n >= last, "{name}:{}: N{n} after N{last}", i + 1);
            last = n;
        }
    }
}

fn compensate(setup: &Setup, program: &str, name: &str) -> (String, Summary) {
    let comp = Compensator::new(&setup.machine, &setup.errors, cli_options()).unwrap();
    let mut out = Vec::new();
    let summary = comp
        .run(program.as_bytes(), name, &mut out)
        .unwrap_or_else(|e| panic!("{name} is refused: {e}"));
    (String::from_utf8(out).unwrap(), summary)
}

/// One fixture through nccomp and the independent evaluation; the rotary positions of
/// its CYCLE800 planes (the control's, closed form here).
fn check_fixture(program: &str) -> Vec<(usize, [f64; 2])> {
    let setup = ac_trunnion();
    let src = fixture(program);
    let (written, summary) = compensate(&setup, &src, program);
    assert_numbers_rise(program, &written);
    // The rotary positions of each plane: the control's (closed form here) and nccomp's
    // report agree.
    let recs = run(&setup, &src);
    let mut planes = Vec::new();
    for (i, rec) in recs.iter().enumerate() {
        let Some(step) = rec.step.filter(|s| s.kind == Kind::Turn) else {
            continue;
        };
        let line = i + 1;
        let (_, reported) = summary
            .plane_positions
            .iter()
            .find(|(l, _)| *l == line)
            .unwrap_or_else(|| panic!("{program}:{line}: no plane position reported"));
        eprintln!(
            "{program}:{line}: CYCLE800 turns to A{:.6} C{:.6}; nccomp reports {reported:?}",
            step.q1[3], step.q1[4]
        );
        assert_eq!(reported.len(), 2, "{program}:{line}: {reported:?}");
        for (name, value) in [("A", step.q1[3]), ("C", step.q1[4])] {
            let (_, r) = reported
                .iter()
                .find(|(n, _)| n == name)
                .unwrap_or_else(|| panic!("{program}:{line}: no {name} in {reported:?}"));
            assert!(
                same_angle(*r, value, 1e-6),
                "{program}:{line}: nccomp turns {name} to {r}, the control to {value}"
            );
        }
        planes.push((line, [step.q1[3], step.q1[4]]));
    }
    assert_eq!(planes.len(), summary.plane_positions.len(), "{program}");
    // As programmed, the real machine misses: the evaluation can fail.
    let before = evaluate(&setup, &src, &src);
    assert!(
        before.end.max(before.end_axes) > 20.0 * END,
        "{program}: uncompensated block ends only {:.3} µm off",
        before.end.max(before.end_axes) * 1e3
    );
    let f = evaluate(&setup, &src, &written);
    eprintln!(
        "{program}: {} block ends within {:.3} µm in planes and under TRAORI, {:.3} µm in machine axes (as programmed {:.3} µm, {:.3} µm); direction at written rotary words within {:.2} µrad (as programmed {:.2} µrad)",
        f.ends,
        f.end * 1e3,
        f.end_axes * 1e3,
        before.end * 1e3,
        before.end_axes * 1e3,
        f.end_direction * 1e6,
        before.end_direction * 1e6,
    );
    eprintln!(
        "{program}: {} inserted block ends within {:.3} µm of the path, the tool within {:.2} µrad; path within {:.3} µm (tolerance {:.3} µm plus floor, worst excess {:.3} µm), direction within {:.2} µrad (worst excess {:.2} µrad); {} pieces across the singular cone's edge (direction there up to {:.2} µrad, not checked)",
        f.piece_ends,
        f.piece_end * 1e3,
        f.piece_end_direction * 1e6,
        f.path * 1e3,
        cli_options().path.unwrap().position * 1e3,
        f.path_excess * 1e3,
        f.path_direction * 1e6,
        f.path_direction_excess * 1e6,
        f.edge_pieces,
        f.edge_direction * 1e6,
    );
    eprintln!(
        "{program}: {} moves split, {} blocks inserted; {} arcs replaced by {} pieces, {} kept; {} holes, bottoms within {:.3} µm, off the axis at the set-up clearance within {:.3} µm and along the stroke within {:.3} µm, the set-up clearance {:.3} µm off the programmed point; {} MCALL copies inserted; {} planes",
        f.split,
        f.inserted,
        f.arcs,
        f.arc_inserted + f.arcs,
        f.arcs_kept,
        f.holes,
        f.hole_bottom * 1e3,
        f.hole_clearance * 1e3,
        f.hole_axis * 1e3,
        f.hole_level * 1e3,
        f.definitions,
        planes.len(),
    );
    let calls = recs
        .iter()
        .filter(|r| r.step.is_some_and(|s| s.hole.is_some()))
        .count();
    assert_eq!(f.holes, calls, "{program}: every hole is evaluated");
    assert_eq!(
        (f.inserted, f.split, f.arc_inserted, f.arcs, f.arcs_kept),
        (
            summary.blocks_added,
            summary.moves_split,
            summary.arc_blocks_added,
            summary.arcs,
            summary.arcs_kept
        ),
        "{program}: the summary counts other splits"
    );
    assert!(
        f.faults.is_empty(),
        "{program}:\n{}\n{written}",
        f.faults.join("\n")
    );
    planes
}

// ---------------------------------------------------------------------------------------
// The tests.

const FIXTURES: [&str; 4] = [
    "840d_ac_trunnion_traori.mpf",
    "840d_ac_trunnion_swivel.mpf",
    "840d_variables.mpf",
    "840d_ac_trunnion_swivel_arcs.mpf",
];

#[test]
fn a_traori_program_meets_the_contract() {
    let planes = check_fixture(FIXTURES[0]);
    assert!(planes.is_empty());
}

#[test]
fn a_cycle800_program_with_holes_meets_the_contract() {
    let planes = check_fixture(FIXTURES[1]);
    // By hand: CYCLE800 mode 57, A-30 B0 C45: R = Rx(-30)·Rz(45), the normal
    // (0, sin 30, cos 30): A∓30; _DIR -1 takes A-30, C 0 (mod 360). Mode 27, A90 B-20 C0:
    // R = Rz(90)·Ry(-20), the normal (0, -sin 20, cos 20): A-20, C 180.
    let expected = [(8, [-30.0, 0.0]), (21, [-20.0, 180.0])];
    assert_eq!(planes.len(), expected.len());
    for ((line, [a, c]), (want_line, [wa, wc])) in planes.iter().zip(expected) {
        assert_eq!(*line, want_line);
        assert!(
            (a - wa).abs() < 1e-9 && same_angle(*c, wc, 1e-9),
            "{line}: A{a} C{c}"
        );
    }
}

#[test]
fn a_program_with_variables_meets_the_contract() {
    let planes = check_fixture(FIXTURES[2]);
    assert!(planes.is_empty());
}

/// Arcs in a CYCLE800 plane (I J and CR=, a helical entry, corners, wide arcs) are the
/// control's arcs in the plane's frame: kept as arcs where that stays within the path
/// tolerance, straight pieces otherwise, both kinds here.
#[test]
fn arcs_in_a_cycle800_plane_meet_the_contract() {
    let planes = check_fixture(FIXTURES[3]);
    assert_eq!(planes.len(), 1);
    let setup = ac_trunnion();
    let src = fixture(FIXTURES[3]);
    let (written, summary) = compensate(&setup, &src, FIXTURES[3]);
    assert!(
        summary.arcs_kept >= 4 && summary.arcs >= 2,
        "{} kept, {} replaced",
        summary.arcs_kept,
        summary.arcs
    );
    // The evaluation follows a kept arc along its way: its centre moved by 10 µm, its end
    // kept, takes it off the path between its ends.
    let kept = written
        .lines()
        .position(|l| l.starts_with("N140 G3 "))
        .expect("a kept corner arc with its I J");
    let broken: Vec<String> = written
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i != kept {
                return l.to_string();
            }
            let (head, j) = l.split_once(" J").unwrap();
            let value: f64 = j.parse().unwrap();
            format!("{head} J{:.4}", value + 0.01)
        })
        .collect();
    let f = evaluate(&setup, &src, &(broken.join("\n") + "\n"));
    assert!(
        f.faults.iter().any(|t| t.contains("strays")),
        "{:?}",
        f.faults
    );
}

#[test]
fn with_the_zero_model_each_fixture_comes_back_byte_for_byte() {
    for program in FIXTURES {
        let mut setup = ac_trunnion();
        setup.errors = ErrorModel::zero(&setup.machine);
        let src = fixture(program);
        let (out, summary) = compensate(&setup, &src, program);
        assert!(summary.zero_model, "{program}");
        assert_eq!(out, src, "{program}");
    }
}

/// The interpreter reads the fixtures' values as the notes say: expressions, variables,
/// wrappers, arcs.
#[test]
fn the_interpreter_reads_the_fixtures_words() {
    let setup = ac_trunnion();
    let steps = |name: &str| -> Vec<(usize, Step)> {
        run(&setup, &fixture(name))
            .iter()
            .enumerate()
            .filter_map(|(i, r)| r.step.map(|s| (i + 1, s)))
            .collect()
    };
    let at =
        |steps: &[(usize, Step)], line: usize| steps.iter().find(|(l, _)| *l == line).unwrap().1;
    let traori = steps(FIXTURES[0]);
    // N110 X=30+10 … C=DC(48) from C35; N120's arc about (40, 22.5) from (40, 12.5) to
    // (50, 22.5) clockwise, 270°: a third of the way (90°) the tip is at (30, 22.5), Z
    // staying at -1.5; N130 C=ACP(75) from C60.
    let n110 = at(&traori, 14);
    assert_eq!((n110.tip1.x, n110.q1[4]), (40.0, 48.0));
    let n120 = at(&traori, 15);
    let mid = arc_point(n120.tip0, n120.tip1, n120.arc.as_ref().unwrap(), 1.0 / 3.0);
    assert!(
        (mid - Vector3::new(30.0, 22.5, -1.5)).norm() < 1e-12,
        "{mid}"
    );
    assert_eq!(at(&traori, 16).q1[4], 75.0);
    let vars = steps(FIXTURES[2]);
    // N90 X=R1 Y=R2 Z=_SAFE; N100 Z=_DEPTH; N120 G2 CR=10 from (30, 20) to (40, 30):
    // centre (40, 20); N130 G3 I=10 J=0 from there: centre (50, 30); N140 G91 X5 Y=IC(-3).
    assert_eq!(&at(&vars, 12).q1[..3], &[10.0, 20.0, 50.0]);
    assert_eq!(at(&vars, 13).q1[2], -2.5);
    let n120 = at(&vars, 15);
    assert!(n120.arc.unwrap().clockwise);
    let [cx, cy] = n120.arc.unwrap().centre;
    assert!((cx - 40.0).abs() < 1e-12 && (cy - 20.0).abs() < 1e-12);
    assert_eq!(at(&vars, 16).arc.unwrap().centre, [50.0, 30.0]);
    assert_eq!(&at(&vars, 17).q1[..2], &[55.0, 17.0]);
    assert_eq!(&at(&vars, 18).q1[..3], &[60.0, 17.0, -3.5]);
    // The swivel: the second plane's zero at R·(10, 0, 5) (_X1 _Y1 _Z1), then TRANS X5 Y5
    // and AROT RPL=15 inside it: N210 X0 Y0 Z25 is the tip at R·(10, 0, 5) + R·(5, 5, 25),
    // N230 X20 Y0 (Z1) at R·(10, 0, 5) + R·((5, 5, 0) + Rz(15)·(20, 0, 1)); T2 M6 … D1
    // takes T2's length, 120 mm.
    let swivel = steps(FIXTURES[1]);
    let n210 = at(&swivel, 24);
    let r = rz(90.0) * ry(-20.0);
    let want = r * Vector3::new(10.0, 0.0, 5.0) + r * Vector3::new(5.0, 5.0, 25.0);
    assert!((setup.forward(n210.q1, 120.0).0 - want).norm() < 1e-9);
    let n230 = at(&swivel, 26);
    let want = r * Vector3::new(10.0, 0.0, 5.0)
        + r * (Vector3::new(5.0, 5.0, 0.0) + rz(15.0) * Vector3::new(20.0, 0.0, 1.0));
    assert!((setup.forward(n230.q1, 120.0).0 - want).norm() < 1e-9);
}

#[test]
fn the_closed_forms_are_the_machines_nominal_kinematics() {
    let setup = ac_trunnion();
    let kin = Kinematics::new(&setup.machine, &ErrorModel::zero(&setup.machine), 0).unwrap();
    let mut state = 11u64;
    let mut rnd = |s: f64| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (2.0 * ((state >> 11) as f64 / (1u64 << 53) as f64) - 1.0) * s
    };
    let mut lengths: Vec<f64> = setup.machine.tool.lengths.values().copied().collect();
    lengths.extend([setup.machine.tool.length, 0.0]);
    for length in lengths {
        for _ in 0..20 {
            let q = [rnd(200.0), rnd(200.0), rnd(200.0), rnd(100.0), rnd(400.0)];
            let (p, o) = setup.forward(q, length);
            let (pose, _) = kin.pose(Model::Nominal, &setup.vars(&kin, q), length);
            assert!(
                (pose.p - p).norm() < 1e-9 && (pose.o - o).norm() < 1e-12,
                "{q:?}"
            );
            let back = setup.linear_axes(p, q[3], q[4], length);
            assert!((0..5).all(|k| (back[k] - q[k]).abs() < 1e-9), "{q:?}");
            // The closed-form plane solution points the tool along the normal.
            let n = setup.direction(q[3], q[4]);
            if q[3].abs() > 1.0 && (-120.0..=30.0).contains(&-q[3].abs()) {
                let [t, c] = setup.plane_rotaries(n, q[4] + 30.0, false);
                assert!((setup.direction(t, c) - n).norm() < 1e-12);
                assert!(t < 0.0);
                assert!((c - q[4] - 30.0).abs() <= 180.0 + 1e-9);
            }
        }
    }
}

//! A differential fuzz campaign: mutated fixture programs, generated
//! programs and windows of the ISO corpus (../shared/corpus, when it is there) are
//! compensated on the AC trunnion through the library (`Compensator::run`, the command
//! line's options); every output nccomp accepts is judged here by an evaluation that
//! shares nothing with the pass or its verification gate: the written text and the
//! original are read by this file's own interpreter of machine-axis ISO G-code (as the
//! control reads them, in both block-delete states where the program has `/` blocks), the
//! nominal machine is taken at the original's axis values and the real machine (the
//! contract's error model, through `Kinematics` for poses only) along the control's
//! interpolation of the written words. Every block end, and the quarter points of every
//! written feed move (straight or arc, the arc swept as G2/G3 command it), must lie within
//! the path tolerance (1 µm) plus the words' rounding of the original's nominal path.
//!
//! What the interpreter does not follow (TCP, working planes, rotations, cycles,
//! parameters, inch, …) leaves an output "not judged" and counted. Axes follow the
//! contract's rule: unknown at the start (but for the machine file's `[start]`), after
//! G28/G30/G53 and, for Z, after a tool change (M6); a rapid at unknown axes must pass
//! unchanged, a feed move touching one must have been refused.
//!
//! The defects it found are pinned by tests at the end; a kind found and not yet fixed is
//! listed in `KNOWN`, counted and reported without failing (`NCCOMP_DIFF_STRICT=1` fails on
//! it too). The programs the gate refuses are also run
//! through the pass without its gate and judged, to show what the gate catches and where
//! it refuses an output this judge finds on the path.
//!
//!     cargo test --test differential -- --nocapture
//!
//! `NCCOMP_DIFF_MUTANTS` sets the number of mutants (default 3000), `NCCOMP_DIFF_SEED` the
//! sequence.

mod common;

use common::Lcg;
use common::contract::{cli_options, root};
use nalgebra::Vector3;
use nccomp::compensate::{Compensator, Options};
use nccomp::kinematics::{Kinematics, Model};
use nccomp::model::{ErrorModel, Machine, error_file, machine_file};
use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::time::Instant;

/// Block ends and mid-path: the path tolerance (1 µm) plus the words' rounding (0.0001 mm
/// on three axes).
const TOL: f64 = 1.0e-3 + 1.1e-4;
/// The axes of the AC trunnion in the order this file keeps them.
const AXES: [char; 5] = ['X', 'Y', 'Z', 'A', 'C'];
/// The in-plane axes (first, second) of G17, G18, G19: X Y, Z X, Y Z.
const PLANES: [[usize; 2]; 3] = [[0, 1], [2, 0], [1, 2]];
/// The centre words (indices into I J K) of the same.
const CENTRES: [[usize; 2]; 3] = [[0, 1], [2, 0], [1, 2]];

// ---------------------------------------------------------------------------------------
// The test's own reader: machine-axis ISO G-code as a control runs it.

#[derive(Clone, Copy, Debug, PartialEq)]
enum Motion {
    Rapid,
    Line,
    Cw,
    Ccw,
}

type Q = [Option<f64>; 5];

#[derive(Clone, Debug)]
struct Arc {
    plane: usize,
    centre: [f64; 2],
    theta0: f64,
    sweep: f64,
    r0: f64,
    r1: f64,
}

#[derive(Clone, Debug)]
struct Move {
    /// Line index (0-based) in its text.
    line: usize,
    motion: Motion,
    start: Q,
    end: Q,
    arc: Option<Arc>,
    length: f64,
    /// In an optional block (`/`).
    optional: bool,
    /// The block's axis words as written.
    words: Q,
    /// Whether an axis the move needs is unknown because a tool change sent it away (and
    /// nothing else made it unknown).
    after_tool_change: bool,
}

fn known(q: &Q) -> Option<[f64; 5]> {
    let mut v = [0.0; 5];
    for k in 0..5 {
        v[k] = q[k]?;
    }
    Some(v)
}

impl Move {
    /// The axis values a fraction `s` along the move as the control interpolates it.
    fn at(&self, s: f64) -> [f64; 5] {
        let a = known(&self.start).expect("known start");
        let b = known(&self.end).expect("known end");
        let mut q = [0.0; 5];
        for k in 0..5 {
            q[k] = a[k] + (b[k] - a[k]) * s;
        }
        if let Some(arc) = &self.arc {
            let [u, v] = PLANES[arc.plane];
            let th = arc.theta0 + arc.sweep * s;
            let r = arc.r0 + (arc.r1 - arc.r0) * s;
            q[u] = arc.centre[0] + r * th.cos();
            q[v] = arc.centre[1] + r * th.sin();
        }
        q
    }
}

#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
enum Step {
    Move(Move),
    /// G28, G30 or G53 with axis words: left as written, its axes unknown afterwards.
    Special {
        line: usize,
        code: i64,
        words: Vec<(char, f64)>,
    },
}

/// The words of a block (comments and `;` removed): letter and value.
fn words(body: &str) -> Result<Vec<(char, f64)>, String> {
    let b = body.as_bytes();
    let mut out = Vec::new();
    let mut i = 0;
    while i < b.len() {
        let c = b[i] as char;
        if c.is_ascii_whitespace() {
            i += 1;
        } else if c == '(' {
            match body[i..].find(')') {
                Some(p) => i += p + 1,
                None => return Err("unclosed comment".into()),
            }
        } else if c == ';' {
            break;
        } else if c.is_ascii_alphabetic() {
            let start = i + 1;
            let mut j = start;
            if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
                j += 1;
            }
            let digits = j;
            while j < b.len() && (b[j].is_ascii_digit() || b[j] == b'.') {
                j += 1;
            }
            if !body[digits..j].bytes().any(|d| d.is_ascii_digit()) {
                return Err(format!("letter {c} without a number"));
            }
            let v: f64 = body[start..j]
                .parse()
                .map_err(|_| format!("number {}", &body[start..j]))?;
            out.push((c.to_ascii_uppercase(), v));
            i = j;
        } else {
            return Err(format!("character {c:?}"));
        }
    }
    Ok(out)
}

struct Tools {
    reference: f64,
    lengths: BTreeMap<u32, f64>,
    /// Where the axes stand when a program starts (machine file `[start]`).
    start: Q,
}

#[allow(clippy::too_many_arguments)]
fn arc(
    motion: Motion,
    plane: usize,
    a: [f64; 5],
    b: [f64; 5],
    ijk: [Option<f64>; 3],
    r: Option<f64>,
    centre_absolute: bool,
) -> Result<Arc, String> {
    let [u, v] = PLANES[plane];
    let (su, sv, eu, ev) = (a[u], a[v], b[u], b[v]);
    let ccw = motion == Motion::Ccw;
    let centre = if let Some(r) = r {
        let (dx, dy) = (eu - su, ev - sv);
        let d = dx.hypot(dy);
        if d < 1e-9 {
            return Err("R arc ending where it starts".into());
        }
        let h2 = r * r - d * d / 4.0;
        if h2 < -1e-6 * r.abs().max(1.0) {
            return Err("R smaller than half the chord (the control alarms)".into());
        }
        let h = h2.max(0.0).sqrt();
        let (nx, ny) = (-dy / d, dx / d);
        let sign = if ccw == (r > 0.0) { 1.0 } else { -1.0 };
        [
            (su + eu) / 2.0 + sign * h * nx,
            (sv + ev) / 2.0 + sign * h * ny,
        ]
    } else {
        let [cu, cv] = CENTRES[plane];
        let (iu, iv) = (ijk[cu].unwrap_or(0.0), ijk[cv].unwrap_or(0.0));
        if centre_absolute {
            [iu, iv]
        } else {
            [su + iu, sv + iv]
        }
    };
    let r0 = (su - centre[0]).hypot(sv - centre[1]);
    let r1 = (eu - centre[0]).hypot(ev - centre[1]);
    if r0 < 1e-9 || r1 < 1e-9 {
        return Err("arc of radius 0".into());
    }
    if (r0 - r1).abs() > 2e-3_f64.max(1e-6 * r0) {
        return Err("arc whose end is not on its circle (the control alarms)".into());
    }
    let theta0 = (sv - centre[1]).atan2(su - centre[0]);
    let theta1 = (ev - centre[1]).atan2(eu - centre[0]);
    let sweep = if ccw {
        let d = (theta1 - theta0).rem_euclid(TAU);
        if d <= 1e-12 { TAU } else { d }
    } else {
        let d = -(theta0 - theta1).rem_euclid(TAU);
        if d >= -1e-12 { -TAU } else { d }
    };
    Ok(Arc {
        plane,
        centre,
        theta0,
        sweep,
        r0,
        r1,
    })
}

/// The motion of `text` with block delete on (`/` blocks skipped) or off. An error: a
/// construct this reader does not follow.
fn read(text: &str, block_delete: bool, tools: &Tools) -> Result<Vec<Step>, String> {
    let mut steps = Vec::new();
    let mut q: Q = tools.start;
    // Why an axis is unknown: sent away by a tool change (true) or anything else.
    let mut changed = [false; 5];
    let mut motion: Option<Motion> = None;
    let mut absolute = true;
    let mut plane = 0;
    let mut centre_absolute = false;
    let mut length = tools.reference;
    let mut tool: Option<u32> = None;
    let mut offset: Option<i64> = None;
    for (i, raw) in text.split('\n').enumerate() {
        let line = raw.trim_end_matches('\r').trim_start();
        if line.is_empty() || line.starts_with('%') {
            continue;
        }
        let (optional, body) = match line.strip_prefix('/') {
            Some(rest) => (true, rest),
            None => (false, line),
        };
        if optional && block_delete {
            continue;
        }
        let at = |m: String| format!("line {}: {m}", i + 1);
        let ws = words(body).map_err(at)?;
        let mut gs = Vec::new();
        let mut ms = Vec::new();
        let mut axes: Q = [None; 5];
        let mut ijk = [None; 3];
        let (mut r, mut h, mut t) = (None, None, None);
        for &(letter, v) in &ws {
            match letter {
                'G' => gs.push((v * 10.0).round() as i64),
                'M' => ms.push((v * 10.0).round() as i64),
                'X' | 'Y' | 'Z' | 'A' | 'C' => {
                    let k = AXES.iter().position(|&a| a == letter).unwrap();
                    if axes[k].replace(v).is_some() {
                        return Err(at(format!("{letter} twice")));
                    }
                }
                'I' | 'J' | 'K' => ijk[(letter as u8 - b'I') as usize] = Some(v),
                'R' => r = Some(v),
                'H' => h = Some(v),
                'T' => t = Some(v),
                'N' | 'F' | 'S' | 'O' | 'D' | 'P' | 'Q' | 'L' => {}
                other => return Err(at(format!("word {other}"))),
            }
        }
        if let Some(t) = t {
            tool = Some(t as u32);
        }
        let mut special = None;
        let mut dwell = false;
        for &g in &gs {
            match g {
                0 => motion = Some(Motion::Rapid),
                10 => motion = Some(Motion::Line),
                20 => motion = Some(Motion::Cw),
                30 => motion = Some(Motion::Ccw),
                40 => dwell = true,
                170 => plane = 0,
                180 => plane = 1,
                190 => plane = 2,
                210 => {}
                900 => absolute = true,
                910 => absolute = false,
                901 => centre_absolute = true,
                911 => centre_absolute = false,
                280 | 300 | 530 => special = Some(g),
                281 | 301 => {
                    if axes.iter().any(Option::is_some) {
                        return Err(at("G28.1 with axis words".into()));
                    }
                }
                430 => {
                    let n = match (h, tool) {
                        (Some(h), _) => h as u32,
                        (None, Some(t)) => t,
                        (None, None) => return Err(at("G43 without H or T".into())),
                    };
                    length = *tools
                        .lengths
                        .get(&n)
                        .ok_or_else(|| at(format!("no length for tool {n}")))?;
                }
                490 => length = tools.reference,
                400 | 800 | 930 | 940 | 950 | 610 | 611 | 640 | 150 | 960 | 970 | 500 => {}
                540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => {
                    if offset.is_some_and(|o| o != g) {
                        return Err(at("a second work offset".into()));
                    }
                    offset = Some(g);
                }
                other => return Err(at(format!("G{}", other as f64 / 10.0))),
            }
        }
        let mut end = false;
        let mut tool_change = false;
        for &m in &ms {
            match m {
                20 | 300 | 990 => end = true,
                60 => tool_change = true,
                0 | 10 | 30 | 40 | 50 | 70 | 80 | 90 | 190 | 480..=530 | 620..=680 => {}
                other => return Err(at(format!("M{}", other as f64 / 10.0))),
            }
        }
        let has_axes = axes.iter().any(Option::is_some);
        let centred = ijk.iter().any(Option::is_some) || r.is_some();
        if dwell {
            if axes[1..].iter().any(Option::is_some) || centred {
                return Err(at("G4 with axis words".into()));
            }
        } else if let Some(code) = special {
            if centred {
                return Err(at("I/J/K/R in a G28/G53 block".into()));
            }
            if code == 530 && !has_axes {
                // G53 alone moves nothing.
            } else {
                let words = (0..5)
                    .filter_map(|k| axes[k].map(|v| (AXES[k], v)))
                    .collect();
                steps.push(Step::Special {
                    line: i,
                    code,
                    words,
                });
                for k in 0..5 {
                    if axes[k].is_some() || !has_axes {
                        q[k] = None;
                        changed[k] = false;
                    }
                }
            }
        } else if has_axes || (centred && matches!(motion, Some(Motion::Cw | Motion::Ccw))) {
            let Some(mode) = motion else {
                return Err(at("axis words before any motion code".into()));
            };
            let mut e = q;
            for k in 0..5 {
                if let Some(v) = axes[k] {
                    e[k] = if absolute {
                        Some(v)
                    } else {
                        q[k].map(|c| c + v)
                    };
                }
            }
            let arc = match mode {
                Motion::Cw | Motion::Ccw => {
                    if ijk.iter().any(Option::is_some) && r.is_some() {
                        return Err(at("arc with both I/J/K and R".into()));
                    }
                    if !centred {
                        return Err(at("arc without a centre".into()));
                    }
                    match (known(&q), known(&e)) {
                        (Some(a), Some(b)) => {
                            Some(arc(mode, plane, a, b, ijk, r, centre_absolute).map_err(at)?)
                        }
                        _ => None,
                    }
                }
                _ if centred => return Err(at("I/J/K/R outside an arc".into())),
                _ => None,
            };
            let unknown: Vec<usize> = (0..5)
                .filter(|&k| q[k].is_none() || e[k].is_none())
                .collect();
            steps.push(Step::Move(Move {
                line: i,
                optional,
                words: axes,
                motion: mode,
                start: q,
                end: e,
                arc,
                length,
                after_tool_change: !unknown.is_empty() && unknown.iter().all(|&k| changed[k]),
            }));
            q = e;
        } else if centred {
            return Err(at("I/J/K/R without a move".into()));
        }
        if tool_change {
            // The contract's default: a tool change sends the tool axis (Z) to the change
            // position, which the program does not know.
            q[2] = None;
            changed[2] = true;
        }
        if end {
            break;
        }
    }
    Ok(steps)
}

// ---------------------------------------------------------------------------------------
// The judge.

/// The defects the campaign has found, each pinned by an ignored test below: reported and
/// counted, but (unless `NCCOMP_DIFF_STRICT=1`) not failing the campaign until fixed.
const FEED_FROM_UNKNOWN: &str =
    "a feed move with an axis the program has not set was accepted (the contract refuses it)";
const TOOL_CHANGE_FEED: &str =
    "a feed move with Z unknown after a tool change was accepted (the contract refuses it)";
const TOOL_CHANGE_RAPID: &str = "a rapid with Z unknown after a tool change is given a Z word";
const OPTIONAL_RAPID: &str = "an optional rapid that sets unknown axes again is left uncorrected: with block delete off its end is off the nominal pose";
/// The kinds found and not yet fixed (none today): counted, not failing the campaign.
const KNOWN: &[&str] = &[];

struct Eval {
    kin: Kinematics,
    /// For each of nccomp's kinematic variables, the index into [X, Y, Z, A, C].
    map: Vec<usize>,
    tools: Tools,
}

impl Eval {
    fn new(machine: &Machine, errors: &ErrorModel) -> Eval {
        let kin = Kinematics::new(machine, errors, 0).unwrap();
        let map = kin
            .axes()
            .iter()
            .map(|&i| {
                let name = machine.axes[i].name.chars().next().unwrap();
                AXES.iter().position(|&a| a == name).unwrap()
            })
            .collect();
        Eval {
            kin,
            map,
            tools: Tools {
                reference: machine.tool.length,
                lengths: machine.tool.lengths.clone(),
                start: {
                    let mut q = [None; 5];
                    for &(i, v) in &machine.start {
                        let name = machine.axes[i].name.chars().next().unwrap();
                        q[AXES.iter().position(|&a| a == name).unwrap()] = Some(v);
                    }
                    q
                },
            },
        }
    }

    fn tip(&self, model: Model, q: [f64; 5], length: f64) -> (Vector3<f64>, Vector3<f64>) {
        let vars: Vec<f64> = self.map.iter().map(|&k| q[k]).collect();
        let (pose, _) = self.kin.pose(model, &vars, length);
        (pose.p, pose.o)
    }

    fn nominal(&self, m: &Move, t: f64) -> Vector3<f64> {
        self.tip(Model::Nominal, m.at(t), m.length).0
    }

    /// The distance of `p` (the real tip at written axis values `q`) from the nominal path
    /// of `m`.
    fn off_path(&self, m: &Move, q: [f64; 5], p: Vector3<f64>) -> f64 {
        let mut starts = Vec::new();
        if let Some(arc) = &m.arc {
            let [u, v] = PLANES[arc.plane];
            let th = (q[v] - arc.centre[1]).atan2(q[u] - arc.centre[0]);
            let a = if arc.sweep > 0.0 {
                (th - arc.theta0).rem_euclid(TAU)
            } else {
                (arc.theta0 - th).rem_euclid(TAU)
            };
            let t = a / arc.sweep.abs();
            starts.push(t.min(1.0));
            if t > 1.0 || t > 0.9 {
                starts.push(0.0);
            }
            starts.push(1.0);
        } else {
            let a = known(&m.start).unwrap();
            let b = known(&m.end).unwrap();
            let w = [1.0, 1.0, 1.0, 3.5, 3.5];
            let (mut num, mut den) = (0.0, 0.0);
            for k in 0..5 {
                let d = (b[k] - a[k]) * w[k];
                num += (q[k] - a[k]) * w[k] * d;
                den += d * d;
            }
            starts.push(if den > 0.0 {
                (num / den).clamp(0.0, 1.0)
            } else {
                0.5
            });
        }
        let mut best = f64::INFINITY;
        for t0 in starts {
            let mut t = t0;
            for _ in 0..6 {
                let h = 1e-5;
                let (ta, tb) = ((t - h).max(0.0), (t + h).min(1.0));
                let tangent = (self.nominal(m, tb) - self.nominal(m, ta)) / (tb - ta);
                let n2 = tangent.norm_squared();
                if n2 < 1e-24 {
                    break;
                }
                let dt = (p - self.nominal(m, t)).dot(&tangent) / n2;
                let next = (t + dt).clamp(0.0, 1.0);
                let done = (next - t).abs() < 1e-12;
                t = next;
                if done {
                    break;
                }
            }
            best = best.min((p - self.nominal(m, t)).norm());
        }
        best
    }
}

#[derive(Debug, Clone)]
struct Failure {
    kind: &'static str,
    block_delete: bool,
    original_line: usize,
    written_line: Option<usize>,
    deviation: f64,
}

#[derive(Default, Debug)]
struct Tally {
    ends: usize,
    mids: usize,
    worst_end: f64,
    worst_mid: f64,
    /// Tool direction at block ends away from the singular cone (|A| > 3°), rad.
    worst_direction: f64,
    /// Where: the original's line (0-based) and the program's index in the campaign.
    worst_direction_at: (usize, usize),
    program: usize,
    /// Rapids at unknown axes whose known words nccomp corrected (in the air; the contract
    /// says they pass unchanged).
    unknown_rapids_changed: usize,
    /// The first: the original's line (0-based) and the program's index.
    unknown_rapid_at: Option<(usize, usize)>,
    /// The same where the axis is unknown only because of a tool change.
    tool_change_rapids_changed: usize,
    /// Rapids written as feed moves or the reverse.
    motion_changed: usize,
}

fn has_optional(text: &str) -> bool {
    text.lines().any(|l| l.trim_start().starts_with('/'))
}

/// Judge `written` against `original`: `Ok(None)` not judged (the reason), `Ok(Some)`
/// passed, `Err` the first disagreement.
fn judge(
    eval: &Eval,
    original: &str,
    written: &str,
    tally: &mut Tally,
) -> Result<Result<(), String>, Failure> {
    let states: &[bool] = if has_optional(original) || has_optional(written) {
        &[false, true]
    } else {
        &[false]
    };
    let mut local = Tally {
        program: tally.program,
        ..Tally::default()
    };
    for &bd in states {
        let o = match read(original, bd, &eval.tools) {
            Ok(o) => o,
            Err(e) => return Ok(Err(e)),
        };
        let w = match read(written, bd, &eval.tools) {
            Ok(w) => w,
            Err(e) => return Ok(Err(format!("written: {e}"))),
        };
        compare(eval, &o, &w, bd, &mut local)?;
    }
    tally.ends += local.ends;
    tally.mids += local.mids;
    tally.worst_end = tally.worst_end.max(local.worst_end);
    tally.worst_mid = tally.worst_mid.max(local.worst_mid);
    if local.worst_direction > tally.worst_direction {
        tally.worst_direction = local.worst_direction;
        tally.worst_direction_at = (local.worst_direction_at.0, tally.program);
    }
    tally.unknown_rapids_changed += local.unknown_rapids_changed;
    if let Some((line, _)) = local.unknown_rapid_at {
        tally.unknown_rapid_at.get_or_insert((line, tally.program));
    }
    tally.tool_change_rapids_changed += local.tool_change_rapids_changed;
    tally.motion_changed += local.motion_changed;
    Ok(Ok(()))
}

fn compare(
    eval: &Eval,
    o: &[Step],
    w: &[Step],
    bd: bool,
    tally: &mut Tally,
) -> Result<(), Failure> {
    let fail = |kind, original_line, written_line, deviation| Failure {
        kind,
        block_delete: bd,
        original_line,
        written_line,
        deviation,
    };
    let line_of = |s: &Step| match s {
        Step::Move(m) => m.line,
        Step::Special { line, .. } => *line,
    };
    let mut j = 0;
    let mut last_end: Option<(Vector3<f64>, usize)> = None;
    for step in o {
        match step {
            Step::Special { line, code, words } => match w.get(j) {
                Some(Step::Special {
                    code: wc,
                    words: ww,
                    ..
                }) if wc == code && ww == words => j += 1,
                other => {
                    return Err(fail(
                        "a G28/G30/G53 block not left as written",
                        *line,
                        other.map(line_of),
                        f64::NAN,
                    ));
                }
            },
            Step::Move(mo) => {
                let feed = mo.motion != Motion::Rapid;
                let end = known(&mo.end);
                if feed && (end.is_none() || known(&mo.start).is_none()) {
                    return Err(fail(
                        if mo.after_tool_change {
                            TOOL_CHANGE_FEED
                        } else {
                            FEED_FROM_UNKNOWN
                        },
                        mo.line,
                        w.get(j).map(line_of),
                        f64::NAN,
                    ));
                }
                let Some(end) = end else {
                    // A rapid at unknown axes passes unchanged.
                    let Some(Step::Move(mw)) = w.get(j) else {
                        return Err(fail(
                            "a rapid at unknown axes has no written block",
                            mo.line,
                            w.get(j).map(line_of),
                            f64::NAN,
                        ));
                    };
                    let mut changed = 0.0f64;
                    for k in 0..5 {
                        match (mo.end[k], mw.end[k]) {
                            (None, None) => {}
                            (Some(_), Some(_)) => {
                                // Only the block's own words: the others are the earlier
                                // blocks' (corrected) values.
                                if let (Some(a), Some(b)) = (mo.words[k], mw.words[k]) {
                                    changed = changed.max((a - b).abs());
                                } else if mo.words[k].is_some() != mw.words[k].is_some() {
                                    changed = f64::INFINITY;
                                }
                            }
                            _ => {
                                return Err(fail(
                                    if mo.after_tool_change {
                                        TOOL_CHANGE_RAPID
                                    } else {
                                        "a rapid at unknown axes moves an axis the program left unknown (or leaves one unknown)"
                                    },
                                    mo.line,
                                    Some(mw.line),
                                    f64::NAN,
                                ));
                            }
                        }
                    }
                    if changed > 1e-9 {
                        if mo.after_tool_change {
                            tally.tool_change_rapids_changed += 1;
                        } else {
                            tally.unknown_rapids_changed += 1;
                            tally
                                .unknown_rapid_at
                                .get_or_insert((mo.line, tally.program));
                        }
                    }
                    j += 1;
                    continue;
                };
                let (nominal, direction) = eval.tip(Model::Nominal, end, mo.length);
                let zero = mo.start == mo.end;
                let mut best = (f64::INFINITY, None);
                let mut found = None;
                let mut i = j;
                while let Some(Step::Move(mw)) = w.get(i) {
                    let Some(we) = known(&mw.end) else { break };
                    let (real, o) = eval.tip(Model::Actual, we, mw.length);
                    let d = (real - nominal).norm();
                    if d < best.0 {
                        best = (d, Some(mw.line));
                    }
                    if d <= TOL {
                        found = Some((i, d, o));
                        break;
                    }
                    i += 1;
                }
                let Some((i, d, o)) = found else {
                    if zero {
                        continue;
                    }
                    // nccomp's documented reading: an optional G90 block does not make an
                    // unknown axis known again, so it passes unchanged; with block delete
                    // off it runs, and its end is a known pose left uncorrected.
                    let unchanged =
                        matches!(w.get(j), Some(Step::Move(mw)) if mw.words == mo.words);
                    return Err(fail(
                        if mo.optional && !feed && unchanged {
                            OPTIONAL_RAPID
                        } else {
                            "no written block ends at the original block's end"
                        },
                        mo.line,
                        best.1,
                        best.0,
                    ));
                };
                tally.ends += 1;
                tally.worst_end = tally.worst_end.max(d);
                let turned = (o - direction).norm();
                if end[3].abs() > 3.0 && turned > tally.worst_direction {
                    tally.worst_direction = turned;
                    tally.worst_direction_at = (mo.line, tally.program);
                }
                for (n, s) in w[j..=i].iter().enumerate() {
                    let Step::Move(mw) = s else { unreachable!() };
                    if !feed && j + n < i {
                        return Err(fail(
                            "a move inserted before a rapid",
                            mo.line,
                            Some(mw.line),
                            f64::NAN,
                        ));
                    }
                    if (mw.motion == Motion::Rapid) == feed {
                        if feed {
                            return Err(fail(
                                "a feed move written as a rapid",
                                mo.line,
                                Some(mw.line),
                                f64::NAN,
                            ));
                        }
                        tally.motion_changed += 1;
                    }
                    if !feed || zero {
                        continue;
                    }
                    if known(&mw.start).is_none() {
                        return Err(fail(
                            "a written feed move starts at unknown axes",
                            mo.line,
                            Some(mw.line),
                            f64::NAN,
                        ));
                    }
                    let piece = j + n < i;
                    for s in [0.25, 0.5, 0.75, 1.0] {
                        if s == 1.0 && !piece {
                            continue;
                        }
                        let q = mw.at(s);
                        let (p, _) = eval.tip(Model::Actual, q, mw.length);
                        let d = eval.off_path(mo, q, p);
                        tally.mids += 1;
                        tally.worst_mid = tally.worst_mid.max(d);
                        if d > TOL {
                            return Err(fail(
                                "the real path strays from the nominal one mid-move",
                                mo.line,
                                Some(mw.line),
                                d,
                            ));
                        }
                    }
                }
                last_end = Some((nominal, mo.line));
                j = i + 1;
            }
        }
    }
    for s in &w[j..] {
        let Step::Move(mw) = s else {
            return Err(fail(
                "a written G28/G30/G53 block the original does not have",
                usize::MAX,
                Some(line_of(s)),
                f64::NAN,
            ));
        };
        let (Some(we), Some((nominal, line))) = (known(&mw.end), last_end) else {
            continue;
        };
        let d = (eval.tip(Model::Actual, we, mw.length).0 - nominal).norm();
        if d > TOL {
            return Err(fail(
                "a written move after the original's last one",
                line,
                Some(mw.line),
                d,
            ));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// Seeds and mutations.

/// Small programs in machine axes for the AC trunnion: arcs in every plane (I/J/K and R,
/// both directions), G91, optional blocks, reference returns, tool changes.
const HANDWRITTEN: &[&str] = &[
    "%\nO0101 (ARCS G17 IJ AND R)\nN10 G21 G90 G94 G17\nN20 T1 M6\nN30 G43 H1\n\
     N40 G0 X20. Y0 Z30. A-15. C5.\nN50 G1 Z5. F600\nN60 G3 X0 Y20. I-20. J0\n\
     N70 G2 X-20. Y0 R20.\nN80 G3 X20. Y0 R-20.\nN90 G1 X25.\nN100 G2 X25. Y0 I-5. J0\n\
     N110 G0 Z40.\nN120 M30\n%\n",
    "%\nO0102 (G18 AND G19 ARCS TILTED)\nN10 G21 G90 G17\nN20 G0 X0 Y10. Z30. A-25. C30.\n\
     N30 G1 Z10. F500\nN40 G18 G2 X15. Z-5. I0 K-15.\nN50 G3 X0 Z10. I-15. K0\n\
     N60 G19 G2 Y30. Z10. R10.\nN70 G3 Y10. Z10. J-10. K0\nN80 G17 G0 Z50.\nN90 M30\n%\n",
    "%\nO0103 (G91 WITH OPTIONAL BLOCKS)\nN10 G21 G90 G17\nN20 G0 X-30. Y-20. Z25. A-10. C0\n\
     N30 G1 Z3. F700\nN40 G91 X20.\n/N50 Y10.\nN60 X-5. Y5. C3.\nN70 G90 X10. Y10.\n\
     /N80 G1 X30. Y-10. A-12.\nN90 G1 X-30. Y-20. A-10.\nN100 G0 Z40.\nN110 M30\n%\n",
    "%\nO0104 (REFERENCE RETURNS AND TOOL CHANGES)\nN10 G21 G90 G17\nN20 T1 M6\nN30 G43 H1\n\
     N40 G0 X10. Y10. Z40. A-20. C15.\nN50 G1 Z8. F900\nN60 X40. Y-10.\nN70 G91 G28 Z0\n\
     N80 G90 G0 X0 Y0\nN90 Z30.\nN100 G1 Z6. F900\nN110 T2 M6\nN120 G43 H2\n\
     N130 G0 X-20. Y20. Z35. A-30. C60.\nN140 G1 Z4.\nN150 G3 X-10. Y30. R10.\n\
     N160 G53 G0 Z0\nN170 G90 G0 X0 Y0 Z50. A0 C0\nN180 G28\nN190 M30\n%\n",
    "%\nO0105 (MODAL ARCS AND FULL CIRCLES)\nN10 G21 G90 G17\nN20 G0 X35. Y0 Z20. A-40. C-20.\n\
     N30 G1 Z2. F400\nN40 G3 X0 Y35. I-35. J0\nN50 X-35. Y0 I0 J-35.\nN60 G2 X0 Y35. I35. J0\n\
     N70 G1 X0 Y12.\nN80 G3 X0 Y12. I0 J-12.\nN90 G2 I0 J-12.\nN100 G0 Z30.\nN110 M30\n%\n",
    "%\nO0106 (SHORT ARCS NEAR A0)\nN10 G21 G90 G17\nN20 G0 X122.439 Y143.682 Z40. A0 C0\n\
     N30 G1 Z-1. F250\nN40 G3 X122.223 Y143.75 I-5.24 J-16.476\n\
     N50 G2 X125.419 Y103.984 I-8.353 J31.15\nN60 X135.551 Y118.147 I-9.876 J17.771\n\
     N70 G0 Z40.\nN80 M30\n%\n",
];

/// A program of random machine-axis moves: G1 with rotary motion, arcs in every plane (I/J/K
/// or R, both directions, helical), stretches in G91, optional blocks.
fn generated(rng: &mut Lcg) -> String {
    let pick = |rng: &mut Lcg, n: usize| ((rng.next() * n as f64) as usize).min(n - 1);
    let mut s = String::from("%\nO0200 (GENERATED)\nG21 G90 G94 G17\n");
    let h = 1 + pick(rng, 2);
    s += &format!("T{h} M6\nG43 H{h}\n");
    let mut q = [
        rng.sym(80.0),
        rng.sym(80.0),
        20.0 + 30.0 * rng.next(),
        -60.0 * rng.next(),
        rng.sym(120.0),
    ];
    // Four decimals, or three as some posts write.
    let decimals = if rng.next() < 0.3 { 3 } else { 4 };
    let scale = 10f64.powi(decimals as i32);
    let f = |v: f64| format!("{v:.decimals$}");
    s += &format!(
        "G0 X{} Y{} Z{} A{} C{}\n",
        f(q[0]),
        f(q[1]),
        f(q[2]),
        f(q[3]),
        f(q[4])
    );
    let mut plane = 0;
    for _ in 0..4 + pick(rng, 10) {
        let slash = if rng.next() < 0.08 { "/" } else { "" };
        match pick(rng, 6) {
            0 | 1 => {
                let mut line = String::from("G1");
                for k in 0..5 {
                    if rng.next() < 0.5 {
                        let step = if k < 3 { rng.sym(30.0) } else { rng.sym(8.0) };
                        q[k] += step;
                        q[3] = q[3].clamp(-110.0, 25.0);
                        line += &format!(" {}{}", AXES[k], f(q[k]));
                    }
                }
                s += &format!("{slash}{line} F800\n");
            }
            2 | 3 => {
                // An arc: a centre at a random offset, a random sweep.
                if rng.next() < 0.3 {
                    plane = pick(rng, 3);
                    s += ["G17\n", "G18\n", "G19\n"][plane];
                }
                let [u, v] = PLANES[plane];
                let r = 2.0 + 40.0 * rng.next();
                let phi = rng.sym(std::f64::consts::PI);
                let c = [q[u] - r * phi.cos(), q[v] - r * phi.sin()];
                let ccw = rng.next() < 0.5;
                // Sweeps of every size, and the hard ones: a few µm of chord, nearly a full
                // turn.
                let size = match pick(rng, 5) {
                    0 => 1e-4 + 0.02 * rng.next(),
                    1 => TAU - 1e-4 - 0.02 * rng.next(),
                    _ => 0.05 + 6.2 * rng.next(),
                };
                let sweep = size * if ccw { 1.0 } else { -1.0 };
                let e = [
                    c[0] + r * (phi + sweep).cos(),
                    c[1] + r * (phi + sweep).sin(),
                ];
                let start = q;
                q[u] = (e[0] * scale).round() / scale;
                q[v] = (e[1] * scale).round() / scale;
                let mut line = format!(
                    "{} {}{} {}{}",
                    if ccw { "G3" } else { "G2" },
                    AXES[u],
                    f(q[u]),
                    AXES[v],
                    f(q[v])
                );
                if rng.next() < 0.3 {
                    let w = 3 - u - v;
                    q[w] += rng.sym(5.0);
                    line += &format!(" {}{}", AXES[w], f(q[w]));
                }
                if rng.next() < 0.3 {
                    let radius = if sweep.abs() > std::f64::consts::PI {
                        -r
                    } else {
                        r
                    };
                    line += &format!(" R{}", f(radius));
                } else {
                    let letters = ['I', 'J', 'K'];
                    let [cu, cv] = CENTRES[plane];
                    line += &format!(
                        " {}{} {}{}",
                        letters[cu],
                        f(c[0] - start[u]),
                        letters[cv],
                        f(c[1] - start[v])
                    );
                }
                s += &format!("{slash}{line}\n");
            }
            4 => {
                let k = pick(rng, 3);
                let d = rng.sym(10.0);
                q[k] += (d * scale).round() / scale;
                s += &format!(
                    "G91 G1 {}{}\nG90\n",
                    AXES[k],
                    f((d * scale).round() / scale)
                );
            }
            _ => {
                q[2] += 10.0;
                s += &format!("G0 Z{}\n", f(q[2]));
            }
        }
    }
    s += "G0 Z80.\nM30\n%\n";
    s
}

const FIXTURES: &[&str] = &[
    "feature_workpiece.nc",
    "ac_trunnion_g91.nc",
    "ac_trunnion_arcs.nc",
    "ac_trunnion_g28_g53.nc",
];

/// The ISO programs of ../shared/corpus (none when it is not there).
fn corpus() -> Vec<String> {
    let Some(dir) = common::skip::corpus_part("") else {
        return Vec::new();
    };
    let mut files = Vec::new();
    let mut stack = vec![dir];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(d).unwrap() {
            let p = entry.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| {
                let e = e.to_string_lossy().to_lowercase();
                ["nc", "ngc", "tap", "gcode", "cnc"].contains(&e.as_str())
            }) {
                files.push(p);
            }
        }
    }
    files.sort();
    files
        .iter()
        .filter_map(|p| std::fs::read_to_string(p).ok())
        .filter(|t| !t.contains("BEGIN PGM") && t.lines().count() >= 5)
        .collect()
}

fn pick(rng: &mut Lcg, n: usize) -> usize {
    ((rng.next() * n as f64) as usize).min(n.max(1) - 1)
}

/// A number of `line` (after one of `letters`) changed: a little, a lot, its sign, its
/// decimals.
fn perturb(rng: &mut Lcg, line: &str, letters: &str) -> String {
    let b = line.as_bytes();
    let spots: Vec<(usize, usize)> = (0..b.len())
        .filter(|&i| letters.contains(b[i].to_ascii_uppercase() as char))
        .filter_map(|i| {
            let mut j = i + 1;
            while j < b.len() && (b[j].is_ascii_digit() || b"+-.".contains(&b[j])) {
                j += 1;
            }
            (j > i + 1).then_some((i + 1, j))
        })
        .collect();
    if spots.is_empty() {
        return line.to_string();
    }
    let (i, j) = spots[pick(rng, spots.len())];
    let v: f64 = line[i..j].parse().unwrap_or(0.0);
    let new = match pick(rng, 6) {
        0 => format!("{:.4}", v + rng.sym(0.01)),
        1 => format!("{:.3}", v + rng.sym(1.0)),
        2 => format!("{:.1}", v + rng.sym(100.0)),
        3 => format!("{:.4}", -v),
        4 => "0".to_string(),
        _ => format!("{:.5}", v + rng.sym(0.0002)),
    };
    format!("{}{}{}", &line[..i], new, &line[j..])
}

fn replace_word(line: &str, from: &str, to: &str) -> Option<String> {
    let upper = line.to_ascii_uppercase();
    let mut at = 0;
    while let Some(p) = upper[at..].find(from) {
        let p = at + p;
        let after = upper.as_bytes().get(p + from.len());
        if !after.is_some_and(|c| c.is_ascii_digit() || *c == b'.') {
            return Some(format!("{}{}{}", &line[..p], to, &line[p + from.len()..]));
        }
        at = p + from.len();
    }
    None
}

const INSERTS: &[&str] = &[
    "G91 G28 Z0",
    "G28",
    "G90 G28 X0 Y0",
    "G53 G0 Z0",
    "T2 M6",
    "T1 M6\nG43 H1",
    "T2 M6\nG43 H2",
    "G43 H2",
    "G49",
    "G90",
    "G91",
    "G17",
    "G18",
    "G19",
    "G0 X0 Y0 Z40. A-20. C10.",
    "G1 X5. Y-5. F500",
    "G1 Z-2.",
    "G0 Z60.",
    "G3 X10. Y0 I5. J0",
    "G2 X0 Y10. R10.",
    "G1 A-35. C45.",
    "M1",
];

fn mutate(rng: &mut Lcg, lines: &mut Vec<String>, others: &[String]) {
    if lines.is_empty() {
        lines.push("G0 X0 Y0 Z40. A0 C0".into());
        return;
    }
    let n = lines.len();
    let i = pick(rng, n);
    match pick(rng, 14) {
        0 | 1 => lines[i] = perturb(rng, &lines[i], "XYZAC"),
        2 => lines[i] = perturb(rng, &lines[i], "IJKR"),
        3 => {
            lines.remove(i);
        }
        4 => {
            let l = lines[i].clone();
            lines.insert(i, l);
        }
        5 if i + 1 < n => lines.swap(i, i + 1),
        6 => {
            if let Some(rest) = lines[i].strip_prefix('/') {
                lines[i] = rest.to_string();
            } else {
                lines[i] = format!("/{}", lines[i]);
            }
        }
        7 => {
            let l = &lines[i];
            lines[i] = replace_word(l, "G90", "G91")
                .or_else(|| replace_word(l, "G91", "G90"))
                .unwrap_or_else(|| format!("G91 {l}"));
        }
        8 => {
            let l = &lines[i];
            let swaps = [
                ("G0", "G1"),
                ("G1", "G0"),
                ("G2", "G3"),
                ("G3", "G2"),
                ("G01", "G00"),
                ("G00", "G01"),
                ("G02", "G03"),
                ("G03", "G02"),
            ];
            let (a, b) = swaps[pick(rng, swaps.len())];
            if let Some(new) = replace_word(l, a, b) {
                lines[i] = new;
            }
        }
        9 | 10 => {
            let piece = INSERTS[pick(rng, INSERTS.len())];
            for (k, p) in piece.lines().enumerate() {
                lines.insert(i + k, p.to_string());
            }
        }
        11 if !others.is_empty() => {
            let l = others[pick(rng, others.len())].clone();
            lines.insert(i, l);
        }
        12 => {
            // An arc's centre words swapped or its radius negated.
            let l = &lines[i];
            if let Some(new) = replace_word(l, "R", "R-").filter(|_| !l.contains("R-")) {
                lines[i] = new;
            } else if let Some(new) = replace_word(l, "I", "J") {
                lines[i] = new;
            }
        }
        _ => lines[i] = perturb(rng, &lines[i], "XYZACIJKR"),
    }
}

/// A mutant: a seed (whole, or a window of a long one after its header), mutated 1–4
/// times.
fn mutant(rng: &mut Lcg, seeds: &[String], corpus: &[String]) -> String {
    let roll = rng.next();
    let mut lines: Vec<String> = if roll < 0.15 && !corpus.is_empty() {
        // A window of a corpus program, set up on the trunnion.
        let text = &corpus[pick(rng, corpus.len())];
        let all: Vec<&str> = text.lines().collect();
        let len = 10 + pick(rng, 30);
        let at = pick(rng, all.len().saturating_sub(len).max(1));
        let mut l = vec![
            "G21 G90 G17".to_string(),
            "G0 X0 Y0 Z60. A-20. C10.".to_string(),
        ];
        l.extend(
            all[at..(at + len).min(all.len())]
                .iter()
                .map(|s| s.to_string()),
        );
        l
    } else if roll < 0.45 {
        generated(rng).lines().map(str::to_string).collect()
    } else {
        let text = &seeds[pick(rng, seeds.len())];
        let all: Vec<&str> = text.lines().collect();
        if all.len() > 60 {
            // The header through the first full positioning, then a window.
            let head = all
                .iter()
                .position(|l| l.contains(" A") && l.contains(" C") && l.contains("G0"))
                .map_or(0, |p| p + 1);
            let len = 15 + pick(rng, 40);
            let at = head + pick(rng, (all.len() - head).saturating_sub(len).max(1));
            let mut l: Vec<String> = all[..head].iter().map(|s| s.to_string()).collect();
            l.extend(
                all[at..(at + len).min(all.len())]
                    .iter()
                    .map(|s| s.to_string()),
            );
            l.push("M30".into());
            l
        } else {
            all.iter().map(|s| s.to_string()).collect()
        }
    };
    let others: Vec<String> = seeds[pick(rng, seeds.len())]
        .lines()
        .map(str::to_string)
        .collect();
    for _ in 0..1 + pick(rng, 4) {
        mutate(rng, &mut lines, &others);
    }
    let mut s = lines.join("\n");
    s.push('\n');
    s
}

// ---------------------------------------------------------------------------------------
// The campaign.

struct Setup {
    machine: Machine,
    errors: ErrorModel,
}

fn setup() -> Setup {
    let dir = root().join("fixtures");
    let machine = machine_file::load(&dir.join("ac_trunnion.machine.toml")).unwrap();
    let errors = error_file::load(&dir.join("ac_trunnion.errors.toml"), &machine).unwrap();
    Setup { machine, errors }
}

enum Outcome {
    Refused,
    Panicked,
    NotJudged(String),
    Passed,
    Failed(Failure, String),
}

fn run_one(comp: &Compensator, eval: &Eval, program: &str, tally: &mut Tally) -> Outcome {
    let mut out = Vec::new();
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        comp.run(program.as_bytes(), "mutant.nc", &mut out)
    }));
    match result {
        Err(_) => Outcome::Panicked,
        Ok(Err(_)) => Outcome::Refused,
        Ok(Ok(_)) => {
            let written = String::from_utf8_lossy(&out).into_owned();
            match judge(eval, program, &written, tally) {
                Ok(Ok(())) => Outcome::Passed,
                Ok(Err(reason)) => Outcome::NotJudged(reason),
                Err(f) => Outcome::Failed(f, written),
            }
        }
    }
}

/// The program with lines dropped while it still fails the same way.
fn minimise(comp: &Compensator, eval: &Eval, program: &str, kind: &str) -> String {
    let mut lines: Vec<&str> = program.lines().collect();
    let mut changed = true;
    while changed {
        changed = false;
        let mut i = 0;
        while i < lines.len() {
            let mut trial = lines.clone();
            trial.remove(i);
            let text = trial.join("\n") + "\n";
            let mut t = Tally::default();
            if matches!(run_one(comp, eval, &text, &mut t), Outcome::Failed(f, _) if f.kind == kind)
            {
                lines = trial;
                changed = true;
            } else {
                i += 1;
            }
        }
    }
    lines.join("\n") + "\n"
}

fn env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.replace('_', "").parse().ok())
        .unwrap_or(default)
}

#[test]
fn no_accepted_output_leaves_its_nominal_path() {
    let started = Instant::now();
    let s = setup();
    // The fixture's calibration (paper 000) for three programs in four, the benchmarks'
    // full random calibration (every error motion tabulated) for the fourth.
    let full = error_file::parse(
        &common::random::random_errors(),
        "full.errors.toml",
        &s.machine,
    )
    .unwrap();
    let models = [&s.errors, &full];
    let gated: Vec<Compensator> = models
        .iter()
        .map(|e| Compensator::new(&s.machine, e, cli_options()).unwrap())
        .collect();
    // The same pass without its verification gate: what the gate refuses, judged here.
    let ungated: Vec<Compensator> = models
        .iter()
        .map(|e| {
            let options = Options {
                verify: false,
                ..cli_options()
            };
            Compensator::new(&s.machine, e, options).unwrap()
        })
        .collect();
    let evals: Vec<Eval> = models.iter().map(|e| Eval::new(&s.machine, e)).collect();
    // Programs the gate refused that the pass alone writes: (judged off the path, judged
    // on it, not judged).
    let mut gate = (0, 0, 0);
    let mut gate_only_example: Option<String> = None;
    let mut gate_kinds: BTreeMap<&str, usize> = BTreeMap::new();
    let mut seeds: Vec<String> = FIXTURES
        .iter()
        .map(|f| std::fs::read_to_string(root().join("fixtures").join(f)).unwrap())
        .collect();
    seeds.extend(HANDWRITTEN.iter().map(|s| s.to_string()));
    let corpus = corpus();
    let count = env("NCCOMP_DIFF_MUTANTS", 3000);
    let mut rng = Lcg(env("NCCOMP_DIFF_SEED", 0x0d1f_f034));
    let mut tally = Tally::default();
    let (mut refused, mut panicked, mut passed) = (0, 0, 0);
    let mut not_judged: BTreeMap<String, usize> = BTreeMap::new();
    let mut failures: Vec<(Failure, String, String, usize)> = Vec::new();
    // The seeds themselves first, then the mutants.
    let mut programs: Vec<String> = seeds.clone();
    for _ in 0..count {
        programs.push(mutant(&mut rng, &seeds, &corpus));
    }
    for (n, program) in programs.iter().enumerate() {
        tally.program = n;
        let m = usize::from(n % 4 == 3);
        match run_one(&gated[m], &evals[m], program, &mut tally) {
            Outcome::Refused => {
                refused += 1;
                let mut t = Tally::default();
                match run_one(&ungated[m], &evals[m], program, &mut t) {
                    Outcome::Failed(f, _) => {
                        gate.0 += 1;
                        *gate_kinds.entry(f.kind).or_default() += 1;
                    }
                    Outcome::Passed => {
                        gate.1 += 1;
                        gate_only_example.get_or_insert_with(|| program.clone());
                    }
                    Outcome::NotJudged(_) => gate.2 += 1,
                    Outcome::Refused | Outcome::Panicked => {}
                }
            }
            Outcome::Panicked => panicked += 1,
            Outcome::Passed => passed += 1,
            Outcome::NotJudged(reason) => {
                // The kind of construct, without its line.
                let key = reason
                    .split_once(": ")
                    .map_or(reason.as_str(), |(_, r)| r)
                    .to_string();
                *not_judged.entry(key).or_default() += 1;
            }
            Outcome::Failed(f, written) => failures.push((f, program.clone(), written, m)),
        }
    }
    let accepted = passed + failures.len() + not_judged.values().sum::<usize>();
    eprintln!(
        "differential campaign: {} programs run ({} seeds, {count} mutants, {} corpus programs available) in {:.1} s",
        programs.len(),
        seeds.len(),
        corpus.len(),
        started.elapsed().as_secs_f64()
    );
    eprintln!(
        "  refused {refused}, panicked {panicked}, accepted {accepted}: judged {} ({passed} on the nominal path, {} off it), not judged {}",
        passed + failures.len(),
        failures.len(),
        not_judged.values().sum::<usize>()
    );
    eprintln!(
        "  {} block ends and {} mid-path points judged; worst block end {:.4} µm, worst mid-path {:.4} µm (tolerance {:.2} µm); worst tool direction at block ends with |A| > 3°: {:.2} µrad",
        tally.ends,
        tally.mids,
        tally.worst_end * 1e3,
        tally.worst_mid * 1e3,
        TOL * 1e3,
        tally.worst_direction * 1e6
    );
    eprintln!(
        "  rapids at unknown axes with corrected words: {} (and {} where Z is unknown after a tool change); moves whose G0/G1 changed: {}",
        tally.unknown_rapids_changed, tally.tool_change_rapids_changed, tally.motion_changed
    );
    eprintln!(
        "  of the refused, the pass without its gate writes {} that the gate alone refuses: {} of them off the path here, {} on it, {} not judged",
        gate.0 + gate.1 + gate.2,
        gate.0,
        gate.1,
        gate.2
    );
    for (kind, n) in &gate_kinds {
        eprintln!("  refused by the gate, off the path here too {n:>4}: {kind}");
    }
    if let Some((line, n)) = tally.unknown_rapid_at {
        eprintln!(
            "  (the first rapid at unknown axes with corrected words: {:?}, line {} of program {n})",
            programs[n].split('\n').nth(line).unwrap_or(""),
            line + 1
        );
    }
    if let Some(p) = &gate_only_example {
        eprintln!(
            "  (the first the gate refuses and this judge finds on the path: {:?}…)",
            p.lines().take(3).collect::<Vec<_>>().join(" / ")
        );
    }
    if tally.worst_direction > 0.0 {
        let (line, n) = tally.worst_direction_at;
        eprintln!(
            "  (the worst tool direction: {:?}, line {} of program {n})",
            programs[n].split('\n').nth(line).unwrap_or(""),
            line + 1,
        );
    }
    for (f, program, ..) in &failures {
        eprintln!(
            "  off: {} | {:?}",
            f.kind,
            program.split('\n').nth(f.original_line).unwrap_or("")
        );
    }
    for (reason, n) in &not_judged {
        eprintln!("  not judged {n:>4}: {reason}");
    }
    let mut kinds: BTreeMap<&str, usize> = BTreeMap::new();
    for (f, ..) in &failures {
        *kinds.entry(f.kind).or_default() += 1;
    }
    for (kind, n) in &kinds {
        eprintln!("  OFF THE PATH {n:>4}: {kind}");
    }
    let minimise_too = std::env::var("NCCOMP_DIFF_MINIMISE").is_ok_and(|v| v != "0");
    let mut shown: Vec<&str> = Vec::new();
    for (f, program, written, m) in &failures {
        if shown.contains(&f.kind) {
            continue;
        }
        shown.push(f.kind);
        eprintln!(
            "\n--- {} (block delete {}): original line {}, written line {:?}, {:.4} µm\n{program}--- written:\n{written}",
            f.kind,
            if f.block_delete { "on" } else { "off" },
            f.original_line.wrapping_add(1),
            f.written_line.map(|l| l + 1),
            f.deviation * 1e3
        );
        if minimise_too {
            eprintln!(
                "--- minimal:\n{}",
                minimise(&gated[*m], &evals[*m], program, f.kind)
            );
        }
    }
    assert!(
        passed * 3 > accepted,
        "too few outputs judged to mean anything"
    );
    let strict = std::env::var("NCCOMP_DIFF_STRICT").is_ok_and(|v| v != "0");
    let new: Vec<_> = failures
        .iter()
        .filter(|(f, ..)| strict || !KNOWN.contains(&f.kind))
        .collect();
    assert!(
        new.is_empty(),
        "{} accepted outputs off their nominal path ({} of them of a kind not yet pinned by an ignored test below)",
        failures.len(),
        failures
            .iter()
            .filter(|(f, ..)| !KNOWN.contains(&f.kind))
            .count()
    );
}

/// A program the campaign found: nccomp must refuse it or write it on its nominal path.
#[track_caller]
fn refused_or_on_the_path(program: &str) {
    let s = setup();
    let comp = Compensator::new(&s.machine, &s.errors, cli_options()).unwrap();
    let eval = Eval::new(&s.machine, &s.errors);
    let mut tally = Tally::default();
    match run_one(&comp, &eval, program, &mut tally) {
        Outcome::Refused | Outcome::Passed => {}
        Outcome::Panicked => panic!("nccomp panicked"),
        Outcome::NotJudged(reason) => panic!("not judged: {reason}"),
        Outcome::Failed(f, written) => panic!(
            "accepted off its nominal path: {} (block delete {}, original line {}, written line {:?}, {:.4} µm)\n{written}",
            f.kind,
            if f.block_delete { "on" } else { "off" },
            f.original_line + 1,
            f.written_line.map(|l| l + 1),
            f.deviation * 1e3
        ),
    }
}

/// Found by the campaign: a feed move that starts where an axis is unknown (never set, or
/// after G28/G53) and sets it in G90 was compensated at its end only; the contract refuses
/// a feed move with an unknown axis (its cut starts from an uncorrected pose).
#[test]
fn a_feed_move_from_an_unknown_axis_is_refused() {
    refused_or_on_the_path("G21 G90 G17\nG0 X100. Y80. A-30. C45.\nG1 Z6. F900\nM30\n");
}

/// Found by the campaign: after G28 Z an optional G90 rapid (`/G0 Z30.`) programs Z again.
/// With block delete off it runs and must end on its nominal pose (it is corrected); with
/// block delete on Z stays unknown, so the feed move after it is refused.
#[test]
fn an_optional_rapid_after_g28_is_corrected_or_refused() {
    refused_or_on_the_path(
        "G21 G90 G17\nG0 X10. Y10. Z40. A-20. C15.\nG91 G28 Z0\nG90 G0 X0 Y0\n/G0 Z30.\nG1 Z6. F900\nM30\n",
    );
}

/// Found by the campaign: a tool change makes Z unknown (the machine file's default sends
/// Z to the change position); a feed move right after it is refused.
#[test]
fn a_feed_move_after_a_tool_change_is_refused() {
    refused_or_on_the_path("G21 G90 G17\nG0 X20. Y0 Z30. A-15. C5.\nT1 M6\nG1 X25. F500\nM30\n");
}

/// Found by the campaign: after a tool change a rapid that does not program Z passes
/// unchanged (no Z word: no diagonal rapid plunge from the change position).
#[test]
fn a_rapid_after_a_tool_change_passes_unchanged() {
    refused_or_on_the_path(
        "G21 G90 G17\nG0 X0 Y0 Z60. A-20. C10.\nT2 M6\nG43 H2\nG0 X-75. Y-75.\nM30\n",
    );
}

/// One program (`NCCOMP_DIFF_PROGRAM`, a file) compensated and judged, with its output:
/// for looking at a case the campaign found.
#[test]
#[ignore]
fn judge_one_program() {
    let Ok(path) = std::env::var("NCCOMP_DIFF_PROGRAM") else {
        return;
    };
    let program = std::fs::read_to_string(path).unwrap();
    let s = setup();
    let comp = Compensator::new(&s.machine, &s.errors, cli_options()).unwrap();
    let eval = Eval::new(&s.machine, &s.errors);
    let mut out = Vec::new();
    let result = comp.run(program.as_bytes(), "mutant.nc", &mut out);
    eprintln!(
        "{result:?}\n--- written:\n{}",
        String::from_utf8_lossy(&out)
    );
    let mut tally = Tally::default();
    let written = String::from_utf8_lossy(&out).into_owned();
    if result.is_ok() {
        match judge(&eval, &program, &written, &mut tally) {
            Ok(v) => eprintln!("judged: {v:?} {tally:?}"),
            Err(f) => eprintln!("OFF THE PATH: {f:?}"),
        }
    }
}

/// The judge is not blind: outputs of the fixtures broken by hand (a word 3 µm off, a kept
/// arc's direction flipped, pieces of a replaced arc dropped, an inserted piece made to
/// run with block delete on) are each found off the path.
#[test]
fn the_judge_finds_hand_broken_outputs() {
    let s = setup();
    let comp = Compensator::new(&s.machine, &s.errors, cli_options()).unwrap();
    let eval = Eval::new(&s.machine, &s.errors);
    let compensate = |src: &str| {
        let mut out = Vec::new();
        comp.run(src.as_bytes(), "p.nc", &mut out).unwrap();
        String::from_utf8(out).unwrap()
    };
    let broken = |original: &str, written: String, what: &str| {
        let mut t = Tally::default();
        assert!(
            judge(&eval, original, &written, &mut t).is_err(),
            "{what}: not found\n{written}"
        );
    };
    // The seeds nccomp accepts, with their outputs.
    let mut seeds: Vec<String> = FIXTURES
        .iter()
        .map(|f| common::contract::fixture(f))
        .collect();
    seeds.extend(HANDWRITTEN.iter().map(|s| s.to_string()));
    let accepted: Vec<(String, String)> = seeds
        .into_iter()
        .filter_map(|src| {
            let mut out = Vec::new();
            comp.run(src.as_bytes(), "p.nc", &mut out).ok()?;
            Some((src, String::from_utf8(out).unwrap()))
        })
        .collect();
    let edit = |text: &str, i: usize, new: Option<String>| {
        let mut l: Vec<String> = text.lines().map(str::to_string).collect();
        match new {
            Some(n) => l[i] = n,
            None => {
                l.drain(i..i + 5);
            }
        }
        l.join("\n") + "\n"
    };
    let (mut words, mut arcs, mut pieces) = (0, 0, 0);
    for (src, good) in &accepted {
        let mut t = Tally::default();
        assert!(
            matches!(judge(&eval, src, good, &mut t), Ok(Ok(()))),
            "{good}"
        );
        let lines: Vec<&str> = good.lines().collect();
        // A word of a feed move 3 µm off.
        if let Some(i) = lines.iter().position(|l| l.contains("G1 X")) {
            // Each linear word off its own way, so that some part is across the move.
            let new: Vec<String> = lines[i]
                .split(' ')
                .map(
                    |w| match (w.chars().next(), w[1.min(w.len())..].parse::<f64>()) {
                        (Some('X'), Ok(v)) => format!("X{:.4}", v + 0.003),
                        (Some('Y'), Ok(v)) => format!("Y{:.4}", v - 0.003),
                        (Some('Z'), Ok(v)) => format!("Z{:.4}", v + 0.002),
                        _ => w.to_string(),
                    },
                )
                .collect();
            broken(src, edit(good, i, Some(new.join(" "))), "words 3 µm off");
            words += 1;
        }
        // A kept arc turned the other way.
        if let Some(i) = lines.iter().position(|l| l.contains(" G3 X")) {
            let new = lines[i].replace(" G3 X", " G2 X");
            broken(src, edit(good, i, Some(new)), "G3 as G2");
            arcs += 1;
        }
        // Five pieces dropped from a run of inserted ones (of an arc: five pieces of a
        // split straight move may still lie on its path, so a run whose loss the judge
        // finds is counted).
        let original: std::collections::HashSet<&str> = src.lines().collect();
        let mut run = 0;
        for (i, l) in lines.iter().enumerate() {
            run = if original.contains(l) { 0 } else { run + 1 };
            if run == 30 {
                let mut t = Tally::default();
                if judge(&eval, src, &edit(good, i - 20, None), &mut t).is_err() {
                    pieces += 1;
                    break;
                }
                run = 0;
            }
        }
    }
    assert!(
        words >= 3 && arcs >= 1 && pieces >= 1,
        "{} accepted seeds: {words} words, {arcs} arcs, {pieces} runs of pieces broken",
        accepted.len()
    );
    // A straight move written without its split: the G91 fixture's tilting moves.
    let g91 = common::contract::fixture("ac_trunnion_g91.nc");
    let good = compensate(&g91);
    let mut t = Tally::default();
    assert!(matches!(judge(&eval, &g91, &good, &mut t), Ok(Ok(()))));
    // An optional block whose inserted pieces run with block delete on.
    let program = "G21 G90 G17\nG0 X-60. Y-40. Z40. A-30. C0\nG1 Z10. F800\n/G1 X60. A-20. C40.\nG0 X60. Y40. Z40. A-20. C40.\nM30\n";
    let good = compensate(program);
    assert!(
        good.lines().filter(|l| l.starts_with('/')).count() > 1,
        "{good}"
    );
    let mut t = Tally::default();
    assert!(matches!(judge(&eval, program, &good, &mut t), Ok(Ok(()))));
    let unmarked: String = good
        .lines()
        .enumerate()
        .map(|(n, l)| {
            let first = good.lines().position(|l| l.starts_with('/')).unwrap();
            if n == first { &l[1..] } else { l }.to_string() + "\n"
        })
        .collect();
    broken(
        program,
        unmarked,
        "a piece of an optional block not optional",
    );
}

/// Defect (over-refusal): the shipped fixture's kept arcs (N60, N70 at A0) are refused by
/// the gate ("strays 0.001771 mm"): the gate holds the real tip at each fraction of the
/// written arc against the nominal tip at the same fraction, which counts a lag along the
/// path; the real tip's distance from the nominal path is 0.91 µm, within the 1 µm
/// tolerance (this file's judge). The campaign counts such refusals.
#[test]
fn the_arcs_fixture_is_compensated() {
    let s = setup();
    let comp = Compensator::new(&s.machine, &s.errors, cli_options()).unwrap();
    let src = common::contract::fixture("ac_trunnion_arcs.nc");
    let mut out = Vec::new();
    comp.run(src.as_bytes(), "ac_trunnion_arcs.nc", &mut out)
        .unwrap();
}

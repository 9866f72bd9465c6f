//! What a TNC control does with a called machining cycle, as far as nccomp follows it
//! (docs/heidenhain.md, "Cycles").
//!
//! Every cycle nccomp compensates is placed by its call (the hole's centre: the X, Y of the
//! block that carries `M99`, or where the tool stands at `CYCL CALL`) and reaches along the
//! tool axis from its set-up clearance (Q203 + Q200) down to its depth (Q203 + Q201) and
//! back to the larger of its set-up clearances (Q204). Some go down the axis and back
//! (drilling, reaming, tapping, deep-hole drilling); the others move the tool around the
//! axis within a radius their definition gives (bore milling within its nominal diameter,
//! thread milling within the thread's, pockets within their sides). [`reach`] gives that
//! extent; the pass compensates the centre, axis and depth, and bounds what the motion
//! around the axis adds (`compensate::lateral`).
//!
//! Where one X, Y cannot serve the whole depth of a drilling cycle whose motion nccomp
//! knows exactly (200, 201, 240), [`hole_steps`] is that motion along the axis: the
//! pass writes it out as `L` blocks with the correction along the depth.

use super::heidenhain::{CycleDef, Param};

/// How far a called cycle's motion reaches, from its definition.
#[derive(Debug, Clone, PartialEq)]
pub struct Reach {
    /// The surface (Q203), the bottom (the deepest the tool goes on the hole's axis), the
    /// set-up clearance (Q203 + Q200) and where the tool ends (Q203 + the larger of Q200
    /// and Q204), along the tool axis, in program units.
    pub levels: [f64; 4],
    /// The largest distance from the hole's axis the tool's tip reaches (program units; 0
    /// for a cycle that goes down the axis and back) ...
    pub radius: f64,
    /// ... and how far below the bottom the motion around the axis may reach (thread
    /// milling's approach), in program units.
    pub below: f64,
    /// What moves the tool around the axis, for messages (empty for none): `bore milling
    /// (208) within its nominal diameter Q335 = 10.2`.
    pub around: String,
}

/// The value of parameter Q`q` of `def`: a number, or a Q parameter set to a constant.
fn known(def: &CycleDef, q: u32) -> Result<f64, String> {
    match def.get(q) {
        Some(Param::Known(v)) => Ok(*v),
        Some(Param::Unknown(what)) => Err(format!(
            "Q{q} is given by {what}, which the program never sets to a constant (its value is decided at run time)"
        )),
        None => Err(format!("it has no Q{q}")),
    }
}

/// A parameter that may be left out (`default` then), but not be decided at run time.
fn optional(def: &CycleDef, q: u32, default: f64) -> Result<f64, String> {
    match def.get(q) {
        None => Ok(default),
        Some(_) => known(def, q),
    }
}

/// A length a definition gives as a size (a diameter, a side): positive and finite.
fn size(def: &CycleDef, q: u32, what: &str) -> Result<f64, String> {
    let v = known(def, q)?;
    if !(v.is_finite() && v > 0.0) {
        return Err(format!(
            "expected its {what} Q{q} greater than 0 (it is {v})"
        ));
    }
    Ok(v)
}

/// What the control does with cycle `def` when it is called, as far as nccomp follows it:
/// its levels and the extent of its motion around the axis; `Err`: why the cycle is not one
/// nccomp follows. `inch`: the program is in inch (the reach of a fixed distance is given in
/// its units).
pub fn reach(def: &CycleDef, inch: bool) -> Result<Reach, String> {
    let mm = |x: f64| if inch { x / super::INCH } else { x };
    let number = def.number;
    // The cycle's depth below the surface, as a negative distance, where another
    // parameter than Q201 takes it deeper (a countersink below the thread).
    let mut deepest: Vec<u32> = Vec::new();
    let (radius, below, around) = match number {
        // Drilling, reaming, universal drilling, universal pecking, tapping with a floating
        // tap holder, rigid tapping, tapping with chip breaking, centering and single-lip
        // deep-hole drilling go straight down the tool axis and back.
        200 | 201 | 203 | 205 | 206 | 207 | 209 | 241 => (0.0, 0.0, String::new()),
        240 => {
            // Centering to a diameter (Q343 = 1) takes its depth from the tool's point
            // angle, which the program does not give.
            if optional(def, 343, 0.0)? != 0.0 {
                return Err("centering (240) to a diameter (Q343 = 1) reaches a depth given by the tool's point angle in the tool table, which nccomp does not know (expected Q343 = 0 and the depth Q201)".into());
            }
            (0.0, 0.0, String::new())
        }
        202 => {
            // Boring: at the bottom the control orients the spindle and, with Q214,
            // moves the tool off the wall before it retracts. That move is a fraction of a
            // millimetre; its change of the error field is bounded over 1 mm.
            if known(def, 214)? == 0.0 {
                (0.0, 0.0, String::new())
            } else {
                (
                    mm(1.0),
                    0.0,
                    "boring (202) with its disengaging move Q214 at the bottom (bounded within 1 mm of the axis)".into(),
                )
            }
        }
        208 => {
            let d = size(def, 335, "nominal diameter")?;
            (
                d / 2.0,
                0.0,
                format!("bore milling (208) within its nominal diameter Q335 = {d}"),
            )
        }
        262..=265 => {
            let d = size(def, 335, "nominal diameter")?;
            let pitch = known(def, 239)?.abs();
            // The countersink at the front moves the tool's centre Q359 off the axis.
            let offset = optional(def, 359, 0.0)?.abs();
            deepest = match number {
                263 | 264 => vec![356, 358],
                265 => vec![358],
                _ => vec![],
            };
            let name = match number {
                262 => "thread milling (262)",
                263 => "thread milling/countersinking (263)",
                264 => "thread drilling/milling (264)",
                _ => "helical thread drilling/milling (265)",
            };
            // The tool approaches the thread on a helix from a starting plane derived from
            // the pitch, the milling direction and the threads per step: within two
            // pitches below the thread's depth.
            (
                (d / 2.0).max(offset),
                2.0 * pitch,
                format!("{name} within its nominal diameter Q335 = {d}"),
            )
        }
        251 | 253 => {
            // The pocket or slot about the call's X, Y (Q367 = 0); with another reference
            // point where the tool ends after it is not followed.
            if optional(def, 367, 0.0)? != 0.0 {
                return Err(format!(
                    "{} with its reference point at a corner or end (Q367 other than 0) is not followed (expected Q367 = 0: the call's X, Y its centre)",
                    if number == 251 {
                        "a rectangular pocket (251)"
                    } else {
                        "a slot (253)"
                    }
                ));
            }
            let a = size(def, 218, "first side length")?;
            let b = size(def, 219, "second side length")?;
            (
                0.5 * a.hypot(b),
                0.0,
                format!(
                    "{} within its sides Q218 = {a} and Q219 = {b}",
                    if number == 251 {
                        "the rectangular pocket (251)"
                    } else {
                        "the slot (253)"
                    }
                ),
            )
        }
        252 => {
            let d = size(def, 223, "circle diameter")?;
            (
                d / 2.0,
                0.0,
                format!("the circular pocket (252) within its diameter Q223 = {d}"),
            )
        }
        204 => {
            return Err("cycle 204 (back boring) goes through the hole off its axis and cuts from below the part, at a height given by the tool's edge, which nccomp does not follow (expected the path programmed as L moves)".into());
        }
        254 => {
            return Err("cycle 254 (circular slot) lies about the centre its definition gives (Q216, Q217), not about the call's X, Y, which nccomp does not follow (expected the path programmed as L moves)".into());
        }
        256 | 257 | 267 => {
            return Err(format!(
                "cycle {number} ({}) moves the tool around the outside of its shape, at a distance given by the tool's radius in the tool table, which nccomp does not know (expected the path programmed as L moves)",
                match number {
                    256 => "rectangular stud",
                    257 => "circular stud",
                    _ => "outside thread milling",
                }
            ));
        }
        n => {
            return Err(format!(
                "cycle {n} is not a machining cycle nccomp follows (expected 200–203, 205–209, 240, 241, 251–253, 262–265, or the path programmed as L moves)"
            ));
        }
    };
    if let Some(Param::Known(v)) = def.get(395)
        && *v != 0.0
    {
        return Err("Q395=1 measures the depth to the tool's full diameter, which depends on the tool's point angle".into());
    }
    let surface = known(def, 203)?;
    let mut depth = known(def, 201)?;
    let clearance = known(def, 200)?;
    let second = optional(def, 204, 0.0)?;
    if depth >= 0.0 || clearance < 0.0 {
        return Err(
            "expected a negative depth Q201 and a set-up clearance Q200 of 0 or more".into(),
        );
    }
    for q in deepest {
        // Depths given as distances below the surface (their sign differs between
        // versions): the deepest counts.
        depth = depth.min(-optional(def, q, 0.0)?.abs());
    }
    if !(radius.is_finite() && below.is_finite()) {
        return Err("its extent around the axis is not a number".into());
    }
    Ok(Reach {
        levels: [
            surface,
            surface + depth,
            surface + clearance,
            surface + clearance.max(second),
        ],
        radius,
        below,
        around,
    })
}

/// One step of a hole's motion along its axis as the control makes it, the levels along
/// the tool axis in program units.
#[derive(Debug, Clone, PartialEq)]
pub enum HoleStep {
    /// At rapid traverse (FMAX) to a level.
    Rapid(f64),
    /// At feed to a level, the feed as the definition gives it (`150`, `Q3`).
    Feed(f64, String),
    /// A dwell (seconds).
    Dwell(f64),
}

/// At most this many steps for one hole (a plunging depth that makes more is refused).
const MAX_STEPS: usize = 2000;

/// The motion of drilling cycle `def` along the hole's axis from where the call leaves the
/// tool over the hole, as the TNC cycles' descriptions give it (docs/heidenhain.md, "Holes
/// written out as L moves"), for the cycles whose motion is known exactly: 200 (drilling, with
/// its pecks and dwells), 201 (reaming), 240 (centering to a depth). `text(q)`: the
/// definition's text of parameter Q`q` (a number or a Q parameter). `Err`: why the motion
/// is not written out.
pub fn hole_steps<'a>(
    def: &CycleDef,
    text: impl Fn(u32) -> Option<&'a str>,
) -> Result<Vec<HoleStep>, String> {
    if def.siemens.is_some() {
        return Err("a Sinumerik drilling cycle is not written out as moves".into());
    }
    let reach = reach(def, false)?;
    let [surface, bottom, clearance, end] = reach.levels;
    let param = |q: u32, what: &str| -> Result<String, String> {
        let t = text(q).ok_or_else(|| format!("its {what} Q{q} is not given"))?;
        known(def, q)?;
        Ok(t.to_string())
    };
    let dwell = |q: u32, steps: &mut Vec<HoleStep>| -> Result<(), String> {
        let seconds = optional(def, q, 0.0)?;
        if seconds > 0.0 {
            steps.push(HoleStep::Dwell(seconds));
        }
        Ok(())
    };
    let mut steps = vec![HoleStep::Rapid(clearance)];
    match def.number {
        200 => {
            let feed = param(206, "feed rate for plunging")?;
            let plunge = known(def, 202)?;
            if !(plunge.is_finite() && plunge > 0.0) {
                return Err(format!(
                    "expected a plunging depth Q202 greater than 0 (it is {plunge})"
                ));
            }
            // Each infeed from the set-up clearance above the depth reached; the control
            // goes to depth in one movement where the plunging depth is the depth or more.
            let total = surface - bottom;
            let advance = clearance - surface;
            let mut reached = 0.0;
            loop {
                let next = (reached + plunge).min(total);
                steps.push(HoleStep::Feed(surface - next, feed.clone()));
                if next >= total || steps.len() > MAX_STEPS {
                    break;
                }
                steps.push(HoleStep::Rapid(clearance));
                dwell(210, &mut steps)?;
                steps.push(HoleStep::Rapid(surface - next + advance));
                reached = next;
            }
            if steps.len() > MAX_STEPS {
                return Err(format!(
                    "its plunging depth Q202 = {plunge} makes more than {MAX_STEPS} moves"
                ));
            }
            dwell(211, &mut steps)?;
            steps.push(HoleStep::Rapid(end));
        }
        201 => {
            let feed = param(206, "feed rate for plunging")?;
            steps.push(HoleStep::Feed(bottom, feed.clone()));
            dwell(211, &mut steps)?;
            // Out at the retraction feed (Q208 = 0: the reaming feed), then to the 2nd
            // set-up clearance at FMAX.
            let back = if optional(def, 208, 0.0)? == 0.0 {
                feed
            } else {
                param(208, "retraction feed rate")?
            };
            steps.push(HoleStep::Feed(clearance, back));
            if end > clearance {
                steps.push(HoleStep::Rapid(end));
            }
        }
        240 => {
            let feed = param(206, "feed rate for plunging")?;
            steps.push(HoleStep::Feed(bottom, feed));
            dwell(211, &mut steps)?;
            steps.push(HoleStep::Rapid(end));
        }
        n => {
            return Err(format!(
                "cycle {n}'s motion is not written out as moves (nccomp writes out 200, 201 and 240, whose motion it knows exactly{})",
                match n {
                    202 => "; boring stops and orients the spindle at the bottom",
                    203 | 205 =>
                        "; its chip breaking and advanced stop distances are the control's",
                    206 | 207 | 209 => "; tapping turns the spindle with the feed",
                    241 => "; it changes the spindle's speed and direction and the coolant",
                    _ => "",
                }
            ));
        }
    }
    Ok(steps)
}

/// The value parameter `key` (`Q203`) is set to in a definition line: where its text
/// starts and its bytes (up to a space, `;` or `~`), however the spaces fall around the `=`
/// (`Q203=-1.5`, `Q203=  -1.5`, `Q203 = -1.5`). Not in the line's comment, nor another
/// parameter (`Q2030`) or a value (`Q204=Q203`).
pub fn value_at<'a>(line: &'a [u8], key: &[u8]) -> Option<(usize, &'a [u8])> {
    let end = line.iter().position(|&b| b == b';').unwrap_or(line.len());
    let line = &line[..end];
    let blank = |b: Option<&u8>| matches!(b, Some(b' ' | b'\t'));
    let mut from = 0;
    while let Some(found) = line[from..].windows(key.len()).position(|w| w == key) {
        let start = from + found;
        from = start + 1;
        let mut i = start + key.len();
        if line.get(i).is_some_and(u8::is_ascii_digit)
            || (start > 0 && !matches!(line[start - 1], b' ' | b'\t'))
        {
            continue;
        }
        while blank(line.get(i)) {
            i += 1;
        }
        if line.get(i) != Some(&b'=') {
            continue;
        }
        i += 1;
        while blank(line.get(i)) {
            i += 1;
        }
        let len = line[i..]
            .iter()
            .take_while(|b| !matches!(b, b' ' | b'\t' | b'~' | b'\r'))
            .count();
        return Some((i, &line[i..i + len]));
    }
    None
}

/// The text parameter Q`q` is given in a definition (`150`, `Q3`), from its lines.
pub fn param_text(def: &CycleDef, q: u32) -> Option<&str> {
    let key = format!("Q{q}");
    def.text.iter().skip(1).find_map(|line| {
        let (_, value) = value_at(line, key.as_bytes())?;
        std::str::from_utf8(value).ok().filter(|t| !t.is_empty())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn def(number: u32, params: &[(u32, f64)]) -> CycleDef {
        let mut text = vec![format!("1 CYCL DEF {number} X~").into_bytes()];
        for (k, v) in params {
            text.push(format!("  Q{k}={v} ;~").into_bytes());
        }
        CycleDef {
            number,
            line: 1,
            params: params.iter().map(|&(k, v)| (k, Param::Known(v))).collect(),
            text,
            surface_written: None,
            siemens: None,
        }
    }

    #[test]
    fn pecks_go_back_to_the_clearance_and_down_to_the_clearance_above_the_depth_reached() {
        let d = def(
            200,
            &[
                (200, 2.0),
                (201, -10.0),
                (206, 150.0),
                (202, 4.0),
                (210, 0.5),
                (203, 0.0),
                (204, 30.0),
                (211, 1.0),
            ],
        );
        let steps = hole_steps(&d, |q| param_text(&d, q)).unwrap();
        use HoleStep::*;
        let f = || "150".to_string();
        assert_eq!(
            steps,
            vec![
                Rapid(2.0),
                Feed(-4.0, f()),
                Rapid(2.0),
                Dwell(0.5),
                Rapid(-2.0),
                Feed(-8.0, f()),
                Rapid(2.0),
                Dwell(0.5),
                Rapid(-6.0),
                Feed(-10.0, f()),
                Dwell(1.0),
                Rapid(30.0),
            ]
        );
    }

    #[test]
    fn a_plunging_depth_of_the_depth_or_more_goes_down_in_one_movement() {
        let d = def(
            200,
            &[
                (200, 3.0),
                (201, -12.0),
                (206, 100.0),
                (202, 12.0),
                (203, -1.5),
            ],
        );
        let steps = hole_steps(&d, |q| param_text(&d, q)).unwrap();
        use HoleStep::*;
        assert_eq!(
            steps,
            vec![Rapid(1.5), Feed(-13.5, "100".into()), Rapid(1.5)]
        );
    }

    #[test]
    fn reaming_retracts_at_its_retraction_feed_then_rapid_to_the_second_clearance() {
        let d = def(
            201,
            &[
                (200, 2.0),
                (201, -15.0),
                (206, 100.0),
                (211, 0.0),
                (208, 250.0),
                (203, 0.0),
                (204, 20.0),
            ],
        );
        let steps = hole_steps(&d, |q| param_text(&d, q)).unwrap();
        use HoleStep::*;
        assert_eq!(
            steps,
            vec![
                Rapid(2.0),
                Feed(-15.0, "100".into()),
                Feed(2.0, "250".into()),
                Rapid(20.0)
            ]
        );
    }

    #[test]
    fn cycles_whose_motion_depends_on_the_tool_or_the_spindle_are_not_written_out() {
        for (number, params) in [
            (207, vec![(200, 2.0), (201, -10.0), (239, 1.25), (203, 0.0)]),
            (241, vec![(200, 2.0), (201, -10.0), (206, 25.0), (203, 0.0)]),
            (
                240,
                vec![(200, 2.0), (343, 1.0), (201, -1.0), (206, 25.0), (203, 0.0)],
            ),
        ] {
            let d = def(number, &params);
            assert!(hole_steps(&d, |q| param_text(&d, q)).is_err(), "{number}");
        }
    }

    #[test]
    fn the_reach_of_milling_cycles_is_their_radius() {
        let d = def(
            208,
            &[
                (200, 0.5),
                (201, -0.5),
                (203, -17.5),
                (204, 92.5),
                (335, 10.2),
            ],
        );
        let r = reach(&d, false).unwrap();
        assert_eq!(r.levels, [-17.5, -18.0, -17.0, 75.0]);
        assert_eq!(r.radius, 5.1);
        let d = def(
            262,
            &[
                (335, 30.0),
                (239, 3.5),
                (201, -59.5),
                (200, 4.0),
                (203, 4.5),
                (204, 25.5),
            ],
        );
        let r = reach(&d, false).unwrap();
        assert_eq!((r.radius, r.below), (15.0, 7.0));
        let d = def(
            251,
            &[
                (218, 60.0),
                (219, 80.0),
                (367, 1.0),
                (201, -5.0),
                (200, 2.0),
                (203, 0.0),
            ],
        );
        assert!(reach(&d, false).unwrap_err().contains("Q367"));
    }
}

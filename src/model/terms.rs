//! ISO 230 error names, and the one place where they are mapped onto the model.
//!
//! A name is `E` + a component letter + an optional `0` + an axis name:
//!
//! - `E<c><axis>` is an **error motion**, a function of the axis position (ISO 230-1):
//!   for axis X, EXX is positioning, EYX and EZX straightness, EAX roll, EBX pitch and
//!   ECX yaw; for axis C, EXC and EYC are radial, EZC axial, EAC and EBC tilt and ECC the
//!   angular positioning error motion. It is a column of a [`MotionTable`].
//! - `E<c>0<axis>` is a **position-independent** term, a single value. Of a linear axis it
//!   is a squareness angle (EC0Y: the direction of motion of Y rotated about +Z, with
//!   `d̃ = Rv(s)·d`). Of a rotary axis it is a location error (ISO 230-7): EX0C and EY0C
//!   shift the axis line (`c̃ = c + shift`), EA0C and EB0C tilt it (`ã = Rv(tilt)·a`),
//!   and the term about the axis's own direction, EC0C, is its zero-position error `e0`.
//!
//! Component letters X, Y, Z name lengths (mm in the model), A, B, C angles (rad).
//! An axis's **own direction** is the coordinate axis (X, Y or Z) with the largest
//! |component| of its nominal direction (the first of them on a tie). A term that would
//! act along or about it is meaningless (a shift of a rotary axis along its own line, a
//! squareness of a linear axis about its own direction) and is rejected.

use super::{Axis, AxisErrors, AxisKind, MotionTable};
use std::fmt;

/// An error component: a translation along X, Y, Z or a rotation about X (A), Y (B),
/// Z (C), in the order of [`MotionTable::values`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Component {
    X,
    Y,
    Z,
    A,
    B,
    C,
}

impl Component {
    pub const ALL: [Component; 6] = [
        Component::X,
        Component::Y,
        Component::Z,
        Component::A,
        Component::B,
        Component::C,
    ];

    /// 0..5 in the order X Y Z A B C: the index into [`MotionTable::values`].
    pub fn index(self) -> usize {
        self as usize
    }

    /// The coordinate axis it acts along or about: 0 for X and A, 1 for Y and B, 2 for
    /// Z and C.
    pub fn coordinate(self) -> usize {
        self.index() % 3
    }

    /// X, Y and Z are lengths; A, B and C are angles.
    pub fn is_length(self) -> bool {
        self.index() < 3
    }

    pub fn letter(self) -> char {
        b"XYZABC"[self.index()] as char
    }

    pub fn from_letter(letter: char) -> Option<Self> {
        Component::ALL.into_iter().find(|c| c.letter() == letter)
    }

    /// The length component along coordinate axis `i` (0..2).
    pub fn length(i: usize) -> Self {
        Component::ALL[i]
    }

    /// The angle component about coordinate axis `i` (0..2).
    pub fn angle(i: usize) -> Self {
        Component::ALL[3 + i]
    }
}

/// Whether a term's value is a length or an angle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    Length,
    Angle,
}

/// A parsed error name such as `EYX`, `EC0Y` or `EX0C2`. It borrows the axis name from
/// the text it was parsed from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TermName<'a> {
    pub component: Component,
    /// `true` for a position-independent term (`E<c>0<axis>`), `false` for an error
    /// motion (`E<c><axis>`).
    pub constant: bool,
    pub axis: &'a str,
}

impl TermName<'_> {
    /// Lengths for X/Y/Z components, angles for A/B/C (for every meaningful term).
    pub fn quantity(&self) -> Quantity {
        if self.component.is_length() {
            Quantity::Length
        } else {
            Quantity::Angle
        }
    }
}

impl fmt::Display for TermName<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let zero = if self.constant { "0" } else { "" };
        write!(f, "E{}{}{}", self.component.letter(), zero, self.axis)
    }
}

/// Whether `name` is a valid axis name: `[A-Z][A-Z0-9]*`.
pub fn is_axis_name(name: &str) -> bool {
    let mut chars = name.chars();
    chars.next().is_some_and(|c| c.is_ascii_uppercase())
        && chars.all(|c| c.is_ascii_uppercase() || c.is_ascii_digit())
}

/// Parse an error name: `"E"` + component letter + optional `"0"` + axis name,
/// case-sensitive. Axis names start with a letter, so the `0` is never ambiguous.
/// Whether the axis exists is the caller's question.
pub fn parse(name: &str) -> Option<TermName<'_>> {
    let rest = name.strip_prefix('E')?;
    let mut chars = rest.chars();
    let component = Component::from_letter(chars.next()?)?;
    let rest = chars.as_str();
    let (constant, axis) = match rest.strip_prefix('0') {
        Some(axis) => (true, axis),
        None => (false, rest),
    };
    is_axis_name(axis).then_some(TermName {
        component,
        constant,
        axis,
    })
}

/// Parse an error name as calibration files from the field write it: the contract's own
/// names (`EYX`, `EC0Y`), or the position-independent terms in the ISO 230 notation
/// without the leading `E` that Beckhoff/ISG volumetric compensation tables and Etalon
/// exchange files use (`C0Y` is EC0Y, `X0B` is EX0B). The two forms cannot be confused:
/// `E` is not a component letter.
pub fn parse_field(name: &str) -> Option<TermName<'_>> {
    if let Some(term) = parse(name) {
        return Some(term);
    }
    let mut chars = name.chars();
    let component = Component::from_letter(chars.next()?)?;
    let axis = chars.as_str().strip_prefix('0')?;
    is_axis_name(axis).then_some(TermName {
        component,
        constant: true,
        axis,
    })
}

/// The coordinate axis (0 X, 1 Y, 2 Z) with the largest |component| of the axis's
/// nominal direction; the first of them on a tie.
pub fn own_direction(axis: &Axis) -> usize {
    let d = axis.direction.abs();
    let mut own = 0;
    for i in 1..3 {
        if d[i] > d[own] {
            own = i;
        }
    }
    own
}

/// Where a term goes in the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// An error motion: a column of the axis's [`MotionTable`].
    Motion(Component),
    /// Linear axis: component `i` of the squareness rotation vector s.
    Squareness(usize),
    /// Rotary axis: component `i` of the shift of the axis line.
    LocationShift(usize),
    /// Rotary axis: component `i` of the tilt rotation vector of the axis line.
    LocationTilt(usize),
    /// Rotary axis: the zero-position error e0.
    Zero,
}

/// What a term means for `axis`, or why it means nothing.
pub fn role(term: &TermName, axis: &Axis) -> Result<Role, String> {
    if term.axis != axis.name {
        return Err(format!(
            "`{term}` is a term of axis {}, not of axis {}",
            term.axis, axis.name
        ));
    }
    if !term.constant {
        return Ok(Role::Motion(term.component));
    }
    let i = term.component.coordinate();
    let own = own_direction(axis);
    let own_letter = Component::length(own).letter();
    match (axis.kind, term.component.is_length()) {
        (AxisKind::Linear, true) => Err(format!(
            "`{term}` is not an error of linear axis {}: its position-independent errors are \
             the squareness angles {}",
            axis.name,
            or_list(&constant_names(axis)),
        )),
        (AxisKind::Linear, false) if i == own => Err(format!(
            "`{term}` is meaningless: it would turn the direction of motion of linear axis {} \
             about itself ({own_letter}); its squareness terms are {}",
            axis.name,
            and_list(&constant_names(axis)),
        )),
        (AxisKind::Linear, false) => Ok(Role::Squareness(i)),
        (AxisKind::Rotary, true) if i == own => Err(format!(
            "`{term}` is meaningless: it would shift rotary axis {} along its own line \
             ({own_letter}); the shifts of its line are {}",
            axis.name,
            and_list(&shift_names(axis)),
        )),
        (AxisKind::Rotary, true) => Ok(Role::LocationShift(i)),
        (AxisKind::Rotary, false) if i == own => Ok(Role::Zero),
        (AxisKind::Rotary, false) => Ok(Role::LocationTilt(i)),
    }
}

/// Set a position-independent term (value in mm or rad) on the errors of `axis`.
/// Error motions, and terms that mean nothing for the axis, are refused with a message.
pub fn apply_constant(
    errors: &mut AxisErrors,
    axis: &Axis,
    term: &TermName,
    value: f64,
) -> Result<(), String> {
    match role(term, axis)? {
        Role::Motion(_) => {
            return Err(format!(
                "`{term}` is an error motion, a function of the position of axis {}: give it \
                 as a series under [motion.{}]",
                axis.name, axis.name
            ));
        }
        Role::Squareness(i) => errors.squareness[i] = value,
        Role::LocationShift(i) => errors.location_shift[i] = value,
        Role::LocationTilt(i) => errors.location_tilt[i] = value,
        Role::Zero => errors.zero = value,
    }
    Ok(())
}

/// Set an error-motion series (values in mm or rad, one per table position) on `table`,
/// the motion table of `axis`. Position-independent terms are refused with a message.
pub fn apply_motion(
    table: &mut MotionTable,
    axis: &Axis,
    term: &TermName,
    series: Vec<f64>,
) -> Result<(), String> {
    match role(term, axis)? {
        Role::Motion(c) => {
            table.values[c.index()] = Some(series);
            Ok(())
        }
        _ => Err(format!(
            "`{term}` is a position-independent term of axis {}, a single value, not an \
             error motion",
            axis.name
        )),
    }
}

/// The position-independent names that are meaningful for `axis`: its squareness terms
/// (linear) or its location terms, shifts, tilts and zero error (rotary).
pub fn constant_names(axis: &Axis) -> Vec<String> {
    let own = own_direction(axis);
    let name = |c: Component| format!("E{}0{}", c.letter(), axis.name);
    match axis.kind {
        AxisKind::Linear => (0..3)
            .filter(|&i| i != own)
            .map(|i| name(Component::angle(i)))
            .collect(),
        AxisKind::Rotary => {
            let mut names = shift_names(axis);
            names.extend((0..3).map(|i| name(Component::angle(i))));
            names
        }
    }
}

fn shift_names(axis: &Axis) -> Vec<String> {
    let own = own_direction(axis);
    (0..3)
        .filter(|&i| i != own)
        .map(|i| format!("E{}0{}", Component::length(i).letter(), axis.name))
        .collect()
}

/// The six error-motion names of `axis`, in component order.
pub fn motion_names(axis: &Axis) -> Vec<String> {
    Component::ALL
        .iter()
        .map(|c| format!("E{}{}", c.letter(), axis.name))
        .collect()
}

/// Every meaningful name of `axis`: [`constant_names`] then [`motion_names`].
pub fn valid_names(axis: &Axis) -> Vec<String> {
    let mut names = constant_names(axis);
    names.extend(motion_names(axis));
    names
}

/// The candidate `name` was most likely meant to be, if one is close: the same letters
/// in another case, or one edit away (an insertion, deletion, substitution or swap of
/// two neighbouring letters; two edits for names of six letters or more). Among equally
/// close candidates the one sharing the longest beginning wins, then the first.
pub fn suggest<'c, I>(name: &str, candidates: I) -> Option<&'c str>
where
    I: IntoIterator<Item = &'c str>,
{
    let wanted: Vec<char> = name.to_uppercase().chars().collect();
    let limit = if wanted.len() >= 6 { 2 } else { 1 };
    // Fewest edits first; among those, the longest common beginning.
    let mut best: Option<((usize, usize), &str)> = None;
    for candidate in candidates {
        let other: Vec<char> = candidate.to_uppercase().chars().collect();
        let d = edit_distance(&wanted, &other);
        let close = d == 0 || (d <= limit && wanted.len().min(other.len()) >= 2);
        let prefix = wanted
            .iter()
            .zip(&other)
            .take_while(|(a, b)| a == b)
            .count();
        let score = (d, usize::MAX - prefix);
        if close && best.is_none_or(|(bs, _)| score < bs) {
            best = Some((score, candidate));
        }
    }
    best.map(|(_, c)| c)
}

/// Optimal string alignment distance (Levenshtein with swaps of neighbours).
fn edit_distance(a: &[char], b: &[char]) -> usize {
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, v) in d[0].iter_mut().enumerate() {
        *v = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut v = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                v = v.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = v;
        }
    }
    d[a.len()][b.len()]
}

/// `A, B or C` (for "expected one of" messages).
pub fn or_list(names: &[String]) -> String {
    join(names, "or")
}

/// `A, B and C`.
pub fn and_list(names: &[String]) -> String {
    join(names, "and")
}

fn join(names: &[String], last: &str) -> String {
    match names {
        [] => String::new(),
        [one] => one.clone(),
        [init @ .., tail] => format!("{} {last} {tail}", init.join(", ")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    fn axis(name: &str, kind: AxisKind, direction: [f64; 3]) -> Axis {
        Axis {
            name: name.to_string(),
            word: name.chars().next().unwrap(),
            kind,
            direction: Vector3::from(direction).normalize(),
            point: Vector3::zeros(),
            travel: None,
            table_offset: 0.0,
            rollover: false,
        }
    }

    #[test]
    fn parses_motion_and_constant_names() {
        let t = parse("EYX").unwrap();
        assert_eq!(
            (t.component, t.constant, t.axis),
            (Component::Y, false, "X")
        );
        let t = parse("EC0Y").unwrap();
        assert_eq!((t.component, t.constant, t.axis), (Component::C, true, "Y"));
        let t = parse("EX0C2").unwrap();
        assert_eq!(
            (t.component, t.constant, t.axis),
            (Component::X, true, "C2")
        );
        let t = parse("EXX2").unwrap();
        assert_eq!(
            (t.component, t.constant, t.axis),
            (Component::X, false, "X2")
        );
        assert_eq!(t.to_string(), "EXX2");
        assert_eq!(parse("EC0Y").unwrap().to_string(), "EC0Y");
        assert_eq!(parse("EC0Y").unwrap().quantity(), Quantity::Angle);
        assert_eq!(parse("EX0C").unwrap().quantity(), Quantity::Length);
    }

    #[test]
    fn rejects_malformed_names() {
        for bad in [
            "", "E", "EX", "EX0", "eyx", "EyX", "FYX", "EQX", "EX00C", "EX0c", "EXx", "E0XC",
            "EX-C", "EX0 C",
        ] {
            assert_eq!(parse(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn parses_field_names() {
        let t = parse_field("X0B").unwrap();
        assert_eq!((t.component, t.constant, t.axis), (Component::X, true, "B"));
        assert_eq!(t.to_string(), "EX0B");
        assert_eq!(parse_field("C0Y").unwrap().to_string(), "EC0Y");
        assert_eq!(parse_field("EYX").unwrap().to_string(), "EYX");
        assert_eq!(parse_field("EC0Y").unwrap().to_string(), "EC0Y");
        for bad in [
            "X", "XB", "X0", "Q0B", "x0B", "X0b", "P0X", "PXA", "VXX", "IDX", "LNX",
        ] {
            assert_eq!(parse_field(bad), None, "{bad:?}");
        }
    }

    #[test]
    fn own_direction_is_the_largest_component() {
        assert_eq!(
            own_direction(&axis("A", AxisKind::Rotary, [-1.0, 0.0, 0.0])),
            0
        );
        assert_eq!(
            own_direction(&axis("B", AxisKind::Rotary, [0.0, -1.0, 0.0])),
            1
        );
        assert_eq!(
            own_direction(&axis("C", AxisKind::Rotary, [0.0, 0.0, 1.0])),
            2
        );
        // A nutating B axis at 30° from Z: still "about Z".
        let b = axis("B", AxisKind::Rotary, [0.0, 0.5, 0.866]);
        assert_eq!(own_direction(&b), 2);
        // Tie: the first.
        assert_eq!(
            own_direction(&axis("B", AxisKind::Rotary, [0.0, 1.0, 1.0])),
            1
        );
    }

    #[test]
    fn rotary_terms_by_own_direction() {
        let a = axis("A", AxisKind::Rotary, [-1.0, 0.0, 0.0]);
        let r = |n: &str| role(&parse(n).unwrap(), &a);
        assert_eq!(r("EA0A"), Ok(Role::Zero));
        assert_eq!(r("EY0A"), Ok(Role::LocationShift(1)));
        assert_eq!(r("EZ0A"), Ok(Role::LocationShift(2)));
        assert_eq!(r("EB0A"), Ok(Role::LocationTilt(1)));
        assert_eq!(r("EC0A"), Ok(Role::LocationTilt(2)));
        assert_eq!(r("EXA"), Ok(Role::Motion(Component::X)));
        let e = r("EX0A").unwrap_err();
        assert!(e.contains("meaningless") && e.contains("own line"), "{e}");
        assert!(e.contains("EY0A and EZ0A"), "{e}");
        let c = axis("C", AxisKind::Rotary, [0.0, 0.0, -1.0]);
        assert_eq!(role(&parse("EC0C").unwrap(), &c), Ok(Role::Zero));
        assert!(role(&parse("EZ0C").unwrap(), &c).is_err());
        assert_eq!(
            constant_names(&c),
            ["EX0C", "EY0C", "EA0C", "EB0C", "EC0C"].map(String::from)
        );
    }

    #[test]
    fn linear_terms_by_own_direction() {
        let x = axis("X", AxisKind::Linear, [-1.0, 0.0, 0.0]);
        let e = role(&parse("EA0X").unwrap(), &x).unwrap_err();
        assert!(
            e.contains("meaningless") && e.contains("EB0X and EC0X"),
            "{e}"
        );
        let e = role(&parse("EY0X").unwrap(), &x).unwrap_err();
        assert!(e.contains("squareness"), "{e}");
        let y = axis("Y", AxisKind::Linear, [0.0, 1.0, 0.0]);
        assert_eq!(role(&parse("EC0Y").unwrap(), &y), Ok(Role::Squareness(2)));
        assert_eq!(role(&parse("EA0Y").unwrap(), &y), Ok(Role::Squareness(0)));
        let z = axis("Z", AxisKind::Linear, [0.0, 0.0, 1.0]);
        assert_eq!(constant_names(&z), ["EA0Z", "EB0Z"].map(String::from));
        assert!(role(&parse("EC0Y").unwrap(), &z).is_err());
    }

    #[test]
    fn applies_constants_and_refuses_motions() {
        let c = axis("C", AxisKind::Rotary, [0.0, 0.0, -1.0]);
        let mut e = AxisErrors::default();
        for (n, v) in [("EX0C", 1.0), ("EY0C", 2.0), ("EA0C", 3.0), ("EB0C", 4.0)] {
            apply_constant(&mut e, &c, &parse(n).unwrap(), v).unwrap();
        }
        apply_constant(&mut e, &c, &parse("EC0C").unwrap(), 5.0).unwrap();
        assert_eq!(e.location_shift, Vector3::new(1.0, 2.0, 0.0));
        assert_eq!(e.location_tilt, Vector3::new(3.0, 4.0, 0.0));
        assert_eq!(e.zero, 5.0);
        assert!(apply_constant(&mut e, &c, &parse("EXC").unwrap(), 1.0).is_err());

        let y = axis("Y", AxisKind::Linear, [0.0, -1.0, 0.0]);
        let mut e = AxisErrors::default();
        apply_constant(&mut e, &y, &parse("EC0Y").unwrap(), 0.5).unwrap();
        assert_eq!(e.squareness, Vector3::new(0.0, 0.0, 0.5));
        assert!(apply_constant(&mut e, &y, &parse("EC0X").unwrap(), 1.0).is_err());

        let mut t = MotionTable {
            positions: vec![0.0, 1.0],
            values: Default::default(),
            periodic: false,
        };
        apply_motion(&mut t, &y, &parse("EZY").unwrap(), vec![1.0, 2.0]).unwrap();
        assert_eq!(t.values[2], Some(vec![1.0, 2.0]));
        assert!(apply_motion(&mut t, &y, &parse("EC0Y").unwrap(), vec![0.0; 2]).is_err());
    }

    #[test]
    fn suggests_close_names() {
        let x = axis("X", AxisKind::Linear, [1.0, 0.0, 0.0]);
        let names = valid_names(&x);
        let s = |n: &str| suggest(n, names.iter().map(String::as_str));
        assert_eq!(s("EYXX"), Some("EYX"));
        assert_eq!(s("eyx"), Some("EYX"));
        assert_eq!(s("EYZ"), Some("EYX"));
        assert_eq!(s("EC0x"), Some("EC0X"));
        assert_eq!(s("YEX"), Some("EYX"));
        assert_eq!(s("QQQQ"), None);
        assert_eq!(suggest("x", ["X", "Y"]), Some("X"));
        assert_eq!(suggest("Q", ["X", "Y"]), None);
    }

    #[test]
    fn lists_read_well() {
        let n = |v: &[&str]| v.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert_eq!(or_list(&n(&["A"])), "A");
        assert_eq!(or_list(&n(&["A", "B", "C"])), "A, B or C");
        assert_eq!(and_list(&n(&["A", "B"])), "A and B");
    }
}

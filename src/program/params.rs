//! Parameters (Fanuc macro variables `#100`, LinuxCNC's `#<name>`): the ones a program sets
//! to a constant are known from its text, so a word that uses one means that number.
//!
//! An assignment line (`#100 = 12.5`, `#<depth> = -3.`) records the value; an assignment
//! of anything else (an expression, another parameter, a system variable) makes the
//! parameter's value unknown, and a word that needs it is refused where it stands. Before a
//! line is read, [`substitute`] replaces each parameter word whose value is known by that
//! number, so the rest of the pass reads it as a number; a word that is corrected is then
//! written as a number (the editor replaces the value's bytes), one that is not keeps its
//! bytes. Writing to the controller's offset variables (see `is_offset_variable`) would
//! move program zero or the tool length: that is refused.

use crate::nc::{Token, TokenKind, Value};

/// A parameter's value as the program set it: the number and its decimals as written, or
/// `None` when it is not a constant.
pub type Known = Option<(f64, u8)>;

/// Parameters the program has assigned, in order of first assignment.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Params {
    values: Vec<(String, Known)>,
}

impl Params {
    /// The value of parameter `name` (`100`, `<depth>` lowercased): `None` when the
    /// program never set it, `Some(None)` when it set it to something not constant.
    pub fn get(&self, name: &str) -> Option<Known> {
        self.values.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
    }

    /// Set parameter `name` to `value` (`None`: not a constant).
    pub fn set(&mut self, name: String, value: Known) {
        match self.values.iter_mut().find(|(n, _)| *n == name) {
            Some(slot) => slot.1 = value,
            None => self.values.push((name, value)),
        }
    }
}

/// The name of a parameter reference `#100` or `#<Name>` (lowercased), or `None` for an
/// indirect one (`##1`, `#[…]`).
pub fn name_of(text: &[u8]) -> Option<String> {
    let rest = text.strip_prefix(b"#")?;
    if rest.first().is_some_and(u8::is_ascii_digit) && rest.iter().all(u8::is_ascii_digit) {
        let n: u64 = std::str::from_utf8(rest).ok()?.parse().ok()?;
        return Some(n.to_string());
    }
    if rest.starts_with(b"<") && rest.ends_with(b">") {
        let inner: Vec<u8> = rest[1..rest.len() - 1]
            .iter()
            .filter(|b| !b.is_ascii_whitespace())
            .map(u8::to_ascii_lowercase)
            .collect();
        return Some(format!("<{}>", String::from_utf8_lossy(&inner)));
    }
    None
}

/// Whether assigning parameter `name` changes what the controller does with positions:
/// FANUC's tool offsets (#2000–#2999), work offsets (#5201–#5335) and extended work
/// offsets (#7001–#7954, #14001–#19988); LinuxCNC's reference points, G92 and work
/// offsets (#5161–#5390). Other system variables (LinuxCNC's #5599 debug switch, FANUC's
/// #3000 alarm) move nothing.
fn is_offset_variable(name: &str) -> bool {
    name.parse::<u64>().is_ok_and(|n| {
        (2000..=2999).contains(&n)
            || (5161..=5390).contains(&n)
            || (7001..=7954).contains(&n)
            || (14001..=19988).contains(&n)
    })
}

/// A literal number as written (`12.5`, `-3.`, `+.5`): its value and decimals.
fn literal(text: &str) -> Option<(f64, u8)> {
    let t = text.trim();
    let digits = t.trim_start_matches(['+', '-']);
    if digits.is_empty()
        || !digits.bytes().all(|b| b.is_ascii_digit() || b == b'.')
        || digits.bytes().filter(|&b| b == b'.').count() > 1
        || t.len() - digits.len() > 1
        || !digits.bytes().any(|b| b.is_ascii_digit())
    {
        return None;
    }
    let decimals = digits.find('.').map_or(0, |p| digits.len() - p - 1) as u8;
    Some((t.parse().ok()?, decimals))
}

/// Follow the assignments of a line whose text starts with `#` (`content` without its
/// comments is `#name = value`, one or more): their values, or an error (byte offset,
/// message) for one that writes an offset variable. False when the line is not an
/// assignment.
pub fn assign(content: &[u8], params: &mut Params) -> Result<bool, (usize, String)> {
    let text = String::from_utf8_lossy(content);
    // Comments end the block's text: `(…)` and `;…`.
    let end = text.find([';', '(']).unwrap_or(text.len());
    let body = &text[..end];
    let Some(eq) = body.find('=') else {
        return Ok(false);
    };
    let target = body[..eq].trim();
    let Some(name) = name_of(target.as_bytes()) else {
        return Ok(false);
    };
    if is_offset_variable(&name) {
        return Err((
            body.find('#').unwrap_or(0),
            format!(
                "`{target}` is one of the controller's offset variables (FANUC #2000–#2999 tool offsets, #5201–#5335, #7001–#7954 and #14001–#19988 work offsets; LinuxCNC #5161–#5390 reference points and offsets): writing it moves program zero or the tool length, which cannot be compensated (expected G10 L2/L20 with a [work_offsets] table)"
            ),
        ));
    }
    params.set(name, literal(&body[eq + 1..]));
    Ok(true)
}

/// Make the parameter an assignment line `content` sets unknown (the line is optional).
pub fn forget(content: &[u8], params: &mut Params) {
    let text = String::from_utf8_lossy(content);
    if let Some(eq) = text.find('=')
        && let Some(name) = name_of(text[..eq].trim().as_bytes())
    {
        params.set(name, None);
    }
}

/// Replace every parameter word of `tokens` whose value `params` knows by that number.
/// Words whose parameter is not known stay parameters (the reader decides whether the
/// word may be one).
pub fn substitute(content: &[u8], tokens: &mut [Token], params: &Params) {
    // The reader has already told numbers from parameters and expressions: a block of
    // numbers pays one look at each word's kind, not a search of its bytes.
    for t in tokens.iter_mut() {
        let TokenKind::Word(w) = &mut t.kind else {
            continue;
        };
        if !matches!(w.value, Value::Parameter | Value::Expression) {
            continue;
        }
        let Some(text) = content.get(w.value_span.clone()) else {
            continue;
        };
        let known = match w.value {
            Value::Parameter => name_of(text).and_then(|n| params.get(&n)).flatten(),
            _ => evaluate(text, params),
        };
        if let Some((value, decimals)) = known {
            w.value = Value::Number { value, decimals };
        }
    }
}

/// The value of a constant expression (`[180.0-0.642]`, `-[#100*2]`): `+ - * /` and
/// brackets over numbers and parameters the program set to constants, as the control
/// computes it; its decimals are the fewest (at most 9) that hold it. `None` for anything
/// else: a parameter not known, a function (SIN …), MOD or a logical operator, more
/// decimals.
pub fn evaluate(text: &[u8], params: &Params) -> Option<(f64, u8)> {
    evaluate_in(text, params, false)
}

/// [`evaluate`] in Sinumerik's syntax: `( )` brackets, and variables by name (`_DEPTH`,
/// `R12`, uppercased in `params`).
pub fn evaluate_840d(text: &[u8], params: &Params) -> Option<(f64, u8)> {
    evaluate_in(text, params, true)
}

fn evaluate_in(text: &[u8], params: &Params, siemens: bool) -> Option<(f64, u8)> {
    let mut p = Expr {
        text,
        at: 0,
        params,
        depth: 0,
        siemens,
    };
    let value = p.sum()?;
    p.blank();
    if p.at != text.len() || !value.is_finite() {
        return None;
    }
    let decimals = (0..=9u8).find(|&d| {
        let x = value * 10f64.powi(d.into());
        (x - x.round()).abs() <= 1e-6
    })?;
    Some((value, decimals))
}

/// A recursive-descent reader of an expression's text.
struct Expr<'t> {
    text: &'t [u8],
    at: usize,
    params: &'t Params,
    /// Brackets and signs open (a line may hold a million: the reader's stack may not).
    depth: u32,
    /// Sinumerik's syntax.
    siemens: bool,
}

/// The most brackets and unary signs nested that [`evaluate`] reads.
const MAX_DEPTH: u32 = 64;

impl Expr<'_> {
    fn blank(&mut self) {
        while self.text.get(self.at).is_some_and(u8::is_ascii_whitespace) {
            self.at += 1;
        }
    }

    fn next_is(&mut self, b: u8) -> bool {
        self.blank();
        if self.text.get(self.at) == Some(&b) {
            self.at += 1;
            true
        } else {
            false
        }
    }

    fn sum(&mut self) -> Option<f64> {
        let mut v = self.product()?;
        loop {
            if self.next_is(b'+') {
                v += self.product()?;
            } else if self.next_is(b'-') {
                v -= self.product()?;
            } else {
                return Some(v);
            }
        }
    }

    fn product(&mut self) -> Option<f64> {
        let mut v = self.factor()?;
        loop {
            if self.next_is(b'*') {
                v *= self.factor()?;
            } else if self.next_is(b'/') {
                let d = self.factor()?;
                if d == 0.0 {
                    return None;
                }
                v /= d;
            } else {
                return Some(v);
            }
        }
    }

    fn factor(&mut self) -> Option<f64> {
        self.depth += 1;
        let value = if self.depth > MAX_DEPTH {
            None
        } else {
            self.operand()
        };
        self.depth -= 1;
        value
    }

    fn operand(&mut self) -> Option<f64> {
        if self.next_is(b'-') {
            return Some(-self.factor()?);
        }
        if self.next_is(b'+') {
            return self.factor();
        }
        let (open, close) = if self.siemens {
            (b'(', b')')
        } else {
            (b'[', b']')
        };
        if self.next_is(open) {
            let v = self.sum()?;
            return self.next_is(close).then_some(v);
        }
        self.blank();
        let start = self.at;
        if self.siemens
            && self
                .text
                .get(self.at)
                .is_some_and(|b| b.is_ascii_alphabetic() || *b == b'_')
        {
            while self
                .text
                .get(self.at)
                .is_some_and(|b| b.is_ascii_alphanumeric() || *b == b'_')
            {
                self.at += 1;
            }
            let name = String::from_utf8_lossy(&self.text[start..self.at]).to_ascii_uppercase();
            // A function's name (SIN, TRUNC …) is followed by its bracket.
            self.blank();
            if self.text.get(self.at) == Some(&b'(') {
                return None;
            }
            return self.params.get(&name).flatten().map(|(v, _)| v);
        }
        if self.text.get(self.at) == Some(&b'#') {
            self.at += 1;
            if self.text.get(self.at) == Some(&b'<') {
                self.at += self.text[self.at..].iter().position(|&b| b == b'>')? + 1;
            } else {
                while self.text.get(self.at).is_some_and(u8::is_ascii_digit) {
                    self.at += 1;
                }
            }
            let name = name_of(&self.text[start..self.at])?;
            return self.params.get(&name).flatten().map(|(v, _)| v);
        }
        while self
            .text
            .get(self.at)
            .is_some_and(|b| b.is_ascii_digit() || *b == b'.')
        {
            self.at += 1;
        }
        literal(std::str::from_utf8(&self.text[start..self.at]).ok()?).map(|(v, _)| v)
    }
}

/// What parameter `name` is, for a message about a value nccomp does not know.
pub fn describe_unknown(name: &str, params: &Params) -> String {
    match params.get(name) {
        Some(None) => format!(
            "#{name}, which the program sets to an expression or another parameter, not a constant: its value is decided at run time"
        ),
        _ => format!(
            "#{name}, which the program never sets (a system variable, or one set by an operator, a probing cycle or another program): its value is decided at run time"
        ),
    }
}

/// The first parameter in `text` (`#100`, `#<name>`) whose value is not a constant the
/// program set, described for a message.
pub fn first_unknown(text: &[u8], params: &Params) -> Option<String> {
    let mut i = 0;
    while i < text.len() {
        if text[i] != b'#' {
            i += 1;
            continue;
        }
        let end = if text.get(i + 1) == Some(&b'<') {
            text[i..]
                .iter()
                .position(|&b| b == b'>')
                .map_or(text.len(), |p| i + p + 1)
        } else {
            i + 1
                + text[i + 1..]
                    .iter()
                    .take_while(|b| b.is_ascii_digit())
                    .count()
        };
        if let Some(name) = name_of(&text[i..end])
            && !matches!(params.get(&name), Some(Some(_)))
        {
            return Some(describe_unknown(&name, params));
        }
        i = end.max(i + 1);
    }
    None
}

/// The refusal of a macro statement (`IF[…]GOTO n`, `WHILE[…]DO n`, `GOTO n`, `END n`):
/// nccomp reads the blocks in order and does not follow jumps, and where the condition or
/// the target reads a value decided at run time, which blocks run is decided then.
pub fn macro_statement(text: &[u8], params: &Params) -> Option<String> {
    let upper: Vec<u8> = text
        .iter()
        .take_while(|&&b| b != b'(' && b != b';')
        .map(u8::to_ascii_uppercase)
        .collect();
    // A keyword, then what follows it in the language: a condition, a number, a parameter.
    let keyword = |k: &[u8], next: &[u8]| {
        upper.starts_with(k)
            && upper[k.len()..]
                .iter()
                .find(|b| !b.is_ascii_whitespace())
                .is_some_and(|b| next.contains(b))
    };
    let what = if keyword(b"IF", b"[") {
        "a macro branch (IF … GOTO / THEN)"
    } else if keyword(b"WHILE", b"[") {
        "a macro loop (WHILE … DO)"
    } else if keyword(b"GOTO", b"#0123456789") {
        "a macro jump (GOTO)"
    } else if keyword(b"DO", b"0123456789") || keyword(b"END", b"0123456789") {
        "a macro loop (DO / END)"
    } else {
        return None;
    };
    Some(match first_unknown(&upper, params) {
        Some(param) => format!(
            "{what} cannot be compensated: which blocks run depends on {param} (expected straight-line blocks: nccomp compensates the blocks a program runs; take the branch out, or write the program for one case)"
        ),
        None => format!(
            "{what} cannot be compensated: nccomp reads the blocks in order and does not follow macro jumps or loops (expected straight-line blocks; write the program without them)"
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_are_known_and_the_rest_is_not() {
        let mut p = Params::default();
        assert_eq!(assign(b"#100 = 12.5", &mut p), Ok(true));
        assert_eq!(assign(b"#<Depth>=-3. (floor)", &mut p), Ok(true));
        assert_eq!(assign(b"#101=[#100+1]", &mut p), Ok(true));
        assert_eq!(assign(b"#102=#100", &mut p), Ok(true));
        assert_eq!(p.get("100"), Some(Some((12.5, 1))));
        assert_eq!(p.get("<depth>"), Some(Some((-3.0, 0))));
        assert_eq!(p.get("101"), Some(None));
        assert_eq!(p.get("102"), Some(None));
        assert_eq!(p.get("103"), None);
        assert!(assign(b"#5221=10.", &mut p).is_err());
        assert!(assign(b"#2001=1.5", &mut p).is_err());
        assert_eq!(assign(b"#3000=1 (ALARM)", &mut p), Ok(true));
        assert_eq!(assign(b"#5599=1 (LinuxCNC debug output)", &mut p), Ok(true));
        assert!(assign(b"#5161=0 (LinuxCNC G28 X)", &mut p).is_err());
        assert!(assign(b"#7001=5. (G54.1 P1 X)", &mut p).is_err());
        // A reassignment replaces the value.
        assert_eq!(assign(b"#100=7", &mut p), Ok(true));
        assert_eq!(p.get("100"), Some(Some((7.0, 0))));
    }

    #[test]
    fn constant_expressions_are_evaluated_and_the_rest_is_not() {
        let mut p = Params::default();
        assign(b"#100=2.5", &mut p).unwrap();
        assign(b"#101=[#100]", &mut p).unwrap();
        assert_eq!(evaluate(b"[180.0-0.642]", &p), Some((179.358, 3)));
        assert_eq!(evaluate(b"[#100*2]", &p), Some((5.0, 0)));
        assert_eq!(evaluate(b"-[1 + 2 * [3 - 1]]", &p), Some((-5.0, 0)));
        assert_eq!(evaluate(b"[1/4]", &p), Some((0.25, 2)));
        assert_eq!(evaluate(b"[#<x>+1]", &p), None);
        assert_eq!(evaluate(b"[#101+1]", &p), None);
        assert_eq!(evaluate(b"[499.984+#600]", &p), None);
        assert_eq!(evaluate(b"SIN[30]", &p), None);
        assert_eq!(evaluate(b"[1/3]", &p), None);
        assert_eq!(evaluate(b"[1/0]", &p), None);
        assert_eq!(evaluate(b"[5 MOD 2]", &p), None);
        assert_eq!(evaluate(b"[1+2", &p), None);
        // Nesting beyond 64 levels is not read (a line may hold a million brackets).
        let deep = |n: usize| format!("{}1{}", "[".repeat(n), "]".repeat(n));
        assert_eq!(evaluate(deep(60).as_bytes(), &p), Some((1.0, 0)));
        assert_eq!(evaluate(deep(1_000_000).as_bytes(), &p), None);
        assert_eq!(
            evaluate(format!("{}1", "-".repeat(1_000_000)).as_bytes(), &p),
            None
        );
    }

    #[test]
    fn macro_statements_name_what_is_decided_at_run_time() {
        let mut p = Params::default();
        assign(b"#100=3", &mut p).unwrap();
        assign(b"#101=#100+1", &mut p).unwrap();
        let m = macro_statement(b"IF[#1005EQ0]GOTO003", &p).unwrap();
        assert!(
            m.contains("macro branch") && m.contains("#1005, which the program never sets"),
            "{m}"
        );
        let m = macro_statement(b"IF[#100EQ#175]GOTO#175", &p).unwrap();
        assert!(m.contains("#175, which the program never sets"), "{m}");
        let m = macro_statement(b"WHILE[#101LT5]DO1", &p).unwrap();
        assert!(
            m.contains("macro loop") && m.contains("#101, which the program sets to an expression"),
            "{m}"
        );
        let m = macro_statement(b"GOTO 20 (skip)", &p).unwrap();
        assert!(m.contains("does not follow macro jumps"), "{m}");
        assert_eq!(macro_statement(b"IFX", &p), None);
        assert!(macro_statement(b"END1", &p).unwrap().contains("loop"));
        assert_eq!(macro_statement(b"X10", &p), None);
        assert_eq!(
            first_unknown(b"Z#901003 B#<depth>", &p).unwrap(),
            describe_unknown("901003", &p)
        );
        assert_eq!(first_unknown(b"R#100", &p), None);
    }
}

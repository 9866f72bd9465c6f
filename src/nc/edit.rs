//! Changing a line of the document, in the spirit of toml_edit: a word's number is set in
//! place (its letter, spacing and every other byte stay, and so does its own text when the
//! new value prints the same), words and whole blocks are added in the block's own style,
//! and inserted blocks are numbered where the program numbers its blocks.
//!
//! Every change a command makes to a program goes through an [`Editor`]; the [`Edit`]s it
//! collects are applied by [`super::emit_line`].

use super::number::{Rounded, same_text, write_fixed};
use super::{Edit, Token, TokenKind, Value, Word};

/// How a block writes its words: letter case, what stands between words, and between a
/// letter and its number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Style {
    pub lowercase: bool,
    /// `" "`, or `""` in a packed block (`G1X10Y5`).
    pub separator: &'static str,
    /// Positive numbers are written with their `+` (a block that writes `X+10.5`).
    pub signed: bool,
}

impl Style {
    /// The style of a block: the case of its first word, packed when two words touch.
    pub fn of(tokens: &[Token]) -> Style {
        let lowercase = tokens.iter().find_map(|t| match &t.kind {
            TokenKind::Word(w) => Some(w.lowercase),
            _ => None,
        }) == Some(true);
        let packed = tokens.windows(2).any(|w| {
            matches!(w[0].kind, TokenKind::Word(_)) && matches!(w[1].kind, TokenKind::Word(_))
        });
        Style {
            lowercase,
            separator: if packed { "" } else { " " },
            signed: false,
        }
    }

    /// `letter` in the block's case.
    pub fn letter(&self, letter: u8) -> char {
        if self.lowercase {
            letter.to_ascii_lowercase() as char
        } else {
            letter.to_ascii_uppercase() as char
        }
    }

    /// A word `letter` + `number` in this style.
    pub fn word(&self, letter: u8, number: &str) -> String {
        let mut w = String::with_capacity(number.len() + 2);
        w.push(self.letter(letter));
        w.push_str(&self.number(number));
        w
    }

    /// `number` as this style writes it: with its `+` in a signed block.
    pub fn number<'n>(&self, number: &'n str) -> std::borrow::Cow<'n, str> {
        if self.signed && !number.starts_with(['-', '+']) {
            format!("+{number}").into()
        } else {
            number.into()
        }
    }
}

/// The edits of one line.
pub struct Editor<'a> {
    content: &'a [u8],
    tokens: &'a [Token],
    edits: &'a mut Vec<Edit>,
    /// Emptied texts of earlier edits, to write new ones in without allocating.
    spare: Option<&'a mut Vec<Vec<u8>>>,
}

impl<'a> Editor<'a> {
    /// The editor of the line whose content is `content`, cut into `tokens`, collecting its
    /// changes in `edits`.
    pub fn new(content: &'a [u8], tokens: &'a [Token], edits: &'a mut Vec<Edit>) -> Self {
        Editor {
            content,
            tokens,
            edits,
            spare: None,
        }
    }

    /// Take the texts of new edits from `spare` (a pass reuses them from line to line).
    pub fn with_spare(mut self, spare: &'a mut Vec<Vec<u8>>) -> Self {
        self.spare = Some(spare);
        self
    }

    pub fn content(&self) -> &'a [u8] {
        self.content
    }

    pub fn tokens(&self) -> &'a [Token] {
        self.tokens
    }

    /// The block's style; signed when one of its numbers is written with a `+`.
    pub fn style(&self) -> Style {
        let mut style = Style::of(self.tokens);
        style.signed = self.tokens.iter().any(|t| match &t.kind {
            TokenKind::Word(w) => {
                matches!(w.value, Value::Number { .. })
                    && self.content.get(w.value_span.start) == Some(&b'+')
            }
            _ => false,
        });
        style
    }

    /// The word at token `i`, if it is one.
    pub fn word(&self, i: usize) -> Option<&'a Word> {
        match &self.tokens.get(i)?.kind {
            TokenKind::Word(w) => Some(w),
            _ => None,
        }
    }

    /// The number of the word at token `i` and its decimals, if it is a number.
    pub fn number(&self, i: usize) -> Option<(f64, u8)> {
        match self.word(i)?.value {
            Value::Number { value, decimals } => Some((value, decimals)),
            _ => None,
        }
    }

    /// The text of token `i` as the program wrote it (for messages and copies).
    pub fn text(&self, i: usize) -> &'a [u8] {
        &self.content[self.tokens[i].span.clone()]
    }

    fn spare_text(&mut self) -> Vec<u8> {
        self.spare
            .as_mut()
            .and_then(|s| s.pop())
            .unwrap_or_default()
    }

    /// Set the number of word `i` to `value` with `decimals` decimals, unless it prints as
    /// the word's own number (then its bytes stay). The value the word holds afterwards, as
    /// the controller reads it, and whether it changed.
    pub fn set_number(&mut self, i: usize, value: f64, decimals: u8) -> (f64, bool) {
        let Some((old, _)) = self.number(i) else {
            return (value, false);
        };
        self.set_number_from(i, old, value, decimals)
    }

    /// [`Editor::set_number`] for a caller that has read the word's number `old` (a pass
    /// over millions of words reads it once).
    #[inline]
    pub fn set_number_from(&mut self, i: usize, old: f64, value: f64, decimals: u8) -> (f64, bool) {
        let rounded = Rounded::new(value, decimals);
        if rounded.prints_as(old) {
            return (old, false);
        }
        let mut text = self.spare_text();
        let written = rounded.write_bytes(&mut text);
        self.replace_number(i, text);
        (written, true)
    }

    /// Write `text` as the number of word `i` (its letter and spacing stay, and so does
    /// the `+` of a number written with one).
    pub fn replace_number(&mut self, i: usize, text: impl Into<Vec<u8>>) {
        if let Some(w) = self.word(i) {
            let mut text = text.into();
            if self.content.get(w.value_span.start) == Some(&b'+')
                && !matches!(text.first(), Some(b'-' | b'+'))
            {
                text.insert(0, b'+');
            }
            self.edits.push(Edit {
                at: w.value_span.clone(),
                text,
            });
        }
    }

    /// Set word `i`'s number to `value` printed with `decimals` when it prints differently
    /// from the word's own number; true when it changed.
    pub fn set_fixed(&mut self, i: usize, value: f64, decimals: u8) -> bool {
        let Some((old, _)) = self.number(i) else {
            return false;
        };
        if same_text(old, value, decimals) {
            return false;
        }
        let mut text = String::new();
        write_fixed(value, decimals, &mut text);
        self.replace_number(i, text);
        true
    }

    /// Add the word `letter` + `number` next to the word at token `neighbour` (after it, or
    /// before it), in that word's style: its case and what stands between its letter and
    /// number, and a space between words unless the block is packed.
    pub fn insert_word_by(&mut self, neighbour: usize, after: bool, letter: u8, number: &str) {
        let (lowercase, gap) = match self.word(neighbour) {
            Some(w) => (
                w.lowercase,
                &self.content[self.tokens[neighbour].span.start + 1..w.value_span.start],
            ),
            None => (false, &self.content[0..0]),
        };
        // Spaces or Sinumerik's `=`; not an address's digits (`A3=`) or a neighbour's
        // `=IC(`, which are its own.
        let gap: &[u8] = if gap.iter().all(|b| matches!(b, b' ' | b'\t' | b'=')) {
            gap
        } else if gap.contains(&b'=') {
            b"="
        } else {
            b""
        };
        let sep = self.style().separator;
        let letter = if lowercase {
            letter.to_ascii_lowercase()
        } else {
            letter.to_ascii_uppercase()
        } as char;
        let number = self.style().number(number);
        let word = format!("{letter}{}{number}", String::from_utf8_lossy(gap));
        let (at, text) = if after {
            let end = self.tokens[neighbour].span.end;
            (end..end, format!("{sep}{word}"))
        } else {
            let start = self.tokens[neighbour].span.start;
            (start..start, format!("{word}{sep}"))
        };
        self.edits.push(Edit {
            at,
            text: text.into(),
        });
    }

    /// Add the word `letter` + `number` after the block's last word, in its letter case,
    /// with a space unless the block is packed.
    pub fn append_word(&mut self, letter: u8, number: &str) {
        let last = self
            .tokens
            .iter()
            .rposition(|t| matches!(t.kind, TokenKind::Word(_)));
        let lowercase = last.and_then(|i| self.word(i)).is_some_and(|w| w.lowercase);
        let letter = if lowercase {
            letter.to_ascii_lowercase()
        } else {
            letter.to_ascii_uppercase()
        } as char;
        let end = last.map_or(self.content.len(), |i| self.tokens[i].span.end);
        let style = self.style();
        let text = format!("{}{letter}{}", style.separator, style.number(number));
        self.edits.push(Edit {
            at: end..end,
            text: text.into(),
        });
    }

    /// Add words (letter, number) after the token ending at byte `end`, in the block's
    /// style.
    pub fn insert_words_at(&mut self, end: usize, words: &[(u8, &str)]) {
        let style = self.style();
        let mut text = String::new();
        for (letter, number) in words {
            text.push_str(style.separator);
            text.push(style.letter(*letter));
            text.push_str(&style.number(number));
        }
        if !text.is_empty() {
            self.edits.push(Edit {
                at: end..end,
                text: text.into(),
            });
        }
    }

    /// Add `text` (words in the block's style, ending with their separator) at the start of
    /// word `i`.
    pub fn insert_before_word(&mut self, i: usize, text: &str) {
        let start = self.tokens[i].span.start;
        self.edits.push(Edit {
            at: start..start,
            text: text.into(),
        });
    }

    /// Replace the bytes of token `i` (a keyword) by `text`.
    pub fn replace_token(&mut self, i: usize, text: &[u8]) {
        self.edits.push(Edit {
            at: self.tokens[i].span.clone(),
            text: text.to_vec(),
        });
    }

    /// Remove the word at token `i` and the space before it.
    pub fn remove_word(&mut self, i: usize) {
        let t = &self.tokens[i];
        let start = self
            .tokens
            .iter()
            .position(|x| x.span.end == t.span.start && x.kind == TokenKind::Space)
            .map_or(t.span.start, |p| self.tokens[p].span.start);
        self.edits.push(Edit {
            at: start..t.span.end,
            text: Vec::new(),
        });
    }

    /// Insert whole blocks (`text`, each ending with its line ending) before the line.
    pub fn insert_blocks(&mut self, text: String) {
        if text.is_empty() {
            return;
        }
        // Before any word inserted at the line's start.
        self.edits.insert(
            0,
            Edit {
                at: 0..0,
                text: text.into(),
            },
        );
    }

    /// N numbers for `count` blocks inserted before this one, whose previous block was
    /// numbered `last_n`: consecutive numbers in the gap after it when the gap is wide
    /// enough, else the block's own number again; none when the block has no N word.
    /// Zero padding only where the program pads (N0010), never a new leading zero.
    pub fn inserted_numbers(&self, last_n: Option<u64>, count: usize) -> Vec<Option<String>> {
        let own = self.tokens.iter().find_map(|t| match &t.kind {
            TokenKind::Word(w) if w.letter == b'N' => {
                let digits = &self.content[w.value_span.clone()];
                let text = String::from_utf8_lossy(digits).into_owned();
                text.parse::<u64>().ok().map(|v| (v, text))
            }
            _ => None,
        });
        let Some((value, text)) = own else {
            return vec![None; count];
        };
        let width = if text.starts_with('0') { text.len() } else { 0 };
        match last_n {
            Some(prev) if value > prev && (value - prev - 1) as usize >= count => (1..=count)
                .map(|i| Some(format!("{:0width$}", prev + i as u64)))
                .collect(),
            _ => vec![Some(text); count],
        }
    }

    /// The line's ending to give inserted blocks (a last line without one gets `\n`).
    pub fn ending(line_ending: &[u8]) -> &str {
        if line_ending.is_empty() {
            "\n"
        } else {
            std::str::from_utf8(line_ending).unwrap_or("\n")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::nc::{Line, emit_line, parse_line};

    fn edited(src: &str, f: impl FnOnce(&mut Editor<'_>)) -> String {
        let mut tokens = Vec::new();
        parse_line(src.as_bytes(), &mut tokens);
        let mut edits = Vec::new();
        f(&mut Editor::new(src.as_bytes(), &tokens, &mut edits));
        let line = Line {
            number: 1,
            offset: 0,
            content: src.as_bytes(),
            ending: b"\n",
        };
        let mut out = Vec::new();
        emit_line(&line, &mut edits, &mut out);
        String::from_utf8(out).unwrap()
    }

    #[test]
    fn a_number_that_prints_the_same_keeps_its_text() {
        // X+12.50 rounds to the same at 4 decimals: nothing changes; a changed number keeps
        // its sign.
        assert_eq!(
            edited("G1 X+12.50 Y3", |e| {
                assert_eq!(e.set_number(2, 12.50000001, 4), (12.5, false));
            }),
            "G1 X+12.50 Y3\n"
        );
        assert_eq!(
            edited("G1 X+12.50 Y3", |e| {
                assert_eq!(e.set_number(2, 12.50012, 4), (12.5001, true));
            }),
            "G1 X+12.5001 Y3\n"
        );
    }

    #[test]
    fn words_and_blocks_come_in_the_blocks_style() {
        assert_eq!(
            edited("n20 g1 x 10 z5", |e| e.insert_word_by(4, true, b'Y', "2.5")),
            "n20 g1 x 10 y 2.5 z5\n"
        );
        assert_eq!(
            edited("G1X10Z5", |e| e.insert_word_by(1, false, b'Y', "2.5")),
            "G1Y2.5X10Z5\n"
        );
        assert_eq!(
            edited("N30 G2 X1 Y2 I3 J4", |e| {
                e.remove_word(8);
                e.remove_word(10);
                e.insert_blocks("N21 G1 X0.5\n".into());
            }),
            "N21 G1 X0.5\nN30 G2 X1 Y2\n"
        );
    }

    #[test]
    fn inserted_blocks_are_numbered_in_the_gap() {
        let src = "N0030 G1 X1";
        let mut tokens = Vec::new();
        parse_line(src.as_bytes(), &mut tokens);
        let mut edits = Vec::new();
        let e = Editor::new(src.as_bytes(), &tokens, &mut edits);
        assert_eq!(
            e.inserted_numbers(Some(20), 2),
            vec![Some("0021".to_string()), Some("0022".to_string())]
        );
        // No room in the gap: the block's own number again.
        assert_eq!(
            e.inserted_numbers(Some(29), 2),
            vec![Some("0030".to_string()); 2]
        );
    }
}

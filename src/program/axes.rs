//! The axes a tool chain's words drive, and where the program's words put them.
//!
//! A block's axis words mean positions in program coordinates: mm (or inch, converted) for
//! linear axes, degrees for rotary ones, a lathe's X as a diameter in G7, absolute (G90)
//! or incremental (G91, summed exactly: [`super::exact`]). [`Positions`] follows them
//! block by block, with which axes are at a place the program does not know (after G28,
//! G30, G53) and which it has programmed at all.

use super::exact::{self, Position, Unit};
use super::{BlockMotion, Modal};
use crate::diag::Diagnostic;
use crate::kinematics::MAX_AXES;
use crate::model::{AxisKind, Machine};
use crate::nc::{Token, TokenKind, Value};

/// The variables of one tool chain (the kinematics' order: the machine file's axis order)
/// as the program's words drive them.
#[derive(Debug, Clone)]
pub struct Axes {
    /// The variable driven by each letter A..Z.
    pub var_of_letter: [Option<usize>; 26],
    /// Each variable's program letter, uppercase.
    pub letters: Vec<u8>,
    /// Bit k: variable k is linear.
    pub linear: u32,
}

impl Axes {
    /// The variables of tool chain `chain` of `machine`.
    pub fn of(machine: &Machine, chain: usize) -> Axes {
        let mut axes = Axes {
            var_of_letter: [None; 26],
            letters: Vec::new(),
            linear: 0,
        };
        for (v, &axis) in machine.variables(chain).iter().enumerate() {
            let letter = machine.axes[axis].word.to_ascii_uppercase() as u8;
            if letter.is_ascii_uppercase() && v < MAX_AXES {
                axes.var_of_letter[(letter - b'A') as usize] = Some(v);
            }
            if machine.axes[axis].kind == AxisKind::Linear {
                axes.linear |= 1 << v;
            }
            axes.letters.push(letter);
        }
        axes
    }

    pub fn len(&self) -> usize {
        self.letters.len()
    }

    pub fn is_empty(&self) -> bool {
        self.letters.is_empty()
    }

    pub fn is_linear(&self, v: usize) -> bool {
        self.linear & (1 << v) != 0
    }

    /// The linear variable driven by `letter`, if any.
    pub fn linear_of(&self, letter: u8) -> Option<usize> {
        self.var_of_letter[(letter.to_ascii_uppercase() - b'A') as usize]
            .filter(|&v| self.is_linear(v))
    }

    /// What variable `v`'s words are in, in the program's current modes.
    pub fn unit(&self, v: usize, modal: &Modal) -> Unit {
        let linear = self.is_linear(v);
        Unit {
            inch: modal.inch && linear,
            diameter: modal.diameter && linear && self.letters[v] == b'X',
        }
    }
}

/// Where the program's words put each variable: nominal values in mm and degrees (and
/// exactly, for G91).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Positions {
    pub nominal: [f64; MAX_AXES],
    /// The same, exactly (for G91: no drift).
    pub exact: [Position; MAX_AXES],
    /// Bit k: variable k is at a position whose program coordinate is not known (after
    /// G28, G30 or G53), until a G90 block programs it.
    pub unknown: u32,
    /// Bit k: variable k has been programmed.
    pub programmed: u32,
}

impl Default for Positions {
    /// Every axis at home (0), none programmed.
    fn default() -> Self {
        Positions {
            nominal: [0.0; MAX_AXES],
            exact: [Position::Units(0); MAX_AXES],
            unknown: 0,
            programmed: 0,
        }
    }
}

impl Positions {
    /// Follow a G0/G1 block's axis words: the nominal values (and their exact twins) become
    /// the block's programmed end, absolute or incremental. Writes each G91 word's increment
    /// exactly into `units` (zeros elsewhere). Returns the variables moved by a G91 word
    /// before the program had set them (from their home value 0). An optional block (`/`)
    /// makes no axis known: with block delete on it does not run.
    #[allow(clippy::too_many_arguments)]
    pub fn advance(
        &mut self,
        axes: &Axes,
        content: &[u8],
        tokens: &[Token],
        motion: &BlockMotion,
        modal: &Modal,
        at: &dyn Fn(usize, String) -> Diagnostic,
        units: &mut [i128; MAX_AXES],
    ) -> Result<u32, Diagnostic> {
        *units = [0i128; MAX_AXES];
        let mut from_home = 0;
        for (v, word) in motion.axis_words.iter().enumerate().take(axes.len()) {
            let Some(i) = *word else { continue };
            let t = &tokens[i];
            let TokenKind::Word(w) = &t.kind else {
                continue;
            };
            let Value::Number { value, decimals } = w.value else {
                continue;
            };
            let unit = axes.unit(v, modal);
            let bit = 1u32 << v;
            if modal.incremental {
                let u = exact::number_units(value, decimals, &content[w.value_span.clone()], unit)
                    .filter(|_| decimals <= exact::MAX_DECIMALS)
                    .ok_or_else(|| {
                        at(
                            t.span.start,
                            format!(
                                "{} has {decimals} decimals; an incremental (G91) word can have at most {} (nccomp sums increments exactly)",
                                w.letter as char,
                                exact::MAX_DECIMALS
                            ),
                        )
                    })?;
                if self.programmed & bit == 0 && self.unknown & bit == 0 {
                    from_home |= bit;
                }
                units[v] = u;
                self.exact[v] = self.exact[v].add(u);
                self.nominal[v] = exact::to_f64(self.exact[v].units());
            } else {
                self.nominal[v] = unit.to_mm(value);
                self.exact[v] = Position::Decimal {
                    value,
                    decimals,
                    unit,
                };
                if !motion.optional {
                    self.unknown &= !bit;
                }
            }
        }
        Ok(from_home)
    }

    /// The axes a G53, G28 or G30 block sends to machine positions (all of them for a bare
    /// G28/G30) leave the program's coordinates; the bits that did.
    pub fn leave(&mut self, motion: &BlockMotion, n: usize) -> u32 {
        let mut gone = (0..n)
            .filter(|&v| motion.axis_words[v].is_some())
            .fold(0u32, |m, v| m | 1 << v);
        if motion.kind == super::MoveKind::Home && gone == 0 {
            gone = match motion.homed {
                0 => (0..n).fold(0u32, |m, v| m | 1 << v),
                homed => homed,
            };
        }
        self.unknown |= gone;
        gone
    }
}

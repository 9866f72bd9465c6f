//! What a compensation run did and what the model predicts, for the user.

use crate::diag::Diagnostic;
use std::fmt;

/// The largest value of something and the line where it occurred.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Extreme {
    pub value: f64,
    pub line: usize,
}

impl Extreme {
    pub(crate) fn update(&mut self, value: f64, line: usize) {
        if value > self.value {
            *self = Extreme { value, line };
        }
    }
}

/// What the model predicts at one program line (kept only when the run is traced, for
/// plots along the program).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sample {
    pub line: usize,
    /// The largest tip error (mm) and direction error (rad) of the line's blocks (an arc or
    /// a split move writes several), without compensation ...
    pub before_position: f64,
    pub before_direction: f64,
    /// ... and at the written axis values (singular poses included).
    pub after_position: f64,
    pub after_direction: f64,
    /// Programmed and written axis values at the end of the line, per variable of the
    /// active configuration (mm, degrees).
    pub nominal: Vec<f64>,
    pub written: Vec<f64>,
    /// The tool chain the line ran in (index into the machine's tool chains).
    pub chain: usize,
    /// A block of the line was at a singular pose (a rotary axis held) ...
    pub singular: bool,
    /// ... or in a tilted working plane (the rotary axes where the control turned them):
    /// the direction error there is left, not corrected.
    pub plane: bool,
    /// The line's move was at feed, not rapid: the tool cuts there (where the part is).
    pub feed: bool,
}

/// Counts and predicted errors of one run.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Summary {
    /// The error model is all zero: the program was passed through unchanged.
    pub zero_model: bool,
    pub lines: usize,
    /// Blocks with axis words that were compensated.
    pub motion_blocks: usize,
    pub words_changed: usize,
    pub words_added: usize,
    /// Largest predicted tip error (mm) and direction error (rad) without compensation...
    pub before_position: Extreme,
    pub before_direction: Extreme,
    /// Sums of the same over every recorded pose, and how many there were (for means).
    pub before_position_sum: f64,
    pub before_direction_sum: f64,
    pub poses: usize,
    /// ... and with the compensated (rounded) axis values.
    pub after_position: Extreme,
    pub after_direction: Extreme,
    /// Blocks where a rotary axis lay along the tool and was held, and the largest
    /// direction error left there (rad).
    pub singular_blocks: usize,
    pub singular_direction: Extreme,
    /// Axes held at singular poses.
    pub held_axes: Vec<String>,
    /// Blocks in a tilted working plane (G68.2), where the rotary axes stand where G53.1
    /// put them, and the largest direction error left there (rad; counted in the after
    /// figures too).
    pub plane_blocks: usize,
    pub plane_direction: Extreme,
    /// How the program tilts its working plane, as its dialect writes it (`G68.2`,
    /// `PLANE`, `CYCLE800`), for the summary's line.
    pub plane_construct: &'static str,
    /// Blocks whose error-table look-up lay beyond a table's ends (values held).
    pub beyond_table_blocks: usize,
    pub first_beyond_table: usize,
    /// Axes that were compensated before the program first set them, assuming their home
    /// value 0, with the first line where that happened.
    pub assumed_home: Vec<(String, usize)>,
    /// The first line compensated before the program said G20 or G21, and the units it
    /// was read in (the machine file's `units`).
    pub units_assumed: Option<(usize, &'static str)>,
    /// Axes held at their programmed value because the correction would have pushed them
    /// past a travel limit: (axis, blocks, first line).
    pub at_limit: Vec<(String, usize, usize)>,
    /// Blocks inserted to keep split moves on their path, the moves split, and the first.
    pub blocks_added: usize,
    pub moves_split: usize,
    pub first_split: usize,
    /// Cycle blocks with an L or K repeat written as a block per hole, the first, and the
    /// blocks inserted for them.
    pub cycles_unrolled: usize,
    pub first_unrolled: usize,
    pub holes_added: usize,
    /// Moves that needed a split but were kept whole (M or T words, G93 without F), and
    /// the first.
    pub unsplit_moves: usize,
    pub first_unsplit: usize,
    /// TNC cycle calls whose motion goes around the hole's axis (bore and thread milling,
    /// pockets), compensated by their centre, axis and depth, and the largest bound on
    /// what the tool can be off there: off the axis at the set-up clearance plus the
    /// error field's change over the cycle's radius (mm).
    pub cycles_around: usize,
    pub around_bound: Extreme,
    /// Holes written out as L moves (one X, Y could not serve their depth), the first,
    /// and the blocks that took beyond the call's own.
    pub holes_written_out: usize,
    pub first_written_out: usize,
    pub hole_blocks_added: usize,
    /// Arcs kept as arcs (compensated end and centre within the path tolerance), and the
    /// TNC poles (`CC` blocks) written before them for their centres.
    pub arcs_kept: usize,
    pub arc_poles: usize,
    /// Arcs replaced by straight pieces, and the blocks that took.
    pub arcs: usize,
    pub arc_blocks_added: usize,
    /// Travel-limit violations written anyway (--allow-limit-violations).
    pub limit_violations: Vec<Diagnostic>,
    /// What the verification gate found of the written program (`None`: not verified).
    pub verdict: Option<crate::verify::Verdict>,
    /// Blocks that move but were written unchanged because an axis was at a position
    /// whose program coordinate is not known (after G28, G30 or G53), the first of them,
    /// and the axes that were unknown in them.
    pub uncompensated_blocks: usize,
    pub first_uncompensated: usize,
    pub unknown_axes: Vec<String>,
    /// Axes moved by an incremental (G91) word before the program set them, from their
    /// home value 0, with the first line where that happened.
    pub incremental_from_home: Vec<(String, usize)>,
    /// Blocks compensated as turning (the spindle turned or was not positioned): the tip's
    /// radius and position along the spindle line.
    pub turning_blocks: usize,
    /// The tool chains compensated blocks ran in, in order of first use.
    pub chains: Vec<String>,
    /// Some axes became unknown at M19 or at a change of tool chain.
    pub lathe_unknown: bool,
    /// One sample per compensated line, when the run was traced
    /// ([`super::Compensator::run_traced`]).
    pub trace: Option<Vec<Sample>>,
    /// Where the control turns the rotary axes for a tilted working plane (G53.1, a TNC
    /// `PLANE … TURN` or the `L` block after `PLANE … STAY`): the line and each rotary
    /// axis's name and angle (degrees), the solution nccomp follows.
    pub plane_positions: Vec<(usize, Vec<(String, f64)>)>,
    /// The line of the M2/M30 that ended the program and the lines with blocks after it,
    /// which do not run with the program and were written unchanged.
    pub after_end: Option<(usize, usize)>,
    /// The copies of TNC labels written for calls that run them in another state: label,
    /// copy, and the line of the call that first named the copy.
    pub label_copies: Vec<(String, String, usize)>,
    /// Tool radius compensation (RL/RR) sections compensated, with the bound on what the
    /// offset adds.
    pub radius: super::radius::RadiusReport,
}

impl Summary {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record(
        &mut self,
        line: usize,
        before_p: f64,
        before_d: f64,
        after_p: f64,
        after_d: f64,
        singular: bool,
        beyond: bool,
    ) {
        self.before_position.update(before_p, line);
        self.before_direction.update(before_d, line);
        self.before_position_sum += before_p;
        self.before_direction_sum += before_d;
        self.poses += 1;
        self.after_position.update(after_p, line);
        if singular {
            self.singular_blocks += 1;
            self.singular_direction.update(after_d, line);
        } else {
            self.after_direction.update(after_d, line);
        }
        if let Some(trace) = &mut self.trace {
            match trace.last_mut() {
                Some(s) if s.line == line => {
                    s.before_position = s.before_position.max(before_p);
                    s.before_direction = s.before_direction.max(before_d);
                    s.after_position = s.after_position.max(after_p);
                    s.after_direction = s.after_direction.max(after_d);
                    s.singular |= singular;
                }
                _ => trace.push(Sample {
                    line,
                    before_position: before_p,
                    before_direction: before_d,
                    after_position: after_p,
                    after_direction: after_d,
                    singular,
                    ..Sample::default()
                }),
            }
        }
        if beyond {
            if self.beyond_table_blocks == 0 {
                self.first_beyond_table = line;
            }
            self.beyond_table_blocks += 1;
        }
    }

    /// Mean predicted tip error (mm) and direction error (rad) without compensation, over
    /// the poses the pass evaluated (0 when there were none).
    pub fn before_means(&self) -> (f64, f64) {
        if self.poses == 0 {
            return (0.0, 0.0);
        }
        let n = self.poses as f64;
        (self.before_position_sum / n, self.before_direction_sum / n)
    }

    /// The summary's lines after the predicted errors, as [`fmt::Display`] shows them:
    /// singular poses, split moves and arcs, then the `note: ` lines (not the warnings).
    pub fn remarks(&self) -> Vec<String> {
        let urad = |e: Extreme| {
            if e.line == 0 {
                format!("{:.2} µrad", e.value * 1e6)
            } else {
                format!("{:.2} µrad (line {})", e.value * 1e6, e.line)
            }
        };
        let mut out = Vec::new();
        if self.singular_blocks > 0 {
            out.push(format!(
                "{} at singular poses (tool along axis {}): the axis was held at its programmed value; direction error left there up to {}",
                count(self.singular_blocks, "block"),
                self.held_axes.join(", "),
                urad(self.singular_direction)
            ));
        }
        if self.plane_blocks > 0 {
            out.push(format!(
                "{} in tilted working planes ({}): the rotary axes stood where the controller turned them; direction error left there up to {}",
                count(self.plane_blocks, "block"),
                self.plane_construct,
                urad(self.plane_direction)
            ));
        }
        if self.turning_blocks > 0 {
            out.push(format!(
                "{} compensated as turning (the spindle turned or was not positioned): radius and position along the spindle line, with X and Z",
                count(self.turning_blocks, "block"),
            ));
        }
        if self.chains.len() > 1 {
            out.push(format!("tool chains used: {}", self.chains.join(", ")));
        }
        if self.moves_split > 0 {
            out.push(format!(
                "{} split to stay on the nominal path (first at line {}): {} added",
                count(self.moves_split, "move"),
                self.first_split,
                count(self.blocks_added, "block")
            ));
        }
        if self.cycles_unrolled > 0 {
            out.push(format!(
                "{} with an L or K repeat written as a block per hole, their corrections differing (first at line {}): {} added",
                count(self.cycles_unrolled, "cycle block"),
                self.first_unrolled,
                count(self.holes_added, "block")
            ));
        }
        if self.cycles_around > 0 {
            out.push(format!(
                "{} moving around the hole's axis (bore or thread milling, pockets) compensated by centre, axis and depth: within {:.3} µm of the nominal motion, the error field's change over their radius included (line {})",
                count(self.cycles_around, "cycle call"),
                self.around_bound.value * 1e3,
                self.around_bound.line
            ));
        }
        if self.radius.sections > 0 {
            out.push(format!(
                "{} under tool radius compensation (RL/RR) in {}, compensated as the contour: the offset by the tool radius of {:.4} mm ([tool] {}) adds at most {:.3} µm (line {}), the error field's change over it and the offset's own change included",
                count(self.radius.moves, "move"),
                count(self.radius.sections, "section"),
                self.radius.radius,
                self.radius.source,
                self.radius.bound * 1e3,
                self.radius.line
            ));
        }
        if self.holes_written_out > 0 {
            out.push(format!(
                "{} that one X, Y could not serve over the depth written out as L moves with the correction along the depth (first at line {}): {} added",
                count(self.holes_written_out, "hole"),
                self.first_written_out,
                count(self.hole_blocks_added, "block")
            ));
        }
        if self.arcs_kept > 0 {
            let poles = if self.arc_poles > 0 {
                format!(
                    ": {} added for their centres",
                    count(self.arc_poles, "CC block")
                )
            } else {
                String::new()
            };
            out.push(format!(
                "{} kept as arcs (compensated end and centre stay within the path tolerance){poles}",
                count(self.arcs_kept, "arc"),
            ));
        }
        if self.arcs > 0 {
            out.push(format!(
                "{} replaced by straight pieces within 0.5 µm of the arc: {} added",
                count(self.arcs, "arc"),
                count(self.arc_blocks_added, "block")
            ));
        }
        if self.unsplit_moves > 0 {
            out.push(format!(
                "note: {} kept whole although the path strays (M or T words, or G93 without F; first at line {})",
                count(self.unsplit_moves, "move"),
                self.first_unsplit
            ));
        }
        for (axis, blocks, line) in &self.at_limit {
            out.push(format!(
                "note: in {} (first at line {line}) the correction would have pushed axis {axis} past its travel limit; it was held at its programmed value",
                count(*blocks, "block")
            ));
        }
        if self.beyond_table_blocks > 0 {
            out.push(format!(
                "note: error tables were read beyond their ends in {} (first at line {}); the end values were used",
                count(self.beyond_table_blocks, "block"),
                self.first_beyond_table
            ));
        }
        if self.uncompensated_blocks > 0 {
            let (noun, verb, pronoun) = if self.unknown_axes.len() == 1 {
                ("axis", "was", "it")
            } else {
                ("axes", "were", "them")
            };
            out.push(format!(
                "note: {} (first at line {}) {} written uncompensated: {noun} {} {verb} at a position nccomp does not know ({}) until a G90 block programmed {pronoun}",
                count(self.uncompensated_blocks, "block"),
                self.first_uncompensated,
                if self.uncompensated_blocks == 1 {
                    "was"
                } else {
                    "were"
                },
                self.unknown_axes.join(", "),
                if self.lathe_unknown {
                    "at the program's start, or after G28, G30, G53, a machine move code, M19 or a change of tool chain"
                } else {
                    "at the program's start, or after G28, G30, G53, a machine move code or a tool change"
                }
            ));
        }
        for (axis, line) in &self.incremental_from_home {
            out.push(format!(
                "note: axis {axis} was moved incrementally (G91) at line {line} before the program set it; its home value 0 was taken as the start"
            ));
        }
        if let Some((line, units)) = self.units_assumed {
            out.push(format!(
                "note: the program moves at line {line} before it says G20 or G21: its words were read in {units}, the machine file's `units` (check the control reads it so)"
            ));
        }
        if let Some((end, lines)) = self.after_end {
            out.push(format!(
                "note: {} after the program's end (line {end}) left unchanged: they do not run with the program (a subprogram stored there is not compensated)",
                count(lines, "line")
            ));
        }
        for (label, copy, line) in &self.label_copies {
            out.push(format!(
                "note: LBL {label} written again as LBL \"{copy}\" for the call at line {line}, which runs it in another state (position, working plane, datum, tool)"
            ));
        }
        for (axis, line) in &self.assumed_home {
            out.push(format!(
                "note: axis {axis} had not been set by the program at line {line}: its home value 0 was assumed for the error model (in machine-axis blocks it keeps where it stands, with no word added)"
            ));
        }
        out
    }

    pub(crate) fn note_assumed_home(&mut self, axis: &str, line: usize) {
        if !self.assumed_home.iter().any(|(a, _)| a == axis) {
            self.assumed_home.push((axis.to_string(), line));
        }
    }

    pub(crate) fn note_uncompensated(&mut self, line: usize, unknown: &[&str]) {
        if self.uncompensated_blocks == 0 {
            self.first_uncompensated = line;
        }
        self.uncompensated_blocks += 1;
        for axis in unknown {
            if !self.unknown_axes.iter().any(|a| a == axis) {
                self.unknown_axes.push(axis.to_string());
            }
        }
    }

    pub(crate) fn note_incremental_from_home(&mut self, axis: &str, line: usize) {
        if !self.incremental_from_home.iter().any(|(a, _)| a == axis) {
            self.incremental_from_home.push((axis.to_string(), line));
        }
    }

    pub(crate) fn note_split(&mut self, line: usize, added: usize) {
        if self.moves_split == 0 {
            self.first_split = line;
        }
        self.moves_split += 1;
        self.blocks_added += added;
    }

    pub(crate) fn note_unrolled(&mut self, line: usize, added: usize) {
        if self.cycles_unrolled == 0 {
            self.first_unrolled = line;
        }
        self.cycles_unrolled += 1;
        self.holes_added += added;
    }

    pub(crate) fn note_arc_kept(&mut self) {
        self.arcs_kept += 1;
    }

    pub(crate) fn note_arc(&mut self, _line: usize, added: usize) {
        self.arcs += 1;
        self.arc_blocks_added += added;
    }

    pub(crate) fn note_unsplit(&mut self, line: usize) {
        if self.unsplit_moves == 0 {
            self.first_unsplit = line;
        }
        self.unsplit_moves += 1;
    }

    pub(crate) fn note_at_limit(&mut self, axis: &str, line: usize) {
        match self.at_limit.iter_mut().find(|(a, _, _)| a == axis) {
            Some(entry) => entry.1 += 1,
            None => self.at_limit.push((axis.to_string(), 1, line)),
        }
    }

    pub(crate) fn note_chain(&mut self, chain: &str) {
        if !self.chains.iter().any(|c| c == chain) {
            self.chains.push(chain.to_string());
        }
    }

    pub(crate) fn note_held(&mut self, axis: &str) {
        if !self.held_axes.iter().any(|a| a == axis) {
            self.held_axes.push(axis.to_string());
        }
    }
}

/// `n` with the noun, pluralised the simple English way.
fn count(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.zero_model {
            return write!(
                f,
                "{}; the error model is zero, so the program is unchanged",
                count(self.lines, "line")
            );
        }
        writeln!(
            f,
            "{}, {} compensated: {} changed, {} added",
            count(self.lines, "line"),
            count(self.motion_blocks, "motion block"),
            count(self.words_changed, "word"),
            count(self.words_added, "word")
        )?;
        let at = |e: Extreme| {
            if e.line == 0 {
                String::new()
            } else {
                format!(" (line {})", e.line)
            }
        };
        let um = |e: Extreme| format!("{:.3} µm{}", e.value * 1e3, at(e));
        let urad = |e: Extreme| format!("{:.2} µrad{}", e.value * 1e6, at(e));
        writeln!(
            f,
            "predicted tip error:       before {}, after {}",
            um(self.before_position),
            um(self.after_position)
        )?;
        write!(
            f,
            "predicted direction error: before {}, after {}",
            urad(self.before_direction),
            urad(self.after_direction)
        )?;
        for remark in self.remarks() {
            write!(f, "\n{remark}")?;
        }
        for v in &self.limit_violations {
            write!(f, "\nwarning: line {}: {}", v.line, v.message)?;
        }
        if let Some(verdict) = &self.verdict {
            write!(f, "\n{verdict}")?;
        }
        Ok(())
    }
}

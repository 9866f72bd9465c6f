//! `nccomp check`: what the model predicts for programs and whether compensation can fix
//! it, as a gate for CI.
//!
//! A check is the compensation pass ([`crate::compensate`]) run on each program with its
//! output thrown away: the pass's summary holds the predicted errors before and after
//! compensation, its refused blocks are the blocks that cannot be compensated. Nothing
//! here evaluates the kinematics itself. Thresholds turn what the pass found into
//! failures ([`Finding`]); programs are checked in parallel.

pub mod config;
mod expand;
mod progress;
mod report;
pub mod settings;
pub mod stale;

pub use expand::{expand, expand_marked, not_regular};
pub use progress::progress_bar;

use crate::compensate::{Compensator, Extreme, Options, Summary, TRAVEL_LIMIT};
use crate::diag::{Diagnostic, Error, panic_message};
use crate::model::setup::Used;
use crate::model::{ErrorModel, Machine};
use crate::nc::{self, TokenKind};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Exit status of a run: 0 clean, 1 findings, 2 unusable input (the same codes as every
/// nccomp command: 2 is also a bad option, machine or error file).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    Clean,
    Findings,
    Unusable,
}

impl Status {
    pub fn exit_code(self) -> u8 {
        match self {
            Status::Clean => 0,
            Status::Findings => 1,
            Status::Unusable => 2,
        }
    }
}

/// `--max-error`'s default (mm), for `check` and `report` alike.
pub const DEFAULT_MAX_ERROR_MM: f64 = settings::MAX_ERROR_MM;

/// `--max-angle`'s default (µrad), for `check` and `report` alike.
pub const DEFAULT_MAX_ANGLE_URAD: f64 = settings::MAX_ANGLE_URAD;

/// The direction error after compensation that the thresholds judge: the largest of the
/// compensated blocks' and the singular poses' (where the held axis leaves it).
pub fn judged_direction(summary: &Summary) -> Extreme {
    if summary.singular_direction.value > summary.after_direction.value {
        summary.singular_direction
    } else {
        summary.after_direction
    }
}

/// What turns a prediction into a failure.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Thresholds {
    /// Largest predicted tip error after compensation, mm.
    pub max_error_mm: f64,
    /// Largest predicted tool direction error after compensation, µrad; `None`: the
    /// direction error is reported, not judged.
    pub max_angle_urad: Option<f64>,
}

impl Default for Thresholds {
    fn default() -> Self {
        Thresholds {
            max_error_mm: settings::MAX_ERROR_MM,
            max_angle_urad: Some(settings::MAX_ANGLE_URAD),
        }
    }
}

impl Thresholds {
    /// The thresholds, if both are positive numbers.
    pub fn new(max_error_mm: f64, max_angle_urad: Option<f64>) -> crate::Result<Self> {
        for (name, v, unit) in [
            ("--max-error", Some(max_error_mm), "mm"),
            ("--max-angle", max_angle_urad, "µrad"),
        ] {
            let Some(v) = v else { continue };
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::Usage(format!(
                    "{name} {v}: expected a positive number ({unit})"
                )));
            }
        }
        Ok(Thresholds {
            max_error_mm,
            max_angle_urad,
        })
    }
}

/// What a finding is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FindingKind {
    /// A block the pass refuses (unsupported construct, correction too large, ...).
    Refused,
    /// A block that leaves an axis's travel (refused, or written anyway with
    /// `--allow-limit-violations`).
    TravelLimit,
    /// The predicted tip error after compensation is above `--max-error`.
    TipError,
    /// The predicted direction error after compensation is above `--max-angle`.
    DirectionError,
    /// The program was not read: the error model is zero, so the pass copies it unread
    /// (a finding unless `--allow-unread`).
    Unread,
}

/// A failure at a place in a program.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Finding {
    pub kind: FindingKind,
    #[serde(flatten)]
    pub at: Place,
}

/// A located message, as the JSON output shows it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Place {
    pub path: String,
    pub line: usize,
    pub column: usize,
    pub message: String,
    pub source_line: String,
}

impl From<&Diagnostic> for Place {
    fn from(d: &Diagnostic) -> Self {
        Place {
            path: d.path.clone(),
            line: d.line,
            column: d.column,
            message: d.message.clone(),
            source_line: d.source_line.clone(),
        }
    }
}

impl Finding {
    /// The finding as a diagnostic, its kind as the code (`error[tip_error]`).
    pub fn diagnostic(&self) -> Diagnostic {
        Diagnostic {
            path: self.at.path.clone(),
            line: self.at.line,
            column: self.at.column,
            message: self.at.message.clone(),
            source_line: self.at.source_line.clone(),
            code: Some(self.kind.code()),
        }
    }
}

impl FindingKind {
    /// The name the JSON output gives the kind.
    pub fn code(self) -> &'static str {
        match self {
            FindingKind::Refused => "refused",
            FindingKind::TravelLimit => TRAVEL_LIMIT,
            FindingKind::TipError => "tip_error",
            FindingKind::DirectionError => "direction_error",
            FindingKind::Unread => "unread",
        }
    }
}

/// The largest value of an error over a program, where it is, and (before compensation)
/// its mean over every pose.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Peak {
    pub max: f64,
    /// 1-based line of the largest value; `None` when no pose was evaluated.
    pub line: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mean: Option<f64>,
}

impl Peak {
    fn new(e: Extreme, scale: f64, mean: Option<f64>) -> Self {
        Peak {
            max: e.value * scale,
            line: (e.line > 0).then_some(e.line),
            mean: mean.map(|m| m * scale),
        }
    }
}

/// Predicted tip (mm) and tool direction (µrad) errors.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Errors {
    pub tip_mm: Peak,
    /// Outside singular poses (as `compensate`'s summary reports it).
    pub direction_urad: Peak,
    /// After compensation, at singular poses (the rotary axis along the tool is held, and
    /// the direction error about it is left): present when the program has such blocks.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub singular_direction_urad: Option<Peak>,
}

/// The check of one program.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ProgramCheck {
    pub path: String,
    pub status: Status,
    /// Why the program could not be checked (status `unusable`).
    pub error: Option<String>,
    /// The machine file and error file it was checked against (`None` for a program no
    /// entry of the config claims).
    pub machine: Option<String>,
    pub errors: Option<String>,
    pub thresholds: Option<Thresholds>,
    /// The set-up values the pass used, each with its file and line.
    pub setup: Vec<Used>,
    /// The pass read the program and evaluated its poses: false with a zero error model
    /// (the program is passed through unread) or when it could not be checked.
    pub checked: bool,
    pub lines: usize,
    pub motion_blocks: usize,
    /// Predicted errors if the program ran as it is...
    pub before: Option<Errors>,
    /// ... and after compensation (rounded as written; singular poses included).
    pub after: Option<Errors>,
    /// No block was refused and every compensated pose is within the thresholds.
    pub lands_every_pose: Option<bool>,
    pub singular_blocks: usize,
    /// Blocks written uncompensated because an axis was at an unknown position (after
    /// G28, G30 or G53).
    pub uncompensated_blocks: usize,
    pub findings: Vec<Finding>,
    /// What is worth knowing but is no failure (the compensation summary's notes).
    pub notes: Vec<String>,
    /// The pass stopped at its limit of refused blocks; later blocks were not checked.
    pub stopped_early: bool,
}

impl ProgramCheck {
    pub fn unusable(path: &str, error: &Error) -> Self {
        ProgramCheck {
            path: path.to_string(),
            status: Status::Unusable,
            error: Some(error.to_string()),
            machine: None,
            errors: None,
            thresholds: None,
            setup: Vec::new(),
            checked: false,
            lines: 0,
            motion_blocks: 0,
            before: None,
            after: None,
            lands_every_pose: None,
            singular_blocks: 0,
            uncompensated_blocks: 0,
            findings: Vec::new(),
            notes: Vec::new(),
            stopped_early: false,
        }
    }
}

/// Checks programs against one machine, error model and set of options.
pub struct Checker<'m> {
    comp: Compensator<'m>,
    /// Program letters of the active axes (to point at a block's axis words).
    letters: Vec<u8>,
    thresholds: Thresholds,
    max_refused: usize,
    /// A program the pass did not read (a zero error model) is clean, not a finding.
    allow_unread: bool,
    /// The machine and error files' names and the set-up values, for each program's entry.
    names: Option<(String, String)>,
    setup: Vec<Used>,
}

impl<'m> Checker<'m> {
    /// `options` are the compensation options the programs will be compensated with.
    pub fn new(
        machine: &'m Machine,
        errors: &ErrorModel,
        options: Options,
        thresholds: Thresholds,
    ) -> crate::Result<Self> {
        let max_refused = options.max_errors;
        let comp = Compensator::new(machine, errors, options)?;
        let letters = comp
            .kinematics()
            .axes()
            .iter()
            .map(|&i| machine.axes[i].word.to_ascii_uppercase() as u8)
            .collect();
        Ok(Checker {
            comp,
            letters,
            thresholds,
            max_refused,
            allow_unread: false,
            names: None,
            setup: Vec::new(),
        })
    }

    /// Name the machine and error files and the set-up values in each program's check.
    pub fn described(self, machine: &str, errors: &str, setup: Vec<Used>) -> Self {
        Checker {
            names: Some((machine.to_string(), errors.to_string())),
            setup,
            ..self
        }
    }

    /// `check` with this checker's machine, error file, thresholds and set-up named.
    fn stamp(&self, mut check: ProgramCheck) -> ProgramCheck {
        if let Some((m, e)) = &self.names {
            check.machine = Some(m.clone());
            check.errors = Some(e.clone());
        }
        check.thresholds = Some(self.thresholds);
        check.setup = self.setup.clone();
        check
    }

    /// Whether a program the pass did not read (a zero error model copies every program
    /// unread) passes as clean (`--allow-unread`) or is a finding (the default: a gate
    /// must not pass what it did not read).
    pub fn allow_unread(self, allow: bool) -> Self {
        Checker {
            allow_unread: allow,
            ..self
        }
    }

    pub fn thresholds(&self) -> Thresholds {
        self.thresholds
    }

    /// Check the program `src`, named `path` in messages.
    pub fn program(&self, src: &[u8], path: &str) -> ProgramCheck {
        let mut out = Vec::with_capacity(src.len() + src.len() / 8);
        let (summary, refused) = self.comp.run_all(src, path, &mut out);
        let t = self.thresholds;
        let mut findings: Vec<Finding> = refused
            .iter()
            .map(|d| Finding {
                kind: if d.code == Some(TRAVEL_LIMIT) {
                    FindingKind::TravelLimit
                } else {
                    FindingKind::Refused
                },
                at: d.into(),
            })
            .collect();
        findings.extend(summary.limit_violations.iter().map(|d| Finding {
            kind: FindingKind::TravelLimit,
            at: d.into(),
        }));
        let (mean_p, mean_d) = summary.before_means();
        let before = Errors {
            tip_mm: Peak::new(summary.before_position, 1.0, Some(mean_p)),
            direction_urad: Peak::new(summary.before_direction, 1e6, Some(mean_d)),
            singular_direction_urad: None,
        };
        // Singular poses keep a direction error the pass cannot remove: it is reported on its
        // own (as `compensate` reports it) and judged with the rest.
        let after_direction = judged_direction(&summary);
        let after = Errors {
            tip_mm: Peak::new(summary.after_position, 1.0, None),
            direction_urad: Peak::new(summary.after_direction, 1e6, None),
            singular_direction_urad: (summary.singular_blocks > 0)
                .then(|| Peak::new(summary.singular_direction, 1e6, None)),
        };
        let worst_direction = Peak::new(after_direction, 1e6, None);
        let mut within = true;
        if summary.zero_model && !self.allow_unread {
            within = false;
            findings.push(Finding {
                kind: FindingKind::Unread,
                at: (&Diagnostic::at(
                    path,
                    src,
                    0,
                    "the error model is zero, so the program was passed through unread and \
                     nothing was checked: expected the machine's real error file (or \
                     --allow-unread to let unread programs pass)",
                ))
                    .into(),
            });
        }
        if let (true, Some(line)) = (after.tip_mm.max > t.max_error_mm, after.tip_mm.line) {
            within = false;
            findings.push(self.at_line(
                FindingKind::TipError,
                src,
                path,
                line,
                format!(
                    "the predicted tip error after compensation is {:.3} µm, above --max-error {} mm",
                    after.tip_mm.max * 1e3,
                    t.max_error_mm
                ),
            ));
        }
        if let (Some(max_angle), Some(line)) = (t.max_angle_urad, worst_direction.line)
            && worst_direction.max > max_angle
        {
            within = false;
            let why = if summary.singular_direction == after_direction {
                " (a singular pose: the rotary axis along the tool is held)"
            } else {
                ""
            };
            findings.push(self.at_line(
                FindingKind::DirectionError,
                src,
                path,
                line,
                format!(
                    "the predicted tool direction error after compensation is {:.2} µrad{why}, above --max-angle {} µrad",
                    worst_direction.max, max_angle
                ),
            ));
        }
        findings.sort_by_key(|f| (f.at.line, f.at.column));
        let notes = notes(&summary, &before, &t);
        self.stamp(ProgramCheck {
            path: path.to_string(),
            status: if findings.is_empty() {
                Status::Clean
            } else {
                Status::Findings
            },
            error: None,
            machine: None,
            errors: None,
            thresholds: None,
            setup: Vec::new(),
            checked: !summary.zero_model,
            lines: summary.lines,
            motion_blocks: summary.motion_blocks,
            before: Some(before),
            after: Some(after),
            // A pass that read nothing lands nothing: it says so instead.
            lands_every_pose: (!summary.zero_model).then_some(refused.is_empty() && within),
            singular_blocks: summary.singular_blocks,
            uncompensated_blocks: summary.uncompensated_blocks,
            findings,
            notes,
            stopped_early: refused.len() >= self.max_refused,
        })
    }

    /// Check the program in the file at `path`: unusable if it cannot be read, or if
    /// nccomp itself fails on it (a panic is caught and reported for this program alone,
    /// so one bad file never stops the others).
    pub fn file(&self, path: &Path) -> ProgramCheck {
        let name = path.display().to_string();
        let check = || match std::fs::read(path) {
            Ok(src) => self.program(&src, &name),
            Err(e) => self.stamp(ProgramCheck::unusable(&name, &Error::io(path, e))),
        };
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(check)).unwrap_or_else(|panic| {
            let message = format!(
                "{name}: nccomp failed on this program ({}): an internal error, please report \
                 it with the program; the other programs were checked",
                panic_message(&*panic)
            );
            self.stamp(ProgramCheck::unusable(&name, &Error::Usage(message)))
        })
    }

    /// Check every file, in parallel (rayon's pool: `RAYON_NUM_THREADS` threads, one per
    /// core by default), calling `done` as each finishes. The result is in the order of
    /// `paths`.
    pub fn files(&self, paths: &[PathBuf], done: &(dyn Fn() + Sync)) -> Vec<ProgramCheck> {
        paths
            .par_iter()
            .map(|p| {
                let check = self.file(p);
                done();
                check
            })
            .collect()
    }

    /// [`Checker::files`] of the files [`super::expand_marked`] gives: one a pattern
    /// matched that is a FIFO or a socket is unusable, not read (reading it would wait for
    /// a writer).
    pub fn matched_files(
        &self,
        files: &[(PathBuf, bool)],
        done: &(dyn Fn() + Sync),
    ) -> Vec<ProgramCheck> {
        files
            .par_iter()
            .map(|(p, special)| {
                let check = if *special {
                    let name = p.display().to_string();
                    let message = format!(
                        "{name}: not a regular file (a FIFO or a socket), matched by a pattern: expected an NC program file"
                    );
                    ProgramCheck::unusable(&name, &Error::Usage(message))
                } else {
                    self.file(p)
                };
                done();
                check
            })
            .collect()
    }

    /// A finding at `line`, pointing at the block's first axis word (or its start).
    fn at_line(
        &self,
        kind: FindingKind,
        src: &[u8],
        path: &str,
        line: usize,
        message: String,
    ) -> Finding {
        let offset = nc::lines(src).nth(line - 1).map_or(src.len(), |l| {
            let mut tokens = Vec::new();
            nc::Dialect::detect_named(path, src).parse_line(l.content, &mut tokens);
            let first_axis = tokens.iter().find_map(|t| match &t.kind {
                TokenKind::Word(w) if self.letters.contains(&w.letter) => Some(t.span.start),
                _ => None,
            });
            let first_word = tokens.iter().find_map(|t| match &t.kind {
                TokenKind::Word(_) => Some(t.span.start),
                _ => None,
            });
            l.offset + first_axis.or(first_word).unwrap_or(0)
        });
        Finding {
            kind,
            at: (&Diagnostic::at(path, src, offset, message)).into(),
        }
    }
}

/// The summary's notes, and whether the program needs compensation at all.
fn notes(summary: &Summary, before: &Errors, t: &Thresholds) -> Vec<String> {
    if summary.zero_model {
        return vec![
            "the error model is zero: the program passes unchanged and nothing was checked".into(),
        ];
    }
    let mut notes = Vec::new();
    if summary.motion_blocks == 0 && summary.uncompensated_blocks == 0 {
        notes.push("no block moves an axis: nothing to compensate".into());
    }
    let over_tip = before.tip_mm.max > t.max_error_mm;
    let over_dir = t
        .max_angle_urad
        .is_some_and(|m| before.direction_urad.max > m);
    if over_tip || over_dir {
        notes.push(format!(
            "run uncompensated, the program would be outside the thresholds (predicted {}): it needs compensation",
            [
                over_tip.then(|| format!("tip error {:.3} µm", before.tip_mm.max * 1e3)),
                over_dir.then(|| format!(
                    "direction error {:.2} µrad",
                    before.direction_urad.max
                )),
            ]
            .into_iter()
            .flatten()
            .collect::<Vec<_>>()
            .join(", ")
        ));
    }
    notes.extend(
        summary
            .remarks()
            .into_iter()
            .map(|r| r.strip_prefix("note: ").map_or(r.clone(), str::to_string)),
    );
    notes
}

/// Every program's check and the run's status.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The config the run followed (`nccomp check` with `nccomp.toml`).
    pub config: Option<String>,
    /// The machine file, error file and thresholds of every program; `None` in a run from
    /// a config (each program names its own).
    pub machine: Option<String>,
    pub errors: Option<String>,
    pub thresholds: Option<Thresholds>,
    pub programs: Vec<ProgramCheck>,
}

impl Run {
    /// The worst status of any program (clean for none).
    pub fn status(&self) -> Status {
        self.programs
            .iter()
            .map(|p| p.status)
            .max()
            .unwrap_or(Status::Clean)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{error_file, machine_file};
    use std::path::Path;

    fn fixture(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("fixtures")
            .join(name)
    }

    #[test]
    fn finding_codes_are_the_json_kinds() {
        for kind in [
            FindingKind::Refused,
            FindingKind::TravelLimit,
            FindingKind::TipError,
            FindingKind::DirectionError,
            FindingKind::Unread,
        ] {
            assert_eq!(serde_json::to_value(kind).unwrap(), kind.code());
        }
    }

    #[test]
    fn the_worst_program_decides_the_run() {
        let machine = machine_file::load(&fixture("ac_trunnion.machine.toml")).unwrap();
        let errors = error_file::load(&fixture("ac_trunnion.errors.toml"), &machine).unwrap();
        let checker =
            Checker::new(&machine, &errors, Options::default(), Thresholds::default()).unwrap();
        let clean = checker.program(b"G0 X10 Y10 Z50 A-20 C30\n", "a.nc");
        assert_eq!(clean.status, Status::Clean, "{clean:#?}");
        let refused = checker.program(b"G0 X10 Y10 Z50 A-20 C30\nG41 D1 X1\n", "b.nc");
        assert_eq!(refused.status, Status::Findings);
        assert_eq!(refused.lands_every_pose, Some(false));
        let mut run = Run {
            config: None,
            machine: None,
            errors: None,
            thresholds: None,
            programs: vec![clean.clone()],
        };
        assert_eq!(run.status(), Status::Clean);
        run.programs.push(refused);
        assert_eq!(run.status(), Status::Findings);
        run.programs
            .push(checker.file(&fixture("no such program.nc")));
        assert_eq!(run.status(), Status::Unusable);
        assert_eq!(run.status().exit_code(), 2);
    }

    #[test]
    fn a_zero_model_reads_nothing_so_each_program_is_a_finding_unless_allowed() {
        let machine = machine_file::load(&fixture("ac_trunnion.machine.toml")).unwrap();
        let zero = ErrorModel::zero(&machine);
        let checker =
            Checker::new(&machine, &zero, Options::default(), Thresholds::default()).unwrap();
        let check = checker.program(b"G41 D1 X1\n", "a.nc");
        assert_eq!(check.status, Status::Findings, "{check:#?}");
        assert_eq!(check.findings[0].kind, FindingKind::Unread);
        assert_eq!(
            (check.findings[0].at.line, check.findings[0].at.column),
            (1, 1)
        );
        let checker = checker.allow_unread(true);
        let check = checker.program(b"G41 D1 X1\n", "a.nc");
        assert_eq!(check.status, Status::Clean);
        assert!(check.notes[0].contains("nothing was checked"), "{check:#?}");
        // Nothing read, nothing landed: the check does not claim it.
        assert_eq!((check.checked, check.lands_every_pose), (false, None));
        let run = Run {
            config: None,
            machine: Some("m.toml".into()),
            errors: Some("zero.toml".into()),
            thresholds: Some(Thresholds::default()),
            programs: vec![check],
        };
        let human = run.human(false, false);
        assert!(!human.contains("lands every pose"), "{human}");
        assert!(human.contains("nothing was checked"), "{human}");
    }

    #[test]
    fn thresholds_must_be_positive() {
        assert!(Thresholds::new(0.01, None).is_ok());
        assert!(Thresholds::new(0.0, None).is_err());
        assert!(Thresholds::new(0.01, Some(-1.0)).is_err());
        assert!(Thresholds::new(f64::NAN, None).is_err());
    }
}

//! The page's pass/fail line: the predicted errors after compensation against
//! `--max-error` and `--max-angle`, judged as `nccomp check` judges them (singular poses
//! and tilted working planes included), so the page and the CI gate agree.

use crate::check::{Thresholds, judged_direction};
use crate::compensate::Summary;

/// What the line says.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    Pass,
    Fail,
    /// Nothing was judged: a zero error model, or no block that moves.
    NotChecked,
}

impl Outcome {
    pub fn word(self) -> &'static str {
        match self {
            Outcome::Pass => "PASS",
            Outcome::Fail => "FAIL",
            Outcome::NotChecked => "NOT CHECKED",
        }
    }
}

/// The outcome and one sentence per threshold.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    pub outcome: Outcome,
    pub lines: Vec<String>,
}

/// A threshold in the unit the plots use: µm for mm.
fn um(mm: f64) -> String {
    format!("{} µm", super::plots::short(mm * 1e3))
}

/// Judge `summary` against `t` (a `None` angle: the direction is reported, not judged).
pub fn judge(summary: &Summary, t: &Thresholds) -> Verdict {
    if summary.zero_model {
        return Verdict {
            outcome: Outcome::NotChecked,
            lines: vec![
                "the error model is zero: the program was passed through unread and nothing \
                 was checked"
                    .into(),
            ],
        };
    }
    if summary.motion_blocks == 0 {
        return Verdict {
            outcome: Outcome::NotChecked,
            lines: vec!["no block moves an axis: nothing to compensate".into()],
        };
    }
    let tip = summary.after_position;
    let tip_over = tip.value > t.max_error_mm;
    let mut lines = vec![format!(
        "tool-tip error after compensation {:.3} µm (line {}): {} --max-error {}",
        tip.value * 1e3,
        tip.line,
        if tip_over { "above" } else { "within" },
        um(t.max_error_mm)
    )];
    let dir = judged_direction(summary);
    let why = if dir.line == 0 {
        ""
    } else if dir == summary.singular_direction && summary.singular_blocks > 0 {
        ", a singular pose: the rotary axis along the tool is held"
    } else if dir == summary.plane_direction && summary.plane_blocks > 0 {
        ", in a tilted working plane: the control turns the rotary axes, nccomp corrects \
         the tip only"
    } else {
        ""
    };
    let dir_over = t.max_angle_urad.is_some_and(|m| dir.value * 1e6 > m);
    lines.push(match t.max_angle_urad {
        Some(m) => format!(
            "tool-direction error after compensation {:.2} µrad (line {}{why}): {} --max-angle {} µrad",
            dir.value * 1e6,
            dir.line,
            if dir_over { "above" } else { "within" },
            super::plots::short(m)
        ),
        None => format!(
            "tool-direction error after compensation {:.2} µrad (line {}{why}): not judged",
            dir.value * 1e6,
            dir.line
        ),
    });
    Verdict {
        outcome: if tip_over || dir_over {
            Outcome::Fail
        } else {
            Outcome::Pass
        },
        lines,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compensate::Extreme;

    fn summary(tip_mm: f64, dir_rad: f64, singular_rad: f64) -> Summary {
        Summary {
            motion_blocks: 10,
            after_position: Extreme {
                value: tip_mm,
                line: 5,
            },
            after_direction: Extreme {
                value: dir_rad,
                line: 6,
            },
            singular_blocks: usize::from(singular_rad > 0.0),
            singular_direction: Extreme {
                value: singular_rad,
                line: 7,
            },
            ..Summary::default()
        }
    }

    fn t(angle: Option<f64>) -> Thresholds {
        Thresholds {
            max_error_mm: 0.010,
            max_angle_urad: angle,
        }
    }

    #[test]
    fn both_thresholds_judge_as_check_does() {
        let v = judge(&summary(0.0001, 50e-6, 0.0), &t(Some(100.0)));
        assert_eq!(v.outcome, Outcome::Pass);
        assert!(v.lines[0].contains("0.100 µm (line 5): within --max-error 10 µm"));
        assert!(v.lines[1].contains("50.00 µrad (line 6): within --max-angle 100 µrad"));
        // The tip alone fails.
        let v = judge(&summary(0.011, 50e-6, 0.0), &t(Some(100.0)));
        assert_eq!(v.outcome, Outcome::Fail);
        assert!(v.lines[0].contains("above --max-error"));
        // A singular pose's direction error is judged, and named.
        let v = judge(&summary(0.0001, 1e-6, 166e-6), &t(Some(100.0)));
        assert_eq!(v.outcome, Outcome::Fail);
        assert!(v.lines[1].contains("166.00 µrad (line 7, a singular pose"));
        // Without an angle the direction is reported, not judged.
        let v = judge(&summary(0.0001, 1e-6, 166e-6), &t(None));
        assert_eq!(v.outcome, Outcome::Pass);
        assert!(v.lines[1].ends_with("not judged"));
    }

    #[test]
    fn nothing_to_judge_is_said() {
        let zero = Summary {
            zero_model: true,
            ..Summary::default()
        };
        assert_eq!(judge(&zero, &t(None)).outcome, Outcome::NotChecked);
        assert_eq!(
            judge(&Summary::default(), &t(None)).outcome,
            Outcome::NotChecked
        );
    }
}

//! The options of a pass and of a check as given in one place (the command line, an entry
//! of `nccomp.toml`, its `[defaults]`), each left out where that place says nothing, so
//! that places can be layered: the command line over the entry over the defaults over
//! the built-in values below.

use super::Thresholds;
use crate::compensate::Options;
use crate::diag::Error;
use std::path::PathBuf;

/// `--max-error` when no place gives it, mm.
pub const MAX_ERROR_MM: f64 = 0.010;
/// `--max-angle` when no place gives it, µrad: the tilt that moves a point 100 mm up the
/// tool by the default `--max-error` (10 µm), so a tool direction error that shows on a
/// flank or a long tool's shank fails the check.
pub const MAX_ANGLE_URAD: f64 = 100.0;
/// `--tolerance` when no place gives it, mm.
pub const TOLERANCE_MM: f64 = 0.001;
/// `--angular-tolerance` when no place gives it, µrad.
pub const ANGULAR_TOLERANCE_URAD: f64 = 10.0;

/// Options of one place; `None`: not given there.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Settings {
    /// `Some(None)`: `off`.
    pub tolerance: Option<Option<f64>>,
    pub angular_tolerance: Option<f64>,
    pub tool_chain: Option<String>,
    pub hold: Option<Vec<String>>,
    pub allow_limit_violations: Option<bool>,
    pub dialect: Option<Option<crate::nc::Dialect>>,
    pub block_delete: Option<bool>,
    pub setup: Option<Vec<PathBuf>>,
    pub max_error: Option<f64>,
    pub max_angle: Option<f64>,
    pub allow_unread: Option<bool>,
}

impl Settings {
    /// These settings, with `under`'s where these say nothing.
    pub fn over(self, under: &Settings) -> Settings {
        let u = under.clone();
        Settings {
            tolerance: self.tolerance.or(u.tolerance),
            angular_tolerance: self.angular_tolerance.or(u.angular_tolerance),
            tool_chain: self.tool_chain.or(u.tool_chain),
            hold: self.hold.or(u.hold),
            allow_limit_violations: self.allow_limit_violations.or(u.allow_limit_violations),
            dialect: self.dialect.or(u.dialect),
            block_delete: self.block_delete.or(u.block_delete),
            setup: self.setup.or(u.setup),
            max_error: self.max_error.or(u.max_error),
            max_angle: self.max_angle.or(u.max_angle),
            allow_unread: self.allow_unread.or(u.allow_unread),
        }
    }

    /// The compensation pass's options (built-in values where no place gave one).
    pub fn options(&self) -> crate::Result<Options> {
        let v = self.angular_tolerance.unwrap_or(ANGULAR_TOLERANCE_URAD);
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::Usage(format!(
                "--angular-tolerance {v}: expected a positive number of µrad"
            )));
        }
        if let Some(Some(mm)) = self.tolerance
            && !(mm.is_finite() && mm > 0.0)
        {
            return Err(Error::Usage(format!(
                "--tolerance {mm}: expected a positive distance in mm (e.g. 0.001) or `off`"
            )));
        }
        Ok(Options {
            tool_chain: self.tool_chain.clone(),
            allow_limit_violations: self.allow_limit_violations.unwrap_or(false),
            hold: self.hold.clone().unwrap_or_default(),
            path: self.tolerance.unwrap_or(Some(TOLERANCE_MM)).map(|mm| {
                crate::kinematics::path::PathTolerance {
                    position: mm,
                    direction: v * 1e-6,
                    ..Default::default()
                }
            }),
            dialect: self.dialect.flatten(),
            block_delete: self.block_delete,
            ..Options::default()
        })
    }

    /// The check's thresholds (built-in values where no place gave one).
    pub fn thresholds(&self) -> crate::Result<Thresholds> {
        Thresholds::new(
            self.max_error.unwrap_or(MAX_ERROR_MM),
            Some(self.max_angle.unwrap_or(MAX_ANGLE_URAD)),
        )
    }

    /// The set-up files, in order (none when no place gave any).
    pub fn setup_files(&self) -> &[PathBuf] {
        self.setup.as_deref().unwrap_or(&[])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_nearer_place_wins_field_by_field() {
        let cli = Settings {
            max_angle: Some(20.0),
            ..Settings::default()
        };
        let entry = Settings {
            max_angle: Some(50.0),
            max_error: Some(0.005),
            tolerance: Some(None),
            ..Settings::default()
        };
        let defaults = Settings {
            max_error: Some(0.02),
            block_delete: Some(false),
            ..Settings::default()
        };
        let s = cli.over(&entry.over(&defaults));
        let t = s.thresholds().unwrap();
        assert_eq!((t.max_error_mm, t.max_angle_urad), (0.005, Some(20.0)));
        let o = s.options().unwrap();
        assert!(o.path.is_none());
        assert_eq!(o.block_delete, Some(false));
    }

    #[test]
    fn built_in_values_judge_the_direction_too() {
        let t = Settings::default().thresholds().unwrap();
        assert_eq!((t.max_error_mm, t.max_angle_urad), (0.010, Some(100.0)));
        let o = Settings::default().options().unwrap();
        assert_eq!(o.path.unwrap().position, 0.001);
    }
}

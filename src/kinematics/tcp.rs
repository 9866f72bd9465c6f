//! Tool-centre-point programs: the controller does the inverse kinematics.
//!
//! A TCP program (G43.4 with rotary words, G43.5 with a tool vector) gives the tool tip in
//! the workpiece frame; the controller turns it into axis values with its nominal inverse
//! kinematics. To land the real machine on the intended pose, nccomp finds the axis values
//! the real machine needs (the ordinary compensation) and then writes the tip and direction
//! at which the *nominal* machine would sit at those axis values: the controller's nominal
//! solve of what is written gives exactly the axis values the real machine needs.

use super::{Kinematics, Model, Pose, Solution, SolveOptions};

/// What to write for one TCP block.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TcpCorrection {
    /// The tip and direction to program.
    pub programmed: Pose,
    /// The axis values the controller will reach (and the solve that found them).
    pub solution: Solution,
}

impl Kinematics {
    /// The nominal axis values for a tip `target.p` with the rotary axes at `rotary` (the
    /// G43.4 case: the program gives the rotary positions, the controller solves the linear
    /// axes). `guess` supplies the linear axes' starting values.
    pub fn tcp_axes_with_rotaries(
        &self,
        tip: &nalgebra::Vector3<f64>,
        rotary_and_guess: &[f64],
        length: f64,
        options: &SolveOptions,
    ) -> Solution {
        self.solve_to_tip(tip, rotary_and_guess, length, options)
    }

    /// The correction of a TCP block whose nominal axis values are `q` (as the controller
    /// would solve the programmed pose): the pose to program instead.
    pub fn compensate_tcp(
        &self,
        q: &[f64],
        length: f64,
        hold: u32,
        options: &SolveOptions,
    ) -> TcpCorrection {
        let solution = self.compensate(q, length, hold, options);
        let (programmed, _) = self.pose(Model::Nominal, solution.values(), length);
        TcpCorrection {
            programmed,
            solution,
        }
    }
}

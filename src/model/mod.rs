//! The machine and its error model, as the contract (design/model.md) defines them.
//!
//! Files are read by [`machine_file`] and [`error_file`]; ISO 230 error names are mapped
//! onto this model in exactly one place, [`terms`]. Everything here is in the units the
//! kinematics use: millimetres and degrees for axis positions, millimetres and radians for
//! errors.

pub mod error_file;
pub mod machine_file;
pub mod setup;
pub mod table;
pub mod terms;

use nalgebra::Vector3;
use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

/// The ranges every number of a machine or error file must lie in, checked where it is
/// read, so that nothing absurd (`1e300`, an overflow to infinity) reaches the model
/// (docs/file-formats.md, "Limits").
pub mod limits {
    /// The largest machine or error file, in bytes (512 KiB): a larger one is refused
    /// before it is read. Reading takes up to about 100 bytes of memory per byte of TOML,
    /// so whatever is read stays within 64 MiB.
    pub const FILE_BYTES: usize = 1 << 19;
    /// Positions and lengths of the machine, mm: points, travels, table offsets, tool
    /// lengths, error-table positions of linear axes (±100 m).
    pub const LENGTH_MM: f64 = 1e5;
    /// Angular positions, degrees: travels, table offsets and error-table positions of
    /// rotary axes.
    pub const ANGLE_DEG: f64 = 1e5;
    /// The components of a `direction` (only its direction counts).
    pub const DIRECTION: f64 = 1e6;
    /// The smallest largest component of a `direction`: below it the vector is taken as
    /// zero.
    pub const DIRECTION_MIN: f64 = 1e-6;
    /// `resolution`, mm or degrees.
    pub const RESOLUTION: [f64; 2] = [1e-6, 0.1];
    /// An error of length (a shift, a straightness, a positioning error), mm.
    pub const ERROR_LENGTH_MM: f64 = 10.0;
    /// An error of angle (a squareness, a tilt, a roll, pitch or yaw), rad.
    pub const ERROR_ANGLE_RAD: f64 = 0.1;
    /// How far from parallel (degrees) two rotary axes that set the tool direction, or
    /// two or three linear axes that set the tip, must be.
    pub const AXIS_ANGLE_DEG: f64 = 1.0;

    /// A limit as the documentation writes it: six significant digits at most, no
    /// trailing zeros (1e-6 is `0.000001`, 0.1 rad in degrees `5.72958`).
    pub fn shown(x: f64) -> String {
        let magnitude = if x == 0.0 {
            0
        } else {
            x.abs().log10().floor() as i32
        };
        let decimals = 5i32.saturating_sub(magnitude).clamp(0, 17) as usize;
        let text = format!("{x:.decimals$}");
        if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        }
    }
}

/// The text of a machine or error file (`what` names it in messages): at most
/// [`limits::FILE_BYTES`], refused by its size before it is read (a pipe or a device by
/// the first byte past the limit), and UTF-8, refused at the first byte that is not.
pub(crate) fn read_text(path: &Path, what: &str) -> crate::Result<String> {
    let io = |e| crate::Error::io(path, e);
    let name = path.display().to_string();
    let too_large = |size: String| {
        crate::Error::at(
            &name,
            b"",
            0,
            format!(
                "the {what} is {size}: expected at most {} bytes (512 KiB), the limit for \
                 machine and error files",
                limits::FILE_BYTES
            ),
        )
    };
    let file = std::fs::File::open(path).map_err(io)?;
    if let Ok(meta) = file.metadata()
        && meta.is_file()
        && meta.len() > limits::FILE_BYTES as u64
    {
        return Err(too_large(format!("{} bytes", meta.len())));
    }
    let mut bytes = Vec::new();
    file.take(limits::FILE_BYTES as u64 + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() > limits::FILE_BYTES {
        return Err(too_large(format!("more than {} bytes", limits::FILE_BYTES)));
    }
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        crate::Error::at(
            &name,
            e.as_bytes(),
            at,
            format!("the {what} is not UTF-8 text here (byte {at}): expected a TOML file"),
        )
    })
}

pub use table::{IndexedTable, MotionTable};

/// Whether an axis slides or turns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AxisKind {
    Linear,
    Rotary,
}

/// One axis of the machine, nominal geometry at the home state (all axis words 0), in B.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// The axis's key in the machine file (`[axes.X]` → "X").
    pub name: String,
    /// The program word that drives it, uppercase ('X', 'A', ...).
    pub word: char,
    pub kind: AxisKind,
    /// Nominal unit direction: of motion (linear) or of the rotation axis (rotary), with
    /// the sense of the body the axis moves.
    pub direction: Vector3<f64>,
    /// Rotary: a point on the axis line. Linear: the error reference point r.
    pub point: Vector3<f64>,
    /// Travel limits in program coordinates (mm or degrees); `None`: unlimited/continuous.
    pub travel: Option<[f64; 2]>,
    /// Added to the program position before error-table look-up.
    pub table_offset: f64,
    /// A rotary axis the control rolls over (FANUC's rotary axis roll-over, parameter
    /// 1008#0 ROA): an absolute word is an angle modulo 360°, reached the shortest way.
    pub rollover: bool,
}

/// A named chain of axes from the bed outward (indices into [`Machine::axes`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Chain {
    pub name: String,
    pub axes: Vec<usize>,
    /// The T numbers that select this chain in a program (machine file `tools`); empty:
    /// T words do not select it.
    pub tools: Vec<u32>,
}

/// A lathe's main spindle and how programs address it (machine file `[lathe]`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lathe {
    /// The rotary axis of the workpiece chain that turns the part (index into
    /// [`Machine::axes`]).
    pub spindle: usize,
    /// X words are diameters at the program start, as after G7 (else radii, as after G8).
    pub diameter: bool,
}

/// Output resolution: the smallest step written for linear (mm) and rotary (degree) words.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    pub linear: f64,
    pub rotary: f64,
}

impl Default for Resolution {
    fn default() -> Self {
        Resolution {
            linear: 0.0001,
            rotary: 0.0001,
        }
    }
}

/// Tool lengths: the reference length the machine file's geometry was measured with,
/// and the lengths of the tools a G43 H word can pick; what a tool change moves.
#[derive(Debug, Clone, PartialEq)]
pub struct Tool {
    pub length: f64,
    /// By number: G43 H, D with T, TOOL CALL n.
    pub lengths: BTreeMap<u32, f64>,
    /// By name: TOOL CALL "name", T="name" (machine file `named_lengths`).
    pub named_lengths: BTreeMap<String, f64>,
    /// Tool radii for tool radius compensation (RL/RR, G41/G42), by number (machine file
    /// `radii`) ...
    pub radii: BTreeMap<u32, f64>,
    /// ... by name (`named_radii`) ...
    pub named_radii: BTreeMap<String, f64>,
    /// ... and a bound for any tool (`max_radius`), used where neither gives the called
    /// tool's.
    pub max_radius: Option<f64>,
    /// The program letters of the axes a tool change (M6, TOOL CALL) sends to the change
    /// position, bit `letter - 'A'` (machine file `change_moves`; default Z): they are
    /// unknown after the change, as after G28.
    pub change_moves: u32,
}

impl Default for Tool {
    fn default() -> Self {
        Tool {
            length: 0.0,
            lengths: BTreeMap::new(),
            named_lengths: BTreeMap::new(),
            radii: BTreeMap::new(),
            named_radii: BTreeMap::new(),
            max_radius: None,
            change_moves: 1 << (b'Z' - b'A'),
        }
    }
}

/// A machine: its axes, the workpiece chain and one or more tool chains.
#[derive(Debug, Clone, PartialEq)]
pub struct Machine {
    pub name: Option<String>,
    pub axes: Vec<Axis>,
    pub workpiece_chain: Vec<usize>,
    /// At least one. A machine file's `tool_chain = [...]` is one chain named "tool".
    pub tool_chains: Vec<Chain>,
    pub resolution: Resolution,
    pub tool: Tool,
    /// Set for a lathe or turning–milling centre: its spindle turns the part.
    pub lathe: Option<Lathe>,
    /// G and M codes of this machine's own that programs may use (machine file `[codes]`).
    pub codes: crate::program::MachineCodes,
    /// Which rotary solution the controller's G53.1 takes (machine file `[working_plane]`).
    pub plane_solution: PlaneSolution,
    /// The units the controller reads a program in until it says G20 or G21 (machine file
    /// `units`; a Haas control's Setting 9, a FANUC parameter): inch when set.
    pub inch_default: bool,
    /// The controller's work offsets (machine file `[work_offsets]`); `None`: the machine
    /// file's geometry is in the program zero of the one work offset a program uses.
    pub work_offsets: Option<WorkOffsets>,
    /// A drilling cycle given no R word takes the level it starts from as its R plane
    /// (machine file `[cycles] missing_r = "initial"`, a Haas control); otherwise it is
    /// refused.
    pub cycle_r_initial: bool,
    /// The block delete switch's state when this machine runs programs (machine file
    /// `block_delete = "on"|"off"`); `None`: not declared, outputs must be right in both.
    pub block_delete: Option<bool>,
    /// Where axes stand when a program starts (machine file `[start]`): machine axis
    /// index and value (mm, degrees). Axes not given stand where the program has not
    /// said: not known until it sets them.
    pub start: Vec<(usize, f64)>,
    /// The error file the machine file names (`errors`, relative to the machine file):
    /// used when no error file is given on the command line.
    pub errors_file: Option<std::path::PathBuf>,
}

/// The work offset table of a controller: where each program zero lies, in machine
/// coordinates (the values on the control's offset page), X, Y, Z in mm.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct WorkOffsets {
    /// The offset whose program zero the machine file's geometry is given in (its code,
    /// see [`WorkOffsets::code`]); `None`: machine zero (G53).
    pub geometry: Option<i64>,
    /// Values by offset code.
    pub values: BTreeMap<i64, [f64; 3]>,
    /// Where the geometry's program zero lies in machine coordinates: the machine file's
    /// value of the `geometry` offset (zero for machine zero). Kept apart from `values`
    /// because a set-up that moves that offset moves the part, not the machine's axes.
    pub geometry_zero: [f64; 3],
    /// Heidenhain's M92 reference: the point, in machine coordinates, that M92 words are
    /// given from (the machine builder's, such as the tool change position).
    pub m92: Option<[f64; 3]>,
}

impl WorkOffsets {
    /// The code of an offset: G54 … G59 by their number times ten (540 … 590, 591 … 593
    /// for G59.1 … G59.3), G54.1 Pn as 100 000 + n.
    pub fn code(name: &str) -> Option<i64> {
        let name = name.trim().to_ascii_uppercase();
        if let Some(p) = name
            .strip_prefix("G54.1")
            .map(|r| r.trim_start())
            .and_then(|r| r.strip_prefix('P'))
        {
            return p
                .parse::<i64>()
                .ok()
                .filter(|n| (1..=300).contains(n))
                .map(|n| 100_000 + n);
        }
        let g: f64 = name.strip_prefix('G')?.parse().ok()?;
        let code = (g * 10.0).round() as i64;
        ([540, 550, 560, 570, 580, 590, 591, 592, 593].contains(&code)
            && (g * 10.0 - code as f64).abs() < 1e-9)
            .then_some(code)
    }

    /// The name of offset `code`, as a program writes it.
    pub fn name(code: &i64) -> String {
        match *code {
            c if c > 100_000 => format!("G54.1 P{}", c - 100_000),
            c if c % 10 == 0 => format!("G{}", c / 10),
            c => format!("G{}.{}", c / 10, c % 10),
        }
    }
}

/// Which of the rotary positions that turn the tool perpendicular to a tilted working plane
/// the controller takes (G53.1): there are two in general, one per sign of the tilting axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlaneSolution {
    /// Fanuc's rule (G53.1): the least move of the first rotary axis (the table's, on a
    /// machine with one in the table and one in the head; else the one nearer the bed),
    /// then of the second, then the angle nearer 0.
    #[default]
    Shortest,
    /// The solution with this axis (index into [`Machine::axes`]) at a positive (or zero)
    /// angle, or at a negative one: Heidenhain's SEQ+ / SEQ-.
    Sign { axis: usize, positive: bool },
}

impl Machine {
    pub fn axis_index(&self, name: &str) -> Option<usize> {
        self.axes.iter().position(|a| a.name == name)
    }

    pub fn tool_chain(&self, name: &str) -> Option<usize> {
        self.tool_chains.iter().position(|c| c.name == name)
    }

    /// The tool chain a program starts in: the one `--tool-chain NAME` names, or the first.
    pub fn start_chain(&self, name: Option<&str>) -> crate::Result<usize> {
        let Some(name) = name else { return Ok(0) };
        self.tool_chain(name).ok_or_else(|| {
            crate::Error::Usage(if self.tool_chains.len() == 1 {
                format!(
                    "--tool-chain {name}: the machine file has a single `tool_chain`, so there is nothing to choose (leave the option out)"
                )
            } else {
                format!(
                    "--tool-chain {name}: the machine file has no such tool chain; it has {}",
                    self.tool_chains
                        .iter()
                        .map(|c| format!("`{}`", c.name))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })
        })
    }

    /// The variables of tool chain `chain`: the machine axes of the workpiece chain and that
    /// tool chain, in the machine file's axis order (the kinematics' variable order).
    pub fn variables(&self, chain: usize) -> Vec<usize> {
        let tool = self.tool_chains.get(chain).map_or(&[][..], |c| &c.axes[..]);
        let mut axes: Vec<usize> = self.workpiece_chain.iter().chain(tool).copied().collect();
        axes.sort_unstable();
        axes.dedup();
        axes
    }

    /// The tool chain a T word selects, if the machine file maps that tool to one.
    pub fn chain_of_tool(&self, tool: u32) -> Option<usize> {
        self.tool_chains
            .iter()
            .position(|c| c.tools.contains(&tool))
    }
}

/// The errors of one axis, in mm and rad. All zero for a perfect axis.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct AxisErrors {
    /// Linear axes: the squareness rotation vector s, d̃ = Rv(s)·d.
    pub squareness: Vector3<f64>,
    /// Rotary axes: shift of the axis line, c̃ = c + shift.
    pub location_shift: Vector3<f64>,
    /// Rotary axes: tilt of the axis line, ã = Rv(tilt)·a.
    pub location_tilt: Vector3<f64>,
    /// Rotary axes: zero-position error e0.
    pub zero: f64,
    /// Error motions against position, if any were given.
    pub motion: Option<MotionTable>,
}

impl AxisErrors {
    pub fn is_zero(&self) -> bool {
        self.squareness == Vector3::zeros()
            && self.location_shift == Vector3::zeros()
            && self.location_tilt == Vector3::zeros()
            && self.zero == 0.0
            && self.motion.as_ref().is_none_or(|m| m.is_zero())
    }
}

/// The error model of a machine: one [`AxisErrors`] per axis, parallel to
/// [`Machine::axes`].
#[derive(Debug, Clone, PartialEq)]
pub struct ErrorModel {
    pub axes: Vec<AxisErrors>,
}

impl ErrorModel {
    /// The model of a perfect machine.
    pub fn zero(machine: &Machine) -> Self {
        ErrorModel {
            axes: vec![AxisErrors::default(); machine.axes.len()],
        }
    }

    pub fn is_zero(&self) -> bool {
        self.axes.iter().all(AxisErrors::is_zero)
    }
}

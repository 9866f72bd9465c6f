//! The one reading of NC programs: what each block means, in no dialect.
//!
//! A program's text is first a lossless document ([`crate::nc`]: lines and tokens). A
//! dialect's front end reads each block's tokens into a [`BlockMotion`]: which axis words
//! it has (by variable of the active tool chain) and how it moves ([`MoveKind`]); it
//! follows the program's [`Modal`] state as it goes (a caller that keeps state of its own
//! compares the modal state before and after the block: the tool chain, the spindle, TCP). The G-code front end ([`Reader::read`]) is the first dialect. Every code's meaning
//! comes from one table ([`codes`]); no other module matches G or M numbers.
//!
//! The compensation pass, its solve-ahead thread, `contour` and `identify` read programs
//! through a [`Reader`]; `probe` follows its own modal state (probing moves, feeds) from
//! the same code table.
//!
//! What the reader refuses, it refuses with the block's place and what was expected: a
//! word given by an expression or a parameter, a letter that is not an axis of the
//! machine, a code not in the table (unless the machine file names it), control flow.

pub mod arc;
pub mod axes;
pub mod codes;
pub mod exact;
pub mod gcode;
pub mod heidenhain;
pub mod moves;
pub mod params;
pub mod sinumerik;
pub mod tnc_cycles;

pub use codes::{Code, CodeName, MachineCodes, Tcp};

use crate::kinematics::MAX_AXES;
use crate::model::Machine;

/// Millimetres per inch.
pub const INCH: f64 = 25.4;

/// How a block moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveKind {
    /// A G0/G1 move in program coordinates (under TCP: the tip and the tool direction).
    Program,
    /// G53: the axis words are machine coordinates. The axes it names end at an unknown
    /// program position.
    Machine,
    /// G28/G30: the axes named (all of them if none is) go to a reference point, and end
    /// at an unknown program position.
    Home,
    /// G2/G3 in program coordinates.
    Arc { clockwise: bool },
    /// A block of a drilling cycle (G81 …).
    Cycle,
    /// G53.1: the controller turns the rotary axes so that the tool is perpendicular to the
    /// tilted working plane.
    ToPlane,
}

/// What a block that moves asks for: token indices of its words in the line's tokens.
#[derive(Debug, Clone, Copy)]
pub struct BlockMotion {
    /// Each variable's axis word (variables of the active tool chain), if the block has one.
    pub axis_words: [Option<usize>; MAX_AXES],
    /// The I, J, K and R words. Under G43.5 I, J, K are the tool vector; in a cycle R is
    /// the retract plane.
    pub arc_words: [Option<usize>; 4],
    /// The G2/G3 word of an arc, the cycle's G word of a cycle block.
    pub arc_code: Option<usize>,
    /// The block starts with a block delete `/`: it runs only with the switch off.
    pub optional: bool,
    pub kind: MoveKind,
    /// The variables a machine file's code (`[codes] machine_moves`) sends to machine
    /// positions; none for G28/G30, whose axis words say which.
    pub homed: u32,
    /// A machine move's words are from Heidenhain's M92 reference, not machine zero.
    pub from_m92: bool,
    /// A TNC cycle call (M99, CYCL CALL): the column of the call, for messages.
    pub cycle_col: Option<usize>,
    /// A TNC arc about a circle centre (CC): the centre in the arc plane's two axes (mm),
    /// absolute.
    pub centre: Option<[f64; 2]>,
    /// A TNC polar arc (CP): its angle (degrees), incremental (IPA) or absolute (PA).
    pub polar: Option<(f64, bool)>,
    /// A TNC helix given incrementally (`CP IPA… IZ…`): the move along the axis
    /// perpendicular to the arc's plane (mm), from where the arc starts.
    pub lead: Option<f64>,
}

impl Default for BlockMotion {
    fn default() -> Self {
        BlockMotion {
            axis_words: [None; MAX_AXES],
            arc_words: [None; 4],
            arc_code: None,
            optional: false,
            kind: MoveKind::Program,
            homed: 0,
            from_m92: false,
            cycle_col: None,
            centre: None,
            polar: None,
            lead: None,
        }
    }
}

/// The side of the contour tool radius compensation puts the tool on (TNC RL/RR, ISO
/// G41/G42), looking along the direction of travel.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RadiusSide {
    Left,
    Right,
}

/// Where the radius tool radius compensation offsets by comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RadiusSource {
    /// The machine file's `[tool] radii`, by the called tool's number.
    Number,
    /// `[tool] named_radii`, by the called tool's name.
    Name,
    /// `[tool] max_radius`: a bound for any tool.
    Max,
}

impl RadiusSource {
    /// The machine file's key.
    pub fn key(self) -> &'static str {
        match self {
            RadiusSource::Number => "radii",
            RadiusSource::Name => "named_radii",
            RadiusSource::Max => "max_radius",
        }
    }
}

/// The radius tool radius compensation offsets the contour by (mm; the tool's radius and
/// the call's delta DR, or a bound for any tool), and where it comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ToolRadius {
    pub radius: f64,
    pub source: RadiusSource,
}

/// What the lathe's spindle does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spindle {
    /// Stopped where the program has not positioned it (at the start, after M5).
    Free,
    /// Turning, since M3 or M4 at this line.
    Turning(usize),
    /// Positioned (M19 or a C word): an axis like any other.
    Positioned,
}

/// The motion mode in force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// G0, G1.
    Line,
    /// G2, G3.
    Arc,
    /// A drilling cycle.
    Cycle,
}

/// A tilted working plane (G68.2): a frame in the part frame (the workpiece coordinate
/// system), in which the X, Y, Z words are given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WorkingPlane {
    /// The frame's origin in the part frame (mm).
    pub origin: nalgebra::Vector3<f64>,
    /// The frame's axes in the part frame: `R · (x, y, z)` is a plane point's offset from
    /// the origin, `R · e_z` the plane's normal (the tool direction after G53.1).
    pub rotation: nalgebra::Rotation3<f64>,
    /// Whether G53.1 has turned the tool to the plane since it was set.
    pub tilted: bool,
    /// G68: a rotation of the program's X, Y about Z in G17, the tool not tilted.
    pub rotation_only: bool,
    /// Heidenhain's SEQ+ / SEQ-: the solution with the master rotary axis at a positive
    /// (or zero) angle, or a negative one; `None`: the machine file's rule.
    pub sequence: Option<bool>,
    /// Heidenhain's TABLE ROT: where a table axis is free to turn (its axis along the
    /// tool), it turns so that the plane's X axis lies along the machine's X; otherwise it
    /// stays (COORD ROT).
    pub table_rot: bool,
}

impl WorkingPlane {
    /// The plane of `G68.2 X Y Z I J K`: origin (mm) and Euler angles in degrees, about Z,
    /// then the new X, then the new Z.
    pub fn new(origin: [f64; 3], euler: [f64; 3]) -> WorkingPlane {
        use nalgebra::{Rotation3, Vector3};
        let [i, j, k] = euler.map(f64::to_radians);
        WorkingPlane {
            origin: Vector3::from(origin),
            rotation: Rotation3::from_axis_angle(&Vector3::z_axis(), i)
                * Rotation3::from_axis_angle(&Vector3::x_axis(), j)
                * Rotation3::from_axis_angle(&Vector3::z_axis(), k),
            tilted: false,
            rotation_only: false,
            sequence: None,
            table_rot: false,
        }
    }

    /// The plane of Heidenhain's `PLANE SPATIAL SPA SPB SPC` about the datum `origin`
    /// (mm): rotations about the fixed X, then Y, then Z axis, in degrees.
    pub fn spatial(origin: [f64; 3], angles: [f64; 3]) -> WorkingPlane {
        use nalgebra::{Rotation3, Vector3};
        let [a, b, c] = angles.map(f64::to_radians);
        WorkingPlane {
            origin: Vector3::from(origin),
            rotation: Rotation3::from_axis_angle(&Vector3::z_axis(), c)
                * Rotation3::from_axis_angle(&Vector3::y_axis(), b)
                * Rotation3::from_axis_angle(&Vector3::x_axis(), a),
            tilted: false,
            rotation_only: false,
            sequence: None,
            table_rot: false,
        }
    }

    /// The plane of Heidenhain's `PLANE VECTOR`: its X axis along `base` (made
    /// perpendicular to the normal), its Z axis along `normal`, about the datum `origin`;
    /// `None` when the vectors do not span a plane.
    pub fn vectors(origin: [f64; 3], base: [f64; 3], normal: [f64; 3]) -> Option<WorkingPlane> {
        use nalgebra::{Matrix3, Rotation3, Vector3};
        let z = Vector3::from(normal).try_normalize(1e-9)?;
        let b = Vector3::from(base);
        let x = (b - z * b.dot(&z)).try_normalize(1e-9)?;
        let y = z.cross(&x);
        Some(WorkingPlane {
            origin: Vector3::from(origin),
            rotation: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z])),
            tilted: false,
            rotation_only: false,
            sequence: None,
            table_rot: false,
        })
    }

    /// This plane turned by `degrees` about its own X (`axis` 0), Y (1) or Z (2) axis:
    /// Heidenhain's `PLANE RELATIV`.
    pub fn turned(&self, axis: usize, degrees: f64) -> WorkingPlane {
        use nalgebra::{Rotation3, Vector3};
        let about = [Vector3::x_axis(), Vector3::y_axis(), Vector3::z_axis()][axis.min(2)];
        WorkingPlane {
            rotation: self.rotation * Rotation3::from_axis_angle(&about, degrees.to_radians()),
            tilted: false,
            ..*self
        }
    }

    /// The rotation of `G17 G68 X Y R`: the program's X, Y turned by `degrees` about the
    /// centre (mm), counter-clockwise seen from +Z; Z as programmed.
    pub fn rotation(centre: [f64; 2], degrees: f64) -> WorkingPlane {
        use nalgebra::{Rotation3, Vector3};
        let rotation = Rotation3::from_axis_angle(&Vector3::z_axis(), degrees.to_radians());
        let c = Vector3::new(centre[0], centre[1], 0.0);
        WorkingPlane {
            // A word w is the part point c + R (w - c).
            origin: c - rotation * c,
            rotation,
            tilted: false,
            rotation_only: true,
            sequence: None,
            table_rot: false,
        }
    }

    /// Its name for messages.
    pub fn name(&self) -> &'static str {
        if self.rotation_only {
            "a coordinate rotation (G68)"
        } else if self.sequence.is_some() || self.table_rot {
            "a tilted working plane (PLANE)"
        } else {
            "a tilted working plane (G68.2)"
        }
    }

    /// The part-frame point of plane coordinates `w` (mm).
    pub fn part(&self, w: &nalgebra::Vector3<f64>) -> nalgebra::Vector3<f64> {
        self.origin + self.rotation * w
    }

    /// The plane coordinates (mm) of part-frame point `p`.
    pub fn words(&self, p: &nalgebra::Vector3<f64>) -> nalgebra::Vector3<f64> {
        self.rotation.inverse() * (p - self.origin)
    }

    /// The plane's normal in the part frame: the tool direction G53.1 turns the tool to.
    pub fn normal(&self) -> nalgebra::Vector3<f64> {
        self.rotation * nalgebra::Vector3::z()
    }
}

/// The program's modal state, as the controller keeps it between blocks.
#[derive(Debug, Clone, PartialEq)]
pub struct Modal {
    /// G20: words are in inch.
    pub inch: bool,
    /// The program has said G20 or G21 (until then `inch` is the machine file's `units`).
    pub units_stated: bool,
    /// G7: X words are diameters (on a lathe).
    pub diameter: bool,
    /// G91: axis words are increments.
    pub incremental: bool,
    pub motion: Option<Motion>,
    /// The motion mode is G0 (rapid), not G1.
    pub rapid: bool,
    /// G93: F words are inverse times.
    pub inverse_time: bool,
    /// Arc plane: 0 G17 (X, Y), 1 G18 (Z, X), 2 G19 (Y, Z), 3 a U/V/W plane.
    pub plane: u8,
    /// G90.1: arc centres are absolute.
    pub arc_absolute: bool,
    /// The last arc code was G2 (clockwise).
    pub clockwise: bool,
    /// Tool-centre-point control is on: X, Y, Z words are the tool tip in the workpiece
    /// frame ...
    pub tcp: bool,
    /// ... and the tool direction is programmed as a vector (I, J, K; G43.5), not by rotary
    /// words.
    pub tcp_vector: bool,
    /// G98: cycles retract to the initial level.
    pub retract_to_initial: bool,
    /// The active tool length (mm); NaN where a length was switched on for a tool the
    /// program has not selected (Sinumerik `D1` before any T): a move compensated with
    /// it is refused.
    pub length: f64,
    /// The last T number.
    pub tool: Option<u32>,
    /// The work offset in force (G54 … by its number times ten, G54.1 Pn as 100 000 + n;
    /// see [`crate::model::WorkOffsets::code`]).
    pub work_offset: Option<i64>,
    /// Work offset values the program set (G10 L2 / L20), by offset code (0: the external
    /// offset, G10 L2 P0), X Y Z in mm, in machine coordinates.
    pub offsets: Vec<(i64, [f64; 3])>,
    /// G52's local shift (X Y Z, mm).
    pub local_shift: [f64; 3],
    /// The parameters the program has assigned (`#100 = 12.5`).
    pub params: params::Params,
    /// Where program zero lies from the zero the machine file's geometry is given in
    /// (X Y Z, mm): the work offset in force, the external offset and G52's shift, less
    /// the geometry's offset. `None`: the value of the offset in force is not known.
    pub shift: Option<[f64; 3]>,
    /// The line of the M99 that ended the program.
    pub ended: Option<usize>,
    /// The line of the M2 or M30 (not optional) that ended an ISO or Sinumerik program, or
    /// of a TNC program's END PGM: the blocks after it do not run with the program (a
    /// subprogram stored there runs only when called), and pass unchanged.
    pub program_end: Option<usize>,
    /// The lines with blocks after `program_end`.
    pub after_end: usize,
    /// A tilted working plane in force (G68.2 … G69).
    pub working_plane: Option<WorkingPlane>,
    /// The active tool chain (index into [`Machine::tool_chains`]).
    pub chain: usize,
    /// What a lathe's spindle does.
    pub spindle: Spindle,
    /// The language the program is written in.
    pub dialect: crate::nc::Dialect,
    /// What the Heidenhain front end keeps between blocks.
    pub tnc: Option<Box<heidenhain::Tnc>>,
    /// What the Sinumerik front end keeps between blocks.
    pub siemens: Option<Box<sinumerik::Siemens>>,
    /// Tool radius compensation in force (TNC RL/RR): the contour's side the tool runs on.
    pub radius_comp: Option<RadiusSide>,
    /// The called tool's radius for it, where the machine file gives one.
    pub tool_radius: Option<ToolRadius>,
}

/// Cut a line into tokens in the program's dialect, with the parameters the program has set
/// to constants put in (see [`params::substitute`], [`heidenhain::substitute`]).
pub fn tokenize(modal: &Modal, content: &[u8], tokens: &mut Vec<crate::nc::Token>) {
    match modal.dialect {
        crate::nc::Dialect::Iso => {
            crate::nc::parse_line(content, tokens);
            params::substitute(content, tokens, &modal.params);
        }
        crate::nc::Dialect::Heidenhain => {
            crate::nc::heidenhain::parse_line(content, tokens);
            if let Some(tnc) = &modal.tnc {
                heidenhain::substitute(content, tokens, tnc);
            }
        }
        crate::nc::Dialect::Sinumerik => {
            crate::nc::sinumerik::parse_line(content, tokens);
            if let Some(s) = &modal.siemens {
                sinumerik::substitute(content, tokens, s);
            }
        }
    }
}

impl Modal {
    /// The state at the start of program `src` written in `dialect`.
    pub fn for_program(&mut self, dialect: crate::nc::Dialect, src: &[u8]) {
        let labels = (dialect == crate::nc::Dialect::Heidenhain)
            .then(|| std::sync::Arc::new(heidenhain::Labels::scan(src)));
        self.for_program_with(dialect, labels.unwrap_or_default());
    }

    /// [`Modal::for_program`] with a TNC program's labels already scanned
    /// ([`heidenhain::LabelScan`]), for a program that is streamed.
    pub fn for_program_with(
        &mut self,
        dialect: crate::nc::Dialect,
        labels: std::sync::Arc<heidenhain::Labels>,
    ) {
        self.dialect = dialect;
        self.tnc = (dialect == crate::nc::Dialect::Heidenhain).then(|| {
            Box::new(heidenhain::Tnc {
                labels,
                ..heidenhain::Tnc::default()
            })
        });
        self.siemens = (dialect == crate::nc::Dialect::Sinumerik).then(Box::default);
    }

    /// The drilling cycle a cycle block calls: a TNC program's last CYCL DEF, a Sinumerik
    /// program's MCALL.
    pub fn called_cycle(&self) -> Option<&heidenhain::CycleDef> {
        match (&self.tnc, &self.siemens) {
            (Some(t), _) => t.cycle.as_ref(),
            (_, Some(s)) => s.mcall.as_ref(),
            _ => None,
        }
    }

    /// [`Modal::called_cycle`], to change.
    pub fn called_cycle_mut(&mut self) -> Option<&mut heidenhain::CycleDef> {
        match (&mut self.tnc, &mut self.siemens) {
            (Some(t), _) => t.cycle.as_mut(),
            (_, Some(s)) => s.mcall.as_mut(),
            _ => None,
        }
    }

    /// The state at the program start, in tool chain `chain`.
    pub fn start(machine: &Machine, chain: usize) -> Modal {
        let mut modal = Modal::fresh(machine, chain);
        modal.shift = modal.shift_from(machine);
        modal
    }

    /// Program zero from the machine file's geometry zero, for the offsets in force (see
    /// [`Modal::shift`]); always zero without a `[work_offsets]` table (the geometry is
    /// then in the one program zero a program uses).
    pub fn shift_from(&self, machine: &Machine) -> Option<[f64; 3]> {
        let Some(table) = &machine.work_offsets else {
            return Some([0.0; 3]);
        };
        let value = |code: i64| {
            self.offsets
                .iter()
                .rev()
                .find(|(c, _)| *c == code)
                .map(|(_, v)| *v)
                .or_else(|| table.values.get(&code).copied())
        };
        // At power-on a Fanuc control is in G54.
        let active = value(self.work_offset.unwrap_or(540))?;
        let external = value(0).unwrap_or([0.0; 3]);
        let geometry = table.geometry_zero;
        Some(std::array::from_fn(|c| {
            active[c] + external[c] + self.local_shift[c] - geometry[c]
        }))
    }

    fn fresh(machine: &Machine, chain: usize) -> Modal {
        Modal {
            inch: machine.inch_default,
            units_stated: false,
            diameter: machine.lathe.is_some_and(|l| l.diameter),
            incremental: false,
            motion: None,
            rapid: false,
            inverse_time: false,
            plane: 0,
            arc_absolute: false,
            clockwise: true,
            tcp: false,
            tcp_vector: false,
            retract_to_initial: true,
            length: machine.tool.length,
            tool: None,
            work_offset: None,
            offsets: Vec::new(),
            local_shift: [0.0; 3],
            params: params::Params::default(),
            shift: Some([0.0; 3]),
            ended: None,
            program_end: None,
            after_end: 0,
            working_plane: None,
            chain,
            spindle: Spindle::Free,
            dialect: crate::nc::Dialect::Iso,
            tnc: None,
            siemens: None,
            radius_comp: None,
            tool_radius: machine.tool.max_radius.map(|radius| ToolRadius {
                radius,
                source: RadiusSource::Max,
            }),
        }
    }

    /// On a lathe: blocks are turning blocks (the spindle turns, or stands where the
    /// program has not positioned it).
    pub fn turning(&self, machine: &Machine) -> bool {
        machine.lathe.is_some() && self.spindle != Spindle::Positioned
    }
}

/// Reads a program's blocks one after the other for one machine, following the modal
/// state it is given.
#[derive(Debug, Clone)]
pub struct Reader<'m> {
    machine: &'m Machine,
    /// The variables of each tool chain.
    chains: Vec<axes::Axes>,
    /// Some tool chain lists the tools that select it.
    tools_listed: bool,
}

impl<'m> Reader<'m> {
    pub fn new(machine: &'m Machine) -> Self {
        let chains = (0..machine.tool_chains.len())
            .map(|c| axes::Axes::of(machine, c))
            .collect();
        Reader {
            machine,
            chains,
            tools_listed: machine.tool_chains.iter().any(|c| !c.tools.is_empty()),
        }
    }

    pub fn machine(&self) -> &'m Machine {
        self.machine
    }

    /// The variables of tool chain `chain`.
    pub fn axes(&self, chain: usize) -> &axes::Axes {
        &self.chains[chain]
    }

    /// The meaning of a G or M code on this machine.
    pub fn code(&self, letter: u8, code10: i64) -> Code {
        codes::meaning(CodeName { letter, code10 }, &self.machine.codes)
    }
}

//! What each G and M code means: the one table of codes in nccomp.
//!
//! Every command that reads programs asks this table; none matches code numbers itself.
//! A code is *known* when its effect on motion and on the controller's transformation is
//! documented here; [`Code::Unknown`] is everything else, and the compensation pass
//! refuses it (design/model.md, "Dialects and what is never guessed"). A machine file may
//! name further codes as harmless or as switching tool-centre-point control on or off
//! ([`MachineCodes`]); the codes of this table cannot be renamed.

/// A G or M code as its letter and its number times ten (`G43.4` is `(b'G', 434)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct CodeName {
    pub letter: u8,
    pub code10: i64,
}

impl CodeName {
    /// `G43.4`, `M428`: the letter, then the number with its tenth when there is one.
    pub fn parse(text: &str) -> Option<CodeName> {
        let mut chars = text.trim().chars();
        let letter = chars.next()?.to_ascii_uppercase();
        if letter != 'G' && letter != 'M' {
            return None;
        }
        let number = chars.as_str();
        let (whole, tenth) = match number.split_once('.') {
            Some((w, t)) if t.len() == 1 => (w, t),
            Some(_) => return None,
            None => (number, "0"),
        };
        if whole.is_empty() || !whole.bytes().all(|b| b.is_ascii_digit()) || whole.len() > 6 {
            return None;
        }
        let tenth: i64 = tenth
            .parse()
            .ok()
            .filter(|_| tenth.bytes().all(|b| b.is_ascii_digit()))?;
        Some(CodeName {
            letter: letter as u8,
            code10: whole.parse::<i64>().ok()? * 10 + tenth,
        })
    }
}

impl std::fmt::Display for CodeName {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (whole, tenth) = (self.code10 / 10, self.code10 % 10);
        if tenth == 0 {
            write!(f, "{}{whole}", self.letter as char)
        } else {
            write!(f, "{}{whole}.{tenth}", self.letter as char)
        }
    }
}

/// Tool-centre-point control: how the block gives the tool direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tcp {
    /// By the rotary axes' words (G43.4, LinuxCNC's TCP kinematics switched by an M code).
    Rotary,
    /// By a tool vector I, J, K (G43.5).
    Vector,
}

/// A drilling or boring cycle, or another canned cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cycle {
    /// G73, G81 … G86, G88, G89: position over the hole, feed to Z, retract.
    Drill,
    /// A cycle whose moves the compensation pass does not model.
    Other(&'static str),
}

/// The spindle codes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Spindle {
    /// M3, M4.
    Turn,
    /// M5.
    Stop,
    /// M19: oriented, standing at an angle of the machine's own.
    Orient,
}

/// What a code does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Code {
    /// G0 (`rapid`) and G1: straight moves, modal.
    Line { rapid: bool },
    /// G2 (`clockwise`), G3.
    Arc { clockwise: bool },
    /// A canned cycle, modal until G80.
    Cycle(Cycle),
    /// G80.
    CancelCycle,
    /// G98 (`initial`: retract to the initial level) and G99 (to the R plane).
    CycleReturn { initial: bool },
    /// G38.2 … G38.5: probing, modal.
    Probe,
    /// G31, G31.1 … G31.4: a one-shot probing (skip) move.
    Skip,
    /// G4: its X or P word is a time.
    Dwell,
    /// G20 (`inch`), G21.
    Units { inch: bool },
    /// G90, G91 (`incremental`).
    Distance { incremental: bool },
    /// G90.1 (`absolute`), G91.1: how arc centres are given.
    ArcCentres { absolute: bool },
    /// G17 (0), G18 (1), G19 (2), G17.1/G18.1/G19.1 (3: a U/V/W plane).
    Plane(u8),
    /// G93 inverse time (`inverse_time`), G94 per minute (neither), G95 per revolution.
    Feed {
        inverse_time: bool,
        per_revolution: bool,
    },
    /// G43: tool length from an H word.
    ToolLength,
    /// G49: back to the reference tool length, tool-centre-point control off.
    ToolLengthOff,
    /// G43.4, G43.5, or a code the machine file names as switching TCP on.
    TcpOn(Tcp),
    /// A code the machine file names as switching TCP off.
    TcpOff,
    /// G54 … G59, G59.1 … G59.3, by their number times ten.
    WorkOffset(i64),
    /// G54.1 Pn.
    ExtendedWorkOffset,
    /// G53: this block's axis words are machine coordinates.
    MachineCoordinates,
    /// G28, G30: return to a reference point through the block's axis words.
    ReturnHome,
    /// A code the machine file names as sending axes to machine positions (Centroid's M25,
    /// Z home; a pallet change): the axes of the mask (bit `letter - 'A'`) end at a place
    /// nccomp does not know, as after G28.
    MachineMove(u32),
    /// G28.1, G30.1: store the reference point; moves nothing.
    SetReference,
    /// G10, G52, G92 …: the axis words are data that set offsets, and the positions of the
    /// axes named (all of them if none is) change meaning.
    DataSetting(&'static str),
    /// G7 (`diameter`), G8: a lathe's X words are diameters or radii.
    Diameter { diameter: bool },
    /// G65: a macro call.
    MacroCall,
    /// G66: a modal macro call (the macro runs after every later move).
    ModalMacro,
    /// G68, G51, G16 … switch on a transformation of the program's coordinates.
    TransformOn(&'static str),
    /// G50, G15 … switch it off.
    TransformOff,
    /// G68.2 X Y Z I J K: a tilted working plane, its origin and Euler angles (Z-X-Z).
    TiltedPlane,
    /// G53.1: the rotary axes turn the tool perpendicular to the tilted working plane.
    ToolToPlane,
    /// G68 X Y R: the program's coordinates turned about a centre in the active plane.
    Rotation,
    /// G69: the working plane (and a G68 rotation) off.
    PlaneOff,
    /// Haas's smoothing, G187 P1…P3 with its tolerance in an E word: it rounds corners
    /// within the tolerance, as a controller's look-ahead does, and moves no block end.
    Smoothing,
    /// M3, M4, M5, M19.
    Spindle(Spindle),
    /// M2, M30: the program ends.
    ProgramEnd,
    /// M97, M98: subprogram calls.
    Subprogram,
    /// M99: the return from a subprogram; at the end of a main program, its end (a
    /// Fanuc-family control rewinds it).
    Return,
    /// Known, moves nothing the pass must follow: planes' companions, feed and spindle
    /// modes, stops, coolant, tool change, overrides, outputs; and codes a machine file
    /// names as harmless.
    Harmless,
    /// Known, and changes motion in a way the pass does not model (its name for messages).
    Unsupported(&'static str),
    /// Not on the list.
    Unknown,
}

/// Codes a machine file adds to the table (`[codes]`).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct MachineCodes {
    /// Codes that move nothing and change no transformation.
    pub harmless: Vec<CodeName>,
    /// Codes that switch tool-centre-point control on (X Y Z the tip, rotary words the
    /// rotary axes), such as LinuxCNC's M428 in its five-axis configurations.
    pub tcp_on: Vec<CodeName>,
    /// Codes that switch it off (M429).
    pub tcp_off: Vec<CodeName>,
    /// Codes that send axes to machine positions, with the axes' letters (bit
    /// `letter - 'A'`).
    pub machine_moves: Vec<(CodeName, u32)>,
}

impl MachineCodes {
    /// The meaning the machine file gives `name`, if it names it.
    pub fn meaning(&self, name: CodeName) -> Option<Code> {
        if self.harmless.contains(&name) {
            Some(Code::Harmless)
        } else if self.tcp_on.contains(&name) {
            Some(Code::TcpOn(Tcp::Rotary))
        } else if self.tcp_off.contains(&name) {
            Some(Code::TcpOff)
        } else {
            self.machine_moves
                .iter()
                .find(|(n, _)| *n == name)
                .map(|&(_, axes)| Code::MachineMove(axes))
        }
    }

    pub fn is_empty(&self) -> bool {
        self.harmless.is_empty()
            && self.tcp_on.is_empty()
            && self.tcp_off.is_empty()
            && self.machine_moves.is_empty()
    }
}

/// The meaning of G code `code10` (its number times ten).
pub fn g_code(code10: i64) -> Code {
    use Code::*;
    match code10 {
        0 => Line { rapid: true },
        10 => Line { rapid: false },
        20 => Arc { clockwise: true },
        30 => Arc { clockwise: false },
        40 => Dwell,
        50..=53 => Unsupported("spline interpolation (G5.x)"),
        70 => Diameter { diameter: true },
        80 => Diameter { diameter: false },
        100 => DataSetting("data setting (G10)"),
        150 => TransformOff,
        160 => TransformOn("polar coordinate programming (G16)"),
        170 => Plane(0),
        180 => Plane(1),
        190 => Plane(2),
        171 | 181 | 191 => Plane(3),
        200 => Units { inch: true },
        210 => Units { inch: false },
        280 | 300 => ReturnHome,
        281 | 301 => SetReference,
        310..=314 => Skip,
        330 | 331 => Unsupported("threading (G33)"),
        382..=385 => Probe,
        380..=389 => Unsupported("probing (G38.x)"),
        // Cutter compensation off.
        400 => Harmless,
        410 | 411 | 420 | 421 => Unsupported("cutter radius compensation (G41/G42)"),
        430 => ToolLength,
        431 | 432 => Unsupported("a dynamic tool length offset (G43.1/G43.2)"),
        434 => TcpOn(Tcp::Rotary),
        435 => TcpOn(Tcp::Vector),
        // G47 is Haas's engraving and FANUC's tool position offset; neither is followed.
        470 => Unsupported(
            "text engraving on a Haas, whose strokes come from the control's font program O9876, not from this program (a shop may replace it: what it cuts is decided on the control; engrave with G1 moves), or a tool position offset on a FANUC control,",
        ),
        450 | 460 | 480 => Unsupported("a tool position offset (G45–G48)"),
        490 => ToolLengthOff,
        500 | 501 => TransformOff,
        510 | 511 => TransformOn("scaling or mirroring (G51)"),
        520 => DataSetting("a local coordinate offset (G52)"),
        530 => MachineCoordinates,
        531 => ToolToPlane,
        541 => ExtendedWorkOffset,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => WorkOffset(code10),
        // Exact stop, exact-stop mode, path blending.
        610 | 611 | 640 => Harmless,
        650 => MacroCall,
        660 | 661 => ModalMacro,
        682 => TiltedPlane,
        683 => TransformOn("a tilted working plane along the tool (G68.3)"),
        684 => TransformOn("an incremental tilted working plane (G68.4)"),
        680 => Rotation,
        681..=689 => TransformOn("a coordinate conversion (G68.1)"),
        690 => PlaneOff,
        730 | 810..=860 | 880 | 890 => Cycle(self::Cycle::Drill),
        740 => Cycle(self::Cycle::Other("a tapping cycle (G74)")),
        760 => Cycle(self::Cycle::Other("a threading or fine boring cycle (G76)")),
        870 => Cycle(self::Cycle::Other("a back boring cycle (G87)")),
        811..=899 => Cycle(self::Cycle::Other("a canned cycle")),
        800 => CancelCycle,
        900 => Distance { incremental: false },
        910 => Distance { incremental: true },
        901 => ArcCentres { absolute: true },
        911 => ArcCentres { absolute: false },
        920..=923 => DataSetting("a coordinate system offset (G92)"),
        930 => Feed {
            inverse_time: true,
            per_revolution: false,
        },
        940 => Feed {
            inverse_time: false,
            per_revolution: false,
        },
        950 => Feed {
            inverse_time: false,
            per_revolution: true,
        },
        // Constant surface speed on and off.
        960 | 970 => Harmless,
        1870 => Smoothing,
        980 => CycleReturn { initial: true },
        990 => CycleReturn { initial: false },
        _ => Unknown,
    }
}

/// The meaning of M code `code10` (its number times ten) on a machine with `extra` codes.
pub fn m_code(code10: i64, extra: &MachineCodes) -> Code {
    use Code::*;
    match code10 {
        30 | 40 => Spindle(self::Spindle::Turn),
        50 => Spindle(self::Spindle::Stop),
        190 => Spindle(self::Spindle::Orient),
        20 | 300 => ProgramEnd,
        970 | 980 => Subprogram,
        990 => Return,
        // Program stop and optional stop, tool change (the length comes with G43), coolant,
        // override switches (M48–M53), digital and analog outputs and waiting on an input
        // (M62–M68): none moves an axis.
        0 | 10 | 60 | 70 | 80 | 90 | 480 | 490 | 500 | 510 | 520 | 530 | 620..=680 => Harmless,
        // What these mean on LinuxCNC; on Fanuc-family controls the machine builder gives
        // them meanings of their own, which a machine file may name.
        _ => {
            let own = extra.meaning(CodeName {
                letter: b'M',
                code10,
            });
            match code10 {
                _ if own.is_some() => own.unwrap_or(Unknown),
                600 => Unsupported("a pallet change (M60)"),
                610 => Unsupported("setting the tool number without a tool change (M61)"),
                700..=730 => Unsupported("saving or restoring the modal state (M70–M73)"),
                _ => Unknown,
            }
        }
    }
}

/// The meaning of a G or M code on a machine with `extra` codes: the table's own meaning
/// first (a machine file cannot rename those), then the machine file's.
pub fn meaning(name: CodeName, extra: &MachineCodes) -> Code {
    match name.letter {
        b'G' => match g_code(name.code10) {
            Code::Unknown => extra.meaning(name).unwrap_or(Code::Unknown),
            known => known,
        },
        _ => m_code(name.code10, extra),
    }
}

/// Whether the table itself follows `name` (a machine file may not give it another meaning;
/// the M codes it only refuses, such as LinuxCNC's M70–M73, a machine may).
pub fn is_known(name: CodeName) -> bool {
    !matches!(
        meaning(name, &MachineCodes::default()),
        Code::Unknown | Code::Unsupported(_)
    ) || name.letter == b'G' && meaning(name, &MachineCodes::default()) != Code::Unknown
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn code_names_read_and_print_back() {
        for text in ["G43.4", "M428", "G0", "M30", "g54.1"] {
            let name = CodeName::parse(text).unwrap();
            assert_eq!(name.to_string(), text.to_ascii_uppercase());
        }
        for bad in ["X1", "G", "G4.25", "M-1", "G1.x", "M 3", ""] {
            assert_eq!(CodeName::parse(bad), None, "{bad}");
        }
        assert_eq!(CodeName::parse("M03").unwrap().code10, 30);
    }

    #[test]
    fn m_codes_are_a_whitelist() {
        let none = MachineCodes::default();
        for code in [1280, 9990, 4280, 690, 740, 1000] {
            assert_eq!(m_code(code, &none), Code::Unknown, "M{}", code / 10);
        }
        for code in [0, 10, 20, 60, 80, 90, 300] {
            assert_ne!(m_code(code, &none), Code::Unknown, "M{}", code / 10);
        }
        let linuxcnc = MachineCodes {
            harmless: vec![CodeName::parse("M100").unwrap()],
            tcp_on: vec![CodeName::parse("M428").unwrap()],
            tcp_off: vec![CodeName::parse("M429").unwrap()],
            machine_moves: vec![(CodeName::parse("M25").unwrap(), 1 << (b'Z' - b'A'))],
        };
        assert_eq!(
            m_code(250, &linuxcnc),
            Code::MachineMove(1 << (b'Z' - b'A'))
        );
        assert_eq!(m_code(4280, &linuxcnc), Code::TcpOn(Tcp::Rotary));
        assert_eq!(m_code(4290, &linuxcnc), Code::TcpOff);
        assert_eq!(m_code(1000, &linuxcnc), Code::Harmless);
        assert!(is_known(CodeName::parse("M3").unwrap()));
        assert!(!is_known(CodeName::parse("M428").unwrap()));
        // LinuxCNC's M72 restores the modal state; on a Robodrill it is the builder's.
        assert!(matches!(m_code(720, &none), Code::Unsupported(_)));
        assert!(!is_known(CodeName::parse("M72").unwrap()));
        assert!(is_known(CodeName::parse("G41").unwrap()));
        let robodrill = MachineCodes {
            harmless: vec![CodeName::parse("M72").unwrap()],
            ..MachineCodes::default()
        };
        assert_eq!(m_code(720, &robodrill), Code::Harmless);
    }
}

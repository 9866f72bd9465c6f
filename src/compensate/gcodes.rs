//! What the pass makes of each G and M code.
//!
//! The list is a whitelist: a code not named here is refused (when there are errors to
//! compensate), because a code we do not understand may move the machine in a way the
//! pass would get wrong.

/// What a G code means to the compensation pass.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GCode {
    /// Straight move in joint space (G0, G1): block end points are compensated.
    Motion,
    /// Circular move (G2, G3).
    Arc,
    /// Dwell (G4): its X or P word is a time, not a position.
    Dwell,
    Inch,
    Millimetre,
    /// G90: axis words are positions.
    Absolute,
    /// G91: axis words are increments from the previous programmed position.
    Incremental,
    /// G43.4: tool-centre-point control with rotary words; takes an H word like G43.
    ToolCentrePoint,
    /// G43.5: tool-centre-point control with the tool direction as a vector (I, J, K).
    ToolCentrePointVector,
    /// G53: a move in machine coordinates, this block only. Left untouched; the axes it
    /// names end where nccomp does not know their program coordinates.
    MachineCoordinates,
    /// G28, G30: return to a reference point, through the intermediate point the block's
    /// axis words give. Left untouched; the axes that go home end at an unknown position.
    ReturnHome,
    /// G28.1, G30.1: store the current position as the reference point; moves nothing.
    SetReference,
    /// G43 with an H word: active tool length from the machine file's tool table.
    ToolLength,
    /// G49: back to the reference tool length.
    ToolLengthOff,
    /// G54 … G59.3: the work offset the machine file's program zero belongs to.
    WorkOffset,
    /// G80: cancels a canned cycle, moves nothing.
    CancelCycle,
    /// G73, G81 … G86, G88, G89: drilling and boring cycles (modal).
    DrillCycle,
    /// G98 (retract to the initial level) and G99 (to the R plane).
    CycleReturn,
    /// G7: a lathe's X words are diameters.
    Diameter,
    /// G8: a lathe's X words are radii.
    Radius,
    /// Modal settings that do not change where block ends are (planes, feed modes, path
    /// control, cancels of things we refuse).
    Harmless,
    /// Refused, with the construct's name.
    Unsupported(&'static str),
}

/// Classify a G code given as its number times ten (G43.4 → 434).
pub fn classify(code10: i64) -> GCode {
    use GCode::*;
    match code10 {
        0 | 10 => Motion,
        20 | 30 => Arc,
        40 => Dwell,
        200 => Inch,
        210 => Millimetre,
        900 => Absolute,
        910 => Incremental,
        530 => MachineCoordinates,
        280 | 300 => ReturnHome,
        281 | 301 => SetReference,
        430 => ToolLength,
        490 => ToolLengthOff,
        540 | 550 | 560 | 570 | 580 | 590 | 591 | 592 | 593 => WorkOffset,
        800 => CancelCycle,
        730 | 810..=860 | 880 | 890 => DrillCycle,
        980 | 990 => CycleReturn,
        70 => Diameter,
        80 => Radius,
        // Planes, cutter compensation off, exact stop / blending, polar and scaling and
        // rotation off, arc centre modes, feed modes, spindle modes.
        170 | 171 | 180 | 181 | 190 | 191 | 400 | 610 | 611 | 640 | 150 | 500 | 690 | 901 | 911
        | 930 | 940 | 950 | 960 | 970 => Harmless,
        50..=53 => Unsupported("spline interpolation (G5.x)"),
        100 => Unsupported("data setting (G10)"),
        330 | 331 => Unsupported("threading (G33)"),
        380..=389 => Unsupported("probing (G38.x)"),
        410 | 411 | 420 | 421 => Unsupported("cutter radius compensation (G41/G42)"),
        431 | 432 => Unsupported("a dynamic tool length offset (G43.1/G43.2)"),
        434 => ToolCentrePoint,
        435 => ToolCentrePointVector,
        520 => Unsupported("a local coordinate offset (G52)"),
        541 => Unsupported("an extended work offset (G54.1)"),
        680..=689 => Unsupported("coordinate rotation (G68)"),
        160 => Unsupported("polar coordinate programming (G16)"),
        510 | 511 => Unsupported("scaling or mirroring (G51)"),
        740 => Unsupported("a tapping cycle (G74)"),
        760 => Unsupported("a threading or fine boring cycle (G76)"),
        870 => Unsupported("a back boring cycle (G87)"),
        811..=899 => Unsupported("a canned cycle"),
        920..=923 => Unsupported("a coordinate system offset (G92)"),
        _ => Unsupported("this G code"),
    }
}

/// M codes the pass refuses: program flow it cannot follow.
pub fn unsupported_m(code10: i64) -> Option<&'static str> {
    match code10 {
        970 | 980 | 990 => Some("a subprogram call or return (M97/M98/M99)"),
        _ => None,
    }
}

//! Machine files: the axes of a machine, its chains and its tool table (design/model.md,
//! "Files").
//!
//! ```toml
//! name = "AC trunnion"
//! workpiece_chain = ["Y", "X", "A", "C"]     # from the bed outward
//! tool_chain = ["Z"]                         # or [tool_chains] upper = [...], lower = [...]
//! resolution = { linear = 0.0001, rotary = 0.0001 }
//!
//! [axes.X]
//! kind = "linear"
//! direction = [-1, 0, 0]
//! travel = [-442.5, 442.5]
//!
//! [axes.A]
//! kind = "rotary"
//! direction = [-1, 0, 0]
//! point = [0, 0, -100]
//!
//! [tool]
//! length = 0.0
//! lengths = { 1 = 95.3 }
//! ```
//!
//! Beyond the contract, an axis may say which program word drives it (`word = "X"`).
//! An axis named by one letter is driven by that letter; any other name
//! (`[A-Z][A-Z0-9]*`, e.g. `X2`) must give its `word`.
//!
//! Every problem is reported at its place in the file (`path:line:col: message`).

use super::limits::{self, shown};
use super::terms::{is_axis_name, or_list, suggest};
use super::{Axis, AxisKind, Chain, Lathe, Machine, PlaneSolution, Resolution, Tool, WorkOffsets};
use crate::program::{self, CodeName, MachineCodes};
use crate::{Error, Result};
use nalgebra::Vector3;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// The program words that can drive an axis.
const AXIS_WORDS: &str = "XYZABCUVW";

/// Read and check a machine file.
pub fn load(path: &Path) -> Result<Machine> {
    let text = super::read_text(path, "machine file")?;
    parse(&text, &path.display().to_string())
}

/// Check the machine file `text`; `path` names it in messages.
pub fn parse(text: &str, path: &str) -> Result<Machine> {
    let doc = Doc { path, text };
    let root = doc.parse()?;
    let root = root.get_ref();
    doc.check_keys(
        root,
        &[
            "name",
            "workpiece_chain",
            "tool_chain",
            "tool_chains",
            "resolution",
            "axes",
            "tool",
            "lathe",
            "codes",
            "working_plane",
            "work_offsets",
            "units",
            "cycles",
            "block_delete",
            "start",
            "errors",
        ],
        "the machine file",
    )?;

    let name = root
        .get("name")
        .map(|v| doc.string(v, "`name`").map(str::to_string))
        .transpose()?;
    let inch_default = match root.get("units") {
        Some(v) => match doc.string(v, "`units`")? {
            "mm" => false,
            "inch" => true,
            other => {
                return Err(doc.err(
                    v.span(),
                    format!("`{other}` in `units`: expected \"mm\" or \"inch\" (the units the control reads a program in until G20 or G21)"),
                ));
            }
        },
        None => false,
    };
    let block_delete = match root.get("block_delete") {
        Some(v) => match doc.string(v, "`block_delete`")? {
            "on" => Some(true),
            "off" => Some(false),
            other => {
                return Err(doc.err(
                    v.span(),
                    format!("`{other}` in `block_delete`: expected \"on\" (blocks with / are skipped) or \"off\" (they run), the switch's state when this machine runs programs"),
                ));
            }
        },
        None => None,
    };
    let cycle_r_initial = match root.get("cycles") {
        Some(v) => cycles(&doc, v)?,
        None => false,
    };
    let resolution = match root.get("resolution") {
        Some(v) => resolution(&doc, v)?,
        None => Resolution::default(),
    };
    // Axes, in file order.
    let mut axes = Vec::new();
    let mut axis_keys: Vec<Range<usize>> = Vec::new();
    if let Some(v) = root.get("axes") {
        let table = doc.table(v, "`axes`, a table of axes such as [axes.X]")?;
        for (key, value) in table.iter() {
            axes.push(axis(&doc, key, value)?);
            axis_keys.push(key.span());
        }
    }

    let tool = match root.get("tool") {
        Some(v) => tool(&doc, v, &axes)?,
        None => Tool::default(),
    };

    // Chains: names → indices, each axis in at most one place.
    let mut used: Vec<Option<String>> = vec![None; axes.len()];
    // Where each axis is named in its chain.
    let mut place: Vec<Range<usize>> = vec![0..0; axes.len()];
    let mut chain_given = false;
    let workpiece_chain = match root.get_key_value("workpiece_chain") {
        Some((_, v)) => {
            chain_given = true;
            chain(&doc, v, "workpiece_chain", &axes, &mut used, &mut place)?
        }
        None => Vec::new(),
    };
    let single = root.get_key_value("tool_chain");
    let named = root.get_key_value("tool_chains");
    let mut tool_chains = Vec::new();
    match (single, named) {
        (Some((k1, _)), Some((k2, _))) => {
            let second = if k1.span().start > k2.span().start {
                k1
            } else {
                k2
            };
            return Err(doc.err(
                second.span(),
                "give either `tool_chain = [...]` (one tool chain) or a [tool_chains] table \
                 (named chains), not both",
            ));
        }
        (Some((_, v)), None) => {
            chain_given = true;
            let axes_of = chain(&doc, v, "tool_chain", &axes, &mut used, &mut place)?;
            tool_chains.push(Chain {
                name: "tool".to_string(),
                axes: axes_of,
                tools: Vec::new(),
            });
        }
        (None, Some((_, v))) => {
            chain_given = true;
            let table = doc.table(v, "[tool_chains], named chains such as `upper = [\"Z\"]`")?;
            if table.is_empty() {
                return Err(doc.err(
                    v.span(),
                    "[tool_chains] is empty: expected at least one named chain, such as \
                     `upper = [\"Z1\", \"X1\"]`",
                ));
            }
            // Where each tool number was given, for a second mention's message.
            let mut tool_owner: Vec<(u32, String)> = Vec::new();
            for (key, value) in table.iter() {
                let what = format!("tool chain `{}`", key.get_ref());
                let (axes_value, tools) = match value.get_ref() {
                    DeValue::Table(t) => {
                        let place = format!("[tool_chains.{}]", key.get_ref());
                        doc.check_keys(t, &["axes", "tools"], &place)?;
                        let Some(a) = t.get("axes") else {
                            return Err(doc.err(
                                value.span(),
                                format!(
                                    "{place} has no `axes`: expected `axes = [\"Z1\", \"X1\"]`, \
                                     its axes from the bed outward"
                                ),
                            ));
                        };
                        let tools = match t.get("tools") {
                            Some(v) => tool_numbers(&doc, v, key.get_ref(), &mut tool_owner)?,
                            None => Vec::new(),
                        };
                        (a, tools)
                    }
                    _ => (value, Vec::new()),
                };
                tool_chains.push(Chain {
                    name: key.get_ref().to_string(),
                    axes: chain(&doc, axes_value, &what, &axes, &mut used, &mut place)?,
                    tools,
                });
            }
        }
        (None, None) => tool_chains.push(Chain {
            name: "tool".to_string(),
            axes: Vec::new(),
            tools: Vec::new(),
        }),
    }

    if !chain_given {
        return Err(doc.err(
            0..0,
            "the machine has no axes: expected `workpiece_chain = [...]` and `tool_chain = \
             [...]` (or [tool_chains]) naming axes defined as [axes.NAME] tables",
        ));
    }
    if workpiece_chain.is_empty() && tool_chains.iter().all(|c| c.axes.is_empty()) {
        let first_chain = ["workpiece_chain", "tool_chain", "tool_chains"]
            .iter()
            .filter_map(|k| root.get_key_value(*k))
            .map(|(k, _)| k.span())
            .min_by_key(|s| s.start)
            .unwrap_or(0..0);
        return Err(doc.err(
            first_chain,
            "the machine has no axes: its chains are all empty; expected axis names defined \
             as [axes.NAME] tables in `workpiece_chain` or a tool chain",
        ));
    }
    if let Some(i) = used.iter().position(Option::is_none) {
        return Err(doc.err(
            axis_keys[i].clone(),
            format!(
                "axis {} is defined but in no chain: expected it in `workpiece_chain` or a \
                 tool chain (or remove its [axes.{}] table)",
                axes[i].name, axes[i].name
            ),
        ));
    }

    // Program words: unique within the workpiece chain plus any one tool chain.
    for chain in &tool_chains {
        let mut seen: Vec<usize> = Vec::new();
        for &i in workpiece_chain.iter().chain(&chain.axes) {
            if let Some(&j) = seen.iter().find(|&&j| axes[j].word == axes[i].word) {
                return Err(doc.err(
                    place[i].clone(),
                    format!(
                        "axes {} and {} are both driven by program word {}{}: expected each \
                         word at most once in the workpiece chain and a tool chain together \
                         (give one of them another `word`)",
                        axes[j].name,
                        axes[i].name,
                        axes[i].word,
                        if tool_chains.len() > 1 {
                            format!(" (with tool chain `{}`)", chain.name)
                        } else {
                            String::new()
                        }
                    ),
                ));
            }
            seen.push(i);
        }
    }

    for chain in &tool_chains {
        geometry(
            &doc,
            &axes,
            &workpiece_chain,
            chain,
            &place,
            tool_chains.len() > 1,
        )?;
    }

    let lathe = match root.get("lathe") {
        Some(v) => Some(lathe(&doc, v, &axes, &workpiece_chain, &tool_chains)?),
        None => None,
    };

    let codes = match root.get("codes") {
        Some(v) => codes(&doc, v, &axes)?,
        None => MachineCodes::default(),
    };

    let plane_solution = match root.get("working_plane") {
        Some(v) => working_plane(&doc, v, &axes)?,
        None => PlaneSolution::default(),
    };

    let work_offsets = match root.get("work_offsets") {
        Some(v) => Some(work_offsets(&doc, v)?),
        None => None,
    };

    let start = match root.get("start") {
        Some(v) => start(&doc, v, &axes)?,
        None => Vec::new(),
    };
    // Relative to the machine file, as a path in it is read by whoever wrote it there.
    let errors_file = match root.get("errors") {
        Some(v) => {
            let name = doc.string(v, "`errors`, the machine's error file")?;
            if name.is_empty() {
                return Err(doc.err(
                    v.span(),
                    "an empty `errors`: expected the path of the machine's error file, relative to the machine file",
                ));
            }
            let dir = Path::new(path).parent().unwrap_or(Path::new(""));
            Some(dir.join(name))
        }
        None => None,
    };
    Ok(Machine {
        name,
        axes,
        workpiece_chain,
        tool_chains,
        resolution,
        tool,
        lathe,
        codes,
        plane_solution,
        inch_default,
        work_offsets,
        cycle_r_initial,
        block_delete,
        start,
        errors_file,
    })
}

/// `[start]`: where axes stand when a program starts (the set-up's positions, e.g.
/// `A = 0.0` for a rotary table a three-axis job never turns), by axis name, mm or degrees.
fn start(doc: &Doc, v: &Spanned<DeValue>, axes: &[Axis]) -> Result<Vec<(usize, f64)>> {
    let t = doc.table(
        v,
        "[start], a table of axis positions at the program's start such as `A = 0.0`",
    )?;
    let mut out = Vec::new();
    for (key, value) in t.iter() {
        let name = key.get_ref();
        let Some(i) = axes.iter().position(|a| a.name == *name) else {
            let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
            return Err(doc.err(
                key.span(),
                format!(
                    "axis `{name}` in [start] is not defined as [axes.{name}]; the defined axes are {}",
                    names.join(", ")
                ),
            ));
        };
        out.push((i, doc.number(value, &format!("`{name}` in [start]"))?));
    }
    Ok(out)
}

/// `[cycles]`: `missing_r = "initial"` says that this control takes the level a drilling
/// cycle starts from as its R plane when the cycle gives no R (a Haas does); without it a
/// cycle with no R is refused.
fn cycles(doc: &Doc, v: &Spanned<DeValue>) -> Result<bool> {
    let t = doc.table(
        v,
        "[cycles], a table with `missing_r = \"initial\"` (the R plane of a cycle given no R is the level it starts from)",
    )?;
    doc.check_keys(t, &["missing_r"], "[cycles]")?;
    let Some(r) = t.get("missing_r") else {
        return Ok(false);
    };
    match doc.string(r, "`missing_r` of [cycles]")? {
        "initial" => Ok(true),
        other => Err(doc.err(
            r.span(),
            format!(
                "`{other}` in `missing_r` of [cycles]: expected \"initial\" (the control takes the level the cycle starts from as its R plane); leave the key out where the control needs R"
            ),
        )),
    }
}

/// Refuse a machine that cannot set the tool's pose with the workpiece chain and `chain`:
/// two rotary axes that set the tool direction (the only two, or all of them) parallel or
/// within [`limits::AXIS_ANGLE_DEG`] of it; two linear axes (the only two) parallel, or
/// three (the only three) in one plane, within the same angle. The message points at the
/// axis in its chain that makes the machine degenerate.
fn geometry(
    doc: &Doc,
    axes: &[Axis],
    workpiece_chain: &[usize],
    chain: &Chain,
    place: &[Range<usize>],
    several: bool,
) -> Result<()> {
    let min = limits::AXIS_ANGLE_DEG.to_radians().sin();
    let of = |kind| -> Vec<usize> {
        workpiece_chain
            .iter()
            .chain(&chain.axes)
            .copied()
            .filter(|&i| axes[i].kind == kind)
            .collect()
    };
    let with = if several {
        format!(" (with tool chain `{}`)", chain.name)
    } else {
        String::new()
    };
    let angle = |i: usize, j: usize| {
        let c = axes[i].direction.dot(&axes[j].direction).abs().min(1.0);
        c.acos().to_degrees()
    };
    let sine = |i: usize, j: usize| axes[i].direction.cross(&axes[j].direction).norm();
    let rotary = of(AxisKind::Rotary);
    if rotary.len() >= 2 {
        let pairs = || {
            rotary
                .iter()
                .enumerate()
                .flat_map(|(k, &i)| rotary[k + 1..].iter().map(move |&j| (i, j)))
        };
        if let Some((i, j)) = pairs().next()
            && pairs().all(|(i, j)| sine(i, j) < min)
        {
            return Err(doc.err(
                place[j].clone(),
                format!(
                    "rotary axes {} and {} are {}° from parallel{with}: the tool direction needs \
                     two rotary axes that are not parallel; expected their directions at least \
                     {}° apart",
                    axes[i].name,
                    axes[j].name,
                    shown(angle(i, j)),
                    shown(limits::AXIS_ANGLE_DEG)
                ),
            ));
        }
    }
    let linear = of(AxisKind::Linear);
    match linear[..] {
        [i, j] if sine(i, j) < min => Err(doc.err(
            place[j].clone(),
            format!(
                "linear axes {} and {} are {}° from parallel{with}: they move the tool along one \
                 line; expected their directions at least {}° apart",
                axes[i].name,
                axes[j].name,
                shown(angle(i, j)),
                shown(limits::AXIS_ANGLE_DEG)
            ),
        )),
        [i, j, k]
            if axes[i]
                .direction
                .cross(&axes[j].direction)
                .dot(&axes[k].direction)
                .abs()
                < min =>
        {
            Err(doc.err(
                place[k].clone(),
                format!(
                    "linear axes {}, {} and {} lie in one plane{with} (within {}°): they cannot \
                     move the tool in three directions; expected three directions that span \
                     space",
                    axes[i].name,
                    axes[j].name,
                    axes[k].name,
                    shown(limits::AXIS_ANGLE_DEG)
                ),
            ))
        }
        _ => Ok(()),
    }
}

/// `[codes]`: the machine's own G and M codes, each in one list, none of nccomp's own.
fn codes(doc: &Doc, v: &Spanned<DeValue>, axes: &[Axis]) -> Result<MachineCodes> {
    let t = doc.table(
        v,
        "[codes], a table with `harmless`, `tcp_on` and `tcp_off` lists such as [\"M428\"] and a `machine_moves` table such as { M25 = [\"Z\"] }",
    )?;
    doc.check_keys(
        t,
        &["harmless", "tcp_on", "tcp_off", "machine_moves"],
        "[codes]",
    )?;
    let mut codes = MachineCodes::default();
    let mut seen: Vec<(CodeName, &str)> = Vec::new();
    // A code's name, checked: a G or M code of this machine's own, in one list only.
    let mut name_of = |text: &str, span, key: &'static str| {
        let Some(name) = CodeName::parse(text) else {
            return Err(doc.err(
                span,
                format!(
                    "`{text}` in `{key}` of [codes]: expected a G or M code such as \"M428\" \
                     or \"G5.1\" (a letter, a number, at most one decimal)"
                ),
            ));
        };
        if program::codes::is_known(name) {
            return Err(doc.err(
                span,
                format!(
                    "`{text}` in `{key}` of [codes]: {name} is one of nccomp's own codes \
                     (docs/nc-support.md), and a machine file cannot give it another \
                     meaning; expected a code of this machine's own"
                ),
            ));
        }
        if let Some((_, other)) = seen.iter().find(|(n, _)| *n == name) {
            return Err(doc.err(
                span,
                format!(
                    "`{text}` in `{key}` of [codes]: {name} is already in `{other}`; \
                     expected each code in one list, once"
                ),
            ));
        }
        seen.push((name, key));
        Ok(name)
    };
    for key in ["harmless", "tcp_on", "tcp_off"] {
        let Some(list) = t.get(key) else { continue };
        let what = format!("`{key}` of [codes], a list of codes such as [\"M428\"]");
        let array = list.get_ref().as_array().ok_or_else(|| {
            doc.err(
                list.span(),
                format!("expected {what}, found {}", describe(list.get_ref())),
            )
        })?;
        for e in array.iter() {
            let text = doc.string(e, &format!("a code in `{key}` of [codes]"))?;
            let name = name_of(text, e.span(), key)?;
            match key {
                "harmless" => codes.harmless.push(name),
                "tcp_on" => codes.tcp_on.push(name),
                _ => codes.tcp_off.push(name),
            }
        }
    }
    if let Some(moves) = t.get("machine_moves") {
        let what = "`machine_moves` of [codes], a table of codes and the axes each sends to \
                    machine positions, such as { M25 = [\"Z\"] }";
        let table = moves.get_ref().as_table().ok_or_else(|| {
            doc.err(
                moves.span(),
                format!("expected {what}, found {}", describe(moves.get_ref())),
            )
        })?;
        for (key, list) in table.iter() {
            let name = name_of(key.get_ref(), key.span(), "machine_moves")?;
            let array = list.get_ref().as_array().ok_or_else(|| {
                doc.err(
                    list.span(),
                    format!(
                        "expected the axes {} sends to machine positions, a list such as \
                         [\"Z\"], found {}",
                        key.get_ref(),
                        describe(list.get_ref())
                    ),
                )
            })?;
            if array.is_empty() {
                return Err(doc.err(
                    list.span(),
                    format!(
                        "{} in `machine_moves` of [codes] names no axis: expected the axes \
                         it sends to machine positions, such as [\"Z\"] (a code that moves \
                         none belongs in `harmless`)",
                        key.get_ref()
                    ),
                ));
            }
            let mut letters = 0u32;
            for e in array.iter() {
                let text = doc.string(e, "an axis in `machine_moves` of [codes]")?;
                let Some(axis) = axes.iter().find(|a| a.name == text) else {
                    let known: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
                    return Err(doc.err(
                        e.span(),
                        format!(
                            "`{text}` in `machine_moves` of [codes] is not an axis of this \
                             machine (expected one of {})",
                            known.join(", ")
                        ),
                    ));
                };
                letters |= 1 << (axis.word as u8 - b'A');
            }
            codes.machine_moves.push((name, letters));
        }
    }
    Ok(codes)
}

/// `[working_plane]`: `solution = "shortest"` (Fanuc's G53.1) or a rotary axis and a
/// sign, `"A+"` or `"A-"` (Heidenhain's SEQ+ / SEQ-).
fn working_plane(doc: &Doc, v: &Spanned<DeValue>, axes: &[Axis]) -> Result<PlaneSolution> {
    let t = doc.table(
        v,
        "[working_plane], a table with `solution = \"shortest\"` or a rotary axis and a sign such as \"A+\"",
    )?;
    doc.check_keys(t, &["solution"], "[working_plane]")?;
    let Some(s) = t.get("solution") else {
        return Ok(PlaneSolution::default());
    };
    let text = doc.string(s, "`solution` of [working_plane]")?;
    if text == "shortest" {
        return Ok(PlaneSolution::Shortest);
    }
    let sign = text.chars().last();
    let name = &text[..text.len() - sign.map_or(0, char::len_utf8)];
    let axis = axes
        .iter()
        .position(|a| a.name == name && a.kind == AxisKind::Rotary);
    match (axis, sign) {
        (Some(axis), Some(c @ ('+' | '-'))) => Ok(PlaneSolution::Sign {
            axis,
            positive: c == '+',
        }),
        _ => Err(doc.err(
            s.span(),
            format!(
                "`{text}` in `solution` of [working_plane]: expected \"shortest\" or a rotary axis of this machine followed by + or - (such as \"{}+\")",
                axes.iter()
                    .find(|a| a.kind == AxisKind::Rotary)
                    .map_or("A", |a| a.name.as_str())
            ),
        )),
    }
}

/// `[work_offsets]`: `geometry = "G54"` (the offset whose program zero the geometry is
/// given in; machine zero when left out) and one table `{ X = …, Y = …, Z = … }` per
/// offset (`G54` … `G59`, `G59.1` … `G59.3`, `"G54.1 P1"` …), in machine coordinates.
fn work_offsets(doc: &Doc, v: &Spanned<DeValue>) -> Result<WorkOffsets> {
    let what =
        "[work_offsets], a table of offsets such as `G54 = { X = -250.0, Y = -180.0, Z = -420.0 }`";
    let t = doc.table(v, what)?;
    let mut offsets = WorkOffsets::default();
    let expected = "expected G54 … G59, G59.1 … G59.3 or \"G54.1 P1\" … \"G54.1 P300\"";
    for (key, value) in t.iter() {
        let k: &str = key.get_ref();
        if k == "geometry" {
            let text = doc.string(value, "`geometry` of [work_offsets]")?;
            if text.eq_ignore_ascii_case("G53") || text.eq_ignore_ascii_case("machine") {
                continue;
            }
            let Some(code) = WorkOffsets::code(text) else {
                return Err(doc.err(
                    value.span(),
                    format!("`{text}` in `geometry` of [work_offsets]: {expected}, or \"G53\" for machine zero"),
                ));
            };
            offsets.geometry = Some(code);
            continue;
        }
        let code = WorkOffsets::code(k);
        if code.is_none() && k != "M92" {
            return Err(doc.err(
                key.span(),
                format!("unknown key `{k}` in [work_offsets]: {expected} (or `geometry`, or `M92`, a Heidenhain control's M92 reference)"),
            ));
        }
        let place = format!("[work_offsets] {k}");
        let entry = doc.table(
            value,
            &format!("{place}, a table such as {{ X = 0, Y = 0, Z = 0 }}"),
        )?;
        doc.check_keys(entry, &["X", "Y", "Z"], &place)?;
        let mut xyz = [0.0; 3];
        for (c, letter) in ["X", "Y", "Z"].iter().enumerate() {
            if let Some(n) = entry.get(*letter) {
                xyz[c] = doc.number_in(
                    n,
                    &format!("{letter} of {place}"),
                    Bounds::within(limits::LENGTH_MM, "mm"),
                )?;
            }
        }
        match code {
            Some(code) => {
                offsets.values.insert(code, xyz);
            }
            None => offsets.m92 = Some(xyz),
        }
    }
    if let Some(g) = offsets.geometry
        && !offsets.values.contains_key(&g)
    {
        let span = t.get("geometry").map_or(v.span(), |g| g.span());
        return Err(doc.err(
            span,
            format!(
                "`geometry` of [work_offsets] names {}, which the table does not give: expected its values in the table",
                WorkOffsets::name(&g)
            ),
        ));
    }
    offsets.geometry_zero = offsets
        .geometry
        .and_then(|g| offsets.values.get(&g).copied())
        .unwrap_or([0.0; 3]);
    Ok(offsets)
}

/// A chain's `tools = [1, 2, 3]`: T numbers, each in one chain only.
fn tool_numbers(
    doc: &Doc,
    v: &Spanned<DeValue>,
    chain: &str,
    owner: &mut Vec<(u32, String)>,
) -> Result<Vec<u32>> {
    let what = format!("`tools` of tool chain `{chain}`, T numbers such as [1, 2, 3]");
    let array = v.get_ref().as_array().ok_or_else(|| {
        doc.err(
            v.span(),
            format!("expected {what}, found {}", describe(v.get_ref())),
        )
    })?;
    let mut out = Vec::new();
    for e in array.iter() {
        let t = match e.get_ref() {
            DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
                .ok()
                .and_then(|t| u32::try_from(t).ok())
                .filter(|&t| t > 0),
            _ => None,
        };
        let Some(t) = t else {
            return Err(doc.err(
                e.span(),
                format!(
                    "`{}` in the `tools` of tool chain `{chain}`: expected a T number, a \
                     whole number from 1 (T0 selects no tool)",
                    &doc.text[e.span()]
                ),
            ));
        };
        if let Some((_, other)) = owner.iter().find(|(n, _)| *n == t) {
            let again = if other == chain { " twice" } else { "" };
            return Err(doc.err(
                e.span(),
                format!(
                    "tool T{t} is listed{again} in tool chain `{chain}` but already selects \
                     tool chain `{other}`: expected each T number in one chain, once"
                ),
            ));
        }
        owner.push((t, chain.to_string()));
        out.push(t);
    }
    Ok(out)
}

/// `[lathe]`: the spindle that turns the part, and whether X words start as diameters.
fn lathe(
    doc: &Doc,
    v: &Spanned<DeValue>,
    axes: &[Axis],
    workpiece_chain: &[usize],
    tool_chains: &[Chain],
) -> Result<Lathe> {
    let t = doc.table(v, "[lathe], a table with `spindle` and `diameter`")?;
    doc.check_keys(t, &["spindle", "diameter"], "[lathe]")?;
    let Some(s) = t.get("spindle") else {
        return Err(doc.err(
            v.span(),
            "[lathe] has no `spindle`: expected `spindle = \"C\"`, the rotary axis of the \
             workpiece chain that turns the part",
        ));
    };
    let name = doc.string(s, "`spindle`")?;
    let spindle = match axes.iter().position(|a| a.name == name) {
        Some(i) if axes[i].kind == AxisKind::Rotary && workpiece_chain.contains(&i) => i,
        Some(_) => {
            return Err(doc.err(
                s.span(),
                format!(
                    "`spindle = \"{name}\"`: expected a rotary axis of the workpiece chain \
                     (the spindle turns the part)"
                ),
            ));
        }
        None => {
            return Err(doc.err(
                s.span(),
                format!("`spindle = \"{name}\"`: there is no axis {name} ([axes.{name}])"),
            ));
        }
    };
    let diameter = match t.get("diameter") {
        Some(d) => d.get_ref().as_bool().ok_or_else(|| {
            doc.err(
                d.span(),
                format!(
                    "`diameter`: expected true (X words are diameters at the start, as after \
                     G7) or false (radii, as after G8), found {}",
                    describe(d.get_ref())
                ),
            )
        })?,
        None => false,
    };
    // Turning moves the tool in X and Z: every turret needs both, as linear axes.
    for chain in tool_chains {
        for letter in ['X', 'Z'] {
            let found = workpiece_chain
                .iter()
                .chain(&chain.axes)
                .any(|&i| axes[i].word == letter && axes[i].kind == AxisKind::Linear);
            if !found {
                return Err(doc.err(
                    v.span(),
                    format!(
                        "[lathe]: tool chain `{}` has no linear axis driven by {letter}: \
                         expected every tool chain of a lathe to move the tool in X and Z",
                        chain.name
                    ),
                ));
            }
        }
    }
    Ok(Lathe { spindle, diameter })
}

fn resolution(doc: &Doc, v: &Spanned<DeValue>) -> Result<Resolution> {
    let t = doc.table(
        v,
        "`resolution`, a table `{ linear = 0.0001, rotary = 0.0001 }`",
    )?;
    doc.check_keys(t, &["linear", "rotary"], "`resolution`")?;
    let mut r = Resolution::default();
    for (key, slot, unit) in [
        ("linear", &mut r.linear, "mm"),
        ("rotary", &mut r.rotary, "degrees"),
    ] {
        if let Some(v) = t.get(key) {
            let [lo, hi] = limits::RESOLUTION;
            *slot = doc.number_in(v, &format!("resolution `{key}`"), Bounds { lo, hi, unit })?;
        }
    }
    Ok(r)
}

fn tool(doc: &Doc, v: &Spanned<DeValue>, axes: &[Axis]) -> Result<Tool> {
    let t = doc.table(
        v,
        "[tool], a table with `length`, `lengths`, `named_lengths`, `radii`, `named_radii`, `max_radius` and `change_moves`",
    )?;
    doc.check_keys(
        t,
        &[
            "length",
            "lengths",
            "named_lengths",
            "radii",
            "named_radii",
            "max_radius",
            "change_moves",
        ],
        "[tool]",
    )?;
    let mut tool = Tool::default();
    let l = limits::LENGTH_MM;
    if let Some(v) = t.get("length") {
        tool.length = doc.number_in(v, "tool `length`", Bounds::within(l, "mm"))?;
    }
    if let Some(v) = t.get("lengths") {
        let table = doc.table(
            v,
            "tool `lengths`, a table of lengths by H number such as `{ 1 = 95.3 }`",
        )?;
        for (key, value) in table.iter() {
            let h: u32 = key.get_ref().parse().map_err(|_| {
                doc.err(
                    key.span(),
                    format!(
                        "tool length key `{}`: expected an H number (0, 1, 2, ...)",
                        key.get_ref()
                    ),
                )
            })?;
            let length = doc.number_in(
                value,
                &format!("the length of tool H{h}"),
                Bounds::within(l, "mm"),
            )?;
            tool.lengths.insert(h, length);
        }
    }
    if let Some(v) = t.get("named_lengths") {
        let table = doc.table(
            v,
            "tool `named_lengths`, a table of lengths by tool name such as `{ \"BALL D10\" = 95.3 }`",
        )?;
        for (key, value) in table.iter() {
            let name = key.get_ref().to_string();
            if name.is_empty() {
                return Err(doc.err(
                    key.span(),
                    "an empty tool name in `named_lengths`: expected the name a program calls the tool by",
                ));
            }
            let length = doc.number_in(
                value,
                &format!("the length of tool \"{name}\""),
                Bounds::within(l, "mm"),
            )?;
            tool.named_lengths.insert(name, length);
        }
    }
    // Radii for tool radius compensation (RL/RR, G41/G42): from 0 to 500 mm.
    let radius_bounds = Bounds {
        lo: 0.0,
        hi: 500.0,
        unit: "mm",
    };
    if let Some(v) = t.get("radii") {
        let table = doc.table(
            v,
            "tool `radii`, a table of radii by tool number such as `{ 1 = 3.0 }`",
        )?;
        for (key, value) in table.iter() {
            let n: u32 = key.get_ref().parse().map_err(|_| {
                doc.err(
                    key.span(),
                    format!(
                        "tool radius key `{}`: expected a tool number (1, 2, ...)",
                        key.get_ref()
                    ),
                )
            })?;
            let r = doc.number_in(value, &format!("the radius of tool {n}"), radius_bounds)?;
            tool.radii.insert(n, r);
        }
    }
    if let Some(v) = t.get("named_radii") {
        let table = doc.table(
            v,
            "tool `named_radii`, a table of radii by tool name such as `{ \"BALL D10\" = 5.0 }`",
        )?;
        for (key, value) in table.iter() {
            let name = key.get_ref().to_string();
            if name.is_empty() {
                return Err(doc.err(
                    key.span(),
                    "an empty tool name in `named_radii`: expected the name a program calls the tool by",
                ));
            }
            let r = doc.number_in(
                value,
                &format!("the radius of tool \"{name}\""),
                radius_bounds,
            )?;
            tool.named_radii.insert(name, r);
        }
    }
    if let Some(v) = t.get("max_radius") {
        tool.max_radius = Some(doc.number_in(
            v,
            "tool `max_radius`, the largest radius of any tool the programs call",
            radius_bounds,
        )?);
    }
    if let Some(v) = t.get("change_moves") {
        let what = "tool `change_moves`, the axes a tool change sends to the change position, such as [\"Z\"] ([] when it moves none)";
        let array = v.get_ref().as_array().ok_or_else(|| {
            doc.err(
                v.span(),
                format!("expected {what}, found {}", describe(v.get_ref())),
            )
        })?;
        let mut letters = 0u32;
        for e in array.iter() {
            let text = doc.string(e, "an axis in `change_moves` of [tool]")?;
            let Some(axis) = axes.iter().find(|a| a.name == text) else {
                let known: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
                return Err(doc.err(
                    e.span(),
                    format!(
                        "`{text}` in `change_moves` of [tool] is not an axis of this machine (expected one of {})",
                        known.join(", ")
                    ),
                ));
            };
            letters |= 1 << (axis.word as u8 - b'A');
        }
        tool.change_moves = letters;
    }
    Ok(tool)
}

fn axis(doc: &Doc, key: &Spanned<std::borrow::Cow<str>>, v: &Spanned<DeValue>) -> Result<Axis> {
    let name = key.get_ref().to_string();
    if !is_axis_name(&name) {
        return Err(doc.err(
            key.span(),
            format!(
                "axis name `{name}`: expected an uppercase letter followed by uppercase letters \
                 or digits, such as X or X2"
            ),
        ));
    }
    let what = format!("[axes.{name}]");
    let t = doc.table(v, &format!("{what}, a table with `kind` and `direction`"))?;
    doc.check_keys(
        t,
        &[
            "kind",
            "word",
            "direction",
            "travel",
            "reference_point",
            "point",
            "table_offset",
            "rollover",
        ],
        &what,
    )?;

    let kind = match t.get("kind") {
        None => {
            return Err(doc.err(
                v.span(),
                format!(
                    "{what} has no `kind`: expected `kind = \"linear\"` or `kind = \"rotary\"`"
                ),
            ));
        }
        Some(k) => match doc.string(k, "`kind`")? {
            "linear" => AxisKind::Linear,
            "rotary" => AxisKind::Rotary,
            other => {
                return Err(doc.err(
                    k.span(),
                    format!("unknown axis kind `{other}`: expected \"linear\" or \"rotary\""),
                ));
            }
        },
    };

    let word = match t.get("word") {
        Some(w) => {
            let s = doc.string(w, "`word`")?;
            let mut chars = s.chars();
            match (chars.next(), chars.next()) {
                (Some(c), None) if AXIS_WORDS.contains(c) => c,
                _ => {
                    return Err(doc.err(
                        w.span(),
                        format!(
                            "`word = \"{s}\"`: expected one program letter, one of X, Y, Z, A, \
                             B, C, U, V, W"
                        ),
                    ));
                }
            }
        }
        None => {
            let mut chars = name.chars();
            match (chars.next(), chars.next()) {
                (Some(c), None) if AXIS_WORDS.contains(c) => c,
                (Some(_), None) => {
                    return Err(doc.err(
                        key.span(),
                        format!(
                            "axis {name}: {name} is not a program axis word; expected `word = \
                             \"...\"`, one of X, Y, Z, A, B, C, U, V, W"
                        ),
                    ));
                }
                _ => {
                    return Err(doc.err(
                        v.span(),
                        format!(
                            "axis {name} has a name longer than one letter: expected `word = \
                             \"...\"`, the program letter that drives it (e.g. `word = \"{}\"`)",
                            name.chars().next().unwrap_or('X')
                        ),
                    ));
                }
            }
        }
    };

    let direction = match t.get("direction") {
        None => {
            return Err(doc.err(
                v.span(),
                format!(
                    "{what} has no `direction`: expected `direction = [x, y, z]`, the sense of \
                     motion of the body the axis moves"
                ),
            ));
        }
        Some(d) => {
            let l = limits::DIRECTION;
            let dir = doc.vec3_in(d, "`direction`", Bounds::within(l, ""))?;
            if dir.amax() < limits::DIRECTION_MIN {
                return Err(doc.err(
                    d.span(),
                    format!(
                        "`direction` is the zero vector (no component reaches {}): expected a \
                         non-zero direction such as [1, 0, 0]",
                        shown(limits::DIRECTION_MIN)
                    ),
                ));
            }
            dir.normalize()
        }
    };
    // Positions along the axis: mm, or degrees.
    let (unit, reach) = match kind {
        AxisKind::Linear => ("mm", limits::LENGTH_MM),
        AxisKind::Rotary => ("degrees", limits::ANGLE_DEG),
    };

    let travel = match t.get("travel") {
        None => None,
        Some(tv) => {
            let what = format!("`travel`, [min, max] in {unit}");
            let values = doc.numbers_in(tv, "`travel`", Bounds::within(reach, unit))?;
            if values.len() != 2 {
                return Err(doc.err(
                    tv.span(),
                    format!("{} numbers in {what}: expected two", values.len()),
                ));
            }
            let (lo, hi) = (values[0].0, values[1].0);
            if lo >= hi {
                return Err(doc.err(
                    tv.span(),
                    format!(
                        "`travel = [{lo}, {hi}]`: expected min < max (omit `travel` for an \
                         unlimited or continuous axis)"
                    ),
                ));
            }
            Some([lo, hi])
        }
    };

    let point = match kind {
        AxisKind::Linear => {
            if let Some((k, _)) = t.get_key_value("point") {
                return Err(doc.err(
                    k.span(),
                    format!(
                        "`point` is for rotary axes, and {name} is linear: expected \
                         `reference_point` (the error reference point) or nothing"
                    ),
                ));
            }
            match t.get("reference_point") {
                Some(p) => doc.vec3_in(
                    p,
                    "`reference_point`",
                    Bounds::within(limits::LENGTH_MM, "mm"),
                )?,
                None => Vector3::zeros(),
            }
        }
        AxisKind::Rotary => {
            if let Some((k, _)) = t.get_key_value("reference_point") {
                return Err(doc.err(
                    k.span(),
                    format!(
                        "`reference_point` is for linear axes, and {name} is rotary: expected \
                         `point`, a point on its axis line"
                    ),
                ));
            }
            match t.get("point") {
                Some(p) => doc.vec3_in(p, "`point`", Bounds::within(limits::LENGTH_MM, "mm"))?,
                None => {
                    return Err(doc.err(
                        v.span(),
                        format!(
                            "rotary axis {name} has no `point`: expected `point = [x, y, z]`, \
                             a point on its axis line at home, in mm"
                        ),
                    ));
                }
            }
        }
    };

    let table_offset = match t.get("table_offset") {
        Some(o) => doc.number_in(o, "`table_offset`", Bounds::within(reach, unit))?,
        None => 0.0,
    };

    let rollover = match t.get_key_value("rollover") {
        None => false,
        Some((k, r)) => {
            let on = r.get_ref().as_bool().ok_or_else(|| {
                doc.err(
                    r.span(),
                    format!(
                        "`rollover`: expected true (the control takes an absolute word modulo 360° and turns the shortest way) or false, found {}",
                        describe(r.get_ref())
                    ),
                )
            })?;
            if on && (kind != AxisKind::Rotary || travel.is_some()) {
                return Err(doc.err(
                    k.span(),
                    format!(
                        "`rollover` is for rotary axes without a `travel` (they turn without end), and {name} {}",
                        if kind == AxisKind::Rotary { "has a travel" } else { "is linear" }
                    ),
                ));
            }
            on
        }
    };

    Ok(Axis {
        name,
        word,
        kind,
        direction,
        point,
        travel,
        table_offset,
        rollover,
    })
}

/// A chain: an array of axis names → indices. `used[i]` records where axis i went.
fn chain(
    doc: &Doc,
    v: &Spanned<DeValue>,
    what: &str,
    axes: &[Axis],
    used: &mut [Option<String>],
    place: &mut [Range<usize>],
) -> Result<Vec<usize>> {
    let array = v.get_ref().as_array().ok_or_else(|| {
        doc.err(
            v.span(),
            format!(
                "{what}: expected an array of axis names such as [\"X\", \"Y\"], found {}",
                describe(v.get_ref())
            ),
        )
    })?;
    let mut out = Vec::new();
    for element in array.iter() {
        let name = doc.string(element, &format!("an axis name in {what}"))?;
        let Some(i) = axes.iter().position(|a| a.name == name) else {
            let names: Vec<String> = axes.iter().map(|a| a.name.clone()).collect();
            let hint = match suggest(name, names.iter().map(String::as_str)) {
                Some(s) => format!("; did you mean {s}?"),
                None if names.is_empty() => "; no axes are defined ([axes.NAME] tables)".into(),
                None => format!("; the defined axes are {}", names.join(", ")),
            };
            return Err(doc.err(
                element.span(),
                format!("axis `{name}` in {what} is not defined as [axes.{name}]{hint}"),
            ));
        };
        if let Some(previous) = &used[i] {
            let again = if previous == what { " again" } else { "" };
            return Err(doc.err(
                element.span(),
                format!(
                    "axis {name} is named{again} in {what} but is already in {previous}: \
                     expected each axis in exactly one chain, once"
                ),
            ));
        }
        used[i] = Some(what.to_string());
        place[i] = element.span();
        out.push(i);
    }
    Ok(out)
}

/// "a string", "an integer", ... for messages.
pub(crate) fn describe(v: &DeValue) -> &'static str {
    match v {
        DeValue::String(_) => "a string",
        DeValue::Integer(_) => "an integer",
        DeValue::Float(_) => "a float",
        DeValue::Boolean(_) => "a boolean",
        DeValue::Datetime(_) => "a date-time",
        DeValue::Array(_) => "an array",
        DeValue::Table(_) => "a table",
    }
}

/// The documented range of a number of a machine or error file, and its unit (empty for
/// none), as messages name it.
#[derive(Clone, Copy)]
pub(crate) struct Bounds<'u> {
    pub lo: f64,
    pub hi: f64,
    pub unit: &'u str,
}

impl<'u> Bounds<'u> {
    /// From −`limit` to `limit`.
    pub fn within(limit: f64, unit: &'u str) -> Self {
        Bounds {
            lo: -limit,
            hi: limit,
            unit,
        }
    }
}

impl std::fmt::Display for Bounds<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let unit = if self.unit.is_empty() {
            String::new()
        } else {
            format!(" {}", self.unit)
        };
        if self.lo == -self.hi {
            write!(f, "within ±{}{unit}", shown(self.hi))
        } else {
            write!(f, "from {} to {}{unit}", shown(self.lo), shown(self.hi))
        }
    }
}

/// A TOML file being checked: its name and text, and helpers that read spanned values
/// and turn every problem into a `path:line:col` diagnostic. Shared with the error file.
pub(crate) struct Doc<'t> {
    pub path: &'t str,
    pub text: &'t str,
}

impl<'t> Doc<'t> {
    pub fn err(&self, span: Range<usize>, message: impl Into<String>) -> Error {
        Error::at(self.path, self.text.as_bytes(), span.start, message)
    }

    /// The document, or the TOML syntax error.
    pub fn parse(&self) -> Result<Spanned<DeTable<'t>>> {
        DeTable::parse(self.text).map_err(|e| {
            let at = e.span().unwrap_or(0..0);
            self.err(at, format!("invalid TOML: {}", e.message().trim_end()))
        })
    }

    /// Refuse keys of `table` not in `allowed` (`place` names the table in messages).
    pub fn check_keys(&self, table: &DeTable, allowed: &[&str], place: &str) -> Result<()> {
        for key in table.keys() {
            let k: &str = key.get_ref();
            if !allowed.contains(&k) {
                let hint = match suggest(k, allowed.iter().copied()) {
                    Some(s) => format!("did you mean `{s}`? "),
                    None => String::new(),
                };
                let list: Vec<String> = allowed.iter().map(|a| format!("`{a}`")).collect();
                return Err(self.err(
                    key.span(),
                    format!(
                        "unknown key `{k}` in {place}: {hint}expected one of {}",
                        or_list(&list)
                    ),
                ));
            }
        }
        Ok(())
    }

    pub fn table<'v>(&self, v: &'v Spanned<DeValue<'t>>, what: &str) -> Result<&'v DeTable<'t>> {
        v.get_ref().as_table().ok_or_else(|| {
            self.err(
                v.span(),
                format!("expected {what}, found {}", describe(v.get_ref())),
            )
        })
    }

    pub fn string<'v>(&self, v: &'v Spanned<DeValue<'t>>, what: &str) -> Result<&'v str> {
        v.get_ref().as_str().ok_or_else(|| {
            self.err(
                v.span(),
                format!("{what}: expected a string, found {}", describe(v.get_ref())),
            )
        })
    }

    /// An integer or a float, finite.
    pub fn number(&self, v: &Spanned<DeValue>, what: &str) -> Result<f64> {
        let x = match v.get_ref() {
            DeValue::Integer(i) => i64::from_str_radix(i.as_str(), i.radix())
                .map(|i| i as f64)
                .ok(),
            DeValue::Float(f) => f.as_str().parse::<f64>().ok(),
            other => {
                return Err(self.err(
                    v.span(),
                    format!("{what}: expected a number, found {}", describe(other)),
                ));
            }
        };
        match x {
            Some(x) if x.is_finite() => Ok(x),
            _ => Err(self.err(
                v.span(),
                format!(
                    "{what}: `{}` is not a finite number: expected a finite number",
                    &self.text[v.span()]
                ),
            )),
        }
    }

    /// An array of finite numbers, each with its span.
    pub fn numbers(&self, v: &Spanned<DeValue>, what: &str) -> Result<Vec<(f64, Range<usize>)>> {
        let array = v.get_ref().as_array().ok_or_else(|| {
            self.err(
                v.span(),
                format!(
                    "{what}: expected an array of numbers, found {}",
                    describe(v.get_ref())
                ),
            )
        })?;
        array
            .iter()
            .map(|e| Ok((self.number(e, &format!("an element of {what}"))?, e.span())))
            .collect()
    }

    /// A finite number within `range`, refused with the range named.
    pub fn number_in(&self, v: &Spanned<DeValue>, what: &str, range: Bounds) -> Result<f64> {
        let x = self.number(v, what)?;
        if x < range.lo || x > range.hi {
            return Err(self.err(
                v.span(),
                format!(
                    "{what} is {}: expected a number {range} (docs/file-formats.md, \"Limits\")",
                    &self.text[v.span()]
                ),
            ));
        }
        Ok(x)
    }

    /// An array of numbers each within `range`, each with its span.
    pub fn numbers_in(
        &self,
        v: &Spanned<DeValue>,
        what: &str,
        range: Bounds,
    ) -> Result<Vec<(f64, Range<usize>)>> {
        self.numbers(v, what)?;
        let array = v.get_ref().as_array().into_iter().flat_map(|a| a.iter());
        array
            .map(|e| {
                Ok((
                    self.number_in(e, &format!("an element of {what}"), range)?,
                    e.span(),
                ))
            })
            .collect()
    }

    /// [`Doc::vec3`] with each component within `range`.
    pub fn vec3_in(&self, v: &Spanned<DeValue>, what: &str, range: Bounds) -> Result<Vector3<f64>> {
        let d = self.vec3(v, what)?;
        self.numbers_in(v, what, range)?;
        Ok(d)
    }

    pub fn vec3(&self, v: &Spanned<DeValue>, what: &str) -> Result<Vector3<f64>> {
        let values = self.numbers(v, what)?;
        if values.len() != 3 {
            return Err(self.err(
                v.span(),
                format!(
                    "{what} has {} numbers: expected three, [x, y, z]",
                    values.len()
                ),
            ));
        }
        Ok(Vector3::new(values[0].0, values[1].0, values[2].0))
    }
}

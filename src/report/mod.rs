//! `nccomp report`: one self-contained HTML page on a program and a machine — the
//! predicted tip and direction errors along the program before and after compensation,
//! the correction of every axis, and maps of the machine's volumetric error.
//!
//! All numbers come from the compensation pass ([`crate::compensate`], traced) and from
//! [`crate::kinematics`]; this module only arranges and draws them.

mod html;
pub mod plots;
pub mod verdict;
pub mod volume;

use crate::check::{DEFAULT_MAX_ANGLE_URAD, DEFAULT_MAX_ERROR_MM, Thresholds};
use crate::compensate::{self, Compensator, Summary};
use crate::model::{AxisKind, ErrorModel, Machine};
use crate::{Error, Result};
use html::Figure;
use volume::{Layout, Map};

/// What the report covers and how.
#[derive(Debug, Clone, PartialEq)]
pub struct Options {
    /// How the program is compensated (tool chain, held axes, ...).
    pub compensate: compensate::Options,
    /// Axis values of the volumetric maps, one map per entry (`A=30,C=90`; axes left out
    /// are 0). Empty: one map with every axis at 0.
    pub at: Vec<String>,
    /// Grid points per axis of a map.
    pub grid: usize,
    /// The pass/fail line's thresholds (`--max-error`, `--max-angle`).
    pub thresholds: Thresholds,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            compensate: compensate::Options::default(),
            at: Vec::new(),
            grid: 15,
            thresholds: Thresholds {
                max_error_mm: DEFAULT_MAX_ERROR_MM,
                max_angle_urad: Some(DEFAULT_MAX_ANGLE_URAD),
            },
        }
    }
}

/// The names the page shows for its inputs.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Names {
    pub program: String,
    pub machine: String,
    pub errors: String,
}

/// Everything the page shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Report {
    pub names: Names,
    pub machine_name: Option<String>,
    /// The compensation run, traced: one sample per compensated line.
    pub summary: Summary,
    /// The active configuration's axes, in variable order.
    pub axes: Vec<(String, AxisKind)>,
    /// Its tool chain (index into the machine's): the maps and the corrections plot are
    /// about the lines that ran in it.
    pub chain: usize,
    pub maps: Vec<Map>,
    /// Why there is no map, when there is none.
    pub no_map: Option<String>,
    pub thresholds: Thresholds,
}

/// The largest grid accepted (points per axis).
pub const MAX_GRID: usize = 101;

/// Compensate `program` and evaluate the maps.
pub fn build(
    machine: &Machine,
    errors: &ErrorModel,
    program: &[u8],
    names: Names,
    options: &Options,
) -> Result<Report> {
    if !(2..=MAX_GRID).contains(&options.grid) {
        return Err(Error::Usage(format!(
            "--grid {}: expected 2 to {MAX_GRID} points per axis",
            options.grid
        )));
    }
    let compensator = Compensator::new(machine, errors, options.compensate.clone())?;
    let kin = compensator.kinematics();
    let mut out = Vec::with_capacity(program.len() + 1024);
    let summary = compensator.run_traced(program, &names.program, &mut out)?;
    let samples = summary.trace.as_deref().unwrap_or_default();
    let axes: Vec<(String, AxisKind)> = kin
        .axes()
        .iter()
        .map(|&i| (machine.axes[i].name.clone(), machine.axes[i].kind))
        .collect();
    let chain = compensator.start_chain();
    let own = || samples.iter().filter(|s| s.chain == chain);
    let nominal: Vec<Vec<f64>> = own().map(|s| s.nominal.clone()).collect();
    // A feed move cuts from where the line before it ended to where it ends: both are
    // on the part.
    let mut feed: Vec<Vec<f64>> = Vec::new();
    let mut last: Option<&compensate::Sample> = None;
    for s in own() {
        if s.feed {
            feed.extend(last.map(|l| l.nominal.clone()));
            feed.push(s.nominal.clone());
        }
        last = Some(s);
    }
    let (maps, no_map) = match Layout::new(machine, kin, &nominal, &feed) {
        None => (
            Vec::new(),
            Some("the machine has fewer than two linear axes: there is no plane to map".into()),
        ),
        Some(layout) => {
            let texts: Vec<&str> = if options.at.is_empty() {
                vec![""]
            } else {
                options.at.iter().map(String::as_str).collect()
            };
            let mut maps = Vec::new();
            for text in texts {
                let at = crate::budget::parse_pose(machine, kin.axes(), text)
                    .map_err(|m| Error::Usage(format!("--at: {m}")))?;
                let given = |v: usize| {
                    let name = &axes[v].0;
                    text.split([',', ' '])
                        .filter_map(|p| p.split_once('='))
                        .any(|(n, _)| n.trim() == name)
                };
                if given(layout.u) || given(layout.v) {
                    return Err(Error::Usage(format!(
                        "--at {text}: {} and {} span the map's grid; give the other axes \
                         (the rotary axes, and {} to pick one level)",
                        axes[layout.u].0,
                        axes[layout.v].0,
                        layout.w.map_or("no other axis", |w| axes[w].0.as_str())
                    )));
                }
                let level_given = layout.w.is_some_and(given);
                maps.push(volume::map(
                    machine,
                    kin,
                    &layout,
                    &at,
                    level_given,
                    options.grid,
                ));
            }
            (maps, None)
        }
    };
    Ok(Report {
        names,
        machine_name: machine.name.clone(),
        summary,
        axes,
        chain,
        maps,
        no_map,
        thresholds: options.thresholds,
    })
}

impl Report {
    /// The compensated lines' samples.
    pub fn samples(&self) -> &[compensate::Sample] {
        self.summary.trace.as_deref().unwrap_or_default()
    }

    /// The page.
    pub fn html(&self) -> std::result::Result<String, String> {
        let samples = self.samples();
        let own: Vec<compensate::Sample> = samples
            .iter()
            .filter(|s| s.chain == self.chain)
            .cloned()
            .collect();
        let t = &self.thresholds;
        let tip_limit = plots::Limit {
            value: t.max_error_mm * 1e3,
            label: format!("--max-error {} µm", plots::short(t.max_error_mm * 1e3)),
        };
        let angle_limit = t.max_angle_urad.map(|a| plots::Limit {
            value: a,
            label: format!("--max-angle {} µrad", plots::short(a)),
        });
        let mut figures = vec![
            Figure {
                id: "tip-error".into(),
                heading: "Tool-tip error along the program".into(),
                text: "The distance between where the tool tip would be and where the program \
                       means it to be, at every compensated line (the largest of its pieces for \
                       arcs and split moves), as the error model predicts it: red without \
                       compensation, blue with the axis values nccomp writes (rounded to the \
                       machine's resolution). Logarithmic scale. The dashed line is --max-error: \
                       blue above it fails."
                    .into(),
                svg: plots::along_program(samples, plots::Along::Tip, Some(&tip_limit))?,
            },
            Figure {
                id: "direction-error".into(),
                heading: "Tool-direction error along the program".into(),
                text: "The angle between the tool's direction and the programmed one, red \
                       without compensation, blue compensated; the dashed line is --max-angle. \
                       Where nccomp cannot correct the direction (tilted working planes, \
                       singular poses) the two lines coincide: those lines are shaded and the \
                       plot says why."
                    .into(),
                svg: plots::along_program(samples, plots::Along::Direction, angle_limit.as_ref())?,
            },
            Figure {
                id: "corrections".into(),
                heading: "Correction per axis".into(),
                text: "What nccomp changes: the written minus the programmed value of every \
                       axis at the end of each compensated line; linear axes in µm, rotary \
                       axes in µrad (1000 µrad = 0.0573°)."
                    .into(),
                svg: plots::corrections(&own, &self.axes)?,
            },
        ];
        let max = self.maps.iter().map(Map::max_magnitude).fold(0.0, f64::max);
        for (k, m) in self.maps.iter().enumerate() {
            let beyond = if m.panels.iter().any(|p| p.beyond) {
                " Parts of this grid lie beyond the ends of an error table; the end values \
                 were used there."
            } else {
                ""
            };
            figures.push(Figure {
                id: format!("map-{k}"),
                heading: if m.label.is_empty() {
                    "Volumetric error of the machine".into()
                } else {
                    format!("Volumetric error of the machine at {}", m.label)
                },
                text: format!(
                    "The tool tip's error without compensation (reference tool) over a grid of \
                     {} × {} positions of {} and {} over the program's working volume (where \
                     its moves take them, with a margin), in the workpiece frame; the dashed \
                     box is the part, where its feed moves take them. The colour is its \
                     length, on one scale for all maps of this page; the arrows are its \
                     components along {} and {}, as the axis motion that would move the tip \
                     the same way.{beyond}",
                    m.u.positions.len(),
                    m.v.positions.len(),
                    m.u.name,
                    m.v.name,
                    m.u.name,
                    m.v.name
                ),
                svg: plots::map(m, max)?,
            });
        }
        let mut inputs = vec![
            ("Program", self.names.program.clone()),
            (
                "Machine",
                match &self.machine_name {
                    Some(name) => format!("{} ({name})", self.names.machine),
                    None => self.names.machine.clone(),
                },
            ),
            ("Errors", self.names.errors.clone()),
        ];
        if let Some(why) = &self.no_map {
            inputs.push(("Volumetric map", format!("none: {why}")));
        }
        Ok(html::page(
            &format!("nccomp report: {}", self.names.program),
            &inputs,
            &verdict::judge(&self.summary, t),
            &self.summary.to_string(),
            &figures,
        ))
    }
}

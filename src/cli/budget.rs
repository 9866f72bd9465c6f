//! `nccomp sensitivity` and `nccomp tolerance`: the error budget commands, and the machine,
//! budget file and poses they both set up.

use super::files::{destinations, print, write_all};
use crate::budget::study::{self, StudyOptions};
use crate::budget::{self, Poses, Probe, Term, budget_file, ranking, report, tolerance};
use crate::kinematics::Kinematics;
use crate::model::{ErrorModel, machine_file};
use std::path::{Path, PathBuf};

/// Output formats of the budget commands.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Format {
    Human,
    Csv,
    Json,
}

/// Where and how the budget commands look at the machine.
#[derive(clap::Args)]
struct BudgetCommon {
    /// Machine file (TOML).
    #[arg(long, short = 'm', value_name = "MACHINE.toml")]
    machine: PathBuf,
    /// Evaluate at this pose (axis values, e.g. X=50,Y=45,Z=5; axes left out are 0).
    /// Repeat for several poses (worst case / pooled over them). Overrides the budget file.
    #[arg(long, value_name = "POSE")]
    at: Vec<String>,
    /// Evaluate on a grid of N points per axis over its travel (default 3, or the budget
    /// file's [poses]).
    #[arg(long, value_name = "N", conflicts_with = "at")]
    grid: Option<usize>,
    /// The direction of the error that matters, in the workpiece frame, e.g. 0,0,1 (the
    /// budget file's `direction` by default, else Z).
    #[arg(
        long,
        value_name = "X,Y,Z",
        value_delimiter = ',',
        allow_hyphen_values = true
    )]
    direction: Vec<f64>,
    /// Tool chain on machines with several.
    #[arg(long, value_name = "NAME")]
    tool_chain: Option<String>,
    /// Active tool length in mm (default: the budget file's, else the machine's reference
    /// tool).
    #[arg(long, value_name = "MM")]
    tool_length: Option<f64>,
    /// Output format.
    #[arg(long, value_enum, default_value = "human")]
    format: Format,
}

#[derive(clap::Args)]
pub(super) struct SensitivityArgs {
    #[command(flatten)]
    common: BudgetCommon,
    /// Budget file (TOML) with the ranges of the terms to rank.
    #[arg(long, short = 'b', value_name = "BUDGET.toml")]
    budget: Option<PathBuf>,
    /// Terms of the parameter study, comma-separated (default: every error motion,
    /// rotary-axis location errors and one squareness per pair of linear axes).
    #[arg(long, value_name = "TERMS", value_delimiter = ',')]
    terms: Vec<String>,
    /// The unit of length terms in the study, µm.
    #[arg(long, value_name = "UM", default_value_t = 1.0)]
    unit_length: f64,
    /// The unit of angular terms in the study, µrad.
    #[arg(long, value_name = "URAD", default_value_t = 10.0)]
    unit_angle: f64,
    /// Sobol base sample size (overrides the budget file).
    #[arg(long, value_name = "N")]
    samples: Option<usize>,
    /// Seed of the Sobol sample (overrides the budget file).
    #[arg(long, value_name = "SEED")]
    seed: Option<u64>,
    /// Write an SVG bar chart of the ranking to this file (needs --budget).
    #[arg(long, value_name = "FILE.svg")]
    svg: Option<PathBuf>,
}

#[derive(clap::Args)]
pub(super) struct ToleranceArgs {
    #[command(flatten)]
    common: BudgetCommon,
    /// Budget file (TOML) with the [tolerance] table.
    #[arg(long, short = 'b', value_name = "BUDGET.toml")]
    budget: PathBuf,
}

/// What the budget commands share: the machine, the budget file, the probe's settings.
struct Setup {
    machine: crate::model::Machine,
    budget: Option<budget_file::Budget>,
    chain: usize,
    active: Vec<usize>,
    length: f64,
    poses: Poses,
    direction: nalgebra::Vector3<f64>,
}

fn setup(common: &BudgetCommon, budget: Option<&Path>) -> crate::Result<Setup> {
    let usage = |m: String| crate::Error::Usage(m);
    let machine = machine_file::load(&common.machine)?;
    let budget = budget
        .map(|b| budget_file::load(b, &machine, common.tool_chain.as_deref()))
        .transpose()?;
    let chain = match (&common.tool_chain, &budget) {
        (_, Some(b)) => b.chain,
        (Some(name), None) => machine.tool_chain(name).ok_or_else(|| {
            let names: Vec<String> = machine.tool_chains.iter().map(|c| c.name.clone()).collect();
            usage(format!(
                "the machine has no tool chain `{name}`: expected {}",
                names.join(", ")
            ))
        })?,
        (None, None) => 0,
    };
    let active = Kinematics::new(&machine, &ErrorModel::zero(&machine), chain)
        .map_err(|e| usage(e.to_string()))?
        .axes()
        .to_vec();
    let length = common
        .tool_length
        .or(budget.as_ref().map(|b| b.tool_length))
        .unwrap_or(machine.tool.length);
    let poses = if !common.at.is_empty() {
        let list = common
            .at
            .iter()
            .map(|p| budget::parse_pose(&machine, &active, p).map_err(usage))
            .collect::<crate::Result<Vec<_>>>()?;
        Poses::At(list)
    } else if let Some(n) = common.grid {
        Poses::Grid(n)
    } else if let Some(b) = &budget {
        b.poses.clone()
    } else {
        Poses::Grid(3)
    };
    let direction = match common.direction.as_slice() {
        [] => budget
            .as_ref()
            .map_or(nalgebra::Vector3::z(), |b| b.ranking.direction),
        &[x, y, z] if (x * x + y * y + z * z) > 0.0 && (x + y + z).is_finite() => {
            nalgebra::Vector3::new(x, y, z).normalize()
        }
        d => {
            return Err(usage(format!(
                "--direction {}: expected three numbers X,Y,Z of a non-zero direction, such as \
                 0,0,1",
                d.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            )));
        }
    };
    Ok(Setup {
        machine,
        budget,
        chain,
        active,
        length,
        poses,
        direction,
    })
}

pub(super) fn sensitivity(args: &SensitivityArgs) -> crate::Result<()> {
    let usage = |m: String| crate::Error::Usage(m);
    let [svg_to] = destinations(
        &[
            ("the machine file", Some(&args.common.machine)),
            ("the budget file", args.budget.as_deref()),
        ],
        [("--svg", args.svg.as_deref())],
    )?;
    let s = setup(&args.common, args.budget.as_deref())?;
    for (name, v) in [
        ("--unit-length", args.unit_length),
        ("--unit-angle", args.unit_angle),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(usage(format!("{name} {v}: expected a positive unit")));
        }
    }
    if args.svg.is_some() && s.budget.is_none() {
        return Err(usage(
            "--svg draws the ranking, which needs the ranges of a budget file (--budget)".into(),
        ));
    }
    let terms = if args.terms.is_empty() {
        budget::default_terms(&s.machine, &s.active)
    } else {
        args.terms
            .iter()
            .map(|t| Term::new(&s.machine, &s.active, t.trim()).map_err(usage))
            .collect::<crate::Result<Vec<_>>>()?
    };
    let probe = Probe::new(&s.machine, s.chain, s.length, &s.poses, terms)?;
    let options = StudyOptions {
        unit_length: args.unit_length * 1e-3,
        unit_angle: args.unit_angle * 1e-6,
    };
    let study = study::run(&probe, &options);

    let ranking = match &s.budget {
        Some(b) => {
            if b.ranges.is_empty() {
                return Err(usage(format!(
                    "{}: the budget file has no [ranges]: nothing to rank",
                    args.budget.as_deref().unwrap_or(Path::new("")).display()
                )));
            }
            let (terms, levels): (Vec<Term>, Vec<[f64; 3]>) = b.ranges.iter().cloned().unzip();
            let probe = Probe::new(&s.machine, s.chain, s.length, &s.poses, terms)?;
            let mut options = b.ranking.clone();
            options.direction = s.direction;
            if let Some(n) = args.samples {
                options.samples = n.max(2);
            }
            if let Some(seed) = args.seed {
                options.seed = seed;
            }
            Some(ranking::rank(&probe, &levels, &options))
        }
        None => None,
    };
    if let (Some(to), Some(r)) = (&svg_to, &ranking) {
        let name = s.machine.name.clone().unwrap_or_else(|| "machine".into());
        let svg = report::ranking_svg(r, &format!("Key errors of {name}"))
            .map_err(|m| usage(format!("cannot draw the ranking: {m}")))?;
        write_all(&[(to, svg.as_bytes())])?;
    }
    let text = match args.common.format {
        Format::Human => {
            let mut t = report::study_human(&study);
            if let Some(r) = &ranking {
                t.push('\n');
                t.push_str(&report::ranking_human(r));
            }
            t
        }
        Format::Csv => {
            let mut t = report::study_csv(&study);
            if let Some(r) = &ranking {
                t.push('\n');
                t.push_str(&report::ranking_csv(r));
            }
            t
        }
        Format::Json => report::Report {
            study: Some(&study),
            ranking: ranking.as_ref(),
            tolerance: None,
        }
        .json(),
    };
    print(&text)
}

pub(super) fn tolerance(args: &ToleranceArgs) -> crate::Result<()> {
    let s = setup(&args.common, Some(&args.budget))?;
    let b = s.budget.as_ref().expect("a budget file was given");
    let Some(spec) = &b.tolerance else {
        return Err(crate::Error::Usage(format!(
            "{}: the budget file has no [tolerance] table: nothing to design (see docs/budget.md)",
            args.budget.display()
        )));
    };
    let (terms, tol): (Vec<Term>, Vec<_>) = spec.terms.iter().cloned().unzip();
    let probe = Probe::new(&s.machine, s.chain, s.length, &s.poses, terms)?;
    let mut options = spec.options.clone();
    options.direction = s.direction;
    let design = tolerance::design(&probe, &tol, &options);
    let text = match args.common.format {
        Format::Human => report::design_human(&design),
        Format::Csv => report::design_csv(&design),
        Format::Json => report::Report {
            tolerance: Some(&design),
            ..Default::default()
        }
        .json(),
    };
    print(&text)
}

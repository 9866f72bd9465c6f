//! What `nccomp probe` prints: the delay, the map's directions and their speeds, and what
//! the program rewrite did; as a human table or as CSV.

use super::delay::DelayFit;
use super::map::DirectionMap;
use super::rewrite::{FeedEdit, RewriteSummary};
use super::speeds::SpeedPlan;
use super::{MapKind, Surface, speed_term};
use std::fmt::Write;

/// Where τ came from.
#[derive(Debug, Clone, PartialEq)]
pub enum Tau {
    Given(f64),
    Fitted { path: String, fit: DelayFit },
}

impl Tau {
    pub fn ms(&self) -> f64 {
        match self {
            Tau::Given(t) => *t,
            Tau::Fitted { fit, .. } => fit.tau_ms,
        }
    }
}

/// `x` with at most `decimals` decimals, without trailing zeros.
pub fn short(x: f64, decimals: usize) -> String {
    let s = format!("{x:.decimals$}");
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// The lines about τ.
pub fn tau_lines(tau: &Tau) -> String {
    match tau {
        Tau::Given(t) => format!("probe delay: τ = {} ms (given)\n", short(*t, 4)),
        Tau::Fitted { path, fit } => {
            let mut s = format!(
                "probe delay: τ = {:.3} ms, standard uncertainty {:.3} ms, from {path}: {} points at {} speeds",
                fit.tau_ms,
                fit.u_tau_ms,
                fit.points,
                fit.speeds.len()
            );
            if fit.groups > 1 {
                let _ = write!(s, " in {} directions", fit.groups);
            }
            let _ = writeln!(
                s,
                ", residual {:.2} µm; the radius {} with the speed, as on {} surface",
                fit.residual_std * 1000.0,
                match fit.surface {
                    Surface::Inside => "grows",
                    Surface::Outside => "shrinks",
                },
                match fit.surface {
                    Surface::Inside => "an inside",
                    Surface::Outside => "an outside",
                }
            );
            for l in &fit.speeds {
                let _ = writeln!(
                    s,
                    "  {:>8.1} mm/min: {:>4} points, mean radius {:.4} mm",
                    l.speed, l.count, l.mean_radius
                );
            }
            s
        }
    }
}

fn quantity(kind: MapKind) -> &'static str {
    match kind {
        MapKind::Radius => "trigger radius",
        MapKind::PreTravel => "pre-travel",
    }
}

/// The summary of the equalisation.
pub fn plan_lines(
    path: &str,
    map: &DirectionMap,
    plan: &SpeedPlan,
    kind: MapKind,
    tau_ms: f64,
) -> String {
    let (lo, hi) = map.beta_range();
    let speeds: Vec<f64> = map.points().iter().map(|p| p.speed).collect();
    let (vlo, vhi) = speeds
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let measured_at = if vhi - vlo < 1e-9 {
        format!("{vlo} mm/min")
    } else {
        format!("{vlo} … {vhi} mm/min")
    };
    let mut s = format!(
        "direction map {path}: {} directions in {} rings (β {lo}° … {hi}°), measured at {measured_at}\n",
        map.len(),
        map.ring_betas().len()
    );
    let what = quantity(kind);
    let _ = write!(
        s,
        "{what} variation: {:.2} µm measured → {:.2} µm predicted",
        plan.variation_before * 1000.0,
        plan.variation_after * 1000.0
    );
    if kind == MapKind::Radius {
        let _ = write!(
            s,
            " ({} refit{} of the centre; it moved {:.2} µm)",
            plan.iterations,
            if plan.iterations == 1 { "" } else { "s" },
            plan.centre_shift.norm() * 1000.0
        );
    }
    s.push('\n');
    let _ = writeln!(
        s,
        "speeds: {:.2} … {:.2} mm/min (mean {:.2}); the span is {:.2} µm of pre-travel at τ = {} ms",
        plan.min_speed(),
        plan.max_speed(),
        plan.mean_speed(),
        speed_term(plan.max_speed() - plan.min_speed(), tau_ms) * 1000.0,
        short(tau_ms, 3)
    );
    s
}

/// The table of directions: rings from the probe's plane towards the axis, α increasing.
pub fn direction_table(map: &DirectionMap, plan: &SpeedPlan, kind: MapKind) -> String {
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    let (m0, m1) = (mean(&plan.before), mean(&plan.predicted));
    let col = match kind {
        MapKind::Radius => "radius/mm",
        MapKind::PreTravel => "pre-travel/mm",
    };
    let mut s = format!(
        "{:>7} {:>6} {:>13} {:>9} {:>9} {:>9} {:>9}\n",
        "alpha/°", "beta/°", col, "dev/µm", "v0", "v", "pred/µm"
    );
    let mut order: Vec<usize> = (0..map.len()).collect();
    let pts = map.points();
    order.sort_by(|&a, &b| {
        let (da, db) = (pts[a].direction, pts[b].direction);
        da.beta
            .abs()
            .total_cmp(&db.beta.abs())
            .then(db.beta.total_cmp(&da.beta))
            .then(da.alpha.total_cmp(&db.alpha))
    });
    for i in order {
        let p = &pts[i];
        let _ = writeln!(
            s,
            "{:>7.1} {:>6.1} {:>13.6} {:>+9.2} {:>9.2} {:>9.2} {:>+9.2}",
            p.direction.alpha,
            p.direction.beta,
            p.radius,
            (plan.before[i] - m0) * 1000.0,
            p.speed,
            plan.speeds[i],
            (plan.predicted[i] - m1) * 1000.0
        );
    }
    s
}

/// The table as CSV: the map's columns, the new speed and the predicted value (mm). A map
/// measured again at `new_speed` can be fed back as a map with `speed` = `new_speed`.
pub fn direction_csv(map: &DirectionMap, plan: &SpeedPlan) -> String {
    let mut s = String::from("alpha,beta,radius,speed,new_speed,predicted_radius\n");
    for (i, p) in map.points().iter().enumerate() {
        let _ = writeln!(
            s,
            "{},{},{:.7},{},{:.3},{:.7}",
            p.direction.alpha,
            p.direction.beta,
            p.radius,
            p.speed,
            plan.speeds[i],
            plan.predicted[i]
        );
    }
    s
}

/// What the rewrite did, with ΔtR.
pub fn program_lines(path: &str, r: &RewriteSummary) -> String {
    let mut s = format!(
        "program {path}: {} lines, {} probing move{}: {} F word{} changed, {} added",
        r.lines,
        r.moves.len(),
        if r.moves.len() == 1 { "" } else { "s" },
        r.words_changed(),
        if r.words_changed() == 1 { "" } else { "s" },
        r.moves.iter().filter(|m| m.edit == FeedEdit::Added).count()
    );
    if !r.restored.is_empty() {
        let _ = write!(
            s,
            "; the original feed restored by an added F word at line{} {}",
            if r.restored.len() == 1 { "" } else { "s" },
            r.restored
                .iter()
                .map(|l| l.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    s.push('\n');
    if let Some(dt) = r.delta_t_r() {
        let _ = writeln!(
            s,
            "measuring time (Σ S/v over the probing moves): {:.4} → {:.4} min, ΔtR = {:+.1} %",
            r.time_before(),
            r.time_after(),
            dt * 100.0
        );
    }
    s
}

/// The table of probing moves.
pub fn moves_table(r: &RewriteSummary) -> String {
    let mut s = format!(
        "{:>6} {:>7} {:>6} {:>9} {:>9} {:>9}\n",
        "line", "alpha/°", "beta/°", "S/mm", "F before", "F after"
    );
    for m in &r.moves {
        let _ = writeln!(
            s,
            "{:>6} {:>7.1} {:>6.1} {:>9.3} {:>9.2} {:>9.2}{}",
            m.line,
            m.direction.alpha,
            m.direction.beta,
            m.length,
            m.old_feed,
            m.new_feed,
            if m.edit == FeedEdit::Added {
                "  (F added)"
            } else {
                ""
            }
        );
    }
    s
}

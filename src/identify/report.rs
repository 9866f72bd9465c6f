//! The separation table, laid out like paper 000's tables 2–3.

use super::decouple::{Decoupling, Identified};
use super::simulate::paper_symbol;

/// The table: one row per identified term with the paper's symbol, total, quasi-static and
/// dynamic values (µm or µrad) and the quasi-static value's standard uncertainty, then
/// the fit residuals and any combination of terms the plan cannot tell apart.
pub fn table(dec: &Decoupling, id: &Identified) -> String {
    let s = &id.separation;
    let mut out = format!(
        "{:<10} {:<17} {:>10} {:>13} {:>10} {:>8}\n",
        "term", "paper", "total", "quasi-static", "dynamic", "± (1σ)"
    );
    for (j, name) in s.names.iter().enumerate() {
        let (k, unit) = if dec.params.is_angle(j) {
            (1e6, "µrad")
        } else {
            (1e3, "µm")
        };
        out.push_str(&format!(
            "{name:<10} {:<17} {:>10.3} {:>13.3} {:>10.3} {:>8.3}  {unit}\n",
            paper_symbol(name),
            s.total[j] * k,
            s.quasi_static[j] * k,
            s.dynamic[j] * k,
            id.uncertainty[j] * k,
        ));
    }
    out.push_str(&format!(
        "\n{} points. Total = CMM − nominal, quasi-static = CMM − on-machine, dynamic = total − \
         quasi-static.\nResidual (RMS, what the model leaves): {:.3} µm total, {:.3} µm \
         quasi-static, {:.3} µm dynamic.\n",
        id.points,
        id.residual[0] * 1e3,
        id.residual[1] * 1e3,
        id.residual[2] * 1e3
    ));
    for combination in dec.unobservable() {
        let terms: Vec<String> = combination
            .iter()
            .map(|(n, w)| format!("{w:+.2}·{n}"))
            .collect();
        out.push_str(&format!(
            "warning: the plan cannot tell these terms apart (their values are arbitrary \
             along {}); add points that see them differently\n",
            terms.join(" ")
        ));
    }
    out
}

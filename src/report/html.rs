//! The report page: one self-contained HTML file, its plots inline SVG, no external
//! resource of any kind (no fonts, scripts or styles from elsewhere), so it can be
//! archived, mailed or attached to a CI run and opens the same everywhere.

use super::verdict::{Outcome, Verdict};
use std::fmt::Write;

/// One plot with its heading and a sentence on how to read it.
pub(super) struct Figure {
    pub id: String,
    pub heading: String,
    pub text: String,
    pub svg: String,
}

/// Text for HTML content and attribute values.
pub(super) fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

const STYLE: &str = "body{font-family:sans-serif;margin:24px;max-width:1240px;color:#222}\
h1{font-size:22px}h2{font-size:18px;margin-top:28px}\
pre.summary{background:#f4f4f4;padding:10px;font-size:13px;white-space:pre-wrap;\
overflow-wrap:anywhere}\
div.verdict{font-size:16px;padding:8px 12px;margin:12px 0;border-left:8px solid}\
div.verdict.pass{background:#e7f4e4;border-color:#2c8a2c}\
div.verdict.fail{background:#fbe5e5;border-color:#c62828}\
div.verdict.not-checked{background:#f4f4f4;border-color:#888}\
div.verdict b{margin-right:10px}div.verdict ul{margin:4px 0 0 0;padding-left:22px}\
figure{margin:8px 0}figure svg{max-width:100%;height:auto;display:block}\
p.how{font-size:14px;color:#444;max-width:1100px}\
table.inputs td{padding:2px 12px 2px 0;font-size:14px}";

/// After load, count each figure's drawn SVG elements with a non-zero box and put the
/// counts on `<body data-rendered="id:count ...">`, and list the elements wider than the
/// window or scrolling sideways on `data-overflow` (the page must read without
/// side-scrolling): what a headless browser test reads to see that the page rendered.
const MARKER: &str = "(function(){var c=[];\
document.querySelectorAll('figure').forEach(function(f){var n=0;\
f.querySelectorAll('svg *').forEach(function(e){if(typeof e.getBBox!=='function')return;\
var b=e.getBBox();if(b.width>0||b.height>0)n++;});c.push(f.id+':'+n);});\
document.body.setAttribute('data-rendered',c.join(' '));\
var o=[],w=document.documentElement.clientWidth;\
if(document.documentElement.scrollWidth>w)o.push('page');\
document.querySelectorAll('body *').forEach(function(e){var r=e.getBoundingClientRect();\
if(r.right>w+1||(e.scrollWidth>e.clientWidth+1&&e.clientWidth>0&&!(e instanceof SVGElement)))\
o.push(e.tagName.toLowerCase()+(e.id?'#'+e.id:'')+(e.className&&e.className.baseVal===undefined?'.'+e.className:''));});\
document.body.setAttribute('data-overflow',o.length?o.join(' '):'none');})();";

/// The page: title, the inputs, the pass/fail line, the run's summary and the figures
/// under their headings.
pub(super) fn page(
    title: &str,
    inputs: &[(&str, String)],
    verdict: &Verdict,
    summary: &str,
    figures: &[Figure],
) -> String {
    let mut out = String::new();
    let _ = write!(
        out,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"generator\" content=\"nccomp {}\">\n<title>{}</title>\n<style>{STYLE}</style>\n\
         </head>\n<body>\n<h1>{}</h1>\n<table class=\"inputs\">\n",
        env!("CARGO_PKG_VERSION"),
        escape(title),
        escape(title)
    );
    for (what, value) in inputs {
        let _ = writeln!(
            out,
            "<tr><td>{}</td><td>{}</td></tr>",
            escape(what),
            escape(value)
        );
    }
    let class = match verdict.outcome {
        Outcome::Pass => "pass",
        Outcome::Fail => "fail",
        Outcome::NotChecked => "not-checked",
    };
    let _ = write!(
        out,
        "</table>\n<div class=\"verdict {class}\" id=\"verdict\"><b>{}</b>predicted after \
         compensation, against the thresholds\n<ul>\n",
        verdict.outcome.word()
    );
    for line in &verdict.lines {
        let _ = writeln!(out, "<li>{}</li>", escape(line));
    }
    let _ = writeln!(
        out,
        "</ul></div>\n<pre class=\"summary\">{}</pre>",
        escape(summary)
    );
    for f in figures {
        let _ = write!(
            out,
            "<h2>{}</h2>\n<p class=\"how\">{}</p>\n<figure id=\"{}\">\n{}\n</figure>\n",
            escape(&f.heading),
            escape(&f.text),
            escape(&f.id),
            strip_prolog(&f.svg)
        );
    }
    let _ = write!(out, "<script>{MARKER}</script>\n</body>\n</html>\n");
    out
}

/// The SVG element alone (an XML declaration has no place inside HTML).
fn strip_prolog(svg: &str) -> &str {
    svg.find("<svg").map_or(svg, |i| &svg[i..]).trim_end()
}

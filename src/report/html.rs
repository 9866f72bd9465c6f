//! The report page: one self-contained HTML file, its plots inline SVG, no external
//! resource of any kind (no fonts, scripts or styles from elsewhere), so it can be
//! archived, mailed or attached to a CI run and opens the same everywhere.

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
pre{background:#f4f4f4;padding:10px;overflow-x:auto;font-size:13px}\
figure{margin:8px 0}figure svg{max-width:100%;height:auto;display:block}\
p.how{font-size:14px;color:#444;max-width:1100px}\
table.inputs td{padding:2px 12px 2px 0;font-size:14px}";

/// After load, count each figure's drawn SVG elements with a non-zero box and put the
/// counts on `<body data-rendered="id:count ...">`: what a headless browser test reads to
/// see that the plots rendered.
const MARKER: &str = "(function(){var c=[];\
document.querySelectorAll('figure').forEach(function(f){var n=0;\
f.querySelectorAll('svg *').forEach(function(e){if(typeof e.getBBox!=='function')return;\
var b=e.getBBox();if(b.width>0||b.height>0)n++;});c.push(f.id+':'+n);});\
document.body.setAttribute('data-rendered',c.join(' '));})();";

/// The page: title, the inputs, the run's summary and the figures under their headings.
pub(super) fn page(
    title: &str,
    inputs: &[(&str, String)],
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
    let _ = writeln!(
        out,
        "</table>\n<pre class=\"summary\">{}</pre>",
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

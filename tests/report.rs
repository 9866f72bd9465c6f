//! `nccomp report`: the numbers behind the plots, and the page rendered in headless
//! Chromium (a screenshot whose pixels must show the plots, and the DOM's count of drawn
//! SVG elements per figure).

use nccomp::model::{error_file, machine_file};
use nccomp::report::{self, Names, Options, plots};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[path = "common/skip.rs"]
mod skip;

const MACHINE: &str = "fixtures/ac_trunnion.machine.toml";
const ERRORS: &str = "fixtures/ac_trunnion.errors.toml";
const PROGRAM: &str = "fixtures/feature_workpiece.nc";

fn ac_report(options: &Options) -> report::Report {
    let machine = machine_file::load(Path::new(MACHINE)).unwrap();
    let errors = error_file::load(Path::new(ERRORS), &machine).unwrap();
    let src = std::fs::read(PROGRAM).unwrap();
    let names = Names {
        program: PROGRAM.into(),
        ..Names::default()
    };
    report::build(&machine, &errors, &src, names, options).unwrap()
}

#[test]
fn the_trace_follows_the_compensation_pass() {
    let r = ac_report(&Options {
        grid: 3,
        ..Options::default()
    });
    let s = &r.summary;
    let samples = r.samples();
    // One sample per compensated line, in program order.
    assert!(samples.len() >= 700, "{}", samples.len());
    assert!(samples.windows(2).all(|w| w[0].line < w[1].line));
    let max = |f: fn(&nccomp::compensate::Sample) -> f64| samples.iter().map(f).fold(0.0, f64::max);
    assert_eq!(max(|x| x.before_position), s.before_position.value);
    assert_eq!(max(|x| x.before_direction), s.before_direction.value);
    assert_eq!(max(|x| x.after_position), s.after_position.value);
    // The summary's "after" direction leaves singular blocks out; the trace keeps them.
    assert!(max(|x| x.after_direction) >= s.after_direction.value);
    assert!(max(|x| x.after_direction) >= s.singular_direction.value);
    // The line of the largest error is a sample's line.
    let at = samples
        .iter()
        .find(|x| x.before_position == s.before_position.value)
        .unwrap();
    assert_eq!(at.line, s.before_position.line);
    // Corrections: five axes everywhere, microns to tens of microns, and not all zero.
    assert!(
        samples
            .iter()
            .all(|x| x.nominal.len() == 5 && x.written.len() == 5)
    );
    let largest = samples
        .iter()
        .flat_map(|x| x.nominal.iter().zip(&x.written).map(|(n, w)| (w - n).abs()))
        .fold(0.0, f64::max);
    assert!(largest > 1e-3 && largest < 1.0, "{largest}");
}

#[test]
fn the_map_of_a_constant_positioning_error_is_uniform_along_its_axis() {
    // Three linear axes carrying the tool; EXX = +10 µm everywhere: the tip is 10 µm off
    // along +X at every grid point, at every level.
    let machine = machine_file::parse(
        "tool_chain = [\"X\", \"Y\", \"Z\"]\nworkpiece_chain = []\n\
         [axes.X]\nkind = \"linear\"\ndirection = [1, 0, 0]\ntravel = [-100, 100]\n\
         [axes.Y]\nkind = \"linear\"\ndirection = [0, 1, 0]\ntravel = [0, 50]\n\
         [axes.Z]\nkind = \"linear\"\ndirection = [0, 0, 1]\ntravel = [-10, 10]\n",
        "m.toml",
    )
    .unwrap();
    let errors = error_file::parse(
        "[motion.X]\npositions = [-100.0, 100.0]\nEXX = [10.0, 10.0]\n",
        "e.toml",
        &machine,
    )
    .unwrap();
    let names = Names::default();
    let options = Options {
        grid: 5,
        ..Options::default()
    };
    // The grid spans the program's working volume with a margin of a tenth of its larger
    // span (at least 10 mm), within the travel; the levels are the part's (its feed moves,
    // from where each starts to where it ends) lowest, middle and highest Z.
    let program = b"G0 X-50 Y0 Z5\nG1 X50 Y40 Z-5 F100\nG0 Z10\n";
    let r = report::build(&machine, &errors, program, names, &options).unwrap();
    assert_eq!(r.maps.len(), 1);
    let map = &r.maps[0];
    assert_eq!(map.u.positions, vec![-60.0, -30.0, 0.0, 30.0, 60.0]);
    assert_eq!(map.v.positions, vec![0.0, 12.5, 25.0, 37.5, 50.0]);
    assert_eq!(map.part, Some([[-50.0, 50.0], [0.0, 40.0]]));
    let levels: Vec<f64> = map
        .panels
        .iter()
        .map(|p| p.level.clone().unwrap().1)
        .collect();
    assert_eq!(levels, vec![-5.0, 0.0, 5.0]);
    let roles: Vec<_> = map.panels.iter().map(|p| p.role).collect();
    assert_eq!(roles, vec![Some("lowest"), Some("middle"), Some("highest")]);
    for p in &map.panels {
        assert_eq!(p.magnitude.len(), 25);
        for (m, a) in p.magnitude.iter().zip(&p.along) {
            assert!((m - 0.010).abs() < 1e-12, "{m}");
            assert!((a[0] - 0.010).abs() < 1e-12 && a[1].abs() < 1e-12, "{a:?}");
        }
    }
    // No angular error: the direction plot is a sentence, not a flat line at 1e-4 µrad;
    // the corrections of the one kind of axis are drawn.
    let html = r.html().unwrap();
    assert!(
        html.contains("predicts no tool-direction error for this program"),
        "{html}"
    );
    assert!(!html.contains("predicts no tool-tip error"));
    // A level picked in --at draws one panel; a grid axis in --at is refused.
    let one = Options {
        at: vec!["Z=5".into()],
        ..options.clone()
    };
    let r = report::build(
        &machine,
        &errors,
        b"G0 X1 Y0 Z0\nG1 X2\n",
        Names::default(),
        &one,
    )
    .unwrap();
    assert_eq!(r.maps[0].panels.len(), 1);
    assert_eq!(r.maps[0].panels[0].level, Some(("Z".into(), 5.0)));
    let bad = Options {
        at: vec!["X=5".into()],
        ..options
    };
    let e = report::build(
        &machine,
        &errors,
        b"G0 X1 Y0 Z0\nG1 X2\n",
        Names::default(),
        &bad,
    )
    .unwrap_err();
    assert!(e.to_string().contains("span the map's grid"), "{e}");
}

#[test]
fn the_page_is_self_contained() {
    let r = ac_report(&Options {
        at: vec!["A=-90,C=90".into()],
        grid: 5,
        ..Options::default()
    });
    let html = r.html().unwrap();
    assert!(html.starts_with("<!DOCTYPE html>"));
    for id in ["tip-error", "direction-error", "corrections", "map-0"] {
        assert!(
            html.contains(&format!("<figure id=\"{id}\">\n<svg")),
            "{id}"
        );
    }
    assert!(!html.contains("<?xml"));
    // Nothing is fetched from anywhere: no URL of any scheme (the SVG namespace is a
    // name, not a resource), no external reference.
    let text = html.replace("xmlns=\"http://www.w3.org/2000/svg\"", "");
    for needle in [
        "http:", "https:", "file:", "src=", "href=", "<link", "@import", "url(",
    ] {
        assert!(!text.contains(needle), "{needle}");
    }
    assert!(html.contains("A = -90°, C = 90°"));
}

// ------------------------------------------------------------------ headless Chromium

/// The browser: $NCCOMP_CHROMIUM, else Debian's `chromium` (or a Chrome) on the PATH.
fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("NCCOMP_CHROMIUM") {
        return Some(p.into());
    }
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .flat_map(|dir| {
            ["chromium", "chromium-browser", "google-chrome"]
                .into_iter()
                .map(move |name| dir.join(name))
        })
        .find(|p| p.is_file())
}

/// Run the browser headless on `page` with `extra` arguments, a fresh profile under `dir`;
/// its standard output.
fn run_chromium(browser: &Path, dir: &Path, page: &Path, extra: &[String]) -> Vec<u8> {
    let profile = tempfile::tempdir_in(dir).unwrap();
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
            "--force-device-scale-factor=1",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(extra)
        .arg(format!("file://{}", page.display()))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", browser.display()));
    let mut stdout = child.stdout.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut buf = Vec::new();
        std::io::Read::read_to_end(&mut stdout, &mut buf).map(|_| buf)
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > Duration::from_secs(90) {
            child.kill().ok();
            panic!("{} did not finish within 90 s", browser.display());
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let out = reader.join().unwrap().unwrap();
    if !status.success() {
        let mut err = String::new();
        if let Some(mut e) = child.stderr.take() {
            std::io::Read::read_to_string(&mut e, &mut err).ok();
        }
        panic!("{} failed ({status}): {err}", browser.display());
    }
    out
}

fn close(a: [u8; 3], b: plotters::style::RGBColor, tolerance: u8) -> bool {
    a[0].abs_diff(b.0) <= tolerance
        && a[1].abs_diff(b.1) <= tolerance
        && a[2].abs_diff(b.2) <= tolerance
}

/// The page width the report is read at (issue 36: "at 1400 px wide").
const WIDTH: usize = 1400;

/// A page rendered in headless Chromium: the DOM after the page's own script, and the
/// screenshot's pixels.
struct Rendered {
    dom: String,
    /// Pixel count per colour of the screenshot, greys apart.
    histogram: HashMap<[u8; 3], usize>,
    white: usize,
    grey: usize,
    height: usize,
}

impl Rendered {
    /// The value of the page's `<body data-NAME="…">`.
    fn marker(&self, name: &str) -> &str {
        self.dom
            .split(&format!("data-{name}=\""))
            .nth(1)
            .and_then(|s| s.split('"').next())
            .unwrap_or_else(|| {
                panic!(
                    "the page's script left no data-{name}: {}",
                    &self.dom[..self.dom.len().min(400)]
                )
            })
    }

    /// Drawn SVG elements with a non-zero box, per figure.
    fn counts(&self) -> HashMap<String, usize> {
        self.marker("rendered")
            .split_whitespace()
            .filter_map(|p| p.split_once(':'))
            .map(|(id, n)| (id.to_string(), n.parse().unwrap()))
            .collect()
    }

    /// Pixels within `tolerance` of `colour`.
    fn count(&self, colour: plotters::style::RGBColor, tolerance: u8) -> usize {
        self.histogram
            .iter()
            .filter(|(c, _)| close(**c, colour, tolerance))
            .map(|(_, n)| n)
            .sum()
    }

    /// The text of the figure `id` (its SVG's text elements, in order).
    fn figure_text(&self, id: &str) -> String {
        let start = self
            .dom
            .find(&format!("<figure id=\"{id}\""))
            .unwrap_or_else(|| panic!("no figure {id}"));
        let figure = &self.dom[start..];
        let figure = &figure[..figure.find("</figure>").unwrap_or(figure.len())];
        figure
            .split("<text")
            .skip(1)
            .filter_map(|t| t.split_once('>').map(|(_, rest)| rest))
            .filter_map(|t| t.split("</text>").next())
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// Write the report of `program` with `extra` options, render it in Chromium at `WIDTH`
/// pixels wide, and keep the screenshot as target/tmp/`name`.png.
fn render(browser: &Path, program: &str, extra: &[&str], name: &str) -> Rendered {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    let out = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args([
            "report",
            "-q",
            "--machine",
            MACHINE,
            "--errors",
            ERRORS,
            program,
        ])
        .args(extra)
        .arg("-o")
        .arg(&page)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    render_page(browser, &page, name)
}

fn render_page(browser: &Path, page: &Path, name: &str) -> Rendered {
    let dir = tempfile::tempdir().unwrap();
    // Tall enough for the whole page: the screenshot is of the window.
    let h = 5200usize;
    let shot = dir.path().join("report.png");
    let dom = run_chromium(
        browser,
        dir.path(),
        page,
        &[
            "--dump-dom".into(),
            format!("--screenshot={}", shot.display()),
            format!("--window-size={WIDTH},{h}"),
        ],
    );
    let dom = String::from_utf8(dom).unwrap();
    let bytes = std::fs::read(&shot).expect("chromium wrote no screenshot");
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width as usize, info.height as usize), (WIDTH, h));
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => panic!("unexpected screenshot colour type {other:?}"),
    };
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    // Greys (background, text, axes) are most of the page: counted apart.
    let (mut white, mut grey) = (0usize, 0usize);
    let mut histogram: HashMap<[u8; 3], usize> = HashMap::new();
    for px in buf[..info.buffer_size()].chunks_exact(channels) {
        if px[0] == px[1] && px[1] == px[2] {
            grey += 1;
            white += usize::from(px[0] == 255);
        } else {
            *histogram.entry([px[0], px[1], px[2]]).or_default() += 1;
        }
    }
    // Keep the screenshot where a person can look at it.
    let keep = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}.png"));
    std::fs::copy(&shot, &keep).unwrap();
    eprintln!("screenshot: {}", keep.display());
    Rendered {
        dom,
        histogram,
        white,
        grey,
        height: h,
    }
}

/// What every page must show: nothing wider than the window or scrolling sideways, the
/// pass/fail line with both thresholds, every plot drawn, the lines before and after
/// compensation and the map's colours on the screenshot.
fn assert_readable(r: &Rendered, maps: usize) {
    assert_eq!(
        r.marker("overflow"),
        "none",
        "elements wider than {WIDTH} px or scrolling sideways"
    );
    assert!(
        r.dom.contains("<div class=\"verdict ") && r.dom.contains("--max-error 10 µm"),
        "no pass/fail line"
    );
    assert!(r.dom.contains("--max-angle 100 µrad"), "no --max-angle");
    let counts = r.counts();
    let mut least = vec![
        ("tip-error".to_string(), 20),
        ("direction-error".to_string(), 20),
        ("corrections".to_string(), 30),
    ];
    // Panels of at least 9 × 9 cells, and the colour bar.
    least.extend((0..maps).map(|k| (format!("map-{k}"), 81 + 60)));
    for (id, least) in least {
        let n = counts.get(&id).copied().unwrap_or(0);
        assert!(
            n >= least,
            "figure {id}: {n} drawn elements, expected at least {least} ({counts:?})"
        );
    }
    let w = WIDTH;
    assert!(
        r.white < w * r.height * 9 / 10,
        "the page is nearly blank: {} white pixels",
        r.white
    );
    assert!(r.grey < w * r.height, "the page has no colour at all");
    let (before, after) = (r.count(plots::BEFORE, 8), r.count(plots::AFTER, 8));
    assert!(
        before > 1500,
        "the lines before compensation: {before} pixels"
    );
    assert!(after > 1500, "the lines after compensation: {after} pixels");
    let ramp: Vec<_> = (0..=512)
        .map(|k| plots::ramp(f64::from(k) / 512.0))
        .collect();
    let cells = r
        .histogram
        .iter()
        .filter(|(c, n)| **n >= 150 && ramp.iter().any(|q| close(**c, *q, 2)))
        .count();
    assert!(cells >= 10, "{cells} colours of the map's ramp fill cells");
    // The colour bar's ticks are round: 1, 2 or 5 × 10ⁿ steps from 0.
    for k in 0..maps {
        let text = r.figure_text(&format!("map-{k}"));
        // The colour bar is drawn last: its unit, then its ticks.
        let words: Vec<&str> = text.split_whitespace().collect();
        let unit = words
            .iter()
            .rposition(|t| *t == "µm")
            .unwrap_or(words.len());
        let ticks: Vec<f64> = words[(unit + 1).min(words.len())..]
            .iter()
            .map_while(|t| t.parse().ok())
            .collect();
        assert!(
            ticks.len() >= 4,
            "map-{k}: colour bar ticks {ticks:?} in {text}"
        );
        let step = ticks[1] - ticks[0];
        let mantissa = step / 10f64.powf(step.log10().floor());
        assert!(
            [1.0, 2.0, 5.0].iter().any(|m| (mantissa - m).abs() < 1e-6) && ticks[0] == 0.0,
            "map-{k}: colour bar ticks {ticks:?}"
        );
    }
}

/// The pass/fail line's background on the screenshot.
const FAIL: plotters::style::RGBColor = plotters::style::RGBColor(0xfb, 0xe5, 0xe5);
const PASS: plotters::style::RGBColor = plotters::style::RGBColor(0xe7, 0xf4, 0xe4);

fn browser_or_skip() -> Option<PathBuf> {
    let browser = chromium();
    if browser.is_none() {
        skip::skip(
            "chromium is not installed",
            "install Debian's `chromium` (.ci/run does) or set NCCOMP_CHROMIUM to a Chromium binary",
        );
    }
    browser
}

#[test]
fn the_feature_workpiece_report_reads_at_1400_px() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let r = render(
        &browser,
        PROGRAM,
        &["--at", "A=0,C=0", "--at", "A=-90,C=90", "--grid", "9"],
        "report-feature-workpiece",
    );
    assert_readable(&r, 2);
    // The singular poses hold C: the direction error there is above the default
    // --max-angle, and the plot says why the lines meet there.
    assert!(r.dom.contains("<b>FAIL</b>"), "no FAIL");
    assert!(
        r.count(FAIL, 0) > 20_000,
        "no red pass/fail line on the screenshot"
    );
    assert!(
        r.dom
            .contains("a singular pose: the rotary axis along the tool is held")
    );
    let direction = r.figure_text("direction-error");
    assert!(direction.contains("Violet band"), "{direction}");
    assert!(direction.contains("at a singular pose"), "{direction}");
    assert!(!direction.contains("Grey band"), "{direction}");
    // Three axes' corrections drawn in their colours.
    for (k, colour) in plots::AXIS_COLOURS.iter().take(3).enumerate() {
        let n = r.count(*colour, 8);
        assert!(n > 500, "the correction of axis {k}: {n} pixels");
    }
    // The parts of the maps: a dashed box per panel, labelled as the part's levels.
    let map = r.figure_text("map-0");
    assert!(map.contains("Dashed box: the part"), "{map}");
    assert!(map.contains("Over the part's grid points"), "{map}");
    assert!(map.contains("(lowest of the part)") && map.contains("(highest of the part)"));
}

#[test]
fn the_tnc_plane_program_report_reads_at_1400_px() {
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let r = render(
        &browser,
        "fixtures/tnc_ac_trunnion.h",
        &["--grid", "9", "--max-angle", "300"],
        "report-tnc-plane",
    );
    assert_readable_with(&r, "--max-angle 300 µrad");
    // In the working planes the direction is the control's: the plot says so.
    let direction = r.figure_text("direction-error");
    assert!(direction.contains("Grey band"), "{direction}");
    assert!(
        direction.contains("in a tilted working plane"),
        "{direction}"
    );
    assert!(direction.contains("FUNCTION TCPM"), "{direction}");
    assert!(r.dom.contains("<b>PASS</b>"), "no PASS");
    assert!(
        r.count(PASS, 0) > 20_000,
        "no green pass/fail line on the screenshot"
    );
    let corrections = r.figure_text("corrections");
    assert!(
        corrections.contains("no correction in the 37 lines in tilted working planes"),
        "{corrections}"
    );
}

/// `assert_readable` for a page with a `--max-angle` of its own.
fn assert_readable_with(r: &Rendered, angle: &str) {
    assert!(r.dom.contains(angle), "no {angle}");
    let dom = r.dom.replace(angle, "--max-angle 100 µrad");
    let r = Rendered {
        dom,
        histogram: r.histogram.clone(),
        white: r.white,
        grey: r.grey,
        height: r.height,
    };
    assert_readable(&r, 1);
}

#[test]
fn a_page_that_scrolls_sideways_fails_the_check() {
    // The check must be able to fail: the summary in a box that does not wrap, as it was.
    let Some(browser) = browser_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    let out = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(["report", "-q", "--machine", MACHINE, "--errors", ERRORS])
        .args(["fixtures/tnc_ac_trunnion.h", "--grid", "3", "-o"])
        .arg(&page)
        .output()
        .unwrap();
    assert!(out.status.success());
    let html = std::fs::read_to_string(&page).unwrap();
    let broken = html.replace("white-space:pre-wrap;", "white-space:pre;overflow-x:auto;");
    assert_ne!(broken, html);
    std::fs::write(&page, broken).unwrap();
    let r = render_page(&browser, &page, "report-broken");
    assert!(
        r.marker("overflow").contains("pre.summary"),
        "{}",
        r.marker("overflow")
    );
}

#[test]
fn cli_refuses_bad_requests_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    let bad_program = dir.path().join("g41.nc");
    std::fs::write(&bad_program, "G90 G1 X10 Y10 Z5 A0 C0\nG41 X10 Y10 D1\n").unwrap();
    let run = |extra: &[&str], program: &Path| {
        Command::new(env!("CARGO_BIN_EXE_nccomp"))
            .args(["report", "--machine", MACHINE, "--errors", ERRORS])
            .arg(program)
            .args(extra)
            .arg("-o")
            .arg(&page)
            .output()
            .unwrap()
    };
    for (extra, program, message) in [
        (
            &["--at", "X=5"][..],
            Path::new(PROGRAM),
            "span the map's grid",
        ),
        (&["--at", "A=1,Q=2"][..], Path::new(PROGRAM), "no axis `Q`"),
        (
            &["--grid", "500"][..],
            Path::new(PROGRAM),
            "--grid 500: expected 2 to 101",
        ),
        (
            &[][..],
            bad_program.as_path(),
            "error: G41 cannot be compensated: cutter radius compensation (G41/G42) is not supported\n --> ",
        ),
    ] {
        let out = run(extra, program);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(stderr.contains(message), "{extra:?}: {stderr}");
        assert!(!page.exists(), "{extra:?}");
    }
}

#[test]
fn a_zero_model_is_not_checked_and_draws_no_flat_map() {
    let machine = machine_file::load(Path::new(MACHINE)).unwrap();
    let errors = error_file::parse("", "zero.toml", &machine).unwrap();
    let src = std::fs::read(PROGRAM).unwrap();
    let options = Options {
        grid: 3,
        ..Options::default()
    };
    let r = report::build(&machine, &errors, &src, Names::default(), &options).unwrap();
    let html = r.html().unwrap();
    assert!(html.contains("<b>NOT CHECKED</b>"), "{html}");
    assert!(html.contains("the error model is zero"));
    assert!(html.contains("The error model predicts no tip error at A = 0°, C = 0°"));
    // Nothing flat is drawn: no colour bar, no cell.
    assert!(!html.contains(">µm<"));
}

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
    let r = report::build(&machine, &errors, b"G0 X10 Y10 Z0\n", names, &options).unwrap();
    assert_eq!(r.maps.len(), 1);
    let map = &r.maps[0];
    assert_eq!(map.u.positions, vec![-100.0, -50.0, 0.0, 50.0, 100.0]);
    assert_eq!(map.v.positions, vec![0.0, 12.5, 25.0, 37.5, 50.0]);
    let levels: Vec<f64> = map
        .panels
        .iter()
        .map(|p| p.level.clone().unwrap().1)
        .collect();
    assert_eq!(levels, vec![-10.0, 0.0, 10.0]);
    for p in &map.panels {
        assert_eq!(p.magnitude.len(), 25);
        for (m, a) in p.magnitude.iter().zip(&p.along) {
            assert!((m - 0.010).abs() < 1e-12, "{m}");
            assert!((a[0] - 0.010).abs() < 1e-12 && a[1].abs() < 1e-12, "{a:?}");
        }
    }
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

#[test]
fn the_report_renders_its_plots_in_headless_chromium() {
    let Some(browser) = chromium() else {
        skip::skip(
            "chromium is not installed",
            "install Debian's `chromium` (.ci/run does) or set NCCOMP_CHROMIUM to a Chromium binary",
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("report.html");
    let out = Command::new(env!("CARGO_BIN_EXE_nccomp"))
        .args(["report", "--machine", MACHINE, "--errors", ERRORS, PROGRAM])
        .args(["--at", "A=0,C=0", "--at", "A=-90,C=90", "--grid", "9", "-o"])
        .arg(&page)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // One browser run: the DOM after the page's own script, and a screenshot.
    let (w, h) = (1280usize, 4200usize);
    let shot = dir.path().join("report.png");
    let dom = run_chromium(
        &browser,
        dir.path(),
        &page,
        &[
            "--dump-dom".into(),
            format!("--screenshot={}", shot.display()),
            format!("--window-size={w},{h}"),
        ],
    );
    let dom = String::from_utf8(dom).unwrap();

    // The script's count of drawn elements with a non-zero box, per figure.
    let marker = dom
        .split("data-rendered=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .unwrap_or_else(|| {
            panic!(
                "the page's script left no marker: {}",
                &dom[..dom.len().min(400)]
            )
        });
    let counts: HashMap<&str, usize> = marker
        .split_whitespace()
        .filter_map(|p| p.split_once(':'))
        .map(|(id, n)| (id, n.parse().unwrap()))
        .collect();
    for (id, least) in [
        ("tip-error", 20),
        ("direction-error", 20),
        ("corrections", 30),
        // Three panels of 9 × 9 cells, and the colour bar.
        ("map-0", 3 * 81 + 60),
        ("map-1", 3 * 81 + 60),
    ] {
        let n = counts.get(id).copied().unwrap_or(0);
        assert!(
            n >= least,
            "figure {id}: {n} drawn elements, expected at least {least} ({marker})"
        );
    }

    // The screenshot: the plots' colours must be on it.
    let bytes = std::fs::read(&shot).expect("chromium wrote no screenshot");
    let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
        .read_info()
        .unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!((info.width as usize, info.height as usize), (w, h));
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
    let count = |colour: plotters::style::RGBColor| -> usize {
        histogram
            .iter()
            .filter(|(c, _)| close(**c, colour, 8))
            .map(|(_, n)| n)
            .sum()
    };
    assert!(
        white < w * h * 9 / 10,
        "the page is nearly blank: {white} white pixels"
    );
    assert!(grey < w * h, "the page has no colour at all");
    let (before, after) = (count(plots::BEFORE), count(plots::AFTER));
    assert!(
        before > 1500,
        "the lines before compensation: {before} pixels"
    );
    assert!(after > 1500, "the lines after compensation: {after} pixels");
    for (k, colour) in plots::AXIS_COLOURS.iter().take(3).enumerate() {
        let n = count(*colour);
        assert!(n > 500, "the correction of axis {k}: {n} pixels");
    }
    // The colour maps: many solid cells of distinct colours of the ramp.
    let ramp: Vec<_> = (0..=512)
        .map(|k| plots::ramp(f64::from(k) / 512.0))
        .collect();
    let cells = histogram
        .iter()
        .filter(|(c, n)| **n >= 150 && ramp.iter().any(|r| close(**c, *r, 2)))
        .count();
    assert!(cells >= 20, "{cells} colours of the map's ramp fill cells");
    // Keep the screenshot where a person can look at it.
    let keep = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    std::fs::copy(&shot, &keep).unwrap();
    eprintln!("screenshot: {}", keep.display());
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

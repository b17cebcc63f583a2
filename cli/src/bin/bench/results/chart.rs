//! SVG charts of recorded runs, drawn with plotters' SVG backend (text is
//! laid out by plotters' built-in metrics, so a chart is the same on every
//! machine): Mrays/s by workload and engine, packet and stream speed-up
//! over scalar, build time against triangle count, thread scaling.
//!
//! Bars are filled rectangles in the series' colour; legend swatches are
//! circles, so a chart's bars are exactly its coloured `<rect>`s.

use super::record::Record;
use super::table::{Group, first_seen};
use plotters::coord::Shift;
use plotters::prelude::*;

/// Series colours (Tableau 10, then a few more), in order of first use.
const PALETTE: [RGBColor; 12] = [
    RGBColor(0x4e, 0x79, 0xa7),
    RGBColor(0xf2, 0x8e, 0x2b),
    RGBColor(0xe1, 0x57, 0x59),
    RGBColor(0x76, 0xb7, 0xb2),
    RGBColor(0x59, 0xa1, 0x4f),
    RGBColor(0xed, 0xc9, 0x48),
    RGBColor(0xb0, 0x7a, 0xa1),
    RGBColor(0xff, 0x9d, 0xa7),
    RGBColor(0x9c, 0x75, 0x5f),
    RGBColor(0xba, 0xb0, 0xac),
    RGBColor(0x1b, 0x9e, 0x77),
    RGBColor(0x7d, 0x3c, 0x98),
];

/// Chart size in pixels.
const SIZE: (u32, u32) = (960, 520);

/// The colour of series `i`.
fn colour(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// A plotters error as text.
fn err(e: impl std::fmt::Display) -> String {
    format!("chart: {e}")
}

/// Draw on a fresh SVG canvas; the SVG text.
fn svg(
    size: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<(), String>,
) -> Result<String, String> {
    let mut out = String::new();
    {
        let root = SVGBackend::with_string(&mut out, size).into_drawing_area();
        root.fill(&WHITE).map_err(err)?;
        draw(&root)?;
        root.present().map_err(err)?;
    }
    Ok(out)
}

/// Grouped bars: one group per category (x axis), one bar per series
/// with a value there; series are `(name, value per category)`.
fn bars(
    size: (u32, u32),
    title: &str,
    y_desc: &str,
    categories: &[&str],
    series: &[(String, Vec<Option<f64>>)],
    reference: Option<f64>,
) -> Result<String, String> {
    let top = series
        .iter()
        .flat_map(|(_, v)| v.iter().flatten())
        .copied()
        .chain(reference)
        .fold(0.0f64, f64::max)
        * 1.15;
    let n = categories.len();
    svg(size, |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .build_cartesian_2d(-0.5f64..n as f64 - 0.5, 0.0f64..top.max(1e-9))
            .map_err(err)?;
        let name = |x: &f64| {
            let i = x.round();
            match categories.get(i as usize) {
                Some(c) if (x - i).abs() < 1e-6 && i >= 0.0 => c.to_string(),
                _ => String::new(),
            }
        };
        chart
            .configure_mesh()
            .disable_x_mesh()
            .max_light_lines(1)
            .x_labels(n.max(2))
            .x_label_formatter(&name)
            .x_label_style(("sans-serif", 12))
            .y_desc(y_desc)
            .draw()
            .map_err(err)?;
        // Each group 0.8 wide, split among the series.
        let width = 0.8 / series.len().max(1) as f64;
        for (i, (label, values)) in series.iter().enumerate() {
            let c = colour(i);
            chart
                .draw_series(values.iter().enumerate().filter_map(|(g, v)| {
                    let x0 = g as f64 - 0.4 + i as f64 * width;
                    v.map(|v| Rectangle::new([(x0, 0.0), (x0 + width * 0.9, v)], c.filled()))
                }))
                .map_err(err)?
                .label(label)
                .legend(move |(x, y)| Circle::new((x + 5, y), 5, c.filled()));
        }
        if let Some(y) = reference {
            chart
                .draw_series(LineSeries::new(
                    [(-0.5, y), (n as f64 - 0.5, y)],
                    BLACK.stroke_width(1),
                ))
                .map_err(err)?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .position(SeriesLabelPosition::UpperRight)
            .draw()
            .map_err(err)
    })
}

/// Lines with points: series are `(name, [(x, y)])`; log axes on request.
fn lines(
    title: &str,
    (x_desc, y_desc): (&str, &str),
    series: &[(String, Vec<(f64, f64)>)],
    log: bool,
) -> Result<String, String> {
    let points = || series.iter().flat_map(|(_, p)| p.iter().copied());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in points() {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (1.0, 2.0, 1.0, 2.0);
    }
    svg(SIZE, |root| {
        let mut builder = ChartBuilder::on(root);
        builder
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64);
        macro_rules! draw {
            ($chart:expr) => {{
                let mut chart = $chart.map_err(err)?;
                let whole = |x: &f64| {
                    if log || x.fract() == 0.0 {
                        format!("{x}")
                    } else {
                        String::new()
                    }
                };
                chart
                    .configure_mesh()
                    .max_light_lines(1)
                    .x_label_formatter(&whole)
                    .x_desc(x_desc)
                    .y_desc(y_desc)
                    .draw()
                    .map_err(err)?;
                for (i, (label, pts)) in series.iter().enumerate() {
                    let c = colour(i);
                    chart
                        .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))
                        .map_err(err)?
                        .label(label)
                        .legend(move |(x, y)| Circle::new((x + 5, y), 5, c.filled()));
                    chart
                        .draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))
                        .map_err(err)?;
                }
                chart
                    .configure_series_labels()
                    .background_style(WHITE.mix(0.85))
                    .border_style(BLACK)
                    .position(if log {
                        SeriesLabelPosition::UpperLeft
                    } else {
                        SeriesLabelPosition::UpperRight
                    })
                    .draw()
                    .map_err(err)
            }};
        }
        if log {
            draw!(builder.build_cartesian_2d(
                (x0 / 2.0..x1 * 2.0).log_scale(),
                (y0 / 2.0..y1 * 2.0).log_scale()
            ))
        } else {
            draw!(builder.build_cartesian_2d(x0 - 0.5..x1 + 1.5, 0.0..y1 * 1.15))
        }
    })
}

/// Per group: Mrays/s by workload (groups of bars) and engine (series).
pub fn mrays(group: &Group) -> Result<String, String> {
    let workloads = group.workloads();
    let series: Vec<(String, Vec<Option<f64>>)> = group
        .engines()
        .into_iter()
        .map(|e| {
            let v = workloads
                .iter()
                .map(|w| group.line(&e, w).map(|r| r.mrays))
                .collect();
            (e, v)
        })
        .collect();
    bars(
        SIZE,
        &format!("{}: Mrays/s", group.title()),
        "Mrays/s",
        &workloads,
        &series,
        None,
    )
}

/// Per group: each packet, stream or group mode's speed-up over its own
/// accel's scalar mode, by workload; `None` when no accel has both.
pub fn speedup(group: &Group) -> Result<Option<String>, String> {
    let workloads = group.workloads();
    let mut series = Vec::new();
    for e in group.engines() {
        let Some((accel, mode)) = e.split_once(' ') else {
            continue;
        };
        if mode == "scalar" {
            continue;
        }
        let scalar = format!("{accel} scalar");
        let v: Vec<Option<f64>> = workloads
            .iter()
            .map(|w| {
                let s = group.line(&scalar, w)?;
                let m = group.line(&e, w)?;
                (s.mrays > 0.0).then(|| m.mrays / s.mrays)
            })
            .collect();
        if v.iter().any(Option::is_some) {
            series.push((e, v));
        }
    }
    if series.is_empty() {
        return Ok(None);
    }
    bars(
        SIZE,
        &format!("{}: speed-up over scalar", group.title()),
        "× scalar of the same accel",
        &workloads,
        &series,
        Some(1.0),
    )
    .map(Some)
}

/// The summary chart (the README's): for each scene at its fewest threads
/// and each workload, every accel's best line over the baseline's best
/// (its `NAME-...` variants included), so the baseline is the line at 1;
/// `None` when the baseline did not run.
pub fn summary(groups: &[Group], baseline: &str) -> Result<Option<String>, String> {
    let mut chosen: Vec<&Group> = Vec::new();
    for g in groups {
        if !chosen.iter().any(|c| c.scene == g.scene) {
            chosen.push(g);
        }
    }
    let mut categories = Vec::new();
    let mut best = Vec::new();
    for g in &chosen {
        for w in g.workloads() {
            if let Some(b) = g.best_of(baseline, w).filter(|b| b.mrays > 0.0) {
                // `cornell_box` as `cornell`: sixteen labels share one axis.
                let scene = g.scene.split('_').next().unwrap_or(g.scene);
                categories.push(format!("{scene} {w}"));
                best.push((*g, w, b));
            }
        }
    }
    if categories.is_empty() {
        return Ok(None);
    }
    let accels = first_seen(
        chosen
            .iter()
            .flat_map(|g| g.records.iter())
            .filter(|r| !r.is_of(baseline))
            .map(|r| r.accel.as_str()),
    );
    let series: Vec<(String, Vec<Option<f64>>)> = accels
        .into_iter()
        .map(|a| {
            let v = best
                .iter()
                .map(|(g, w, b)| {
                    g.records
                        .iter()
                        .filter(|r| r.accel == a && r.workload == *w)
                        .filter(|r| r.fingerprint.is_none() || r.fingerprint == b.fingerprint)
                        .map(|r| r.mrays / b.mrays)
                        .reduce(f64::max)
                })
                .collect();
            (format!("{a} best"), v)
        })
        .collect();
    let threads = chosen.iter().map(|g| g.threads).max().unwrap_or(1);
    let labels: Vec<&str> = categories.iter().map(String::as_str).collect();
    bars(
        (1600, 520),
        &format!(
            "Best Mrays/s of each engine over {baseline}'s best ({threads} thread{})",
            if threads == 1 { "" } else { "s" }
        ),
        &format!("× {baseline}'s best"),
        &labels,
        &series,
        Some(1.0),
    )
    .map(Some)
}

/// Build seconds against triangles, one series per accel, over every
/// scene of the fewest threads; `None` when no line has a build time.
pub fn build(records: &[Record]) -> Result<Option<String>, String> {
    let Some(threads) = records.iter().map(|r| r.threads).min() else {
        return Ok(None);
    };
    let chosen: Vec<&Record> = records
        .iter()
        .filter(|r| r.threads == threads && r.build_seconds.is_some_and(|s| s > 0.0))
        .collect();
    let mut series = Vec::new();
    for accel in first_seen(chosen.iter().map(|r| r.accel.as_str())) {
        let mut pts: Vec<(f64, f64)> = Vec::new();
        for r in chosen.iter().filter(|r| r.accel == accel) {
            let p = (r.triangles as f64, r.build_seconds.unwrap_or(0.0));
            if !pts.iter().any(|q| q.0 == p.0) {
                pts.push(p);
            }
        }
        pts.sort_by(|a, b| a.0.total_cmp(&b.0));
        // A variant sharing its engine's build (embree-coherent) adds no line.
        let shared = series
            .iter()
            .any(|(name, theirs): &(String, Vec<(f64, f64)>)| {
                accel
                    .strip_prefix(name.as_str())
                    .is_some_and(|r| r.starts_with('-'))
                    && pts.iter().all(|p| theirs.contains(p))
            });
        if !shared {
            series.push((accel.to_string(), pts));
        }
    }
    if series.is_empty() {
        return Ok(None);
    }
    lines(
        &format!(
            "Build time against triangles ({threads} thread{})",
            if threads == 1 { "" } else { "s" }
        ),
        ("triangles", "build seconds"),
        &series,
        true,
    )
    .map(Some)
}

/// Per scene run at several thread counts: each accel's best Mrays/s
/// (over its modes) against threads, one series per accel and workload;
/// `None` for a single thread count.
pub fn threads(scene: &str, records: &[&Record]) -> Result<Option<String>, String> {
    let mut counts = first_seen(records.iter().map(|r| r.threads));
    if counts.len() < 2 {
        return Ok(None);
    }
    counts.sort_unstable();
    let mut series = Vec::new();
    for (accel, workload) in first_seen(records.iter().map(|r| (&r.accel, &r.workload))) {
        let best = |t: u64| {
            records
                .iter()
                .filter(|r| &r.accel == accel && &r.workload == workload && r.threads == t)
                .map(|r| r.mrays)
                .reduce(f64::max)
        };
        let pts: Vec<(f64, f64)> = counts
            .iter()
            .filter_map(|&t| best(t).map(|m| (t as f64, m)))
            .collect();
        // Lines only: an accel that ran at one thread count scales nothing.
        if pts.len() > 1 {
            series.push((format!("{accel} best, {workload}"), pts));
        }
    }
    lines(
        &format!("{scene}: thread scaling (each accel's best mode)"),
        ("threads", "Mrays/s"),
        &series,
        false,
    )
    .map(Some)
}

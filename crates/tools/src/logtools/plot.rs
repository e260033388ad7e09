//! `dima log plot FILE -o OUT.png [--what imu|gnss|outputs|latency|track]`: a PNG with a real
//! time axis from the recorded timestamps, units on the axes, a legend and the mode changes
//! marked; `track` draws the GNSS path in local metres over the mission and the fence (see
//! `plot_track`), `latency` the wake-up latency histogram.

use std::ops::Range;
use std::path::Path;
use std::sync::Once;

use anyhow::Context;
use dima_core::Mode;
use dima_log::schema::Event;
use dima_sensorboard::units;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use dima_log::schema::ReplayMessage;

use super::plot_math::{
    align_turns, angle_lines, heading_lines, latency_histogram, split_at_gaps,
    HEADING_MIN_SPEED_M_S, LATENCY_MAX_BUCKETS, MAX_GAP_S,
};
use super::read::{LoggedRun, Timed};

/// What to plot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum What {
    /// Accelerometer (m/s²) and yaw rate (°/s) over time.
    Imu,
    /// GNSS ground speed (m/s) and heading of motion (°) over time.
    Gnss,
    /// Servo targets (µs) over time.
    Outputs,
    /// Wake-up latency histogram (µs).
    Latency,
    /// The GNSS track in local metres (east, north), with the mission and the fence.
    Track,
}

/// Which cycles a plot draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Source {
    /// The recorded cycles (`/dima/cycle`).
    Cycle,
    /// The replayed cycles of a comparison file (`/replay/cycle`) beside the recorded ones:
    /// `outputs` draws both servo targets, `gnss` the replayed estimate beside GNSS and the
    /// setpoints.
    Replay,
}

/// The font family of every plot.
pub(super) const FONT: &str = "sans-serif";

/// Registers the bundled font once (text is drawn without system fonts).
fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        );
    });
}

/// The colour of `mode` in every plot.
pub(super) fn mode_color(mode: Mode) -> RGBColor {
    match mode {
        Mode::Killed => RGBColor(90, 90, 90),
        Mode::Manual => RGBColor(30, 120, 220),
        Mode::Auto => RGBColor(30, 160, 60),
        Mode::Failsafe => RGBColor(220, 40, 40),
    }
}

/// `(min, max)` of `values` with a margin; a flat or empty series gets a unit range.
fn span(values: impl Iterator<Item = f64>) -> Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return 0.0..1.0;
    }
    let pad = ((hi - lo) * 0.05).max(0.5);
    (lo - pad)..(hi + pad)
}

/// A named series drawn as lines (broken where data is missing).
type Series = (&'static str, RGBColor, Vec<Vec<(f64, f64)>>);

/// A time chart of `series` with the mode changes as vertical lines.
fn time_chart(
    area: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
    run: &LoggedRun,
    title: &str,
    y_desc: &str,
    series: &[Series],
) -> anyhow::Result<()> {
    let t_end = run
        .cycles
        .last()
        .map_or(1.0, |c| run.seconds(c.t_ns))
        .max(0.1);
    let y = span(
        series
            .iter()
            .flat_map(|s| s.2.iter().flatten().map(|p| p.1)),
    );
    let mut chart: ChartContext<BitMapBackend, Cartesian2d<RangedCoordf64, RangedCoordf64>> =
        ChartBuilder::on(area)
            .caption(title, (FONT, 22))
            .margin(12)
            .x_label_area_size(44)
            .y_label_area_size(70)
            .build_cartesian_2d(0.0..t_end, y.clone())?;
    chart
        .configure_mesh()
        .x_desc("time since the first cycle (s)")
        .y_desc(y_desc)
        .label_style((FONT, 15))
        .draw()?;
    for (name, color, lines) in series {
        let c = *color;
        let style = c.stroke_width(2);
        // One path per line (a gap in the data is a gap in the plot); a lone point is a dot.
        chart
            .draw_series(
                lines
                    .iter()
                    .filter(|l| l.len() > 1)
                    .map(move |line| PathElement::new(line.clone(), style)),
            )?
            .label(*name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart.draw_series(
            lines
                .iter()
                .filter(|l| l.len() == 1)
                .map(move |l| Circle::new(l[0], 2, c.filled())),
        )?;
    }
    for s in run
        .states
        .iter()
        .filter(|s| s.msg.events.contains(&Event::ModeChanged))
    {
        let t = run.seconds(s.t_ns);
        let c = mode_color(s.msg.mode);
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(t, y.start), (t, y.end)],
            c.mix(0.8).stroke_width(1),
        )))?;
        chart.draw_series(std::iter::once(Text::new(
            s.msg.mode.name().to_owned(),
            (t, y.end),
            (FONT, 14).into_font().color(&c),
        )))?;
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    Ok(())
}

/// `(time, value)` of every cycle, `None` where the cycle has no value.
fn cycle_samples(
    run: &LoggedRun,
    f: impl Fn(&dima_log::schema::CycleMessage) -> Option<f64>,
) -> Vec<(f64, Option<f64>)> {
    run.cycles
        .iter()
        .map(|c| (run.seconds(c.t_ns), f(&c.msg)))
        .collect()
}

/// A value of every cycle as lines, broken where cycles have no value or are missing.
fn cycle_series(
    run: &LoggedRun,
    f: impl Fn(&dima_log::schema::CycleMessage) -> Option<f64>,
) -> Vec<Vec<(f64, f64)>> {
    split_at_gaps(&cycle_samples(run, f), MAX_GAP_S)
}

/// `(time, heading of motion, ground speed)` of every new GNSS fix with a valid position
/// (the packets of the cycles between fixes repeat the last one).
fn gnss_fixes(run: &LoggedRun) -> Vec<(f64, Option<f64>, Option<f64>)> {
    let mut last_itow = None;
    let mut out = Vec::new();
    for c in &run.cycles {
        let Some(s) = &c.msg.sensor else { continue };
        if s.itow_ms.is_none() || s.itow_ms == last_itow {
            continue;
        }
        last_itow = s.itow_ms;
        let t = run.seconds(c.t_ns);
        if !s.gnss_fix_ok {
            out.push((t, None, None));
            continue;
        }
        out.push((
            t,
            s.head_mot_deg,
            s.g_speed_mm_s.map(|v| f64::from(v) / 1e3),
        ));
    }
    out
}

fn imu(
    run: &LoggedRun,
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let accel = |i: usize| {
        cycle_series(run, move |c| {
            c.sensor
                .as_ref()
                .map(|s| f64::from(units::accel_m_s2_2g(s.accel[i])))
        })
    };
    time_chart(
        &top,
        run,
        "accelerometer",
        "acceleration (m/s²)",
        &[
            ("x", RED, accel(0)),
            ("y", GREEN, accel(1)),
            ("z", BLUE, accel(2)),
        ],
    )?;
    let gyro_z = cycle_series(run, |c| c.sensor.as_ref().map(|s| f64::from(s.gyro_z_dps)));
    time_chart(
        &bottom,
        run,
        "gyroscope",
        "yaw rate, gyro z (°/s)",
        &[("gyro z", MAGENTA, gyro_z)],
    )
}

fn gnss(
    run: &LoggedRun,
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    gnss_with_estimate(run, None, root)
}

/// GNSS ground speed and heading of motion with their setpoints; with `replayed`, the
/// replayed estimate beside them. The heading is unwrapped, drawn only above
/// [`HEADING_MIN_SPEED_M_S`], and every line breaks where data is missing.
fn gnss_with_estimate(
    run: &LoggedRun,
    replayed: Option<&[Timed<ReplayMessage>]>,
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
    let fixes = gnss_fixes(run);
    let speed_samples: Vec<(f64, Option<f64>)> = fixes.iter().map(|f| (f.0, f.2)).collect();
    let speed = split_at_gaps(&speed_samples, MAX_GAP_S);
    let setpoint = cycle_series(run, |c| c.setpoints.speed_mm_s.map(|v| f64::from(v) / 1e3));
    let estimate = |f: fn(&ReplayMessage) -> Option<f64>| {
        replayed.map(|r| {
            let samples: Vec<(f64, Option<f64>)> =
                r.iter().map(|m| (run.seconds(m.t_ns), f(&m.msg))).collect();
            samples
        })
    };
    let mut speeds = vec![
        ("GNSS ground speed", BLUE, speed),
        ("setpoint", RED, setpoint),
    ];
    if let Some(samples) = estimate(|m| m.estimate.speed_mm_s.map(|s| f64::from(s.value) / 1e3)) {
        speeds.push((
            "replayed estimate",
            GREEN,
            split_at_gaps(&samples, MAX_GAP_S),
        ));
    }
    time_chart(&top, run, "ground speed", "speed (m/s)", &speeds)?;
    let heading = heading_lines(&fixes, HEADING_MIN_SPEED_M_S, MAX_GAP_S);
    let setpoint = angle_lines(&cycle_samples(run, |c| c.setpoints.heading_deg), MAX_GAP_S);
    // Setpoint and estimate in the turn of the measured heading beside them.
    let setpoint = align_turns(&setpoint, &heading);
    let replayed_heading = estimate(|m| m.estimate.heading_deg.map(|h| f64::from(h.value)))
        .map(|samples| align_turns(&angle_lines(&samples, MAX_GAP_S), &heading));
    let mut headings = vec![
        ("GNSS heading of motion", BLUE, heading),
        ("setpoint", RED, setpoint),
    ];
    if let Some(lines) = replayed_heading {
        headings.push(("replayed estimate", GREEN, lines));
    }
    time_chart(
        &bottom,
        run,
        &format!("heading of motion (drawn above {HEADING_MIN_SPEED_M_S} m/s)"),
        "heading, unwrapped (° from north)",
        &headings,
    )
}

fn outputs(
    run: &LoggedRun,
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    let target = |i: usize| cycle_series(run, move |c| Some(f64::from(c.targets_us[i])));
    time_chart(
        root,
        run,
        "servo targets",
        "pulse width (µs)",
        &[
            ("throttle", RED, target(0)),
            ("steering", BLUE, target(1)),
            ("tail", GREEN, target(2)),
        ],
    )
}

fn latency(
    run: &LoggedRun,
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    let values: Vec<f64> = run.cycles.iter().map(|c| c.msg.wake_latency_us).collect();
    let h = latency_histogram(&values, LATENCY_MAX_BUCKETS);
    let max_count = h.counts.iter().copied().max().unwrap_or(1).max(1);
    let w = h.width_us;
    let mut chart = ChartBuilder::on(root)
        .caption(
            format!(
                "wake-up latency ({} samples; up to the 99.9th percentile, {} beyond {} µs)",
                values.len(),
                h.beyond,
                h.top_us
            ),
            (FONT, 22),
        )
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(0u32..h.top_us, (1u64..max_count * 2).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(format!("latency (µs, {w} µs buckets)"))
        .y_desc("cycles (log scale)")
        .label_style((FONT, 15))
        .draw()?;
    chart
        .draw_series(
            h.counts
                .iter()
                .enumerate()
                .filter(|(_, &n)| n > 0)
                .map(|(i, &n)| {
                    let x0 = i as u32 * w;
                    Rectangle::new([(x0, 1), (x0 + w, n.max(1))], BLUE.mix(0.7).filled())
                }),
        )?
        .label(format!("cycles per {w} µs bucket"))
        .legend(|(x, y)| Rectangle::new([(x, y - 5), (x + 20, y + 5)], BLUE.mix(0.7).filled()));
    chart
        .configure_series_labels()
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

/// Bucket counts of a cyclictest-format histogram (`NNNNNN COUNT` lines, 1 µs buckets).
pub fn parse_histogram(text: &str) -> Vec<u64> {
    let mut buckets = Vec::new();
    for line in text.lines() {
        let mut fields = line.split_whitespace();
        let (Some(us), Some(n), None) = (fields.next(), fields.next(), fields.next()) else {
            continue;
        };
        let (Ok(us), Ok(n)) = (us.parse::<usize>(), n.parse::<u64>()) else {
            continue;
        };
        if us >= buckets.len() {
            buckets.resize(us + 1, 0);
        }
        buckets[us] += n;
    }
    buckets
}

/// Histograms (name, 1 µs bucket counts) side by side as fractions of their samples, up to the
/// largest 99.9th percentile.
pub fn histograms(
    series: &[(String, Vec<u64>)],
    title: &str,
    path: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    fonts();
    let p999 = |b: &[u64]| {
        let total: u64 = b.iter().sum();
        let mut seen = 0;
        b.iter()
            .position(|&n| {
                seen += n;
                seen * 1000 >= total * 999
            })
            .unwrap_or(b.len())
    };
    let top = series
        .iter()
        .map(|(_, b)| p999(b))
        .max()
        .unwrap_or(10)
        .max(10) as u32
        + 1;
    let fraction = |b: &[u64], us: usize| {
        let total: u64 = b.iter().sum();
        b.get(us).map_or(0.0, |&n| n as f64 / total.max(1) as f64)
    };
    let peak = series
        .iter()
        .flat_map(|(_, b)| (0..top as usize).map(move |us| fraction(b, us)))
        .fold(0.0, f64::max);
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT, 22))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(70)
        .build_cartesian_2d(0.0..f64::from(top), 0.0..peak * 1.1 + 1e-9)?;
    chart
        .configure_mesh()
        .x_desc("latency (µs, 1 µs buckets)")
        .y_desc("fraction of wake-ups")
        .label_style((FONT, 15))
        .draw()?;
    let colors = [BLUE, RED, GREEN, MAGENTA];
    let width = 1.0 / series.len().max(1) as f64;
    for (k, (name, b)) in series.iter().enumerate() {
        let c = colors[k % colors.len()];
        chart
            .draw_series((0..top as usize).map(|us| {
                let x0 = us as f64 + k as f64 * width;
                Rectangle::new(
                    [(x0, 0.0), (x0 + width, fraction(b, us))],
                    c.mix(0.75).filled(),
                )
            }))?
            .label(name.as_str())
            .legend(move |(x, y)| {
                Rectangle::new([(x, y - 5), (x + 20, y + 5)], c.mix(0.75).filled())
            });
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// The replayed servo targets (thick) over the recorded ones (thin, lighter) of each channel.
fn replay_outputs(
    run: &LoggedRun,
    replayed: &[Timed<ReplayMessage>],
    root: &DrawingArea<BitMapBackend, plotters::coord::Shift>,
) -> anyhow::Result<()> {
    let series = |i: usize, recorded: bool| -> Vec<Vec<(f64, f64)>> {
        let samples: Vec<(f64, Option<f64>)> = replayed
            .iter()
            .map(|r| {
                let t = if recorded {
                    r.msg.recorded_targets_us[i]
                } else {
                    r.msg.targets_us[i]
                };
                (run.seconds(r.t_ns), Some(f64::from(t)))
            })
            .collect();
        split_at_gaps(&samples, MAX_GAP_S)
    };
    time_chart(
        root,
        run,
        "servo targets: replayed (new configuration) and recorded",
        "pulse width (µs)",
        &[
            (
                "throttle recorded",
                RGBColor(240, 160, 160),
                series(0, true),
            ),
            (
                "steering recorded",
                RGBColor(150, 170, 240),
                series(1, true),
            ),
            ("tail recorded", RGBColor(150, 210, 150), series(2, true)),
            ("throttle replayed", RED, series(0, false)),
            ("steering replayed", BLUE, series(1, false)),
            ("tail replayed", GREEN, series(2, false)),
        ],
    )
}

/// Draws `what` of the comparison file `run` with its replayed cycles `replayed` (see
/// [`Source::Replay`]) into a PNG of `size` pixels at `path`.
///
/// # Errors
/// `what` is not `outputs` or `gnss`, or the file cannot be written.
pub fn plot_replay(
    run: &LoggedRun,
    replayed: &[Timed<ReplayMessage>],
    what: What,
    path: &Path,
    size: (u32, u32),
) -> anyhow::Result<()> {
    if !matches!(what, What::Outputs | What::Gnss) {
        anyhow::bail!("--channel replay plots --what outputs or --what gnss");
    }
    fonts();
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    match what {
        What::Gnss => gnss_with_estimate(run, Some(replayed), &root)?,
        _ => replay_outputs(run, replayed, &root)?,
    }
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Draws `what` of `run` into a PNG of `size` pixels at `path`.
pub fn plot(run: &LoggedRun, what: What, path: &Path, size: (u32, u32)) -> anyhow::Result<()> {
    fonts();
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    match what {
        What::Imu => imu(run, &root)?,
        What::Gnss => gnss(run, &root)?,
        What::Outputs => outputs(run, &root)?,
        What::Latency => latency(run, &root)?,
        What::Track => super::plot_track::track(run, &root)?,
    }
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixture's drive turned by `degrees`: its heading of motion crosses north.
    fn turned_drive(degrees: f64) -> LoggedRun {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../tests/fixtures/auto-pid-before-plugins.mcap"
        );
        let mut run = LoggedRun::read(Path::new(path)).unwrap();
        for c in &mut run.cycles {
            if let Some(h) = c.msg.sensor.as_mut().and_then(|s| s.head_mot_deg.as_mut()) {
                *h = (*h + degrees).rem_euclid(360.0);
            }
        }
        run
    }

    #[test]
    fn the_gnss_plot_of_a_drive_across_north_has_no_vertical_bar() {
        // Turned so that the AUTO leg's heading is near north: both sides of 0/360° occur.
        let run = turned_drive(240.0);
        let fixes = gnss_fixes(&run);
        let raw: Vec<f64> = fixes.iter().filter_map(|f| f.1).collect();
        assert!(raw.iter().any(|h| *h < 20.0) && raw.iter().any(|h| *h > 340.0));
        let lines = heading_lines(&fixes, HEADING_MIN_SPEED_M_S, MAX_GAP_S);
        assert!(!lines.is_empty());
        for line in &lines {
            for pair in line.windows(2) {
                assert!((pair[1].1 - pair[0].1).abs() < 90.0, "{pair:?}");
            }
        }
        // Drawn only while moving: no point of a fix slower than the threshold.
        let drawn: usize = lines.iter().map(Vec::len).sum();
        let moving = fixes
            .iter()
            .filter(|f| f.1.is_some() && f.2.is_some_and(|v| v >= HEADING_MIN_SPEED_M_S))
            .count();
        assert_eq!(drawn, moving);
        let png = std::env::temp_dir().join(format!("dima-plot-north-{}.png", std::process::id()));
        plot(&run, What::Gnss, &png, (900, 500)).unwrap();
        assert!(std::fs::metadata(&png).unwrap().len() > 1_000);
        if std::env::var_os("DIMA_KEEP_PLOTS").is_none() {
            std::fs::remove_file(&png).unwrap();
        }
    }
}

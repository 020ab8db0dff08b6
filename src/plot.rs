//! SVG plots (plotters), shared by the matrix report and the studies: one way to draw a plot
//! into a string, one palette, one legend style, and a numbered key for scatter plots whose
//! points are too many to label in place.

use plotters::coord::Shift;
use plotters::coord::combinators::{BindKeyPoints, LogCoord, WithKeyPoints};
use plotters::coord::ranged1d::Ranged;
use plotters::prelude::*;

/// One plot: its file name, title and SVG text.
#[derive(Clone, Debug)]
pub struct Plot {
    pub file: String,
    pub title: String,
    pub svg: String,
    /// Its own size, pixels: a page lays it out at this size (or narrower) before the
    /// file loads.
    pub size: (u32, u32),
}

pub type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

pub const FONT: &str = "sans-serif";

/// Draw `file` at `size` pixels: `draw` paints on a white area and returns None when it
/// has nothing to show (or failed), and then there is no plot.
pub fn svg(
    file: &str,
    title: &str,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Option<()>,
) -> Option<Plot> {
    let mut svg = String::new();
    {
        let area = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        area.fill(&WHITE).ok()?;
        draw(&area)?;
        area.present().ok()?;
    }
    Some(Plot {
        file: file.into(),
        title: title.into(),
        svg,
        size,
    })
}

/// The i-th colour of Tableau 20: the ten hues, then their light tints.
pub fn series_color(i: usize) -> RGBColor {
    const COLORS: [RGBColor; 20] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
        RGBColor(174, 199, 232),
        RGBColor(255, 187, 120),
        RGBColor(152, 223, 138),
        RGBColor(255, 152, 150),
        RGBColor(197, 176, 213),
        RGBColor(196, 156, 148),
        RGBColor(247, 182, 210),
        RGBColor(199, 199, 199),
        RGBColor(219, 219, 141),
        RGBColor(158, 218, 229),
    ];
    COLORS[i % COLORS.len()]
}

/// A log axis over `lo..hi` (positive) labelled at round numbers (`log_ticks`), with no
/// light grid lines between them: dense lines made a grey band.
pub type LogAxis = WithKeyPoints<LogCoord<f64>>;

pub fn log_axis(lo: f64, hi: f64) -> LogAxis {
    (lo..hi).log_scale().with_key_points(log_ticks(lo, hi))
}

/// Round numbers within `lo..=hi` to label a log axis with, far enough apart on it never to
/// overprint: powers of ten over 2.5 decades or more (every second or third one past 7
/// decades), 1, 2 and 5 times them over one to 2.5 decades, 1, 2, 3, 5 and 7 times them
/// under a decade, and where that leaves fewer than two, about four even steps.
pub fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo > 0.0 && hi > lo && hi.is_finite()) {
        return Vec::new();
    }
    let decades = (hi / lo).log10();
    let mantissas: &[f64] = if decades >= 2.5 {
        &[1.0]
    } else if decades >= 1.0 {
        &[1.0, 2.0, 5.0]
    } else {
        &[1.0, 2.0, 3.0, 5.0, 7.0]
    };
    let every = (decades / 7.0).ceil().max(1.0) as i32;
    let mut ticks = Vec::new();
    for k in (lo.log10().floor() as i32)..=(hi.log10().ceil() as i32) {
        if k.rem_euclid(every) != 0 {
            continue;
        }
        for m in mantissas {
            let v = round_significant(m * 10f64.powi(k));
            if (lo..=hi).contains(&v) {
                ticks.push(v);
            }
        }
    }
    if ticks.len() < 2 {
        let step = nice_step((hi - lo) / 4.0);
        let first = (lo / step).ceil() as i64;
        ticks = (first..)
            .map(|i| round_significant(i as f64 * step))
            .take_while(|&v| v <= hi)
            .collect();
    }
    ticks
}

/// 1, 2 or 5 times a power of ten, the nearest at or above `x`.
fn nice_step(x: f64) -> f64 {
    let power = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * power)
        .find(|&s| s >= x)
        .unwrap_or(10.0 * power)
}

/// `v` to 12 significant digits: `0.1 * 3` is `0.3`, as a label should say.
fn round_significant(v: f64) -> f64 {
    if v == 0.0 {
        return 0.0;
    }
    let scale = 10f64.powi(11 - v.abs().log10().floor() as i32);
    (v * scale).round() / scale
}

/// A tick label: a whole number without a decimal point (`10000`, not `10000.0`), others to
/// three significant digits, very small or large ones in exponent form.
pub fn tick_label(v: &f64) -> String {
    let v = *v;
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e6).contains(&a) {
        return format!("{v:.0e}");
    }
    if (v - v.round()).abs() < 1e-9 * a.max(1.0) {
        return format!("{}", v.round() as i64);
    }
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// Width of the legend column beside a plot's data.
pub const LEGEND_WIDTH: u32 = 300;

/// `area` split into the data's part and a legend column of [`LEGEND_WIDTH`] at its right:
/// a legend never covers a line or a point.
pub fn legend_column<'a>(area: &Area<'a>) -> (Area<'a>, Area<'a>) {
    let width = area.dim_in_pixel().0 as i32;
    area.split_horizontally(width - LEGEND_WIDTH as i32)
}

/// A series' entry in a legend: its name, colour and marker (a series index whose marker
/// it shows; None: a line alone).
pub type Entry = (String, RGBColor, Option<usize>);

/// The legend of series named `names`, in order: the i-th in series i's colour and marker.
pub fn series_legend<S: AsRef<str>>(names: impl IntoIterator<Item = S>) -> Vec<Entry> {
    names
        .into_iter()
        .enumerate()
        .map(|(i, name)| (name.as_ref().to_string(), series_color(i), Some(i)))
        .collect()
}

/// The legend in its own column (`legend_column`): per series its marker on a short line in
/// its colour, and its name.
pub fn side_legend(area: &Area, title: &str, entries: &[Entry]) -> Option<()> {
    let line = 17;
    area.draw(&Text::new(
        title.to_string(),
        (6, 16),
        (FONT, KEY_FONT + 1).into_font().style(FontStyle::Bold),
    ))
    .ok()?;
    for (k, (name, color, i)) in entries.iter().enumerate() {
        let y = 36 + line * k as i32;
        let color = *color;
        area.draw(&PathElement::new(
            vec![(6, y), (6 + LEGEND_SWATCH, y)],
            color.stroke_width(2),
        ))
        .ok()?;
        if let Some(i) = i {
            draw_marker(area, *i, (6 + LEGEND_SWATCH / 2, y), color)?;
        }
        area.draw(&Text::new(
            name.clone(),
            (12 + LEGEND_SWATCH, y - 7),
            (FONT, KEY_FONT).into_font().color(&RGBColor(30, 30, 30)),
        ))
        .ok()?;
    }
    Some(())
}

/// The width of a legend entry's line, pixels.
const LEGEND_SWATCH: i32 = 20;

/// Marker size, pixels from the centre.
const MARKER_SIZE: i32 = 4;

/// The shape of series i's markers: circles for the first ten colours, then squares,
/// triangles and crosses, so two series of like colours still differ.
#[derive(Clone, Copy)]
enum Shape {
    Circle,
    Square,
    Triangle,
    Cross,
}

fn shape(i: usize) -> Shape {
    match (i / 10) % 4 {
        0 => Shape::Circle,
        1 => Shape::Square,
        2 => Shape::Triangle,
        _ => Shape::Cross,
    }
}

/// Draw series i's marker at pixel `at` of `area` (a legend's).
fn draw_marker(area: &Area, i: usize, at: (i32, i32), color: RGBColor) -> Option<()> {
    let (fill, r) = (color.filled(), MARKER_SIZE);
    let (x, y) = at;
    match shape(i) {
        Shape::Circle => area.draw(&Circle::new(at, r, fill)),
        Shape::Square => area.draw(&Rectangle::new([(x - r, y - r), (x + r, y + r)], fill)),
        Shape::Triangle => area.draw(&TriangleMarker::new(at, r + 1, fill)),
        Shape::Cross => area.draw(&Cross::new(at, r, color.stroke_width(2))),
    }
    .ok()
}

/// Series `i` in its colour and marker: a line through `points`, a marker at each. Its
/// legend entry is the i-th of `series_legend`.
pub fn line_with_points<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    points: Vec<(f64, f64)>,
    i: usize,
) -> Option<()>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let color = series_color(i);
    let (line, fill, r) = (color.stroke_width(2), color.filled(), MARKER_SIZE);
    chart
        .draw_series(LineSeries::new(points.clone(), line))
        .ok()?;
    match shape(i) {
        Shape::Circle => chart.draw_series(points.iter().map(|&p| Circle::new(p, r, fill))),
        Shape::Square => chart.draw_series(
            points
                .iter()
                .map(|&p| EmptyElement::at(p) + Rectangle::new([(-r, -r), (r, r)], fill)),
        ),
        Shape::Triangle => {
            chart.draw_series(points.iter().map(|&p| TriangleMarker::new(p, r + 1, fill)))
        }
        Shape::Cross => chart.draw_series(points.iter().map(|&p| Cross::new(p, r, line))),
    }
    .ok()?;
    Some(())
}

/// The legend of a chart built on `area` with `.margin_right(LEGEND_WIDTH)`: in that margin,
/// beside the data, never over a line or a point.
pub fn legend(area: &Area, entries: &[Entry]) -> Option<()> {
    let (w, h) = area.dim_in_pixel();
    let strip = area
        .clone()
        .shrink((w - LEGEND_WIDTH, 20), (LEGEND_WIDTH, h - 20));
    side_legend(&strip, "", entries)
}

/// The smallest text a plot that must read at its natural size asks for: plotters' SVG
/// writes a font of size s as s / 1.24 px, so 14 shows at 11.3 px, 11 px or more on a page
/// 1024 px wide (`tests/page.rs` measures it in a browser).
pub const KEY_FONT: u32 = 14;
/// A key line's height, and the characters a key line holds before it wraps.
const KEY_LINE: u32 = 17;
const KEY_WRAP: usize = 44;
/// About how wide a character of [`KEY_FONT`] is (a sans-serif digit is 0.55 of the size).
const KEY_CHAR: f64 = 0.6 * KEY_FONT as f64;

/// A key entry's lines: `n  name`, the name wrapped at [`KEY_WRAP`] characters (at a `_`,
/// `,` or `[` where there is one), never cut.
fn key_lines(n: usize, name: &str) -> Vec<String> {
    let mut lines = Vec::new();
    let mut rest = name;
    let mut first = true;
    while !rest.is_empty() {
        let cut = if rest.chars().count() <= KEY_WRAP {
            rest.len()
        } else {
            let head: String = rest.chars().take(KEY_WRAP).collect();
            head.rfind(['_', ',', '['])
                .filter(|&k| k > KEY_WRAP / 2)
                .map_or(head.len(), |k| k + 1)
        };
        let (line, tail) = rest.split_at(cut);
        lines.push(if first {
            format!("{n:>2}  {line}")
        } else {
            format!("     {line}")
        });
        first = false;
        rest = tail;
    }
    lines
}

/// The size a [`numbered_key`] of `entries` takes: every entry whole, at [`KEY_FONT`].
pub fn key_size(entries: &[(String, RGBColor)]) -> (u32, u32) {
    let lines: Vec<String> = entries
        .iter()
        .enumerate()
        .flat_map(|(i, (name, _))| key_lines(i + 1, name))
        .collect();
    let widest = lines.iter().map(|l| l.chars().count()).max().unwrap_or(0);
    let width = 24 + (widest as f64 * KEY_CHAR).ceil() as u32;
    (width, 44 + KEY_LINE * lines.len() as u32)
}

/// A key beside a scatter plot whose points carry numbers instead of names: one entry per
/// point, `n  name` in the entry's colour, long names wrapped, never cut (size the area
/// with [`key_size`]). Names never overlap, however close the points.
pub fn numbered_key(area: &Area, title: &str, entries: &[(String, RGBColor)]) -> Option<()> {
    area.draw(&Text::new(
        title.to_string(),
        (4, 18),
        (FONT, KEY_FONT + 1).into_font().style(FontStyle::Bold),
    ))
    .ok()?;
    let mut y = 40;
    for (i, (name, color)) in entries.iter().enumerate() {
        area.draw(&Circle::new((10, y + 6), 4, color.filled()))
            .ok()?;
        for line in key_lines(i + 1, name) {
            area.draw(&Text::new(
                line,
                (20, y),
                (FONT, KEY_FONT).into_font().color(&RGBColor(40, 40, 40)),
            ))
            .ok()?;
            y += KEY_LINE as i32;
        }
    }
    Some(())
}

/// Each point's number in a numbered key, drawn above and right of the point, not under it;
/// a number that would overprint one already placed moves up a line until it does not (a
/// thin line leads back to its point), so points piled on one spot stay told apart.
pub fn number_points<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    points: &[(f64, f64)],
) -> Option<()>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let size = KEY_FONT + 1;
    let style = (FONT, size).into_font().color(&RGBColor(20, 20, 20));
    let mut placed: Vec<[i32; 4]> = Vec::new();
    let mut labels = Vec::new();
    for (i, &p) in points.iter().enumerate() {
        let (px, py) = chart.backend_coord(&p);
        let text = format!("{}", i + 1);
        let w = (text.len() as f64 * 0.6 * size as f64).ceil() as i32 + 2;
        let h = size as i32 + 1;
        let mut dy = -17;
        let boxed = |dy: i32| [px + 5, py + dy, px + 5 + w, py + dy + h];
        let overlaps = |b: &[i32; 4], placed: &[[i32; 4]]| {
            placed
                .iter()
                .any(|q| b[0] < q[2] && q[0] < b[2] && b[1] < q[3] && q[1] < b[3])
        };
        while overlaps(&boxed(dy), &placed) && dy > -17 - 40 * h {
            dy -= h;
        }
        placed.push(boxed(dy));
        labels.push((p, text, dy));
    }
    for (p, text, dy) in labels {
        let lead = (dy < -17)
            .then(|| PathElement::new(vec![(2, -2), (4, dy + 14)], RGBColor(160, 160, 160)));
        chart
            .draw_series(std::iter::once(
                EmptyElement::at(p) + Text::new(text, (5, dy), style.clone()),
            ))
            .ok()?;
        if let Some(lead) = lead {
            chart
                .draw_series(std::iter::once(EmptyElement::at(p) + lead))
                .ok()?;
        }
    }
    Some(())
}

#[cfg(test)]
mod key_tests {
    use super::*;

    /// A long name wraps at a separator and keeps every character; a short one is one line.
    #[test]
    fn a_key_wraps_long_names_and_cuts_none() {
        let long = "clustered_deferred_16x16x24_with_a_very_long_suffix[grid=32x18x48]";
        let lines = key_lines(7, long);
        assert!(lines.len() >= 2, "{lines:?}");
        let joined: String = lines
            .iter()
            .enumerate()
            .map(|(k, l)| if k == 0 { &l[4..] } else { &l[5..] })
            .collect();
        assert_eq!(joined, long);
        assert!(lines.iter().all(|l| l.chars().count() <= KEY_WRAP + 5));
        assert_eq!(key_lines(12, "forward_plus"), ["12  forward_plus"]);
    }
}

/// A point of a time-against-error plot ([`time_error`]).
pub struct TimeErrorPoint {
    /// The median frame, ms, and its 95% interval where there is one.
    pub ms: f64,
    pub interval: Option<[f64; 2]>,
    /// RMSE in 8-bit LSB (drawn at [`ERROR_FLOOR`] where below it).
    pub error: f64,
    /// Its name in the key (with any mark, `* ` for the front).
    pub name: String,
    pub color: RGBColor,
    /// On the decided Pareto front: the staircase joins these.
    pub on_front: bool,
}

/// Errors below this show at it on the log axis (an exact image has RMSE 0), inside a
/// band that says so.
pub const ERROR_FLOOR: f64 = 1e-3;

/// A time-against-error plot's data area (left of its key), pixels: with the key beside
/// it, the whole stays under the 960 px a page 1024 px wide gives a figure, so that it
/// shows at its own size and its text at [`KEY_FONT`] or more.
const TIME_ERROR_PLOT: (u32, u32) = (500, 460);

/// The key of a time-against-error plot.
fn time_error_key(points: &[TimeErrorPoint]) -> Vec<(String, RGBColor)> {
    points.iter().map(|p| (p.name.clone(), p.color)).collect()
}

/// The height of a legend of `entries` above the key: a title line and a line each.
fn legend_height(entries: usize) -> u32 {
    40 + 17 * (entries as u32 + 1)
}

/// The size of a [`time_error`] plot: its data area and a key that holds every name whole.
pub fn time_error_size(points: &[TimeErrorPoint], legend: usize) -> (u32, u32) {
    let (kw, kh) = key_size(&time_error_key(points));
    let (w, h) = TIME_ERROR_PLOT;
    (
        w + kw.max(LEGEND_WIDTH - 80),
        h.max(legend_height(legend) + kh),
    )
}

/// GPU time (each point's 95% interval a bar) against error, both log: exact points sit in
/// a band at the floor, the decided Pareto front is a staircase, every point is numbered
/// and the key beside it names each (size the area with [`time_error_size`]). False where
/// there are under two points.
pub fn time_error(
    area: &Area,
    points: &[TimeErrorPoint],
    legend: &[Entry],
    y_desc: &str,
) -> Result<bool, Box<dyn std::error::Error>> {
    if points.len() < 2 {
        return Ok(false);
    }
    let (plot_area, key_area) = area.split_horizontally(TIME_ERROR_PLOT.0);
    let (plot_area, _) = plot_area.split_vertically(TIME_ERROR_PLOT.1);
    let ends = points.iter().flat_map(|p| {
        let [lo, hi] = p.interval.unwrap_or([p.ms, p.ms]);
        [p.ms, lo, hi]
    });
    let (lo, hi) = ends.fold((f64::INFINITY, 0f64), |(lo, hi), v| (lo.min(v), hi.max(v)));
    let (t0, t1) = (lo.max(1e-4) / 1.5, hi.max(1e-3) * 1.5);
    let floored = |e: f64| e.max(ERROR_FLOOR);
    let e1 = points.iter().map(|p| floored(p.error)).fold(0.1, f64::max) * 3.0;
    let font = (FONT, KEY_FONT + 1);
    let mut chart = ChartBuilder::on(&plot_area)
        .margin(16)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(log_axis(t0, t1), log_axis(ERROR_FLOOR / 2.0, e1))?;
    chart
        .configure_mesh()
        .light_line_style(TRANSPARENT)
        .x_desc("GPU time per frame, ms (log; bars: 95% interval)")
        .y_desc(y_desc)
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .label_style(font)
        .axis_desc_style(font)
        .draw()?;
    chart.draw_series(std::iter::once(Rectangle::new(
        [(t0, ERROR_FLOOR / 2.0), (t1, ERROR_FLOOR * 1.6)],
        RGBColor(232, 240, 232).filled(),
    )))?;
    chart.draw_series(std::iter::once(Text::new(
        "RMSE 0: exact",
        (t0 * 1.05, ERROR_FLOOR * 1.5),
        (FONT, KEY_FONT).into_font().color(&RGBColor(60, 110, 60)),
    )))?;
    // The decided front: a staircase from the fastest down to the most faithful.
    let mut front: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p.on_front)
        .map(|p| (p.ms, floored(p.error)))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let stairs: Vec<(f64, f64)> = front
        .windows(2)
        .flat_map(|w| [w[0], (w[1].0, w[0].1)])
        .chain(front.last().copied())
        .collect();
    chart.draw_series(LineSeries::new(stairs, BLACK.stroke_width(2)))?;
    chart.draw_series(points.iter().filter_map(|p| {
        let [lo, hi] = p.interval?;
        let e = floored(p.error);
        Some(PathElement::new(
            vec![(lo, e), (hi, e)],
            p.color.stroke_width(2),
        ))
    }))?;
    chart.draw_series(
        points
            .iter()
            .map(|p| Circle::new((p.ms, floored(p.error)), 5, p.color.filled())),
    )?;
    let at: Vec<(f64, f64)> = points.iter().map(|p| (p.ms, floored(p.error))).collect();
    number_points(&mut chart, &at).ok_or("the point numbers did not draw")?;
    let mut entries = vec![("Pareto front (decided)".to_string(), BLACK, None)];
    entries.extend(legend.iter().cloned());
    let (legend_area, key_area) = key_area.split_vertically(legend_height(legend.len()));
    side_legend(&legend_area, "", &entries).ok_or("the legend did not draw")?;
    numbered_key(
        &key_area,
        "* = Pareto front, ? = undecided",
        &time_error_key(points),
    )
    .ok_or("the key did not draw")?;
    Ok(true)
}

/// One panel of [`against_lights`]: its label, the values that set its range, and one line
/// of (lights, value) points per named series.
pub struct Panel<'a> {
    pub label: &'a str,
    pub values: Vec<f64>,
    pub series: Vec<(&'a str, Vec<(f64, f64)>)>,
}

/// Panels side by side, each log-log against the light count from `lights` (its first and
/// last, widened), one line per series in its colour and marker; the legend in a column of
/// its own.
pub fn against_lights(
    file: &str,
    title: &str,
    lights: (u32, u32),
    panels: &[Panel<'_>],
) -> Option<Plot> {
    let (x0, x1) = (lights.0 as f64 * 0.8, lights.1 as f64 * 1.25);
    svg(file, title, (1100 + LEGEND_WIDTH, 480), |area| {
        let (data, key) = legend_column(area);
        let parts = data.split_evenly((1, panels.len()));
        for (panel, part) in panels.iter().zip(parts.iter()) {
            let positive = panel.values.iter().copied().filter(|&v| v > 0.0);
            let lo = positive.clone().fold(f64::MAX, f64::min) * 0.8;
            let hi = positive.fold(0.0, f64::max) * 1.25;
            let mut chart = ChartBuilder::on(part)
                .caption(panel.label, (FONT, 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(log_axis(x0, x1), log_axis(lo, hi))
                .ok()?;
            chart
                .configure_mesh()
                .light_line_style(TRANSPARENT)
                .x_desc("lights")
                .y_desc(panel.label)
                .x_label_formatter(&tick_label)
                .y_label_formatter(&tick_label)
                .draw()
                .ok()?;
            for (i, (_, points)) in panel.series.iter().enumerate() {
                line_with_points(&mut chart, points.clone(), i)?;
            }
        }
        let entries = series_legend(panels.first()?.series.iter().map(|(name, _)| name));
        side_legend(&key, "series", &entries)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_ticks_are_round_and_few_whatever_the_range() {
        assert_eq!(log_ticks(0.8, 12500.0), [1.0, 10.0, 100.0, 1000.0, 10000.0]);
        assert_eq!(
            log_ticks(50.0, 6000.0),
            [50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0]
        );
        assert_eq!(log_ticks(80.0, 125.0), [80.0, 100.0, 120.0]);
        assert_eq!(log_ticks(1e-4, 1e10).len(), 8);
        assert_eq!(tick_label(&10000.0), "10000");
        assert_eq!(tick_label(&0.25), "0.25");
        assert_eq!(tick_label(&1e-5), "1e-5");
    }
}

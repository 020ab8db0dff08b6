//! SVG plots (plotters), shared by the matrix report and the studies: one way to draw a plot
//! into a string, one palette, one legend style, and a numbered key for scatter plots whose
//! points are too many to label in place.

use plotters::coord::ranged1d::Ranged;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

/// One plot: its file name, title and SVG text.
#[derive(Clone, Debug)]
pub struct Plot {
    pub file: String,
    pub title: String,
    pub svg: String,
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

/// The legend box of every plot.
pub fn legend<'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, CT>,
    position: SeriesLabelPosition,
) -> Option<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 12))
        .draw()
        .ok()
}

/// Series `label` in `color`: a line through `points`, a dot at each, and its legend entry.
pub fn line_with_points<'a, X, Y>(
    chart: &mut ChartContext<'a, SVGBackend<'a>, Cartesian2d<X, Y>>,
    points: Vec<(f64, f64)>,
    color: RGBColor,
    label: &str,
) -> Option<()>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let dots: Vec<Circle<(f64, f64), i32>> = points
        .iter()
        .map(|&p| Circle::new(p, 3, color.filled()))
        .collect();
    chart
        .draw_series(LineSeries::new(points, color.stroke_width(2)))
        .ok()?
        .label(label)
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
    chart.draw_series(dots).ok()?;
    Some(())
}

/// A key beside a scatter plot whose points carry numbers instead of names: one line per
/// entry, `n  name`, in the entry's colour. Names never overlap, however close the points.
pub fn numbered_key(area: &Area, title: &str, entries: &[(String, RGBColor)]) -> Option<()> {
    let line = 15;
    area.draw(&Text::new(
        title.to_string(),
        (4, 18),
        (FONT, 13).into_font().style(FontStyle::Bold),
    ))
    .ok()?;
    for (i, (name, color)) in entries.iter().enumerate() {
        let y = 40 + line * i as i32;
        area.draw(&Circle::new((10, y + 6), 4, color.filled()))
            .ok()?;
        area.draw(&Text::new(
            format!("{:>2}  {name}", i + 1),
            (20, y),
            (FONT, 11).into_font().color(&RGBColor(40, 40, 40)),
        ))
        .ok()?;
    }
    Some(())
}

/// The number of the i-th key entry, drawn beside its point.
pub fn number_label<C>(i: usize, at: C) -> Text<'static, C, String> {
    Text::new(
        format!("{}", i + 1),
        at,
        (FONT, 10).into_font().color(&RGBColor(40, 40, 40)),
    )
}

/// One panel of [`against_lights`]: its label, the values that set its range, and one line
/// of (lights, value) points per named series.
pub struct Panel<'a> {
    pub label: &'a str,
    pub values: Vec<f64>,
    pub series: Vec<(&'a str, Vec<(f64, f64)>)>,
}

/// Panels side by side, each log-log against the light count from `lights` (its first and
/// last, widened), one coloured line per series with its legend.
pub fn against_lights(
    file: &str,
    title: &str,
    lights: (u32, u32),
    panels: &[Panel<'_>],
) -> Option<Plot> {
    let x = (lights.0 as f64 * 0.8)..(lights.1 as f64 * 1.25);
    svg(file, title, (1100, 480), |area| {
        let parts = area.split_evenly((1, panels.len()));
        for (panel, part) in panels.iter().zip(parts.iter()) {
            let positive = panel.values.iter().copied().filter(|&v| v > 0.0);
            let lo = positive.clone().fold(f64::MAX, f64::min) * 0.8;
            let hi = positive.fold(0.0, f64::max) * 1.25;
            let mut chart = ChartBuilder::on(part)
                .caption(panel.label, (FONT, 18))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(x.clone().log_scale(), (lo..hi).log_scale())
                .ok()?;
            chart
                .configure_mesh()
                .x_desc("lights")
                .y_desc(panel.label)
                .draw()
                .ok()?;
            for (i, (name, points)) in panel.series.iter().enumerate() {
                line_with_points(&mut chart, points.clone(), series_color(i), name)?;
            }
            legend(&mut chart, SeriesLabelPosition::UpperLeft)?;
        }
        Some(())
    })
}

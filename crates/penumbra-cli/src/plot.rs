//! `sweep.png`: error against time, every setting a dot, the Pareto front a
//! line with its settings named. Drawn with `plotters` (axes, ticks and text
//! are its job, not ours) into a pixel buffer that `output` writes; text in
//! DejaVu Sans, bundled so that the plot looks the same on every machine
//! (a headless CI container has no fonts).

use std::path::Path;
use std::sync::OnceLock;

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use penumbra::error::{Error, Result};
use penumbra::tune::SweepReport;

const WIDTH: u32 = 1000;
const HEIGHT: u32 = 700;
const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

fn register_font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok());
    if ok {
        Ok(())
    } else {
        Err(Error::internal("the bundled plot font does not load"))
    }
}

/// An axis range covering `values` with a margin; logarithmic where the
/// values are positive and span more than a decade.
enum Axis {
    Linear(f64, f64),
    Log(f64, f64),
}

fn axis(values: impl Iterator<Item = f64>) -> Axis {
    let v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() {
        return Axis::Linear(0.0, 1.0);
    }
    if lo > 0.0 && hi / lo > 10.0 {
        return Axis::Log(lo / 1.5, hi * 1.5);
    }
    let pad = ((hi - lo) * 0.1).max(hi.abs() * 0.05).max(1e-12);
    Axis::Linear((lo - pad).min(if lo >= 0.0 { 0.0 } else { lo }), hi + pad)
}

/// Draws the report into `path` (PNG).
pub fn write_png(path: &Path, report: &SweepReport) -> Result<()> {
    register_font()?;
    let mut pixels = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    let x = axis(report.rows.iter().map(|r| r.time_ms));
    let y = axis(report.rows.iter().map(|r| r.error));
    let drawn = match (x, y) {
        (Axis::Linear(a, b), Axis::Linear(c, d)) => draw(&mut pixels, report, a..b, c..d),
        (Axis::Linear(a, b), Axis::Log(c, d)) => draw(&mut pixels, report, a..b, (c..d).log_scale()),
        (Axis::Log(a, b), Axis::Linear(c, d)) => draw(&mut pixels, report, (a..b).log_scale(), c..d),
        (Axis::Log(a, b), Axis::Log(c, d)) => draw(&mut pixels, report, (a..b).log_scale(), (c..d).log_scale()),
    };
    drawn.map_err(|e| Error::internal(format!("cannot draw the sweep plot: {e}")))?;
    let image = image::RgbImage::from_raw(WIDTH, HEIGHT, pixels).expect("buffer of the image's size");
    penumbra::io::output::write_image(path, &image, image::ImageFormat::Png)
}

/// A tick label with at most three significant digits and no trailing zeros.
fn tick(v: &f64) -> String {
    if *v == 0.0 {
        return "0".into();
    }
    let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 12) as usize;
    let text = format!("{v:.digits$}");
    if text.contains('.') {
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        text
    }
}

type DrawResult = std::result::Result<(), Box<dyn std::error::Error>>;

fn draw<X, Y>(pixels: &mut [u8], report: &SweepReport, x: X, y: Y) -> DrawResult
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let root = BitMapBackend::with_buffer(pixels, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE)?;
    let caption = format!(
        "penumbra sweep {}: {} settings, best of {}",
        report.method, report.settings, report.repeats
    );
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, (FONT, 24))
        .margin(20)
        .x_label_area_size(60)
        .y_label_area_size(90)
        .build_cartesian_2d(x, y)?;
    chart
        .configure_mesh()
        .x_labels(8)
        .y_labels(8)
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .x_desc(format!("time, ms ({})", report.time_measure))
        .y_desc(format!("error ({})", report.error_measure))
        .axis_desc_style((FONT, 16))
        .label_style((FONT, 14))
        .draw()?;
    // One colour per value of the first knob the grid varies.
    let first = report.axes.first();
    let mut groups: Vec<String> = Vec::new();
    for r in &report.rows {
        let v = first.and_then(|k| r.knobs.text(k)).unwrap_or_default().to_string();
        if !groups.contains(&v) {
            groups.push(v);
        }
    }
    for (g, value) in groups.iter().enumerate() {
        let dot = Palette99::pick(g).mix(0.8).filled();
        let rows = report
            .rows
            .iter()
            .filter(|r| first.and_then(|k| r.knobs.text(k)) == Some(value.as_str()));
        let label = match first {
            Some(k) => format!("{k}={value}"),
            None => "setting".into(),
        };
        chart
            .draw_series(rows.map(|r| Circle::new((r.time_ms, r.error), 5, dot)))?
            .label(label)
            .legend(move |(x, y)| Circle::new((x, y), 5, dot));
    }
    let front: Vec<(f64, f64)> = report
        .front
        .iter()
        .map(|&i| (report.rows[i].time_ms, report.rows[i].error))
        .collect();
    chart
        .draw_series(LineSeries::new(front.clone(), RED.stroke_width(2)))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x - 12, y), (x + 12, y)], RED.stroke_width(2)));
    chart.draw_series(front.iter().map(|&p| Circle::new(p, 6, RED.stroke_width(2))))?;
    let small = TextStyle::from((FONT, 12).into_font()).color(&BLACK);
    chart.draw_series(report.front.iter().map(|&i| {
        let r = &report.rows[i];
        Text::new(format!("  {}", r.knobs.label()), (r.time_ms, r.error), small.clone())
    }))?;
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

/// `bench.png`: the median time of each method (x, in the report's order)
/// on each device and thread count (one colour each), with the fastest and
/// slowest run as a bar, on a log axis of milliseconds.
pub fn write_bench_png(path: &Path, report: &penumbra::bench::BenchReport) -> Result<()> {
    register_font()?;
    let mut pixels = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    draw_bench(&mut pixels, report).map_err(|e| Error::internal(format!("cannot draw the bench plot: {e}")))?;
    let image = image::RgbImage::from_raw(WIDTH, HEIGHT, pixels).expect("buffer of the image's size");
    penumbra::io::output::write_image(path, &image, image::ImageFormat::Png)
}

fn draw_bench(pixels: &mut [u8], report: &penumbra::bench::BenchReport) -> DrawResult {
    let rows: Vec<_> = report
        .rows
        .iter()
        .filter(|r| r.median_ms.is_finite() && r.min_ms > 0.0)
        .collect();
    let mut methods: Vec<&'static str> = Vec::new();
    let mut series: Vec<String> = Vec::new();
    for r in &rows {
        if !methods.contains(&r.method.name()) {
            methods.push(r.method.name());
        }
        let s = format!("{} x{}", r.device, r.threads);
        if !series.contains(&s) {
            series.push(s);
        }
    }
    let lo = rows.iter().map(|r| r.min_ms).fold(f64::INFINITY, f64::min);
    let hi = rows.iter().map(|r| r.max_ms).fold(0.0, f64::max);
    let (lo, hi) = if lo.is_finite() && hi > 0.0 {
        (lo / 2.0, hi * 2.0)
    } else {
        (0.1, 10.0)
    };
    let root = BitMapBackend::with_buffer(pixels, (WIDTH, HEIGHT)).into_drawing_area();
    root.fill(&WHITE)?;
    let caption = format!(
        "penumbra bench: median of {} runs after {} warm-up (bars: fastest to slowest)",
        report.repeat, report.warmup
    );
    let n = methods.len().max(1) as f64;
    let mut chart = ChartBuilder::on(&root)
        .caption(caption, (FONT, 20))
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(90)
        .build_cartesian_2d(-0.5..n - 0.5, (lo..hi).log_scale())?;
    let names = methods.clone();
    let label = move |x: &f64| {
        let i = x.round();
        match (x - i).abs() < 1e-6 && i >= 0.0 {
            true => names.get(i as usize).map_or(String::new(), |s| s.to_string()),
            false => String::new(),
        }
    };
    chart
        .configure_mesh()
        .x_labels(methods.len() * 2 + 1)
        .y_labels(10)
        .x_label_formatter(&label)
        .y_label_formatter(&tick)
        .disable_x_mesh()
        .y_desc("timed work per run, ms (log)")
        .axis_desc_style((FONT, 16))
        .label_style((FONT, 14))
        .draw()?;
    let k = series.len().max(1) as f64;
    for (s, name) in series.iter().enumerate() {
        let colour = Palette99::pick(s).mix(0.9);
        let x = |r: &&penumbra::bench::BenchRow| {
            let m = methods.iter().position(|&m| m == r.method.name()).unwrap_or(0) as f64;
            m - 0.3 + 0.6 * (s as f64 + 0.5) / k
        };
        let mine: Vec<_> = rows
            .iter()
            .filter(|r| format!("{} x{}", r.device, r.threads) == *name)
            .collect();
        chart.draw_series(
            mine.iter()
                .map(|r| PathElement::new(vec![(x(r), r.min_ms), (x(r), r.max_ms)], colour.stroke_width(2))),
        )?;
        chart
            .draw_series(
                mine.iter()
                    .map(|r| Circle::new((x(r), r.median_ms), 5, colour.filled())),
            )?
            .label(name.clone())
            .legend(move |(x, y)| Circle::new((x, y), 5, colour.filled()));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    root.present()?;
    Ok(())
}

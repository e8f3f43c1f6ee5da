//! Log-log line plots written as PNG, for the benchmark figures.
//!
//! plotters draws into an RGB buffer (its bitmap backend, with no image-encoder feature) and the
//! workspace's `png` crate writes it. Text goes through plotters' `ab_glyph` feature with a font
//! shipped in `bench/assets/` (DejaVu Sans, licence beside it), so no system font libraries are
//! needed on a fresh machine.

use std::path::Path;
use std::sync::Once;

use anyhow::{Context, Result, anyhow};
use plotters::prelude::*;

const FONT: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");
const WIDTH: u32 = 900;
const HEIGHT: u32 = 600;

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mark {
    /// Points joined by a line (a sweep).
    Line,
    /// Points alone (separate measurements).
    Points,
    /// A dashed line (a fit).
    Dashed,
}

/// One named series of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub mark: Mark,
}

/// Axis titles and the figure title.
pub struct Labels<'a> {
    pub title: &'a str,
    pub x: &'a str,
    pub y: &'a str,
}

fn register_font() -> Result<()> {
    static ONCE: Once = Once::new();
    let mut result = Ok(());
    ONCE.call_once(|| {
        result =
            plotters::style::register_font("sans-serif", FontStyle::Normal, FONT).map_err(|_| {
                anyhow!("the shipped plot font bench/assets/DejaVuSans.ttf is not a font")
            });
    });
    result
}

/// The range of positive values, widened by a margin on a log scale.
fn log_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (lo, hi) = values
        .filter(|v| *v > 0.0 && v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if !lo.is_finite() {
        return None;
    }
    let (lo, hi) = if hi / lo < 1.5 {
        (lo / 1.5, hi * 1.5)
    } else {
        (lo, hi)
    };
    Some((lo / 1.3, hi * 1.3))
}

/// Writes a log-log plot of `series` to `path` (PNG). Non-positive values are left out.
pub fn loglog(path: &Path, labels: &Labels, series: &[Series]) -> Result<()> {
    register_font()?;
    let all = || series.iter().flat_map(|s| s.points.iter());
    let Some(x_range) = log_range(all().map(|p| p.0)) else {
        return Ok(());
    };
    let Some(y_range) = log_range(all().map(|p| p.1)) else {
        return Ok(());
    };
    let mut buffer = vec![0u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, labels, series, x_range, y_range)
            .map_err(|e| anyhow!("drawing {}: {e}", path.display()))?;
        root.present()
            .map_err(|e| anyhow!("drawing {}: {e}", path.display()))?;
    }
    write_png(path, &buffer)
}

fn draw<DB: DrawingBackend>(
    root: &DrawingArea<DB, plotters::coord::Shift>,
    labels: &Labels,
    series: &[Series],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(labels.title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
    chart
        .configure_mesh()
        .x_desc(labels.x)
        .y_desc(labels.y)
        .x_label_formatter(&|v| format!("{v:.0e}"))
        .y_label_formatter(&|v| format!("{v:.0e}"))
        .label_style(("sans-serif", 14))
        .draw()?;
    for (i, s) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let points: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| *x > 0.0 && *y > 0.0 && x.is_finite() && y.is_finite())
            .collect();
        let style = ShapeStyle::from(color).stroke_width(2);
        let legend_style = style;
        match s.mark {
            Mark::Line => {
                chart.draw_series(LineSeries::new(points.clone(), style))?;
                chart
                    .draw_series(points.iter().map(|&p| Circle::new(p, 3, style.filled())))?
                    .label(&s.name)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], legend_style)
                    });
            }
            Mark::Points => {
                chart
                    .draw_series(points.iter().map(|&p| Cross::new(p, 6, style)))?
                    .label(&s.name)
                    .legend(move |(x, y)| Cross::new((x + 10, y), 6, legend_style));
            }
            Mark::Dashed => {
                chart
                    .draw_series(DashedLineSeries::new(points.clone(), 8, 6, style))?
                    .label(&s.name)
                    .legend(move |(x, y)| {
                        PathElement::new(vec![(x, y), (x + 20, y)], legend_style)
                    });
            }
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    Ok(())
}

fn write_png(path: &Path, rgb: &[u8]) -> Result<()> {
    let file =
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), WIDTH, HEIGHT);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder
        .write_header()
        .with_context(|| format!("cannot write {}", path.display()))?;
    writer
        .write_image_data(rgb)
        .with_context(|| format!("cannot write {}", path.display()))?;
    writer
        .finish()
        .with_context(|| format!("cannot write {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_a_png_of_the_expected_size_with_something_drawn() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plot.png");
        let series = [
            Series {
                name: "y = x".into(),
                points: vec![(1.0, 1.0), (10.0, 10.0), (100.0, 100.0)],
                mark: Mark::Line,
            },
            Series {
                name: "points".into(),
                points: vec![(3.0, 2.0), (0.0, 5.0)],
                mark: Mark::Points,
            },
        ];
        let labels = Labels {
            title: "test",
            x: "x",
            y: "y",
        };
        loglog(&path, &labels, &series).unwrap();
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        assert_eq!((info.width, info.height), (WIDTH, HEIGHT));
        // Mostly white paper, but not blank: axes, text and lines are drawn.
        let dark = pixels
            .chunks(3)
            .filter(|p| p.iter().all(|&c| c < 128))
            .count();
        assert!(dark > 1000, "only {dark} dark pixels");
    }
}

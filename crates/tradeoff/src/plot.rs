//! The sweep's plots (plotters): error against render milliseconds, one chart per knob and
//! one of the Pareto front, each as SVG and PNG, written atomically.

use crate::sweep::{Sweep, Why};
use anyhow::{Result, anyhow};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

const SIZE: (u32, u32) = (640, 420);

/// A named set of (ms, error %) points.
type Series = (String, Vec<(f64, f64)>);

/// Text is drawn with egui's bundled Ubuntu Light (no system font lookup).
fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font shipped by the crate; a failure only loses
        // the text.
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        );
    });
}

fn draw<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    title: &str,
    all: &[(f64, f64)],
    series: &[Series],
    front: Option<&[(f64, f64)]>,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("plot {title}: {e:?}");
    root.fill(&WHITE).map_err(err)?;
    let max_x = all.iter().map(|p| p.0).fold(1e-3, f64::max) * 1.08;
    let max_y = all.iter().map(|p| p.1).fold(1e-3, f64::max) * 1.5;
    let floor = y_floor(all);
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0.0..max_x, (floor..max_y).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("render time, ms")
        .y_desc("error against the best setting, % (log; 0 at the bottom)")
        .label_style(("sans-serif", 13))
        .draw()
        .map_err(err)?;
    chart
        .draw_series(
            all.iter()
                .map(|&p| Circle::new(p, 3, RGBColor(200, 200, 200).filled())),
        )
        .map_err(err)?;
    for (i, (name, pts)) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let mut sorted = pts.clone();
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
        chart
            .draw_series(sorted.iter().map(|&p| Circle::new(p, 5, color.filled())))
            .map_err(err)?
            .label(name.clone())
            .legend(move |(x, y)| Circle::new((x + 8, y), 5, color.filled()));
    }
    if let Some(f) = front {
        chart
            .draw_series(LineSeries::new(f.iter().copied(), RED.stroke_width(2)))
            .map_err(err)?
            .label("Pareto front")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], RED.stroke_width(2)));
        chart
            .draw_series(f.iter().map(|&p| Circle::new(p, 4, RED.filled())))
            .map_err(err)?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(err)?;
    root.present().map_err(err)?;
    Ok(())
}

/// The bottom of the log error axis: half the smallest non-zero error (the best setting's
/// zero error is drawn there).
fn y_floor(all: &[(f64, f64)]) -> f64 {
    0.5 * all
        .iter()
        .map(|p| p.1)
        .filter(|&e| e > 0.0)
        .fold(f64::INFINITY, f64::min)
        .min(1.0)
}

/// Writes `stem.svg` and `stem.png` in `dir`.
fn write_pair(
    dir: &Path,
    stem: &str,
    title: &str,
    all: &[(f64, f64)],
    series: &[Series],
    front: Option<&[(f64, f64)]>,
) -> Result<()> {
    let mut svg = String::new();
    draw(
        SVGBackend::with_string(&mut svg, SIZE).into_drawing_area(),
        title,
        all,
        series,
        front,
    )?;
    haze_render::output::write_atomic(&dir.join(format!("{stem}.svg")), svg.as_bytes())?;
    let mut rgb = vec![0u8; (SIZE.0 * SIZE.1 * 3) as usize];
    draw(
        BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area(),
        title,
        all,
        series,
        front,
    )?;
    let img = image::RgbImage::from_raw(SIZE.0, SIZE.1, rgb)
        .ok_or_else(|| anyhow!("plot {title}: bad buffer"))?;
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .map_err(|e| anyhow!("plot {title}: {e}"))?;
    haze_render::output::write_atomic(&dir.join(format!("{stem}.png")), &png)
}

/// Every plot of `sweep` in `dir`: `pareto.{svg,png}` and `knob-NAME.{svg,png}` per knob
/// with more than one value. Returns the number of charts.
pub fn write_all(dir: &Path, sweep: &Sweep) -> Result<usize> {
    register_font();
    let raw: Vec<(f64, f64)> = sweep
        .measured
        .iter()
        .map(|m| (m.sample.render_ms, 100.0 * m.error))
        .collect();
    let floor = y_floor(&raw);
    let pt = |i: usize| (raw[i].0, raw[i].1.max(floor));
    let all: Vec<(f64, f64)> = (0..sweep.measured.len()).map(pt).collect();
    let front: Vec<(f64, f64)> = sweep.front.iter().map(|&i| pt(i)).collect();
    let factorial = sweep.measured.iter().any(|m| m.why == Why::Factorial);
    let mut charts = 0;
    write_pair(
        dir,
        "pareto",
        &format!("{} settings and their Pareto front", sweep.measured.len()),
        &all,
        &[],
        Some(&front),
    )?;
    charts += 1;
    for (k, knob) in sweep.knobs.iter().enumerate() {
        if knob.values.len() < 2 {
            continue;
        }
        // One series per value: the settings that differ from the defaults in this knob
        // alone (every setting with that value in a factorial sweep).
        let series: Vec<Series> = knob
            .values
            .iter()
            .enumerate()
            .map(|(v, value)| {
                let pts = sweep
                    .measured
                    .iter()
                    .enumerate()
                    .filter(|(_, m)| {
                        m.setting[k] == v
                            && (factorial || m.why == Why::Default || m.why == Why::OneKnob(k))
                    })
                    .map(|(i, _)| pt(i))
                    .collect();
                (format!("{} = {value}", knob.name), pts)
            })
            .filter(|(_, p): &Series| !p.is_empty())
            .collect();
        write_pair(
            dir,
            &format!("knob-{}", knob.name),
            &format!("knob {}", knob.name),
            &all,
            &series,
            None,
        )?;
        charts += 1;
    }
    Ok(charts)
}

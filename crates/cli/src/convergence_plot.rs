//! Convergence curves of `focal compare` as log-log SVG plots (plotters): one line per method.

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use std::path::Path;

/// One method's curve: its name and (x, error) points, x increasing.
pub struct Curve {
    /// Method name (the legend entry).
    pub name: String,
    /// Points (budget, error); non-positive values cannot be drawn on a log scale and are dropped.
    pub points: Vec<(f64, f64)>,
}

/// Writes a log-log plot of `curves` to `path` (SVG).
pub fn write_loglog_svg(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    curves: &[Curve],
) -> Result<()> {
    let positive = |p: &&(f64, f64)| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite();
    let all: Vec<(f64, f64)> = curves
        .iter()
        .flat_map(|c| c.points.iter().filter(positive).copied())
        .collect();
    let range = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| {
            (lo.min(x), hi.max(x))
        });
        if lo.is_finite() && hi > 0.0 {
            // A decade-aligned margin so single points and flat lines still get an axis.
            (lo / 1.5, (hi * 1.5).max(lo * 2.0))
        } else {
            (1e-3, 1.0)
        }
    };
    let (x0, x1) = range(&mut all.iter().map(|p| p.0));
    let (y0, y1) = range(&mut all.iter().map(|p| p.1));
    let err = |e: &dyn std::fmt::Display| anyhow!("plotting {}: {e}", path.display());
    let root = SVGBackend::new(path, (640, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .x_labels(8)
        .x_label_formatter(&|v| tick(*v))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, c) in curves.iter().enumerate() {
        let colour = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64)> = c.points.iter().filter(positive).copied().collect();
        chart
            .draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2)))
            .map_err(|e| err(&e))?
            .label(c.name.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        chart
            .draw_series(pts.iter().map(|&p| Circle::new(p, 3, colour.filled())))
            .map_err(|e| err(&e))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .position(SeriesLabelPosition::UpperRight)
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// A short tick label: integers above 10, otherwise up to three decimals without trailing zeros.
fn tick(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.0}")
    } else {
        let s = format!("{v:.3}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(4.0), "4");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(120.4), "120");
    }

    #[test]
    fn svg_has_one_line_per_method() {
        let d = std::env::temp_dir().join(format!("focal-plot-{}.svg", std::process::id()));
        let curves = [
            Curve {
                name: "pt".into(),
                points: vec![(1.0, 0.1), (2.0, 0.05)],
            },
            Curve {
                name: "gmm".into(),
                points: vec![(1.0, 0.02), (2.0, 0.0)],
            },
        ];
        write_loglog_svg(&d, "t", "x", "y", &curves).unwrap();
        let svg = std::fs::read_to_string(&d).unwrap();
        let _ = std::fs::remove_file(&d);
        assert!(svg.starts_with("<svg") && svg.contains("pt") && svg.contains("gmm"));
        assert!(svg.matches("<polyline").count() >= 2, "{svg}");
    }
}

//! convergence.png: the error against run time.

use crate::error::{CliError, Result};
use crate::raster::register_font;
use imap::Progress;
use std::path::Path;

/// convergence.png: the estimated global error against run time, log–log, with the
/// t^-1/2 reference through the last point.
pub fn plot_convergence(path: &Path, history: &[Progress]) -> Result<()> {
    use plotters::prelude::*;
    // Points a plot can show: from a microsecond to 30 000 years (a state file may hold
    // any finite number; a log axis over 300 decades is no plot).
    let pts: Vec<(f64, f64)> = history
        .iter()
        .filter(|p| (1e-6..=1e12).contains(&p.elapsed_s))
        // 1 exactly is the library's "no data yet"; errors above 100 % are estimates too.
        .filter(|p| (1e-12..1e6).contains(&p.rel_error) && p.rel_error != 1.0)
        .map(|p| (p.elapsed_s, p.rel_error))
        .collect();
    let font = register_font();
    if pts.is_empty() {
        // Nothing to plot (no recorded surface got light yet): a plot that says so, rather
        // than failing a run that may be right (a recorded side facing away from the light).
        let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
            let root = BitMapBackend::new(path, (800, 560)).into_drawing_area();
            root.fill(&WHITE)?;
            if font {
                root.draw(&Text::new(
                    "no error estimate yet: no recorded surface received light",
                    (120, 270),
                    ("sans-serif", 22),
                ))?;
            }
            root.present()?;
            Ok(())
        };
        return draw().map_err(|e| CliError(format!("{}: {e}", path.display())));
    }
    let (t0, t1) = (pts[0].0 * 0.8, pts.last().unwrap().0 * 1.25);
    let emin = pts.iter().map(|p| p.1).fold(f64::INFINITY, f64::min) * 0.7;
    let emax = pts.iter().map(|p| p.1).fold(0.0, f64::max) * 1.4;
    let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(path, (800, 560)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut builder = ChartBuilder::on(&root);
        builder.margin(20);
        if font {
            builder
                .caption(
                    "estimated global error against run time",
                    ("sans-serif", 22),
                )
                .x_label_area_size(45)
                .y_label_area_size(70);
        }
        let mut chart =
            builder.build_cartesian_2d((t0..t1).log_scale(), (emin..emax).log_scale())?;
        let mut mesh = chart.configure_mesh();
        if font {
            mesh.x_desc("run time (s)")
                .y_desc("relative error")
                .y_label_formatter(&|y| format!("{:.1}%", y * 100.0));
        } else {
            mesh.disable_x_mesh().disable_y_mesh();
        }
        mesh.draw()?;
        let (tl, el) = *pts.last().unwrap();
        let reference = [t0, t1].map(|t| (t, el * (tl / t).sqrt()));
        let s = chart.draw_series(LineSeries::new(
            reference,
            ShapeStyle::from(&RGBColor(150, 150, 150)).stroke_width(2),
        ))?;
        if font {
            s.label("t^-1/2 reference")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], RGBColor(150, 150, 150)));
        }
        let s = chart.draw_series(LineSeries::new(
            pts.iter().copied(),
            ShapeStyle::from(&BLUE).stroke_width(2),
        ))?;
        if font {
            s.label("estimated error")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLUE));
        }
        chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, BLUE.filled())))?;
        if font {
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.8))
                .border_style(BLACK)
                .draw()?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| CliError(format!("{}: {e}", path.display())))
}

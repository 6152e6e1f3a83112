//! Pictures' common parts: PNG writing, the viridis colour scale, round scale ends and the
//! lux legend.

use crate::error::{CliError, Result};
use std::path::Path;

pub fn write_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<()> {
    let f = create(path)?;
    let mut enc = png::Encoder::new(f, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc
        .write_header()
        .map_err(|e| CliError(format!("{}: {e}", path.display())))?;
    wr.write_image_data(rgb)
        .map_err(|e| CliError(format!("{}: {e}", path.display())))
}

/// The viridis colour map at t ∈ [0, 1] (piecewise linear through five of its colours).
pub fn colour_map(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [68.0, 1.0, 84.0],
        [59.0, 82.0, 139.0],
        [33.0, 145.0, 140.0],
        [94.0, 201.0, 98.0],
        [253.0, 231.0, 37.0],
    ];
    let x = t.clamp(0.0, 1.0) * 4.0;
    let i = (x as usize).min(3);
    let f = x - i as f64;
    [0, 1, 2].map(|k| (STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f).round() as u8)
}

/// The smallest of 1, 2, 2.5, 5 × 10^k at or above `x`.
pub fn nice_ceiling(x: f64) -> f64 {
    if !(x > 0.0 && x.is_finite()) {
        return 1.0;
    }
    let p = 10f64.powf(x.log10().floor());
    [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * p)
        .find(|&v| v >= x * (1.0 - 1e-12))
        .unwrap_or(10.0 * p)
}

/// The tallest the legend's strip gets, pixels.
pub const LEGEND_MAX_PX: u32 = 24 + 3 * 12 + 22;

/// The colour scale 0 … `top` lx along the bottom of the image (labels when a font is
/// found).
pub fn draw_legend(img: &mut [u8], w: u32, h: u32, top: f64) {
    draw_legend_in(img, w, h, top, "lx")
}

/// `draw_legend` with the values in `unit`.
pub fn draw_legend_in(img: &mut [u8], w: u32, h: u32, top: f64, unit: &str) {
    use plotters::prelude::*;
    let bar_h = (h / 40).clamp(6, 24);
    let pad = (h / 60).clamp(3, 12);
    let label_h = (h / 28).clamp(9, 22);
    let strip = bar_h + 3 * pad + label_h;
    if h < 2 * strip || w < 60 {
        return; // too small for a legend
    }
    let font = register_font();
    let mut draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::with_buffer(img, (w, h)).into_drawing_area();
        let y0 = (h - strip) as i32;
        root.draw(&Rectangle::new(
            [(0, y0), (w as i32, h as i32)],
            RGBColor(24, 24, 28).filled(),
        ))?;
        let (x0, x1) = ((w / 20) as i32, (w - w / 20) as i32);
        let by = y0 + pad as i32;
        for x in x0..x1 {
            let c = colour_map((x - x0) as f64 / (x1 - x0 - 1).max(1) as f64);
            root.draw(&Rectangle::new(
                [(x, by), (x + 1, by + bar_h as i32)],
                RGBColor(c[0], c[1], c[2]).filled(),
            ))?;
        }
        if font {
            let style = ("sans-serif", label_h as f64)
                .into_font()
                .color(&RGBColor(230, 230, 230));
            use plotters::style::text_anchor::{HPos, Pos, VPos};
            for k in 0..=4 {
                let x = x0 + (x1 - x0) * k / 4;
                let v = top * k as f64 / 4.0;
                let (text, h) = match k {
                    0 => (fmt_lux(v), HPos::Left),
                    4 => (format!("{} {unit}", fmt_lux(v)), HPos::Right),
                    _ => (fmt_lux(v), HPos::Center),
                };
                root.draw(&Text::new(
                    text,
                    (x, by + (bar_h + pad) as i32),
                    style.clone().pos(Pos::new(h, VPos::Top)),
                ))?;
            }
        }
        root.present()?;
        Ok(())
    };
    // The legend is a courtesy: a drawing failure leaves the view without it.
    let _ = draw();
}

pub fn fmt_lux(v: f64) -> String {
    if v == 0.0 || v >= 10.0 {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
    }
}

pub fn create(path: &Path) -> Result<std::io::BufWriter<std::fs::File>> {
    std::fs::File::create(path)
        .map(std::io::BufWriter::new)
        .map_err(|e| CliError(format!("{}: {e}", path.display())))
}

pub fn io(path: &Path) -> impl Fn(std::io::Error) -> CliError + '_ {
    move |e| CliError(format!("{}: {e}", path.display()))
}

/// Registers a system sans-serif font with plotters (DejaVu on Debian); false when none
/// is found, and the plot goes without text.
pub fn register_font() -> bool {
    use std::sync::OnceLock;
    static DONE: OnceLock<bool> = OnceLock::new();
    *DONE.get_or_init(|| {
        for p in [
            "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/dejavu/DejaVuSans.ttf",
            "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
        ] {
            if let Ok(bytes) = std::fs::read(p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font(
                    "sans-serif",
                    plotters::style::FontStyle::Normal,
                    bytes,
                )
                .is_ok()
                {
                    return true;
                }
            }
        }
        false
    })
}

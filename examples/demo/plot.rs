//! The error-against-time plot: plotters draws it on a small RGB canvas of the demo's own, whose
//! text comes from the font8x8 bitmap font (no font files or system font libraries needed, and no
//! plotters font feature, which would also change how criterion draws its plots).

use std::convert::Infallible;
use std::path::Path;

use font8x8::{UnicodeFonts, BASIC_FONTS};
use plotters::prelude::*;
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{
    BackendColor, BackendCoord, BackendTextStyle, DrawingBackend, DrawingErrorKind,
};

/// An RGB8 drawing surface for plotters.
struct Canvas<'a> {
    width: u32,
    height: u32,
    rgb: &'a mut [u8],
}

impl Canvas<'_> {
    /// Glyph scale for a requested text size in pixels (the font is 8 × 8).
    fn scale(size: f64) -> i32 {
        ((size / 14.0).round() as i32).max(1)
    }
}

impl DrawingBackend for Canvas<'_> {
    type ErrorType = Infallible;

    fn get_size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Infallible>> {
        Ok(())
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Infallible>> {
        Ok(())
    }

    fn draw_pixel(
        &mut self,
        (x, y): BackendCoord,
        color: BackendColor,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        if x < 0 || y < 0 || x >= self.width as i32 || y >= self.height as i32 {
            return Ok(());
        }
        let i = 3 * (y as usize * self.width as usize + x as usize);
        let a = color.alpha.clamp(0.0, 1.0);
        let (r, g, b) = color.rgb;
        for (dst, src) in self.rgb[i..i + 3].iter_mut().zip([r, g, b]) {
            *dst = (*dst as f64 * (1.0 - a) + src as f64 * a).round() as u8;
        }
        Ok(())
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<Infallible>> {
        let s = Self::scale(style.size()) as u32;
        Ok((8 * s * text.chars().count() as u32, 8 * s))
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<Infallible>> {
        let s = Self::scale(style.size());
        let width = 8 * s * text.chars().count() as i32;
        let height = 8 * s;
        let dx = match style.anchor().h_pos {
            HPos::Left => 0,
            HPos::Right => -width,
            HPos::Center => -width / 2,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0,
            VPos::Center => -height / 2,
            VPos::Bottom => -height,
        };
        let transform = style.transform();
        let color = style.color();
        for (k, c) in text.chars().enumerate() {
            let glyph = BASIC_FONTS.get(c).or_else(|| BASIC_FONTS.get('?'));
            let Some(glyph) = glyph else { continue };
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) == 0 {
                        continue;
                    }
                    for sy in 0..s {
                        for sx in 0..s {
                            let x = dx + 8 * s * k as i32 + col * s + sx;
                            let y = dy + row as i32 * s + sy;
                            let (x, y) = transform.transform(x, y);
                            self.draw_pixel((pos.0 + x, pos.1 + y), color)?;
                        }
                    }
                }
            }
        }
        Ok(())
    }
}

/// One line of the plot: a name and (seconds, relative RMS error) points.
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

/// One colour per surface metric (seven), so that no two lines share one.
const COLOURS: [RGBColor; 7] = [
    RGBColor(230, 120, 20),
    RGBColor(200, 40, 40),
    RGBColor(120, 80, 180),
    RGBColor(30, 120, 200),
    RGBColor(200, 60, 160),
    RGBColor(20, 150, 90),
    RGBColor(90, 90, 90),
];

/// Writes a plot of relative RMS error against CPU time to `path` (PNG).
pub fn error_against_time(path: &Path, title: &str, series: &[Series]) -> Result<(), String> {
    error_against_time_of(path, title, "indirect irradiance", series)
}

/// [`error_against_time`] of another quantity (named on the y axis).
pub fn error_against_time_of(
    path: &Path,
    title: &str,
    quantity: &str,
    series: &[Series],
) -> Result<(), String> {
    let (w, h) = (900u32, 600u32);
    let mut buffer = vec![0u8; (w * h * 3) as usize];
    {
        let root = Canvas {
            width: w,
            height: h,
            rgb: &mut buffer,
        }
        .into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let pts: Vec<(f64, f64)> = series.iter().flat_map(|s| s.points.clone()).collect();
        if pts.is_empty() {
            return Err("nothing to plot".into());
        }
        let x1 = pts.iter().map(|p| p.0).fold(0.0, f64::max) * 1.1;
        let y1 = pts.iter().map(|p| p.1).fold(0.0, f64::max) * 1.15;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 24))
            .margin(16)
            .x_label_area_size(40)
            .y_label_area_size(80)
            .build_cartesian_2d(0.0..x1, 0.0..y1)
            .map_err(|e| e.to_string())?;
        chart
            .configure_mesh()
            .x_desc("CPU time: ray casting + raddiff + cache (s)")
            .y_desc(format!("relative RMS error of {quantity}"))
            .label_style(("sans-serif", 15))
            .x_labels(8)
            .y_labels(10)
            .x_label_formatter(&|x| format!("{x:.3}"))
            .y_label_formatter(&|y| format!("{y:.3}"))
            .axis_desc_style(("sans-serif", 17))
            .draw()
            .map_err(|e| e.to_string())?;
        for (i, s) in series.iter().enumerate() {
            let colour = COLOURS[i % COLOURS.len()];
            let mut points = s.points.clone();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            chart
                .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))
                .map_err(|e| e.to_string())?
                .label(s.name.as_str())
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            chart
                .draw_series(points.iter().map(|&p| Circle::new(p, 4, colour.filled())))
                .map_err(|e| e.to_string())?;
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .label_font(("sans-serif", 15))
            .position(SeriesLabelPosition::UpperRight)
            .margin(10)
            .draw()
            .map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    crate::image::write_png(path, w as usize, h as usize, &buffer).map_err(|e| e.to_string())
}

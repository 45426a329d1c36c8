//! PNG output: tone-mapped renders, false-colour maps and record overlays.

use std::path::Path;

use glam::DVec3;

/// An 8-bit RGB image.
pub struct Rgb8 {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u8>,
}

impl Rgb8 {
    pub fn new(width: usize, height: usize) -> Self {
        Rgb8 {
            width,
            height,
            data: vec![0; width * height * 3],
        }
    }

    pub fn set(&mut self, x: usize, y: usize, c: [u8; 3]) {
        if x < self.width && y < self.height {
            let i = 3 * (y * self.width + x);
            self.data[i..i + 3].copy_from_slice(&c);
        }
    }

    pub fn save(&self, path: &Path) -> std::io::Result<()> {
        write_png(path, self.width, self.height, &self.data)
    }
}

pub fn write_png(path: &Path, width: usize, height: usize, rgb: &[u8]) -> std::io::Result<()> {
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    let mut encoder = png::Encoder::new(file, width as u32, height as u32);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
    writer
        .write_image_data(rgb)
        .map_err(std::io::Error::other)?;
    writer.finish().map_err(std::io::Error::other)
}

fn srgb(v: f64) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Linear RGB values scaled by `exposure`, clamped, sRGB-encoded.
pub fn tonemap(width: usize, height: usize, values: &[DVec3], exposure: f64) -> Rgb8 {
    let mut img = Rgb8::new(width, height);
    for (i, v) in values.iter().enumerate() {
        let c = *v * exposure;
        img.set(i % width, i / width, [srgb(c.x), srgb(c.y), srgb(c.z)]);
    }
    img
}

/// An exposure mapping the 99th percentile luminance of `values` to 0.9.
pub fn auto_exposure(values: &[DVec3]) -> f64 {
    let mut l: Vec<f64> = values
        .iter()
        .map(|v| luminance(*v))
        .filter(|l| *l > 0.0)
        .collect();
    if l.is_empty() {
        return 1.0;
    }
    l.sort_by(f64::total_cmp);
    0.9 / l[(l.len() * 99 / 100).min(l.len() - 1)]
}

pub fn luminance(c: DVec3) -> f64 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}
/// A perceptually ordered colour ramp (black, blue, magenta, orange, yellow-white) for t in [0, 1].
pub fn heat(t: f64) -> [u8; 3] {
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [0.15, 0.1, 0.55],
        [0.75, 0.15, 0.5],
        [0.98, 0.55, 0.1],
        [1.0, 1.0, 0.75],
    ];
    let t = t.clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
    let i = (t.floor() as usize).min(STOPS.len() - 2);
    let f = t - i as f64;
    let mut c = [0u8; 3];
    for (ch, out) in c.iter_mut().enumerate() {
        *out = ((STOPS[i][ch] * (1.0 - f) + STOPS[i + 1][ch] * f) * 255.0 + 0.5) as u8;
    }
    c
}

/// False-colour map of non-negative scalars, `scale` mapping to the top of the ramp.
pub fn heat_map(width: usize, height: usize, values: &[f64], scale: f64) -> Rgb8 {
    let mut img = Rgb8::new(width, height);
    for (i, v) in values.iter().enumerate() {
        img.set(i % width, i / width, heat(v / scale));
    }
    img
}

/// Draws `text` in the font8x8 bitmap font, `s` pixels per font pixel, top-left corner at (x, y).
pub fn draw_text(img: &mut Rgb8, x: usize, y: usize, s: usize, text: &str, colour: [u8; 3]) {
    use font8x8::{UnicodeFonts, BASIC_FONTS};
    for (k, c) in text.chars().enumerate() {
        let Some(glyph) = BASIC_FONTS.get(c) else {
            continue;
        };
        for (row, bits) in glyph.iter().enumerate() {
            for col in (0..8).filter(|col| bits & (1 << col) != 0) {
                for sy in 0..s {
                    for sx in 0..s {
                        img.set(x + (8 * k + col) * s + sx, y + row * s + sy, colour);
                    }
                }
            }
        }
    }
}

/// `map` (a [`heat_map`] with this `scale`) above a colour bar: the ramp from 0 to `scale`, ticks at
/// 0, `scale` / 2 and `scale`, the end values and `caption` (what is mapped) in a light strip.
pub fn with_colour_bar(map: &Rgb8, scale: f64, caption: &str) -> Rgb8 {
    const BACKGROUND: [u8; 3] = [232, 232, 232];
    const INK: [u8; 3] = [16, 16, 16];
    let w = map.width;
    // Glyphs 8 px high up to 383 px wide images, 16 px from 384.
    let s = (w / 192).max(1);
    let glyph = 8 * s;
    let margin = 4 * s;
    let (low, high) = ("0".to_string(), format!("{scale}"));
    let text_width = |t: &str| glyph * t.chars().count();
    // The caption shares the row of the end values if it fits between them, else gets its own.
    let caption_fits = text_width(caption) + text_width(&low) + text_width(&high) + 4 * margin <= w;
    let ramp_top = 3 * s;
    let ramp_height = 8 * s;
    let ticks_top = ramp_top + ramp_height;
    let labels_top = ticks_top + 4 * s;
    let caption_top = if caption_fits {
        labels_top
    } else {
        labels_top + glyph + 2 * s
    };
    let strip = caption_top + glyph + 3 * s;
    let mut img = Rgb8::new(w, map.height + strip);
    img.data[..map.data.len()].copy_from_slice(&map.data);
    for y in map.height..img.height {
        for x in 0..w {
            img.set(x, y, BACKGROUND);
        }
    }
    let top = map.height;
    let (x0, x1) = (margin, w.saturating_sub(margin + 1).max(margin + 1));
    for x in x0..=x1 {
        let colour = heat((x - x0) as f64 / (x1 - x0) as f64);
        for y in 0..ramp_height {
            img.set(x, top + ramp_top + y, colour);
        }
    }
    // A frame around the ramp (its low end is black like the map's zero error).
    for x in x0 - 1..=x1 + 1 {
        img.set(x, top + ramp_top - 1, INK);
        img.set(x, top + ramp_top + ramp_height, INK);
    }
    for y in ramp_top - 1..=ramp_top + ramp_height {
        img.set(x0 - 1, top + y, INK);
        img.set(x1 + 1, top + y, INK);
    }
    for tick in [x0, (x0 + x1) / 2, x1] {
        for y in ticks_top..ticks_top + 3 * s {
            for dx in 0..s {
                img.set(tick + dx - s / 2, top + y, INK);
            }
        }
    }
    // End values centred on their ticks, kept inside the image.
    let place = |centre: usize, t: &str| {
        centre
            .saturating_sub(text_width(t) / 2)
            .min(w.saturating_sub(text_width(t)))
    };
    draw_text(&mut img, place(x0, &low), top + labels_top, s, &low, INK);
    draw_text(&mut img, place(x1, &high), top + labels_top, s, &high, INK);
    draw_text(
        &mut img,
        place(w / 2, caption),
        top + caption_top,
        s,
        caption,
        INK,
    );
    img
}

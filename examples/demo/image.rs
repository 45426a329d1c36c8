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

//! Command-line options of the demo.

use std::path::PathBuf;

use crate::caching::{Baseline, Metric, Safeguards};
use crate::media_cache::MediaMetric;
use crate::scene::SceneKind;

pub const USAGE: &str = "\
raddiff demo: irradiance caching with every error metric against a path-traced reference

USAGE: cargo run --release -p raddiff-demo -- [OPTIONS]

OPTIONS:
  --scene NAME        cornell | cornell-black | room | courtyard | all
                                                                     [default: cornell]
  --metric NAME       split-sphere | bounded-split-sphere | gradient | hessian-unaware |
                      hessian-geometric | hessian-isotropic | hessian-anisotropic | all
                                                                     [default: all]
  --baseline NAME     production | thesis | all                      [default: all]
                      production: overture pass, gradients for every metric, the cache's
                      gradient limit, curvature floor, radii in [0.004, 0.25] x size;
                      thesis (sec. 6.4): lazy scanline placement, Ward 1988 split sphere
                      without gradients, one-pixel minimum radius, bounded split sphere
                      capped at 150 px of 1800, no maximum for Hessian records
  --gradient-limit C  production caches' gradient limit c, or off     [default: 2]
  --neighbour-clamp on|off  production caches' two-sided neighbour clamping [default: off]
  --records N         record count every metric is tuned to          [default: 1000]
  --resolution W[xH]  image size in pixels                           [default: 256]
  --threads N         worker threads (0: one per core)               [default: 0]
  --gather MxN        gather strata per record (rays = M*N)          [default: 32x128]
  --reference N       reference rays per pixel (a square number)     [default: 4096]
  --thresholds N      error thresholds per metric for the error-against-time plot [default: 4]
  --out DIR           output directory                               [default: out]

MEDIA (VOLUME) CACHES, scenes with a medium (room) only:
  --media-metric NAME split-sphere | gradient | hessian-isotropic | hessian-anisotropic |
                      all | none                                     [default: all]
  --media-records N   record count every media metric is tuned to    [default: 300]
  --media-resolution W[xH]  media image size in pixels               [default: 64]
  --media-steps N     march points per camera ray (record candidates) [default: 16]
  --media-gather MxN  sphere gather strata per media record          [default: 16x32]
  --media-reference MxN  sphere gather strata per reference point    [default: 32x64]
  -h, --help          this text
";

#[derive(Clone, Debug)]
pub struct Options {
    pub scenes: Vec<SceneKind>,
    pub metrics: Vec<Metric>,
    pub baselines: Vec<Baseline>,
    pub safeguards: Safeguards,
    pub records: usize,
    pub width: usize,
    pub height: usize,
    pub threads: usize,
    pub gather_m: usize,
    pub gather_n: usize,
    pub reference_samples: usize,
    pub thresholds: usize,
    pub out: PathBuf,
    pub media_metrics: Vec<MediaMetric>,
    pub media_records: usize,
    pub media_width: usize,
    pub media_height: usize,
    pub media_steps: usize,
    pub media_gather_m: usize,
    pub media_gather_n: usize,
    pub media_reference_m: usize,
    pub media_reference_n: usize,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            scenes: vec![SceneKind::Cornell],
            metrics: Vec::new(),
            baselines: Baseline::ALL.to_vec(),
            safeguards: Safeguards::default(),
            records: 1000,
            width: 256,
            height: 256,
            threads: 0,
            gather_m: 32,
            gather_n: 128,
            reference_samples: 4096,
            thresholds: 4,
            out: PathBuf::from("out"),
            media_metrics: MediaMetric::ALL.to_vec(),
            media_records: 300,
            media_width: 64,
            media_height: 64,
            media_steps: 16,
            media_gather_m: 16,
            media_gather_n: 32,
            media_reference_m: 32,
            media_reference_n: 64,
        }
    }
}

fn number(flag: &str, value: &str) -> Result<usize, String> {
    value
        .parse::<usize>()
        .map_err(|_| format!("{flag} expects a non-negative integer, got {value:?}"))
}

fn pair(flag: &str, value: &str) -> Result<(usize, usize), String> {
    match value.split_once('x') {
        Some((a, b)) => Ok((number(flag, a)?, number(flag, b)?)),
        None => {
            let a = number(flag, value)?;
            Ok((a, a))
        }
    }
}

/// Parses the arguments (without the program name). `Ok(None)` means help was printed.
pub fn parse(args: impl IntoIterator<Item = String>) -> Result<Option<Options>, String> {
    let mut o = Options::default();
    let mut metric = "all".to_string();
    let mut it = args.into_iter();
    while let Some(flag) = it.next() {
        if flag == "-h" || flag == "--help" {
            print!("{USAGE}");
            return Ok(None);
        }
        let value = it
            .next()
            .ok_or_else(|| format!("{flag} needs a value (see --help)"))?;
        match flag.as_str() {
            "--scene" => {
                o.scenes = if value == "all" {
                    SceneKind::ALL.to_vec()
                } else {
                    vec![SceneKind::parse(&value)
                        .ok_or_else(|| format!("unknown scene {value:?} (see --help)"))?]
                }
            }
            "--metric" => metric = value,
            "--baseline" => {
                o.baselines = if value == "all" {
                    Baseline::ALL.to_vec()
                } else {
                    vec![Baseline::parse(&value)
                        .ok_or_else(|| format!("unknown baseline {value:?} (see --help)"))?]
                }
            }
            "--gradient-limit" => {
                o.safeguards.gradient_limit = if value == "off" {
                    f64::INFINITY
                } else {
                    match value.parse::<f64>() {
                        Ok(c) if c > 0.0 => c,
                        _ => {
                            return Err(format!(
                                "--gradient-limit expects a positive number or off, got {value:?}"
                            ))
                        }
                    }
                }
            }
            "--neighbour-clamp" => {
                o.safeguards.neighbour_clamp = match value.as_str() {
                    "on" => true,
                    "off" => false,
                    _ => {
                        return Err(format!(
                            "--neighbour-clamp expects on or off, got {value:?}"
                        ))
                    }
                }
            }
            "--records" => o.records = number(&flag, &value)?.max(1),
            "--resolution" => (o.width, o.height) = pair(&flag, &value)?,
            "--threads" => o.threads = number(&flag, &value)?,
            "--gather" => (o.gather_m, o.gather_n) = pair(&flag, &value)?,
            "--reference" => o.reference_samples = number(&flag, &value)?,
            "--thresholds" => o.thresholds = number(&flag, &value)?.max(1),
            "--out" => o.out = PathBuf::from(value),
            "--media-metric" => {
                o.media_metrics = match value.as_str() {
                    "all" => MediaMetric::ALL.to_vec(),
                    "none" => Vec::new(),
                    _ => vec![MediaMetric::parse(&value)
                        .ok_or_else(|| format!("unknown media metric {value:?} (see --help)"))?],
                }
            }
            "--media-records" => o.media_records = number(&flag, &value)?.max(1),
            "--media-resolution" => (o.media_width, o.media_height) = pair(&flag, &value)?,
            "--media-steps" => o.media_steps = number(&flag, &value)?.max(1),
            "--media-gather" => (o.media_gather_m, o.media_gather_n) = pair(&flag, &value)?,
            "--media-reference" => {
                (o.media_reference_m, o.media_reference_n) = pair(&flag, &value)?
            }
            _ => return Err(format!("unknown option {flag:?} (see --help)")),
        }
    }
    if o.width == 0 || o.height == 0 || o.width * o.height > 4096 * 4096 {
        return Err("--resolution must be between 1x1 and 4096x4096".into());
    }
    if o.gather_m < 2 || o.gather_n < 3 || o.gather_m * o.gather_n > 1 << 20 {
        return Err("--gather needs M >= 2, N >= 3 and M*N <= 2^20".into());
    }
    if o.media_width == 0 || o.media_height == 0 || o.media_width * o.media_height > 1024 * 1024 {
        return Err("--media-resolution must be between 1x1 and 1024x1024".into());
    }
    for (flag, m, n) in [
        ("--media-gather", o.media_gather_m, o.media_gather_n),
        (
            "--media-reference",
            o.media_reference_m,
            o.media_reference_n,
        ),
    ] {
        if m < 2 || n < 3 || m * n > 1 << 20 {
            return Err(format!("{flag} needs M >= 2, N >= 3 and M*N <= 2^20"));
        }
    }
    let side = (o.reference_samples as f64).sqrt().round() as usize;
    if side == 0 || side * side != o.reference_samples {
        return Err("--reference must be a positive square number (e.g. 1024, 4096)".into());
    }
    o.metrics = if metric == "all" {
        Metric::ALL.to_vec()
    } else {
        vec![Metric::parse(&metric)
            .ok_or_else(|| format!("unknown metric {metric:?} (see --help)"))?]
    };
    Ok(Some(o))
}

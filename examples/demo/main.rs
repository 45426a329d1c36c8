//! The raddiff demo: scenes built in code, a path-traced reference of indirect irradiance, and
//! irradiance caching with every error metric at equal record counts.
//!
//! Run `cargo run --release -p raddiff-demo -- --help` for the options; images, the report and the
//! plot are written under `out/`.

mod bvh;
mod caching;
mod cli;
mod derivs;
mod geometry;
mod image;
mod lightmap;
mod media_cache;
mod media_gather;
mod media_report;
mod media_view;
mod outputs;
mod placement;
mod plot;
mod render;
mod report;
mod scene;
mod timing;

use std::path::Path;
use std::time::Instant;

use glam::DVec3;
use indicatif::{ProgressBar, ProgressStyle};

use crate::caching::{Baseline, GatherStore, MetricTuning};
use crate::lightmap::LightMap;
use crate::render::GBuffer;
use crate::scene::Scene;

fn progress(message: &str) -> ProgressBar {
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template(
            "{msg:>24} [{bar:32}] {percent:>3}% {elapsed_precise} eta {eta}",
        )
        .expect("valid template")
        .progress_chars("=> "),
    );
    bar.set_message(message.to_string());
    bar
}

/// A reference and where it came from.
pub struct Reference {
    pub values: Vec<DVec3>,
    /// Wall seconds it took to compute (then or now).
    pub seconds: f64,
    /// The file it was read from or saved to.
    pub path: std::path::PathBuf,
    /// Whether it was read from `path` rather than computed by this run.
    pub reused: bool,
}

impl Reference {
    /// One console line: what was computed or reused, and where it is.
    pub fn describe(&self, what: &str) -> String {
        if self.reused {
            format!(
                "   {what}: reused {} (computed in {:.1} s by an earlier run)",
                self.path.display(),
                self.seconds
            )
        } else {
            format!(
                "   {what}: computed in {:.1} s, wrote {}",
                self.seconds,
                self.path.display()
            )
        }
    }
}

/// The reference is the slow part and depends only on the scene, resolution and sample count: keep
/// it under out/ and reuse it (the file name's version changes whenever the scenes do).
fn load_or_compute_reference(
    scene: &Scene,
    lightmap: &LightMap,
    gbuffer: &GBuffer,
    samples: usize,
    out: &Path,
) -> std::io::Result<Reference> {
    let path = out.join(format!(
        "{}-reference-v7-{}x{}-{}.f64",
        scene.kind.name(),
        gbuffer.width,
        gbuffer.height,
        samples
    ));
    let count = gbuffer.width * gbuffer.height;
    if let Ok(bytes) = std::fs::read(&path) {
        if bytes.len() == count * 24 + 8 {
            let f = |i: usize| f64::from_le_bytes(bytes[8 * i..8 * i + 8].try_into().unwrap());
            let seconds = f(0);
            let values = (0..count)
                .map(|p| DVec3::new(f(1 + 3 * p), f(2 + 3 * p), f(3 + 3 * p)))
                .collect();
            return Ok(Reference {
                values,
                seconds,
                path,
                reused: true,
            });
        }
    }
    let side = (samples as f64).sqrt().round() as usize;
    let start = Instant::now();
    let values = render::reference(scene, lightmap, gbuffer, side, side, &progress("reference"));
    let seconds = start.elapsed().as_secs_f64();
    let mut bytes = Vec::with_capacity(count * 24 + 8);
    bytes.extend_from_slice(&seconds.to_le_bytes());
    for v in &values {
        for c in v.to_array() {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(&path, bytes)?;
    Ok(Reference {
        values,
        seconds,
        path,
        reused: false,
    })
}

/// What every baseline's caches of one scene share.
struct SceneRun<'a> {
    scene: &'a Scene,
    gbuffer: &'a GBuffer,
    reference: &'a [DVec3],
    exposure: f64,
    options: &'a cli::Options,
}

impl SceneRun<'_> {
    /// Every metric's cache under `baseline`, tuned to the record target, its images, and the
    /// threshold sweep of the error-against-time plot, added to `scene_report`.
    fn caches(
        &self,
        store: &GatherStore,
        baseline: Baseline,
        report_name: &str,
        scene_report: &mut report::SceneReport,
    ) -> Result<(), String> {
        let (options, gbuffer, reference) = (self.options, self.gbuffer, self.reference);
        let (width, height) = (options.width, options.height);
        let save = |img: image::Rgb8, file: &str| {
            let path = options.out.join(format!("{report_name}-{file}.png"));
            img.save(&path)
                .map_err(|e| format!("{}: {e}", path.display()))
        };
        let bar = progress(&format!("caches ({})", baseline.name()));
        bar.set_length((options.metrics.len() * options.thresholds) as u64);
        for &metric in &options.metrics {
            if metric.surfaces_only() && self.scene.medium.is_some() {
                bar.println(format!(
                    "   {}: not defined in a participating medium, skipped",
                    metric.name()
                ));
                continue;
            }
            let tuned = caching::tune(store, metric, options.records, baseline, options.safeguards)
                .map_err(|e| e.to_string())?;
            let render: Vec<DVec3> = gbuffer
                .pixels
                .iter()
                .zip(&tuned.image)
                .map(|(p, e)| p.base + p.indirect_weight * *e)
                .collect();
            let file = format!("cache-{}", metric.name());
            save(image::tonemap(width, height, &render, self.exposure), &file)?;
            save(
                outputs::records_overlay(
                    &self.scene.camera,
                    gbuffer,
                    &render,
                    self.exposure,
                    &tuned.records,
                ),
                &format!("{file}-records"),
            )?;
            save(
                outputs::error_map(gbuffer, &tuned.image, reference, report::ERROR_MAP_SCALE),
                &format!("{file}-error"),
            )?;
            // Error against time: the same metric at thresholds around the tuned one, spaced so
            // that every metric's radii change by the same factors (2^0.75 per step).
            let mut sweep = Vec::new();
            for k in 0..options.thresholds {
                let factor = 2f64.powf(0.75 * (k as f64 - 1.0) / metric.radius_exponent());
                let run = if factor == 1.0 {
                    None
                } else {
                    Some(
                        caching::run(
                            store,
                            metric,
                            tuned.parameter * factor,
                            baseline,
                            options.safeguards,
                        )
                        .map_err(|e| e.to_string())?,
                    )
                };
                let r = run.as_ref().unwrap_or(&tuned);
                sweep.push(report::Row::new(r, reference, gbuffer));
                bar.inc(1);
            }
            scene_report.add(report::Row::new(&tuned, reference, gbuffer), sweep);
        }
        bar.finish_and_clear();
        println!(
            "   wrote {}/{report_name}-cache-<metric>[-records|-error].png",
            options.out.display()
        );
        Ok(())
    }
}

fn run() -> Result<(), String> {
    let Some(options) = cli::parse(std::env::args().skip(1))? else {
        return Ok(());
    };
    if options.threads > 0 {
        rayon::ThreadPoolBuilder::new()
            .num_threads(options.threads)
            .build_global()
            .map_err(|e| e.to_string())?;
    }
    std::fs::create_dir_all(&options.out).map_err(|e| e.to_string())?;
    for &kind in &options.scenes {
        let scene = Scene::build(kind);
        let name = kind.name();
        println!(
            "== scene {name}: {} primitives, {}x{} pixels, {} threads",
            scene.bvh.primitive_count(),
            options.width,
            options.height,
            rayon::current_num_threads()
        );
        let start = Instant::now();
        let lightmap = LightMap::build(&scene, &progress("light map"));
        let gbuffer = GBuffer::build(&scene, &lightmap, options.width, options.height);
        println!(
            "   light map and primary hits: {:.2} s",
            start.elapsed().as_secs_f64()
        );
        let computed = load_or_compute_reference(
            &scene,
            &lightmap,
            &gbuffer,
            options.reference_samples,
            &options.out,
        )
        .map_err(|e| e.to_string())?;
        println!(
            "{}",
            computed.describe(&format!(
                "reference ({} rays per pixel)",
                options.reference_samples
            ))
        );
        let (reference, ref_seconds) = (computed.values, computed.seconds);
        let final_image: Vec<DVec3> = gbuffer
            .pixels
            .iter()
            .zip(&reference)
            .map(|(p, e)| p.base + p.indirect_weight * *e)
            .collect();
        let exposure = image::auto_exposure(&final_image);
        let save = |img: image::Rgb8, file: &str| {
            let path = options.out.join(format!("{name}-{file}.png"));
            img.save(&path)
                .map_err(|e| format!("{}: {e}", path.display()))
        };
        save(
            image::tonemap(options.width, options.height, &final_image, exposure),
            "reference",
        )?;
        save(
            image::tonemap(
                options.width,
                options.height,
                &reference,
                image::auto_exposure(&reference),
            ),
            "reference-indirect-irradiance",
        )?;

        let store = GatherStore::new(
            &scene,
            &lightmap,
            &gbuffer,
            options.gather_m,
            options.gather_n,
            raddiff::cache::irradiance::Hessians::for_metrics(&options.metrics),
        )
        .map_err(|e| e.to_string())?;
        let ctx = SceneRun {
            scene: &scene,
            gbuffer: &gbuffer,
            reference: &reference,
            exposure,
            options: &options,
        };
        for &baseline in &options.baselines {
            let report_name = match baseline {
                Baseline::Production => name.to_string(),
                Baseline::Thesis => format!("{name}-thesis"),
            };
            let mut scene_report =
                report::SceneReport::new(&report_name, &options, ref_seconds, baseline);
            ctx.caches(&store, baseline, &report_name, &mut scene_report)?;
            scene_report.overhead(&store, &reference);
            if scene.medium.is_some() && baseline == Baseline::Production {
                media_report::run(&scene, &lightmap, &options, &mut scene_report, progress)?;
            }
            scene_report
                .write(&options.out)
                .map_err(|e| e.to_string())?;
            let files = [
                format!("{report_name}-report.md"),
                format!("{report_name}-report.csv"),
            ];
            for file in files {
                println!("   wrote {}", options.out.join(file).display());
            }
            let plot_path = options.out.join(format!("{report_name}-error-time.png"));
            plot::error_against_time(
                &plot_path,
                &format!("{name} ({}): error against time", baseline.name()),
                &scene_report.series(),
            )
            .map(|()| println!("   wrote {}", plot_path.display()))
            .unwrap_or_else(|e| eprintln!("   plot skipped: {e}"));
            let media_series = scene_report.media_series();
            if !media_series.is_empty() {
                let path = options.out.join(format!("{name}-media-error-time.png"));
                plot::error_against_time_of(
                    &path,
                    &format!("{name}: media caches, error against time"),
                    "indirect in-scattering",
                    &media_series,
                )
                .map(|()| println!("   wrote {}", path.display()))
                .unwrap_or_else(|e| eprintln!("   plot skipped: {e}"));
            }
            print!("{}", scene_report.markdown());
        }
    }
    Ok(())
}

fn main() {
    if let Err(e) = run() {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}

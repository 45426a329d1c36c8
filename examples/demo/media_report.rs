//! The media caches' part of a scene's run: the cached reference, one tuned cache and a threshold
//! sweep per media metric, images, rows of the scene report and the error-against-time plot.

use std::path::Path;
use std::time::Instant;

use glam::DVec3;

use crate::cli::Options;
use crate::image;
use crate::lightmap::LightMap;
use crate::media_cache::{self, MediaRun, MediaStore, MediaView};
use crate::media_gather::MediaGatherer;
use crate::report::{self, RadiusStats, Row, SceneReport};
use crate::scene::Scene;

impl Row {
    pub fn media(run: &MediaRun, reference: &[DVec3], view: &MediaView) -> Row {
        let image = run.image(view);
        let (rms, relative_rms) = media_cache::rms_error(&image, reference, view);
        let squared_errors = image
            .iter()
            .zip(reference)
            .enumerate()
            .filter(|(p, _)| view.in_medium(*p))
            .map(|(_, (v, r))| (image::luminance(*v) - image::luminance(*r)).powi(2))
            .collect();
        Row {
            metric: run.metric.report_name(),
            parameter: run.parameter,
            records: run.records.len(),
            trace_seconds: run.trace_seconds,
            raddiff_seconds: run.raddiff_seconds,
            cache_seconds: run.cache_seconds,
            rms,
            relative_rms,
            uncovered: run.uncovered,
            // Volume records: the smallest of the ellipsoid's three radii.
            radii: RadiusStats::of(
                run.records
                    .iter()
                    .map(|r| r.extent.radii.into_iter().fold(f64::INFINITY, f64::min))
                    .collect(),
            ),
            worst_share: report::worst_percent_share(squared_errors),
        }
    }
}

/// The reference q at every march point depends only on the scene, the view and the reference
/// gather size: keep it under out/ and reuse it (it is the slow part).
fn load_or_compute_reference(
    store: &MediaStore,
    o: &Options,
    out: &Path,
    progress: &indicatif::ProgressBar,
) -> std::io::Result<crate::Reference> {
    let view = store.view;
    let path = out.join(format!(
        "{}-media-reference-v2-{}x{}x{}-{}x{}.f64",
        store.scene.kind.name(),
        view.width,
        view.height,
        view.steps,
        o.media_reference_m,
        o.media_reference_n
    ));
    let count = view.points();
    if let Ok(bytes) = std::fs::read(&path) {
        if bytes.len() == count * 24 + 8 {
            let f = |i: usize| f64::from_le_bytes(bytes[8 * i..8 * i + 8].try_into().unwrap());
            let values = (0..count)
                .map(|p| DVec3::new(f(1 + 3 * p), f(2 + 3 * p), f(3 + 3 * p)))
                .collect();
            return Ok(crate::Reference {
                values,
                seconds: f(0),
                path,
                reused: true,
            });
        }
    }
    let start = Instant::now();
    let values = media_cache::reference(store, o.media_reference_m, o.media_reference_n, progress);
    let seconds = start.elapsed().as_secs_f64();
    let mut bytes = Vec::with_capacity(count * 24 + 8);
    bytes.extend_from_slice(&seconds.to_le_bytes());
    for v in &values {
        for c in v.to_array() {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    std::fs::write(&path, bytes)?;
    Ok(crate::Reference {
        values,
        seconds,
        path,
        reused: false,
    })
}

/// The records' centres (red) over the dimmed image.
fn records_overlay(
    scene: &Scene,
    view: &MediaView,
    image_values: &[DVec3],
    exposure: f64,
    run: &MediaRun,
) -> image::Rgb8 {
    let dim: Vec<DVec3> = image_values.iter().map(|v| *v * 0.45).collect();
    let mut img = image::tonemap(view.width, view.height, &dim, exposure);
    for r in &run.records {
        if let Some((x, y)) = view.project(scene, r.position) {
            img.set(x, y, [255, 60, 40]);
        }
    }
    img
}

/// Runs every media metric of `o` on the room's medium and adds their rows to `report`.
pub fn run(
    scene: &Scene,
    lightmap: &LightMap,
    o: &Options,
    report: &mut SceneReport,
    progress: impl Fn(&str) -> indicatif::ProgressBar,
) -> Result<(), String> {
    if o.media_metrics.is_empty() {
        return Ok(());
    }
    let hessian = o.media_metrics.iter().any(|m| m.uses_hessian());
    let Some(gatherer) = MediaGatherer::new(scene, o.media_gather_m, o.media_gather_n, hessian)
    else {
        return Ok(());
    };
    let name = scene.kind.name();
    let view = MediaView::build(scene, o.media_width, o.media_height, o.media_steps);
    let store = MediaStore::new(scene, lightmap, &view, gatherer);
    let computed = load_or_compute_reference(&store, o, &o.out, &progress("media reference"))
        .map_err(|e| e.to_string())?;
    println!(
        "{}",
        computed.describe(&format!(
            "media reference ({}x{} rays at {} points)",
            o.media_reference_m,
            o.media_reference_n,
            view.points()
        ))
    );
    let (reference_points, ref_seconds) = (computed.values, computed.seconds);
    let reference = view.integrate(&reference_points);
    let exposure = image::auto_exposure(&reference);
    let save = |img: image::Rgb8, file: &str| {
        let path = o.out.join(format!("{name}-media-{file}.png"));
        img.save(&path)
            .map_err(|e| format!("{}: {e}", path.display()))
    };
    save(
        image::tonemap(view.width, view.height, &reference, exposure),
        "reference",
    )?;
    // Context: the sun's single scattering along the same camera rays (the light shafts, computed
    // directly, marched finely) plus the reference of the cached indirect term.
    let shafts: Vec<DVec3> = view
        .march(256, |x| lightmap.inscattered(scene, x))
        .iter()
        .zip(&reference)
        .map(|(a, b)| *a + *b)
        .collect();
    save(
        image::tonemap(
            view.width,
            view.height,
            &shafts,
            image::auto_exposure(&shafts),
        ),
        "shafts",
    )?;
    let mean =
        reference.iter().map(|v| image::luminance(*v)).sum::<f64>() / reference.len().max(1) as f64;
    let bar = progress("media caches");
    bar.set_length((o.media_metrics.len() * o.thresholds) as u64);
    for &metric in &o.media_metrics {
        let tuned =
            media_cache::tune(&store, metric, o.media_records).map_err(|e| e.to_string())?;
        let tuned_image = tuned.image(&view);
        save(
            image::tonemap(view.width, view.height, &tuned_image, exposure),
            metric.name(),
        )?;
        save(
            records_overlay(scene, &view, &tuned_image, exposure, &tuned),
            &format!("{}-records", metric.name()),
        )?;
        let errors: Vec<f64> = tuned_image
            .iter()
            .zip(&reference)
            .map(|(v, r)| (image::luminance(*v) - image::luminance(*r)).abs() / mean.max(1e-300))
            .collect();
        save(
            image::with_colour_bar(
                &image::heat_map(view.width, view.height, &errors, report::ERROR_MAP_SCALE),
                report::ERROR_MAP_SCALE,
                crate::outputs::ERROR_CAPTION,
            ),
            &format!("{}-error", metric.name()),
        )?;
        let mut sweep = Vec::new();
        // radii change by 2^0.75 per step for every metric
        for k in 0..o.thresholds {
            let factor = 2f64.powf(0.75 * (k as f64 - 1.0) / metric.radius_exponent());
            let r = if factor == 1.0 {
                None
            } else {
                Some(
                    media_cache::run(&store, metric, tuned.parameter * factor)
                        .map_err(|e| e.to_string())?,
                )
            };
            sweep.push(Row::media(r.as_ref().unwrap_or(&tuned), &reference, &view));
            bar.inc(1);
        }
        report.add_media(Row::media(&tuned, &reference, &view), sweep);
    }
    bar.finish_and_clear();
    let (mut trace, mut gradient, mut hessian_s, mut count) = (0.0, 0.0, 0.0, 0usize);
    for (_, g) in store.computed() {
        trace += g.trace_seconds;
        gradient += g.gradient_seconds;
        hessian_s += g.hessian_seconds;
        count += 1;
    }
    let per = |s: f64| s / count.max(1) as f64 * 1e6;
    report.media_settings(format!(
        "Indirect in-scattered radiance sigma_s/(4 pi) x fluence in a volume cache, records from \
         {}x{} = {} ray sphere gathers at {} points ({}x{} pixels x {} march steps along the camera \
         rays), target {} records, reference {}x{} = {} ray sphere gathers per point ({ref_seconds:.1} \
         s wall). Per gather, over {count} gathers: ray casting {:.0} us, raddiff fluence + gradients \
         {:.0} us, raddiff occlusion-aware gradient + Hessian {:.0} us. The gathers' own q differs \
         from the reference at their points by {:.4} (relative RMS).",
        o.media_gather_m,
        o.media_gather_n,
        o.media_gather_m * o.media_gather_n,
        view.points(),
        view.width,
        view.height,
        view.steps,
        o.media_records,
        o.media_reference_m,
        o.media_reference_n,
        o.media_reference_m * o.media_reference_n,
        per(trace),
        per(gradient),
        per(hessian_s),
        store.gather_noise(&reference_points),
    ));
    Ok(())
}

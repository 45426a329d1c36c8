//! Renders the single scattering of a back-lit bumpy sphere (9680 triangles, η = 1.5) with the
//! per-triangle interval method, beside the straight-line approximation renderers commonly use, and
//! writes `out/single_scatter.png` (left: accurate, right: straight line; same exposure).
//!
//! `cargo run --release --example single_scatter [size] [frequency]` (default 96 pixels square,
//! geodesic frequency 22). Prints the time and the pruning statistics.

use std::time::Instant;

use glam::DVec3;
use raddiff::scatter::{
    scene, single_scatter, straight_line_single_scatter, Medium, RefractiveMesh, ScatterOptions,
    ScatterStats,
};

fn chord(mesh: &RefractiveMesh, origin: DVec3, dir: DVec3) -> Option<(DVec3, DVec3)> {
    let a = mesh.closest_hit(origin, dir, 0.0, 1e9)?;
    let b = mesh.closest_hit(origin, dir, a.t + 1e-9, 1e9)?;
    Some((origin + a.t * dir, origin + b.t * dir))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let size: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(96);
    let frequency: usize = args.next().map(|s| s.parse()).transpose()?.unwrap_or(22);
    let data = scene::bumpy_sphere(frequency, 0.05, 6.0);
    let mesh = data.build()?;
    let medium = Medium {
        eta: 1.5,
        sigma_t: 0.5,
        sigma_s: 0.45,
        g: 0.0,
    };
    let camera = DVec3::new(0.0, 0.0, 4.0);
    let light = DVec3::new(0.35, 0.6, -3.0);
    let options = ScatterOptions::default();
    let mut accurate = vec![0.0f64; size * size];
    let mut straight = vec![0.0f64; size * size];
    let mut stats = ScatterStats::default();
    let (mut t_accurate, mut t_straight) = (0.0, 0.0);
    for j in 0..size {
        for i in 0..size {
            let target = DVec3::new(
                1.2 * (2.0 * (i as f64 + 0.5) / size as f64 - 1.0),
                -1.2 * (2.0 * (j as f64 + 0.5) / size as f64 - 1.0),
                0.0,
            );
            let dir = (target - camera).normalize();
            let Some((entry_point, exit_point)) = chord(&mesh, camera, dir) else {
                continue;
            };
            // The eye ray refracts at the entry: follow the refracted ray inside.
            let tri_n = {
                let hit = mesh.closest_hit(camera, dir, 0.0, 1e9).unwrap();
                mesh.triangle(hit.triangle as usize).geometric_normal
            };
            let cos_i = -dir.dot(tri_n);
            let k = 1.0 - (1.0 - cos_i * cos_i) / (medium.eta * medium.eta);
            let inside =
                (dir / medium.eta + (cos_i / medium.eta - k.max(0.0).sqrt()) * tri_n).normalize();
            let exit = match mesh.closest_hit(entry_point, inside, 1e-9, 1e9) {
                Some(h) => entry_point + h.t * inside,
                None => exit_point,
            };
            let t = Instant::now();
            let r = single_scatter(&mesh, &medium, entry_point, exit, light, 1.0, &options)?;
            t_accurate += t.elapsed().as_secs_f64();
            stats += r.stats;
            let t = Instant::now();
            let s =
                straight_line_single_scatter(&mesh, &medium, entry_point, exit, light, 1.0, 64)?;
            t_straight += t.elapsed().as_secs_f64();
            accurate[j * size + i] = r.radiance;
            straight[j * size + i] = s;
        }
    }
    // Shared exposure: the 99th percentile of both images maps to white.
    let mut all: Vec<f64> = accurate
        .iter()
        .chain(&straight)
        .copied()
        .filter(|v| *v > 0.0)
        .collect();
    all.sort_by(f64::total_cmp);
    let white = all
        .get(all.len() * 99 / 100)
        .copied()
        .unwrap_or(1.0)
        .max(1e-300);
    let mut rgb = vec![0u8; 2 * size * size * 3];
    for j in 0..size {
        for i in 0..2 * size {
            let v = if i < size {
                accurate[j * size + i]
            } else {
                straight[j * size + i - size]
            };
            let x = (v / white).clamp(0.0, 1.0).powf(1.0 / 2.2);
            let o = (j * 2 * size + i) * 3;
            // Warm translucent tint.
            rgb[o] = (255.0 * x) as u8;
            rgb[o + 1] = (255.0 * x.powf(1.3)) as u8;
            rgb[o + 2] = (255.0 * x.powf(1.8)) as u8;
        }
    }
    std::fs::create_dir_all("out")?;
    let file = std::fs::File::create("out/single_scatter.png")?;
    let mut encoder = png::Encoder::new(
        std::io::BufWriter::new(file),
        (2 * size) as u32,
        size as u32,
    );
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    encoder.write_header()?.write_image_data(&rgb)?;

    let s = stats;
    let pct = |a: u64, b: u64| 100.0 * a as f64 / b.max(1) as f64;
    println!(
        "bumpy sphere: {} triangles, {size}x{size} pixels, {} eye segments",
        mesh.triangle_count(),
        s.segments
    );
    println!(
        "interval method: {:.2} s ({:.1} µs per segment); straight line: {:.2} s",
        t_accurate,
        1e6 * t_accurate / s.segments.max(1) as f64,
        t_straight
    );
    println!(
        "hierarchy nodes visited {} (spindle-pruned {:.1}%); triangles reached {} ({:.2}% of all per segment)",
        s.nodes_visited,
        pct(s.nodes_pruned_spindle, s.nodes_visited),
        s.triangles_visited,
        pct(s.triangles_visited, s.segments * mesh.triangle_count() as u64)
    );
    println!(
        "triangles: sidedness-pruned {:.1}%, spindle-pruned {:.1}%, normal-cone-pruned {:.1}%, no support {:.1}%, contributing {:.1}%, folded {:.2}%",
        pct(s.triangles_pruned_sidedness, s.triangles_visited),
        pct(s.triangles_pruned_spindle, s.triangles_visited),
        pct(s.triangles_pruned_normal_cone, s.triangles_visited),
        pct(s.triangles_without_support, s.triangles_visited),
        pct(s.triangles_contributing, s.triangles_visited),
        pct(s.triangles_fallback, s.triangles_visited)
    );
    println!(
        "Newton: {} interior solves ({:.2} iterations each, {:.1}% without solution), {} edge solves ({:.2} iterations each)",
        s.interior.solves,
        s.interior.iterations as f64 / s.interior.solves.max(1) as f64,
        pct(s.interior.failures, s.interior.solves),
        s.edge.solves,
        s.edge.iterations as f64 / s.edge.solves.max(1) as f64
    );
    println!("paths found {}, quadrature samples {}", s.paths, s.samples);
    println!(
        "wrote out/single_scatter.png (left: interval method, right: straight-line approximation)"
    );
    Ok(())
}

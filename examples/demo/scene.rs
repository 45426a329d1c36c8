//! The demo scenes, built in code from parallelograms: a Cornell box with an occluding block, the
//! same with a black back wall, a room lit by the sun through a window and filled with a
//! homogeneous scattering medium, and a sunlit courtyard whose arcade columns cast indirect shadows.

use std::f64::consts::PI;

use glam::DVec3;

use crate::bvh::Bvh;
use crate::geometry::{Hit, Parallelogram, Ray};

/// Which scene to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneKind {
    /// Cornell box (1 L wide) with a tall rotated block and a short block: indirect penumbrae.
    Cornell,
    /// The same box with a black back wall: a dark surface next to bright ones, where an
    /// occlusion-unaware (radiometric) Hessian sees no occluder (thesis Fig. 6.x test).
    CornellBlack,
    /// A 4 × 3 × 4 room with a window, sunlight and a homogeneous scattering medium.
    Room,
    /// A sunlit courtyard before a covered walkway: the sun never reaches under the roof, and the
    /// light the courtyard floor reflects through the colonnade casts the columns' indirect shadows
    /// on the walkway's floor and back wall (thesis Fig. 6.17).
    Courtyard,
}

impl SceneKind {
    pub fn name(self) -> &'static str {
        match self {
            SceneKind::Cornell => "cornell",
            SceneKind::CornellBlack => "cornell-black",
            SceneKind::Room => "room",
            SceneKind::Courtyard => "courtyard",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s {
            "cornell" => Some(SceneKind::Cornell),
            "cornell-black" => Some(SceneKind::CornellBlack),
            "room" => Some(SceneKind::Room),
            "courtyard" => Some(SceneKind::Courtyard),
            _ => None,
        }
    }

    pub const ALL: [SceneKind; 4] = [
        SceneKind::Cornell,
        SceneKind::CornellBlack,
        SceneKind::Room,
        SceneKind::Courtyard,
    ];
}

/// Diffuse reflectance and emitted radiance of a primitive (RGB).
#[derive(Clone, Copy, Debug)]
pub struct Material {
    pub albedo: DVec3,
    pub emission: DVec3,
}

/// The light of a scene.
#[derive(Clone, Copy, Debug)]
pub enum Light {
    /// A one-sided parallelogram emitter (primitive index), emitting along its normal.
    Area { primitive: usize, radiance: DVec3 },
    /// A distant sun: irradiance on a surface facing it, light travels along `direction`.
    Sun { direction: DVec3, irradiance: DVec3 },
}

/// A homogeneous medium filling an axis-aligned box (the room), isotropic phase function.
#[derive(Clone, Copy, Debug)]
pub struct Medium {
    pub sigma_s: f64,
    pub sigma_a: f64,
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Medium {
    pub fn sigma_t(&self) -> f64 {
        self.sigma_s + self.sigma_a
    }

    /// Length of the part of the segment origin + t·dir, t in [0, t_max], inside the box.
    pub fn inside_length(&self, origin: DVec3, dir: DVec3, t_max: f64) -> f64 {
        let inv = DVec3::ONE / dir;
        let t0 = (self.lo - origin) * inv;
        let t1 = (self.hi - origin) * inv;
        let enter = t0.min(t1).max_element().max(0.0);
        let exit = t0.max(t1).min_element().min(t_max);
        (exit - enter).max(0.0)
    }
}

/// A pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    pub position: DVec3,
    pub forward: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    /// tan(vertical field of view / 2).
    pub tan_half_fov: f64,
}

impl Camera {
    pub fn look_at(position: DVec3, target: DVec3, up: DVec3, fov_degrees: f64) -> Self {
        let forward = (target - position).normalize();
        let right = forward.cross(up).normalize();
        let up = right.cross(forward);
        Camera {
            position,
            forward,
            right,
            up,
            tan_half_fov: (fov_degrees.to_radians() * 0.5).tan(),
        }
    }

    /// The ray through the centre of pixel (x, y) of a width × height image (y down).
    pub fn ray(&self, x: usize, y: usize, width: usize, height: usize) -> Ray {
        let aspect = width as f64 / height as f64;
        let px = (2.0 * (x as f64 + 0.5) / width as f64 - 1.0) * self.tan_half_fov * aspect;
        let py = (1.0 - 2.0 * (y as f64 + 0.5) / height as f64) * self.tan_half_fov;
        Ray {
            origin: self.position,
            direction: (self.forward + px * self.right + py * self.up).normalize(),
        }
    }
}

pub struct Scene {
    pub kind: SceneKind,
    pub bvh: Bvh,
    pub materials: Vec<Material>,
    pub light: Light,
    pub medium: Option<Medium>,
    pub camera: Camera,
    /// A length that spans the scene (used for ray offsets and plots).
    pub size: f64,
}

/// A surface point seen along a ray: position, the normal facing the ray's origin side, and the
/// primitive and its (s, t) parameters.
#[derive(Clone, Copy, Debug)]
pub struct SurfacePoint {
    pub position: DVec3,
    pub normal: DVec3,
    pub hit: Hit,
}

/// Relative pull-back of a surface point towards the ray's origin (see [`Scene::intersect`]).
pub const PULL_BACK: f64 = 1e-4;

impl Scene {
    pub fn build(kind: SceneKind) -> Scene {
        match kind {
            SceneKind::Cornell => cornell(false),
            SceneKind::CornellBlack => cornell(true),
            SceneKind::Room => room(),
            SceneKind::Courtyard => courtyard(),
        }
    }

    /// Offset for spawning secondary rays off a surface.
    pub fn epsilon(&self) -> f64 {
        1e-7 * self.size
    }

    pub fn intersect(&self, ray: &Ray) -> Option<SurfacePoint> {
        let hit = self.bvh.intersect(ray, self.epsilon(), f64::INFINITY)?;
        let prim = self.bvh.primitive(hit.primitive);
        let mut normal = prim.normal;
        if normal.dot(ray.direction) > 0.0 {
            normal = -normal;
        }
        // The point is pulled back along the ray by 1e-4 of the hit distance (the advice of the
        // Embree section: scaled to the hit distance, so it means the same at every scene
        // scale): where two surfaces meet (a wall on the floor) a hit can land exactly on the
        // seam, and rays leaving a point on both planes at once would pass through the
        // neighbouring surface (light leaks into corners).
        Some(SurfacePoint {
            position: ray.origin + ray.direction * (hit.distance * (1.0 - PULL_BACK)),
            normal,
            hit,
        })
    }

    /// Direct irradiance (RGB) at a point with unit normal `n`, from the scene's light, with
    /// visibility and the medium's attenuation. `strata` × `strata` stratum-centre samples on an area
    /// light (deterministic, so light maps are smooth).
    pub fn direct_irradiance(&self, p: DVec3, n: DVec3, strata: usize) -> DVec3 {
        let eps = self.epsilon() * 10.0;
        match self.light {
            Light::Area {
                primitive,
                radiance,
            } => {
                let light = self.bvh.primitive(primitive);
                let area = light.area();
                let mut sum = 0.0;
                for i in 0..strata {
                    for j in 0..strata {
                        let q = light.point(
                            (i as f64 + 0.5) / strata as f64,
                            (j as f64 + 0.5) / strata as f64,
                        );
                        let d = q - p;
                        let r2 = d.length_squared();
                        let r = r2.sqrt();
                        let w = d / r;
                        let cos_r = n.dot(w);
                        let cos_l = -light.normal.dot(w);
                        if cos_r <= 0.0 || cos_l <= 0.0 {
                            continue;
                        }
                        let ray = Ray {
                            origin: p,
                            direction: w,
                        };
                        if self.bvh.occluded(&ray, eps, r * (1.0 - 1e-9)) {
                            continue;
                        }
                        sum += cos_r * cos_l / r2;
                    }
                }
                radiance * (sum * area / (strata * strata) as f64)
            }
            Light::Sun {
                direction,
                irradiance,
            } => {
                let to_sun = -direction;
                let cos = n.dot(to_sun);
                if cos <= 0.0 {
                    return DVec3::ZERO;
                }
                let ray = Ray {
                    origin: p,
                    direction: to_sun,
                };
                if self.bvh.occluded(&ray, eps, f64::INFINITY) {
                    return DVec3::ZERO;
                }
                irradiance * cos * self.sun_transmittance(p)
            }
        }
    }

    /// Transmittance from the sun to p through the medium (1 without medium or sun).
    pub fn sun_transmittance(&self, p: DVec3) -> f64 {
        match (self.light, self.medium) {
            (Light::Sun { direction, .. }, Some(m)) => {
                (-m.sigma_t() * m.inside_length(p, -direction, f64::INFINITY)).exp()
            }
            _ => 1.0,
        }
    }

    /// In-scattered radiance σ_s·L_i (RGB, per unit length) at a point in the medium: single
    /// scattering of the sun, isotropic phase function. Zero outside the medium.
    pub fn inscattered(&self, p: DVec3) -> DVec3 {
        let (
            Light::Sun {
                direction,
                irradiance,
            },
            Some(m),
        ) = (self.light, self.medium)
        else {
            return DVec3::ZERO;
        };
        let ray = Ray {
            origin: p,
            direction: -direction,
        };
        if self.bvh.occluded(&ray, 0.0, f64::INFINITY) {
            return DVec3::ZERO;
        }
        irradiance * (m.sigma_s * self.sun_transmittance(p) / (4.0 * PI))
    }
}

fn parallelogram(corner: [f64; 3], u: [f64; 3], v: [f64; 3]) -> Parallelogram {
    Parallelogram::new(DVec3::from(corner), DVec3::from(u), DVec3::from(v))
}

/// The five faces (no bottom) of a block standing on y = 0, normals outward: footprint corner, two
/// horizontal edges, height.
fn block(corner: DVec3, a: DVec3, b: DVec3, height: f64) -> Vec<Parallelogram> {
    let h = DVec3::new(0.0, height, 0.0);
    let centre = corner + 0.5 * (a + b + h);
    let outward = |p: DVec3, u: DVec3, v: DVec3| {
        let f = Parallelogram::new(p, u, v);
        if f.normal.dot(f.point(0.5, 0.5) - centre) < 0.0 {
            Parallelogram::new(p, v, u)
        } else {
            f
        }
    };
    let ring = [corner, corner + a, corner + a + b, corner + b];
    let mut faces = vec![outward(corner + h, a, b)];
    for i in 0..4 {
        faces.push(outward(ring[i], ring[(i + 1) % 4] - ring[i], h));
    }
    faces
}

/// The Cornell box's ceiling (y = 1, facing down) as four pieces around the square opening
/// [lo, hi]² in x and z.
fn ceiling_around(lo: f64, hi: f64) -> Vec<Parallelogram> {
    let w = hi - lo;
    vec![
        parallelogram([0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, lo]), // z < lo
        parallelogram([0.0, 1.0, hi], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0 - hi]), // z > hi
        parallelogram([0.0, 1.0, lo], [lo, 0.0, 0.0], [0.0, 0.0, w]),    // x < lo
        parallelogram([hi, 1.0, lo], [1.0 - hi, 0.0, 0.0], [0.0, 0.0, w]), // x > hi
    ]
}

fn rotated(angle_degrees: f64, length: f64) -> DVec3 {
    let a = angle_degrees.to_radians();
    DVec3::new(a.cos(), 0.0, -a.sin()) * length
}

fn cornell(black_back_wall: bool) -> Scene {
    let white = DVec3::splat(0.75);
    let red = DVec3::new(0.75, 0.12, 0.1);
    let green = DVec3::new(0.12, 0.65, 0.15);
    let back = if black_back_wall { DVec3::ZERO } else { white };
    let mut prims = Vec::new();
    let mut materials = Vec::new();
    let mut add = |p: Parallelogram, albedo: DVec3, emission: DVec3| {
        prims.push(p);
        materials.push(Material { albedo, emission });
        prims.len() - 1
    };
    let none = DVec3::ZERO;
    // Walls, normals facing into the box [0,1]³; the front (z = 1) is open towards the camera.
    add(
        parallelogram([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]),
        white,
        none,
    ); // floor
       // The ceiling, in four pieces around the light's opening (x, z in [0.38, 0.62]).
    for piece in ceiling_around(0.38, 0.62) {
        add(piece, white, none);
    }
    add(
        parallelogram([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        back,
        none,
    ); // back
    add(
        parallelogram([0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]),
        red,
        none,
    ); // left
    add(
        parallelogram([1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        green,
        none,
    ); // right
       // The light fills the ceiling's opening, flush with it and facing down. A panel hung below
       // the ceiling left a slit the camera looked into (its pixels held most of every metric's
       // squared error); a housing closing that slit made a 2 mm wall whose contact shadow on the
       // ceiling, one pixel row wide, did the same at 256 px. Flush, there is neither.
    let light_index = add(
        parallelogram([0.38, 1.0, 0.38], [0.24, 0.0, 0.0], [0.0, 0.0, 0.24]),
        none,
        DVec3::splat(1.0),
    );
    // Tall block (rotated) in the back left, short block in the front right.
    let tall = block(
        DVec3::new(0.18, 0.0, 0.42),
        rotated(18.0, 0.3),
        rotated(108.0, 0.3),
        0.62,
    );
    for f in tall {
        add(f, white, none);
    }
    let short = block(
        DVec3::new(0.56, 0.0, 0.78),
        rotated(-17.0, 0.28),
        rotated(73.0, 0.28),
        0.3,
    );
    for f in short {
        add(f, white, none);
    }
    // About π irradiance on the floor below the light.
    let light_radiance = DVec3::splat(50.0);
    materials[light_index].emission = light_radiance;
    Scene {
        kind: if black_back_wall {
            SceneKind::CornellBlack
        } else {
            SceneKind::Cornell
        },
        bvh: Bvh::new(prims),
        materials,
        light: Light::Area {
            primitive: light_index,
            radiance: light_radiance,
        },
        medium: None,
        camera: Camera::look_at(
            DVec3::new(0.5, 0.5, 2.35),
            DVec3::new(0.5, 0.5, 0.0),
            DVec3::Y,
            38.0,
        ),
        size: 1.0,
    }
}

fn room() -> Scene {
    let (w, h, d) = (4.0, 3.0, 4.0);
    let wall = DVec3::new(0.7, 0.68, 0.62);
    let floor = DVec3::new(0.45, 0.35, 0.28);
    let none = DVec3::ZERO;
    let mut prims = Vec::new();
    let mut materials = Vec::new();
    let mut add = |p: Parallelogram, albedo: DVec3| {
        prims.push(p);
        materials.push(Material {
            albedo,
            emission: none,
        });
    };
    add(
        parallelogram([0.0, 0.0, 0.0], [0.0, 0.0, d], [w, 0.0, 0.0]),
        floor,
    );
    add(
        parallelogram([0.0, h, 0.0], [w, 0.0, 0.0], [0.0, 0.0, d]),
        wall,
    );
    add(
        parallelogram([0.0, 0.0, 0.0], [w, 0.0, 0.0], [0.0, h, 0.0]),
        wall,
    ); // back z = 0
    add(
        parallelogram([0.0, 0.0, d], [0.0, h, 0.0], [w, 0.0, 0.0]),
        wall,
    ); // front z = d
    add(
        parallelogram([w, 0.0, 0.0], [0.0, 0.0, d], [0.0, h, 0.0]),
        wall,
    ); // right x = w
       // Left wall x = 0 with a window opening z in [1.3, 2.7], y in [1.0, 2.2]: four pieces.
    let (z0, z1, y0, y1) = (1.3, 2.7, 1.0, 2.2);
    add(
        parallelogram([0.0, 0.0, 0.0], [0.0, y0, 0.0], [0.0, 0.0, d]),
        wall,
    ); // below
    add(
        parallelogram([0.0, y1, 0.0], [0.0, h - y1, 0.0], [0.0, 0.0, d]),
        wall,
    ); // above
    add(
        parallelogram([0.0, y0, 0.0], [0.0, y1 - y0, 0.0], [0.0, 0.0, z0]),
        wall,
    ); // left of it
    add(
        parallelogram([0.0, y0, z1], [0.0, y1 - y0, 0.0], [0.0, 0.0, d - z1]),
        wall,
    ); // right
       // A table-like block in the sun patch.
    for f in block(
        DVec3::new(1.6, 0.0, 1.5),
        rotated(10.0, 0.9),
        rotated(100.0, 0.7),
        0.75,
    ) {
        add(f, DVec3::splat(0.6));
    }
    let direction = DVec3::new(1.0, -0.75, 0.15).normalize();
    Scene {
        kind: SceneKind::Room,
        bvh: Bvh::new(prims),
        materials,
        light: Light::Sun {
            direction,
            irradiance: DVec3::new(6.0, 5.6, 5.0),
        },
        medium: Some(Medium {
            sigma_s: 0.08,
            sigma_a: 0.02,
            lo: DVec3::ZERO,
            hi: DVec3::new(w, h, d),
        }),
        camera: Camera::look_at(
            DVec3::new(3.6, 1.5, 3.85),
            DVec3::new(1.2, 0.9, 0.6),
            DVec3::Y,
            62.0,
        ),
        size: 4.0,
    }
}

/// The courtyard's walkway: `WALKWAY.0` long (x from 0), `WALKWAY.1` deep (z from 0, the back wall,
/// to the colonnade's front) and `WALKWAY.2` high (y, the underside of the roof).
pub const COURTYARD_WALKWAY: (f64, f64, f64) = (10.0, 3.0, 3.0);

/// The x ranges of the courtyard's columns (square, their fronts flush with the roof's).
pub const COURTYARD_COLUMNS: [(f64, f64); 4] = [(1.6, 2.4), (3.6, 4.4), (5.6, 6.4), (7.6, 8.4)];

/// A covered walkway (arcade) along one side of a sunlit courtyard: a back wall, two end walls and
/// a roof slab on four square columns, every piece a closed block (the light map is one-sided, so
/// no surface may be seen from its back). The sun comes from above, behind the roof and from the
/// -x side: it lights the courtyard floor in front of the colonnade but nothing under the roof,
/// where all light is indirect, mostly from the courtyard floor through the gaps between the
/// columns, and the columns cast indirect shadows on the walkway floor and back wall.
fn courtyard() -> Scene {
    let (w, d, h) = COURTYARD_WALKWAY;
    let (thick, slab) = (0.3, 0.3);
    let stone = DVec3::new(0.72, 0.68, 0.6);
    let ground = DVec3::new(0.55, 0.48, 0.38);
    let none = DVec3::ZERO;
    let mut prims = Vec::new();
    let mut materials = Vec::new();
    let mut add = |faces: Vec<Parallelogram>, albedo: DVec3| {
        for f in faces {
            prims.push(f);
            materials.push(Material {
                albedo,
                emission: none,
            });
        }
    };
    let (x_axis, z_axis) = (DVec3::X, DVec3::Z);
    // The ground: the walkway floor and the courtyard, one plane facing up.
    add(
        vec![parallelogram(
            [-2.0, 0.0, -thick],
            [0.0, 0.0, 11.0 + thick],
            [w + 4.0, 0.0, 0.0],
        )],
        ground,
    );
    // Back wall (its front face at z = 0) and end walls (x = 0, x = w), up to the roof's underside.
    add(
        block(
            DVec3::new(-thick, 0.0, -thick),
            x_axis * (w + 2.0 * thick),
            z_axis * thick,
            h,
        ),
        stone,
    );
    for x in [-thick, w] {
        add(
            block(DVec3::new(x, 0.0, 0.0), x_axis * thick, z_axis * d, h),
            stone,
        );
    }
    for &(x0, x1) in &COURTYARD_COLUMNS {
        add(
            block(
                DVec3::new(x0, 0.0, d - (x1 - x0)),
                x_axis * (x1 - x0),
                z_axis * (x1 - x0),
                h,
            ),
            stone,
        );
    }
    // The roof slab over walls and columns: a block lifted to y = h, and its underside facing down.
    let roof_corner = DVec3::new(-thick, h, -thick);
    let (roof_x, roof_z) = (x_axis * (w + 2.0 * thick), z_axis * (d + thick));
    add(block(roof_corner, roof_x, roof_z, slab), stone);
    add(vec![Parallelogram::new(roof_corner, roof_x, roof_z)], stone);
    // Travelling +x and slightly +z: no sunlight enters the walkway through its open front.
    let direction = DVec3::new(0.55, -1.0, 0.12).normalize();
    Scene {
        kind: SceneKind::Courtyard,
        bvh: Bvh::new(prims),
        materials,
        light: Light::Sun {
            direction,
            irradiance: DVec3::new(6.0, 5.6, 5.0),
        },
        medium: None,
        camera: Camera::look_at(
            DVec3::new(9.6, 1.9, 0.4),
            DVec3::new(4.0, 0.0, 4.2),
            DVec3::Y,
            65.0,
        ),
        size: 14.0,
    }
}

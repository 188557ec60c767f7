//! Reflective shadow maps (Dachsbacher and Stamminger 2005, "Reflective Shadow Maps"): the
//! surfaces a light sees directly, one texel each, with world position, normal and reflected
//! flux — the virtual point lights of one-bounce GI. ROMA's one-bounce GI (paper §5.2, §6)
//! projects each secondary hit into the RSM to fetch its reflected radiance; the light-cuts
//! technique takes the texels as VPLs. Shared here so neither technique crate knows the other.
//!
//! What is stored per texel (flat arrays): the first surface along the texel's centre ray from
//! the light (found with the exact tracer: it plays the rasterizer), its unit normal facing the
//! light, its diffuse albedo, the **reflected flux** Φ = ρ · I(ω) · Δω (W; Δω is the texel's
//! solid angle, so Φ is the power the patch receives times ρ), the world area of the patch the
//! texel covers (`A = Δω · d² / cos θ`), and the distance from the light. A Lambertian patch
//! then reflects radiance `Φ / (π A) = ρ E / π` in every direction of its front side.
//!
//! Projections, per light kind (the paper: "512×512 RSM for each spot light and point light";
//! point-light maps and area lights are not described, so these are ours):
//! - spot light: a perspective frustum around its direction, half-angle = the outer cone angle
//!   (capped at 85°), intensity × glTF's falloff;
//! - point light: an octahedral map (Engelhardt and Dachsbacher) of the whole sphere;
//! - area light (the emissive triangles of one instance, e.g. the Cornell ceiling light): treated
//!   as a Lambertian **spot pointing along its mean normal**, from a point drawn uniformly on its
//!   area every frame (this is the per-frame "jittered light position" of paper §6), with
//!   intensity I(θ) = Σ L·A · cos θ, over a hemi-octahedral map of its front hemisphere. Averaged
//!   over frames this converges to the area light's own illumination of the first bounce;
//! - directional light: an orthographic map over the scene's bounding sphere (Φ = ρ · E⊥ · A⊥);
//! - the environment map ([`environment_lights`], for `gi-roma`): a few directions drawn from
//!   the map each frame, each a directional light.
//!
//! Point and spot maps get a per-frame sub-texel jitter of the texel ray instead.

use glimpse_core::sampling::{hammersley, octahedral_decode, octahedral_encode, rotate_sample};
use glimpse_core::{Frame, Ray, Rng, Vec2, Vec3};
use glimpse_scene::{LightKind, SceneFrame, frame::spot_falloff};
use glimpse_trace::{ExactTracer, SurfacePoint};
use rayon::prelude::*;
use std::f32::consts::PI;

/// How directions (or, for a directional light, positions) map to texels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Pinhole along the frame's z, `tan_half` = tan of the half field of view.
    Perspective { tan_half: f32 },
    /// The whole sphere (octahedral map, in the light's frame).
    Octahedral,
    /// The frame's +z hemisphere (the upper half of the octahedral map, rotated to fill the square).
    HemiOctahedral,
    /// Parallel rays along the frame's z over a square of half-size `half_extent` (world units).
    Orthographic { half_extent: f32 },
}

/// Radiant intensity of an RSM light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Emission {
    /// W/sr in every direction.
    Isotropic(Vec3),
    /// W/sr × glTF's smooth falloff between the inner and outer half-angles around the frame's z.
    Spot { intensity: Vec3, inner: f32, outer: f32 },
    /// A Lambertian emitter: I(θ) = `normal_intensity` · cos θ around the frame's z (W/sr).
    Lambertian(Vec3),
    /// Irradiance (W/m²) on a surface facing the light, travelling along the frame's z.
    Directional(Vec3),
}

/// One light as the RSM sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RsmLight {
    /// The light's position (for a directional light: the centre of the map's square, placed
    /// before the scene along the light's direction).
    pub position: Vec3,
    /// For an area light's point on its emitter, the magnitude that point's rounding error is
    /// relative to (the offset of the rays leaving it, [`glimpse_core::ray::error_scale`]); 0
    /// for the others, which are not on a surface.
    pub error_scale: f32,
    /// The light's frame; z is the axis of the projection (a spot's direction, an area light's
    /// normal, a directional light's direction of travel).
    pub axes: Frame,
    pub emission: Emission,
    pub projection: Projection,
}

impl RsmLight {
    /// Intensity (W/sr) towards unit direction `w` (world), for the non-directional kinds.
    pub fn intensity(&self, w: Vec3) -> Vec3 {
        let c = w.dot(self.axes.z);
        match self.emission {
            Emission::Isotropic(i) => i,
            Emission::Spot { intensity, inner, outer } => intensity * spot_falloff(c, inner, outer),
            Emission::Lambertian(i) => i * c.max(0.0),
            Emission::Directional(_) => Vec3::ZERO,
        }
    }
}

/// The RSM lights of a frame: every punctual light, and one Lambertian spot per instance with
/// emissive triangles, from a point drawn uniformly on that instance's emitting area with `rng`.
pub fn rsm_lights(frame: &SceneFrame, rng: &mut Rng) -> Vec<RsmLight> {
    let mut out = Vec::new();
    for l in &frame.lights {
        out.push(match l.kind {
            LightKind::Point => RsmLight {
                position: l.position,
                error_scale: 0.0,
                axes: Frame::from_z(Vec3::Z),
                emission: Emission::Isotropic(l.intensity),
                projection: Projection::Octahedral,
            },
            LightKind::Spot { inner_angle, outer_angle } => RsmLight {
                position: l.position,
                error_scale: 0.0,
                axes: Frame::from_z(l.direction),
                emission: Emission::Spot { intensity: l.intensity, inner: inner_angle, outer: outer_angle },
                projection: Projection::Perspective { tan_half: outer_angle.min(85f32.to_radians()).tan() },
            },
            LightKind::Directional => directional(frame, l.direction, l.intensity),
        });
    }
    // Area lights: group the emissive triangles by instance.
    let mut instances: Vec<u32> = frame.emissive.iter().map(|e| e.instance).collect();
    instances.sort_unstable();
    instances.dedup();
    for inst in instances {
        let tris: Vec<_> = frame.emissive.iter().filter(|e| e.instance == inst).collect();
        let area: f32 = tris.iter().map(|e| e.area).sum();
        let normal = tris.iter().fold(Vec3::ZERO, |n, e| n + e.normal * e.area).normalize_or(-Vec3::Y);
        let normal_intensity = tris.iter().fold(Vec3::ZERO, |i, e| i + e.radiance * e.area);
        // A uniform point on the instance's emitting area.
        let mut pick = rng.next_f32() * area;
        let tri = tris.iter().find(|e| {
            pick -= e.area;
            pick <= 0.0
        });
        let tri = tri.unwrap_or(tris.last().expect("an instance listed here has an emissive triangle"));
        let (position, error_scale) = tri.sample(rng.next_2d());
        out.push(RsmLight {
            position,
            error_scale,
            axes: Frame::from_z(normal),
            emission: Emission::Lambertian(normal_intensity),
            projection: Projection::HemiOctahedral,
        });
    }
    out
}

/// A directional light travelling along `direction` with irradiance `irradiance` on a surface
/// facing it: an orthographic map over the scene's bounding sphere.
fn directional(frame: &SceneFrame, direction: Vec3, irradiance: Vec3) -> RsmLight {
    let radius = (frame.bounds.extent().length() * 0.5).max(1e-3) * 1.01;
    RsmLight {
        position: frame.bounds.center() - direction * 2.0 * radius,
        error_scale: 0.0,
        axes: Frame::from_z(direction),
        emission: Emission::Directional(irradiance),
        projection: Projection::Orthographic { half_extent: radius },
    }
}

/// The environment map as `count` directional lights (ours: the RSM papers light scenes with
/// spot and point lights only): directions drawn from the map's importance distribution at a
/// randomly shifted Hammersley set (one per 1/`count` of the first dimension), each travelling
/// towards the scene with irradiance `L(ω) / (count · p(ω))`. Summed over the directions a
/// surface sees, their light is an unbiased one-sample-per-light estimate of the irradiance the
/// map gives it, visibility included (each map sees only what its direction lights), so a
/// technique that redraws them every frame converges to the map's light over its frames. Empty
/// without a map.
pub fn environment_lights(frame: &SceneFrame, count: u32, rng: &mut Rng) -> Vec<RsmLight> {
    let Some(env) = frame.scene.environment.as_ref() else {
        return Vec::new();
    };
    let shift = rng.next_2d();
    (0..count)
        .filter_map(|i| {
            let s = env.sample_direction(rotate_sample(hammersley(i, count), shift));
            let radiance = env.sample_radiance(&s);
            (s.pdf > 0.0 && radiance.max_element() > 0.0).then(|| directional(frame, -s.dir, radiance / (count as f32 * s.pdf)))
        })
        .collect()
}

/// Bytes per RSM texel: position, normal, albedo, flux (12 B each), error scale, area and depth
/// (4 B each).
pub const BYTES_PER_TEXEL: u64 = 4 * 12 + 3 * 4;

/// How many RSMs [`rsm_lights`] makes for `frame`: one per punctual light and one per instance
/// with emissive triangles.
pub fn rsm_light_count(frame: &SceneFrame) -> usize {
    let mut instances: Vec<u32> = frame.emissive.iter().map(|e| e.instance).collect();
    instances.sort_unstable();
    instances.dedup();
    frame.lights.len() + instances.len()
}

/// One reflective shadow map: `resolution²` texels, row-major, flat per-attribute arrays.
#[derive(Clone, Debug, Default)]
pub struct Rsm {
    pub resolution: u32,
    pub light: Option<RsmLight>,
    /// World position of the surface the texel sees (zero where it sees nothing).
    pub position: Vec<Vec3>,
    /// Each position's error scale (`SurfacePoint::error_scale`; 0 where empty): the offset of
    /// rays that end at a VPL placed there.
    pub error_scale: Vec<f32>,
    /// Unit normal facing the light (zero where the texel sees nothing).
    pub normal: Vec<Vec3>,
    pub albedo: Vec<Vec3>,
    /// Reflected flux Φ = ρ · I · Δω (W).
    pub flux: Vec<Vec3>,
    /// World area of the patch the texel covers (0 where empty).
    pub area: Vec<f32>,
    /// Distance from the light (along the direction for a directional light); ∞ where empty.
    pub depth: Vec<f32>,
}

impl Rsm {
    /// Renders the RSM of `light` at `resolution²` texels, each texel's ray through its centre
    /// moved by `jitter` (in texels, each component in [−0.5, 0.5)).
    pub fn build(frame: &SceneFrame, tracer: &ExactTracer, light: &RsmLight, resolution: u32, jitter: Vec2) -> Rsm {
        let r = resolution;
        let n = (r * r) as usize;
        let mut rsm = Rsm {
            resolution,
            light: Some(*light),
            position: vec![Vec3::ZERO; n],
            error_scale: vec![0.0; n],
            normal: vec![Vec3::ZERO; n],
            albedo: vec![Vec3::ZERO; n],
            flux: vec![Vec3::ZERO; n],
            area: vec![0.0; n],
            depth: vec![f32::INFINITY; n],
        };
        let texel_u = |i: usize| {
            let (x, y) = ((i as u32 % r) as f32, (i as u32 / r) as f32);
            Vec2::new((x + 0.5 + jitter.x) / r as f32, (y + 0.5 + jitter.y) / r as f32)
        };
        // A tile's rays leave one point (or go one way) nearly together: traced as packets.
        let hits = tracer.closest_hits_tiled(r, r, |i| texel_ray(light, texel_u(i)));
        // Each texel written in place by its thread (a map of up to 512² surface points, collected
        // and then copied out one by one, was a fifth of the build).
        let columns =
            (&mut rsm.position, &mut rsm.error_scale, &mut rsm.normal, &mut rsm.albedo, &mut rsm.flux, &mut rsm.area, &mut rsm.depth);
        columns.into_par_iter().enumerate().for_each(|(i, (position, error_scale, normal, albedo, texel_flux, texel_area, depth))| {
            let (x, y) = ((i as u32 % r) as f32, (i as u32 / r) as f32);
            let Some((ray, Some(hit))) = hits[i] else { return };
            let sp = SurfacePoint::from_hit(frame, &ray, &hit);
            let cos = sp.normal.dot(-ray.dir).max(0.0);
            let rho = sp.base_color(frame);
            let (flux, area) = match light.emission {
                Emission::Directional(e) => {
                    let side = 2.0 * half_extent(light) / r as f32;
                    (rho * e * side * side, side * side / cos.max(1e-4))
                }
                _ => {
                    let d_omega = texel_solid_angle(light, x as u32, y as u32, r);
                    let d2 = (sp.position - light.position).length_squared();
                    (rho * light.intensity(ray.dir) * d_omega, d_omega * d2 / cos.max(1e-4))
                }
            };
            *position = sp.position;
            *normal = sp.normal;
            *error_scale = sp.error_scale;
            *albedo = rho;
            *texel_flux = flux;
            *texel_area = area;
            *depth = light_depth(light, sp.position);
        });
        rsm
    }

    pub fn len(&self) -> usize {
        self.depth.len()
    }

    pub fn is_empty(&self) -> bool {
        self.depth.is_empty()
    }

    pub fn memory_bytes(&self) -> usize {
        self.len() * BYTES_PER_TEXEL as usize
    }

    /// Total reflected flux of the map (W per channel).
    pub fn total_flux(&self) -> Vec3 {
        self.flux.iter().copied().sum()
    }

    /// Radiance the patch of texel `i` reflects (Lambertian): Φ / (π A).
    pub fn radiance(&self, i: usize) -> Vec3 {
        if self.area[i] > 0.0 { self.flux[i] / (PI * self.area[i]) } else { Vec3::ZERO }
    }

    /// The texel a world point projects to and the point's depth from the light.
    pub fn project(&self, p: Vec3) -> Option<(usize, f32)> {
        let light = self.light.as_ref()?;
        let u = texel_coordinates(light, p)?;
        let r = self.resolution;
        let (x, y) = ((u.x * r as f32) as u32, (u.y * r as f32) as u32);
        (x < r && y < r).then(|| ((y * r + x) as usize, light_depth(light, p)))
    }

    /// Radiance reflected towards `viewer` by the directly lit surface at `p`, or zero when `p`
    /// is farther from the light than the texel's surface by more than `bias` plus the texel's
    /// own depth range (in shadow), or the viewer is behind the texel's surface.
    pub fn lit_radiance(&self, p: Vec3, viewer: Vec3, bias: f32) -> Vec3 {
        let Some((i, depth)) = self.project(p) else {
            return Vec3::ZERO;
        };
        let limit = self.depth[i] + bias + self.slope_depth(i);
        let in_shadow = depth.partial_cmp(&limit) != Some(std::cmp::Ordering::Less);
        if in_shadow || self.normal[i].dot(viewer - self.position[i]) <= 0.0 {
            return Vec3::ZERO;
        }
        self.radiance(i)
    }
}

impl Rsm {
    /// How far from the light the texel's own surface reaches beyond its centre's depth: the
    /// half-diagonal of its footprint across the light's rays times the tangent of the surface's
    /// tilt from them (capped at 10, i.e. 84°). A surface point in the texel but off its centre
    /// is up to this much deeper; without it a tilted surface shadows itself in stripes wherever
    /// the texels are larger than `bias` (the standard slope-scaled depth bias of shadow maps).
    /// The environment's orthographic maps over a whole scene have texels of decimetres, while
    /// `gi-roma`'s bias is two ROMA cells of a centimetre or two under `focus=auto`: without this
    /// a floor lit by the sky lost 30 % of its light in the bounce.
    fn slope_depth(&self, i: usize) -> f32 {
        let Some(light) = self.light.as_ref() else { return 0.0 };
        let towards_light = match light.projection {
            Projection::Orthographic { .. } => -light.axes.z,
            _ => (light.position - self.position[i]).normalize_or_zero(),
        };
        let cos = self.normal[i].dot(towards_light).abs().clamp(0.1, 1.0);
        // The texel's side across the rays: its surface area projected onto their plane.
        let side = (self.area[i] * cos).sqrt();
        side * std::f32::consts::FRAC_1_SQRT_2 * (1.0 - cos * cos).sqrt() / cos
    }
}

fn half_extent(light: &RsmLight) -> f32 {
    match light.projection {
        Projection::Orthographic { half_extent } => half_extent,
        _ => 0.0,
    }
}

/// Distance of `p` from the light (along the axis for a directional light).
fn light_depth(light: &RsmLight, p: Vec3) -> f32 {
    match light.projection {
        Projection::Orthographic { .. } => (p - light.position).dot(light.axes.z),
        _ => (p - light.position).length(),
    }
}

/// Map coordinates in [0,1]² → direction in the light's local frame (not for orthographic).
fn local_direction(projection: Projection, u: Vec2) -> Option<Vec3> {
    let o = u * 2.0 - Vec2::ONE;
    match projection {
        Projection::Perspective { tan_half } => Some(Vec3::new(o.x * tan_half, o.y * tan_half, 1.0).normalize()),
        Projection::Octahedral => Some(octahedral_decode(u)),
        Projection::HemiOctahedral => {
            let p = Vec2::new(0.5 * (o.x + o.y), 0.5 * (o.x - o.y));
            Some(Vec3::new(p.x, p.y, (1.0 - p.x.abs() - p.y.abs()).max(0.0)).normalize())
        }
        Projection::Orthographic { .. } => None,
    }
}

/// The ray of map coordinates `u` (world space).
fn texel_ray(light: &RsmLight, u: Vec2) -> Option<Ray> {
    match light.projection {
        Projection::Orthographic { half_extent } => {
            let o = (u * 2.0 - Vec2::ONE) * half_extent;
            Some(Ray::new(light.position + light.axes.x * o.x + light.axes.y * o.y, light.axes.z))
        }
        p => {
            let d = light.axes.to_world(local_direction(p, u)?).normalize();
            // An area light's point lies on its own emitter: leave it along the emitter normal.
            let origin = if matches!(light.emission, Emission::Lambertian(_)) {
                glimpse_core::ray::offset_origin(light.position, light.axes.z, light.error_scale)
            } else {
                light.position
            };
            Some(Ray::new(origin, d))
        }
    }
}

/// Map coordinates in [0,1]² of world point `p`, if the map covers it.
fn texel_coordinates(light: &RsmLight, p: Vec3) -> Option<Vec2> {
    let local = light.axes.to_local(p - light.position);
    let u = match light.projection {
        Projection::Orthographic { half_extent } => Vec2::new(local.x, local.y) / half_extent,
        Projection::Perspective { tan_half } => {
            if local.z <= 0.0 {
                return None;
            }
            Vec2::new(local.x, local.y) / (local.z * tan_half)
        }
        Projection::Octahedral => return Some(octahedral_encode(local.normalize_or(Vec3::Z))),
        Projection::HemiOctahedral => {
            if local.z < 0.0 {
                return None;
            }
            let l1 = local.x.abs() + local.y.abs() + local.z;
            if l1 <= 0.0 {
                return None;
            }
            let q = Vec2::new(local.x, local.y) / l1;
            Vec2::new(q.x + q.y, q.x - q.y)
        }
    };
    let u = (u + Vec2::ONE) * 0.5;
    (u.x >= 0.0 && u.y >= 0.0 && u.x <= 1.0 && u.y <= 1.0).then_some(u)
}

/// Solid angle of texel (x, y): its spherical quad, as two triangles (Van Oosterom and
/// Strackee's formula).
fn texel_solid_angle(light: &RsmLight, x: u32, y: u32, r: u32) -> f32 {
    let corner = |i: u32, j: u32| local_direction(light.projection, Vec2::new(i as f32 / r as f32, j as f32 / r as f32)).unwrap_or(Vec3::Z);
    let (a, b, c, d) = (corner(x, y), corner(x + 1, y), corner(x + 1, y + 1), corner(x, y + 1));
    triangle_solid_angle(a, b, c) + triangle_solid_angle(a, c, d)
}

fn triangle_solid_angle(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_scene::{Light, Scene};

    #[test]
    fn texel_solid_angles_cover_the_sphere_and_hemisphere() {
        for (projection, expected) in [(Projection::Octahedral, 4.0 * PI), (Projection::HemiOctahedral, 2.0 * PI)] {
            let light = RsmLight {
                position: Vec3::ZERO,
                error_scale: 0.0,
                axes: Frame::from_z(Vec3::Y),
                emission: Emission::Isotropic(Vec3::ONE),
                projection,
            };
            let r = 64;
            let total: f32 = (0..r * r).map(|i| texel_solid_angle(&light, i % r, i / r, r)).sum();
            println!("{projection:?}: Σ Δω = {total:.5} (expected {expected:.5})");
            assert!((total - expected).abs() < 1e-3 * expected);
        }
    }

    #[test]
    fn projection_round_trips() {
        let mut rng = Rng::new(5, 1);
        for projection in [Projection::Octahedral, Projection::HemiOctahedral, Projection::Perspective { tan_half: 1.0 }] {
            let light = RsmLight {
                position: Vec3::new(1.0, 2.0, 3.0),
                error_scale: 0.0,
                axes: Frame::from_z(Vec3::new(0.3, -1.0, 0.2).normalize()),
                emission: Emission::Isotropic(Vec3::ONE),
                projection,
            };
            let mut worst = 0.0f32;
            for _ in 0..2000 {
                let u = Vec2::new(0.05, 0.05) + rng.next_2d() * 0.9;
                let ray = texel_ray(&light, u).unwrap();
                let back = texel_coordinates(&light, ray.at(2.5)).unwrap();
                worst = worst.max((back - u).abs().max_element());
            }
            println!("{projection:?}: worst map round-trip error {worst:e}");
            assert!(worst < 1e-4);
        }
    }

    /// A point light above an infinite-ish white floor: the RSM's total flux is ρ times the
    /// power the floor receives, and every texel's radiance is ρ E / π.
    /// A white (ρ = 0.5) square floor of half-size `q` at y = 0, facing up, and nothing else.
    fn white_floor(q: f32) -> Scene {
        let mut s = Scene::default();
        let white = s.add_material(glimpse_scene::Material::diffuse("w", Vec3::splat(0.5)));
        let floor = glimpse_scene::Mesh {
            name: "floor".into(),
            positions: vec![Vec3::new(-q, 0.0, -q), Vec3::new(q, 0.0, -q), Vec3::new(q, 0.0, q), Vec3::new(-q, 0.0, q)],
            indices: vec![[0, 2, 1], [0, 3, 2]],
            material: white,
            ..Default::default()
        };
        s.add_mesh(floor, glimpse_core::Mat4::IDENTITY);
        s
    }

    #[test]
    fn point_light_over_a_floor_reflects_rho_e_over_pi() {
        let q = 50.0;
        let mut s = white_floor(q);
        s.lights.push(Light::point(Vec3::new(0.0, 1.0, 0.0), Vec3::splat(10.0)));
        let frame = s.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let lights = rsm_lights(&frame, &mut Rng::new(0, 0));
        let rsm = Rsm::build(&frame, &tracer, &lights[0], 128, Vec2::ZERO);
        // The floor subtends (almost) the lower hemisphere: Φ ≈ ρ · I · 2π.
        let expected = 0.5 * 10.0 * 2.0 * PI * (1.0 - 1.0 / (1.0f32 + 2.0 * q * q).sqrt());
        let total = rsm.total_flux().x;
        let i = rsm.project(Vec3::new(0.3, 0.0, -0.2)).unwrap().0;
        let p = rsm.position[i];
        let e = 10.0 * (1.0 / (p - Vec3::Y).length()).powi(3); // I cos θ / d², cos θ = h/d
        println!("total flux {total:.4} (expected ≈ {expected:.4}); texel radiance {:.5} vs ρE/π {:.5}", rsm.radiance(i).x, 0.5 * e / PI);
        assert!((total - expected).abs() < 0.02 * expected);
        assert!((rsm.radiance(i).x - 0.5 * e / PI).abs() < 0.02 * 0.5 * e / PI);
    }

    /// The environment's directional lights estimate the map's irradiance without bias: on an
    /// open floor under a constant sky of radiance L, Σ_k ρ E_k cos θ_k / π (each map's texel
    /// radiance) averages to ρ L, and directions from below light nothing (the floor hides them).
    #[test]
    fn environment_lights_average_to_the_maps_irradiance() {
        let mut s = white_floor(10.0);
        let frame = s.at(0.0);
        assert!(environment_lights(&frame, 4, &mut Rng::new(0, 0)).is_empty(), "no map, no lights");
        s.environment = Some(glimpse_scene::Environment::constant(Vec3::splat(2.0)));
        let frame = s.at(0.0);
        let tracer = ExactTracer::build(&frame);
        let mut rng = Rng::new(3, 0);
        let (rounds, count) = (2000, 4);
        let mut sum = 0.0f64;
        for _ in 0..rounds {
            let lights = environment_lights(&frame, count, &mut rng);
            assert_eq!(lights.len(), count as usize);
            for light in &lights {
                let rsm = Rsm::build(&frame, &tracer, light, 32, Vec2::ZERO);
                // The floor point the texel over its centre sees, seen from above (from below
                // the map shows the floor's back: unlit). At 32² texels that point is on the
                // floor unless the direction grazes it (cos θ < 0.04: 0.2 % of the light).
                let p = rsm.position[rsm.project(Vec3::ZERO).unwrap().0];
                sum += rsm.lit_radiance(p, p + Vec3::Y, 1e-3).x as f64;
            }
        }
        let mean = sum / rounds as f64;
        println!("floor radiance from {count} environment directions, mean of {rounds} draws: {mean:.4} (ρL = 1)");
        assert!((mean - 1.0).abs() < 0.05, "{mean}"); // about 3.5 standard errors
    }
}

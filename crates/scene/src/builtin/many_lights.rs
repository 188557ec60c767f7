//! A small town at night lit only by many small coloured point lights, for many-light sampling.
//!
//! 4 × 4 blocks on a 10 m grid (centres at ±5 and ±15 m) hold boxy buildings, round towers with
//! domes and two fountain plazas; everything stays within ±3 m of its block centre, which leaves
//! streets 4 m wide on the lines x, z ∈ {−20, −10, 0, 10, 20} m. Each light circles a centre near
//! a street's centre line (at most 0.3 m off it, 1.5–4.5 m up) on a tilted orbit of radius
//! 0.3–1.2 m with its own period (3–12 s, either way round) and phase, so it never leaves the
//! street nor comes within 0.3 m of the ground. Layout and lights are seeded separately, so
//! `many_lights(n)` shares its first lights with every larger `n`; intensities scale with
//! 1,024 / n so that the town's brightness does not depend on the count (mean irradiance on the
//! ground ≈ 1 W/m² without occlusion).

use super::{box_mesh, cylinder_mesh, plane_mesh, sphere_mesh};
use crate::{Camera, Light, Material, Motion, Scene};
use glimpse_core::{Mat4, Rng, Vec2, Vec3, luminance};

/// The light count of the built-in `many-lights` scene.
pub const DEFAULT_LIGHT_COUNT: usize = 1024;

const SEED: u64 = 0x6c69_6768_7473; // "lights"
/// Block pitch; block centres at (i − 1.5) · CELL and street centre lines at (k − 2) · CELL.
const CELL: f32 = 10.0;
/// Every object stays within this distance (x and z) of its block centre.
const LOT_HALF: f32 = 3.0;
const GROUND_HALF: f32 = 25.0;
/// Mean luminous intensity (W/sr) of one light when there are [`DEFAULT_LIGHT_COUNT`].
const MEAN_INTENSITY: f32 = 0.43;

pub fn many_lights(light_count: usize) -> Scene {
    let mut s = Scene { name: "many-lights".into(), ..Default::default() };
    let asphalt = s.add_material(Material::diffuse("asphalt", Vec3::splat(0.3)));
    let walls = [
        s.add_material(Material::diffuse("plaster", Vec3::new(0.8, 0.75, 0.65))),
        s.add_material(Material::diffuse("concrete", Vec3::splat(0.6))),
        s.add_material(Material::diffuse("brick", Vec3::new(0.6, 0.28, 0.2))),
        s.add_material(Material::diffuse("whitewash", Vec3::splat(0.85))),
    ];
    let copper = s.add_material(Material::diffuse("copper patina", Vec3::new(0.3, 0.6, 0.5)));
    let stone = s.add_material(Material::diffuse("stone", Vec3::new(0.7, 0.68, 0.62)));

    let ground = plane_mesh("ground", asphalt, Vec2::splat(2.0 * GROUND_HALF), [50, 50]);
    s.add_mesh(ground, Mat4::IDENTITY);

    let mut rng = Rng::new(SEED, 0);
    let mut uniform = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let at = |c: Vec3, scale: Vec3| Mat4::from_scale_rotation_translation(scale, glimpse_core::Quat::IDENTITY, c);
    for j in 0..4 {
        for i in 0..4 {
            let c = Vec3::new((i as f32 - 1.5) * CELL, 0.0, (j as f32 - 1.5) * CELL);
            let wall = walls[(i + 2 * j) % walls.len()];
            match (i, j) {
                (1, 2) | (2, 1) => {
                    // A fountain: a wide low basin with a stone ball on it.
                    let (r, h) = (uniform(2.2, LOT_HALF), uniform(0.3, 0.6));
                    s.add_mesh(cylinder_mesh("basin", stone, 48), at(c + Vec3::Y * h * 0.5, Vec3::new(r, h * 0.5, r)));
                    let ball = uniform(0.8, 1.4);
                    s.add_mesh(sphere_mesh("fountain ball", stone, 24, 48), at(c + Vec3::Y * (h + ball), Vec3::splat(ball)));
                }
                (0, 3) | (3, 0) | (1, 1) => {
                    // A round tower with a dome.
                    let (r, h) = (uniform(1.6, 2.6), uniform(5.0, 11.0));
                    s.add_mesh(cylinder_mesh("tower", wall, 32), at(c + Vec3::Y * h * 0.5, Vec3::new(r, h * 0.5, r)));
                    s.add_mesh(sphere_mesh("dome", copper, 16, 32), at(c + Vec3::Y * h, Vec3::splat(r)));
                }
                _ => {
                    // A building, off-centre in its lot, and often a low annex in a corner.
                    let half = Vec3::new(uniform(1.8, LOT_HALF), uniform(1.0, 4.5), uniform(1.8, LOT_HALF));
                    let slack = Vec2::new(LOT_HALF - half.x, LOT_HALF - half.z);
                    let offset = Vec3::new(uniform(-slack.x, slack.x), half.y, uniform(-slack.y, slack.y));
                    s.add_mesh(box_mesh("building", wall, half), Mat4::from_translation(c + offset));
                    if uniform(0.0, 1.0) < 0.7 {
                        let half = Vec3::new(uniform(0.8, 1.5), uniform(0.5, 1.5), uniform(0.8, 1.5));
                        let corner = Vec3::new(
                            if uniform(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 },
                            0.0,
                            if uniform(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 },
                        );
                        let offset = corner * (Vec3::splat(LOT_HALF) - half) + Vec3::Y * half.y;
                        s.add_mesh(box_mesh("annex", walls[(i + 2 * j + 1) % walls.len()], half), Mat4::from_translation(c + offset));
                    }
                }
            }
        }
    }

    let mut rng = Rng::new(SEED, 1);
    let mut uniform = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let scale = MEAN_INTENSITY * DEFAULT_LIGHT_COUNT as f32 / light_count.max(1) as f32;
    for _ in 0..light_count {
        let street = (uniform(0.0, 5.0).floor().min(4.0) - 2.0) * CELL + uniform(-0.3, 0.3);
        let along = uniform(-(GROUND_HALF - 1.5), GROUND_HALF - 1.5);
        let height = uniform(1.5, 4.5);
        let center = if uniform(0.0, 1.0) < 0.5 { Vec3::new(along, height, street) } else { Vec3::new(street, height, along) };
        let mut axis = Vec3::new(uniform(-0.6, 0.6), 1.0, uniform(-0.6, 0.6)).normalize();
        if uniform(0.0, 1.0) < 0.5 {
            axis = -axis;
        }
        let radius = uniform(0.3, 1.2);
        let start = center + axis.any_orthonormal_vector() * radius;
        let colour = hue(uniform(0.0, 1.0)).lerp(Vec3::ONE, uniform(0.1, 0.7));
        let intensity = colour / luminance(colour) * scale * uniform(0.5, 1.5);
        let motion = Motion::Orbit { base: Mat4::IDENTITY, center, axis, period_s: uniform(3.0, 12.0), phase: uniform(0.0, 1.0) };
        s.lights.push(Light::point(start, intensity).with_motion(motion));
    }

    s.camera = Some(Camera::look_at(Vec3::new(4.0, 24.0, 40.0), Vec3::new(0.0, 0.0, 2.0), Vec3::Y, 50.0));
    s
}

/// A fully saturated colour of hue `h` in [0, 1).
fn hue(h: f32) -> Vec3 {
    let h6 = h * 6.0;
    Vec3::new((h6 - 3.0).abs() - 1.0, 2.0 - (h6 - 2.0).abs(), 2.0 - (h6 - 4.0).abs()).clamp(Vec3::ZERO, Vec3::ONE)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Aabb;

    #[test]
    fn count_is_a_parameter_and_brightness_does_not_depend_on_it() {
        let s = crate::load("many-lights").unwrap();
        assert_eq!(s.lights.len(), DEFAULT_LIGHT_COUNT);
        assert!(s.lights.iter().all(|l| matches!(l.motion, Motion::Orbit { .. })));
        let small = many_lights(100);
        let power = |s: &Scene| s.lights.iter().map(|l| luminance(l.intensity)).sum::<f32>();
        println!(
            "{} triangles; total intensity {:.1} W/sr with {} lights, {:.1} W/sr with {}",
            s.triangle_count(),
            power(&s),
            s.lights.len(),
            power(&small),
            small.lights.len()
        );
        assert_eq!(small.lights.len(), 100);
        assert!((power(&small) / power(&s) - 1.0).abs() < 0.15);
        assert_eq!(small.lights[7].position, s.lights[7].position, "the same seed gives the same first lights");
    }

    #[test]
    fn lights_stay_in_the_streets_above_the_ground() {
        let s = many_lights(DEFAULT_LIGHT_COUNT);
        let (mut lowest, mut clearance) = (f32::INFINITY, f32::INFINITY);
        for t in [0.0, 1.7, 3.3, 6.1, 9.8] {
            let f = s.at(t);
            let solids: Vec<Aabb> = s
                .instances
                .iter()
                .enumerate()
                .filter(|(_, i)| s.meshes[i.mesh as usize].name != "ground")
                .map(|(ii, i)| s.meshes[i.mesh as usize].bounds().transform(&f.transforms[ii]))
                .collect();
            for l in &f.lights {
                let p = l.position;
                lowest = lowest.min(p.y);
                for b in &solids {
                    clearance = clearance.min((b.min - p).max(p - b.max).max(Vec3::ZERO).length());
                }
                assert!(p.x.abs() < GROUND_HALF && p.z.abs() < GROUND_HALF, "light off the ground at {p}");
            }
        }
        println!("over 5 times: lowest light {lowest:.2} m above the ground; closest light to an object's box {clearance:.2} m");
        assert!(lowest > 0.25 && clearance > 0.25);
    }

    #[test]
    fn ground_irradiance_is_of_order_one() {
        let s = many_lights(DEFAULT_LIGHT_COUNT);
        for t in [0.0, 5.0] {
            let f = s.at(t);
            let n = 41;
            let mut e = Vec::new();
            for j in 0..n {
                for i in 0..n {
                    let p = Vec3::new(i as f32, 0.0, j as f32) * (2.0 * 24.0 / (n - 1) as f32) - Vec3::new(24.0, 0.0, 24.0);
                    // Unoccluded irradiance on the ground: Σ I cosθ / d².
                    let sum: Vec3 = f
                        .lights
                        .iter()
                        .map(|l| {
                            let (wi, _, e) = l.incident(p);
                            e * wi.y.max(0.0)
                        })
                        .sum();
                    e.push(luminance(sum));
                }
            }
            let mean = e.iter().sum::<f32>() / e.len() as f32;
            let (lo, hi) = e.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &v| (lo.min(v), hi.max(v)));
            println!("t = {t} s: ground irradiance over {} points: mean {mean:.3}, min {lo:.3}, max {hi:.3} W/m²", e.len());
            assert!((0.4..2.5).contains(&mean), "mean ground irradiance {mean}");
        }
    }
}

//! Daylight: objects on a large ground (80 × 80 m) lit only by
//! `Environment::procedural_sky(256, …)` with a low sun 20° above the horizon, 25° left of the
//! camera's view, so the sun disk is in the picture (for any aspect ratio from 1:1 up) and shadows
//! are long. The objects give occlusion to look at: an arch and a table (overhangs), a column,
//! stacked boxes, spheres (one under the table), a tall block and a big sphere farther back.
//! A red ball (radius 0.5 m) circles the group at 6 m every 10 s, so acceleration structures and
//! caches have to follow one moving object per frame. No punctual lights: the sun is in the map.

use super::{box_mesh, cylinder_mesh, plane_mesh, sphere_mesh};
use crate::{Camera, Environment, Instance, Material, Motion, Scene};
use glimpse_core::{Mat4, Vec2, Vec3};

/// Radiance of the sun disk (2° radius): about 10 W/m² at normal incidence, ~3.4 W/m² on the
/// ground at 20° elevation, against ~1.8 W/m² from the rest of the sky.
pub const SUN_RADIANCE: f32 = 2500.0;
/// Radius of the moving ball's circle around the origin.
const ORBIT_RADIUS: f32 = 6.0;

/// Unit direction towards the sun: elevation 20°, azimuth 25° from −z towards −x.
pub fn sun_direction() -> Vec3 {
    let (elevation, azimuth) = (20f32.to_radians(), 25f32.to_radians());
    Vec3::new(-azimuth.sin() * elevation.cos(), elevation.sin(), -azimuth.cos() * elevation.cos())
}

pub fn sky() -> Scene {
    let mut s = Scene { name: "sky".into(), ..Default::default() };
    let ground = s.add_material(Material::diffuse("ground", Vec3::new(0.45, 0.42, 0.38)));
    let stone = s.add_material(Material::diffuse("stone", Vec3::new(0.7, 0.68, 0.62)));
    let wood = s.add_material(Material::diffuse("wood", Vec3::new(0.55, 0.38, 0.22)));
    let white = s.add_material(Material::diffuse("white", Vec3::splat(0.8)));
    let blue = s.add_material(Material::diffuse("blue", Vec3::new(0.15, 0.3, 0.7)));
    let red = s.add_material(Material::diffuse("red", Vec3::new(0.7, 0.15, 0.1)));

    s.add_mesh(plane_mesh("ground", ground, Vec2::splat(80.0), [40, 40]), Mat4::IDENTITY);

    // Unit-size meshes (box half 1, sphere radius 1, cylinder radius 1 from y = −1 to 1) placed
    // by `place · translate(centre) · scale(half)`.
    let part = |s: &mut Scene, mesh: crate::Mesh, place: Mat4, centre: Vec3, half: Vec3| {
        s.add_mesh(mesh, place * Mat4::from_translation(centre) * Mat4::from_scale(half));
    };
    let cube = |name: &str, material| box_mesh(name, material, Vec3::ONE);

    // Arch: two pillars 2.4 m tall carrying a lintel.
    let arch = Mat4::from_translation(Vec3::new(-2.5, 0.0, -2.0)) * Mat4::from_rotation_y(15f32.to_radians());
    for x in [-1.0, 1.0] {
        part(&mut s, cube("arch pillar", stone), arch, Vec3::new(x, 1.2, 0.0), Vec3::new(0.3, 1.2, 0.4));
    }
    part(&mut s, cube("arch lintel", stone), arch, Vec3::new(0.0, 2.65, 0.0), Vec3::new(1.6, 0.25, 0.5));

    // Table: a 2 × 1.2 m top at 0.8 m on four legs, with a ball underneath.
    let table = Mat4::from_translation(Vec3::new(2.5, 0.0, -1.5)) * Mat4::from_rotation_y(-15f32.to_radians());
    part(&mut s, cube("table top", wood), table, Vec3::new(0.0, 0.76, 0.0), Vec3::new(1.0, 0.04, 0.6));
    for (x, z) in [(-0.9, -0.5), (0.9, -0.5), (-0.9, 0.5), (0.9, 0.5)] {
        part(&mut s, cube("table leg", wood), table, Vec3::new(x, 0.36, z), Vec3::new(0.04, 0.36, 0.04));
    }
    part(&mut s, sphere_mesh("ball under table", blue, 16, 32), table, Vec3::new(0.3, 0.25, 0.1), Vec3::splat(0.25));

    // A column, a big sphere, two stacked boxes (the top one turned).
    part(&mut s, cylinder_mesh("column", stone, 32), Mat4::IDENTITY, Vec3::new(0.5, 1.5, -3.5), Vec3::new(0.4, 1.5, 0.4));
    part(&mut s, sphere_mesh("sphere", white, 32, 64), Mat4::IDENTITY, Vec3::new(1.5, 0.8, 2.0), Vec3::splat(0.8));
    part(&mut s, cube("box", white), Mat4::IDENTITY, Vec3::new(-1.2, 0.5, 2.8), Vec3::splat(0.5));
    let turned = Mat4::from_translation(Vec3::new(-1.2, 1.0, 2.8)) * Mat4::from_rotation_y(35f32.to_radians());
    part(&mut s, cube("box on box", blue), turned, Vec3::new(0.0, 0.35, 0.0), Vec3::splat(0.35));

    // Farther back, outside the moving ball's circle.
    part(&mut s, cube("tall block", white), Mat4::IDENTITY, Vec3::new(-9.0, 3.0, -7.0), Vec3::new(1.5, 3.0, 1.5));
    part(&mut s, sphere_mesh("big sphere", stone, 32, 64), Mat4::IDENTITY, Vec3::new(8.5, 1.2, -4.0), Vec3::splat(1.2));

    // The moving ball, circling the origin on the ground.
    s.meshes.push(sphere_mesh("moving ball", red, 24, 48));
    let base = Mat4::from_translation(Vec3::new(ORBIT_RADIUS, 0.5, 0.0)) * Mat4::from_scale(Vec3::splat(0.5));
    let motion = Motion::Orbit { base, center: Vec3::ZERO, axis: Vec3::Y, period_s: 10.0, phase: 0.0 };
    s.instances.push(Instance { mesh: s.meshes.len() as u32 - 1, motion });

    s.environment = Some(Environment::procedural_sky(256, sun_direction(), SUN_RADIANCE));
    s.camera = Some(Camera::look_at(Vec3::new(0.0, 1.7, 12.0), Vec3::new(0.0, 1.6, 0.0), Vec3::Y, 55.0));
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::luminance;
    use std::f32::consts::{PI, TAU};

    #[test]
    fn brightest_direction_is_the_sun_and_it_dominates() {
        let s = crate::load("sky").unwrap();
        assert!(s.lights.is_empty());
        let env = s.environment.as_ref().unwrap();
        let (w, h) = (env.image.width, env.image.height);
        let (mut best, mut best_dir) = (0.0f32, Vec3::ZERO);
        let (mut sun_normal, mut sky_ground) = (0.0f32, 0.0f32);
        let sun = sun_direction();
        let mut texels = Vec::new();
        for y in 0..h {
            // Solid angle of a texel in row y.
            let dw = TAU / w as f32 * ((PI * y as f32 / h as f32).cos() - (PI * (y + 1) as f32 / h as f32).cos());
            for x in 0..w {
                let d = Environment::uv_to_dir(Vec2::new((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32));
                let l = luminance(env.image.get(x, y)) * env.scale;
                if l > best {
                    (best, best_dir) = (l, d);
                }
                texels.push((l, d));
                if d.dot(sun) > 4f32.to_radians().cos() {
                    sun_normal += l * d.dot(sun) * dw;
                } else {
                    sky_ground += l * d.y.max(0.0) * dw;
                }
            }
        }
        // Every texel of the sun disk is equally bright: the brightest one lies within the disk
        // (2° radius plus half a texel), and the centroid of the bright texels on the sun.
        let bright: Vec3 = texels.iter().filter(|(l, _)| *l > 0.5 * best).map(|(l, d)| *d * *l).sum();
        let (angle, centroid_angle) = (best_dir.angle_between(sun).to_degrees(), bright.normalize().angle_between(sun).to_degrees());
        let sun_ground = sun_normal * sun.y;
        println!(
            "brightest texel {best:.0} W/(m²·sr) at {angle:.2}° from the sun, bright texels' centroid at {centroid_angle:.2}°; sun irradiance {sun_normal:.2} W/m² facing it, {sun_ground:.2} on the ground; sky alone {sky_ground:.2} on the ground"
        );
        assert!(angle < 2.0 + 1.0, "brightest direction {best_dir} is {angle}° from the sun {sun}");
        assert!(centroid_angle < 0.5, "bright texels centre {centroid_angle}° from the sun");
        assert!(best > 100.0 * luminance(env.radiance(Vec3::Y)));
        assert!(sun_ground > sky_ground, "the sun should cast clear shadows");
    }

    #[test]
    fn the_sun_is_in_the_picture() {
        let s = sky();
        let c = s.camera.as_ref().unwrap();
        let forward = (c.target - c.position).normalize();
        let right = forward.cross(c.up).normalize();
        let up = right.cross(forward);
        let sun = sun_direction();
        let (sx, sy) = (sun.dot(right) / sun.dot(forward), sun.dot(up) / sun.dot(forward));
        let tan_half = (c.fov * 0.5).tan();
        println!(
            "sun at image-plane ({sx:.3}, {sy:.3}); frame half-size {tan_half:.3} tall, {tan_half:.3}..{:.3} wide",
            tan_half * 16.0 / 9.0
        );
        assert!(sun.dot(forward) > 0.0 && sx.abs() < tan_half && sy.abs() < tan_half);
    }

    #[test]
    fn moving_ball_circles_clear_of_everything() {
        let s = sky();
        let moving = s.instances.iter().position(|i| s.meshes[i.mesh as usize].name == "moving ball").unwrap();
        assert!(s.is_animated() && s.instances.iter().enumerate().all(|(ii, i)| (ii == moving) != i.motion.is_static()));
        let mut gap = f32::INFINITY;
        let mut travelled = 0.0f32;
        for i in 0..=100 {
            let t = i as f32 * 0.1;
            let f = s.at(t);
            let centre = f.transforms[moving].transform_point3(Vec3::ZERO);
            travelled = travelled.max((centre - Vec3::new(ORBIT_RADIUS, 0.5, 0.0)).length());
            assert!((centre.y - 0.5).abs() < 1e-5, "the ball rolls on the ground");
            for (ii, inst) in s.instances.iter().enumerate().filter(|(ii, _)| *ii != moving) {
                let mesh = &s.meshes[inst.mesh as usize];
                if mesh.name == "ground" {
                    continue;
                }
                let b = mesh.bounds().transform(&f.transforms[ii]);
                gap = gap.min((b.min - centre).max(centre - b.max).max(Vec3::ZERO).length() - 0.5);
            }
        }
        println!(
            "{} triangles; the moving ball goes {travelled:.1} m from its start and keeps {gap:.2} m from every object's box",
            s.triangle_count()
        );
        assert!(gap > 0.1 && travelled > 2.0 * ORBIT_RADIUS - 0.1);
    }
}

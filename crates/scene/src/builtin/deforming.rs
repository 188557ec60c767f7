//! Vertex animation: a cloth canopy (3 × 2 m, 3,072 triangles) on four posts, rippled by a
//! travelling wave (`Deformation::Wave`, 8 cm amplitude), and a ball that bounces once a second
//! (rigid keyframes) while squashing at each contact and stretching in flight, volume-preserving
//! (`Deformation::Keyframes` about its lowest point, so it never dips into the ground). Lit by a
//! directional sun and a constant blue-grey sky. Animated over `0..CLIP_S` seconds.

use super::{CLIP_S, cylinder_mesh, plane_mesh, sampled_track, sphere_mesh};
use crate::{Camera, Deformation, Environment, Instance, Light, Material, Scene, Transform};
use glimpse_core::{Mat4, Vec2, Vec3};

/// The cloth's rest height; the posts stop 10 cm below it, more than the wave's amplitude.
const CANOPY_Y: f32 = 1.6;
const BALL_RADIUS: f32 = 0.35;

pub fn deforming() -> Scene {
    let mut s = Scene { name: "deforming".into(), ..Default::default() };
    let ground = s.add_material(Material::diffuse("ground", Vec3::new(0.6, 0.6, 0.58)));
    let cloth = s.add_material(Material::diffuse("cloth", Vec3::new(0.7, 0.12, 0.1)));
    let wood = s.add_material(Material::diffuse("wood", Vec3::new(0.45, 0.32, 0.2)));
    let yellow = s.add_material(Material::diffuse("ball", Vec3::new(0.9, 0.75, 0.15)));

    s.add_mesh(plane_mesh("ground", ground, Vec2::splat(12.0), [12, 12]), Mat4::IDENTITY);

    let mut canopy = plane_mesh("canopy", cloth, Vec2::new(3.0, 2.0), [48, 32]);
    canopy.deformation = Some(Deformation::Wave {
        amplitude: 0.08,
        wavelength: 1.2,
        period_s: 2.0,
        direction: Vec3::new(1.0, 0.0, 0.4).normalize(),
        displacement: Vec3::Y,
    });
    s.add_mesh(canopy, Mat4::from_translation(Vec3::Y * CANOPY_Y));
    let post_h = CANOPY_Y - 0.1;
    for (x, z) in [(-1.4, -0.9), (1.4, -0.9), (-1.4, 0.9), (1.4, 0.9)] {
        let m = Mat4::from_translation(Vec3::new(x, post_h * 0.5, z)) * Mat4::from_scale(Vec3::new(0.04, post_h * 0.5, 0.04));
        s.add_mesh(cylinder_mesh("post", wood, 16), m);
    }

    // The unit ball resting on y = 0; squashing by `sy` scales y about its lowest point and x, z
    // by 1/√sy. Keys per bounce: squashed at contact, stretched rising, round at the top,
    // stretched falling.
    let mut ball = sphere_mesh("ball", yellow, 24, 48);
    for p in &mut ball.positions {
        p.y += 1.0;
    }
    let rest = ball.positions.clone();
    let squash = |sy: f32| rest.iter().map(|p| Vec3::new(p.x / sy.sqrt(), p.y * sy, p.z / sy.sqrt())).collect::<Vec<_>>();
    let (mut times, mut positions) = (Vec::new(), Vec::new());
    for k in 0..CLIP_S as u32 {
        for (dt, sy) in [(0.0, 0.7), (0.1, 1.15), (0.5, 1.0), (0.9, 1.15)] {
            times.push(k as f32 + dt);
            positions.push(squash(sy));
        }
    }
    times.push(CLIP_S);
    positions.push(squash(0.7));
    ball.deformation = Some(Deformation::Keyframes { times, positions });
    s.meshes.push(ball);
    let bounce = sampled_track(CLIP_S, 0.05, |t| {
        let f = t - t.floor();
        Transform { translation: Vec3::new(1.9, 4.0 * f * (1.0 - f), 1.4), scale: Vec3::splat(BALL_RADIUS), ..Default::default() }
    });
    s.instances.push(Instance { mesh: s.meshes.len() as u32 - 1, motion: bounce });

    s.lights.push(Light::directional(Vec3::new(0.4, -1.0, 0.3), Vec3::new(3.0, 2.85, 2.6)));
    s.environment = Some(Environment::constant(Vec3::new(0.16, 0.2, 0.28)));
    s.camera = Some(Camera::look_at(Vec3::new(4.2, 2.6, 5.6), Vec3::new(0.3, 0.9, 0.3), Vec3::Y, 45.0));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertices_move_and_recomputed_normals_are_unit() {
        let s = crate::load("deforming").unwrap();
        let (f0, f1) = (s.at(0.0), s.at(0.25));
        for (mi, m) in s.meshes.iter().enumerate().filter(|(_, m)| m.deformation.is_some()) {
            let moved = f0.positions[mi].iter().zip(f1.positions[mi].iter()).map(|(a, b)| (*a - *b).length()).fold(0.0f32, f32::max);
            println!("{}: {} triangles, largest vertex move between t = 0 and 0.25 s: {:.1} mm", m.name, m.indices.len(), moved * 1e3);
            assert!(moved > 0.01);
        }
        assert!(s.meshes.iter().any(|m| m.name == "canopy" && m.indices.len() >= 2000));
        let mut worst = 0.0f32;
        for t in [0.0, 0.25, 0.6, 3.3, 9.95] {
            let f = s.at(t);
            for (mi, m) in s.meshes.iter().enumerate().filter(|(_, m)| m.deformation.is_some()) {
                assert_eq!(f.normals[mi].len(), m.positions.len(), "{} normals recomputed", m.name);
                worst = f.normals[mi].iter().map(|n| (n.length() - 1.0).abs()).fold(worst, f32::max);
            }
        }
        println!("recomputed normals: largest | |n| − 1 | = {worst:.2e}");
        assert!(worst < 1e-4);
    }

    #[test]
    fn ball_stays_above_ground_and_cloth_above_posts() {
        let s = deforming();
        let world_y = |f: &crate::SceneFrame, name: &str| {
            let ii = s.instances.iter().position(|i| s.meshes[i.mesh as usize].name == name).unwrap();
            let mi = s.instances[ii].mesh as usize;
            f.positions[mi]
                .iter()
                .map(|p| f.transforms[ii].transform_point3(*p).y)
                .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), y| (lo.min(y), hi.max(y)))
        };
        let (mut ball_lo, mut ball_hi, mut cloth_lo, mut squash) = (f32::INFINITY, 0.0f32, f32::INFINITY, f32::INFINITY);
        for i in 0..=400 {
            let t = i as f32 * CLIP_S / 400.0;
            let f = s.at(t);
            let (lo, hi) = world_y(&f, "ball");
            ball_lo = ball_lo.min(lo);
            ball_hi = ball_hi.max(hi);
            squash = squash.min(hi - lo);
            cloth_lo = cloth_lo.min(world_y(&f, "canopy").0);
        }
        println!(
            "ball bottom ≥ {:.1} mm, top ≤ {ball_hi:.2} m, shortest {squash:.3} m (round {:.2}); cloth lowest {cloth_lo:.3} m over posts at {:.2} m",
            ball_lo * 1e3,
            2.0 * BALL_RADIUS,
            CANOPY_Y - 0.1
        );
        assert!(ball_lo > -1e-3 && ball_lo < 1e-3, "the ball touches the ground without entering it");
        assert!(squash < 0.75 * 2.0 * BALL_RADIUS);
        assert!(cloth_lo > CANOPY_Y - 0.1);
    }
}

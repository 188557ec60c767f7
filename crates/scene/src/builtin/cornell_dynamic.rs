//! The Cornell box (see [`cornell`]) with moving objects, for temporal techniques: the short
//! block is replaced by a block of the same height spinning about its vertical axis, a blue ball
//! bounces once a second while circling slowly in the back-left corner, and an orange cylinder
//! slides left and right in front of the tall block (which stays). Every motion is authored over
//! `0..CLIP_S` seconds and keeps clear of the walls, the tall block and the other movers.

use super::{CLIP_S, box_mesh, cornell, cylinder_mesh, sampled_track, sphere_mesh};
use crate::{Instance, Material, Mesh, Motion, Scene, Transform};
use glimpse_core::{Mat4, Vec3};
use std::f32::consts::TAU;

pub fn cornell_dynamic() -> Scene {
    let mut s = cornell();
    s.name = "cornell-dynamic".into();
    remove_mesh(&mut s, "short block");
    let white = s.materials.iter().position(|m| m.name == "white").expect("the Cornell box has a white material") as u32;
    let blue = s.add_material(Material::diffuse("blue", Vec3::new(0.1, 0.2, 0.6)));
    let orange = s.add_material(Material::diffuse("orange", Vec3::new(0.8, 0.4, 0.08)));

    // Where the short block stood (its footprint's centre, 165 mm tall), spinning once every 5 s.
    let centre = Vec3::new(0.1855, 0.0825, 0.169);
    let base = Mat4::from_translation(centre) * Mat4::from_rotation_y(-17f32.to_radians());
    let spin = Motion::Orbit { base, center: centre, axis: Vec3::Y, period_s: 5.0, phase: 0.0 };
    add_moving(&mut s, box_mesh("spinning block", white, Vec3::new(0.08, 0.0825, 0.08)), spin);

    // A ball of radius 70 mm bouncing 280 mm high every second (contact at whole seconds), its
    // centre circling 30 mm around (130, 430) mm every 5 s.
    let r = 0.07;
    let bounce = sampled_track(CLIP_S, 0.05, |t| {
        let f = t - t.floor();
        let a = TAU * t / 5.0;
        Transform {
            translation: Vec3::new(0.13 + 0.03 * a.cos(), r + 0.28 * 4.0 * f * (1.0 - f), 0.43 + 0.03 * a.sin()),
            scale: Vec3::splat(r),
            // No rolling: a rotated sphere's transformed bounds would poke through the walls.
            ..Default::default()
        }
    });
    add_moving(&mut s, sphere_mesh("bouncing ball", blue, 16, 32), bounce);

    // A cylinder (radius 45 mm, 140 mm tall) sliding along x between 360 and 490 mm every 4 s.
    let slide = sampled_track(CLIP_S, 0.1, |t| Transform {
        translation: Vec3::new(0.425 + 0.065 * (TAU * t / 4.0).sin(), 0.07, 0.12),
        scale: Vec3::new(0.045, 0.07, 0.045),
        ..Default::default()
    });
    add_moving(&mut s, cylinder_mesh("sliding cylinder", orange, 24), slide);
    s
}

fn add_moving(s: &mut Scene, mesh: Mesh, motion: Motion) {
    s.meshes.push(mesh);
    s.instances.push(Instance { mesh: s.meshes.len() as u32 - 1, motion });
}

/// Removes the mesh called `name` and its instances, renumbering the others.
fn remove_mesh(s: &mut Scene, name: &str) {
    let id = s.meshes.iter().position(|m| m.name == name).unwrap_or_else(|| panic!("no mesh '{name}'")) as u32;
    s.meshes.remove(id as usize);
    s.instances.retain(|i| i.mesh != id);
    for i in &mut s.instances {
        if i.mesh > id {
            i.mesh -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// World-space triangles of the instance whose mesh is called `name`, at frame `f`.
    fn world_triangles(f: &crate::SceneFrame, name: &str) -> Vec<[Vec3; 3]> {
        let s = f.scene;
        let ii = s.instances.iter().position(|i| s.meshes[i.mesh as usize].name == name).unwrap();
        let mesh = s.instances[ii].mesh as usize;
        let p = &f.positions[mesh];
        s.meshes[mesh].indices.iter().map(|t| t.map(|i| f.transforms[ii].transform_point3(p[i as usize]))).collect()
    }

    /// Counts the points lying more than `margin` inside the convex solid bounded by `tris` (faces
    /// oriented by the centroid, so the winding does not matter; an open bottom counts as closed
    /// by the floor).
    fn count_inside_convex(tris: &[[Vec3; 3]], points: impl Iterator<Item = Vec3>, margin: f32) -> usize {
        let centroid = tris.iter().flatten().copied().sum::<Vec3>() / (3 * tris.len()) as f32;
        let planes: Vec<(Vec3, Vec3)> = tris
            .iter()
            .map(|[a, b, c]| {
                let n = (*b - *a).cross(*c - *a).normalize();
                (*a, if n.dot(centroid - *a) > 0.0 { -n } else { n })
            })
            .collect();
        points.filter(|p| planes.iter().all(|(a, n)| n.dot(*p - *a) < -margin)).count()
    }

    #[test]
    fn movers_stay_inside_the_box_and_clear_of_each_other() {
        let s = crate::load("cornell-dynamic").unwrap();
        let room = cornell().bounds();
        let movers = ["spinning block", "bouncing ball", "sliding cylinder"];
        let solids = ["tall block", "spinning block", "bouncing ball", "sliding cylinder"];
        let (mut worst_out, mut closest_wall, mut penetrations, mut frames) = (f32::NEG_INFINITY, f32::INFINITY, 0, 0);
        for i in 0..=200 {
            let t = i as f32 * CLIP_S / 200.0;
            let f = s.at(t);
            frames += 1;
            let out = (room.min - f.bounds.min).max(f.bounds.max - room.max).max_element();
            worst_out = worst_out.max(out);
            for m in movers {
                let b = glimpse_core::Aabb::from_points(world_triangles(&f, m).iter().flatten());
                // Distance to the side walls, back and ceiling (the movers rest on the floor).
                let lo = b.min - room.min;
                let gap = lo.x.min(lo.z).min((room.max - b.max).min_element());
                closest_wall = closest_wall.min(gap);
            }
            for a in solids {
                for b in solids.iter().filter(|b| **b != a) {
                    let (ta, tb) = (world_triangles(&f, a), world_triangles(&f, b));
                    penetrations += count_inside_convex(&tb, ta.iter().flatten().copied(), 1e-4);
                }
            }
        }
        println!(
            "{frames} frames over 0..{CLIP_S} s: scene bounds exceed the box by at most {:.3} mm; closest mover-to-wall gap {:.1} mm; {penetrations} vertices inside another solid",
            worst_out * 1e3,
            closest_wall * 1e3
        );
        assert!(worst_out <= 1e-3, "something leaves the box");
        assert!(closest_wall > 0.0);
        assert_eq!(penetrations, 0);
    }

    #[test]
    fn objects_move_and_the_short_block_is_gone() {
        let s = cornell_dynamic();
        assert!(s.meshes.iter().all(|m| m.name != "short block"));
        assert!(s.instances.iter().all(|i| (i.mesh as usize) < s.meshes.len()));
        let (f0, f1) = (s.at(0.0), s.at(0.37));
        let moved: Vec<_> = s
            .instances
            .iter()
            .enumerate()
            .filter(|(ii, _)| !f0.transforms[*ii].abs_diff_eq(f1.transforms[*ii], 1e-6))
            .map(|(_, i)| s.meshes[i.mesh as usize].name.as_str())
            .collect();
        println!("{} triangles; moving between t = 0 and 0.37 s: {moved:?}", s.triangle_count());
        assert_eq!(moved, ["spinning block", "bouncing ball", "sliding cylinder"]);
        // The ball touches the floor at whole seconds and is airborne in between.
        let ball_bottom = |t: f32| {
            let f = s.at(t);
            world_triangles(&f, "bouncing ball").iter().flatten().map(|p| p.y).fold(f32::INFINITY, f32::min)
        };
        println!("ball bottom at t = 3, 3.5 s: {:.4}, {:.4} m", ball_bottom(3.0), ball_bottom(3.5));
        assert!(ball_bottom(3.0) < 2e-3 && ball_bottom(3.5) > 0.25);
    }
}

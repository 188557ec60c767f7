//! An alpha-masked (glTF MASK) blocker: ROMA's grid is voxelized from the covered pieces of its
//! triangles (`SceneFrame::occluding_triangles`), so the floor under its cut-out half is as
//! open in `ao-roma` as in `ao-exact`, which cuts the mask out ray by ray.

use glimpse_core::{Image, Mat4, Vec3};
use glimpse_render::ao::AoExact;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::{AlphaMask, Camera, Material, Mesh, Scene};

mod common;

fn rmse(a: &Image, b: &Image) -> f64 {
    let sum: f64 = a.pixels.iter().zip(&b.pixels).map(|(p, q)| ((p.x - q.x) as f64).powi(2)).sum();
    (sum / a.pixels.len() as f64).sqrt()
}

/// A floor with a 1.6 m square 15 cm above it, seen from above; `masked`: the square's left
/// half cut out (coverage 0 in its texture's left texel, 1 in its right).
fn scene(masked: bool) -> Scene {
    let mut s = Scene::default();
    let floor = s.add_material(Material::diffuse("floor", Vec3::splat(0.8)));
    let coverage = s.textures.len() as u32;
    s.textures.push(Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32)));
    let mask = masked.then_some(AlphaMask { texture: Some(coverage), factor: 1.0, cutoff: 0.5 });
    let leaf = s.add_material(Material { alpha_mask: mask, ..Material::diffuse("leaf", Vec3::splat(0.8)) });
    let c = Vec3::new;
    s.add_mesh(Mesh::quad("floor", floor, [c(-3., 0., -3.), c(3., 0., -3.), c(3., 0., 3.), c(-3., 0., 3.)]), Mat4::IDENTITY);
    s.add_mesh(Mesh::quad("leaf", leaf, [c(-0.8, 0.15, 0.8), c(0.8, 0.15, 0.8), c(0.8, 0.15, -0.8), c(-0.8, 0.15, -0.8)]), Mat4::IDENTITY);
    s.camera = Some(Camera::look_at(c(0.0, 2.5, 0.01), Vec3::ZERO, Vec3::Y, 60.0));
    s
}

#[test]
fn ao_roma_sees_through_a_masked_blocker() {
    let render = |masked: bool| {
        let scene = scene(masked);
        let mut ctx = FrameContext::new(&scene, 0.0, 48, 48);
        let mut exact = ctx.image();
        AoExact::new(&Settings { spp: 128, seed: 9 }, &Params::default()).unwrap().render(&ctx, &ctx.gbuffer(), &mut exact).unwrap();
        let (roma, _) = common::accumulated_ao_roma(&mut ctx, 2, 3, 16, "focus=auto");
        (exact, roma)
    };
    let (exact, roma) = render(true);
    // Drawn opaque, ROMA's grid is the unmasked scene's: its image against the masked reference
    // is the error the alpha test removes.
    let (_, roma_opaque) = render(false);
    let (error, opaque_error) = (rmse(&roma, &exact), rmse(&roma_opaque, &exact));
    println!("ao-roma (16 frames) vs ao-exact on the masked blocker: RMSE {error:.4}; with the blocker drawn opaque {opaque_error:.4}");
    assert!(opaque_error > 0.05, "the test needs a mask that matters: {opaque_error}");
    assert!(error < 0.6 * opaque_error, "ao-roma does not see the holes: RMSE {error} (drawn opaque {opaque_error})");
}

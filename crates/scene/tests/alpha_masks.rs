//! Alpha-masked triangles for the structures built from triangles: `occluding_triangles`
//! keeps the covered part of a masked triangle, in pieces under half a grid cell.

use glimpse_core::{Image, Mat4, Vec3};
use glimpse_scene::{AlphaMask, Material, Mesh, Scene};

fn area(tris: &[[Vec3; 3]]) -> f32 {
    tris.iter().map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length()).sum()
}

#[test]
fn occluding_triangles_keep_the_covered_part() {
    let mut s = Scene::default();
    let coverage = s.textures.len() as u32;
    // Coverage 0 in the left texel, 1 in the right: ≥ 0.5 for u in [0.5, 1] (bilinear, repeating).
    s.textures.push(Image::from_fn(2, 1, |x, _| Vec3::splat(x as f32)));
    let mask = AlphaMask { texture: Some(coverage), factor: 1.0, cutoff: 0.5 };
    let leaf = s.add_material(Material { alpha_mask: Some(mask), ..Material::diffuse("leaf", Vec3::ONE) });
    let wall = s.add_material(Material::diffuse("wall", Vec3::ONE));
    let quad = |z: f32| [Vec3::new(-1.0, -1.0, z), Vec3::new(1.0, -1.0, z), Vec3::new(1.0, 1.0, z), Vec3::new(-1.0, 1.0, z)];
    s.add_mesh(Mesh::quad("leaf", leaf, quad(0.0)), Mat4::IDENTITY);
    s.add_mesh(Mesh::quad("wall", wall, quad(-1.0)), Mat4::IDENTITY);
    let frame = s.at(0.0);
    let (all, occluding) = (frame.world_triangles(), frame.occluding_triangles());
    let leaf_area = area(&occluding) - 4.0;
    println!("{} triangles → {}; the leaf's covered area {leaf_area:.4} of 4", all.len(), occluding.len());
    assert!((leaf_area - 2.0).abs() < 0.1, "half the leaf is covered: {leaf_area}");
    // Every kept piece lies in the covered half (x ≥ 0, u = (x + 1)/2 ≥ 0.5), up to a piece.
    let piece = frame.bounds.extent().length() / 512.0;
    for t in occluding.iter().filter(|t| t[0].z == 0.0) {
        let x = (t[0].x + t[1].x + t[2].x) / 3.0;
        assert!(x >= -piece, "a piece in the hole at x = {x}");
    }
    // The wall is kept whole, and a scene without masks gives the same list.
    assert!(occluding.contains(&all[2]) && occluding.contains(&all[3]));
    s.materials[leaf as usize].alpha_mask = None;
    assert_eq!(s.at(0.0).occluding_triangles(), s.at(0.0).world_triangles());
}

/// Many large masked triangles are cut into coarser pieces, never more than about 2M in all.
#[test]
fn occluding_triangles_are_bounded() {
    let mut s = Scene::default();
    let mask = AlphaMask { texture: None, factor: 1.0, cutoff: 0.5 };
    let leaf = s.add_material(Material { alpha_mask: Some(mask), ..Material::diffuse("leaf", Vec3::ONE) });
    // 3,000 quads of 1 m in a 2 m cube: 64 × 64 pieces each would be 24.6M.
    let quad =
        Mesh::quad("leaf", leaf, [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]);
    for k in 0..3000 {
        s.add_mesh(quad.clone(), Mat4::from_translation(Vec3::new(0.0, 0.0, k as f32 / 3000.0)));
    }
    let n = s.at(0.0).occluding_triangles().len();
    println!("6,000 masked triangles (coverage 1 everywhere) → {n} pieces");
    assert!((6000..=2_000_000).contains(&n), "{n} pieces");
}

/// `scenes/extra/leaf-cards`' glTF loads with its coverage texture (embedded: the repository
/// ignores *.png, and a file left behind made every card opaque on a fresh clone).
#[test]
fn the_leaf_cards_load_with_their_coverage() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/extra/leaf-cards/cards.gltf");
    let scene = glimpse_scene::load(path.to_str().unwrap()).unwrap();
    let mask = scene.materials.iter().find_map(|m| m.alpha_mask).expect("the leaf material is masked");
    let coverage = &scene.textures[mask.texture.expect("its texture's alpha") as usize];
    let open = coverage.pixels.iter().filter(|p| p.x < mask.cutoff).count() as f64 / coverage.pixels.len() as f64;
    println!("{} triangles, {:.3} of the texture cut out; warnings {:?}", scene.triangle_count(), open, scene.warnings);
    assert!((0.4..0.5).contains(&open), "{open}");
    assert!(!scene.warnings.iter().any(|w| w.contains("not loaded")), "{:?}", scene.warnings);
}

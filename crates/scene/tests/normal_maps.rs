//! glTF normal textures ([`NormalMap::perturb`]): the texel's tangent-space normal in the
//! triangle's frame, T along dp/du, B against dp/dv (the image's up), N the interpolated normal.

use glimpse_core::{Image, Vec2, Vec3};
use glimpse_scene::{Bitangent, NormalMap, NormalMapShadowing};

/// A 1 × 1 texture holding the tangent-space normal `n` as glTF stores it: (n + 1) / 2.
fn texel(n: Vec3) -> Image {
    let c = (n.normalize() + Vec3::ONE) * 0.5;
    Image::from_fn(1, 1, |_, _| c)
}

#[test]
fn the_texel_normal_is_read_in_the_triangles_frame() {
    // A floor (n = +y) with u along +x and v along +z: the image's up (−v) is −z.
    let (n, dpdu, dpdv, uv) = (Vec3::Y, Vec3::X, Vec3::Z, Vec2::new(0.3, 0.6));
    let map = NormalMap { texture: 0, scale: 1.0, bitangent: Bitangent::ImageUp, shadowing: NormalMapShadowing::None };
    let bend = |t: Vec3, dpdu: Vec3, dpdv: Vec3| map.perturb(&texel(t), uv, n, dpdu, dpdv).unwrap();
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-2;
    let flat = bend(Vec3::Z, dpdu, dpdv);
    let right = bend(Vec3::new(1.0, 0.0, 1.0), dpdu, dpdv);
    let up = bend(Vec3::new(0.0, 1.0, 1.0), dpdu, dpdv);
    let mirrored = bend(Vec3::new(0.0, 1.0, 1.0), dpdu, -dpdv);
    println!("flat {flat}, +x {right}, +y {up}, +y under a mirrored v {mirrored}");
    let s = std::f32::consts::FRAC_1_SQRT_2;
    assert!(close(flat, Vec3::Y), "{flat}");
    assert!(close(right, Vec3::new(s, s, 0.0)), "+x leans along dp/du: {right}");
    assert!(close(up, Vec3::new(0.0, s, -s)), "+y leans towards the image's up, −dp/dv: {up}");
    assert!(close(mirrored, Vec3::new(0.0, s, s)), "a mirrored v flips the bitangent: {mirrored}");
    // Mitsuba's frame: B = n × T on either mapping.
    let mitsuba = NormalMap { bitangent: Bitangent::NormalCrossTangent, ..map };
    let either = [dpdv, -dpdv].map(|dpdv| mitsuba.perturb(&texel(Vec3::new(0.0, 1.0, 1.0)), uv, n, dpdu, dpdv).unwrap());
    assert!(either.iter().all(|&b| close(b, Vec3::new(0.0, s, -s))), "{either:?}");
    // glTF's scale multiplies x and y; a tangent parallel to n leaves no frame.
    let half = NormalMap { scale: 0.5, ..map }.perturb(&texel(Vec3::new(1.0, 0.0, 1.0)), uv, n, dpdu, dpdv).unwrap();
    assert!(close(half, Vec3::new(0.5, 1.0, 0.0).normalize()), "{half}");
    assert!(map.perturb(&texel(Vec3::Z), uv, n, Vec3::Y, dpdv).is_none());
}

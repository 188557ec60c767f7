//! The Cornell box as measured at Cornell (www.graphics.cornell.edu/online/box/data.html),
//! converted from millimetres to metres. The camera is the published one (at (278, 273, −800) mm
//! looking along +z, 35 mm focal length on a 25 mm film: 39.3° vertical field of view).
//! Colours and light radiance are McGuire's RGB version (Ke 17 12 4); the light sits 0.5 mm below
//! the ceiling so the two never overlap.

use super::quads_mesh;
use crate::{Camera, Material, Scene};
use glimpse_core::{Mat4, Vec3};

pub fn cornell() -> Scene {
    let mut s = Scene { name: "cornell".into(), ..Default::default() };
    let white = s.add_material(Material::diffuse("white", Vec3::new(0.725, 0.71, 0.68)));
    let red = s.add_material(Material::diffuse("red", Vec3::new(0.63, 0.065, 0.05)));
    let green = s.add_material(Material::diffuse("green", Vec3::new(0.14, 0.45, 0.091)));
    let light = s.add_material(Material::emissive("light", Vec3::new(17.0, 12.0, 4.0)));
    let mm = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * 0.001;
    let add = |s: &mut Scene, name: &str, material, quads: &[[Vec3; 4]]| {
        s.add_mesh(quads_mesh(name, material, quads), Mat4::IDENTITY);
    };
    add(&mut s, "floor", white, &[[mm(552.8, 0.0, 0.0), mm(0.0, 0.0, 0.0), mm(0.0, 0.0, 559.2), mm(549.6, 0.0, 559.2)]]);
    add(&mut s, "ceiling", white, &[[mm(556.0, 548.8, 0.0), mm(556.0, 548.8, 559.2), mm(0.0, 548.8, 559.2), mm(0.0, 548.8, 0.0)]]);
    add(&mut s, "back", white, &[[mm(549.6, 0.0, 559.2), mm(0.0, 0.0, 559.2), mm(0.0, 548.8, 559.2), mm(556.0, 548.8, 559.2)]]);
    add(&mut s, "green wall", green, &[[mm(0.0, 0.0, 559.2), mm(0.0, 0.0, 0.0), mm(0.0, 548.8, 0.0), mm(0.0, 548.8, 559.2)]]);
    add(&mut s, "red wall", red, &[[mm(552.8, 0.0, 0.0), mm(549.6, 0.0, 559.2), mm(556.0, 548.8, 559.2), mm(556.0, 548.8, 0.0)]]);
    add(&mut s, "light", light, &[[mm(343.0, 548.3, 227.0), mm(343.0, 548.3, 332.0), mm(213.0, 548.3, 332.0), mm(213.0, 548.3, 227.0)]]);
    add(
        &mut s,
        "short block",
        white,
        &[
            [mm(130.0, 165.0, 65.0), mm(82.0, 165.0, 225.0), mm(240.0, 165.0, 272.0), mm(290.0, 165.0, 114.0)],
            [mm(290.0, 0.0, 114.0), mm(290.0, 165.0, 114.0), mm(240.0, 165.0, 272.0), mm(240.0, 0.0, 272.0)],
            [mm(130.0, 0.0, 65.0), mm(130.0, 165.0, 65.0), mm(290.0, 165.0, 114.0), mm(290.0, 0.0, 114.0)],
            [mm(82.0, 0.0, 225.0), mm(82.0, 165.0, 225.0), mm(130.0, 165.0, 65.0), mm(130.0, 0.0, 65.0)],
            [mm(240.0, 0.0, 272.0), mm(240.0, 165.0, 272.0), mm(82.0, 165.0, 225.0), mm(82.0, 0.0, 225.0)],
        ],
    );
    add(
        &mut s,
        "tall block",
        white,
        &[
            [mm(423.0, 330.0, 247.0), mm(265.0, 330.0, 296.0), mm(314.0, 330.0, 456.0), mm(472.0, 330.0, 406.0)],
            [mm(423.0, 0.0, 247.0), mm(423.0, 330.0, 247.0), mm(472.0, 330.0, 406.0), mm(472.0, 0.0, 406.0)],
            [mm(472.0, 0.0, 406.0), mm(472.0, 330.0, 406.0), mm(314.0, 330.0, 456.0), mm(314.0, 0.0, 456.0)],
            [mm(314.0, 0.0, 456.0), mm(314.0, 330.0, 456.0), mm(265.0, 330.0, 296.0), mm(265.0, 0.0, 296.0)],
            [mm(265.0, 0.0, 296.0), mm(265.0, 330.0, 296.0), mm(423.0, 330.0, 247.0), mm(423.0, 0.0, 247.0)],
        ],
    );
    s.camera = Some(Camera::look_at(mm(278.0, 273.0, -800.0), mm(278.0, 273.0, 0.0), Vec3::Y, 2.0 * (12.5f32 / 35.0).atan().to_degrees()));
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn light_faces_down_and_has_the_published_area() {
        let s = super::cornell();
        let f = s.at(0.0);
        let area: f32 = f.emissive.iter().map(|e| e.area).sum();
        println!("light area {area:.5} m² (published 0.130 × 0.105 = 0.01365)");
        assert!((area - 0.01365).abs() < 1e-6);
        assert!(f.emissive.iter().all(|e| e.normal.y < -0.999));
        assert_eq!(s.triangle_count(), 32, "5 walls + light = 6 quads, two open-bottomed blocks = 10 quads");
    }
}

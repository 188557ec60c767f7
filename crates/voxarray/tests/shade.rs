//! The tiled AVX2 shader of `lights-voxarray` ([`glimpse_voxarray::shade8`]) against the scalar
//! per-sample path: the images must be bit-identical (same segments, same extents, same
//! decisions, same sums), with point, spot and directional lights, plain and compressed.

use glimpse_core::Vec3;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_scene::Light;
use glimpse_voxarray::technique::LightsVoxArray;

#[test]
fn tiled_simd_image_equals_scalar_image() {
    let mut scene = glimpse_scene::builtin::many_lights(64);
    // The scalar formation inside the tiled shader: a spot and a directional light.
    scene.lights.push(Light::spot(Vec3::new(2.0, 6.0, 3.0), Vec3::new(0.1, -1.0, 0.2).normalize(), Vec3::splat(40.0), 0.3, 0.6));
    scene.lights.push(Light::directional(Vec3::new(0.4, -1.0, 0.3).normalize(), Vec3::splat(0.5)));
    let mut compared = 0usize;
    // 45×29: tiles cut at the right and bottom edges.
    // `refine` (66 lights: on by default) confirms occluded answers with exact rays in both paths.
    for (compress, (w, h), refine) in
        [(true, (48, 36), "auto"), (false, (48, 36), "auto"), (true, (45, 29), "auto"), (true, (48, 36), "none")]
    {
        let ctx = FrameContext::new(&scene, 0.0, w, h);
        let g = ctx.gbuffer();
        let render = |tiled: bool, simd: bool| {
            let p = format!("compress={compress}");
            let (t, s, r) = (format!("tiled={tiled}"), format!("simd={simd}"), format!("refine={refine}"));
            let params =
                Params::parse(&["resolution=32", "directions=8", "dictionary=4096", "epsilon=false", "disk_cache=false", &p, &t, &s, &r])
                    .unwrap();
            let mut tech = LightsVoxArray::new(&scene, &Settings::default(), &params).unwrap();
            params.finish("lights-voxarray").unwrap();
            tech.prepare(&ctx).unwrap();
            let mut img = ctx.image();
            let st = tech.render(&ctx, &g, &mut img).unwrap();
            (img, st.rays)
        };
        let (reference, decisions) = render(false, false);
        let lit = reference.pixels.iter().filter(|p| p.max_element() > 0.0).count();
        assert!(decisions > 0 && lit > reference.pixels.len() / 2, "{decisions} decisions, {lit} lit pixels");
        for (tiled, simd) in [(true, true), (true, false), (false, true)] {
            let (img, rays) = render(tiled, simd);
            let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
            let differ = img.pixels.iter().zip(&reference.pixels).filter(|(a, b)| bits(a) != bits(b)).count();
            println!(
                "{w}x{h} compress={compress} refine={refine} tiled={tiled} simd={simd} (AVX2 on this CPU: {}): {} pixels compared, {differ} differ; {rays} vs {decisions} shadow decisions",
                glimpse_voxarray::extent8::avx2_available(),
                img.pixels.len()
            );
            assert_eq!(differ, 0);
            assert_eq!(rays, decisions);
            compared += img.pixels.len();
        }
    }
    println!("{compared} pixels compared bit for bit, 0 differ");
}

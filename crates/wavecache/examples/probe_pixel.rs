//! One pixel's glossy reading, point by point, beside the same product with maps baked at the
//! pixel itself (few and many texel samples, with and without light samples): whether a wrong
//! pixel comes from its cache points' place, from the maps' noise or from after the product.
//!
//! cargo run --release -p glimpse-wavecache --example probe_pixel -- SCENE WxH X Y [key=value ...]

use glimpse_core::{Rng, Vec3};
use glimpse_render::bsdf::reflect;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_wavecache::bake::{Integrator, MapSettings};
use glimpse_wavecache::halfcube::map_frame;
use glimpse_wavecache::points::SurfaceSample;
use glimpse_wavecache::technique::{Runtime, ShadePoint};
use glimpse_wavecache::{Wavecache, haar};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 4 {
        return Err("usage: probe_pixel SCENE WxH X Y [key=value ...]".into());
    }
    let scene = glimpse_scene::load(&args[0])?;
    let (w, h) = args[1].split_once('x').ok_or("size WxH")?;
    let (w, h): (u32, u32) = (w.parse()?, h.parse()?);
    let (x, y): (u32, u32) = (args[2].parse()?, args[3].parse()?);
    let params = Params::parse(&args[4..])?;
    let mut t = Wavecache::new(&Settings { spp: 1, seed: 0 }, &params)?;
    params.finish("wavecache")?;
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    t.prepare(&ctx)?;
    let mut cache = t.cache.clone().ok_or("no cache")?;
    let wp = t.params.clone();
    let i = (y * w + x) as usize;
    if !g.is_hit(i) {
        return Err("the pixel sees no surface".into());
    }
    let s = ShadePoint::at_pixel(&g, i);
    let wo = -g.view_dir[i];
    let ns = s.facing_normal(wo);
    let mc = cache.meshes[s.instance as usize];
    println!("material {} class {} map_res {} r_max {:.4} base {:?}", s.material, mc.class, mc.map_res, mc.r_max, s.base);
    // Maps baked at the pixel itself, appended to a copy of the cache.
    let integ = Integrator::new(&ctx.frame, &ctx.tracer, wp.max_depth, wp.brdf);
    let sample = SurfaceSample { position: s.position, error_scale: s.error_scale, normal: s.normal, shading_normal: ns };
    let res = mc.map_res.max(4);
    let mut own = Vec::new();
    for (texel, light, seed) in [(16, 0, 1), (16, 0, 2), (16, 4, 1), (16, 4, 2), (256, 0, 1), (256, 16, 1)] {
        let img = integ
            .radiance_map(
                &sample,
                &map_frame(ns),
                &MapSettings { res, samples: texel, light_samples: light, split_env: false },
                &mut Rng::new(seed, 1),
            )
            .image;
        let tree = haar::build(&img, res, wp.radiance_beta as f64, &mut cache.radiance_nodes);
        cache.radiance_trees.push(tree);
        own.push((
            format!("map at the pixel, {texel} rays + {light} light samples per texel, seed {seed}"),
            cache.radiance_trees.len() as u32 - 1,
        ));
    }
    let rt = Runtime::new(&cache, &wp, &ctx.frame, &ctx.tracer);
    let reading = rt.point_for(&s, wo);
    let r = reflect(wo, ns);
    for (p, weight) in reading.blended() {
        let np = Vec3::from(p.shading_normal);
        let d = (Vec3::from(p.position) - s.position).length() / mc.r_max;
        let wo_local = map_frame(np).to_local(reflect(r, np));
        println!(
            "point at {d:.2} r_max, n·n {:.3}, weight {weight:.3}: Eq. 20 {:?}",
            ns.dot(np),
            rt.glossy(s.material, s.base, wo_local, p.payload)
        );
    }
    // Diffuse: each blended point's cached irradiance beside the irradiance computed afresh at
    // the point and at the pixel (many paths): whether a wrong pixel comes from its points'
    // estimates or from their place.
    if mc.class == 0 {
        let fresh = |position: Vec3, normal: Vec3, shading_normal: Vec3, n: u32| {
            let at = SurfaceSample { position, error_scale: s.error_scale, normal, shading_normal };
            let mut rng = Rng::new(7, 1);
            (0..n).map(|_| integ.irradiance(&at, &mut rng).0).sum::<Vec3>() / n as f32
        };
        for (p, weight) in reading.blended() {
            let (pos, n, sn) = (Vec3::from(p.position), Vec3::from(p.normal), Vec3::from(p.shading_normal));
            println!(
                "point weight {weight:.3}, reach {:.3e}: cached E {:?}, afresh (8,192 paths) {:?}",
                p.reach,
                cache.irradiance_at(p.payload).unwrap_or(Vec3::ZERO),
                fresh(pos, n, sn, 8192)
            );
        }
        println!("E at the pixel afresh (8,192 paths): {:?}", fresh(s.position, s.normal, ns, 8192));
    }
    println!("far {}; cached (after the texel) {:?}; punctual {:?}", reading.far, rt.cached(&s, wo), rt.punctual(&s, wo).0);
    println!("shaded as the render shades it (one sample): {:?}", rt.shade(&s, wo, 0, &mut Rng::new(0, i as u64)).0);
    // The nearest points of the mesh by brute force, against what the query chose.
    let pts = &cache.points[mc.first_point as usize..(mc.first_point + mc.point_count) as usize];
    let mut near: Vec<(f32, f32, f32)> = pts
        .iter()
        .map(|p| {
            (
                (Vec3::from(p.position) - s.position).length() / mc.r_max,
                ns.dot(Vec3::from(p.shading_normal)),
                s.normal.dot(Vec3::from(p.position) - s.position),
            )
        })
        .collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    for (d, c, h) in near.iter().take(4) {
        println!("nearest by brute force: {d:.2} r_max, n·n {c:.3}, height above the pixel's plane {h:.2e}");
    }
    let wo_local = map_frame(ns).to_local(reflect(r, ns));
    for (name, tree) in &own {
        println!("{name}: Eq. 20 {:?}", rt.glossy(s.material, s.base, wo_local, *tree));
    }
    Ok(())
}

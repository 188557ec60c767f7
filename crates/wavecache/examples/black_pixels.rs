//! Which cache point each pixel reads, to find why a pixel is black or too bright: an EXR with
//! R = the chosen point's distance in r_max (−1: none found), G = 1 for a point found, B = its
//! irradiance's luminance (diffuse meshes; −1 on glossy ones, which store radiance maps).
//!
//! cargo run --release -p glimpse-wavecache --example black_pixels -- SCENE WxH OUT.exr

use glimpse_core::{Image, Vec3};
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_wavecache::Wavecache;
use glimpse_wavecache::technique::{Runtime, ShadePoint};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 3 {
        return Err("usage: black_pixels SCENE WxH OUT.exr [key=value ...]".into());
    }
    let scene = glimpse_scene::load(&args[0])?;
    let (w, h) = args[1].split_once('x').ok_or("size WxH")?;
    let (w, h): (u32, u32) = (w.parse()?, h.parse()?);
    let params = Params::parse(&args[3..])?;
    let mut t = Wavecache::new(&Settings { spp: 1, seed: 0 }, &params)?;
    params.finish("wavecache")?;
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    t.prepare(&ctx)?;
    let cache = t.cache.as_ref().ok_or("no cache")?;
    let wp = t.params.clone();
    let rt = Runtime::new(cache, &wp, &ctx.frame, &ctx.tracer);
    let mut out = Image::filled(w, h, Vec3::ZERO);
    for i in 0..out.pixels.len() {
        if !g.is_hit(i) {
            continue;
        }
        let s = ShadePoint::at_pixel(&g, i);
        let ns = s.facing_normal(-g.view_dir[i]);
        let mc = cache.meshes[s.instance as usize];
        match rt.lookup(&s, ns) {
            Some(p) => {
                let d = (Vec3::from(p.position) - s.position).length() / mc.r_max;
                let diffuse = mc.class == glimpse_wavecache::Class::Diffuse as u32;
                let e = cache.irradiance_at(p.payload).filter(|_| diffuse).map_or(-1.0, glimpse_core::luminance);
                out.pixels[i] = Vec3::new(d, 1.0, e);
            }
            None => out.pixels[i] = Vec3::new(-1.0, 0.0, 0.0),
        }
    }
    out.write(std::path::Path::new(&args[2]), glimpse_core::image::ToneMap::default())?;
    Ok(())
}

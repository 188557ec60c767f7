//! Error of `wavecache` against a reference image, split by material: which part of the paper's
//! pipeline (irradiance points, radiance maps ⊗ BRDF trees, traced lights) costs what.
//!
//! cargo run --release -p glimpse-wavecache --example diagnose -- SCENE REF.exr WxH [key=value ...]
//! cargo run --release -p glimpse-wavecache --example diagnose -- compare A.exr B.exr

use glimpse_core::Image;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_wavecache::Wavecache;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("compare") && args.len() == 3 {
        let (a, b) = (Image::read(std::path::Path::new(&args[1]))?, Image::read(std::path::Path::new(&args[2]))?);
        let mse = a.pixels.iter().zip(&b.pixels).map(|(x, y)| ((*x - *y) * (*x - *y)).element_sum() as f64 / 3.0).sum::<f64>()
            / a.pixels.len() as f64;
        println!("MSE {mse:.3e}");
        return Ok(());
    }
    if args.len() < 3 {
        return Err("usage: diagnose SCENE REF.exr WxH [key=value ...]".into());
    }
    let scene = glimpse_scene::load(&args[0])?;
    let reference = Image::read(std::path::Path::new(&args[1]))?;
    let (w, h) = args[2].split_once('x').ok_or("size WxH")?;
    let (w, h): (u32, u32) = (w.parse()?, h.parse()?);
    let params = Params::parse(&args[3..])?;
    let spp = std::env::var("DIAG_SPP").ok().and_then(|v| v.parse().ok()).unwrap_or(1);
    let mut t = Wavecache::new(&Settings { spp, seed: 0 }, &params)?;
    params.finish("wavecache")?;
    let ctx = FrameContext::new(&scene, 0.0, w, h);
    let g = ctx.gbuffer();
    let prep = t.prepare(&ctx)?;
    let mut img = ctx.image();
    let rend = t.render(&ctx, &g, &mut img)?;
    let mut per = vec![(0.0f64, 0usize); scene.materials.len() + 1];
    // Mean luminance per material, technique and reference (bias apart from noise).
    let mut means = vec![(0.0f64, 0.0f64); scene.materials.len() + 1];
    let mut total = 0.0f64;
    for i in 0..img.pixels.len() {
        let d = img.pixels[i] - reference.pixels[i];
        let e = (d * d).element_sum() as f64 / 3.0;
        total += e;
        let m = if g.is_hit(i) { g.material[i] as usize } else { scene.materials.len() };
        per[m].0 += e;
        per[m].1 += 1;
        means[m].0 += glimpse_core::luminance(img.pixels[i]) as f64;
        means[m].1 += glimpse_core::luminance(reference.pixels[i]) as f64;
    }
    let n = img.pixels.len() as f64;
    println!("prepare {:?}\nrender {:?}\nstorage {} bytes", prep.stages, rend.stages, prep.memory_bytes);
    println!("MSE {:.3e} (RMSE {:.4})", total / n, (total / n).sqrt());
    for (m, (e, c)) in per.iter().enumerate() {
        let name = scene.materials.get(m).map_or("background", |x| x.name.as_str());
        if *c > 0 {
            let (a, b) = (means[m].0 / *c as f64, means[m].1 / *c as f64);
            println!(
                "  {name:>14}: {c:6} px, share of image MSE {:.3e}, own MSE {:.3e}, mean luminance {a:.4} vs reference {b:.4}",
                e / n,
                e / *c as f64
            );
        }
    }
    if let Some(c) = &t.cache {
        let before: u32 = c.meshes.iter().map(|m| m.points_before).sum();
        println!(
            "points {} of {before} kept by sparsification ({:.1}% removed); BRDF {} B, lighting {} B",
            c.points.len(),
            100.0 * (1.0 - c.points.len() as f64 / before.max(1) as f64),
            c.brdf_bytes(),
            c.lighting_bytes()
        );
    }
    if let Some(out) = std::env::var_os("DIAG_OUT") {
        img.write(std::path::Path::new(&out), glimpse_core::image::ToneMap::default())?;
    }
    Ok(())
}

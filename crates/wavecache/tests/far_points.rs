//! `trace_far` (ours): a pixel whose cache point lies more than `trace_far` × r_max away (or that
//! finds none) is traced as a sharp lobe is, instead of reading another place's cached light.
//! Distances are in r_max, which grows as the cache thins, so what makes a point far is the
//! geometry (a ledge's underside with no point of its orientation near: `sponza-interior`, 19 %
//! of its pixels at 320 × 180; docs/techniques/wavecache.md, "Far points"), which no small
//! built-in scene has. Here a sparse cache (a few dozen points for `glossy`) with a tight
//! `trace_far` of 1 r_max stands in: the pixels it traces must come nearer `pt`; and at the
//! default, on a dense cache, no pixel is far and the image is unchanged.

use glimpse_core::{Image, luminance};
use glimpse_render::pt::PathTracer;
use glimpse_render::{FrameContext, Params, Settings, Technique};
use glimpse_trace::GBuffer;
use glimpse_wavecache::{Wavecache, WavecacheParams};

fn params(points: u32, trace_far: f32) -> WavecacheParams {
    WavecacheParams {
        brdf_grid_u1: 8,
        brdf_grid_u2: 32,
        brdf_res: 16,
        map_scale: 8,
        texel_samples: 2,
        irradiance_samples: 64,
        diffuse_points: points,
        glossy_points: points,
        min_points: 1,
        trace_far,
        disk_cache: false,
        progress: false,
        ..WavecacheParams::default()
    }
}

fn render(t: &mut dyn Technique, ctx: &FrameContext, g: &GBuffer) -> (Image, Option<f64>) {
    t.prepare(ctx).expect("prepare");
    let mut img = ctx.image();
    let stats = t.render(ctx, g, &mut img).expect("render");
    let far = stats.metrics.iter().find(|(k, _)| k == "far_traced_pct").map(|(_, v)| *v);
    (img, far)
}

fn mse(a: &Image, b: &Image) -> f64 {
    a.pixels.iter().zip(&b.pixels).map(|(x, y)| ((*x - *y) * (*x - *y)).element_sum() as f64 / 3.0).sum::<f64>() / a.pixels.len() as f64
}

/// Pixels under 10 % of the reference's luminance, and over 2×, where the reference is lit.
fn faults(img: &Image, reference: &Image) -> (usize, usize) {
    let lit = |r: f32| r > 0.02;
    let pairs = img.pixels.iter().zip(&reference.pixels).map(|(a, b)| (luminance(*a), luminance(*b)));
    pairs.filter(|(_, r)| lit(*r)).fold((0, 0), |(black, over), (a, r)| (black + usize::from(a < 0.1 * r), over + usize::from(a > 2.0 * r)))
}

#[test]
fn far_cache_points_are_traced_not_read() {
    let scene = glimpse_scene::load("glossy").unwrap();
    let ctx = FrameContext::new(&scene, 0.0, 48, 36);
    let g = ctx.gbuffer();
    let mut pt = PathTracer::new(&Settings { spp: 256, seed: 5 }, &Params::default()).unwrap();
    let (reference, _) = render(&mut pt, &ctx, &g);
    let settings = Settings { spp: 16, seed: 1 };
    let run = |points: u32, trace_far: f32| render(&mut Wavecache::with_params(&settings, params(points, trace_far)), &ctx, &g);

    // A sparse cache: read as it is, then with its far pixels traced.
    let (read, read_far) = run(24, f32::INFINITY);
    let (traced, far) = run(24, 1.0);
    let far = far.expect("the share of traced pixels is reported");
    let ((b0, o0), (b1, o1)) = (faults(&read, &reference), faults(&traced, &reference));
    let (e0, e1) = (mse(&read, &reference), mse(&traced, &reference));
    println!(
        "24 points: trace_far=inf MSE {e0:.3e}, {b0} black, {o0} over 2×; trace_far=1: {far:.1} % of pixels traced, MSE {e1:.3e}, {b1} black, {o1} over 2×"
    );
    assert_eq!(read_far, Some(0.0), "trace_far=inf traces no pixel for being far");
    assert!(far > 5.0, "a sparse cache leaves pixels far from their points: {far} %");
    assert!(e1 < e0, "tracing the far pixels brings the image nearer pt: {e0} → {e1}");
    assert!(b1 + o1 < b0 + o0, "fewer black and too-bright pixels: {b0}+{o0} → {b1}+{o1}");

    // A dense cache: no pixel's point is far, so the default rule changes nothing.
    let (dense_read, _) = run(2000, f32::INFINITY);
    let (dense, dense_far) = run(2000, WavecacheParams::default().trace_far);
    println!("2000 points: {dense_far:?} % traced for being far");
    assert_eq!(dense_far, Some(0.0));
    assert!(dense.pixels == dense_read.pixels, "the same image where no point is far");
}

#[test]
fn trace_far_is_a_parameter_and_the_paper_profile_turns_it_off() {
    let read = |args: &[&str]| WavecacheParams::read(&Params::parse(args).unwrap()).unwrap();
    assert_eq!(read(&[]).trace_far, glimpse_wavecache::DEFAULT_TRACE_FAR);
    assert_eq!(read(&["trace_far=2.5"]).trace_far, 2.5);
    assert_eq!(read(&["profile=paper"]).trace_far, f32::INFINITY);
    assert!(WavecacheParams::read(&Params::parse(&["trace_far=-1"]).unwrap()).is_err());
    // Runtime-only: not part of the precomputation's key.
    assert_eq!(read(&["trace_far=2.5"]).precompute_part(), read(&[]).precompute_part());
}

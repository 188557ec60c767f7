//! Timing that noise cannot decide. Over several frames a run reports the median frame's stats
//! among the frames after the first (the first pays one-time costs, and is reported beside
//! them: `first_frame` in results.json, a line under eval's table); a short single frame is
//! shaded again and its median pass reported. One pass's time alone decided comparisons by the
//! noise of a shared machine.

use glimpse_core::Image;
use glimpse_eval::experiment::render_frames;
use glimpse_render::{FrameContext, RenderError, Stats, Technique};
use glimpse_trace::GBuffer;

/// A technique whose frames take the scripted times (ms) and whose image is its frame index.
struct Scripted {
    times: Vec<f64>,
    frame: usize,
}

impl Technique for Scripted {
    fn id(&self) -> &'static str {
        "scripted"
    }

    fn prepare(&mut self, _ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut s = Stats::default();
        s.stage("build", 1.0);
        Ok(s)
    }

    fn render(&mut self, _ctx: &FrameContext, _g: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let mut s = Stats::default();
        s.stage("shade", self.times[self.frame]);
        s.rays = self.frame as u64;
        out.pixels.iter_mut().for_each(|p| *p = glimpse_core::Vec3::splat(self.frame as f32));
        self.frame += 1;
        Ok(s)
    }
}

#[test]
fn a_run_of_frames_reports_the_median_frame_after_the_first() {
    let scene = glimpse_scene::load("cornell").unwrap();
    let mut ctx = FrameContext::new(&scene, 0.0, 4, 4);
    let g = ctx.gbuffer();
    // Frame 0 pays a one-time cost; frame 2 is a hiccup of the machine.
    let mut t = Scripted { times: vec![100.0, 5.0, 50.0, 7.0, 6.0], frame: 0 };
    let r = render_frames(&mut t, &mut ctx, &g, 5).unwrap();
    println!("frames {:?}: reported {} ms (frame {})", t.times, r.prepare.total_ms() + r.render.total_ms(), r.render.rays);
    // Frames 1..4 cost 6, 51, 8, 7 ms: the median (upper of the middle two) is frame 3's 8 ms.
    assert_eq!(r.render.total_ms(), 7.0);
    assert_eq!(r.render.rays, 3);
    // The image is still the average of every frame.
    assert_eq!(r.image.pixels[0].x, 2.0);
    // The first frame's time (its one-time work) is kept beside the median.
    assert_eq!(r.first_frame_ms, Some(101.0));
    // One frame: its own stats.
    let mut one = Scripted { times: vec![42.0], frame: 0 };
    let single = render_frames(&mut one, &mut ctx, &g, 1).unwrap();
    assert_eq!((single.render.total_ms(), single.first_frame_ms), (42.0, None));
}

/// A single frame whose shading took under `STEADY_BELOW_MS` is shaded again, and the median
/// pass reported; its prepare (a build that a second call could find cached) is timed once; a
/// long pass is not repeated.
#[test]
fn a_short_single_frame_reports_the_median_of_five_shading_passes() {
    use glimpse_eval::experiment::{STEADY_BELOW_MS, STEADY_REPEATS, render_once, steady_render};
    let scene = glimpse_scene::load("cornell").unwrap();
    let ctx = FrameContext::new(&scene, 0.0, 4, 4);
    let g = ctx.gbuffer();
    let mut t = Scripted { times: vec![3.0, 50.0, 4.0, 5.0, 2.0], frame: 0 };
    let first = render_once(&mut t, &ctx, &g).unwrap();
    let r = steady_render(&mut t, &ctx, &g, first).unwrap();
    println!(
        "passes {:?}: reported shading {} ms (pass {}), prepare {} ms",
        t.times,
        r.render.total_ms(),
        r.render.rays,
        r.prepare.total_ms()
    );
    assert_eq!(t.frame, STEADY_REPEATS);
    assert_eq!((r.render.total_ms(), r.render.rays, r.prepare.total_ms()), (4.0, 2, 1.0));
    assert_eq!(r.image.pixels[0].x, 0.0, "the first pass's image");
    let mut long = Scripted { times: vec![STEADY_BELOW_MS + 1.0, 1.0], frame: 0 };
    let first = render_once(&mut long, &ctx, &g).unwrap();
    assert_eq!(steady_render(&mut long, &ctx, &g, first).unwrap().render.total_ms(), STEADY_BELOW_MS + 1.0);
    assert_eq!(long.frame, 1);
}

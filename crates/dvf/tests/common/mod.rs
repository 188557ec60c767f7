//! Helpers shared by the DVF's integration tests.

use glimpse_core::Image;
use glimpse_render::{FrameContext, Stats, Technique};

/// One frame of `t` on `ctx`'s GBuffer: the image, the prepare's stats and the render's.
pub fn render(t: &mut dyn Technique, ctx: &FrameContext) -> (Image, Stats, Stats) {
    let g = ctx.gbuffer();
    let prepared = t.prepare(ctx).expect("prepare");
    let mut img = ctx.image();
    let rendered = t.render(ctx, &g, &mut img).expect("render");
    (img, prepared, rendered)
}

//! What `lights-shadowmap` and `lights-ism` share (the voxel-array paper's SM and ISM baselines,
//! §5): one map per light, all built in `prepare` (timed as the paper's per-frame map pass);
//! `render` looks every light up at every pixel and shades diffusely, as `lights-exact` does;
//! after the render, untimed, the decisions are measured against exact shadow rays (ε_v, ε_s in
//! `Stats::metrics`, param `epsilon`).

use glimpse_core::{Aabb, Image, Vec3};
use glimpse_render::direct::{self, Shading};
use glimpse_render::focus::Focus;
use glimpse_render::metrics::epsilon;
use glimpse_render::{FrameContext, ParamError, Params, RenderError, Settings, Stats, Technique};
use glimpse_scene::{Cutouts, Scene, SceneFrame, WorldLight};
use glimpse_trace::GBuffer;
use std::f32::consts::PI;

/// What the maps must hold: the triangles that may block a shadow ray, and their box.
///
/// `focus=auto` (ours; `profile=paper`/`focus=scene`: the whole scene): a scene's supporting
/// planes cannot block a shadow ray toward these lights ([`Focus::occluders`]); where the other
/// triangles' box is much smaller than the scene's, the maps hold only those, and a directional
/// light's orthographic map is fitted to their box, as engines fit a shadow map to its casters
/// (a point whose projection falls outside it has no caster above it). The cube maps' texels
/// are angles, so for them only the dropped planes change anything.
pub struct Occluders {
    pub triangles: Vec<[Vec3; 3]>,
    pub bounds: Aabb,
    /// The focus's share of the scene's diagonal, where one is used.
    pub focus_share: Option<f32>,
    /// In a scene with alpha masks: their coverage, and each triangle's (instance, triangle).
    cutouts: Option<(Cutouts, Vec<(u32, u32)>)>,
}

impl Occluders {
    /// Every triangle of `frame`, the scene's bounds.
    pub fn whole(frame: &SceneFrame) -> Self {
        Self::of(frame, &[], false)
    }

    /// With `focus`, the triangles that may block a shadow ray toward `lights` where they are
    /// much smaller than the scene; otherwise [`Occluders::whole`].
    pub fn of(frame: &SceneFrame, lights: &[WorldLight], focus: bool) -> Self {
        let triangles = frame.world_triangles();
        let cutouts = Cutouts::new(frame.scene).map(|c| (c, frame.world_triangle_ids()));
        match if focus { Focus::occluders(&triangles, frame.bounds, lights) } else { None } {
            Some(f) => Self {
                triangles: f.inside(&triangles),
                bounds: f.bounds,
                focus_share: Some(f.share_of(frame.bounds)),
                cutouts: cutouts.map(|(c, ids)| (c, f.inside(&ids))),
            },
            None => Self { triangles, bounds: frame.bounds, focus_share: None, cutouts },
        }
    }

    /// Whether the point at barycentrics (`b1`, `b2`) of occluder `k` is cut out (glTF alpha
    /// MASK): maps test it per texel and per point sample, as engines alpha-test a shadow
    /// map's depth pass, so they agree with the references, which cut masks out.
    #[inline]
    pub fn hole(&self, k: usize, b1: f32, b2: f32) -> bool {
        self.cutouts.as_ref().is_some_and(|(c, ids)| {
            let (instance, triangle) = ids[k];
            c.hole(instance, triangle, b1, b2)
        })
    }

    /// Whether any occluder can have holes ([`Occluders::hole`]).
    pub fn has_holes(&self) -> bool {
        self.cutouts.is_some()
    }
}

/// Per-light shadow maps of one kind.
pub trait PerLightMaps: Send + Sync + Sized + 'static {
    type Params: Copy + Default + Send;
    /// Technique id.
    const ID: &'static str;
    /// Name of the `prepare` stage.
    const STAGE: &'static str;
    /// Whether the maps may leave out the supporting planes (`focus`, [`Occluders::of`]).
    const FOCUS: bool;
    fn read_params(defaults: Self::Params, params: &Params) -> Result<Self::Params, ParamError>;
    fn build(occluders: &Occluders, lights: &[WorldLight], p: &Self::Params) -> Self;
    /// Whether light `l` is hidden from the surface point `p` with normal `n`.
    fn shadowed(&self, l: usize, p: Vec3, n: Vec3) -> bool;
    fn memory_bytes(&self) -> usize;
    /// What the maps of `lights` lights will hold, and its size in bytes, for the memory budget
    /// (checked before the build).
    fn estimate(lights: usize, p: &Self::Params) -> (String, u64);
}

/// A many-light technique over maps `M`: every light (or the first `lights`) at every pixel.
pub struct LightsWithMaps<M: PerLightMaps> {
    pub lights: u32,
    pub params: M::Params,
    pub settings: Settings,
    pub maps: Option<M>,
    /// Measure ε_v / ε_s of the shadow decisions against exact rays after each render (untimed;
    /// reported in `Stats::metrics`, so `glimpse eval` lists them).
    pub epsilon: bool,
    /// `focus=auto`: the maps hold the occluders only ([`Occluders::of`]).
    pub focus: bool,
}

impl<M: PerLightMaps> LightsWithMaps<M> {
    pub fn new(scene: &Scene, settings: &Settings, params: &Params) -> Result<Self, RenderError> {
        let all = (scene.lights.len() as u32).max(1);
        Ok(Self {
            lights: params.u32("lights", all, 1, u32::MAX)?,
            params: M::read_params(M::Params::default(), params)?,
            settings: *settings,
            maps: None,
            epsilon: params.bool("epsilon", true)?,
            focus: M::FOCUS && {
                let paper = params.choice("profile", "default", &["default", "paper"])? == "paper";
                params.choice("focus", if paper { "scene" } else { "auto" }, &["auto", "scene"])? == "auto"
            },
        })
    }

    fn active_lights<'a>(&self, ctx: &'a FrameContext) -> &'a [WorldLight] {
        &ctx.frame.lights[..ctx.frame.lights.len().min(self.lights as usize)]
    }
}

impl<M: PerLightMaps> Technique for LightsWithMaps<M> {
    fn id(&self) -> &'static str {
        M::ID
    }

    fn prepare(&mut self, ctx: &FrameContext) -> Result<Stats, RenderError> {
        let mut stats = Stats::default();
        let lights = self.active_lights(ctx);
        let (what, bytes) = M::estimate(lights.len(), &self.params);
        glimpse_core::memory_budget::check(format!("{}: {what}", M::ID), bytes)?;
        let occluders = stats.time("occluders", || Occluders::of(&ctx.frame, lights, self.focus));
        self.maps = Some(stats.time(M::STAGE, || M::build(&occluders, lights, &self.params)));
        stats.memory_bytes = self.maps.as_ref().map_or(0, |m| m.memory_bytes());
        if let Some(share) = occluders.focus_share {
            stats.metrics.push(("focus_share".to_owned(), share as f64));
        }
        Ok(stats)
    }

    fn render(&mut self, ctx: &FrameContext, gbuffer: &GBuffer, out: &mut Image) -> Result<Stats, RenderError> {
        let lights = self.active_lights(ctx);
        let Some(maps) = &self.maps else {
            return Err(RenderError::Unsupported { technique: M::ID.into(), message: "render before prepare".into() });
        };
        let mut stats = Stats { memory_bytes: maps.memory_bytes(), ..Default::default() };
        stats.rays = stats.time("shade", || {
            direct::shade_pixels(ctx, gbuffer, self.settings.seed, out, |i, _rng| {
                let Some(s) = Shading::from_gbuffer(gbuffer, i) else {
                    return (Vec3::ZERO, 0);
                };
                let (e, lookups) = direct::punctual_irradiance_with(lights, &s, |l, _| maps.shadowed(l, s.position, s.normal));
                (s.albedo / PI * e, lookups)
            })
        })?;
        if self.epsilon {
            let e = epsilon::epsilon(&ctx.frame, gbuffer, &ctx.tracer, lights.len(), |l, _, s| maps.shadowed(l, s.position, s.normal));
            stats.metrics = e.to_metrics();
        }
        Ok(stats)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ism::LightsIsm;
    use crate::shadowmap::LightsShadowMap;

    fn render_and_measure<T: Technique>(t: &mut T, ctx: &FrameContext) -> Stats {
        t.prepare(ctx).unwrap();
        let mut img = ctx.image();
        t.render(ctx, &ctx.gbuffer(), &mut img).unwrap()
    }

    /// Both baselines shade through the shell and report ε against exact rays: a finer cube map
    /// makes fewer wrong decisions.
    #[test]
    fn reports_epsilon_and_it_falls_with_resolution() {
        let scene = glimpse_scene::builtin::many_lights(16);
        let ctx = FrameContext::new(&scene, 0.0, 24, 24);
        let eps = |st: &Stats| st.metrics.iter().find(|(k, _)| k == "eps_v_pct").map(|m| m.1).unwrap();
        let mut by_res = Vec::new();
        for r in [8, 128] {
            let p = Params::parse(&[format!("resolution={r}")]).unwrap();
            let st = render_and_measure(&mut LightsShadowMap::new(&scene, &Settings::default(), &p).unwrap(), &ctx);
            by_res.push(eps(&st));
        }
        let ism = render_and_measure(&mut LightsIsm::new(&scene, &Settings::default(), &Params::default()).unwrap(), &ctx);
        println!("ε_v: shadow map 8² {:.2}%, 128² {:.2}%; ISM {:.2}%", by_res[0], by_res[1], eps(&ism));
        assert!(by_res[1] < by_res[0], "{by_res:?}");
        assert!(by_res[1] < 10.0 && eps(&ism) < 50.0);
        let off = Params::parse(&["epsilon=false"]).unwrap();
        assert!(render_and_measure(&mut LightsIsm::new(&scene, &Settings::default(), &off).unwrap(), &ctx).metrics.is_empty());
    }
}

//! What a technique sees of one frame: the scene evaluated at the frame's time, the exact tracer
//! over it, the camera and the image size.

use glimpse_core::Image;
use glimpse_scene::{Camera, Film, Scene, SceneFrame};
use glimpse_trace::{ExactTracer, GBuffer};

pub struct FrameContext<'a> {
    pub frame: SceneFrame<'a>,
    pub tracer: ExactTracer,
    pub camera: Camera,
    pub width: u32,
    pub height: u32,
    /// Index of this frame in an animation (temporal techniques re-draw their random choices
    /// from it); 0 for a still image.
    pub frame_index: u32,
    /// Pixel filter and primary samples per pixel (the scene's, unless the command line says).
    pub film: Film,
    /// Which primary sample of each pixel [`FrameContext::gbuffer`] traces.
    pub film_pass: u32,
    /// Pixels finished in the current `render`, for progress bars.
    pub progress: crate::Progress,
}

impl<'a> FrameContext<'a> {
    pub fn new(scene: &'a Scene, time: f32, width: u32, height: u32) -> Self {
        let frame = scene.at(time);
        let tracer = ExactTracer::build(&frame);
        let camera = scene.camera_or_default(width as f32 / height as f32);
        let film = scene.film;
        Self { frame, tracer, camera, width, height, frame_index: 0, film, film_pass: 0, progress: crate::Progress::default() }
    }

    pub fn scene(&self) -> &'a Scene {
        self.frame.scene
    }

    /// Moves to another time of the same scene, updating the tracer in place.
    pub fn advance(&mut self, time: f32, frame_index: u32) {
        self.frame = self.frame.scene.at(time);
        self.tracer.update(&self.frame);
        self.frame_index = frame_index;
    }

    /// The instances whose back faces (against their winding) the camera sees, sorted, from
    /// `across` primary rays across the image (and as many down as its aspect gives): the
    /// double-sided surfaces in view (leaves, cloth, a room's outward-facing walls). Cheap
    /// (128 across: about 10K rays); an instance seen from behind in fewer pixels than the
    /// probe's spacing can be missed.
    pub fn instances_seen_from_behind(&self, across: u32) -> Vec<u32> {
        use rayon::prelude::*;
        let w = across.max(1);
        let h = ((w as f32 * self.height as f32 / self.width.max(1) as f32).round() as u32).max(1);
        let mut seen: Vec<u32> = (0..w * h)
            .into_par_iter()
            .filter_map(|i| {
                let ray = self.camera.ray((i % w) as f32 + 0.5, (i / w) as f32 + 0.5, w, h);
                let hit = self.tracer.closest_hit(&ray, f32::INFINITY)?;
                let sp = glimpse_trace::SurfacePoint::from_hit(&self.frame, &ray, &hit);
                (!sp.front_face).then_some(sp.instance)
            })
            .collect();
        seen.sort_unstable();
        seen.dedup();
        seen
    }

    /// The GBuffer of primary sample [`FrameContext::film_pass`] under the film's filter.
    pub fn gbuffer(&self) -> GBuffer {
        GBuffer::sampled(&self.frame, &self.tracer, &self.camera, self.width, self.height, self.film.filter, self.film_pass)
    }

    pub fn image(&self) -> Image {
        Image::new(self.width, self.height)
    }
}

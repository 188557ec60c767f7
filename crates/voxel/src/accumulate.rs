//! Temporal accumulation (paper §4.3, §6: ROMA relies on re-drawn candidate directions and BOM
//! jitter every frame, integrated over time by NRD ReLAX and TAA, "accumulating up to 10
//! frames"). We have neither denoiser: a technique blends each new frame into a history with
//! weight `1 / min(frames so far, window)`, i.e. a running mean over the first `window` frames
//! and an exponential moving average after that (so a moving scene forgets old frames). The
//! history restarts at `frame_index == 0`, when the frame index goes backwards or skips, and
//! when the image size changes. Static camera only: there is no reprojection.

use glimpse_core::Image;

/// Frames accumulated by default: NRD in the paper "accumulates up to 10 frames" (§7.3).
pub const DEFAULT_ACCUMULATE: u32 = 10;

/// The per-technique history.
#[derive(Clone, Debug, Default)]
pub struct Accumulator {
    /// Frames averaged at most (1 = no accumulation).
    pub window: u32,
    history: Option<Image>,
    frames: u32,
    last_index: u32,
}

impl Accumulator {
    pub fn new(window: u32) -> Self {
        Self { window: window.max(1), ..Default::default() }
    }

    /// Frames in the current history.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Blends `image` (this frame's estimate) into the history and writes the blend back.
    pub fn blend(&mut self, frame_index: u32, image: &mut Image) {
        let restart = match &self.history {
            None => true,
            Some(h) => {
                frame_index == 0 || frame_index != self.last_index.wrapping_add(1) || h.width != image.width || h.height != image.height
            }
        };
        self.last_index = frame_index;
        if restart || self.window <= 1 {
            self.history = Some(image.clone());
            self.frames = 1;
            return;
        }
        self.frames += 1;
        let alpha = 1.0 / self.frames.min(self.window) as f32;
        let history = self.history.as_mut().expect("checked above");
        for (h, p) in history.pixels.iter_mut().zip(image.pixels.iter_mut()) {
            *h += (*p - *h) * alpha;
            *p = *h;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Vec3;

    #[test]
    fn running_mean_then_moving_average_and_restart() {
        let mut acc = Accumulator::new(4);
        let mut out = Vec::new();
        for (k, v) in [1.0, 3.0, 5.0, 7.0, 9.0].into_iter().enumerate() {
            let mut img = Image::filled(2, 1, Vec3::splat(v));
            acc.blend(k as u32, &mut img);
            out.push(img.pixels[0].x);
        }
        println!("accumulated: {out:?}");
        assert_eq!(&out[..4], &[1.0, 2.0, 3.0, 4.0]); // running mean over the window
        assert!((out[4] - (4.0 + (9.0 - 4.0) / 4.0)).abs() < 1e-6); // then α = 1/4
        let mut img = Image::filled(2, 1, Vec3::splat(100.0));
        acc.blend(0, &mut img);
        assert_eq!(img.pixels[0].x, 100.0, "frame 0 restarts");
    }
}

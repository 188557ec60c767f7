//! A per-pixel scalar map (an SSIM map, a FLIP error map, an HDR-FLIP exposure map), row-major
//! from the top-left pixel like [`glimpse_core::Image`].

/// One `f32` per pixel, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct ScalarMap {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

impl ScalarMap {
    pub fn get(&self, x: u32, y: u32) -> f32 {
        self.values[y as usize * self.width as usize + x as usize]
    }

    /// Mean of all values, accumulated in f64 (0 for an empty map).
    pub fn mean(&self) -> f64 {
        if self.values.is_empty() {
            return 0.0;
        }
        self.values.iter().map(|&v| f64::from(v)).sum::<f64>() / self.values.len() as f64
    }

    pub fn max(&self) -> f32 {
        self.values.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    }
}

//! The film: how each pixel's primary samples are placed. A pixel is the filter-weighted average
//! of the radiance around its centre; glimpse draws sample positions *from* the filter (exact
//! importance sampling, so every sample weighs 1, as pbrt-v4's filter sampling does) instead of
//! splatting weighted samples, which keeps every technique's pixel an independent average that
//! a reference can match sample for sample.
//!
//! Filters (widths as Mitsuba 3 and pbrt-v4 define them; every filter is separable):
//! - `box`: 1 pixel wide (radius ½), the default;
//! - `tent`: radius 1;
//! - `gaussian`: σ = ½, cut at radius 4σ = 2 and shifted down to reach 0 there (Mitsuba's form);
//!   sampled from a 1,024-bin table per axis;
//! - `pixel-centre`: every sample at the pixel's centre (no antialiasing: what glimpse did
//!   before filters, kept for comparisons with it).

use glimpse_core::Vec2;
use std::sync::OnceLock;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    #[default]
    Box,
    Tent,
    Gaussian,
    PixelCentre,
}

impl Filter {
    pub const NAMES: [&'static str; 4] = ["box", "tent", "gaussian", "pixel-centre"];

    pub fn parse(name: &str) -> Option<Filter> {
        match name {
            "box" => Some(Filter::Box),
            "tent" => Some(Filter::Tent),
            "gaussian" => Some(Filter::Gaussian),
            "pixel-centre" | "pixel-center" => Some(Filter::PixelCentre),
            _ => None,
        }
    }

    /// Like [`Filter::parse`], with an error naming the known filters.
    pub fn from_name(name: &str) -> Result<Filter, String> {
        Self::parse(name).ok_or_else(|| format!("unknown filter '{name}' (known: {})", Self::NAMES.join(", ")))
    }

    pub fn name(self) -> &'static str {
        match self {
            Filter::Box => "box",
            Filter::Tent => "tent",
            Filter::Gaussian => "gaussian",
            Filter::PixelCentre => "pixel-centre",
        }
    }

    /// How far from the pixel centre samples reach, in pixels.
    pub fn radius(self) -> f32 {
        match self {
            Filter::Box => 0.5,
            Filter::Tent => 1.0,
            Filter::Gaussian => GAUSSIAN_RADIUS,
            Filter::PixelCentre => 0.0,
        }
    }

    /// The filter's value at offset `x` along one axis (unnormalized).
    pub fn eval_1d(self, x: f32) -> f32 {
        let x = x.abs();
        match self {
            Filter::Box => (x <= 0.5) as u32 as f32,
            Filter::Tent => (1.0 - x).max(0.0),
            Filter::Gaussian => gaussian(x),
            Filter::PixelCentre => (x == 0.0) as u32 as f32,
        }
    }

    /// A sample offset from the pixel centre, in pixels, distributed as the filter (`u` uniform
    /// in [0, 1)²).
    pub fn sample(self, u: Vec2) -> Vec2 {
        Vec2::new(self.sample_1d(u.x), self.sample_1d(u.y))
    }

    fn sample_1d(self, u: f32) -> f32 {
        match self {
            Filter::Box => u - 0.5,
            // Inverse CDF of the triangle on [−1, 1].
            Filter::Tent => {
                if u < 0.5 {
                    (2.0 * u).sqrt() - 1.0
                } else {
                    1.0 - (2.0 - 2.0 * u).sqrt()
                }
            }
            Filter::Gaussian => gaussian_table().sample(u),
            Filter::PixelCentre => 0.0,
        }
    }
}

/// The film a scene asks for: its filter and how many primary samples each pixel averages
/// (each a pass of the whole technique on a GBuffer of its own; see `glimpse_render::film`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Film {
    pub filter: Filter,
    pub samples: u32,
}

impl Default for Film {
    fn default() -> Self {
        Self { filter: Filter::Box, samples: 1 }
    }
}

impl Film {
    /// Most primary samples per pixel a film may ask for (each is a full pass).
    pub const MAX_SAMPLES: u32 = 65_536;

    /// Checks `samples`; the error says what is wrong.
    pub fn validate(&self) -> Result<(), String> {
        if self.samples == 0 || self.samples > Self::MAX_SAMPLES {
            return Err(format!("film samples = {} must be in 1..={}", self.samples, Self::MAX_SAMPLES));
        }
        Ok(())
    }
}

const GAUSSIAN_SIGMA: f32 = 0.5;
const GAUSSIAN_RADIUS: f32 = 4.0 * GAUSSIAN_SIGMA;

fn gaussian(x: f32) -> f32 {
    let g = |x: f32| (-x * x / (2.0 * GAUSSIAN_SIGMA * GAUSSIAN_SIGMA)).exp();
    if x >= GAUSSIAN_RADIUS { 0.0 } else { (g(x) - g(GAUSSIAN_RADIUS)).max(0.0) }
}

/// A 1D density on [−r, r] tabulated in equal bins, sampled by inverting its piecewise-constant
/// CDF.
struct Table {
    radius: f32,
    cdf: Vec<f32>,
}

impl Table {
    fn new(f: impl Fn(f32) -> f32, radius: f32, bins: usize) -> Table {
        let mut cdf = Vec::with_capacity(bins + 1);
        cdf.push(0.0);
        let mut sum = 0.0f64;
        for i in 0..bins {
            let x = -radius + (i as f32 + 0.5) / bins as f32 * 2.0 * radius;
            sum += f(x) as f64;
            cdf.push(sum as f32);
        }
        cdf.iter_mut().for_each(|c| *c /= sum as f32);
        Table { radius, cdf }
    }

    fn sample(&self, u: f32) -> f32 {
        let bins = self.cdf.len() - 1;
        // The last bin whose CDF start is ≤ u.
        let i = self.cdf.partition_point(|&c| c <= u).clamp(1, bins) - 1;
        let width = self.cdf[i + 1] - self.cdf[i];
        let within = if width > 0.0 { ((u - self.cdf[i]) / width).clamp(0.0, 1.0) } else { 0.5 };
        -self.radius + (i as f32 + within) / bins as f32 * 2.0 * self.radius
    }
}

fn gaussian_table() -> &'static Table {
    static TABLE: OnceLock<Table> = OnceLock::new();
    TABLE.get_or_init(|| Table::new(gaussian, GAUSSIAN_RADIUS, 1024))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Histograms of many sampled offsets follow each filter's shape.
    #[test]
    fn samples_are_distributed_as_the_filter() {
        for filter in [Filter::Box, Filter::Tent, Filter::Gaussian] {
            let r = filter.radius();
            let bins = 16;
            let n = 400_000;
            let mut hist = vec![0u32; bins];
            for i in 0..n {
                // A stratified u, so the test measures the inversion, not sampling noise.
                let x = filter.sample_1d((i as f32 + 0.5) / n as f32);
                assert!(x.abs() <= r + 1e-6, "{filter:?}: {x} outside ±{r}");
                hist[(((x + r) / (2.0 * r) * bins as f32) as usize).min(bins - 1)] += 1;
            }
            // Expected share of each bin from the filter's own integral.
            let fine = 64;
            let mass: Vec<f64> = (0..bins)
                .map(|b| {
                    (0..fine).map(|k| filter.eval_1d(-r + (b as f32 + (k as f32 + 0.5) / fine as f32) * 2.0 * r / bins as f32) as f64).sum()
                })
                .collect();
            let total: f64 = mass.iter().sum();
            let worst = hist.iter().zip(&mass).map(|(&h, &m)| (h as f64 / n as f64 - m / total).abs()).fold(0.0, f64::max);
            println!("{}: worst bin share error {worst:.5}", filter.name());
            assert!(worst < 2e-3, "{filter:?}: histogram differs from the filter by {worst}");
        }
        assert_eq!(Filter::PixelCentre.sample(Vec2::new(0.3, 0.9)), Vec2::ZERO);
    }

    #[test]
    fn names_round_trip_and_unknown_names_are_refused() {
        for name in Filter::NAMES {
            assert_eq!(Filter::parse(name).unwrap().name(), name);
        }
        let e = Filter::from_name("lanczos").unwrap_err();
        assert!(e.contains("lanczos") && e.contains("gaussian"), "{e}");
    }
}

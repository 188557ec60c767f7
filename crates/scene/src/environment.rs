//! Environment light: an equirectangular radiance map at infinity, importance-sampled by
//! luminance × sin θ (pbrt-v4's image infinite light).
//!
//! Direction convention (+y up): `u = 0.5 + atan2(d.x, −d.z) / 2π`, `v = acos(d.y) / π`, so the
//! image centre looks along −z and the top row is the zenith.

use glimpse_core::distribution::{Distribution2D, RowAlias};
use glimpse_core::{Image, Vec2, Vec3, luminance};
use std::f32::consts::{PI, TAU};

/// The brightest part of a map ([`Environment::brightest_part`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BrightPart {
    /// Texels with luminance (unscaled) strictly above this belong to the part.
    pub threshold: f32,
    /// Their solid angle (sr).
    pub solid_angle: f32,
    /// Their share of the map's power (Σ L ω).
    pub power_fraction: f32,
}

/// A direction drawn by [`Environment::sample_direction`] and its solid-angle density (0 where
/// the map cannot send it); its radiance is read on demand.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    pub dir: Vec3,
    pub pdf: f32,
    uv: Vec2,
}

#[derive(Clone, Debug)]
pub struct Environment {
    pub image: Image,
    /// Multiplies every texel.
    pub scale: f32,
    distribution: Distribution2D,
    /// The rows' alias tables: a light sample's bin in one load ([`RowAlias`]).
    rows: RowAlias,
    /// [`Environment::half_power_solid_angle`], computed on first use.
    half_power: std::sync::OnceLock<f32>,
}

impl Environment {
    pub fn new(image: Image, scale: f32) -> Self {
        let (w, h) = (image.width as usize, image.height as usize);
        let func: Vec<f32> = (0..h)
            .flat_map(|y| {
                let sin_theta = (PI * (y as f32 + 0.5) / h as f32).sin();
                let img = &image;
                (0..w).map(move |x| luminance(img.pixels[y * w + x]) * sin_theta)
            })
            .collect();
        let distribution = Distribution2D::new(&func, w, h);
        let rows = RowAlias::new(&distribution);
        Self { image, scale, distribution, rows, half_power: std::sync::OnceLock::new() }
    }

    /// The solid angle (sr) of the brightest directions that together send half the map's power
    /// (luminance × solid angle, texel by texel): about 2π for a uniform sky, a few hundredths
    /// of a steradian for a studio map lit by small softboxes. A measure of how small the map's
    /// bright features are, for techniques whose resolution must resolve them.
    pub fn half_power_solid_angle(&self) -> f32 {
        *self.half_power.get_or_init(|| {
            let (texels, total) = self.texels_by_luminance();
            if total.is_nan() || total <= 0.0 {
                return 4.0 * PI;
            }
            let (mut power, mut solid_angle) = (0.0f64, 0.0f32);
            for (l, o) in texels {
                if power >= 0.5 * total {
                    break;
                }
                power += (l * o) as f64;
                solid_angle += o;
            }
            solid_angle
        })
    }

    /// The map's brightest texels spanning at most `solid_angle` sr: those whose luminance
    /// (unscaled) is above the returned threshold, with the share of the map's power they send.
    /// `None` for a black map or when no texel fits. Ties at the threshold stay out, so the part
    /// may be smaller than asked.
    pub fn brightest_part(&self, solid_angle: f32) -> Option<BrightPart> {
        let (mut texels, total) = self.texels();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        // Only the brightest texels are sorted: the k brightest are selected (linear time), and
        // k grows until they span more than `solid_angle` (a 1k map's 0.2 sr is ~5,000 of 512K).
        let brighter = |a: &(f32, f32), b: &(f32, f32)| b.0.total_cmp(&a.0);
        let mut k = 8192.min(texels.len() - 1);
        let top = loop {
            texels.select_nth_unstable_by(k, brighter);
            let top = &mut texels[..=k];
            top.sort_unstable_by(brighter);
            if top.iter().map(|t| t.1).sum::<f32>() > solid_angle || k + 1 == texels.len() {
                break &texels[..=k];
            }
            k = (4 * k).min(texels.len() - 1);
        };
        // The first texel that no longer fits sets the threshold; those tied with it stay out.
        let mut running = 0.0f32;
        let fit = top
            .iter()
            .take_while(|t| {
                running += t.1;
                running <= solid_angle
            })
            .count();
        let threshold = top.get(fit).map_or(0.0, |t| t.0);
        let part = top.iter().take_while(|t| t.0 > threshold);
        let (power, covered) = part.fold((0.0f64, 0.0f32), |(p, c), &(l, o)| (p + (l * o) as f64, c + o));
        (covered > 0.0).then(|| BrightPart { threshold, solid_angle: covered, power_fraction: (power / total) as f32 })
    }

    /// Every texel's (luminance, solid angle), brightest first, and the map's power Σ L ω.
    fn texels_by_luminance(&self) -> (Vec<(f32, f32)>, f64) {
        let (mut texels, total) = self.texels();
        texels.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
        (texels, total)
    }

    /// Every texel's (luminance, solid angle), in image order, and the map's power Σ L ω.
    fn texels(&self) -> (Vec<(f32, f32)>, f64) {
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        let texel = 2.0 * PI * PI / (w * h) as f32; // (2π / w) · (π / h), times sin θ below
        let texels: Vec<(f32, f32)> = (0..h)
            .flat_map(|y| {
                let omega = texel * (PI * (y as f32 + 0.5) / h as f32).sin();
                let img = &self.image;
                (0..w).map(move |x| (luminance(img.pixels[y * w + x]).max(0.0), omega))
            })
            .collect();
        let total: f64 = texels.iter().map(|(l, o)| (*l * *o) as f64).sum();
        (texels, total)
    }

    /// The same radiance from every direction (the furnace test's light).
    pub fn constant(radiance: Vec3) -> Self {
        Self::new(Image::filled(1, 1, radiance), 1.0)
    }

    pub fn dir_to_uv(d: Vec3) -> Vec2 {
        let u = 0.5 + d.x.atan2(-d.z) / TAU;
        let v = d.y.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(u - u.floor(), v)
    }

    pub fn uv_to_dir(uv: Vec2) -> Vec3 {
        let phi = TAU * (uv.x - 0.5);
        let theta = PI * uv.y;
        Vec3::new(theta.sin() * phi.sin(), theta.cos(), -theta.sin() * phi.cos())
    }

    /// Radiance arriving from direction `d` (pointing away from the receiver).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.radiance_at_uv(Self::dir_to_uv(d))
    }

    fn radiance_at_uv(&self, uv: Vec2) -> Vec3 {
        self.image.sample_bilinear(uv.x, uv.y, false) * self.scale
    }

    /// Samples a direction by importance; returns (direction, radiance, solid-angle pdf).
    pub fn sample(&self, u: Vec2) -> (Vec3, Vec3, f32) {
        let s = self.sample_direction(u);
        (s.dir, self.sample_radiance(&s), s.pdf)
    }

    /// [`Environment::sample`] without the radiance lookup, for callers that read it
    /// ([`Environment::sample_radiance`]) only where the sample counts: above the surface, where
    /// the BRDF is not zero and the shadow ray is free. The lookup is a cache miss on a 1k map
    /// (12 B texels, 6 MiB), and a path tracer discards about half its light samples.
    pub fn sample_direction(&self, u: Vec2) -> EnvSample {
        let (v, pdf_v, row) = self.distribution.marginal.sample_continuous(u.y);
        let (x, pdf_u) = self.rows.sample(row, u.x);
        let (uv, pdf_uv) = (Vec2::new(x, v), pdf_u * pdf_v);
        let dir = Self::uv_to_dir(uv);
        let sin_theta = (PI * uv.y).sin();
        let pdf = if pdf_uv == 0.0 || sin_theta == 0.0 { 0.0 } else { pdf_uv / (2.0 * PI * PI * sin_theta) };
        EnvSample { dir, pdf, uv }
    }

    /// The radiance of a [`Environment::sample_direction`] sample, read at the sample's own uv
    /// (no atan2/acos back from its direction); zero where its density is zero.
    pub fn sample_radiance(&self, s: &EnvSample) -> Vec3 {
        if s.pdf == 0.0 { Vec3::ZERO } else { self.radiance_at_uv(s.uv) }
    }

    /// Solid-angle density of [`Environment::sample`] for direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        self.pdf_at_uv(Self::dir_to_uv(d))
    }

    fn pdf_at_uv(&self, uv: Vec2) -> f32 {
        let sin_theta = (PI * uv.y).sin();
        if sin_theta == 0.0 { 0.0 } else { self.distribution.pdf(uv) / (2.0 * PI * PI * sin_theta) }
    }

    /// [`Environment::radiance`] and [`Environment::pdf`] of one direction with one
    /// direction-to-uv conversion: what a BRDF-sampled ray that escapes needs for MIS.
    pub fn radiance_and_pdf(&self, d: Vec3) -> (Vec3, f32) {
        let uv = Self::dir_to_uv(d);
        (self.radiance_at_uv(uv), self.pdf_at_uv(uv))
    }

    /// A procedural sky: a blue gradient above, a dim ground below, and a small bright sun disk
    /// around `sun_dir` (unit, pointing towards the sun), at `width × width/2`.
    pub fn procedural_sky(width: u32, sun_dir: Vec3, sun_radiance: f32) -> Self {
        let height = (width / 2).max(1);
        let sun_dir = sun_dir.normalize();
        let sun_cos = (2.0f32).to_radians().cos();
        let image = Image::from_fn(width, height, |x, y| {
            let d = Self::uv_to_dir(Vec2::new((x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32));
            let sky = if d.y >= 0.0 {
                let h = d.y.powf(0.5);
                Vec3::new(0.85, 0.9, 1.0).lerp(Vec3::new(0.25, 0.45, 0.9), h)
            } else {
                Vec3::new(0.3, 0.28, 0.25)
            };
            if d.dot(sun_dir) > sun_cos { Vec3::new(1.0, 0.95, 0.85) * sun_radiance } else { sky }
        });
        Self::new(image, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Rng;

    /// A sample's lazily read radiance is the radiance of its direction, and its density the
    /// density `pdf` gives that direction; `radiance_and_pdf` is the two calls in one.
    #[test]
    fn lazy_samples_and_joint_lookups_agree_with_the_plain_ones() {
        let (w, h) = (37u32, 19u32);
        let image = Image::from_fn(w, h, |x, y| {
            let mut r = Rng::new(9, (y * w + x) as u64);
            Vec3::new(r.next_f32(), 10.0 * r.next_f32(), r.next_f32().powi(6) * 1e3)
        });
        let env = Environment::new(image, 2.5);
        let mut rng = Rng::new(9, 0);
        for _ in 0..20_000 {
            let s = env.sample_direction(rng.next_2d());
            assert!(s.pdf > 0.0);
            let (l, pdf) = env.radiance_and_pdf(s.dir);
            assert_eq!((l, pdf), (env.radiance(s.dir), env.pdf(s.dir)));
            let rel = |a: f32, b: f32| (a - b).abs() <= 1e-3 * a.abs().max(b.abs()) + 1e-6;
            // Near a pole acos loses the sample's v (and sin θ with it) to rounding.
            if s.dir.y.abs() < 0.99 {
                assert!(rel(pdf, s.pdf), "pdf {} of a sample, {pdf} of its direction {}", s.pdf, s.dir);
            }
            // The sample's uv and its direction's uv differ by rounding: near a texel's edge the
            // bilinear weights move a little, never more than a texel's worth of difference.
            let lazy = env.sample_radiance(&s);
            assert!((lazy - l).abs().max_element() <= 1e-3 * l.max_element() + 1e-4, "{lazy} vs {l}");
        }
    }

    /// A grid over a map's own texels gives `uv_to_dir`'s directions bit for bit, the texels
    /// as `radiance` reads them at their centres, and cells that tile the sphere; a finer grid
    /// over a coarse map reads it bilinearly.
    #[test]
    fn a_sphere_grid_walks_the_maps_texels() {
        let env = Environment::new(
            Image::from_fn(48, 24, |x, y| {
                let mut rng = Rng::new(3, (y * 48 + x) as u64);
                Vec3::new(rng.next_f32(), rng.next_f32(), 4.0 * rng.next_f32())
            }),
            2.0,
        );
        for (grid, own) in [(SphereGrid::for_map(&env, 16, 8), true), (SphereGrid::for_map(&env, 64, 32), false)] {
            assert_eq!((grid.width == 48, grid.height == 24), (own, own));
            let mut solid_angle = 0.0f64;
            for y in 0..grid.height {
                let mut x = 0;
                grid.for_row(&env, y, |d, l| {
                    let uv = Vec2::new((x as f32 + 0.5) / grid.width as f32, (y as f32 + 0.5) / grid.height as f32);
                    assert_eq!(d, Environment::uv_to_dir(uv));
                    let expected = env.radiance(d);
                    assert!((l - expected).abs().max_element() <= 1e-4 * expected.max_element().max(1.0), "({x}, {y}): {l} vs {expected}");
                    x += 1;
                });
                assert_eq!(x, grid.width);
                solid_angle += grid.row_solid_angle(y) as f64 * grid.width as f64;
            }
            assert!((solid_angle - 4.0 * std::f64::consts::PI).abs() < 1e-4, "{solid_angle}");
        }
    }

    /// Uniform: half the power comes from half the sphere. One bright texel holding most of the
    /// power: its own solid angle.
    #[test]
    fn half_power_solid_angle_measures_the_bright_part() {
        let uniform = Environment::new(Image::filled(64, 32, Vec3::ONE), 1.0).half_power_solid_angle();
        println!("uniform: {uniform} sr (2π = {})", 2.0 * PI);
        assert!((uniform - 2.0 * PI).abs() < 0.05 * 2.0 * PI, "{uniform}");
        let mut img = Image::filled(64, 32, Vec3::splat(0.001));
        img.pixels[16 * 64 + 10] = Vec3::splat(1e4);
        let spot = Environment::new(img, 1.0).half_power_solid_angle();
        let texel = 2.0 * PI * PI / (64.0 * 32.0) * (PI * 16.5 / 32.0).sin();
        println!("one bright texel: {spot} sr (its solid angle {texel})");
        assert!((spot - texel).abs() < 1e-6, "{spot} vs {texel}");
        assert_eq!(Environment::constant(Vec3::ZERO).half_power_solid_angle(), 4.0 * PI);
    }

    /// The brightest part within a solid angle: whole texels, brightest first, ties at the
    /// threshold left out.
    #[test]
    fn brightest_part_takes_the_brightest_texels_that_fit() {
        let mut img = Image::filled(64, 32, Vec3::splat(1.0));
        img.pixels[16 * 64 + 10] = Vec3::splat(100.0);
        img.pixels[16 * 64 + 11] = Vec3::splat(50.0);
        let env = Environment::new(img, 1.0);
        let texel = 2.0 * PI * PI / (64.0 * 32.0) * (PI * 16.5 / 32.0).sin();
        let both = env.brightest_part(2.5 * texel).unwrap();
        println!("{both:?} (one texel {texel} sr)");
        assert_eq!(both.threshold, 1.0);
        assert!((both.solid_angle - 2.0 * texel).abs() < 1e-6);
        let one = env.brightest_part(1.5 * texel).unwrap();
        assert_eq!(one.threshold, 50.0);
        assert!((one.power_fraction - 100.0 * texel / (150.0 * texel + 4.0 * PI - 2.0 * texel)).abs() < 1e-3);
        assert!(env.brightest_part(0.5 * texel).is_none(), "no texel fits");
        assert!(Environment::constant(Vec3::ONE).brightest_part(1.0).is_none(), "all tied");
    }

    #[test]
    fn direction_mapping_round_trips() {
        let mut rng = Rng::new(9, 0);
        for _ in 0..1000 {
            let d = glimpse_core::sampling::uniform_sphere(rng.next_2d());
            assert!((Environment::uv_to_dir(Environment::dir_to_uv(d)) - d).length() < 1e-4);
        }
        assert!((Environment::uv_to_dir(Vec2::new(0.5, 0.5)) - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
    }

    #[test]
    fn importance_sampling_integrates_the_map() {
        // ∫ L dω estimated with importance samples equals the texel-weighted integral.
        let sky = Environment::procedural_sky(128, Vec3::new(0.3, 0.8, 0.2), 500.0);
        let mut rng = Rng::new(2, 0);
        let n = 200_000;
        let mut est = 0.0f64;
        let mut pdf_mismatches = 0;
        for _ in 0..n {
            let (d, l, pdf) = sky.sample(rng.next_2d());
            if pdf > 0.0 {
                est += (luminance(l) / pdf) as f64;
                // Only samples on a texel border may round into the neighbouring texel.
                pdf_mismatches += ((sky.pdf(d) - pdf).abs() > 1e-3 * pdf) as u32;
            }
        }
        est /= n as f64;
        println!("pdf(sample) != sample's pdf for {pdf_mismatches} of {n}");
        assert!(pdf_mismatches < n / 1000);
        let (w, h) = (sky.image.width, sky.image.height);
        let exact: f64 = (0..h)
            .map(|y| {
                let th0 = PI as f64 * y as f64 / h as f64;
                let th1 = PI as f64 * (y + 1) as f64 / h as f64;
                let dw = TAU as f64 / w as f64 * (th0.cos() - th1.cos());
                (0..w).map(|x| luminance(sky.image.get(x, y)) as f64 * dw).sum::<f64>()
            })
            .sum();
        println!("importance estimate {est:.3} vs texel integral {exact:.3}");
        assert!((est - exact).abs() / exact < 0.02);
    }
}

/// A latitude-longitude grid of `width × height` cells over the sphere, laid out as an
/// equirectangular map's texels, for integrals over the whole environment (SH projection,
/// moments). Each cell's direction is [`Environment::uv_to_dir`] at its centre, bit for bit;
/// the column angles' sines and cosines are computed once instead of per cell.
#[derive(Clone, Debug)]
pub struct SphereGrid {
    pub width: u32,
    pub height: u32,
    /// (sin φ, cos φ) of each column's centre.
    columns: Vec<(f32, f32)>,
}

impl SphereGrid {
    pub fn new(width: u32, height: u32) -> Self {
        let columns = (0..width)
            .map(|x| {
                let u = (x as f32 + 0.5) / width as f32;
                (TAU * (u - 0.5)).sin_cos()
            })
            .collect();
        Self { width, height, columns }
    }

    /// The grid of `env`'s own texels, or at least `min_width × min_height` cells for a coarser
    /// map (which is then read by bilinear lookups).
    pub fn for_map(env: &Environment, min_width: u32, min_height: u32) -> Self {
        Self::new(env.image.width.max(min_width), env.image.height.max(min_height))
    }

    /// The solid angle of each cell of row `y`.
    pub fn row_solid_angle(&self, y: u32) -> f32 {
        let (th0, th1) = (PI * y as f32 / self.height as f32, PI * (y + 1) as f32 / self.height as f32);
        TAU / self.width as f32 * (th0.cos() - th1.cos())
    }

    /// `f(direction, radiance)` for each cell of row `y`: the texel itself (× scale) where the
    /// grid is the map's own, else [`Environment::radiance`] at the cell's direction (bilinear
    /// at a texel centre is that texel up to rounding).
    pub fn for_row(&self, env: &Environment, y: u32, mut f: impl FnMut(Vec3, Vec3)) {
        let (sin_theta, cos_theta) = (PI * ((y as f32 + 0.5) / self.height as f32)).sin_cos();
        let own = env.image.width == self.width && env.image.height == self.height;
        let row = (y * self.width) as usize;
        for (x, &(sin_phi, cos_phi)) in self.columns.iter().enumerate() {
            let d = Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi);
            let l = if own { env.image.pixels[row + x] * env.scale } else { env.radiance(d) };
            f(d, l);
        }
    }
}

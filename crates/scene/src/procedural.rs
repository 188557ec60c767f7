//! Procedural base-colour textures for scene.toml (`texture = { checker = … }` or `{ noise = … }`),
//! baked into an ordinary linear RGB image so every technique reads them as it reads a file
//! texture (`Scene::base_color` with repeat wrapping over the mesh's uvs).
//!
//! - checker: `cells` squares per side alternating `colors[0]` and `colors[1]`.
//! - noise: value noise (a seeded lattice of random values, smoothstep-interpolated) summed over
//!   `octaves` with halving amplitude, mapped linearly between the two colours; the lattice wraps,
//!   so the texture tiles without seams.
//!
//! Baked at `resolution` texels per side (default 512): a checker cell is then ≥ 8 texels wide for
//! up to 64 cells, so bilinear filtering only softens the edges by one texel.

use glimpse_core::{Image, Rng, Vec3};
use serde::Deserialize;

#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct TextureDef {
    pub checker: Option<CheckerDef>,
    pub noise: Option<NoiseDef>,
    /// Texels per side of the baked image; default 512.
    pub resolution: Option<u32>,
}

#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct CheckerDef {
    /// Squares per side of the uv square.
    pub cells: u32,
    /// The two alternating linear RGB colours; default black and white.
    pub colors: Option<[[f32; 3]; 2]>,
}

#[derive(Deserialize, Clone, Debug)]
#[serde(deny_unknown_fields)]
pub struct NoiseDef {
    /// Lattice cells per side of the uv square (the largest feature is 1/cells of it).
    pub cells: u32,
    /// Octaves of halving amplitude and doubling frequency; default 4.
    pub octaves: Option<u32>,
    /// Colours at noise 0 and 1; default black and white.
    pub colors: Option<[[f32; 3]; 2]>,
    pub seed: Option<u64>,
}

/// The baked image, or a message naming the bad field.
pub fn bake(def: &TextureDef) -> Result<Image, String> {
    let res = def.resolution.unwrap_or(512);
    if !(2..=4096).contains(&res) {
        return Err(format!("texture resolution {res} must lie in 2..=4096"));
    }
    let check_colors = |c: Option<[[f32; 3]; 2]>| -> Result<[Vec3; 2], String> {
        let c = c.unwrap_or([[0.0; 3], [1.0; 3]]);
        if c.iter().flatten().any(|v| !v.is_finite() || *v < 0.0) {
            return Err("texture colors must be finite and non-negative".into());
        }
        Ok(c.map(Vec3::from_array))
    };
    match (&def.checker, &def.noise) {
        (Some(c), None) => {
            if !(1..=1024).contains(&c.cells) {
                return Err(format!("checker cells {} must lie in 1..=1024", c.cells));
            }
            let colors = check_colors(c.colors)?;
            Ok(Image::from_fn(res, res, |x, y| {
                let cx = (x as u64 * c.cells as u64) / res as u64;
                let cy = (y as u64 * c.cells as u64) / res as u64;
                colors[((cx + cy) % 2) as usize]
            }))
        }
        (None, Some(n)) => {
            if !(1..=256).contains(&n.cells) {
                return Err(format!("noise cells {} must lie in 1..=256", n.cells));
            }
            let octaves = n.octaves.unwrap_or(4);
            if !(1..=8).contains(&octaves) {
                return Err(format!("noise octaves {octaves} must lie in 1..=8"));
            }
            let colors = check_colors(n.colors)?;
            let noise = ValueNoise::new(n.cells, octaves, n.seed.unwrap_or(0));
            Ok(Image::from_fn(res, res, |x, y| {
                let t = noise.at((x as f32 + 0.5) / res as f32, (y as f32 + 0.5) / res as f32);
                colors[0] + (colors[1] - colors[0]) * t
            }))
        }
        _ => Err("a texture is exactly one of checker or noise".into()),
    }
}

/// Tiling multi-octave value noise on the unit square, in [0, 1].
struct ValueNoise {
    cells: u32,
    octaves: u32,
    /// One lattice per octave, `(cells << octave)²` values each.
    lattices: Vec<Vec<f32>>,
}

impl ValueNoise {
    fn new(cells: u32, octaves: u32, seed: u64) -> Self {
        let lattices = (0..octaves)
            .map(|o| {
                let n = (cells << o) as usize;
                let mut rng = Rng::new(seed, o as u64);
                (0..n * n).map(|_| rng.next_f32()).collect()
            })
            .collect();
        Self { cells, octaves, lattices }
    }

    fn at(&self, u: f32, v: f32) -> f32 {
        let (mut sum, mut weight, mut amp) = (0.0, 0.0, 1.0);
        for o in 0..self.octaves {
            let n = self.cells << o;
            let lattice = &self.lattices[o as usize];
            let (x, y) = (u * n as f32, v * n as f32);
            let (x0, y0) = (x.floor(), y.floor());
            let smooth = |t: f32| t * t * (3.0 - 2.0 * t);
            let (tx, ty) = (smooth(x - x0), smooth(y - y0));
            let at = |i: f32, j: f32| {
                let (i, j) = ((i as i64).rem_euclid(n as i64) as usize, (j as i64).rem_euclid(n as i64) as usize);
                lattice[j * n as usize + i]
            };
            let top = at(x0, y0) + (at(x0 + 1.0, y0) - at(x0, y0)) * tx;
            let bottom = at(x0, y0 + 1.0) + (at(x0 + 1.0, y0 + 1.0) - at(x0, y0 + 1.0)) * tx;
            sum += amp * (top + (bottom - top) * ty);
            weight += amp;
            amp *= 0.5;
        }
        sum / weight
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_alternates_and_noise_spans_its_colours() {
        let def =
            TextureDef { checker: Some(CheckerDef { cells: 4, colors: Some([[0.1; 3], [0.9; 3]]) }), noise: None, resolution: Some(64) };
        let img = bake(&def).unwrap();
        // Texel (0,0) is in cell (0,0); texel (16,0) in cell (1,0); (16,16) in (1,1).
        assert_eq!(img.get(0, 0), Vec3::splat(0.1));
        assert_eq!(img.get(16, 0), Vec3::splat(0.9));
        assert_eq!(img.get(16, 16), Vec3::splat(0.1));

        let def = TextureDef {
            checker: None,
            noise: Some(NoiseDef { cells: 4, octaves: None, colors: None, seed: Some(3) }),
            resolution: Some(64),
        };
        let img = bake(&def).unwrap();
        let values: Vec<f32> = img.pixels.iter().map(|p| p.x).collect();
        let (lo, hi) = values.iter().fold((f32::MAX, f32::MIN), |(l, h), &v| (l.min(v), h.max(v)));
        println!("noise range [{lo:.3}, {hi:.3}]");
        assert!(lo >= 0.0 && hi <= 1.0 && hi - lo > 0.3, "noise should vary within [0, 1]: [{lo}, {hi}]");
        assert_eq!(img.pixels, bake(&def).unwrap().pixels, "noise must be deterministic for a seed");
    }

    #[test]
    fn bad_definitions_are_errors() {
        let both = TextureDef {
            checker: Some(CheckerDef { cells: 4, colors: None }),
            noise: Some(NoiseDef { cells: 4, octaves: None, colors: None, seed: None }),
            resolution: None,
        };
        assert!(bake(&both).unwrap_err().contains("exactly one"));
        let zero = TextureDef { checker: Some(CheckerDef { cells: 0, colors: None }), noise: None, resolution: None };
        assert!(bake(&zero).unwrap_err().contains("cells"));
    }
}

//! Piecewise-constant 1D and 2D distributions for importance sampling (pbrt-v4 §A.5): the
//! environment map samples by luminance × sin θ, lights by power.

use glam::Vec2;

/// A piecewise-constant density over [0,1) with `func.len()` equal bins.
#[derive(Clone, Debug)]
pub struct Distribution1D {
    pub func: Vec<f32>,
    /// `cdf[0] = 0`, `cdf[n] = 1`.
    pub cdf: Vec<f32>,
    /// Integral of `func` over [0,1).
    pub integral: f32,
    /// `guide[k]` = the bin of u = k/n (Chen and Asau's cutpoint method): a search starts there
    /// and bisects only up to the next cutpoint's bin, on average one bin, instead of the whole CDF. Environment
    /// maps sample a marginal and a conditional per light sample, and the bisection's chain of
    /// dependent loads was 13 % of a wavelet-cache precompute on `mixed-lights`.
    guide: Vec<u32>,
}

impl Distribution1D {
    /// Negative or non-finite weights count as zero; an all-zero function becomes uniform.
    pub fn new(func: &[f32]) -> Self {
        let n = func.len().max(1);
        let mut func: Vec<f32> = func.iter().map(|&f| if f.is_finite() && f > 0.0 { f } else { 0.0 }).collect();
        func.resize(n, 0.0);
        let mut cdf = vec![0.0f64; n + 1];
        for i in 0..n {
            cdf[i + 1] = cdf[i] + func[i] as f64 / n as f64;
        }
        let integral = cdf[n];
        if integral <= 0.0 {
            func.iter_mut().for_each(|f| *f = 1.0);
            return Self::new(&func);
        }
        let cdf: Vec<f32> = cdf.iter().map(|c| (c / integral) as f32).collect();
        let mut guide = Vec::with_capacity(n);
        let mut bin = 0;
        for k in 0..n {
            let u = k as f32 / n as f32;
            while bin + 1 < n && cdf[bin + 1] <= u {
                bin += 1;
            }
            guide.push(bin as u32);
        }
        Self { func, cdf, integral: integral as f32, guide }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Samples a continuous position in [0,1); returns (x, pdf(x), bin).
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let bin = self.find_bin(u);
        let (c0, c1) = (self.cdf[bin], self.cdf[bin + 1]);
        let du = if c1 > c0 { (u - c0) / (c1 - c0) } else { 0.0 };
        let x = ((bin as f32 + du.clamp(0.0, 1.0)) / self.len() as f32).min(1.0 - f32::EPSILON);
        (x, self.func[bin] / self.integral, bin)
    }

    /// Samples a bin with probability proportional to its weight; returns (bin, probability).
    pub fn sample_discrete(&self, u: f32) -> (usize, f32) {
        let bin = self.find_bin(u);
        (bin, self.discrete_pdf(bin))
    }

    pub fn discrete_pdf(&self, bin: usize) -> f32 {
        self.func[bin] / (self.integral * self.len() as f32)
    }

    /// The last bin whose cdf start is <= u (0 for u < 0 or NaN): the bisection's answer, found
    /// from the guide table (the unit test checks the two agree).
    fn find_bin(&self, u: f32) -> usize {
        let n = self.len();
        if u.is_nan() {
            return 0;
        }
        let k = ((u * n as f32) as usize).min(n - 1);
        let mut lo = self.guide[k] as usize;
        // u·n can round up past u's own interval: step back first.
        while lo > 0 && self.cdf[lo] > u {
            lo -= 1;
        }
        // The bin lies between this cutpoint's and the next one's (bisected there: where a few
        // bins hold most of the weight, a sun in a sky, one u-interval spans hundreds of the
        // others and a walk through them was 5 % of a wavelet-cache precompute on
        // `sponza-interior`); the walk after it only covers u·n rounding down past the next.
        let hi = if k + 1 < n { (self.guide[k + 1] as usize).max(lo) } else { n - 1 };
        let mut bin = lo + self.cdf[lo + 1..=hi].partition_point(|&c| c <= u);
        while bin + 1 < n && self.cdf[bin + 1] <= u {
            bin += 1;
        }
        bin
    }
}

/// A piecewise-constant density over [0,1)², sampled as a marginal in v then a conditional in u.
#[derive(Clone, Debug)]
pub struct Distribution2D {
    pub conditional: Vec<Distribution1D>,
    pub marginal: Distribution1D,
    /// Row-major `func / integral`: [`Distribution2D::pdf`] in one load instead of a chase
    /// through the row's own allocation (environment lookups are cache misses on a 1k map).
    density: Vec<f32>,
    width: usize,
}

impl Distribution2D {
    /// `func` is row-major, `width × height`, row 0 at v = 0.
    pub fn new(func: &[f32], width: usize, height: usize) -> Self {
        let conditional: Vec<Distribution1D> = (0..height).map(|y| Distribution1D::new(&func[y * width..(y + 1) * width])).collect();
        let marginal = Distribution1D::new(&conditional.iter().map(|c| c.integral).collect::<Vec<_>>());
        let width = conditional.first().map_or(0, Distribution1D::len);
        let density = conditional.iter().flat_map(|c| c.func.iter().map(|&f| f / marginal.integral)).collect();
        Self { conditional, marginal, density, width }
    }

    /// Returns a point in [0,1)² and its density.
    pub fn sample(&self, u: Vec2) -> (Vec2, f32) {
        let (v, pdf_v, row) = self.marginal.sample_continuous(u.y);
        let (x, pdf_u, _) = self.conditional[row].sample_continuous(u.x);
        (Vec2::new(x, v), pdf_u * pdf_v)
    }

    pub fn pdf(&self, p: Vec2) -> f32 {
        let (w, h) = (self.width, self.conditional.len());
        let row = ((p.y * h as f32) as usize).min(h - 1);
        let col = ((p.x * w as f32) as usize).min(w - 1);
        self.density[row * w + col]
    }
}

/// Per-row alias tables (Walker; Vose's construction) over a [`Distribution2D`]'s conditionals:
/// a row's bin from one table entry instead of a search through its CDF. The same density as
/// [`Distribution2D::sample`] (bin ∝ weight, uniform inside the bin) through another mapping of
/// the random numbers; the marginal is still inverted (its 512 entries stay in cache, a row's
/// CDF and guide are two cache misses on a 1k environment map).
#[derive(Clone, Debug)]
pub struct RowAlias {
    /// Row-major, one entry per bin.
    entries: Vec<AliasEntry>,
    width: usize,
}

/// 16 bytes: the bin's own share of its slot, the other bin of the slot, and both bins'
/// densities in u (so a sample reads one entry).
#[derive(Clone, Copy, Debug, Default)]
struct AliasEntry {
    keep: f32,
    alias: u32,
    pdf: f32,
    alias_pdf: f32,
}

impl RowAlias {
    pub fn new(d: &Distribution2D) -> Self {
        let width = d.conditional.first().map_or(0, Distribution1D::len);
        let mut entries = Vec::with_capacity(width * d.conditional.len());
        for row in &d.conditional {
            entries.extend(alias_row(row));
        }
        Self { entries, width }
    }

    /// Samples u ∈ [0,1) in `row`; returns (u, its density in u).
    pub fn sample(&self, row: usize, u: f32) -> (f32, f32) {
        let w = self.width;
        let t = u.clamp(0.0, 1.0) * w as f32;
        let slot = (t as usize).min(w - 1);
        let f = (t - slot as f32).clamp(0.0, 1.0);
        let e = &self.entries[row * w + slot];
        // The slot's fraction picks the bin and, rescaled, the position inside it.
        let (bin, within, pdf) =
            if f < e.keep { (slot, f / e.keep, e.pdf) } else { (e.alias as usize, (f - e.keep) / (1.0 - e.keep), e.alias_pdf) };
        let x = ((bin as f32 + within.clamp(0.0, 1.0)) / w as f32).min(1.0 - f32::EPSILON);
        (x, pdf)
    }
}

/// Vose's alias construction for one row: slot i keeps bin i with probability `keep`, else
/// gives `alias`.
fn alias_row(row: &Distribution1D) -> Vec<AliasEntry> {
    let n = row.len();
    let pdf = |i: usize| row.func[i] / row.integral;
    // Each bin's probability × n: 1 is one full slot.
    let mut scaled: Vec<f64> = (0..n).map(|i| row.func[i] as f64 / row.integral as f64).collect();
    let mut entries: Vec<AliasEntry> = (0..n).map(|i| AliasEntry { keep: 1.0, alias: i as u32, pdf: pdf(i), alias_pdf: pdf(i) }).collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        entries[s] = AliasEntry { keep: scaled[s] as f32, alias: l as u32, pdf: pdf(s), alias_pdf: pdf(l) };
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left is 1 up to rounding: those slots keep their own bin.
    entries
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rng;

    #[test]
    fn discrete_sampling_follows_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0, 4.0]);
        let mut counts = [0u32; 4];
        let mut rng = Rng::new(3, 0);
        for _ in 0..80_000 {
            counts[d.sample_discrete(rng.next_f32()).0] += 1;
        }
        println!("counts {counts:?} for weights 1:0:3:4");
        assert_eq!(counts[1], 0);
        assert!((counts[0] as f32 / 10_000.0 - 1.0).abs() < 0.05);
        assert!((counts[3] as f32 / 40_000.0 - 1.0).abs() < 0.03);
        assert!((d.discrete_pdf(2) - 3.0 / 8.0).abs() < 1e-6);
    }

    /// The guide table finds the bin bisection finds, for every u: random ones, the CDF's own
    /// values and their neighbours, on shapes with zero bins, a spike and uniform weights.
    #[test]
    fn guided_search_equals_bisection() {
        let mut rng = Rng::new(11, 0);
        let shapes: Vec<Vec<f32>> = vec![
            vec![1.0; 7],
            vec![0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            (0..1000).map(|i| if i == 617 { 1e6 } else { 1e-3 }).collect(),
            (0..513).map(|_| if rng.next_f32() < 0.3 { 0.0 } else { rng.next_f32().powi(8) }).collect(),
            vec![3.0],
        ];
        for func in shapes {
            let d = Distribution1D::new(&func);
            let bisect = |u: f32| d.cdf.partition_point(|&c| c <= u).saturating_sub(1).min(d.len() - 1);
            let mut us: Vec<f32> = (0..20_000).map(|_| rng.next_f32()).collect();
            for &c in &d.cdf {
                us.extend([c, f32::from_bits(c.to_bits().saturating_sub(1)), f32::from_bits(c.to_bits() + 1)]);
            }
            us.extend([0.0, -0.5, 1.0 - f32::EPSILON, 1.0, f32::NAN]);
            for u in us {
                assert_eq!(d.find_bin(u), bisect(u), "u = {u} over {} bins", d.len());
            }
        }
    }

    /// The alias tables draw each bin as often as its weight says, return the density
    /// `Distribution2D::pdf` gives the sample, and stay inside the bin they pick.
    #[test]
    fn alias_rows_sample_the_same_density() {
        let mut rng = Rng::new(17, 0);
        let (w, h) = (16, 3);
        let func: Vec<f32> = (0..w * h)
            .map(|i| match i % 5 {
                0 => 0.0,
                1 => 40.0,
                _ => rng.next_f32(),
            })
            .collect();
        let d = Distribution2D::new(&func, w, h);
        let alias = RowAlias::new(&d);
        for row in 0..h {
            let c = &d.conditional[row];
            let n = 200_000;
            let mut counts = vec![0u32; w];
            for _ in 0..n {
                let (x, pdf) = alias.sample(row, rng.next_f32());
                assert!((0.0..1.0).contains(&x), "x = {x}");
                let bin = (x * w as f32) as usize;
                let p = Vec2::new(x, (row as f32 + 0.5) / h as f32);
                // Its density times the row's (the marginal's) is the 2D density there.
                let pdf_v = d.marginal.func[row] / d.marginal.integral;
                assert!((pdf * pdf_v - d.pdf(p)).abs() <= 1e-5 * d.pdf(p), "pdf {pdf} for bin {bin}");
                counts[bin] += 1;
            }
            for (bin, &k) in counts.iter().enumerate() {
                let expected = c.func[bin] as f64 / (c.integral as f64 * w as f64) * n as f64;
                println!("row {row} bin {bin}: {k} drawn, {expected:.0} expected");
                if c.func[bin] == 0.0 {
                    assert_eq!(k, 0, "a zero-weight bin was drawn");
                }
                assert!((k as f64 - expected).abs() <= 5.0 * expected.sqrt() + 1.0);
            }
        }
    }

    #[test]
    fn two_d_pdf_matches_sampling() {
        let func: Vec<f32> = (0..32).map(|i| (i % 8) as f32 + (i / 8) as f32 * 2.0).collect();
        let d = Distribution2D::new(&func, 8, 4);
        let mut rng = Rng::new(5, 0);
        // E[1/pdf] over samples from pdf = area of the support = 1 (bins with zero weight excluded).
        let n = 50_000;
        let mean_inv: f64 = (0..n).map(|_| 1.0 / d.sample(rng.next_2d()).1 as f64).sum::<f64>() / n as f64;
        println!("E[1/pdf] = {mean_inv:.4} (expected 31/32 = 0.96875)");
        assert!((mean_inv - 31.0 / 32.0).abs() < 0.01);
        let (p, pdf) = d.sample(Vec2::new(0.3, 0.7));
        assert!((d.pdf(p) - pdf).abs() < 1e-4);
    }
}

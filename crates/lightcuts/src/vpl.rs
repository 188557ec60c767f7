//! VPL generation from bounded reflective shadow maps (thesis §4.1 and Ch. 6, after BRSM,
//! Dachsbacher and Stamminger's RSM): every RSM texel is a potential VPL (pVPL); its expected
//! contribution to the visible image is estimated from a few G-buffer surfaces around it
//! (Ch. 6: a random direction and a 1/x² radius capped to 1, projected into the G-buffer, no
//! occlusion), filtered with an edge-aware Gaussian (stop function S of Eq. 5.3), normalized to a
//! PDF, mip-mapped, and sampled by hierarchical warping (§4.1.2, Clarberg et al.) of a randomized
//! Hammersley set. Several lights share the VPL budget in proportion to their brightness (Ch. 6).
//!
//! Gaps filled (spec §4):
//! - VPL flux = Φ_texel / (N_l · p(texel)) (spec §4.6), so that Σ VPL flux is unbiased for the
//!   pVPLs' total flux; for that p must be positive wherever Φ is: `defensive` (default 0.05) mixes
//!   the flux PDF into the contribution PDF. 0 gives the thesis' PDF alone.
//! - The filter smooths the per-unit-flux *receiver factor* and multiplies Φ back afterwards, so
//!   unlit texels (outside a spot's cone) never get a PDF from their lit neighbours.
//! - Per-sample estimate: lum(Φ) · lum(ρ_s)/π · cos_s · cos_pVPL / max(d², clamp²) (both cosines).
//! - Brightness of a light = its emitted power (W, luminance): 4πI point, 2π(1−cos θ_o)I spot,
//!   E·π r² directional over its map's disk, πI area (Lambertian); counts by largest remainder.
//! - The RSM (crates/render/src/rsm.rs) treats an area light as a Lambertian spot from one point
//!   drawn on it per frame (seeded), so the built-in `cornell` works without a punctual light.

use crate::tree::Vpl;
use glimpse_core::sampling::{hammersley, rotate_sample, uniform_sphere};
use glimpse_core::{Rng, Vec2, Vec3, luminance};
use glimpse_render::rsm::{Emission, Projection, Rsm, RsmLight, rsm_lights};
use glimpse_scene::{Camera, SceneFrame};
use glimpse_trace::{ExactTracer, GBuffer};
use rayon::prelude::*;
use std::f32::consts::PI;

/// The binary geometric similarity of Eq. 5.3: normals closer than `n_min` (cosine) and points
/// closer than `d_max` (world units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    pub n_min: f32,
    pub d_max: f32,
}

impl Similarity {
    pub fn similar(&self, p1: Vec3, n1: Vec3, p2: Vec3, n2: Vec3) -> bool {
        n1.dot(n2) > self.n_min && (p1 - p2).length_squared() < self.d_max * self.d_max
    }
}

/// VPL generation settings (defaults: the thesis where it gives a value).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VplParams {
    /// Total VPL count N (a power of two: the tree is perfect). Thesis: 4096.
    pub count: u32,
    /// RSM resolution per light (a power of two for the mip pyramid). Thesis: 512. The largest
    /// with `rsm_per_light`.
    pub rsm_resolution: u32,
    /// Each light's RSM sized by its VPL count ([`rsm_resolution_for`]).
    pub rsm_per_light: bool,
    /// G-buffer samples per pVPL (thesis: "a few"; ours 4).
    pub pvpl_samples: u32,
    /// Unit of the 1/x² sample radius, capped to 1 (thesis: 1 scene unit).
    pub pvpl_radius: f32,
    /// Edge-aware Gaussian: radius (texels) and sigma (texels) [UNSPEC: ours 2 and 1].
    pub filter_radius: u32,
    pub filter_sigma: f32,
    /// Fraction of the flux PDF mixed into the contribution PDF (ours, for unbiased weights).
    pub defensive: f32,
    /// Distance clamp of 1/d² (world units).
    pub clamp: f32,
    /// Edge stop of the filter.
    pub similarity: Similarity,
}

/// The VPLs of one frame.
#[derive(Clone, Debug, Default)]
pub struct VplSet {
    pub vpls: Vec<Vpl>,
    /// VPLs per light (in light order).
    pub per_light: Vec<u32>,
    /// Σ Φ over every pVPL texel of every light that got VPLs (what Σ VPL colour estimates).
    pub pvpl_flux: Vec3,
    /// Bytes of the largest per-light working set (RSM + PDF + mips), constant across lights.
    pub memory_bytes: usize,
}

/// Emitted power (luminance, W) of an RSM light: its share of the VPL budget.
pub fn light_power(light: &RsmLight) -> f32 {
    match (light.emission, light.projection) {
        (Emission::Isotropic(i), _) => 4.0 * PI * luminance(i),
        (Emission::Spot { intensity, outer, .. }, _) => 2.0 * PI * (1.0 - outer.cos()) * luminance(intensity),
        (Emission::Lambertian(i), _) => PI * luminance(i),
        (Emission::Directional(e), Projection::Orthographic { half_extent }) => luminance(e) * PI * half_extent * half_extent,
        (Emission::Directional(e), _) => luminance(e),
    }
}

/// Splits `total` over weights by largest remainder (Σ = total; all to the first when Σw = 0).
pub fn allocate(total: u32, weights: &[f32]) -> Vec<u32> {
    let sum: f32 = weights.iter().map(|w| w.max(0.0)).sum();
    if weights.is_empty() {
        return Vec::new();
    }
    if sum <= 0.0 {
        let mut v = vec![0; weights.len()];
        v[0] = total;
        return v;
    }
    let exact: Vec<f64> = weights.iter().map(|w| total as f64 * w.max(0.0) as f64 / sum as f64).collect();
    let mut n: Vec<u32> = exact.iter().map(|e| e.floor() as u32).collect();
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by(|&a, &b| (exact[b] - exact[b].floor()).total_cmp(&(exact[a] - exact[a].floor())).then(a.cmp(&b)));
    let mut left = total - n.iter().sum::<u32>();
    for &i in order.iter().cycle() {
        if left == 0 {
            break;
        }
        n[i] += 1;
        left -= 1;
    }
    n
}

/// World points to the pixels they project to (the inverse of [`Camera::ray`]), with the
/// camera's frame and scales computed once: the pVPL estimate projects four points per RSM
/// texel, a million per frame, and the camera's basis (two normalized cross products and a
/// tangent) cost as much as the projection itself.
pub struct Projector {
    position: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// tan(fov_y / 2) · aspect and tan(fov_y / 2), divided by (not multiplied by reciprocals:
    /// the pixels, and so the VPLs, stay those of the per-point projection).
    extent: Vec2,
    width: u32,
    height: u32,
}

impl Projector {
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let forward = (camera.target - camera.position).normalize();
        let right = forward.cross(camera.up).normalize();
        let up = right.cross(forward);
        let tan_half = (camera.fov_y(width, height) * 0.5).tan();
        let aspect = width as f32 / height as f32;
        let extent = Vec2::new(tan_half * aspect, tan_half);
        Self { position: camera.position, forward, right, up, extent, width, height }
    }

    /// The pixel `p` projects to, if on screen.
    pub fn pixel(&self, p: Vec3) -> Option<usize> {
        let d = p - self.position;
        let z = d.dot(self.forward);
        if z <= 1e-6 {
            return None;
        }
        let sx = d.dot(self.right) / z / self.extent.x;
        let sy = d.dot(self.up) / z / self.extent.y;
        let px = (sx + 1.0) * 0.5 * self.width as f32;
        let py = (1.0 - sy) * 0.5 * self.height as f32;
        if px < 0.0 || py < 0.0 || px >= self.width as f32 || py >= self.height as f32 {
            return None;
        }
        Some(py as usize * self.width as usize + px as usize)
    }
}

/// A radius with density ∝ min(1, 1/r²) on [0, ∞) (unit 1): uniform on [0,1] with probability
/// ½, else 1/(2(1−u)).
pub fn capped_inverse_square(u: f32) -> f32 {
    if u < 0.5 { 2.0 * u } else { 1.0 / (2.0 * (1.0 - u)).max(1e-6) }
}

/// Expected contribution per unit flux of every texel of `rsm` (before filtering): the mean over
/// `samples` G-buffer surfaces, no occlusion.
pub fn receiver_factor(rsm: &Rsm, gbuffer: &GBuffer, params: &VplParams, rng_seed: u64) -> Vec<f32> {
    let clamp2 = params.clamp * params.clamp;
    let projector = Projector::new(&gbuffer.camera, gbuffer.width, gbuffer.height);
    (0..rsm.len())
        .into_par_iter()
        .map(|i| {
            if rsm.flux[i].max_element() <= 0.0 || params.pvpl_samples == 0 {
                return 0.0;
            }
            let mut rng = Rng::new(rng_seed, i as u64);
            let (y, ny) = (rsm.position[i], rsm.normal[i]);
            let mut sum = 0.0;
            for _ in 0..params.pvpl_samples {
                let dir = uniform_sphere(rng.next_2d());
                let r = capped_inverse_square(rng.next_f32()) * params.pvpl_radius;
                let Some(px) = projector.pixel(y + dir * r) else {
                    continue;
                };
                if !gbuffer.is_hit(px) {
                    continue;
                }
                let to = y - gbuffer.position[px];
                let d2 = to.length_squared();
                let w = to / d2.sqrt().max(1e-12);
                let cos_s = gbuffer.normal[px].dot(w).max(0.0);
                let cos_v = ny.dot(-w).max(0.0);
                sum += luminance(gbuffer.albedo[px]) / PI * cos_s * cos_v / d2.max(clamp2);
            }
            sum / params.pvpl_samples as f32
        })
        .collect()
}

/// Edge-aware Gaussian over an `r×r` map: weights g(Δ) · S(texel, neighbour), only between
/// texels that see geometry; normalized by the weight sum (a constant stays constant).
#[allow(clippy::too_many_arguments)]
pub fn edge_aware_filter(
    values: &[f32],
    position: &[Vec3],
    normal: &[Vec3],
    valid: &[bool],
    r: u32,
    radius: u32,
    sigma: f32,
    sim: Similarity,
) -> Vec<f32> {
    let rad = radius as i32;
    let g: Vec<f32> = (-rad..=rad).map(|d| (-(d * d) as f32 / (2.0 * sigma * sigma).max(1e-12)).exp()).collect();
    (0..values.len())
        .into_par_iter()
        .map(|i| {
            if !valid[i] {
                return 0.0;
            }
            let (x, y) = ((i as u32 % r) as i32, (i as u32 / r) as i32);
            let (mut acc, mut wsum) = (0.0f32, 0.0f32);
            for dy in -rad..=rad {
                let yy = y + dy;
                if yy < 0 || yy >= r as i32 {
                    continue;
                }
                for dx in -rad..=rad {
                    let xx = x + dx;
                    if xx < 0 || xx >= r as i32 {
                        continue;
                    }
                    let j = (yy as u32 * r + xx as u32) as usize;
                    if !valid[j] || (j != i && !sim.similar(position[i], normal[i], position[j], normal[j])) {
                        continue;
                    }
                    let w = g[(dx + rad) as usize] * g[(dy + rad) as usize];
                    acc += w * values[j];
                    wsum += w;
                }
            }
            if wsum > 0.0 { acc / wsum } else { 0.0 }
        })
        .collect()
}

/// Mip pyramid of a `2^L × 2^L` map: `mips[l]` is `2^l × 2^l`, each texel the sum of its four
/// children; `mips[0][0]` is the total.
pub fn mip_pyramid(pdf: &[f32], r: u32) -> Vec<Vec<f32>> {
    let levels = r.trailing_zeros() as usize;
    let mut mips = vec![Vec::new(); levels + 1];
    mips[levels] = pdf.to_vec();
    for l in (0..levels).rev() {
        let rl = 1usize << l;
        let fine = &mips[l + 1];
        let coarse: Vec<f32> = (0..rl * rl)
            .into_par_iter()
            .map(|i| {
                let (x, y) = (i % rl, i / rl);
                let rf = 2 * rl;
                fine[2 * y * rf + 2 * x]
                    + fine[2 * y * rf + 2 * x + 1]
                    + fine[(2 * y + 1) * rf + 2 * x]
                    + fine[(2 * y + 1) * rf + 2 * x + 1]
            })
            .collect();
        mips[l] = coarse;
    }
    mips
}

/// Hierarchical warping (Clarberg et al.; thesis §4.1.2): from the 1×1 level down, a vertical
/// then a horizontal pass choose the child quadrant of the current texel by its share, rescaling
/// `u`. Returns the finest texel (x, y).
pub fn warp(mips: &[Vec<f32>], mut u: Vec2) -> (u32, u32) {
    const ONE_MINUS: f32 = 1.0 - f32::EPSILON / 2.0;
    let (mut ix, mut iy) = (0usize, 0usize);
    for (l, m) in mips.iter().enumerate().skip(1) {
        let r = 1usize << l;
        let a = |x: usize, y: usize| m[y * r + x];
        let (a00, a10, a01, a11) = (a(2 * ix, 2 * iy), a(2 * ix + 1, 2 * iy), a(2 * ix, 2 * iy + 1), a(2 * ix + 1, 2 * iy + 1));
        let total = a00 + a10 + a01 + a11;
        let p_row0 = if total > 0.0 { (a00 + a10) / total } else { 0.5 };
        let row = if u.y < p_row0 {
            u.y /= p_row0;
            0
        } else {
            u.y = (u.y - p_row0) / (1.0 - p_row0);
            1
        };
        let (left, right) = if row == 0 { (a00, a10) } else { (a01, a11) };
        let p_col0 = if left + right > 0.0 { left / (left + right) } else { 0.5 };
        let col = if u.x < p_col0 {
            u.x /= p_col0;
            0
        } else {
            u.x = (u.x - p_col0) / (1.0 - p_col0);
            1
        };
        u = u.clamp(Vec2::ZERO, Vec2::splat(ONE_MINUS));
        ix = 2 * ix + col;
        iy = 2 * iy + row;
    }
    (ix as u32, iy as u32)
}

/// `n` randomized Hammersley points: the set rotated (Cranley-Patterson) by `shift`.
pub fn randomized_hammersley(n: u32, shift: Vec2) -> Vec<Vec2> {
    (0..n).map(|i| rotate_sample(hammersley(i, n), shift)).collect()
}

/// The normalized selection PDF of one RSM (Σ = 1), and whether any texel has flux.
pub fn selection_pdf(rsm: &Rsm, gbuffer: &GBuffer, params: &VplParams, rng_seed: u64) -> Vec<f32> {
    let r = rsm.resolution;
    let factor = receiver_factor(rsm, gbuffer, params, rng_seed);
    let valid: Vec<bool> = rsm.depth.par_iter().map(|d| d.is_finite()).collect();
    let filtered =
        edge_aware_filter(&factor, &rsm.position, &rsm.normal, &valid, r, params.filter_radius, params.filter_sigma, params.similarity);
    let contrib: Vec<f32> = filtered.par_iter().zip(&rsm.flux).map(|(f, phi)| f * luminance(*phi).max(0.0)).collect();
    let flux: Vec<f32> = rsm.flux.par_iter().map(|phi| luminance(*phi).max(0.0)).collect();
    // Summed in order (a parallel sum's grouping would change the PDF's last bits).
    let (sc, sf) = (contrib.iter().map(|&v| v as f64).sum::<f64>(), flux.iter().map(|&v| v as f64).sum::<f64>());
    let eps = if sc > 0.0 { params.defensive as f64 } else { 1.0 };
    contrib
        .par_iter()
        .zip(&flux)
        .map(|(&c, &f)| {
            let a = if sc > 0.0 { (1.0 - eps) * c as f64 / sc } else { 0.0 };
            let b = if sf > 0.0 { eps * f as f64 / sf } else { 0.0 };
            (a + b) as f32
        })
        .collect()
}

/// RSM texels per VPL in the thesis' setting: one 512² map for 4,096 VPLs.
pub const RSM_TEXELS_PER_VPL: f64 = 64.0;

/// The RSM resolution of a light that gets `vpls` VPLs: [`RSM_TEXELS_PER_VPL`] texels per VPL,
/// as a power of two between 16 and `max` (a light's PDF is then as finely resolved per VPL as
/// the thesis' one light's, whatever the number of lights).
pub fn rsm_resolution_for(vpls: u32, max: u32) -> u32 {
    let side = (RSM_TEXELS_PER_VPL * vpls as f64).sqrt().ceil() as u32;
    side.next_power_of_two().clamp(16.min(max), max)
}

/// Generates this frame's VPLs: per light (one at a time: constant memory), RSM → PDF → mips →
/// warped randomized Hammersley points → VPLs with flux Φ/(N_l p). Seeded by `seed` and
/// `frame_index` only, so every technique of one command sees the same VPLs.
pub fn generate(frame: &SceneFrame, tracer: &ExactTracer, gbuffer: &GBuffer, params: &VplParams, seed: u64, frame_index: u32) -> VplSet {
    let mut rng = Rng::new(seed ^ 0x7670_6c73, frame_index as u64);
    let lights = rsm_lights(frame, &mut rng);
    let counts = allocate(params.count, &lights.iter().map(light_power).collect::<Vec<_>>());
    let mut set = VplSet { per_light: counts.clone(), ..Default::default() };
    for (li, (light, &n_l)) in lights.iter().zip(&counts).enumerate() {
        let jitter = rng.next_2d() - Vec2::splat(0.5);
        let shift = rng.next_2d();
        let light_seed = rng.next_u32() as u64 | ((li as u64) << 32);
        if n_l == 0 {
            continue;
        }
        let r = if params.rsm_per_light { rsm_resolution_for(n_l, params.rsm_resolution) } else { params.rsm_resolution };
        let rsm = Rsm::build(frame, tracer, light, r, jitter);
        let pdf = selection_pdf(&rsm, gbuffer, params, light_seed);
        let mips = mip_pyramid(&pdf, r);
        set.memory_bytes = set.memory_bytes.max(rsm.memory_bytes() + pdf.len() * 4 * 2 + mips.iter().map(|m| m.len() * 4).sum::<usize>());
        set.pvpl_flux += rsm.total_flux();
        let points = randomized_hammersley(n_l, shift);
        let vpls: Vec<Vpl> = points
            .par_iter()
            .map(|&u| {
                let (x, y) = warp(&mips, u);
                let t = (y * r + x) as usize;
                let p = pdf[t];
                let color = if p > 0.0 { rsm.flux[t] / (n_l as f32 * p) } else { Vec3::ZERO };
                Vpl { pos: rsm.position[t], normal: rsm.normal[t], color, error_scale: rsm.error_scale[t] }
            })
            .collect();
        set.vpls.extend(vpls);
    }
    // A scene whose lights all got no VPLs still gives a (black) perfect tree.
    set.vpls.resize(params.count as usize, Vpl { pos: frame.bounds.center(), normal: Vec3::Y, color: Vec3::ZERO, error_scale: 0.0 });
    set
}

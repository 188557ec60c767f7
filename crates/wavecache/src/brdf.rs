//! BRDF precomputation (paper Sec. 4.2 "Precomputation", Sec. 6 "BRDFs precomputation", Sec. 5.2
//! runtime lookup): for each glossy material, ω_o on a uniform-hemisphere grid (cos θ_o × φ_o,
//! the paper's "172×1080"), one half-cube map of the BRDF × cosine over ω_i per ω_o, stratified
//! over each texel, Haar-transformed and pruned (β by roughness), fp16. At runtime the four
//! neighbouring ω_o trees are blended bilinearly (φ wraps, cos θ clamps).
//!
//! The BRDF is the path tracer's (`glimpse_render::bsdf`, glTF metallic-roughness: Lambert under
//! a dielectric layer + GGX with α = roughness², Smith height-correlated G, Schlick F), so the
//! cache shades the same material as the ground truth. Texel value (spec §5.5, the ΔΩ moved to
//! the BRDF side): N² ∫_texel f cos dω, so that with radiance texels holding the mean radiance the
//! tree product is Σ_q L_q ∫_q f cos dω whatever the two resolutions.
//! Textured base colours are not grouped (the paper's alpha-channel groups): a glossy material is
//! tabulated with its base-colour factor only (a documented gap).

use crate::haar::{self, HaarNode, TreeRef};
use crate::halfcube::HalfCube;
use bytemuck::{Pod, Zeroable};
use glimpse_core::{Vec2, Vec3};
use glimpse_render::bsdf::{BrdfModel, Bsdf};
use glimpse_scene::MaterialModel;
use rayon::prelude::*;
use std::f32::consts::{PI, TAU};

/// Where a material's trees sit in the shared arrays.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BrdfTable {
    pub n_u1: u32,
    pub n_u2: u32,
    /// Half-cube resolution N.
    pub res: u32,
    /// Index of the tree of grid node (0, 0) in the tree array; node (i, j) is `first_tree + i·n_u2 + j`.
    pub first_tree: u32,
}

/// The ω_o grid node directions: cos θ = (i + ½)/n_u1, φ = 2π (j + ½)/n_u2.
pub fn grid_direction(i: u32, j: u32, n_u1: u32, n_u2: u32) -> Vec3 {
    let cos = (i as f32 + 0.5) / n_u1 as f32;
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let phi = TAU * (j as f32 + 0.5) / n_u2 as f32;
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// The inverse uniform-hemisphere map: (u1, u2) = (cos θ, φ / 2π) ∈ [0,1]².
pub fn inverse_uniform_hemisphere(wo: Vec3) -> Vec2 {
    let mut u2 = wo.y.atan2(wo.x) / TAU;
    if u2 < 0.0 {
        u2 += 1.0;
    }
    Vec2::new(wo.z.clamp(0.0, 1.0), u2.min(1.0))
}

/// The four grid nodes around `wo` (local, z > 0) with their bilinear weights.
pub fn bilinear(wo: Vec3, n_u1: u32, n_u2: u32) -> [(u32, u32, f32); 4] {
    let u = inverse_uniform_hemisphere(wo);
    let gi = (u.x * n_u1 as f32 - 0.5).clamp(0.0, (n_u1 - 1) as f32);
    let gj = u.y * n_u2 as f32 - 0.5;
    let i0 = (gi.floor() as u32).min(n_u1 - 1);
    let i1 = (i0 + 1).min(n_u1 - 1);
    let fi = gi - i0 as f32;
    let gj_floor = gj.floor();
    let fj = gj - gj_floor;
    let j0 = (gj_floor as i64).rem_euclid(n_u2 as i64) as u32;
    let j1 = (j0 + 1) % n_u2;
    [(i0, j0, (1.0 - fi) * (1.0 - fj)), (i0, j1, (1.0 - fi) * fj), (i1, j0, fi * (1.0 - fj)), (i1, j1, fi * fj)]
}

/// The material as the tables see it: the integrator's BRDF model and the material's own
/// (a conductor's GGX lobe with its complex Fresnel term, a Lambertian `diffuse`), as `pt`
/// shades it ([`Bsdf::for_material`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialBrdf {
    pub model: BrdfModel,
    pub material: MaterialModel,
    pub base: Vec3,
    pub metallic: f32,
    pub roughness: f32,
}

impl MaterialBrdf {
    /// The glTF metallic-roughness BRDF of `base`, `metallic`, `roughness`.
    pub fn pbr(base: Vec3, metallic: f32, roughness: f32) -> Self {
        Self { model: BrdfModel::Pbr, material: MaterialModel::Pbr, base, metallic, roughness }
    }

    /// The BRDF at ω_o in the local frame (z = normal).
    fn bsdf(&self, wo: Vec3) -> Option<Bsdf> {
        Bsdf::for_material(self.model, self.material, self.base, self.metallic, self.roughness, Vec3::Z, Vec3::Z, wo)
    }

    /// f(ω_i, ω_o) in the local frame (z = normal).
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        self.bsdf(wo).map_or(Vec3::ZERO, |b| b.eval_local(wi))
    }
}

/// The N×N texel image N² ∫_texel f(ω, wo) cos dω of one ω_o, `strata`² stratified samples per
/// texel (uniform over the texel's face area, weighted by the cube Jacobian).
pub fn brdf_image(m: &MaterialBrdf, wo: Vec3, res: u32, strata: u32) -> Vec<[f64; 3]> {
    let h = HalfCube::new(res);
    let bsdf = m.bsdf(wo);
    let s2 = (strata * strata) as f32;
    let mut img = vec![[0.0f64; 3]; h.texels()];
    let Some(bsdf) = bsdf else {
        return img;
    };
    for y in 0..res {
        for x in 0..res {
            let mut sum = Vec3::ZERO;
            for a in 0..strata {
                for b in 0..strata {
                    let f = Vec2::new((a as f32 + 0.5) / strata as f32, (b as f32 + 0.5) / strata as f32);
                    let uv = h.uv(x, y, f);
                    let Some(wi) = HalfCube::direction(uv) else {
                        continue;
                    };
                    sum += bsdf.eval_local(wi) * (wi.z * HalfCube::jacobian(uv));
                }
            }
            // N² × (texel area (4/N)² / S) × Σ f cos J.
            let v = sum * (16.0 / s2);
            img[(y * res + x) as usize] = [v.x as f64, v.y as f64, v.z as f64];
        }
    }
    img
}

/// The paper's BRDF β: 0.2 when roughness > 0.2, else 0.1 (Sec. 4.2).
pub fn paper_brdf_beta(roughness: f32) -> f64 {
    if roughness > 0.2 { 0.2 } else { 0.1 }
}

/// Tabulates one material: n_u1 × n_u2 trees appended to `nodes`/`trees`, in parallel over ω_o.
#[allow(clippy::too_many_arguments)]
pub fn tabulate(
    m: &MaterialBrdf,
    n_u1: u32,
    n_u2: u32,
    res: u32,
    strata: u32,
    beta_rel: f64,
    nodes: &mut Vec<HaarNode>,
    trees: &mut Vec<TreeRef>,
    tick: &(dyn Fn(u64) + Sync),
) -> BrdfTable {
    let first_tree = trees.len() as u32;
    let per: Vec<(Vec<HaarNode>, TreeRef)> = (0..n_u1 * n_u2)
        .into_par_iter()
        .map(|k| {
            let wo = grid_direction(k / n_u2, k % n_u2, n_u1, n_u2);
            let img = brdf_image(m, wo, res, strata);
            let mut local = Vec::new();
            let t = haar::build(&img, res, beta_rel, &mut local);
            tick(1);
            (local, t)
        })
        .collect();
    for (local, mut t) in per {
        t.first = nodes.len() as u32;
        nodes.extend_from_slice(&local);
        trees.push(t);
    }
    BrdfTable { n_u1, n_u2, res, first_tree }
}

/// Directional albedos for the irradiance (diffuse) path: A_d(cos θ_o) of the diffuse lobe with
/// base colour 1 and A_s(cos θ_o) of the specular lobe, in `bins` bins of cos θ_o, so that
/// L_o = E (base A_d + A_s) / π is exact under uniform incident radiance (Eq. 19 for a
/// Lambertian material: A_d = 1, A_s = 0).
pub fn albedo_table(model: BrdfModel, roughness: f32, bins: u32, samples: u32) -> Vec<[f32; 2]> {
    (0..bins)
        .map(|b| {
            let cos = (b as f32 + 0.5) / bins as f32;
            let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
            let white = Bsdf::new(model, Vec3::ONE, 0.0, roughness, Vec3::Z, Vec3::Z, wo);
            let black = Bsdf::new(model, Vec3::ZERO, 0.0, roughness, Vec3::Z, Vec3::Z, wo);
            let (Some(white), Some(black)) = (white, black) else {
                return [0.0, 0.0];
            };
            let (mut ad, mut as_) = (0.0f64, 0.0f64);
            let k = samples.max(1);
            for i in 0..k {
                for j in 0..k {
                    let u = Vec2::new((i as f32 + 0.5) / k as f32, (j as f32 + 0.5) / k as f32);
                    let wi = glimpse_core::sampling::cosine_hemisphere(u);
                    // f cos / pdf with pdf = cos/π.
                    let fs = black.eval_local(wi).x;
                    let fd = white.eval_local(wi).x - fs;
                    ad += (fd * PI) as f64;
                    as_ += (fs * PI) as f64;
                }
            }
            let n = (k * k) as f64;
            [(ad / n) as f32, (as_ / n) as f32]
        })
        .collect()
}

/// Linear lookup in an albedo table.
pub fn albedo_lookup(table: &[[f32; 2]], cos: f32) -> [f32; 2] {
    let n = table.len();
    if n == 0 {
        return [1.0, 0.0];
    }
    let g = (cos.clamp(0.0, 1.0) * n as f32 - 0.5).clamp(0.0, (n - 1) as f32);
    let i0 = g.floor() as usize;
    let i1 = (i0 + 1).min(n - 1);
    let f = g - i0 as f32;
    [table[i0][0] * (1.0 - f) + table[i1][0] * f, table[i0][1] * (1.0 - f) + table[i1][1] * f]
}

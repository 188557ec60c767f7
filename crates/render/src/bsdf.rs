//! The path tracer's BRDF: glTF 2.0's metallic-roughness model (spec Appendix B), reflection
//! only, two-sided.
//!
//! f(ωo, ωi) = (1 − metallic) · (1 − F_d(ωo·h)) · base/π  +  F(ωo·h) · D(h) · G₂(ωo, ωi) / (4 cos θo cos θi)
//!
//! - F is Schlick's with F0 = lerp(0.04, base, metallic); F_d is Schlick's with F0 = 0.04 (the
//!   dielectric layer that the diffuse base sits under), h the half vector;
//! - D is GGX (Trowbridge-Reitz) with α = roughness², clamped below at [`MIN_ALPHA`] (a mirror is
//!   a very sharp GGX lobe rather than a delta, so every lobe can be evaluated and MIS applies);
//! - G₂ is Smith's height-correlated masking-shadowing 1/(1 + Λ(ωo) + Λ(ωi)) (Heitz 2014);
//! - sampling: the specular lobe by GGX's distribution of visible normals (Heitz 2018, "Sampling
//!   the GGX Distribution of Visible Normals"), pdf = G₁(ωo) D(h) / (4 cos θo); the diffuse lobe
//!   cosine-weighted. The lobe is chosen with probability P_spec ∝ lum(F(cos θo)) against
//!   lum((1 − metallic) base) · (1 − F_d(cos θo)) (the Fresnel-weighted albedos at normal
//!   reflection), clamped to [0.1, 0.9]; the returned pdf is the mixture
//!   P_spec pdf_spec + (1 − P_spec) pdf_diffuse (one-sample MIS over the lobes, balance
//!   heuristic), so any lobe choice is unbiased.
//!
//! [`BrdfModel::Lambert`] replaces all of this by base/π (to compare with the Lambertian
//! references). Shading normals: if ωo lies below the shading normal the geometric normal is
//! used; ωi below either the shading or the geometric surface reflects nothing.

use glimpse_core::sampling::cosine_hemisphere;
use glimpse_core::{Frame, Vec2, Vec3, luminance};
use glimpse_scene::{BumpShadowing, MaterialModel};
use std::f32::consts::PI;

/// Smallest GGX α (roughness 0 becomes this).
pub const MIN_ALPHA: f32 = 1e-3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BrdfModel {
    /// glTF metallic-roughness: diffuse + GGX.
    Pbr,
    /// base/π only, whatever the material says.
    Lambert,
}

/// A BRDF sample: unit world direction, f (without the cosine), the solid-angle pdf and the
/// shading cosine of `wi`.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub f: Vec3,
    pub pdf: f32,
    pub cos: f32,
}

#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    frame: Frame,
    ng: Vec3,
    /// ωo in the shading frame (z > 0).
    wo: Vec3,
    diffuse: Vec3,
    f0: Vec3,
    alpha: f32,
    p_spec: f32,
    model: BrdfModel,
    /// A conductor's complex IOR (η, k) per channel: `None` for the metallic-roughness model.
    conductor: Option<(Vec3, Vec3)>,
    /// Light arriving at a bent normal, shadowed where its format's renderer does so
    /// ([`Bsdf::with_bump_shadowing`]).
    bump_shadowing: Option<BumpShadowing>,
}

impl Bsdf {
    /// At a surface with unit shading normal `ns` and geometric normal `ng` (both facing `wo`),
    /// seen from unit direction `wo` (pointing away from the surface). `None` at a grazing view
    /// that the geometric normal does not face (reflects nothing).
    pub fn new(model: BrdfModel, base: Vec3, metallic: f32, roughness: f32, ns: Vec3, ng: Vec3, wo: Vec3) -> Option<Bsdf> {
        if ng.dot(wo) <= 0.0 {
            return None;
        }
        let ns = if ns.dot(wo) > 0.0 { ns } else { ng };
        let frame = Frame::from_z(ns);
        let wo_l = frame.to_local(wo);
        if wo_l.z <= 0.0 {
            return None;
        }
        let metallic = metallic.clamp(0.0, 1.0);
        let alpha = (roughness * roughness).max(MIN_ALPHA);
        let (diffuse, f0, p_spec) = match model {
            BrdfModel::Lambert => (base, Vec3::ZERO, 0.0),
            BrdfModel::Pbr => {
                let diffuse = base * (1.0 - metallic);
                let f0 = Vec3::splat(0.04).lerp(base, metallic);
                let ws = luminance(schlick(f0, wo_l.z));
                let wd = luminance(diffuse) * (1.0 - schlick1(0.04, wo_l.z));
                let p = if ws + wd > 0.0 { ws / (ws + wd) } else { 0.5 };
                (diffuse, f0, p.clamp(0.1, 0.9))
            }
        };
        Some(Bsdf { frame, ng, wo: wo_l, diffuse, f0, alpha, p_spec, model, conductor: None, bump_shadowing: None })
    }

    /// The BRDF of a material of model `material` (not `Dielectric`, whose lobes are deltas the
    /// path tracer handles itself): `Diffuse` is [`BrdfModel::Lambert`]; `Conductor` is the
    /// GGX lobe alone with F = base × [`fresnel_conductor`]; `integrator` = Lambert overrides all.
    #[allow(clippy::too_many_arguments)]
    pub fn for_material(
        integrator: BrdfModel,
        material: MaterialModel,
        base: Vec3,
        metallic: f32,
        roughness: f32,
        ns: Vec3,
        ng: Vec3,
        wo: Vec3,
    ) -> Option<Bsdf> {
        match (integrator, material) {
            (BrdfModel::Lambert, _) | (_, MaterialModel::Diffuse) => Bsdf::new(BrdfModel::Lambert, base, 0.0, 1.0, ns, ng, wo),
            (_, MaterialModel::Conductor { eta, k }) => {
                let mut b = Bsdf::new(BrdfModel::Pbr, base, 1.0, roughness, ns, ng, wo)?;
                b.conductor = Some((eta, k));
                b.diffuse = Vec3::ZERO;
                b.p_spec = 1.0;
                Some(b)
            }
            _ => Bsdf::new(integrator, base, metallic, roughness, ns, ng, wo),
        }
    }

    /// The same BSDF with its light shadowed by the bend of a normal map
    /// ([`BumpShadowing`]: f × its factor, in [`Bsdf::eval`] and [`Bsdf::sample`]; the density
    /// is the unshadowed lobe's, as Mitsuba's `normalmap` has it).
    pub fn with_bump_shadowing(mut self, shadowing: Option<BumpShadowing>) -> Self {
        self.bump_shadowing = shadowing;
        self
    }

    /// The share of light from `wi` that the bump shadowing lets through (1 without it).
    fn shadowing(&self, wi: Vec3) -> f32 {
        self.bump_shadowing.map_or(1.0, |s| s.factor(wi))
    }

    /// The specular layer's Fresnel term at cos θ = ωo·h.
    fn fresnel(&self, cos: f32) -> Vec3 {
        match self.conductor {
            Some((eta, k)) => self.f0 * fresnel_conductor(cos, eta, k),
            None => schlick(self.f0, cos),
        }
    }

    /// The shading cosine of unit world direction `wi` (0 below either surface).
    pub fn cos(&self, wi: Vec3) -> f32 {
        if self.ng.dot(wi) <= 0.0 { 0.0 } else { self.frame.z.dot(wi).max(0.0) }
    }

    /// f(ωo, ωi) for unit world direction `wi`.
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        if self.ng.dot(wi) <= 0.0 { Vec3::ZERO } else { self.eval_local(self.frame.to_local(wi)) * self.shadowing(wi) }
    }

    /// Solid-angle density with which [`Bsdf::sample`] returns `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if self.ng.dot(wi) <= 0.0 { 0.0 } else { self.pdf_local(self.frame.to_local(wi)) }
    }

    /// Samples ωi: `u_lobe` picks the lobe, `u` the direction in it. `None` when the sample
    /// reflects nothing (below the surface).
    pub fn sample(&self, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let wi_l = if u_lobe < self.p_spec {
            let m = sample_vndf(self.wo, self.alpha, u);
            reflect(self.wo, m)
        } else {
            cosine_hemisphere(u)
        };
        if wi_l.z <= 0.0 {
            return None;
        }
        let wi = self.frame.to_world(wi_l).normalize();
        let cos = self.cos(wi);
        if cos <= 0.0 {
            return None;
        }
        let pdf = self.pdf_local(wi_l);
        let f = self.eval_local(wi_l) * self.shadowing(wi);
        (pdf > 0.0 && f.max_element() > 0.0).then_some(BsdfSample { wi, f, pdf, cos })
    }

    /// f in the shading frame (no geometric-normal test).
    pub fn eval_local(&self, wi: Vec3) -> Vec3 {
        let wo = self.wo;
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        if self.model == BrdfModel::Lambert {
            return self.diffuse / PI;
        }
        let h = (wo + wi).normalize();
        let c = wo.dot(h).clamp(0.0, 1.0);
        let diffuse = self.diffuse * ((1.0 - schlick1(0.04, c)) / PI);
        let g2 = 1.0 / (1.0 + lambda(wo, self.alpha) + lambda(wi, self.alpha));
        let spec = self.fresnel(c) * (ggx_d(h, self.alpha) * g2 / (4.0 * wo.z * wi.z));
        diffuse + spec
    }

    /// The sampling density in the shading frame.
    pub fn pdf_local(&self, wi: Vec3) -> f32 {
        let wo = self.wo;
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let p_diffuse = wi.z / PI;
        if self.model == BrdfModel::Lambert {
            return p_diffuse;
        }
        let h = (wo + wi).normalize();
        let g1 = 1.0 / (1.0 + lambda(wo, self.alpha));
        let p_spec = g1 * ggx_d(h, self.alpha) / (4.0 * wo.z);
        self.p_spec * p_spec + (1.0 - self.p_spec) * p_diffuse
    }
}

/// The exact Fresnel reflectance of a conductor with complex IOR η + ik (per channel) at
/// cos θ (pbrt-v4's FrComplex). η = 0, k = 1 reflects everything at every angle.
pub fn fresnel_conductor(cos: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let one = |eta: f32, k: f32| -> f32 {
        // Complex arithmetic on (re, im) pairs.
        let mul = |a: (f32, f32), b: (f32, f32)| (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0);
        let div = |a: (f32, f32), b: (f32, f32)| {
            let d = b.0 * b.0 + b.1 * b.1;
            ((a.0 * b.0 + a.1 * b.1) / d, (a.1 * b.0 - a.0 * b.1) / d)
        };
        let sqrt = |a: (f32, f32)| {
            let r = (a.0 * a.0 + a.1 * a.1).sqrt();
            let re = ((r + a.0) * 0.5).max(0.0).sqrt();
            let im = ((r - a.0) * 0.5).max(0.0).sqrt();
            (re, if a.1 < 0.0 { -im } else { im })
        };
        let norm = |a: (f32, f32)| a.0 * a.0 + a.1 * a.1;
        if eta == 0.0 && k == 0.0 {
            return 1.0;
        }
        let c = cos.clamp(0.0, 1.0);
        let e = (eta, k);
        let sin2_t = div((1.0 - c * c, 0.0), mul(e, e));
        let cos_t = sqrt((1.0 - sin2_t.0, -sin2_t.1));
        let ec = (e.0 * c, e.1 * c);
        let r_parl = div((ec.0 - cos_t.0, ec.1 - cos_t.1), (ec.0 + cos_t.0, ec.1 + cos_t.1));
        let ect = mul(e, cos_t);
        let r_perp = div((c - ect.0, -ect.1), (c + ect.0, ect.1));
        (0.5 * (norm(r_parl) + norm(r_perp))).clamp(0.0, 1.0)
    };
    Vec3::new(one(eta.x, k.x), one(eta.y, k.y), one(eta.z, k.z))
}

/// One of smooth glass's two delta lobes for `wo` (unit, away from the surface) at its unit
/// normal `n` (facing `wo`), picked by `u` ∈ [0, 1): reflection with probability F (weight
/// `base`·F/F), else refraction (weight `base`/η², radiance compressed by the change of solid
/// angle, pbrt-v4's radiance transport). `front_face`: `wo` is on the side the winding faces,
/// outside a glass of relative index `ior`. Returns (direction, weight).
pub fn sample_smooth_glass(wo: Vec3, n: Vec3, front_face: bool, ior: f32, base: Vec3, u: f32) -> (Vec3, Vec3) {
    let eta = if front_face { ior } else { 1.0 / ior };
    let f = fresnel_dielectric(n.dot(wo), eta);
    match if u < f { None } else { refract(wo, n, eta) } {
        Some(t) => (t, base / (eta * eta)),
        None => ((2.0 * n.dot(wo) * n - wo).normalize(), base),
    }
}

/// The exact Fresnel reflectance of a smooth dielectric boundary at cos θi (> 0, on the side
/// of the incident light) with relative IOR `eta` = η_transmitted / η_incident (pbrt-v4's
/// FrDielectric); 1 under total internal reflection.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    let c = cos_i.clamp(0.0, 1.0);
    let sin2_t = (1.0 - c * c) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let r_parl = (eta * c - cos_t) / (eta * c + cos_t);
    let r_perp = (c - eta * cos_t) / (c + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// `wo` (unit, on `n`'s side, n·wo = `cos_i` > 0) refracted through a boundary of relative IOR
/// `eta`; `None` under total internal reflection.
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = n.dot(wo);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wo / eta + n * (cos_i / eta - cos_t)).normalize())
}

/// Schlick's Fresnel, per channel.
pub fn schlick(f0: Vec3, cos: f32) -> Vec3 {
    f0 + (Vec3::ONE - f0) * (1.0 - cos).clamp(0.0, 1.0).powi(5)
}

fn schlick1(f0: f32, cos: f32) -> f32 {
    f0 + (1.0 - f0) * (1.0 - cos).clamp(0.0, 1.0).powi(5)
}

/// GGX normal distribution of microfacet normal `m` (local frame, unit).
pub fn ggx_d(m: Vec3, alpha: f32) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let a2 = alpha * alpha;
    let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
    1.0 / (PI * a2 * t * t)
}

/// Smith's Λ for GGX: G₁ = 1/(1 + Λ).
pub fn lambda(w: Vec3, alpha: f32) -> f32 {
    let z2 = w.z * w.z;
    if z2 <= 0.0 {
        return f32::INFINITY;
    }
    let tan2 = (w.x * w.x + w.y * w.y) / z2;
    0.5 * ((1.0 + alpha * alpha * tan2).sqrt() - 1.0)
}

/// A microfacet normal from GGX's distribution of normals visible from `wo` (Heitz 2018,
/// listing 1, isotropic α).
pub fn sample_vndf(wo: Vec3, alpha: f32, u: Vec2) -> Vec3 {
    let vh = Vec3::new(alpha * wo.x, alpha * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { Vec3::X };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = t1 * p1 + t2 * p2 + vh * (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    Vec3::new(alpha * nh.x, alpha * nh.y, nh.z.max(0.0)).normalize()
}

/// `wo` mirrored about `m`.
pub fn reflect(wo: Vec3, m: Vec3) -> Vec3 {
    m * (2.0 * wo.dot(m)) - wo
}

#[cfg(test)]
mod tests {
    use super::*;
    use glimpse_core::Rng;
    use glimpse_core::sampling::uniform_hemisphere;

    fn local(model: BrdfModel, base: Vec3, metallic: f32, roughness: f32, theta_o: f32) -> Bsdf {
        let wo = Vec3::new(theta_o.sin(), 0.0, theta_o.cos());
        Bsdf::new(model, base, metallic, roughness, Vec3::Z, Vec3::Z, wo).unwrap()
    }

    const CASES: &[(f32, f32, f32)] =
        &[(0.0, 1.0, 0.2), (0.0, 0.5, 1.1), (1.0, 0.3, 0.7), (1.0, 0.05, 1.3), (0.5, 0.6, 0.0), (0.0, 0.0, 0.9)];

    #[test]
    fn sampling_matches_pdf_and_albedo() {
        // For each material: (1) E_sample[f cos / pdf] (importance) = E_uniform[f cos 2π];
        // (2) the sampled pdf equals pdf(wi); (3) the pdf integrates to at most 1 (the VNDF
        // lobe may reflect below the horizon) and near 1 for rough lobes.
        let base = Vec3::new(0.9, 0.6, 0.3);
        for &(metallic, roughness, theta) in CASES {
            let b = local(BrdfModel::Pbr, base, metallic, roughness, theta);
            let mut rng = Rng::new(11, 0);
            let n = 400_000;
            let (mut imp, mut uni, mut pdf_int) = (0.0f64, 0.0f64, 0.0f64);
            let mut mismatches = 0;
            for _ in 0..n {
                if let Some(s) = b.sample(rng.next_f32(), rng.next_2d()) {
                    imp += (luminance(s.f) * s.cos / s.pdf) as f64;
                    mismatches += ((b.pdf(s.wi) - s.pdf).abs() > 1e-3 * s.pdf) as u32;
                }
                let w = uniform_hemisphere(rng.next_2d());
                uni += (luminance(b.eval_local(w)) * w.z * 2.0 * PI) as f64;
                pdf_int += (b.pdf_local(w) * 2.0 * PI) as f64;
            }
            let (imp, uni, pdf_int) = (imp / n as f64, uni / n as f64, pdf_int / n as f64);
            println!(
                "metallic {metallic} roughness {roughness} θo {theta}: albedo importance {imp:.4} uniform {uni:.4}, ∫pdf {pdf_int:.4}"
            );
            assert_eq!(mismatches, 0);
            assert!(imp <= 1.0 + 1e-3, "energy");
            // Uniform sampling of a sharp lobe is noisy: compare only where it is reliable.
            if roughness >= 0.3 {
                assert!((imp - uni).abs() < 0.02 * uni.max(0.05), "{imp} vs {uni}");
                assert!(pdf_int <= 1.02 && pdf_int > 0.8, "{pdf_int}");
            }
        }
    }

    #[test]
    fn reciprocal_and_lambert() {
        let mut rng = Rng::new(3, 0);
        for &(metallic, roughness, _) in CASES {
            for _ in 0..1000 {
                let (a, c) = (uniform_hemisphere(rng.next_2d()), uniform_hemisphere(rng.next_2d()));
                let ba = Bsdf::new(BrdfModel::Pbr, Vec3::splat(0.7), metallic, roughness, Vec3::Z, Vec3::Z, a).unwrap();
                let bc = Bsdf::new(BrdfModel::Pbr, Vec3::splat(0.7), metallic, roughness, Vec3::Z, Vec3::Z, c).unwrap();
                let (x, y) = (ba.eval(c), bc.eval(a));
                assert!((x - y).abs().max_element() <= 1e-4 * x.max_element().max(1.0), "{x} vs {y}");
            }
        }
        let l = local(BrdfModel::Lambert, Vec3::splat(0.5), 1.0, 0.1, 0.4);
        assert_eq!(l.eval_local(Vec3::Z), Vec3::splat(0.5 / PI));
        assert!((l.pdf_local(Vec3::Z) - 1.0 / PI).abs() < 1e-6);
    }

    #[test]
    fn fresnel_known_values() {
        // Normal incidence: ((η−1)/(η+1))² for glass, ((η−1)² + k²)/((η+1)² + k²) for a metal.
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.1, 1.0 / 1.5), 1.0, "total internal reflection");
        let f = fresnel_conductor(1.0, Vec3::splat(0.2), Vec3::splat(3.9)).x;
        assert!((f - (0.64 + 15.21) / (1.44 + 15.21)).abs() < 1e-5, "{f}");
        for c in [0.0f32, 0.3, 1.0] {
            assert!((fresnel_conductor(c, Vec3::ZERO, Vec3::ONE) - Vec3::ONE).abs().max_element() < 1e-6);
            // A conductor with k = 0 is a dielectric.
            assert!((fresnel_conductor(c.max(0.05), Vec3::splat(1.5), Vec3::ZERO).x - fresnel_dielectric(c.max(0.05), 1.5)).abs() < 1e-5);
        }
        // Snell's law.
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let t = refract(wo, Vec3::Z, 1.5).unwrap();
        assert!((0.6 - 1.5 * (t.x * t.x + t.y * t.y).sqrt()).abs() < 1e-5 && t.z < 0.0);
    }

    #[test]
    fn smooth_white_metal_reflects_almost_everything() {
        // F = 1, nearly no masking: the directional albedo is ~1 (the white furnace).
        for theta in [0.0f32, 0.6, 1.2] {
            let b = local(BrdfModel::Pbr, Vec3::ONE, 1.0, 0.1, theta);
            let mut rng = Rng::new(5, 0);
            let n = 100_000;
            let (mut sum, mut sum2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let x = b.sample(rng.next_f32(), rng.next_2d()).map_or(0.0, |s| (s.f.x * s.cos / s.pdf) as f64);
                sum += x;
                sum2 += x * x;
            }
            let a = sum / n as f64;
            let se = ((sum2 / n as f64 - a * a) / n as f64).sqrt();
            println!("white metal, roughness 0.1, θo {theta}: albedo {a:.5} ± {se:.5}");
            assert!(a > 0.97 && a < 1.0 + 3.0 * se, "a single-scattering BRDF cannot reflect more than it receives");
        }
    }
}

//! The point-sample half of CS4 (§3.2.2, Eq. 1, Eq. 2, Figs. 9–10): how many samples each
//! triangle gets, how the work of large triangles is split, and where each sample lies.
//!
//! - Eq. (1): `N(T_k) = ⌈N_P · A(T_k) / Σ A⌉` (the paper's ceiling; `round` is Xu et al.'s).
//!   Ours, `cumulative`: `round(N_P S_{k+1} / Σ A) − round(N_P S_k / Σ A)` from the exclusive
//!   prefix sums S_k, i.e. the rounded running total. Every triangle gets ⌊x⌋ or ⌈x⌉ of its share
//!   x, the total is N_P, and a run of tiny triangles gets one sample per unit of share, where
//!   `round` gives each of them none.
//! - Eq. (2) (Osada et al.): `P = (1−√r1) A + √r1 (1−r2) B + √r1 r2 C`.
//! - (r1, r2) from `hashwithoutsine33` (Jarzynski and Olano's port of Dave Hoskins' hash), seeded
//!   from the triangle's vertex indices, or from the triangle's own N(T_k)-point Hammersley set
//!   `(i/N, Φ₂(i))` (the paper's two variants).
//!
//! Gaps filled (the paper does not say): the hash seed is `(i0, i1, i2) + (i+1)·(7.31, 3.17,
//! 5.13)` for sample i; a triangle's samples are split into tasks of at most `task_points`
//! (the paper's illustration uses 3) without rounding the count up; each sample's global id is
//! `⌊N_P · S_k / Σ A⌋ + k + i` from the exclusive prefix sum S_k (the ids of different triangles
//! never collide because ⌈x⌉ ≤ ⌊x⌋ + 1), and it keys the sample's random ray rotation.

use glimpse_core::{Vec2, Vec3};
use rayon::prelude::*;

/// Eq. (1)'s rounding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rounding {
    /// The paper's: at least one sample on every triangle of non-zero area.
    Ceil,
    /// Xu et al.'s: tiny triangles may get none.
    Round,
    /// Ours: the rounded running total (module doc). Used when triangles outnumber samples:
    /// `round` starves a finely tessellated mesh (15 Stanford bunnies at N_P = 10,000 kept 6,270
    /// samples, almost none on the bunnies), the ceiling would give it one per triangle.
    Cumulative,
}

/// Where (r1, r2) of Eq. (2) come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointSampling {
    Hash,
    Hammersley,
}

/// Eq. (1) for a triangle of `area` whose exclusive area prefix sum is `span[0]` and the next
/// triangle's is `span[1]` (the total for the last one; only `cumulative` reads the span).
pub fn sample_count(points: u32, area: f32, span: [f32; 2], total_area: f32, rounding: Rounding) -> u32 {
    if total_area <= 0.0 || area <= 0.0 {
        return 0;
    }
    let share = |a: f32| points as f64 * a as f64 / total_area as f64;
    (match rounding {
        Rounding::Ceil => share(area).ceil(),
        Rounding::Round => share(area).round(),
        // From the scan's own sums, not S_k + A_k: the counts then telescope to N_P exactly,
        // even where the f32 prefix cannot resolve a tiny triangle (it gets 0, a later one 1).
        Rounding::Cumulative => (share(span[1]).round() - share(span[0]).round()).max(0.0),
    }) as u32
}

/// Eq. (1) for every triangle (in parallel), from the areas and their exclusive prefix sums.
pub fn sample_counts(points: u32, areas: &[f32], prefix: &[f32], total_area: f32, rounding: Rounding) -> Vec<u32> {
    (0..areas.len())
        .into_par_iter()
        .map(|k| {
            let next = prefix.get(k + 1).copied().unwrap_or(total_area);
            sample_count(points, areas[k], [prefix[k], next], total_area, rounding)
        })
        .collect()
}

/// First global sample id of triangle k from its exclusive area prefix sum.
pub fn first_sample_id(points: u32, prefix: f32, total_area: f32, k: usize) -> u64 {
    let f = if total_area > 0.0 { (points as f64 * prefix as f64 / total_area as f64).floor() } else { 0.0 };
    f as u64 + k as u64
}

/// Eq. (2).
pub fn point_on_triangle([a, b, c]: [Vec3; 3], r: Vec2) -> Vec3 {
    point_and_error_scale([a, b, c], r).0
}

/// [`point_on_triangle`] and the magnitude its rounding error is relative to
/// ([`glimpse_core::ray::error_scale`]: the offset of the rays leaving it).
pub fn point_and_error_scale(p: [Vec3; 3], r: Vec2) -> (Vec3, f32) {
    let s = r.x.sqrt();
    let w = [1.0 - s, s * (1.0 - r.y), s * r.y];
    (p[0] * w[0] + p[1] * w[1] + p[2] * w[2], glimpse_core::ray::error_scale(&p, w))
}

fn fract(v: Vec3) -> Vec3 {
    v - v.floor()
}

/// `hashwithoutsine33` as in the GLSL source, in f32.
pub fn hash_without_sine33(p: Vec3) -> Vec3 {
    let mut p3 = fract(p * Vec3::new(0.1031, 0.1030, 0.0973));
    p3 += Vec3::splat(p3.dot(Vec3::new(p3.y, p3.x, p3.z) + Vec3::splat(33.33)));
    fract((Vec3::new(p3.x, p3.x, p3.y) + Vec3::new(p3.y, p3.x, p3.x)) * Vec3::new(p3.z, p3.y, p3.x))
}

/// (r1, r2) of sample `i` of `n` on the triangle with vertex indices `tri`.
pub fn sample_uv(sampling: PointSampling, tri: [u32; 3], i: u32, n: u32) -> Vec2 {
    let below_one = |x: f32| x.clamp(0.0, 1.0 - f32::EPSILON / 2.0);
    match sampling {
        PointSampling::Hash => {
            let seed = Vec3::new(tri[0] as f32, tri[1] as f32, tri[2] as f32) + Vec3::new(7.31, 3.17, 5.13) * (i + 1) as f32;
            let h = hash_without_sine33(seed);
            Vec2::new(below_one(h.x), below_one(h.y))
        }
        PointSampling::Hammersley => Vec2::new(i as f32 / n.max(1) as f32, glimpse_core::sampling::radical_inverse_base2(i)),
    }
}

/// One task of CS4: `count` samples of triangle `triangle`, from its sample `first` on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Task {
    pub triangle: u32,
    pub first: u32,
    pub count: u32,
    /// Samples the triangle has in all (N(T_k)).
    pub of: u32,
}

/// Per-triangle sample counts (Eq. 1) and the tasks that cover them.
pub fn tasks(counts: &[u32], task_points: u32) -> Vec<Task> {
    let per = task_points.max(1);
    counts
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, &n)| {
            (0..n.div_ceil(per)).map(move |j| Task { triangle: k as u32, first: j * per, count: per.min(n - j * per), of: n })
        })
        .collect()
}

//! Which of a 4-wide node's children each ray of a packet enters: the box test of
//! [`ExactTracer::occluded_many`](crate::ExactTracer::occluded_many)'s packets.
//!
//! One ray against the node's four boxes ([`Ray4::enter`](crate::tracer)) leaves a 4-bit mask
//! per ray that must be scattered into one ray mask per child: on a packet of coherent shadow
//! rays that scatter and the per-ray loop cost more than the slab tests (62 % of a `vpl-exact`
//! frame on sponza-interior was that loop). With AVX2, eight rays are tested against one box at
//! a time instead, the rays kept as structure-of-arrays, and the compare's sign bits are the ray
//! mask directly, wherever enough of the packet's rays are still together ([`DENSE`]).
//!
//! Both paths make the same decision for every ray and box, bit for bit: the slab test takes
//! each axis's near plane as `min(t₀, t₁)` of the two planes' distances instead of choosing by
//! the direction's sign, which is the same value (rounding is monotonic, and `1/d` is never 0
//! or NaN: [`PreparedRay`] replaces zero components), and then compares `near ≤ far·(1 + 2γ₃)`
//! exactly as the one-ray test does.

use crate::bvh::{Bvh4Node, EMPTY_SLOT, WIDTH};
use crate::tracer::Ray4;
use crate::triangle::PreparedRay;

/// Rays per occupied group of eight from which the eight-wide test is the faster: a group costs
/// the same however few of its rays are asked, and deep nodes are entered by a few rays spread
/// over the groups. `vpl-exact`'s render gi at 96 × 64, interleaved runs: always eight-wide
/// (0) / 2 / 3 / 4 / never: `million-triangles` 1.86–1.89 / 1.74–1.76 / 1.66–1.72 / 1.69–1.75 /
/// 1.83 s, `sponza-interior` 1.47–1.48 / 1.41–1.44 / 1.40 / 1.40–1.43 / 1.89–1.95 s.
const DENSE: u32 = 3;

/// Up to `N` rays (a multiple of 8, at most 64) as structure-of-arrays, plus each one's
/// one-ray form for the fallback.
pub(crate) struct PacketRays<const N: usize> {
    origin: [[f32; N]; 3],
    inv_dir: [[f32; N]; 3],
    t_max: [f32; N],
    one: [Ray4; N],
    avx2: bool,
}

impl<const N: usize> PacketRays<N> {
    /// `rays` (at least one): lanes past them repeat the last ray, never asked about.
    pub(crate) fn new(rays: &[PreparedRay], t_max: impl Fn(usize) -> f32) -> Self {
        const { assert!(N.is_multiple_of(8) && N <= 64) };
        let n = rays.len();
        let ray = |i: usize| &rays[i.min(n - 1)];
        let axis = |f: &dyn Fn(&PreparedRay) -> [f32; 3], a: usize| std::array::from_fn(|i| f(ray(i))[a]);
        let o = |r: &PreparedRay| r.origin.to_array();
        let inv = |r: &PreparedRay| r.inv_dir.to_array();
        Self {
            origin: [axis(&o, 0), axis(&o, 1), axis(&o, 2)],
            inv_dir: [axis(&inv, 0), axis(&inv, 1), axis(&inv, 2)],
            t_max: std::array::from_fn(|i| t_max(i.min(n - 1))),
            one: std::array::from_fn(|i| Ray4::new(ray(i))),
            avx2: avx2_available(),
        }
    }

    pub(crate) fn t_max(&self, r: usize) -> f32 {
        self.t_max[r]
    }

    /// Ray `r` now ends at `t` (a closest-hit query found a hit there).
    pub(crate) fn set_t_max(&mut self, r: usize, t: f32) {
        self.t_max[r] = t;
    }

    /// Per child slot of `node`, the rays of `mask` that enter its box before their `t_max`:
    /// eight at a time where the groups of eight that hold a ray hold [`DENSE`] on average.
    #[inline]
    pub(crate) fn enter(&self, node: &Bvh4Node, mask: u64) -> [u64; WIDTH] {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 && mask.count_ones() >= DENSE * groups(mask) {
            // SAFETY: `avx2` is set only where the CPU has AVX2.
            return unsafe { self.enter_avx2(node, mask) };
        }
        self.enter_one_by_one(node, mask)
    }

    /// Ray by ray, four boxes at a time, scattering each ray's bits into the slots' masks.
    pub(crate) fn enter_one_by_one(&self, node: &Bvh4Node, mask: u64) -> [u64; WIDTH] {
        let mut entered = [0u64; WIDTH];
        let mut bits = mask;
        while bits != 0 {
            let r = bits.trailing_zeros() as usize;
            bits &= bits - 1;
            let (m, _) = self.one[r].enter(node, self.t_max[r]);
            for (slot, e) in entered.iter_mut().enumerate() {
                *e |= (((m >> slot) & 1) as u64) << r;
            }
        }
        entered
    }

    /// Eight rays against one box at a time; groups of eight with no ray in `mask` are skipped.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn enter_avx2(&self, node: &Bvh4Node, mask: u64) -> [u64; WIDTH] {
        use std::arch::x86_64::*;
        let mut entered = [0u64; WIDTH];
        let widen = _mm256_set1_ps(1.0 + 2.0 * crate::tracer::GAMMA3);
        for group in 0..N / 8 {
            let lanes = ((mask >> (8 * group)) & 0xff) as u32;
            if lanes == 0 {
                continue;
            }
            let at = 8 * group;
            // SAFETY (the loads): `at + 8 <= N` for every array read.
            let load = |a: &[f32; N]| unsafe { _mm256_loadu_ps(a.as_ptr().add(at)) };
            let origin = [load(&self.origin[0]), load(&self.origin[1]), load(&self.origin[2])];
            let inv_dir = [load(&self.inv_dir[0]), load(&self.inv_dir[1]), load(&self.inv_dir[2])];
            let t_max = load(&self.t_max);
            for (slot, out) in entered.iter_mut().enumerate() {
                if node.child[slot] == EMPTY_SLOT {
                    continue;
                }
                let mut near = _mm256_setzero_ps();
                let mut far = t_max;
                for axis in 0..3 {
                    let planes = &node.planes[axis];
                    let t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(planes[0][slot]), origin[axis]), inv_dir[axis]);
                    let t1 = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(planes[1][slot]), origin[axis]), inv_dir[axis]);
                    near = _mm256_max_ps(near, _mm256_min_ps(t0, t1));
                    far = _mm256_min_ps(far, _mm256_max_ps(t0, t1));
                }
                let inside = _mm256_cmp_ps::<_CMP_LE_OQ>(near, _mm256_mul_ps(far, widen));
                let hit = _mm256_movemask_ps(inside) as u32 & lanes;
                *out |= (hit as u64) << at;
            }
        }
        entered
    }
}

/// How many of `mask`'s bytes (groups of eight rays) have a ray.
#[inline(always)]
fn groups(mask: u64) -> u32 {
    let mut x = mask;
    x |= x >> 4;
    x |= x >> 2;
    x |= x >> 1;
    (x & 0x0101_0101_0101_0101).count_ones()
}

/// Whether this CPU runs the AVX2 box test (`GLIMPSE_NO_AVX2` set in the environment turns it
/// off, to compare both paths).
fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        static AVX2: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
        *AVX2.get_or_init(|| std::arch::is_x86_feature_detected!("avx2") && std::env::var_os("GLIMPSE_NO_AVX2").is_none())
    }
    #[cfg(not(target_arch = "x86_64"))]
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::{BuildParams, Bvh, Bvh4};
    use glimpse_core::{Aabb, Ray, Rng, Vec3};

    #[test]
    fn groups_count_the_occupied_bytes() {
        assert_eq!(groups(0), 0);
        assert_eq!(groups(1), 1);
        assert_eq!(groups(0x8000_0000_0000_0100), 2);
        assert_eq!(groups(u64::MAX), 8);
    }

    /// Every node of a random tree against packets of coherent and incoherent rays, with random
    /// masks and finite and infinite `t_max`: both paths give the same ray masks.
    #[test]
    fn eight_rays_per_box_decide_as_one_ray_per_node() {
        let mut rng = Rng::new(5, 0);
        let mut p = |s: f32| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * s;
        let boxes: Vec<Aabb> = (0..3000)
            .map(|_| {
                let c = p(10.0);
                Aabb::new(c, c + p(0.5))
            })
            .collect();
        let bvh = Bvh4::from_bvh2(&Bvh::build(&boxes, BuildParams::default()));
        let (mut rng, mut masks) = (Rng::new(6, 0), Rng::new(7, 0));
        let mut p = |s: f32| Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * s;
        let (mut checked, mut entered) = (0u64, 0u64);
        for packet in 0..200 {
            let origin = p(12.0) - Vec3::ONE;
            let target = p(10.0);
            let spread = if packet % 2 == 0 { 0.3 } else { 10.0 };
            let rays: Vec<PreparedRay> = (0..64)
                .map(|i| {
                    // Some rays along an axis, so 1/d holds the replaced zeros.
                    let mut d = target + p(spread) - origin;
                    if i % 16 == 0 {
                        d.y = 0.0;
                    }
                    PreparedRay::new(&Ray::new(origin, d))
                })
                .collect();
            let t_max = |i: usize| if i.is_multiple_of(3) { f32::INFINITY } else { 2.0 + i as f32 * 0.2 };
            let packet_rays = PacketRays::<64>::new(&rays, t_max);
            if !packet_rays.avx2 {
                println!("no AVX2 on this CPU: only the one-ray path runs");
                return;
            }
            let mask = (masks.next_u32() as u64) << 32 | masks.next_u32() as u64;
            for node in &bvh.nodes {
                let by_one = packet_rays.enter_one_by_one(node, mask);
                // SAFETY: checked above that the CPU has AVX2.
                let by_eight = unsafe { packet_rays.enter_avx2(node, mask) };
                assert_eq!(by_one, by_eight, "packet {packet}: the two box tests disagree");
                checked += 1;
                entered += by_one.iter().map(|m| m.count_ones() as u64).sum::<u64>();
            }
        }
        println!("{checked} node tests of 64 rays, {entered} ray-box entries, identical");
        assert!(entered > 10_000);
    }
}

//! The tiled shader of `lights-voxarray` ([`crate::technique`]): one tile of pixels × one light
//! at a time, the tile's GBuffer held in structure-of-arrays form, the shadow segments of eight
//! pixels formed at once with AVX2, then every row load of the tile × light in flight together
//! ([`Array::occluded_rows`]). Buffers are per thread ([`Tile`]), reused from tile to tile: no
//! allocation and no dynamic dispatch per sample.
//!
//! Per light, for each group of eight pixels: the irradiance (`WorldLight::incident`) and the
//! facing test (`Shading::cos`); a group where no pixel faces the light stops there. Otherwise
//! the shadow segments (`direct::punctual` → `direct::segment` with `Ray::spawn`'s offset, then
//! [`Array::surface_segment`]: the far cut and the normal offset) of the pixels that face it are
//! appended, left-packed, to the tile's list. Then pass 1 ([`crate::extent8`]) runs on full
//! lanes of that list and the valid extents' row queries are left-packed (row index computed
//! 8-wide); then every row is prefetched, the compressed array's dictionary entries read and
//! their rows prefetched, the rows tested; then each pixel adds the Lambertian term of the
//! light if no row hit. Every lane performs exactly the scalar code's float operations in the
//! same order (glam's `dot` as `(x·x + y·y) + z·z`, `max_element` as `if a > b { a } else { b }`
//! = `maxps`, Rust's `f32::max`/`min` NaN rules, no FMA), so the segments, the extents, the
//! decisions and the image are bit-identical to the per-sample path (`tests/shade.rs` renders
//! both). Point lights take the AVX2 path; spot and directional lights (and a group with a
//! non-finite distance) form their segments with the scalar code, lane by lane, and share the
//! rest. Without AVX2 (or with `simd=false`, or `GLIMPSE_VOXARRAY_SCALAR=1`) every step is
//! scalar.
//!
//! Tried and not kept: software-pipelining three lights per tile (light `l` formed and its
//! index words prefetched while `l − 1` reads its dictionary entries and `l − 2` tests its rows)
//! gave no measurable change in CPU time.

use crate::batch::LANES;
use crate::query;
use crate::row::Row;
use crate::technique::Refine;
use crate::{Array, extent8};
use glimpse_core::Vec3;
use glimpse_render::direct::{self, Shading};
use glimpse_scene::{LightKind, WorldLight};
use glimpse_trace::GBuffer;

/// Per-thread buffers of one tile, reused from tile to tile.
#[derive(Default)]
pub struct Tile {
    /// Pixel (within the tile) of each slot; slots are the tile's hit pixels, padded to a
    /// multiple of [`LANES`] with copies of the last one (masked off).
    pixel: Vec<usize>,
    shading: Vec<Shading>,
    /// Position, geometric normal and shading normal of each slot, by component.
    p: [Vec<f32>; 3],
    /// Each slot's error scale (the ray offset's, `Shading::error_scale`).
    error_scale: Vec<f32>,
    n: [Vec<f32>; 3],
    sn: [Vec<f32>; 3],
    /// The irradiance summed over the lights so far, by component.
    e: [Vec<f32>; 3],
    /// The current light's irradiance × cosine at each slot (added where not occluded).
    contrib: [Vec<f32>; 3],
    /// Per group of [`LANES`] slots: the lanes that receive the current light (they face it
    /// with some irradiance and are not occluded).
    visible: Vec<u32>,
    /// Per group: the lanes `refine` traced a full exact ray for (scratch for `shade_light`).
    traced: Vec<u32>,
    /// The current light's shadow segments of the slots that face it, packed: start x, y, z,
    /// end x, y, z (pass 1 then runs on full lanes).
    seg: [Vec<f32>; 6],
    /// Slot of each packed segment.
    seg_slot: Vec<u32>,
    segs: usize,
    /// The current light's row queries: row index ([`crate::query::Extent::row_index`]), clip
    /// and slot, `queries` of them (`LANES` spare at the end).
    q_row: Vec<u32>,
    q_s: Vec<u32>,
    q_e: Vec<u32>,
    q_slot: Vec<u32>,
    queries: usize,
    /// Hit pixels (slots before the padding).
    hits: usize,
    /// Occluded answers re-tested by an exact ray (`refine`), summed over the tile's lights.
    pub confirmed: u64,
}

impl Tile {
    /// Loads the GBuffer's pixels `pixels` (the hit ones) and clears the sums.
    pub fn load(&mut self, gbuffer: &GBuffer, pixels: &[usize]) {
        self.pixel.clear();
        self.shading.clear();
        for (k, &i) in pixels.iter().enumerate() {
            if let Some(s) = Shading::from_gbuffer(gbuffer, i) {
                self.pixel.push(k);
                self.shading.push(s);
            }
        }
        self.hits = self.pixel.len();
        if let (Some(&k), Some(&s)) = (self.pixel.last(), self.shading.last()) {
            while !self.pixel.len().is_multiple_of(LANES) {
                self.pixel.push(k);
                self.shading.push(s);
            }
        }
        let slots = self.pixel.len();
        self.error_scale.clear();
        self.error_scale.extend(self.shading.iter().map(|s| s.error_scale));
        for c in 0..3 {
            let get = |v: Vec3| v.to_array()[c];
            for (dst, f) in [(&mut self.p[c], 0), (&mut self.n[c], 1), (&mut self.sn[c], 2)] {
                dst.clear();
                dst.extend(self.shading.iter().map(|s| get([s.position, s.normal, s.shading_normal][f])));
            }
            self.e[c].clear();
            self.e[c].resize(slots, 0.0);
            self.contrib[c].resize(slots, 0.0);
        }
        for v in &mut self.seg {
            v.resize(slots + LANES, 0.0);
        }
        self.seg_slot.resize(slots + LANES, 0);
        for v in [&mut self.q_row, &mut self.q_s, &mut self.q_e, &mut self.q_slot] {
            v.resize(slots + LANES, 0);
        }
        self.visible.clear();
        self.visible.resize(slots / LANES, 0);
    }

    /// Hit pixels of the tile: `(k, shading, summed irradiance)` for the hit `pixels[k]` of
    /// [`Self::load`], by `k`.
    pub fn results(&self) -> impl Iterator<Item = (usize, &Shading, Vec3)> + '_ {
        (0..self.hits).map(|i| (self.pixel[i], &self.shading[i], Vec3::new(self.e[0][i], self.e[1][i], self.e[2][i])))
    }

    /// Adds `light`'s unoccluded Lambertian term to every hit pixel of the tile; returns the
    /// shadow decisions made (the pixels that face the light with some irradiance).
    /// `refine` ([`crate::technique::Refine`]): an occluded answer stands only if the exact
    /// tracer agrees on `lights-exact`'s own shadow ray, and a visible one only if that ray's
    /// first `near` units are clear.
    pub fn shade_light<R: Row>(&mut self, array: &Array<R>, light: &WorldLight, simd: bool, refine: Option<Refine>) -> u64 {
        let simd = simd && extent8::avx2_available();
        let mut decisions = 0u64;
        // The facing test, the contributions and the packed segments, group by group.
        self.segs = 0;
        for g in 0..self.visible.len() {
            let real = lane_mask(self.hits.saturating_sub(g * LANES));
            #[cfg(target_arch = "x86_64")]
            if simd {
                // SAFETY: AVX2 was detected on this CPU.
                if let Some(active) = unsafe { avx2::form(self, array, light, g, real) } {
                    self.visible[g] = active;
                    decisions += active.count_ones() as u64;
                    continue;
                }
            }
            let active = self.form_scalar(array, light, g, real);
            self.visible[g] = active;
            decisions += active.count_ones() as u64;
        }
        // Pass 1 on the packed segments: the extents, the row queries of the valid ones (a
        // segment that covers no voxel is unoccluded).
        assert!(array.row_count() <= u32::MAX as usize, "row indices fit in u32");
        self.queries = 0;
        for at in (0..self.segs).step_by(LANES) {
            let lanes = lane_mask(self.segs - at);
            #[cfg(target_arch = "x86_64")]
            if simd {
                // SAFETY: AVX2 was detected on this CPU.
                unsafe { avx2::queries(self, array, at, lanes) };
                continue;
            }
            for k in 0..LANES {
                if lanes >> k & 1 == 0 {
                    continue;
                }
                let v = |c: usize| Vec3::new(self.seg[c][at + k], self.seg[c + 1][at + k], self.seg[c + 2][at + k]);
                if let Some(x) = query::extent(&array.grid, &array.dirs, v(0), v(3), array.bias_start_cells, array.bias_end_cells) {
                    let q = self.queries;
                    self.q_row[q] = x.row_index(R::BITS) as u32;
                    (self.q_s[q], self.q_e[q], self.q_slot[q]) = (x.s, x.e, self.seg_slot[at + k]);
                    self.queries += 1;
                }
            }
        }
        // Passes 2 and 3: every row load of the tile × light in flight together.
        let (visible, slots, n, shading, confirmed) = (&mut self.visible, &self.q_slot, self.queries, &self.shading, &mut self.confirmed);
        // The lanes whose full exact ray was traced (their near part needs no second look).
        let traced = &mut self.traced;
        traced.clear();
        traced.resize(visible.len(), 0);
        array.occluded_rows(&mut self.q_row[..n], &self.q_s[..n], &self.q_e[..n], |q| {
            let slot = slots[q] as usize;
            if let Some(r) = refine {
                *confirmed += 1;
                traced[slot / LANES] |= 1 << (slot % LANES);
                if !crate::technique::exactly_occluded(r.exact, light, &shading[slot]) {
                    return;
                }
            }
            visible[slot / LANES] &= !(1 << (slot % LANES));
        });
        if let Some(r) = refine.filter(|r| r.near > 0.0) {
            for (g, (lanes, &traced)) in visible.iter_mut().zip(traced.iter()).enumerate() {
                let mut unchecked = *lanes & !traced;
                while unchecked != 0 {
                    let k = unchecked.trailing_zeros() as usize;
                    unchecked &= unchecked - 1;
                    let s = &shading[g * LANES + k];
                    if r.occluded(false, &direct::punctual(light, s.position, s.normal, s.error_scale)) {
                        *lanes &= !(1 << k);
                    }
                }
            }
        }
        // The Lambertian sum.
        for (g, &visible) in self.visible.iter().enumerate() {
            if visible == 0 {
                continue;
            }
            #[cfg(target_arch = "x86_64")]
            if simd {
                // SAFETY: AVX2 was detected on this CPU.
                unsafe { avx2::accumulate(&mut self.e, &self.contrib, g * LANES, visible) };
                continue;
            }
            for k in 0..LANES {
                if visible >> k & 1 != 0 {
                    for c in 0..3 {
                        self.e[c][g * LANES + k] += self.contrib[c][g * LANES + k];
                    }
                }
            }
        }
        decisions
    }

    /// The per-sample path's code for the real lanes of group `g`, lane by lane:
    /// `direct::punctual`, the facing test, the contribution and [`Array::surface_segment`].
    /// Returns the lanes that face the light.
    fn form_scalar<R: Row>(&mut self, array: &Array<R>, light: &WorldLight, g: usize, real: u32) -> u32 {
        let mut active = 0;
        for k in 0..LANES {
            if real >> k & 1 == 0 {
                continue;
            }
            let slot = g * LANES + k;
            let s = &self.shading[slot];
            let ps = direct::punctual(light, s.position, s.normal, s.error_scale);
            let cos = s.cos(ps.wi);
            if cos <= 0.0 || ps.irradiance.max_element() <= 0.0 {
                continue;
            }
            active |= 1 << k;
            let c = ps.irradiance * cos;
            let (a, b) = array.surface_segment(&ps, s.normal);
            for (i, ((a, b), c)) in a.to_array().into_iter().zip(b.to_array()).zip(c.to_array()).enumerate() {
                self.seg[i][self.segs] = a;
                self.seg[i + 3][self.segs] = b;
                self.contrib[i][slot] = c;
            }
            self.seg_slot[self.segs] = slot as u32;
            self.segs += 1;
        }
        active
    }
}

/// Bits `0..n.min(LANES)`.
#[inline]
fn lane_mask(n: usize) -> u32 {
    if n >= LANES { (1 << LANES) - 1 } else { (1 << n) - 1 }
}

/// `PACK[m]`: the lanes set in the mask `m`, in order, then zeros (a left-pack permutation).
#[cfg(target_arch = "x86_64")]
const PACK: [[i32; LANES]; 1 << LANES] = {
    let mut t = [[0; LANES]; 1 << LANES];
    let mut m = 0;
    while m < 1 << LANES {
        let (mut k, mut n) = (0, 0);
        while k < LANES {
            if m >> k & 1 != 0 {
                t[m][n] = k as i32;
                n += 1;
            }
            k += 1;
        }
        m += 1;
    }
    t
};

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::*;
    use crate::extent8::avx2::{V, abs, extents_regs, neg, rmax, rmin, select, splat};
    use std::arch::x86_64::*;

    #[inline]
    #[target_feature(enable = "avx2")]
    fn load(x: &[f32]) -> V {
        assert!(x.len() >= LANES);
        // SAFETY: eight floats are readable at `x`.
        unsafe { _mm256_loadu_ps(x.as_ptr()) }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn store(x: &mut [f32], v: V) {
        assert!(x.len() >= LANES);
        // SAFETY: eight floats are writable at `x`.
        unsafe { _mm256_storeu_ps(x.as_mut_ptr(), v) }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn load_i(x: &[i32; LANES]) -> __m256i {
        // SAFETY: eight i32s are readable at `x`.
        unsafe { _mm256_loadu_si256(x.as_ptr() as *const __m256i) }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn load_u(x: &[u32]) -> __m256i {
        assert!(x.len() >= LANES);
        // SAFETY: eight u32s are readable at `x`.
        unsafe { _mm256_loadu_si256(x.as_ptr() as *const __m256i) }
    }

    #[inline]
    #[target_feature(enable = "avx2")]
    fn store_i(x: &mut [u32], v: __m256i) {
        assert!(x.len() >= LANES);
        // SAFETY: eight u32s are writable at `x`.
        unsafe { _mm256_storeu_si256(x.as_mut_ptr() as *mut __m256i, v) }
    }

    /// glam's `Vec3::dot`: `(x·x' + y·y') + z·z'`.
    #[inline]
    #[target_feature(enable = "avx2")]
    fn dot(a: [V; 3], b: [V; 3]) -> V {
        _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(a[0], b[0]), _mm256_mul_ps(a[1], b[1])), _mm256_mul_ps(a[2], b[2]))
    }

    /// glam's `max_element`: `max(x, max(y, z))` with `if a > b { a } else { b }` (`maxps`).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn max_element(a: [V; 3]) -> V {
        _mm256_max_ps(a[0], _mm256_max_ps(a[1], a[2]))
    }

    /// `if mask { -a } else { a }` per lane (exact: a sign flip).
    #[inline]
    #[target_feature(enable = "avx2")]
    fn flip(mask: V, a: [V; 3]) -> [V; 3] {
        a.map(|x| select(mask, neg(x), x))
    }

    /// Group `g` of a point light: the facing test and irradiance of its eight slots, their
    /// contributions, and the shadow segments of the active ones appended to the packed list.
    /// Returns the active lanes (within `real`), or `None` if the light is not a point light or
    /// a lane's distance is not finite (the caller then runs the scalar formation).
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[target_feature(enable = "avx2")]
    pub unsafe fn form<R: Row>(tile: &mut Tile, array: &Array<R>, light: &WorldLight, g: usize, real: u32) -> Option<u32> {
        if light.kind != LightKind::Point {
            return None;
        }
        let at = g * LANES;
        let zero = _mm256_setzero_ps();
        let p = [0, 1, 2].map(|c| load(&tile.p[c][at..]));
        let n = [0, 1, 2].map(|c| load(&tile.n[c][at..]));
        let lp = [splat(light.position.x), splat(light.position.y), splat(light.position.z)];
        // `WorldLight::incident`: to = L − p, d² = max(|to|², 1e-12), d = √d², wi = to / d, E = I / d².
        let to = [0, 1, 2].map(|c| _mm256_sub_ps(lp[c], p[c]));
        let d2 = rmax(dot(to, to), splat(1e-12));
        let d = _mm256_sqrt_ps(d2);
        // `direct::punctual` takes the segment branch where d is finite: here, every lane.
        if _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(abs(d), splat(f32::INFINITY))) != 0xff {
            return None;
        }
        let wi = to.map(|x| _mm256_div_ps(x, d));
        let irr = [light.intensity.x, light.intensity.y, light.intensity.z].map(|i| _mm256_div_ps(splat(i), d2));
        // `Shading::cos`: 0 where n·wi ≤ 0, else max(sn·wi, 0); no decision where it is 0 or
        // the irradiance's largest component is not positive.
        let sn = [0, 1, 2].map(|c| load(&tile.sn[c][at..]));
        let cos = select(_mm256_cmp_ps::<_CMP_LE_OQ>(dot(n, wi), zero), zero, rmax(dot(sn, wi), zero));
        let skip = _mm256_or_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(cos, zero), _mm256_cmp_ps::<_CMP_LE_OQ>(max_element(irr), zero));
        let active = !(_mm256_movemask_ps(skip) as u32) & real;
        if active == 0 {
            return Some(0);
        }
        for (dst, irr) in tile.contrib.iter_mut().zip(irr) {
            store(&mut dst[at..], _mm256_mul_ps(irr, cos));
        }
        // `direct::segment(p, n, L)`: `Ray::spawn(p, n, L − p).origin`, then the unit direction
        // and the length to L.
        let n1 = flip(_mm256_cmp_ps::<_CMP_LT_OQ>(dot(n, to), zero), n);
        // `offset_origin`: RAY_OFFSET × max(|p|'s largest coordinate, error scale).
        let scale = rmax(max_element(p.map(|x| abs(x))), load(&tile.error_scale[at..]));
        let k = _mm256_mul_ps(splat(glimpse_core::ray::RAY_OFFSET), scale);
        let origin = [0, 1, 2].map(|c| _mm256_add_ps(p[c], _mm256_mul_ps(n1[c], k)));
        let to2 = [0, 1, 2].map(|c| _mm256_sub_ps(lp[c], origin[c]));
        let len = _mm256_sqrt_ps(dot(to2, to2));
        let div = rmax(len, splat(f32::MIN_POSITIVE));
        let dir = to2.map(|x| _mm256_div_ps(x, div));
        // `Array::segment`: the end at min(t_max, |origin − centre| + 0.87·N/scale) along the ray.
        let center = array.grid.center.to_array();
        let oc = [0, 1, 2].map(|c| _mm256_sub_ps(origin[c], splat(center[c])));
        let far = splat(0.87 * array.grid.resolution as f32 / array.grid.scale);
        let t = rmin(len, _mm256_add_ps(_mm256_sqrt_ps(dot(oc, oc)), far));
        let end = [0, 1, 2].map(|c| _mm256_add_ps(origin[c], _mm256_mul_ps(dir[c], t)));
        // `Array::surface_segment`: the start moved along the normal, on the ray's side.
        let n2 = flip(_mm256_cmp_ps::<_CMP_LT_OQ>(dot(n, dir), zero), n);
        let offset = splat(array.normal_offset_cells / array.grid.scale);
        let start = [0, 1, 2].map(|c| _mm256_add_ps(origin[c], _mm256_mul_ps(n2[c], offset)));
        // Append the active lanes, left-packed.
        let pack = load_i(&PACK[active as usize]);
        let m = tile.segs;
        for c in 0..3 {
            store(&mut tile.seg[c][m..], _mm256_permutevar8x32_ps(start[c], pack));
            store(&mut tile.seg[c + 3][m..], _mm256_permutevar8x32_ps(end[c], pack));
        }
        let slots = _mm256_add_epi32(_mm256_set1_epi32(at as i32), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        let packed = _mm256_permutevar8x32_epi32(slots, pack);
        store_i(&mut tile.seg_slot[m..], packed);
        tile.segs += active.count_ones() as usize;
        Some(active)
    }

    /// Pass 1 on the packed segments `at..at + LANES` (those in `lanes`): their extents
    /// ([`extents_regs`]), and the row queries of the valid ones appended, left-packed.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn queries<R: Row>(tile: &mut Tile, array: &Array<R>, at: usize, lanes: u32) {
        let v = |c: usize| load(&tile.seg[c][at..]);
        let (bs, be) = (array.bias_start_cells, array.bias_end_cells);
        // SAFETY: the caller's.
        let x = unsafe { extents_regs(&array.grid, &array.dirs, (v(0), v(1), v(2)), (v(3), v(4), v(5)), bs, be) };
        let valid = x.valid & lanes;
        // `Extent::row_index`: (voxelization · N + y) · N + x, below 2³² (checked by the caller).
        let n = _mm256_set1_epi32(R::BITS as i32);
        let row = _mm256_add_epi32(_mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(x.voxelization, n), x.y), n), x.x);
        let pack = load_i(&PACK[valid as usize]);
        let q = tile.queries;
        store_i(&mut tile.q_row[q..], _mm256_permutevar8x32_epi32(row, pack));
        store_i(&mut tile.q_s[q..], _mm256_permutevar8x32_epi32(x.s, pack));
        store_i(&mut tile.q_e[q..], _mm256_permutevar8x32_epi32(x.e, pack));
        let slot = load_u(&tile.seg_slot[at..]);
        store_i(&mut tile.q_slot[q..], _mm256_permutevar8x32_epi32(slot, pack));
        tile.queries += valid.count_ones() as usize;
    }

    /// `e[c][at + k] += contrib[c][at + k]` for the lanes `k` set in `visible`.
    ///
    /// # Safety
    /// The CPU must support AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub unsafe fn accumulate(e: &mut [Vec<f32>; 3], contrib: &[Vec<f32>; 3], at: usize, visible: u32) {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        let mask = _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(visible as i32), bits), bits));
        for (e, c) in e.iter_mut().zip(contrib) {
            let x = load(&e[at..]);
            store(&mut e[at..], select(mask, _mm256_add_ps(x, load(&c[at..])), x));
        }
    }
}

// CS1, the sample counts, CS4 and CS5 of one frame's field (crates/dvf/src/gpu.rs; the CPU's
// areas.rs, points.rs, field.rs and labels.rs, operation for operation). Appended to trace.wgsl
// (bindings 0, 1, 3: the BVH, its triangles, the traversal's uniform), exact_f64.wgsl and
// exact.wgsl.

struct Build {
    // triangles, N_P, rounding (0 ceil, 1 round, 2 cumulative), sampling (0 hash, 1 Hammersley)
    counts: vec4<u32>,
    // rays per sample, (unused), rotation about the normal, octahedral resolution R
    rays: vec4<u32>,
    // grid dims x, y, z; u32 words per mask
    cells: vec4<u32>,
    // cell count, frame index, (unused), zero (for `no_fold`)
    misc: vec4<u32>,
    // the samples' PCG state (`mix64(seed ^ 0xd1f5eed ^ 0x853c…)`, lo, hi)
    rng: vec4<u32>,
    // grid origin, cell size
    grid: vec4<f32>,
}

@group(0) @binding(6) var<uniform> build: Build;
@group(0) @binding(7) var<storage, read> vertices: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> indices: array<vec4<u32>>;
@group(0) @binding(9) var<storage, read_write> normals: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> areas: array<f32>;
// The area scan's levels (level 0: the areas, then their exclusive prefix sums) and total.
@group(0) @binding(11) var<storage, read_write> area_scan: array<f32>;
@group(0) @binding(12) var<storage, read_write> area_total: array<f32>;
// The sample-count scan's level 0 (counts, then their exclusive prefix: each triangle's first
// sample) and total (samples this frame).
@group(0) @binding(13) var<storage, read_write> count_scan: array<u32>;
@group(0) @binding(14) var<storage, read_write> count_total: array<u32>;
// Per triangle: N(T_k), first global sample id (lo, hi).
@group(0) @binding(15) var<storage, read_write> tri_info: array<vec4<u32>>;
// dispatch_workgroups_indirect arguments of CS4.
@group(0) @binding(16) var<storage, read_write> dispatch: array<u32>;
// Visible words of every cell, then occluded words (u32 halves of the CPU's u64 words).
@group(0) @binding(17) var<storage, read_write> masks: array<atomic<u32>>;
@group(0) @binding(18) var<storage, read_write> labels: array<u32>;
// Debug read-back of the samples (`GpuDvf::samples`): two vec4 per sample.
@group(0) @binding(19) var<storage, read_write> samples_out: array<vec4<u32>>;

fn no_fold() -> u32 {
    return build.misc.w;
}

const WG_1D: u32 = 64u;

fn linear_id(gid: vec3<u32>, groups: vec3<u32>) -> u32 {
    return gid.y * groups.x * WG_1D + gid.x;
}

// ---- CS1 (areas.rs) ------------------------------------------------------------------------

fn triangle_vertex(k: u32, v: u32) -> vec3<f32> {
    return vertices[indices[k][v]].xyz;
}

// `area_and_normal`: ½|(B−A)×(C−A)| and the normal (zero when degenerate), as glam computes them.
@compute @workgroup_size(64)
fn areas_and_normals(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = linear_id(gid, groups);
    if k >= build.counts.x {
        return;
    }
    let a = triangle_vertex(k, 0u);
    let e1 = triangle_vertex(k, 1u) - a;
    let e2 = triangle_vertex(k, 2u) - a;
    let cross = vec3<f32>(
        mx(e1.y, e2.z) - mx(e2.y, e1.z),
        mx(e1.z, e2.x) - mx(e2.z, e1.x),
        mx(e1.x, e2.y) - mx(e2.x, e1.y),
    );
    let len = sqrt_exact(dot_cpu(cross, cross));
    let rcp = div_exact(1.0, len);
    let finite = (bitcast<u32>(rcp) & F32_INF) != F32_INF;
    var n = vec3<f32>(0.0);
    if finite && rcp > 0.0 {
        n = cross * rcp;
    }
    normals[k] = vec4<f32>(n, 0.0);
    areas[k] = 0.5 * len;
    area_scan[k] = 0.5 * len;
}

// ---- Eq. (1) and the sample ids (points.rs) --------------------------------------------------

// Rust's `f64::round` (half away from zero) for x ≥ 0.
fn round_half_away(x: f64) -> f64 {
    let f = floor(x);
    return select(f, f + f64(1.0), x - f >= f64(0.5));
}

// `sample_count` and `first_sample_id` per triangle, in f64 as on the CPU.
@compute @workgroup_size(64)
fn counts(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let k = linear_id(gid, groups);
    if k >= build.counts.x {
        return;
    }
    let total = area_total[0];
    let area = areas[k];
    let points = f64(build.counts.y);
    var count = 0u;
    if !(total <= 0.0 || area <= 0.0) {
        let x = points * f64(area) / f64(total);
        if build.counts.z == 2u {
            // The rounded running total, from the exclusive prefixes S_k and S_{k+1} (points.rs).
            var next = total;
            if k + 1u < build.counts.x {
                next = area_scan[k + 1u];
            }
            let here = round_half_away(points * f64(area_scan[k]) / f64(total));
            count = u32(max(round_half_away(points * f64(next) / f64(total)) - here, f64(0.0)));
        } else {
            count = u32(select(ceil(x), round_half_away(x), build.counts.z == 1u));
        }
    }
    var first = 0u;
    if total > 0.0 {
        first = u32(floor(points * f64(area_scan[k]) / f64(total)));
    }
    let id = add64(vec2<u32>(first, 0u), vec2<u32>(k, 0u));
    tri_info[k] = vec4<u32>(count, id.x, id.y, 0u);
    count_scan[k] = count;
}

// CS4's indirect dispatch: one invocation per sample, 64 per workgroup, rows of at most the
// device's workgroups per dimension (`build.misc.z`).
@compute @workgroup_size(1)
fn dispatch_args() {
    let groups = (count_total[0] + WG_1D - 1u) / WG_1D;
    let gx = min(groups, build.misc.z);
    var gy = 0u;
    if gx > 0u {
        gy = (groups + gx - 1u) / gx;
    }
    dispatch[0] = gx;
    dispatch[1] = gy;
    dispatch[2] = 1u;
}

// ---- CS4: point samples (points.rs, field.rs) ------------------------------------------------

fn fract_cpu(v: vec3<f32>) -> vec3<f32> {
    return v - floor(v);
}

fn mxv(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(a * b) | vec3<u32>(no_fold()));
}

// `hash_without_sine33`.
fn hash33(p: vec3<f32>) -> vec3<f32> {
    var p3 = fract_cpu(mxv(p, HASH_SCALE));
    let d = dot_cpu(p3, vec3<f32>(p3.y, p3.x, p3.z) + vec3<f32>(HASH_ADD));
    p3 = p3 + vec3<f32>(d);
    return fract_cpu(mxv(vec3<f32>(p3.x, p3.x, p3.y) + vec3<f32>(p3.y, p3.x, p3.x), vec3<f32>(p3.z, p3.y, p3.x)));
}

// `sample_uv`: (r1, r2) of sample i of n on the triangle with vertex indices `tri`.
fn sample_uv(tri: vec3<u32>, i: u32, n: u32) -> vec2<f32> {
    if build.counts.w == 1u {
        return vec2<f32>(div_exact(f32(i), f32(max(n, 1u))), radical_inverse(i));
    }
    let seed = vec3<f32>(f32(tri.x), f32(tri.y), f32(tri.z)) + mx3(HASH_STEP, f32(i + 1u));
    let h = hash33(seed);
    return vec2<f32>(clamp(h.x, 0.0, BELOW_ONE), clamp(h.y, 0.0, BELOW_ONE));
}

// `Grid::cell_of`.
fn cell_of(p: vec3<f32>) -> u32 {
    let rel = p - build.grid.xyz;
    let q = floor(vec3<f32>(div_exact(rel.x, build.grid.w), div_exact(rel.y, build.grid.w), div_exact(rel.z, build.grid.w)));
    let dims = build.cells.xyz;
    let c = vec3<u32>(min(to_u32_sat(q.x), dims.x - 1u), min(to_u32_sat(q.y), dims.y - 1u), min(to_u32_sat(q.z), dims.z - 1u));
    return (c.z * dims.y + c.y) * dims.x + c.x;
}

struct Sample {
    position: vec3<f32>,
    // `PointSample::error_scale` (the ray offset's scale).
    error_scale: f32,
    normal: vec3<f32>,
    shift: vec2<f32>,
    cell: u32,
    triangle: u32,
    index: u32,
}

// The triangle holding global sample s: the last k whose first sample is ≤ s.
fn triangle_of(s: u32) -> u32 {
    var lo = 0u;
    var hi = build.counts.x;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if count_scan[mid] <= s {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    return lo;
}

// `field::point_sample` of global sample s.
fn point_sample(s: u32) -> Sample {
    let k = triangle_of(s);
    let info = tri_info[k];
    let i = s - count_scan[k];
    let tri = indices[k].xyz;
    let r = sample_uv(tri, i, info.x);
    // `point_and_error_scale` (Eq. 2; `ray::error_scale`).
    let root = sqrt_exact(r.x);
    let a = vertices[tri.x].xyz;
    let b = vertices[tri.y].xyz;
    let c = vertices[tri.z].xyz;
    let w = vec3<f32>(1.0 - root, root * (1.0 - r.y), root * r.y);
    let position = (mx3(a, w.x) + mx3(b, w.y)) + mx3(c, w.z);
    let e = (abs(mx3(a, w.x)) + abs(mx3(b, w.y))) + abs(mx3(c, w.z));
    let error_scale = max(max(e.x, e.y), e.z);
    // Rng::new(seed ^ 0xd1f5eed, mix64(first_id + i) ^ frame_index).next_2d()
    let stream = mix64(add64(info.yz, vec2<u32>(i, 0u))) ^ vec2<u32>(build.misc.y, 0u);
    var rng = pcg_new(build.rng.xy, stream);
    let shift = pcg_next_2d(&rng);
    return Sample(position, error_scale, normals[k].xyz, shift, cell_of(position), k, i);
}

// The samples of this frame, for comparison with the CPU's (two vec4<u32> each).
@compute @workgroup_size(64)
fn samples(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = linear_id(gid, groups);
    if s >= count_total[0] {
        return;
    }
    let p = point_sample(s);
    samples_out[2u * s] = vec4<u32>(bitcast<vec3<u32>>(p.position), p.cell);
    samples_out[2u * s + 1u] = vec4<u32>(bitcast<vec2<u32>>(p.shift), p.triangle, p.index);
}

// CS4 proper: each sample's N_r rays (and its back hemisphere's where `sides` asks), traced
// exactly, OR-ed into the cell's maps: a hit sets the occlusion bit, a miss the visibility bit.
@compute @workgroup_size(64)
fn field(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let s = linear_id(gid, groups);
    if s >= count_total[0] {
        return;
    }
    let p = point_sample(s);
    let r = build.rays.w;
    let words = build.cells.w;
    let occluded_base = build.misc.x * words;
    // The index's w: whether this triangle's samples also trace the back hemisphere (`sides`).
    let sides = 1u + indices[p.triangle].w;
    for (var side = 0u; side < sides; side++) {
        let n = select(p.normal, -p.normal, side == 1u);
        let rs = ray_set(n, build.rays.x, p.shift, build.rays.z == 1u);
        let origin = offset_origin(p.position, n, p.error_scale);
        for (var k = 0u; k < build.rays.x; k++) {
            let d = ray_direction(rs, k);
            if !(dot_cpu(n, d) > 0.0) {
                continue;
            }
            let hit = occluded_from(origin, d);
            let pixel = octahedral_pixel(d, r);
            let word = select(0u, occluded_base, hit) + p.cell * words + pixel / 32u;
            atomicOr(&masks[word], 1u << (pixel % 32u));
        }
    }
}

// ---- CS5 (labels.rs) -------------------------------------------------------------------------

// `l_occ = 1` iff the occlusion map has more pixels set than the visibility map.
@compute @workgroup_size(64)
fn occlusion_labels(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let c = linear_id(gid, groups);
    if c >= build.misc.x {
        return;
    }
    let words = build.cells.w;
    let occluded_base = build.misc.x * words;
    var n_vis = 0u;
    var n_occ = 0u;
    for (var w = 0u; w < words; w++) {
        n_vis += countOneBits(atomicLoad(&masks[c * words + w]));
        n_occ += countOneBits(atomicLoad(&masks[occluded_base + c * words + w]));
    }
    labels[c] = select(0u, 1u, n_occ > n_vis);
}

// Alg. 3 (`Intersect`) on the GPU: one invocation per segment (start, end), the decisions of
// `Array::occluded_segment` (query.rs, directions.rs, voxelize.rs `Grid::to_cells_ij`,
// glimpse-core `fast_math`) ported operation for operation, in the same operand order:
// DiscretizeDirection (line 1), both ends rotated into voxelization (i, j) with the CPU's
// cos/sin table, the midpoint row (line 3), the biased extent clipped to the row (line 4), the
// row fetched (through the dictionary when compressed) and masked to bits s..=e (lines 5–7).
//
// `gpu.rs` prepends a generated header: `RowT` (u32, vec2<u32> or vec4<u32> for 32-, 64- or
// 128-bit rows) and `row_words` (the row as four u32 words, LSB first), `COMPRESSED`, the chunk
// bindings with `load_row`/`load_index_word` (big arrays are split over several bindings), and
// `div_rn`/`sqrt_rn` (correctly rounded through f64 when the device has SHADER_F64, as the CPU's
// IEEE division and square root; plain WGSL `/` and `sqrt`, 2.5 ulp, otherwise).
//
// Not ported: non-finite inputs (WGSL may treat inf/NaN arithmetic loosely); callers send
// finite segments. Flushed subnormals may differ from the CPU for lengths below ~1e-19.

struct Params {
    count: u32,
    n_dirs: u32,
    resolution: u32,
    index_bits: u32,
    cx: f32,
    cy: f32,
    cz: f32,
    scale: f32,
    nf: f32,
    half_n: f32,
    bias_start: f32,
    bias_end: f32,
    // `nf - 1e-3` as the CPU computes it.
    hi_cap: f32,
    // π / n.
    step: f32,
    row_shift: u32,
    word_shift: u32,
    // 0, unknown to the compiler: see `mul`.
    zero: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<uniform> P: Params;
// (cos, sin) of angle index k·180°/n: `Directions::cos_sin`.
@group(0) @binding(1) var<storage, read> cos_sin: array<vec2<f32>>;
// Segment k: start at 2k (xyz), end at 2k + 1.
@group(0) @binding(2) var<storage, read> segments: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> occluded: array<u32>;

fn f32_bits(b: u32) -> f32 {
    return bitcast<f32>(b);
}

// a·b where the CPU rounds the product before adding it. Drivers contract `a * b + c` into a
// fused multiply-add and factor `a·x + b·x` (Mesa's NIR does both for lavapipe on an FMA CPU;
// GPU compilers contract too); passing the product through an integer XOR with a uniform 0
// hides it from every floating-point rewrite, so the sum rounds as the CPU's.
fn mul(a: f32, b: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(a * b) ^ P.zero);
}

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// glimpse_core::fast_math::atan_unit, coefficients as the CPU's f32 bits.
fn atan_unit(x: f32) -> f32 {
    let c0 = f32_bits(C0);
    let c1 = f32_bits(C1);
    let c2 = f32_bits(C2);
    let c3 = f32_bits(C3);
    let c4 = f32_bits(C4);
    let c5 = f32_bits(C5);
    let x2 = x * x;
    return x * (c0 + mul(x2, c1 + mul(x2, c2 + mul(x2, c3 + mul(x2, c4 + mul(x2, c5))))));
}

// fast_math::atan2.
fn atan2_fast(y: f32, x: f32) -> f32 {
    let ax = abs(x);
    let ay = abs(y);
    let lo = min(ax, ay);
    let hi = max(ax, ay);
    var a = 0.0;
    if hi > 0.0 {
        a = atan_unit(div_rn(lo, hi));
    }
    if ay > ax {
        a = f32_bits(FRAC_PI_2) - a;
    }
    if x < 0.0 {
        a = f32_bits(PI) - a;
    }
    if y < 0.0 {
        a = -a;
    }
    return a;
}

// fast_math::asin (inputs are finite, so the clamp matches Rust's).
fn asin_fast(y_in: f32) -> f32 {
    let y = clamp(y_in, -1.0, 1.0);
    return atan2_fast(y, sqrt_rn(max(1.0 - mul(y, y), 0.0)));
}

// directions::discretize.
fn discretize(d_in: vec3<f32>) -> vec2<u32> {
    let n = i32(P.n_dirs);
    // glam's normalize_or(Z): 1 / length, fallback unless finite and positive.
    let dot = mul(d_in.x, d_in.x) + mul(d_in.y, d_in.y) + mul(d_in.z, d_in.z);
    let len = sqrt_rn(dot);
    var d = vec3<f32>(0.0, 0.0, 1.0);
    if len > 0.0 && is_finite(len) {
        let rcp = div_rn(1.0, len);
        if is_finite(rcp) && rcp > 0.0 {
            d = vec3<f32>(d_in.x * rcp, d_in.y * rcp, d_in.z * rcp);
        }
    }
    if d.y < 0.0 {
        d = -d;
    }
    let pi = f32_bits(PI);
    var phi = asin_fast(d.y);
    var theta = atan2_fast(-d.x, d.z);
    if theta < 0.0 {
        theta = theta + pi;
        phi = pi - phi;
    }
    if theta >= pi {
        theta = theta - pi;
        phi = pi - phi;
    }
    var i = i32(div_rn(theta, P.step) + 0.5);
    var j = i32(div_rn(phi, P.step) + 0.5);
    if i >= n {
        i = 0;
        j = n - j;
    }
    j = ((j % n) + n) % n;
    return vec2<u32>(u32(i), u32(j));
}

// Grid::to_cells_ij: (p − c)·scale, Directions::rotate, + N/2.
fn to_cells(i: u32, j: u32, p: vec3<f32>) -> vec3<f32> {
    let vx = (p.x - P.cx) * P.scale;
    let vy = (p.y - P.cy) * P.scale;
    let vz = (p.z - P.cz) * P.scale;
    let t = cos_sin[i];
    let f = cos_sin[j];
    let ct = t.x;
    let st = t.y;
    let cp = f.x;
    let sp = f.y;
    let ux = mul(ct, vx) + mul(st, vz);
    let uz = mul(-st, vx) + mul(ct, vz);
    let ry = mul(cp, vy) - mul(sp, uz);
    let rz = mul(sp, vy) + mul(cp, uz);
    return vec3<f32>(ux + P.half_n, ry + P.half_n, rz + P.half_n);
}

// Bits a..=b of a 32-bit word (a ≤ b < 32), as `Row::mask`.
fn mask32(a: u32, b: u32) -> u32 {
    return (0xffffffffu >> (31u - (b - a))) << a;
}

// query::clip_hits on a row given as four LSB-first words.
fn clip_hits(w: vec4<u32>, s: u32, e: u32) -> bool {
    var hit = 0u;
    for (var k = 0u; k < 4u; k = k + 1u) {
        let lo = max(s, 32u * k);
        let hi = min(e, 32u * k + 31u);
        if lo <= hi {
            hit = hit | (w[k] & mask32(lo - 32u * k, hi - 32u * k));
        }
    }
    return hit != 0u;
}

// Compressed::index: `index_bits` bits at bit `row · index_bits` of the packed words (LSB
// first; the CPU's u64 words are pairs of u32 words, low first).
fn packed_index(row: u32) -> u32 {
    let pos = row * P.index_bits;
    let w = pos >> 5u;
    let off = pos & 31u;
    var v = load_index_word(w) >> off;
    if off > 0u {
        v = v | (load_index_word(w + 1u) << (32u - off));
    }
    if P.index_bits < 32u {
        v = v & ((1u << P.index_bits) - 1u);
    }
    return v;
}

fn occluded_segment(start: vec3<f32>, end: vec3<f32>) -> bool {
    let ij = discretize(end - start);
    let q0 = to_cells(ij.x, ij.y, start);
    let q1 = to_cells(ij.x, ij.y, end);
    let mx = (q0.x + q1.x) * 0.5;
    let my = (q0.y + q1.y) * 0.5;
    if !(mx >= 0.0 && mx < P.nf && my >= 0.0 && my < P.nf) {
        return false;
    }
    var lo: f32;
    var hi: f32;
    if q0.z <= q1.z {
        lo = q0.z + P.bias_start;
        hi = q1.z - P.bias_end;
    } else {
        lo = q1.z + P.bias_end;
        hi = q0.z - P.bias_start;
    }
    // Rust's f32::max/min: a NaN operand gives the other one.
    if !(lo > 0.0) {
        lo = 0.0;
    }
    if !(hi < P.hi_cap) {
        hi = P.hi_cap;
    }
    if lo > hi {
        return false;
    }
    let s = u32(lo);
    let e = u32(hi);
    let voxelization = ij.x * P.n_dirs + ij.y;
    let row = (voxelization * P.resolution + u32(my)) * P.resolution + u32(mx);
    var entry = row;
    if COMPRESSED {
        entry = packed_index(row);
    }
    return clip_hits(row_words(load_row(entry)), s, e);
}

@compute @workgroup_size(64)
fn query(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= P.count {
        return;
    }
    let a = segments[2u * k].xyz;
    let b = segments[2u * k + 1u].xyz;
    occluded[k] = select(0u, 1u, occluded_segment(a, b));
}

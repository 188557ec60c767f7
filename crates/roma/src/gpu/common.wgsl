// Shared by ROMA's kernels (crates/roma/src/gpu.rs prepends the constants: RESOLUTION, HALF,
// and the CPU's f32 constants as exact hex literals).
//
// Vulkan allows 2.5 ulp of error in division and more in sqrt; the CPU's are correctly rounded.
// Where the CPU divides or takes a square root, these functions compute the correctly rounded
// IEEE result with integer arithmetic, so the GPU rounds exactly as the CPU does.

// A product the driver may not fuse into an fma with the sum it feeds (SPIR-V lets a driver
// contract a·b + c, which rounds once where the CPU rounds twice): the product's bits pass
// through an OR with `no_fold()`, a zero each kernel reads from its uniform, which the compiler
// cannot see through. Every product that feeds a sum goes through `mul`.
fn mul(a: f32, b: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(a * b) | no_fold());
}

fn mul3(a: vec3<f32>, b: f32) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(a * b) | vec3<u32>(no_fold()));
}

const F32_NAN: u32 = 0x7fc00000u;
const F32_INF: u32 = 0x7f800000u;
const SIGN_BIT: u32 = 0x80000000u;

// Mantissa (with the implicit bit, normalized to [2^23, 2^24)) and biased exponent of a finite,
// non-zero f32 given as bits; subnormals are normalized (their exponent goes below 1).
fn unpack(bits: u32) -> vec2<i32> {
    var e = i32((bits >> 23u) & 0xffu);
    var m = bits & 0x7fffffu;
    if e == 0 {
        let s = countLeadingZeros(m) - 8u;
        m = m << s;
        e = 1 - i32(s);
    } else {
        m = m | 0x800000u;
    }
    return vec2<i32>(i32(m), e);
}

// Rounds the quotient or root `q` (value q · 2^-(shift) in units of the result's last place,
// `sticky` when bits below it are non-zero) to nearest even and packs it with biased exponent `e`
// (q has its leading one at bit 23 + shift). Handles overflow to infinity and subnormal results.
fn round_pack(sign: u32, q_in: u32, shift_in: u32, e_in: i32, sticky_in: bool) -> f32 {
    var e = e_in;
    var shift = shift_in;
    var sticky = sticky_in;
    if e >= 255 {
        return bitcast<f32>(sign | F32_INF);
    }
    if e <= 0 {
        shift = shift + u32(1 - e);
        e = 0;
    }
    if shift >= 27u {
        return bitcast<f32>(sign);
    }
    var m = q_in >> shift;
    let round = (q_in >> (shift - 1u)) & 1u;
    sticky = sticky || (q_in & ((1u << (shift - 1u)) - 1u)) != 0u;
    if round == 1u && (sticky || (m & 1u) == 1u) {
        m = m + 1u;
    }
    if e == 0 {
        // Subnormal (m < 2^23), or rounded up to the smallest normal (m = 2^23: exponent field 1).
        return bitcast<f32>(sign | m);
    }
    if m == 0x1000000u {
        m = 0x800000u;
        e = e + 1;
        if e >= 255 {
            return bitcast<f32>(sign | F32_INF);
        }
    }
    return bitcast<f32>(sign | (u32(e) << 23u) | (m & 0x7fffffu));
}

// a / b, correctly rounded (IEEE 754 round to nearest even), as the CPU's `/`.
fn div_exact(a: f32, b: f32) -> f32 {
    let ua = bitcast<u32>(a);
    let ub = bitcast<u32>(b);
    let sign = (ua ^ ub) & SIGN_BIT;
    let a_abs = ua & 0x7fffffffu;
    let b_abs = ub & 0x7fffffffu;
    if a_abs > F32_INF || b_abs > F32_INF {
        return bitcast<f32>(F32_NAN);
    }
    if a_abs == F32_INF {
        if b_abs == F32_INF {
            return bitcast<f32>(F32_NAN);
        }
        return bitcast<f32>(sign | F32_INF);
    }
    if b_abs == F32_INF {
        return bitcast<f32>(sign);
    }
    if b_abs == 0u {
        if a_abs == 0u {
            return bitcast<f32>(F32_NAN);
        }
        return bitcast<f32>(sign | F32_INF);
    }
    if a_abs == 0u {
        return bitcast<f32>(sign);
    }
    let pa = unpack(a_abs);
    let pb = unpack(b_abs);
    var ma = u32(pa.x);
    let mb = u32(pb.x);
    var e = pa.y - pb.y + 127;
    if ma < mb {
        ma = ma << 1u;
        e = e - 1;
    }
    // Restoring division: 26 quotient bits (the leading one, 23 more, a round bit, one more).
    var rem = ma;
    var q = 0u;
    for (var i = 0u; i < 26u; i = i + 1u) {
        q = q << 1u;
        if rem >= mb {
            rem = rem - mb;
            q = q | 1u;
        }
        rem = rem << 1u;
    }
    return round_pack(sign, q, 2u, e, rem != 0u);
}

// The bits (2p+1, 2p) of the 50-bit radicand m · 2^25.
fn radicand_pair(m: u32, p: u32) -> u32 {
    let k = 2u * p;
    if k >= 25u {
        return (m >> (k - 25u)) & 3u;
    }
    if k == 24u {
        return (m & 1u) << 1u;
    }
    return 0u;
}

// sqrt(x), correctly rounded, as the CPU's `f32::sqrt` (digit-by-digit integer square root).
fn sqrt_exact(x: f32) -> f32 {
    let u = bitcast<u32>(x);
    let x_abs = u & 0x7fffffffu;
    if x_abs == 0u {
        return x;
    }
    if x_abs > F32_INF || (u & SIGN_BIT) != 0u {
        return bitcast<f32>(F32_NAN);
    }
    if x_abs == F32_INF {
        return x;
    }
    let p = unpack(u);
    var m = u32(p.x);
    // x = m · 2^ex with m an integer; make ex odd so that (ex − 25) / 2 is whole.
    var ex = p.y - 127 - 23;
    if (ex & 1) == 0 {
        m = m << 1u;
        ex = ex - 1;
    }
    var rem = 0u;
    var root = 0u;
    for (var i = 0u; i < 25u; i = i + 1u) {
        rem = (rem << 2u) | radicand_pair(m, 24u - i);
        let trial = (root << 2u) | 1u;
        if rem >= trial {
            rem = rem - trial;
            root = (root << 1u) | 1u;
        } else {
            root = root << 1u;
        }
    }
    // root in [2^24, 2^25): 24 result bits and a round bit; the value is root · 2^((ex − 25) / 2).
    let f = (ex - 25) / 2 + 1;
    return round_pack(0u, root, 1u, f + 23 + 127, rem != 0u);
}

// Bit-wise helpers on 128-bit occupancy words held as vec4<u32> (.x = bits 0..31, .w = bits
// 96..127, as a little-endian u128). Slice s (0 = nearest) is bit 127 − s: element 3 − s/32,
// bit 31 − s%32 of it.

// The word with slices lo..=hi set (lo ≤ hi < 128), `Word::slice_range`.
fn slice_range(lo: u32, hi: u32) -> vec4<u32> {
    var out = vec4<u32>(0u);
    for (var e = 0u; e < 4u; e = e + 1u) {
        let base = 32u * (3u - e);
        let l = max(lo, base);
        let h = min(hi, base + 31u);
        if l <= h {
            out[e] = (0xffffffffu >> (l - base)) & (0xffffffffu << (31u - (h - base)));
        }
    }
    return out;
}

// The slice of bit `s` in a word, set.
fn slice_bit(s: u32) -> vec4<u32> {
    var out = vec4<u32>(0u);
    out[3u - s / 32u] = 1u << (31u - s % 32u);
    return out;
}

fn any_bits(w: vec4<u32>) -> bool {
    return any(w != vec4<u32>(0u));
}

// The first (lowest-numbered) occupied slice of a non-zero word: its leading zeros as a u128.
fn first_slice(w: vec4<u32>) -> u32 {
    for (var e = 3i; e >= 0i; e = e - 1i) {
        if w[e] != 0u {
            return 32u * (3u - u32(e)) + countLeadingZeros(w[e]);
        }
    }
    return 128u;
}

// The last (highest-numbered) occupied slice of a non-zero word: 127 − its trailing zeros.
fn last_slice(w: vec4<u32>) -> u32 {
    for (var e = 0u; e < 4u; e = e + 1u) {
        if w[e] != 0u {
            return 127u - (32u * e + countTrailingZeros(w[e]));
        }
    }
    return 0u;
}

// `1.0f32.copysign(s)`-style: |m| with the sign bit of s.
fn copysign(m: f32, s: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(m) & 0x7fffffffu) | (bitcast<u32>(s) & SIGN_BIT));
}

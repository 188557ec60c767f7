// The CPU's arithmetic, reproduced bit for bit (crates/dvf/src/gpu.rs prepends the constants as
// exact hex literals; every kernel defines `no_fold()`, a zero read from its uniform).
//
// - Products that feed a sum go through `mx` (and `mx3`): SPIR-V lets a driver contract a·b + c
//   into an fma, which rounds once where the CPU rounds twice (lavapipe does); OR-ing the
//   product's bits with a zero the compiler cannot see through keeps the two roundings.
// - Division and square root are `div_exact` / `sqrt_exact`: correctly rounded with integer
//   arithmetic (Vulkan allows 2.5 ulp in division), copied from glimpse-roma's common.wgsl.
// - 64-bit integers (PCG32, SplitMix64) are vec2<u32>(lo, hi).
// - sin and cos are glibc's `__sincosf_fma` (the CPU's libm) in f64, operation for operation,
//   as crates/dvf/src/raybatch.rs replicates it on AVX2.

fn mx(a: f32, b: f32) -> f32 {
    return bitcast<f32>(bitcast<u32>(a * b) | no_fold());
}

fn mx3(a: vec3<f32>, b: f32) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(a * b) | vec3<u32>(no_fold()));
}

// glam's `Vec3::dot`: (a.x·b.x + a.y·b.y) + a.z·b.z, each product rounded.
fn dot_cpu(a: vec3<f32>, b: vec3<f32>) -> f32 {
    return (mx(a.x, b.x) + mx(a.y, b.y)) + mx(a.z, b.z);
}

fn copysign_f(m: f32, s: f32) -> f32 {
    return bitcast<f32>((bitcast<u32>(m) & 0x7fffffffu) | (bitcast<u32>(s) & 0x80000000u));
}

// Rust's `v as u32` for 0 ≤ v < 2^32 (NaN and negatives → 0).
fn to_u32_sat(v: f32) -> u32 {
    if !(v >= 1.0) {
        return 0u;
    }
    if v >= 4294967296.0 {
        return 0xffffffffu;
    }
    return u32(v);
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

// ---- 64-bit integers as vec2<u32>(lo, hi) ----------------------------------------------------

// The full 64-bit product of two u32.
fn mul32_wide(a: u32, b: u32) -> vec2<u32> {
    let a0 = a & 0xffffu;
    let a1 = a >> 16u;
    let b0 = b & 0xffffu;
    let b1 = b >> 16u;
    let p00 = a0 * b0;
    let p01 = a0 * b1;
    let p10 = a1 * b0;
    let p11 = a1 * b1;
    let mid = (p00 >> 16u) + (p01 & 0xffffu) + (p10 & 0xffffu);
    return vec2<u32>((p00 & 0xffffu) | (mid << 16u), p11 + (p01 >> 16u) + (p10 >> 16u) + (mid >> 16u));
}

// `wrapping_mul`.
fn mul64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let p = mul32_wide(a.x, b.x);
    return vec2<u32>(p.x, p.y + a.x * b.y + a.y * b.x);
}

// `wrapping_add`.
fn add64(a: vec2<u32>, b: vec2<u32>) -> vec2<u32> {
    let lo = a.x + b.x;
    return vec2<u32>(lo, a.y + b.y + select(0u, 1u, lo < a.x));
}

// `a >> s` for 0 < s < 64.
fn shr64(a: vec2<u32>, s: u32) -> vec2<u32> {
    if s >= 32u {
        return vec2<u32>(a.y >> (s - 32u), 0u);
    }
    return vec2<u32>((a.x >> s) | (a.y << (32u - s)), a.y >> s);
}

// `glimpse_core::sampling::mix64` (SplitMix64's finalizer).
fn mix64(z_in: vec2<u32>) -> vec2<u32> {
    var z = z_in;
    z = mul64(z ^ shr64(z, 30u), vec2<u32>(0x1ce4e5b9u, 0xbf58476du));
    z = mul64(z ^ shr64(z, 27u), vec2<u32>(0x133111ebu, 0x94d049bbu));
    return z ^ shr64(z, 31u);
}

// rand_pcg's `Lcg64Xsh32` (PCG32), the generator behind `glimpse_core::Rng`.
struct Pcg {
    state: vec2<u32>,
    inc: vec2<u32>,
}

const PCG_MULT: vec2<u32> = vec2<u32>(0x4c957f2du, 0x5851f42du);

// `Pcg32::new(state, stream)`.
fn pcg_new(state: vec2<u32>, stream: vec2<u32>) -> Pcg {
    let inc = vec2<u32>((stream.x << 1u) | 1u, (stream.y << 1u) | (stream.x >> 31u));
    let s = add64(state, inc);
    return Pcg(add64(mul64(s, PCG_MULT), inc), inc);
}

fn pcg_next_u32(p: ptr<function, Pcg>) -> u32 {
    let s = (*p).state;
    (*p).state = add64(mul64(s, PCG_MULT), (*p).inc);
    let rot = s.y >> 27u;
    let xsh = shr64(shr64(s, 18u) ^ s, 27u).x;
    return (xsh >> rot) | (xsh << ((32u - rot) & 31u));
}

// `Rng::next_f32`: 24 random bits, exactly.
fn pcg_next_f32(p: ptr<function, Pcg>) -> f32 {
    return f32(pcg_next_u32(p) >> 8u) * (1.0 / 16777216.0);
}

// `Rng::next_2d`.
fn pcg_next_2d(p: ptr<function, Pcg>) -> vec2<f32> {
    let x = pcg_next_f32(p);
    let y = pcg_next_f32(p);
    return vec2<f32>(x, y);
}

// ---- sin and cos: glibc 2.36 `__sincosf_fma` ------------------------------------------------

// (sin θ, cos θ) for |θ| < 120, as `raybatch::avx2::sincos4_glibc`: tiny angles give (θ, 1);
// otherwise reduce by n = round(θ·2/π) and evaluate glibc's polynomials (swapped for odd n).
fn sincos_glibc(y: f32) -> vec2<f32> {
    let top12 = (bitcast<u32>(y) >> 20u) & 0x7ffu;
    if top12 < 0x398u {
        return vec2<f32>(y, 1.0);
    }
    let x = f64(y);
    let r = x * HPI_INV;
    let n = (i32(r) + 0x800000) >> 24u;
    let xr = fma(-f64(n), HPI, x);
    let n3 = n & 3;
    let neg = n3 == 1 || n3 == 2;
    let tab1 = (n & 2) == 2;
    let odd = (n & 1) == 1;
    let sign = select(f64(1.0), f64(-1.0), neg);
    let flip = select(f64(1.0), f64(-1.0), tab1);
    let xs = xr * sign;
    let x2 = xr * xr;
    let x3 = x2 * xs;
    let x4 = x2 * x2;
    let x5 = x2 * x3;
    let x6 = x2 * x4;
    let a_s = fma(x2, S3, S2);
    let a_c = fma(x2, C4 * flip, C3 * flip);
    let c_lo = fma(x2, C1 * flip, C0 * flip);
    let b_s = fma(x3, S1, xs);
    let b_c = fma(x4, C2 * flip, c_lo);
    let lo = f32(fma(a_s, x5, b_s));
    let hi = f32(fma(a_c, x6, b_c));
    if odd {
        return vec2<f32>(hi, lo);
    }
    return vec2<f32>(lo, hi);
}

// ---- The ray set of a normal (crates/dvf/src/rays.rs) ----------------------------------------

// `Frame::from_z(n)`: x, y (z is n).
struct Basis {
    x: vec3<f32>,
    y: vec3<f32>,
    z: vec3<f32>,
}

fn frame_from_z(n: vec3<f32>) -> Basis {
    let sign = copysign_f(1.0, n.z);
    let a = div_exact(-1.0, sign + n.z);
    let b = (n.x * n.y) * a;
    let x = vec3<f32>(1.0 + mx((sign * n.x) * n.x, a), sign * b, -sign * n.x);
    let y = vec3<f32>(b, sign + mx(n.y * n.y, a), -n.y);
    return Basis(x, y, n);
}

// `Frame::to_world`: (X·v.x + Y·v.y) + Z·v.z.
fn to_world(f: Basis, v: vec3<f32>) -> vec3<f32> {
    return (mx3(f.x, v.x) + mx3(f.y, v.y)) + mx3(f.z, v.z);
}

// `radical_inverse_base2`.
fn radical_inverse(i: u32) -> f32 {
    return f32(reverseBits(i) >> 8u) * (1.0 / 16777216.0);
}

// `cosine_hemisphere(u)` (Malley's method over Shirley and Chiu's concentric map).
fn cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let o = u * 2.0 - vec2<f32>(1.0);
    var d = vec2<f32>(0.0);
    if !(o.x == 0.0 && o.y == 0.0) {
        let x_major = abs(o.x) > abs(o.y);
        var r = o.y;
        var theta = HALF_PI - mx(FRAC_PI_4, div_exact(o.x, o.y));
        if x_major {
            r = o.x;
            theta = FRAC_PI_4 * div_exact(o.y, o.x);
        }
        let sc = sincos_glibc(theta);
        d = vec2<f32>(r * sc.y, r * sc.x);
    }
    let z = sqrt_exact(max(1.0 - (mx(d.x, d.x) + mx(d.y, d.y)), 0.0));
    return vec3<f32>(d, z);
}

// One rotated ray set (`RaySet`).
struct RaySet {
    frame: Basis,
    count: u32,
    shift: vec2<f32>,
    about_normal: bool,
    // (sin, cos) of the rotation about the normal.
    rot: vec2<f32>,
}

fn ray_set(normal: vec3<f32>, count: u32, shift: vec2<f32>, about_normal: bool) -> RaySet {
    var rot = vec2<f32>(0.0, 1.0);
    if about_normal {
        rot = sincos_glibc(TAU * shift.x);
    }
    return RaySet(frame_from_z(normal), count, shift, about_normal, rot);
}

// `RaySet::direction(k)`.
fn ray_direction(s: RaySet, k: u32) -> vec3<f32> {
    let u = vec2<f32>(div_exact(f32(k) + 0.5, f32(s.count)), radical_inverse(k));
    var local: vec3<f32>;
    if s.about_normal {
        let d = cosine_hemisphere(u);
        local = vec3<f32>(mx(d.x, s.rot.y) - mx(d.y, s.rot.x), mx(d.x, s.rot.x) + mx(d.y, s.rot.y), d.z);
    } else {
        let v = u + s.shift;
        local = cosine_hemisphere(v - floor(v));
    }
    return to_world(s.frame, local);
}

// `grid::octahedral_pixel(d, r)`.
fn octahedral_pixel(d: vec3<f32>, r: u32) -> u32 {
    let inv_l1 = div_exact(1.0, (abs(d.x) + abs(d.y)) + abs(d.z));
    let x = d.x * inv_l1;
    let y = d.y * inv_l1;
    let sx = select(-1.0, 1.0, x >= 0.0);
    let sy = select(-1.0, 1.0, y >= 0.0);
    let lower = d.z < 0.0;
    let fx = select(x, (1.0 - abs(y)) * sx, lower);
    let fy = select(y, (1.0 - abs(x)) * sy, lower);
    let half = f32(r) * 0.5;
    let px = min(to_u32_sat(mx(fx, half) + half), r - 1u);
    let py = min(to_u32_sat(mx(fy, half) + half), r - 1u);
    return py * r + px;
}

// `ray::offset_origin(p, n)`.
fn offset_origin(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let a = abs(p);
    let scale = max(max(max(a.x, a.y), a.z), 1.0);
    return p + mx3(n, OFFSET * scale);
}

// `GpuRay::new` (the CPU's `PreparedRay::new`) for trace.wgsl, t_max = ∞.
fn prepare_ray(origin: vec3<f32>, dir: vec3<f32>) -> Ray {
    let a = abs(dir);
    let tiny = vec3<f32>(TINY);
    let safe = select(vec3<f32>(copysign_f(TINY, dir.x), copysign_f(TINY, dir.y), copysign_f(TINY, dir.z)), dir, a > tiny);
    let inv = vec3<f32>(div_exact(1.0, safe.x), div_exact(1.0, safe.y), div_exact(1.0, safe.z));
    var kz = 2u;
    if a.x >= a.y && a.x >= a.z {
        kz = 0u;
    } else if a.y >= a.z {
        kz = 1u;
    }
    let kx = (kz + 1u) % 3u;
    let ky = (kz + 2u) % 3u;
    let shear = vec3<f32>(div_exact(dir[kx], dir[kz]), div_exact(dir[ky], dir[kz]), div_exact(1.0, dir[kz]));
    return Ray(origin, kz, inv, bitcast<f32>(F32_INF), shear, 0u);
}

// Any hit along the ray from `origin` (t_max = ∞), by trace.wgsl's exact traversal.
fn occluded_from(origin: vec3<f32>, dir: vec3<f32>) -> bool {
    return trace(prepare_ray(origin, dir), true).prim != NO_HIT;
}

// The CPU's arithmetic, reproduced bit for bit (crates/dvf/src/gpu.rs prepends the constants as
// exact hex literals; every kernel defines `no_fold()`, a zero read from its uniform).
//
// - Products that feed a sum go through `mx` (and `mx3`): SPIR-V lets a driver contract a·b + c
//   into an fma, which rounds once where the CPU rounds twice (lavapipe does); OR-ing the
//   product's bits with a zero the compiler cannot see through keeps the two roundings.
// - Division and square root are `div_exact` / `sqrt_exact`: correctly rounded through f64
//   (Vulkan allows 2.5 ulp in f32 division); glimpse-roma's integer versions compile to far more
//   code, which lavapipe's compiler takes seconds over, and the build needs f64 anyway.
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

// a / b, correctly rounded. The f64 quotient of two f32 is never within 2^-49 (relative) of an
// f32 rounding midpoint, unless exactly on a representable value, so rounding it to f32 gives the
// correctly rounded quotient even if the f64 division is a few ulp off (Vulkan does not promise
// a correctly rounded f64 division). Division by zero is spelled out (undefined in Vulkan).
fn div_exact(a: f32, b: f32) -> f32 {
    if b == 0.0 {
        if (bitcast<u32>(a) & 0x7fffffffu) == 0u || (bitcast<u32>(a) & 0x7fffffffu) > F32_INF {
            return bitcast<f32>(F32_NAN);
        }
        return bitcast<f32>(((bitcast<u32>(a) ^ bitcast<u32>(b)) & SIGN_BIT) | F32_INF);
    }
    return f32(f64(a) / f64(b));
}

// sqrt(x), correctly rounded, by the same argument (the root of an f32 is never within 2^-50 of
// an f32 midpoint unless exact).
fn sqrt_exact(x: f32) -> f32 {
    if x == 0.0 {
        return x;
    }
    if x < 0.0 {
        return bitcast<f32>(F32_NAN);
    }
    return f32(sqrt(f64(x)));
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

// `ray::offset_origin(p, n, error_scale)`.
fn offset_origin(p: vec3<f32>, n: vec3<f32>, error_scale: f32) -> vec3<f32> {
    let a = abs(p);
    let scale = max(max(max(a.x, a.y), a.z), error_scale);
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
    // t_max = ∞ read through the uniform's zero: a compiler may treat an infinite constant as it
    // likes (Vulkan keeps infinities only under SignedZeroInfNanPreserve, which naga does not ask
    // for), but not a value it cannot see.
    return Ray(origin, kz, inv, bitcast<f32>(F32_INF | params.zero), shear, 0u);
}

// Any hit along the ray from `origin` (t_max = ∞), by trace.wgsl's exact traversal.
fn occluded_from(origin: vec3<f32>, dir: vec3<f32>) -> bool {
    return trace(prepare_ray(origin, dir), true).prim != NO_HIT;
}

// a·b − c·d exactly as the CPU's double-precision fallback computes it (products of f32 values
// are exact in f64; the difference is rounded to f64, then to f32). Needs SHADER_F64.
fn exact_difference(a: f32, b: f32, c: f32, d: f32) -> f32 {
    return f32(f64(a) * f64(b) - f64(c) * f64(d));
}

// a / b (b ≠ 0) rounded as the CPU's f32 division: the f64 quotient rounded to f32 is the
// correctly rounded one, while WGSL's f32 `/` may be 2.5 ulp off (NVIDIA's is), which moves t by
// an ulp and hands a tie at a shared edge to the other triangle.
fn div_rounded(a: f32, b: f32) -> f32 {
    return f32(f64(a) / f64(b));
}

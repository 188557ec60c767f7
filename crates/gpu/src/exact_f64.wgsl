// a·b − c·d exactly as the CPU's double-precision fallback computes it (products of f32 values
// are exact in f64; the difference is rounded to f64, then to f32). Needs SHADER_F64.
fn exact_difference(a: f32, b: f32, c: f32, d: f32) -> f32 {
    return f32(f64(a) * f64(b) - f64(c) * f64(d));
}

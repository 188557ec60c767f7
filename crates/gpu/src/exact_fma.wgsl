// a·b − c·d close to the CPU's double-precision fallback, for devices without f64: the
// products' rounding errors come from fma (exact only where the driver fuses it; lavapipe 22.3
// does not, and then an edge function that is zero in f32 stays zero), and two-sum keeps the
// difference's.
fn exact_difference(a: f32, b: f32, c: f32, d: f32) -> f32 {
    // Unfused (trace.wgsl's `unfused`): `p − q` must subtract the rounded products.
    let p = bitcast<f32>(bitcast<u32>(a * b) | params.zero);
    let q = bitcast<f32>(bitcast<u32>(c * d) | params.zero);
    let ep = fma(a, b, -p);
    let eq = fma(c, d, -q);
    let s = p - q;
    let bb = s - p;
    let es = (p - (s - bb)) + (-q - bb);
    return s + (es + (ep - eq));
}

// a / b (b ≠ 0) close to the CPU's correctly rounded division: WGSL's `/` (2.5 ulp allowed)
// corrected once by its fma residual.
fn div_rounded(a: f32, b: f32) -> f32 {
    let q = a / b;
    return q + fma(-q, b, a) / b;
}

// env-dvf's shading (crates/dvf/src/technique.rs, `Runtime::irradiance_per_ray`) on the GPU: per
// GBuffer pixel, the CPU's ray set (its pixel's PCG stream, Hammersley set, shift, frame), the
// cell's label and masks selecting which rays to trace, the exact traversal, and E from the
// traced sum (label 1) or E_unshad − the occluded sum (label 0). Appended to trace.wgsl,
// exact_f64.wgsl and exact.wgsl. The environment lookup (atan2, acos) and the SH evaluation use
// WGSL's built-ins, so radiance agrees with the CPU's to rounding, not bit for bit.

struct Shade {
    // pixels, rays N_r, rotation about the normal, octahedral resolution R
    size: vec4<u32>,
    // unshadowed from rays (1) or SH (0), trace unknown pixels, u32 words per mask, zero
    flags: vec4<u32>,
    // grid dims x, y, z; cell count
    cells: vec4<u32>,
    // the pixel streams' PCG state (lo, hi), frame index (lo, hi)
    rng: vec4<u32>,
    grid: vec4<f32>,
    // environment width, height, scale, 1 when there is an environment
    env: vec4<f32>,
    // `bright`: the luminance threshold (x), and its octahedral pixels at 32², 32 to a u32 (all
    // 0: off)
    bright: vec4<f32>,
    // `footprint=around` (x = 1): the union of the masks of the 2×2×2 cells around the fragment
    lookup: vec4<u32>,
    bright_pixels: array<vec4<u32>, 8>,
}

@group(0) @binding(6) var<uniform> shade: Shade;
// Per pixel: (position, hit), (normal or, for a miss, the view direction), shading normal,
// albedo, emission.
@group(0) @binding(7) var<storage, read> gbuffer: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> env_texels: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> sh: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> masks: array<u32>;
@group(0) @binding(11) var<storage, read> labels: array<u32>;
@group(0) @binding(12) var<storage, read_write> image: array<vec4<f32>>;

fn no_fold() -> u32 {
    return shade.flags.w;
}

const PI_F: f32 = 3.14159265358979;

// `Environment::radiance`: the equirectangular map's bilinear lookup, times its scale.
fn radiance(d: vec3<f32>) -> vec3<f32> {
    if shade.env.w == 0.0 {
        return vec3<f32>(0.0);
    }
    var u = 0.5 + atan2(d.x, -d.z) / TAU;
    let v = acos(clamp(d.y, -1.0, 1.0)) / PI_F;
    u = u - floor(u);
    let w = i32(shade.env.x);
    let h = i32(shade.env.y);
    let x = u * shade.env.x - 0.5;
    let y = v * shade.env.y - 0.5;
    let x0 = floor(x);
    let y0 = floor(y);
    let fx = x - x0;
    let fy = y - y0;
    let xi = i32(x0);
    let yi = i32(y0);
    let t00 = texel(xi, yi, w, h);
    let t10 = texel(xi + 1, yi, w, h);
    let t01 = texel(xi, yi + 1, w, h);
    let t11 = texel(xi + 1, yi + 1, w, h);
    let top = t00 * (1.0 - fx) + t10 * fx;
    let bottom = t01 * (1.0 - fx) + t11 * fx;
    return (top * (1.0 - fy) + bottom * fy) * shade.env.z;
}

fn texel(x: i32, y: i32, w: i32, h: i32) -> vec3<f32> {
    let xi = ((x % w) + w) % w;
    let yi = clamp(y, 0, h - 1);
    return env_texels[yi * w + xi].xyz;
}

// `Sh9::irradiance(n) / π`.
fn sh_irradiance_over_pi(n: vec3<f32>) -> vec3<f32> {
    let b = array<f32, 9>(
        0.282095,
        0.488603 * n.y,
        0.488603 * n.z,
        0.488603 * n.x,
        1.092548 * n.x * n.y,
        1.092548 * n.y * n.z,
        0.315392 * (3.0 * n.z * n.z - 1.0),
        1.092548 * n.x * n.z,
        0.546274 * (n.x * n.x - n.y * n.y),
    );
    let a = array<f32, 9>(PI_F, 2.0 * PI_F / 3.0, 2.0 * PI_F / 3.0, 2.0 * PI_F / 3.0, PI_F / 4.0, PI_F / 4.0, PI_F / 4.0, PI_F / 4.0, PI_F / 4.0);
    var e = vec3<f32>(0.0);
    for (var i = 0u; i < 9u; i++) {
        e += sh[i].xyz * (a[i] * b[i]);
    }
    return e / PI_F;
}

// `Grid::cell_of`.
fn cell_of(p: vec3<f32>) -> u32 {
    let rel = p - shade.grid.xyz;
    let q = floor(vec3<f32>(div_exact(rel.x, shade.grid.w), div_exact(rel.y, shade.grid.w), div_exact(rel.z, shade.grid.w)));
    let dims = shade.cells.xyz;
    let c = vec3<u32>(min(to_u32_sat(q.x), dims.x - 1u), min(to_u32_sat(q.y), dims.y - 1u), min(to_u32_sat(q.z), dims.z - 1u));
    return (c.z * dims.y + c.y) * dims.x + c.x;
}

// `BrightDirections::holds`' pixel test (at `bright::RESOLUTION` = 32).
fn bright_pixel(pixel: u32) -> bool {
    return ((shade.bright_pixels[pixel / 128u][(pixel / 32u) % 4u] >> (pixel % 32u)) & 1u) == 1u;
}

// `glimpse_core::luminance`.
fn luminance(c: vec3<f32>) -> f32 {
    return 0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z;
}

// u32 words per mask at the largest R (32² bits).
const MAX_MASK_WORDS: u32 = 32u;

// One axis of `Grid::cells_around`: the cell below `q` (the fragment's position in cells, less
// half a cell) plus `o`, clamped into the grid.
fn around_axis(q: f32, o: u32, dim: u32) -> u32 {
    let below = i32(min(max(floor(q), -1.0), f32(dim))) + i32(o);
    return u32(clamp(below, 0, i32(dim) - 1));
}

@compute @workgroup_size(64)
fn shade_pixels(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = gid.y * groups.x * 64u + gid.x;
    if i >= shade.size.x {
        return;
    }
    let g0 = gbuffer[5u * i];
    if bitcast<u32>(g0.w) == 0u {
        image[i] = vec4<f32>(radiance(gbuffer[5u * i + 1u].xyz), 1.0);
        return;
    }
    let position = g0.xyz;
    let g1 = gbuffer[5u * i + 1u];
    let normal = g1.xyz;
    let error_scale = g1.w;
    let shading = gbuffer[5u * i + 2u].xyz;
    let albedo = gbuffer[5u * i + 3u].xyz;
    let emission = gbuffer[5u * i + 4u].xyz;
    // Rng::for_pixel(seed, i, frame_index).next_2d()
    let stream = mix64(mul64(vec2<u32>(i, 0u), vec2<u32>(0x7f4a7c15u, 0x9e3779b9u)) ^ shade.rng.zw);
    var rng = pcg_new(shade.rng.xy, stream);
    let rs = ray_set(shading, shade.size.y, pcg_next_2d(&rng), shade.size.z == 1u);
    let cell = cell_of(position);
    let label = labels[cell];
    let words = shade.flags.z;
    // The fragment's visible and occluded words: its cell's, or the union over the 2×2×2 cells
    // around it (`Runtime::fragment_words`).
    var visible: array<u32, MAX_MASK_WORDS>;
    var occluded: array<u32, MAX_MASK_WORDS>;
    let dims = shade.cells.xyz;
    let rel = position - shade.grid.xyz;
    let q = vec3<f32>(div_exact(rel.x, shade.grid.w), div_exact(rel.y, shade.grid.w), div_exact(rel.z, shade.grid.w)) - vec3<f32>(0.5);
    var reads = 1u;
    if shade.lookup.x == 1u {
        reads = 8u;
    }
    for (var n = 0u; n < reads; n++) {
        var c = cell;
        if shade.lookup.x == 1u {
            c = (around_axis(q.z, (n >> 2u) & 1u, dims.z) * dims.y + around_axis(q.y, (n >> 1u) & 1u, dims.y)) * dims.x
                + around_axis(q.x, n & 1u, dims.x);
        }
        for (var w = 0u; w < words; w++) {
            visible[w] |= masks[c * words + w];
            occluded[w] |= masks[shade.cells.w * words + c * words + w];
        }
    }
    let unknown = shade.flags.y == 1u;
    let rays_unshadowed = shade.flags.x == 1u;
    let inv = div_exact(1.0, f32(shade.size.y));
    let origin = offset_origin(position, normal, error_scale);
    var sum = vec3<f32>(0.0);
    var unshadowed = vec3<f32>(0.0);
    for (var k = 0u; k < shade.size.y; k++) {
        let d = ray_direction(rs, k);
        // `Shading::cos(d) > 0`: above the geometric horizon, then the shading one.
        if !(dot_cpu(normal, d) > 0.0) || !(dot_cpu(shading, d) > 0.0) {
            continue;
        }
        let pixel = octahedral_pixel(d, shade.size.w);
        let v = ((visible[pixel / 32u] >> (pixel % 32u)) & 1u) == 1u;
        let o = ((occluded[pixel / 32u] >> (pixel % 32u)) & 1u) == 1u;
        // Label 1 (mostly occluded): trace inside the visible region, add what escapes. Label 0:
        // trace inside the occluded region, add what is blocked. One trace and one lookup per
        // ray in the code, so the traversal is compiled once.
        var traced = o || (unknown && !v);
        if label == 1u {
            traced = v || (unknown && !o);
        }
        // `bright`: rays toward the map's brightest texels, whatever the masks say.
        if !traced && bright_pixel(octahedral_pixel(d, 32u)) {
            traced = luminance(radiance(d)) > shade.bright.x;
        }
        var blocked = false;
        if traced {
            blocked = occluded_from(origin, d);
        }
        let adds = traced && (blocked == (label != 1u));
        let unshadowed_term = label != 1u && rays_unshadowed;
        if adds || unshadowed_term {
            let l = radiance(d) * inv;
            if unshadowed_term {
                unshadowed += l;
            }
            if adds {
                sum += l;
            }
        }
    }
    var e = sum;
    if label != 1u {
        var e_unshad = unshadowed;
        if !rays_unshadowed {
            e_unshad = sh_irradiance_over_pi(shading);
        }
        e = max(e_unshad - sum, vec3<f32>(0.0));
    }
    image[i] = vec4<f32>(emission + albedo * e, 1.0);
}

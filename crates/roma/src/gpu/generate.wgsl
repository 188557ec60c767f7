// Alg. 1 (`generate::generate_texel`): texel (x, y) of OM k samples the BOM at the cell centres
// of its column, start + i·step in BOM cells, and sets slice i when the sampled cell is
// occupied. One invocation per texel of every map; the float operations are the CPU's, in the
// same order (the column's entry and exit by div_exact).

struct GenerateParams {
    // x: maps, y: invocations per dispatch row (2D dispatch), z: 0 (`no_fold`), w: unused.
    counts: vec4<u32>,
}

@group(0) @binding(0) var<uniform> params: GenerateParams;
// Three vec4 per map: the axes x, y, z of OM k (w unused), `grid::om_axes` from the CPU.
@group(0) @binding(1) var<storage, read> axes: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> bom: array<vec4<u32>>;
// The OMs, layer-major: word k·R² + y·R + x.
@group(0) @binding(3) var<storage, read_write> maps: array<vec4<u32>>;

fn no_fold() -> u32 {
    return params.counts.z;
}

// `BomBits::get_at`: is the BOM cell containing q occupied? (Outside the grid: no.)
fn bom_at(q: vec3<f32>) -> bool {
    let r = f32(RESOLUTION);
    if !(q.x >= 0.0 && q.y >= 0.0 && q.z >= 0.0 && q.x < r && q.y < r && q.z < r) {
        return false;
    }
    let w = bom[u32(q.y) * RESOLUTION + u32(q.x)];
    let bit = 127u - u32(q.z);
    return ((w[bit / 32u] >> (bit % 32u)) & 1u) == 1u;
}

@compute @workgroup_size(64)
fn generate(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = gid.y * params.counts.y + gid.x;
    let texels = RESOLUTION * RESOLUTION;
    if id >= params.counts.x * texels {
        return;
    }
    let k = id / texels;
    let y = (id / RESOLUTION) % RESOLUTION;
    let x = id % RESOLUTION;
    let ax = axes[3u * k].xyz;
    let ay = axes[3u * k + 1u].xyz;
    let az = axes[3u * k + 2u].xyz;
    // `column_start_and_step`.
    let local = vec3<f32>(f32(x) + 0.5 - HALF, f32(y) + 0.5 - HALF, 0.5 - HALF);
    let start = mul3(ax, local.x) + mul3(ay, local.y) + mul3(az, local.z) + vec3<f32>(HALF);
    let step = az;
    // `column_samples`.
    let r = f32(RESOLUTION);
    var lo = 0.0;
    var hi = r - 1.0;
    for (var c = 0u; c < 3u; c = c + 1u) {
        if abs(step[c]) > STEP_EPS {
            let a = div_exact(0.0 - start[c], step[c]);
            let b = div_exact(r - start[c], step[c]);
            lo = max(lo, min(a, b) - 1.0);
            hi = min(hi, max(a, b) + 1.0);
        } else if start[c] < 0.0 || start[c] >= r {
            maps[id] = vec4<u32>(0u);
            return;
        }
    }
    var out = vec4<u32>(0u);
    if lo <= hi {
        let last = u32(floor(hi));
        for (var i = u32(ceil(lo)); i <= last; i = i + 1u) {
            if bom_at(start + mul3(step, f32(i))) {
                out = out | slice_bit(i);
            }
        }
    }
    maps[id] = out;
}

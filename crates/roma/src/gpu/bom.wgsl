// The BOM (`glimpse_voxel::occupancy::voxelize` at `Voxelization::PAPER`): every triangle in the
// three axis passes, one cell per texel centre inside its projection, at the depth interpolated
// there, set by atomic OR. One invocation per (triangle, pass, texel row); the float operations
// are the CPU's `sampled_triangle`, one for one and in the same order (divisions by div_exact).

struct BomParams {
    // xyz: the grid's centre (world), w: its cell size (world).
    center_cell: vec4<f32>,
    // x: triangles, y: invocations per dispatch row (2D dispatch), z: 0 (`no_fold`), w: unused.
    counts: vec4<u32>,
}

@group(0) @binding(0) var<uniform> params: BomParams;
// Three vec4 per triangle: world-space vertices (w unused).
@group(0) @binding(1) var<storage, read> triangles: array<vec4<f32>>;
// R² words of four u32 (word y·R + x, slice z at bit 127 − z).
@group(0) @binding(2) var<storage, read_write> bom: array<atomic<u32>>;

// `Grid::to_cells`: (p − centre) / cell + R/2.
fn to_cells(p: vec3<f32>) -> vec3<f32> {
    let d = p - params.center_cell.xyz;
    let c = params.center_cell.w;
    return vec3<f32>(div_exact(d.x, c), div_exact(d.y, c), div_exact(d.z, c)) + vec3<f32>(HALF);
}

fn no_fold() -> u32 {
    return params.counts.z;
}

fn perp_dot(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return mul(a.x, b.y) - mul(a.y, b.x);
}

// `(a − 0.5).ceil().max(0.0) as u32`, capped at R (beyond it the loops are empty either way).
fn first_texel(a: f32) -> u32 {
    return u32(min(max(ceil(a - 0.5), 0.0), f32(RESOLUTION)));
}

@compute @workgroup_size(64)
fn voxelize(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = gid.y * params.counts.y + gid.x;
    if id >= params.counts.x * 3u * RESOLUTION {
        return;
    }
    let j = id % RESOLUTION;
    let pass_index = id / RESOLUTION;
    let axis = pass_index % 3u;
    let t = pass_index / 3u;
    let q0 = to_cells(triangles[3u * t].xyz);
    let q1 = to_cells(triangles[3u * t + 1u].xyz);
    let q2 = to_cells(triangles[3u * t + 2u].xyz);
    let cu = (axis + 1u) % 3u;
    let cv = (axis + 2u) % 3u;
    let cw = axis;
    let p0 = vec2<f32>(q0[cu], q0[cv]);
    let p1 = vec2<f32>(q1[cu], q1[cv]);
    let p2 = vec2<f32>(q2[cu], q2[cv]);
    let area = perp_dot(p1 - p0, p2 - p0);
    if abs(area) < AREA_EPS {
        return;
    }
    let r = f32(RESOLUTION);
    let lo = min(min(p0, p1), p2);
    let hi = max(max(p0, p1), p2);
    let l_u = min(floor(hi.x - 0.5), r - 1.0);
    let l_v = min(floor(hi.y - 0.5), r - 1.0);
    if l_u < 0.0 || l_v < 0.0 {
        return;
    }
    if j < first_texel(lo.y) || j > u32(l_v) {
        return;
    }
    let last_u = u32(l_u);
    for (var i = first_texel(lo.x); i <= last_u; i = i + 1u) {
        let c = vec2<f32>(f32(i) + 0.5, f32(j) + 0.5);
        let b0 = div_exact(perp_dot(p2 - p1, c - p1), area);
        let b1 = div_exact(perp_dot(p0 - p2, c - p2), area);
        let b2 = 1.0 - b0 - b1;
        if b0 < 0.0 || b1 < 0.0 || b2 < 0.0 {
            continue;
        }
        let w = mul(b0, q0[cw]) + mul(b1, q1[cw]) + mul(b2, q2[cw]);
        if w >= 0.0 && w < r {
            var cell = vec3<u32>(0u);
            cell[cu] = i;
            cell[cv] = j;
            cell[cw] = u32(w);
            let bit = 127u - cell.z;
            atomicOr(&bom[4u * (cell.y * RESOLUTION + cell.x) + bit / 32u], 1u << (bit % 32u));
        }
    }
}

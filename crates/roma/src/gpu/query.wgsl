// Snapped queries (Alg. 2, `RomaMaps::any_hit_snapped` / `occluded_ray` / `closest_hit_snapped`):
// the ray's stratum (`CandidateSet::select`), its origin in OM k's cells (`MapTransform::apply`),
// the slice range (`trace::slice_range`) and the bits of the column in that range. The float
// operations are the CPU's, in the same order; division and sqrt by div_exact / sqrt_exact.

struct QueryParams {
    // x: queries, y: invocations per dispatch row (2D dispatch), z: n (candidates n×n),
    // w: mode (0: any-hit from the origin as given, 1: `occluded_ray`, offset origin and
    // shortened t_max, 2: closest hit).
    counts: vec4<u32>,
    // x: cell size (world), y: origin offset (cells), z: 0 (`no_fold`), w: unused.
    scales: vec4<f32>,
}

struct Query {
    origin: vec3<f32>,
    t_max: f32,
    dir: vec3<f32>,
    pad: f32,
}

@group(0) @binding(0) var<uniform> params: QueryParams;
@group(0) @binding(1) var<storage, read> queries: array<Query>;
// Three rows per map: world point → OM k cell coordinates (`MapTransform::rows`).
@group(0) @binding(2) var<storage, read> to_map: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> maps: array<vec4<u32>>;
// Any-hit: 0 or 1; closest hit: the distance's f32 bits, or 0xffffffff for a miss.
@group(0) @binding(4) var<storage, read_write> results: array<u32>;

fn no_fold() -> u32 {
    return bitcast<u32>(params.scales.z);
}

// `fast_math::atan_unit`.
fn atan_unit(x: f32) -> f32 {
    let x2 = x * x;
    return x * (ATAN_C0 + mul(x2, ATAN_C1 + mul(x2, ATAN_C2 + mul(x2, ATAN_C3 + mul(x2, ATAN_C4 + mul(x2, ATAN_C5))))));
}

// `directions::hemisphere_to_disk_square`.
fn disk_square(d: vec3<f32>) -> vec2<f32> {
    let r = sqrt_exact(1.0 - clamp(d.z, 0.0, 1.0));
    let ax = abs(d.x);
    let ay = abs(d.y);
    if r <= 0.0 || max(ax, ay) <= 0.0 {
        return vec2<f32>(0.0);
    }
    let swap = ay > ax;
    var major = d.x;
    var minor = d.y;
    if swap {
        major = d.y;
        minor = d.x;
    }
    let main = copysign(r, major);
    let other = main * atan_unit(div_exact(minor, major)) * INV_FRAC_PI_4;
    if swap {
        return vec2<f32>(other, main);
    }
    return vec2<f32>(main, other);
}

// `CandidateSet::select`: (candidate k, sign as ±1).
struct Selection {
    k: u32,
    sign: f32,
}

fn select_candidate(d: vec3<f32>) -> Selection {
    let n = params.counts.z;
    let local = vec3<f32>(d.x, -d.z, d.y);
    let sign = copysign(1.0, local.z);
    let o = disk_square(local * sign);
    let half_n = 0.5 * f32(n);
    let a = min(u32(max((o.x + 1.0) * half_n, 0.0)), n - 1u);
    let b = min(u32(max((o.y + 1.0) * half_n, 0.0)), n - 1u);
    return Selection(a * n + b, sign);
}

// `MapTransform::apply`: each row · (p, 1), summed as the CPU's 4-wide dot, (x + z) + (y + w).
fn apply(k: u32, p: vec3<f32>) -> vec3<f32> {
    var q = vec3<f32>(0.0);
    for (var i = 0u; i < 3u; i = i + 1u) {
        let row = to_map[3u * k + i];
        q[i] = (mul(row.x, p.x) + mul(row.z, p.z)) + (mul(row.y, p.y) + row.w);
    }
    return q;
}

// The occupied slices of the column of OM k under q within the ray's slice range
// (`RomaMaps::column` + `trace::slice_range`, masked as `range_bits` selects them); `ok` false
// when the ray misses the map. `hi` is the range's larger end.
struct Column {
    bits: vec4<u32>,
    ok: bool,
}

fn column(k: u32, plus: bool, q: vec3<f32>, depth_cells: f32) -> Column {
    let r = f32(RESOLUTION);
    let none = Column(vec4<u32>(0u), false);
    if !(q.x >= 0.0 && q.y >= 0.0 && q.x < r && q.y < r) {
        return none;
    }
    let last = r - 1.0;
    var end: f32;
    if plus {
        end = q.z + depth_cells;
        if q.z >= r || end < 0.0 {
            return none;
        }
    } else {
        end = q.z - depth_cells;
        if q.z < 0.0 || end >= r {
            return none;
        }
    }
    let t_start = u32(clamp(q.z, 0.0, last));
    let t_end = u32(clamp(end, 0.0, last));
    let word = maps[k * RESOLUTION * RESOLUTION + u32(q.y) * RESOLUTION + u32(q.x)];
    return Column(word & slice_range(min(t_start, t_end), max(t_start, t_end)), true);
}

@compute @workgroup_size(64)
fn query(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = gid.y * params.counts.y + gid.x;
    if id >= params.counts.x {
        return;
    }
    let ray = queries[id];
    let s = select_candidate(ray.dir);
    let plus = s.sign > 0.0;
    let cell = params.scales.x;
    let offset = params.scales.y;
    var q = apply(s.k, ray.origin);
    let mode = params.counts.w;
    if mode == 2u {
        let c = column(s.k, plus, q, div_exact(ray.t_max, cell));
        if !c.ok || !any_bits(c.bits) {
            results[id] = 0xffffffffu;
            return;
        }
        var cells: f32;
        if plus {
            cells = (f32(first_slice(c.bits)) + 0.5) - q.z;
        } else {
            cells = q.z - (f32(last_slice(c.bits)) + 1.0);
        }
        results[id] = bitcast<u32>(max(cells, 0.0) * cell);
        return;
    }
    var depth = div_exact(ray.t_max, cell);
    if mode == 1u {
        q.z = q.z + s.sign * offset;
        depth = depth - 2.0 * offset;
        if !(depth > 0.0) {
            results[id] = 0u;
            return;
        }
    }
    let c = column(s.k, plus, q, depth);
    results[id] = select(0u, 1u, c.ok && any_bits(c.bits));
}

// Un-snapped any-hit (`RomaMaps::any_hit_unsnapped`): the segment's stratum, both ends in OM k's
// cells, clipped to the map (`MapSegment::clip`), then the 2D DDA of `trace::any_hit_dda`. Built
// after query.wgsl (its bindings, `select_candidate` and `apply`); `Query.origin` is the
// segment's start, `Query.dir` its end, and `counts.w` the step limit. The float operations are
// the CPU's, in the same order; every product feeding a sum goes through `mul`.

fn f32_inf() -> f32 {
    return bitcast<f32>(F32_INF);
}

// Rust's `f32::max` / `min` on values that are never NaN here.
fn clip_segment(p0: vec3<f32>, p1: vec3<f32>, r: f32) -> array<vec3<f32>, 3> {
    let d = p1 - p0;
    var t0 = 0.0;
    var t1 = 1.0;
    var inside = true;
    for (var c = 0u; c < 3u; c = c + 1u) {
        if abs(d[c]) < AREA_EPS {
            if p0[c] < 0.0 || p0[c] >= r {
                inside = false;
            }
        } else {
            let ta = div_exact(0.0 - p0[c], d[c]);
            let tb = div_exact(r - p0[c], d[c]);
            t0 = max(t0, min(ta, tb));
            t1 = min(t1, max(ta, tb));
        }
    }
    // x: 1 when the segment meets the box; y, z: the clipped ends.
    if !inside || !(t0 <= t1) {
        return array<vec3<f32>, 3>(vec3<f32>(0.0), vec3<f32>(0.0), vec3<f32>(0.0));
    }
    return array<vec3<f32>, 3>(vec3<f32>(1.0), p0 + mul3(d, t0), p0 + mul3(d, t1));
}

fn dda_cell(v: f32) -> u32 {
    return min(u32(max(v, 0.0)), RESOLUTION - 1u);
}

// `trace::any_hit_dda`'s `next_boundary`.
fn next_boundary(p: f32, i: u32, s: i32, dv: f32) -> f32 {
    if abs(dv) < AREA_EPS {
        return f32_inf();
    }
    var edge = f32(i);
    if s > 0 {
        edge = f32(i) + 1.0;
    }
    return div_exact(edge - p, dv);
}

fn inv_abs(dv: f32) -> f32 {
    if abs(dv) < AREA_EPS {
        return f32_inf();
    }
    return div_exact(1.0, abs(dv));
}

fn any_hit_dda(k: u32, p0: vec3<f32>, p1: vec3<f32>, max_steps: u32) -> bool {
    let last = f32(RESOLUTION) - 1.0;
    let d = p1 - p0;
    var x = dda_cell(p0.x);
    var y = dda_cell(p0.y);
    let end_x = dda_cell(p1.x);
    let end_y = dda_cell(p1.y);
    let step_x = select(-1, 1, d.x > 0.0);
    let step_y = select(-1, 1, d.y > 0.0);
    var t_x = next_boundary(p0.x, x, step_x, d.x);
    var t_y = next_boundary(p0.y, y, step_y, d.y);
    let delta_x = inv_abs(d.x);
    let delta_y = inv_abs(d.y);
    var t_in = 0.0;
    for (var i = 0u; i < max_steps; i = i + 1u) {
        let at_end = x == end_x && y == end_y;
        var t_out = 1.0;
        if !at_end {
            t_out = min(min(t_x, t_y), 1.0);
        }
        let z_in = p0.z + mul(d.z, t_in);
        let z_out = p0.z + mul(d.z, t_out);
        let lo = u32(clamp(min(z_in, z_out), 0.0, last));
        let hi = u32(clamp(max(z_in, z_out), 0.0, last));
        let word = maps[k * RESOLUTION * RESOLUTION + y * RESOLUTION + x];
        if any_bits(word & slice_range(lo, hi)) {
            return true;
        }
        if t_out >= 1.0 {
            return false;
        }
        t_in = t_out;
        if t_x < t_y {
            x = u32(clamp(i32(x) + step_x, 0, i32(RESOLUTION) - 1));
            t_x = t_x + delta_x;
        } else {
            y = u32(clamp(i32(y) + step_y, 0, i32(RESOLUTION) - 1));
            t_y = t_y + delta_y;
        }
    }
    return false;
}

@compute @workgroup_size(64)
fn dda(@builtin(global_invocation_id) gid: vec3<u32>) {
    let id = gid.y * params.counts.y + gid.x;
    if id >= params.counts.x {
        return;
    }
    let p0 = queries[id].origin;
    let p1 = queries[id].dir;
    // `Vec3::try_normalize`: glam's scalar dot, ((x·x + y·y) + z·z), then 1 / √.
    let d = p1 - p0;
    let rcp = div_exact(1.0, sqrt_exact((mul(d.x, d.x) + mul(d.y, d.y)) + mul(d.z, d.z)));
    if !(rcp > 0.0 && rcp < f32_inf()) {
        results[id] = 0u;
        return;
    }
    let s = select_candidate(d * rcp);
    let seg = clip_segment(apply(s.k, p0), apply(s.k, p1), f32(RESOLUTION));
    if seg[0].x == 0.0 {
        results[id] = 0u;
        return;
    }
    results[id] = select(0u, 1u, any_hit_dda(s.k, seg[1], seg[2], params.counts.w));
}

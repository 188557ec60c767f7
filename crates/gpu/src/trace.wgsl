// Exact ray traversal of a 4-wide BVH over world-space triangles: any-hit (`occluded`) and
// closest-hit (`closest`). A port of glimpse-trace's `tracer.rs` traversal and `triangle.rs`
// watertight test (Woop, Benthin and Wald 2013) with the same operations in the same order, so
// that answers agree with the CPU tracer's except within rounding of an edge. Rays arrive
// prepared by the CPU (`GpuRay::new`: kz, shear, 1/dir), so no division sets the test up.

struct Node {
    // planes[2*axis + side]: the four children's minima (side 0) or maxima (side 1) on `axis`.
    planes: array<vec4<f32>, 6>,
    child: vec4<u32>,
    count: vec4<u32>,
}

struct Ray {
    origin: vec3<f32>,
    kz: u32,
    inv_dir: vec3<f32>,
    t_max: f32,
    shear: vec3<f32>,
    pad: u32,
}

struct Hit {
    t: f32,
    b1: f32,
    b2: f32,
    prim: u32,
}

struct Params {
    ray_count: u32,
    node_count: u32,
    // Always 0, but unknown to the compiler: see `unfused`.
    zero: u32,
    box_exit_scale: f32,
}

const EMPTY_SLOT: u32 = 0xffffffffu;
const NO_HIT: u32 = 0xffffffffu;
// Three pending siblings per level of a tree at most 64 levels deep (checked on upload).
const STACK_SIZE: u32 = 192u;

@group(0) @binding(0) var<storage, read> nodes: array<Node>;
@group(0) @binding(1) var<storage, read> triangles: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rays: array<Ray>;
@group(0) @binding(3) var<uniform> params: Params;
@group(0) @binding(4) var<storage, read_write> occluded_out: array<u32>;
@group(0) @binding(5) var<storage, read_write> hits_out: array<Hit>;

// `exact_difference(a, b, c, d)`: a·b − c·d as exactly as the CPU's double-precision
// fallback, and `div_rounded(a, b)`: a / b as the CPU rounds it; one of exact_f64.wgsl or
// exact_fma.wgsl is appended here by `GpuTracer::new`.

// `v` with its bits OR-ed with `params.zero` (0): a product passed through this cannot be fused
// with the add or subtract that follows it. The CPU rounds each product before the add; a GPU
// compiler may contract `a·b − c·d` into an fma, which moves an edge function by an ulp and
// flips rays through shared edges (on an NVIDIA H200, 204 of 120,523 parity rays answered
// otherwise than the CPU before the tracer's products were guarded; lavapipe fuses too).
fn unfused(v: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(v) | vec3<u32>(params.zero));
}

// `PreparedRay::intersect_along`: (t, b1, b2, 1) for a hit with 0 < t < t_max, else w = 0.
fn intersect(ray: Ray, prim: u32, t_max: f32) -> vec4<f32> {
    let kz = ray.kz;
    let kx = (kz + 1u) % 3u;
    let ky = (kz + 2u) % 3u;
    let a = triangles[3u * prim].xyz - ray.origin;
    let b = triangles[3u * prim + 1u].xyz - ray.origin;
    let c = triangles[3u * prim + 2u].xyz - ray.origin;
    let z = vec3<f32>(a[kz], b[kz], c[kz]);
    // Sheared into the ray's space: x = (ax, bx, cx), y = (ay, by, cy).
    let x = vec3<f32>(a[kx], b[kx], c[kx]) - unfused(z * ray.shear.x);
    let y = vec3<f32>(a[ky], b[ky], c[ky]) - unfused(z * ray.shear.y);
    // Edge functions (w, u, v): w = bx·ay − by·ax, u = cx·by − cy·bx, v = ax·cy − ay·cx.
    var edges = unfused(x.yzx * y) - unfused(y.yzx * x);
    if (any(edges == vec3<f32>(0.0))) {
        // Exactly on an edge in single precision: decide all three as exactly as the CPU's
        // double-precision recomputation.
        edges = vec3<f32>(
            exact_difference(x.y, y.x, y.y, x.x),
            exact_difference(x.z, y.y, y.z, x.y),
            exact_difference(x.x, y.z, y.x, x.z),
        );
    }
    if (any(edges < vec3<f32>(0.0)) && any(edges > vec3<f32>(0.0))) {
        return vec4<f32>(0.0);
    }
    let w = edges.x;
    let u = edges.y;
    let v = edges.z;
    let det = u + v + w;
    if (det == 0.0) {
        return vec4<f32>(0.0);
    }
    let weighted = unfused(edges * (z * ray.shear.z).zxy);
    var t_scaled = weighted.y + weighted.z + weighted.x;
    var det_abs = det;
    if (det < 0.0) {
        t_scaled = -t_scaled;
        det_abs = -det;
    }
    if (t_scaled <= 0.0 || t_scaled >= t_max * det_abs) {
        return vec4<f32>(0.0);
    }
    let inv = div_rounded(1.0, det);
    return vec4<f32>(div_rounded(t_scaled, det_abs), v * inv, w * inv, 1.0);
}

// `Ray4::enter`: which of the node's children the ray enters before t_max (bits), and where.
struct Entered {
    mask: u32,
    near: vec4<f32>,
}

fn enter(ray: Ray, n: Node, t_max: f32) -> Entered {
    var near = vec4<f32>(0.0);
    var far = vec4<f32>(t_max);
    for (var axis = 0u; axis < 3u; axis++) {
        let neg = select(0u, 1u, ray.inv_dir[axis] < 0.0);
        let o = ray.origin[axis];
        let inv = ray.inv_dir[axis];
        let t_near = (n.planes[2u * axis + neg] - vec4<f32>(o)) * inv;
        let t_far = (n.planes[2u * axis + 1u - neg] - vec4<f32>(o)) * inv;
        near = max(near, t_near);
        far = min(far, t_far);
    }
    let inside = (near <= far * params.box_exit_scale) & (n.child != vec4<u32>(EMPTY_SLOT));
    let mask = select(0u, 1u, inside.x) | select(0u, 2u, inside.y) | select(0u, 4u, inside.z) | select(0u, 8u, inside.w);
    return Entered(mask, near);
}

// A child to visit: a node (count 0) or a leaf's triangle range, and where the ray enters it.
struct Pending {
    child: u32,
    count: u32,
    near: f32,
}

// Traces one ray; `any_hit` stops at the first hit (children in slot order), otherwise children
// are visited nearest first and the closest hit is kept (`tracer.rs`'s `traverse`).
fn trace(ray: Ray, any_hit: bool) -> Hit {
    var best = Hit(0.0, 0.0, 0.0, NO_HIT);
    if (params.node_count == 0u) {
        return best;
    }
    var t_max = ray.t_max;
    var stack: array<Pending, STACK_SIZE>;
    var sp = 0u;
    var cur = Pending(0u, 0u, 0.0);
    loop {
        // Down through interior nodes to a leaf (or out, when the stack runs dry).
        var done = false;
        while (cur.count == 0u) {
            let n = nodes[cur.child];
            let e = enter(ray, n, t_max);
            let k = countOneBits(e.mask);
            if (k == 0u) {
                // Pop the most recent entry the ray enters before t_max.
                var found = false;
                while (sp > 0u) {
                    sp -= 1u;
                    let p = stack[sp];
                    if (any_hit || p.near < t_max) {
                        cur = p;
                        found = true;
                        break;
                    }
                }
                if (!found) {
                    done = true;
                    break;
                }
                continue;
            }
            let first = firstTrailingBit(e.mask);
            let rest = e.mask & (e.mask - 1u);
            if (k == 1u) {
                cur = Pending(n.child[first], n.count[first], e.near[first]);
            } else if (any_hit) {
                var bits = rest;
                while (bits != 0u) {
                    let s = firstTrailingBit(bits);
                    bits &= bits - 1u;
                    stack[min(sp, STACK_SIZE - 1u)] = Pending(n.child[s], n.count[s], e.near[s]);
                    sp += 1u;
                }
                cur = Pending(n.child[first], n.count[first], e.near[first]);
            } else if (k == 2u) {
                let s = firstTrailingBit(rest);
                let pa = Pending(n.child[first], n.count[first], e.near[first]);
                let pb = Pending(n.child[s], n.count[s], e.near[s]);
                if (pa.near <= pb.near) {
                    stack[min(sp, STACK_SIZE - 1u)] = pb;
                    cur = pa;
                } else {
                    stack[min(sp, STACK_SIZE - 1u)] = pa;
                    cur = pb;
                }
                sp += 1u;
            } else {
                // Three or four: insertion sort by entry distance, farthest first; keep the nearest.
                var sorted: array<Pending, 4>;
                var m = 0u;
                var bits = e.mask;
                while (bits != 0u) {
                    let s = firstTrailingBit(bits);
                    bits &= bits - 1u;
                    let p = Pending(n.child[s], n.count[s], e.near[s]);
                    var j = m;
                    while (j > 0u && sorted[j - 1u].near < p.near) {
                        sorted[j] = sorted[j - 1u];
                        j -= 1u;
                    }
                    sorted[j] = p;
                    m += 1u;
                }
                for (var i = 0u; i + 1u < m; i++) {
                    stack[min(sp, STACK_SIZE - 1u)] = sorted[i];
                    sp += 1u;
                }
                cur = sorted[m - 1u];
            }
        }
        if (done) {
            return best;
        }
        // A leaf: test its triangles, shrinking t_max on every hit.
        for (var i = cur.child; i < cur.child + cur.count; i++) {
            let h = intersect(ray, i, t_max);
            if (h.w != 0.0) {
                t_max = h.x;
                best = Hit(h.x, h.y, h.z, i);
                if (any_hit) {
                    return best;
                }
            }
        }
        // Next: the most recent pending entry the ray enters before t_max.
        var found = false;
        while (sp > 0u) {
            sp -= 1u;
            let p = stack[sp];
            if (any_hit || p.near < t_max) {
                cur = p;
                found = true;
                break;
            }
        }
        if (!found) {
            return best;
        }
    }
    return best;
}

@compute @workgroup_size(64)
fn occluded(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.ray_count) {
        return;
    }
    occluded_out[i] = select(0u, 1u, trace(rays[i], true).prim != NO_HIT);
}

@compute @workgroup_size(64)
fn closest(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.ray_count) {
        return;
    }
    hits_out[i] = trace(rays[i], false);
}

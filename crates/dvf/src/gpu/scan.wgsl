// CS2 and CS3 (crates/dvf/src/scan.rs on the GPU): the Blelloch up-sweep and down-sweep of one
// level's blocks of BLOCK = 2·WG elements, one workgroup per block, in workgroup memory. Every
// addition has the CPU's two operands, so the f32 sums are the CPU's bit for bit whatever order
// the invocations run in. `T` (f32 for the areas, u32 for the sample counts) and WG are
// substituted by crates/dvf/src/gpu.rs.
//
// Levels lie one after another in `data`; `level.src` is this level's offset, `level.dst` the
// next level's (the block totals), `level.top` 1 on the last level, whose total goes to
// `total[0]` ("Areas Sum") and whose single block starts the down-sweep from 0.

struct Level {
    src: u32,
    dst: u32,
    top: u32,
    pad: u32,
}

@group(0) @binding(0) var<uniform> level: Level;
@group(0) @binding(1) var<storage, read_write> data: array<T>;
@group(0) @binding(2) var<storage, read_write> total: array<T>;

const BLOCK: u32 = 2u * WG;
var<workgroup> block: array<T, BLOCK>;

fn load(base: u32, t: u32) {
    block[2u * t] = data[base + 2u * t];
    block[2u * t + 1u] = data[base + 2u * t + 1u];
}

fn store(base: u32, t: u32) {
    data[base + 2u * t] = block[2u * t];
    data[base + 2u * t + 1u] = block[2u * t + 1u];
}

// `scan::up_sweep` of block `wid.x`: afterwards its last element is the block's total.
@compute @workgroup_size(WG)
fn up_sweep(@builtin(local_invocation_index) t: u32, @builtin(workgroup_id) wid: vec3<u32>) {
    let base = level.src + wid.x * BLOCK;
    load(base, t);
    workgroupBarrier();
    for (var d = 1u; d < BLOCK; d = d * 2u) {
        let i = t * 2u * d;
        if i < BLOCK {
            block[i + 2u * d - 1u] = block[i + 2u * d - 1u] + block[i + d - 1u];
        }
        workgroupBarrier();
    }
    store(base, t);
    if t == 0u {
        if level.top == 1u {
            total[0] = block[BLOCK - 1u];
        } else {
            data[level.dst + wid.x] = block[BLOCK - 1u];
        }
    }
}

// `scan::down_sweep` of block `wid.x`, seeded with its offset (the level above, already swept).
@compute @workgroup_size(WG)
fn down_sweep(@builtin(local_invocation_index) t: u32, @builtin(workgroup_id) wid: vec3<u32>) {
    let base = level.src + wid.x * BLOCK;
    load(base, t);
    workgroupBarrier();
    if t == 0u {
        var offset = T(0);
        if level.top == 0u {
            offset = data[level.dst + wid.x];
        }
        block[BLOCK - 1u] = offset;
    }
    workgroupBarrier();
    for (var d = BLOCK / 2u; d >= 1u; d = d / 2u) {
        let i = t * 2u * d;
        if i < BLOCK {
            let held = block[i + d - 1u];
            block[i + d - 1u] = block[i + 2u * d - 1u];
            block[i + 2u * d - 1u] = block[i + 2u * d - 1u] + held;
        }
        workgroupBarrier();
    }
    store(base, t);
}

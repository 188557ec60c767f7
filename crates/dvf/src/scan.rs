//! CS2 and CS3 of the paper (§3.2.1, "Adaptive Prefix Sum", Figs. 5–8, Algorithm 1): a
//! work-efficient (Blelloch) parallel prefix sum of the triangle areas in blocks of
//! `2 × workgroup` elements, dispatched over several passes. CS2 up-sweeps every block of a
//! level in parallel and hands the block totals to the next level; CS3 walks the levels back
//! down, seeding each block's root with its offset and down-sweeping. The result is the
//! exclusive prefix sum (a Blelloch down-sweep zeroes the root) and the total ("Areas Sum").
//!
//! Deviations, each with its reason:
//! - Algorithm 1 with ceiling division in its loop (the spec's erratum E4: truncation gives the
//!   last pass 0 workgroups) and at least one pass for N = 1 (⌈log 1⌉ = 0).
//! - A level's block totals are copied into their own (padded) array instead of being read in
//!   place at stride `(2·workgroup)^k`: the same arithmetic, contiguous blocks for rayon.

use rayon::prelude::*;

/// Algorithm 1 (with the ceiling fix): the number of passes and the workgroups of each pass, for
/// `n` elements and `workgroup` threads of two elements each. CS3 runs the passes in reverse.
pub fn schedule(n: usize, workgroup: usize) -> Vec<usize> {
    let block = 2 * workgroup.max(1);
    let mut passes = Vec::new();
    let mut size = n.max(1);
    loop {
        let groups = size.div_ceil(block);
        passes.push(groups);
        if groups == 1 {
            return passes;
        }
        size = groups;
    }
}

/// In-place Blelloch up-sweep (reduce) of one power-of-two block: afterwards the last element
/// holds the block's total and the others hold the partial sums `A_{M..N}` of Fig. 6.
pub fn up_sweep(block: &mut [f32]) {
    let n = block.len();
    let mut d = 1;
    while d < n {
        for i in (0..n).step_by(2 * d) {
            block[i + 2 * d - 1] += block[i + d - 1];
        }
        d *= 2;
    }
}

/// In-place Blelloch down-sweep of an up-swept block whose last element was replaced by the
/// block's offset: afterwards element i holds offset + the sum of the elements before i.
pub fn down_sweep(block: &mut [f32]) {
    let n = block.len();
    let mut d = n / 2;
    while d >= 1 {
        for i in (0..n).step_by(2 * d) {
            let t = block[i + d - 1];
            block[i + d - 1] = block[i + 2 * d - 1];
            block[i + 2 * d - 1] += t;
        }
        d /= 2;
    }
}

/// The levels of the scan after CS2: level 0 is the padded input, level k+1 the totals of level
/// k's blocks; every block up-swept.
pub struct ScanLevels {
    levels: Vec<Vec<f32>>,
    block: usize,
    n: usize,
}

/// CS2: up-sweep of every level (one parallel pass per level, blocks in parallel).
pub fn up_sweep_passes(values: &[f32], workgroup: usize) -> ScanLevels {
    let block = 2 * workgroup.max(1);
    let passes = schedule(values.len(), workgroup);
    let mut levels = Vec::with_capacity(passes.len());
    let mut current: Vec<f32> = values.to_vec();
    for &groups in &passes {
        current.resize(groups * block, 0.0);
        current.par_chunks_mut(block).for_each(up_sweep);
        let totals: Vec<f32> = current.par_chunks(block).map(|b| b[block - 1]).collect();
        levels.push(std::mem::replace(&mut current, totals));
    }
    ScanLevels { levels, block, n: values.len() }
}

/// CS3: writes the total, then down-sweeps from the top level to level 0. Returns the exclusive
/// prefix sum of the input and the total.
pub fn down_sweep_passes(mut s: ScanLevels) -> (Vec<f32>, f32) {
    let block = s.block;
    let top = s.levels.len() - 1;
    let total = s.levels[top][block - 1];
    let mut offsets = vec![0.0f32];
    for level in (0..=top).rev() {
        let data = &mut s.levels[level];
        data.par_chunks_mut(block).zip(offsets.par_iter()).for_each(|(b, &off)| {
            b[block - 1] = off;
            down_sweep(b);
        });
        offsets = std::mem::take(data);
    }
    offsets.truncate(s.n);
    (offsets, total)
}

/// Both shaders: exclusive prefix sum and total.
pub fn exclusive_scan(values: &[f32], workgroup: usize) -> (Vec<f32>, f32) {
    down_sweep_passes(up_sweep_passes(values, workgroup))
}

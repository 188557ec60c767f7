//! Vertex clustering before Alg. 1 (`cluster`, ours): on finely tessellated meshes it removes most
//! triangles while the voxelizations, and the shadow answers, stay nearly the same; on meshes of
//! voxel-sized triangles it changes nothing.

use glimpse_core::Vec3;
use glimpse_voxarray::voxelize::{Grid, cluster_vertices};
use glimpse_voxarray::{Array, Rows, VoxArrayParams};

/// The world triangles of a scene.toml text, written to a folder of its own (removed when this
/// returns or panics; `name` names the file).
fn scene(name: &str, toml: &str) -> Vec<[Vec3; 3]> {
    let dir = tempfile::Builder::new().prefix(&format!("glimpse-cluster-{name}-")).tempdir().unwrap();
    let path = dir.path().join(format!("{name}.toml"));
    std::fs::write(&path, toml).unwrap();
    let scene = glimpse_scene::load(path.to_str().unwrap()).expect("scene loads");
    scene.at(0.0).world_triangles()
}

fn plain(a: &Array<u64>) -> &[u64] {
    match &a.rows {
        Rows::Plain(r) => r,
        Rows::Compressed(_) => panic!("expected plain rows"),
    }
}

#[test]
fn clustering_fine_meshes_keeps_the_voxels_and_answers() {
    // Three finely tessellated spheres (≈ 0.1-cell triangles at 64³) over a floor.
    let triangles = scene(
        "fine",
        "[[quad]]\nsize = [4.0, 4.0]\n\
         [[sphere]]\nradius = 0.5\nsegments = 512\ntranslate = [-1.0, 0.5, 0.0]\n\
         [[sphere]]\nradius = 0.4\nsegments = 512\ntranslate = [0.8, 0.4, 0.5]\n\
         [[sphere]]\nradius = 0.3\nsegments = 384\ntranslate = [0.2, 0.3, -1.0]\n",
    );
    let p = VoxArrayParams { resolution: 64, directions: 8, compress: None, ..VoxArrayParams::default() };
    let grid = Grid::around(&triangles, 64);
    let clustered = cluster_vertices(&triangles, &grid, p.cluster_cells);
    let off = Array::<u64>::build(&triangles, &VoxArrayParams { cluster_cells: 0.0, ..p });
    let on = Array::<u64>::build(&triangles, &p);
    let (a, b) = (plain(&off), plain(&on));
    let set: u64 = a.iter().map(|r| r.count_ones() as u64).sum();
    let differ: u64 = a.iter().zip(b).map(|(x, y)| (x ^ y).count_ones() as u64).sum();
    // Shadow answers between random points of the scene's surfaces.
    let mut s = 5u64;
    let mut rnd = move || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut point = || {
        let t = &triangles[(rnd() * triangles.len() as f32) as usize % triangles.len()];
        let (u, v) = (rnd(), rnd());
        let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
        t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v
    };
    let queries = 200_000;
    let mut disagree = 0;
    for _ in 0..queries {
        let (x, y) = (point(), point());
        disagree += (off.occluded_segment(x, y) != on.occluded_segment(x, y)) as u32;
    }
    let (bit_pct, answer_pct) = (100.0 * differ as f64 / set as f64, 100.0 * disagree as f64 / queries as f64);
    println!(
        "{} -> {} triangles; {differ} of {set} set voxels differ ({bit_pct:.2} %); {disagree} of {queries} shadow answers differ ({answer_pct:.3} %)",
        triangles.len(),
        clustered.len()
    );
    assert!(clustered.len() * 3 < triangles.len(), "most sub-voxel triangles collapse");
    assert!(bit_pct < 5.0, "voxels changed: {bit_pct:.2} %");
    assert!(answer_pct < 0.5, "answers changed: {answer_pct:.3} %");
}

#[test]
fn clustering_leaves_voxel_sized_triangles_alone() {
    // A floor and boxes: every vertex alone in its quarter-cell cube, or an exact duplicate.
    let triangles = scene(
        "coarse",
        "[[quad]]\nsize = [4.0, 4.0]\n[[box]]\nsize = [1.0, 0.7, 0.4]\ntranslate = [0.3, 0.35, 0.1]\n\
         [[box]]\nsize = [0.3, 1.2, 0.3]\ntranslate = [-1.0, 0.6, -0.5]\nrotate_y_degrees = 30.0\n",
    );
    let grid = Grid::around(&triangles, 64);
    let clustered = cluster_vertices(&triangles, &grid, 0.25);
    assert!(clustered == triangles, "{} triangles in, {} out, or moved", triangles.len(), clustered.len());
}

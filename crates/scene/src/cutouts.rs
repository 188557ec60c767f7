//! The alpha-masked (glTF `alphaMode: MASK`) triangles' coverage in a form that owns its data,
//! for the structures that test it per point without borrowing the scene: the exact tracer at
//! each candidate hit, the shadow-map baselines at each texel and point sample.

use crate::{AlphaMask, Scene};
use glimpse_core::{Image, Vec2};
use std::collections::HashMap;
use std::sync::Arc;

/// Per instance, its mesh's uvs and mask ([`AlphaMask`]): [`Cutouts::hole`] answers for any
/// (instance, triangle, barycentrics).
#[derive(Debug, Default)]
pub struct Cutouts {
    /// Per instance: its mesh's index in `meshes`, or [`OPAQUE`].
    instance_mesh: Vec<u32>,
    meshes: Vec<CutoutMesh>,
}

const OPAQUE: u32 = u32::MAX;

#[derive(Debug)]
struct CutoutMesh {
    /// Per triangle: its vertices' uvs ((0, 0), (1, 0), (0, 1) where the mesh has none, as
    /// the surface point reads them).
    uvs: Vec<[Vec2; 3]>,
    mask: AlphaMask,
    texture: Option<Arc<Image>>,
}

impl Cutouts {
    /// `None` where no material is masked.
    pub fn new(scene: &Scene) -> Option<Cutouts> {
        if !scene.has_alpha_masks() {
            return None;
        }
        let mut textures: HashMap<u32, Arc<Image>> = HashMap::new();
        let mut mesh_entry: HashMap<u32, u32> = HashMap::new();
        let mut cut = Cutouts::default();
        for inst in &scene.instances {
            let mesh = &scene.meshes[inst.mesh as usize];
            let Some(mask) = scene.materials[mesh.material as usize].alpha_mask else {
                cut.instance_mesh.push(OPAQUE);
                continue;
            };
            let entry = *mesh_entry.entry(inst.mesh).or_insert_with(|| {
                let uvs = if mesh.uvs.is_empty() {
                    vec![[Vec2::ZERO, Vec2::X, Vec2::Y]; mesh.indices.len()]
                } else {
                    mesh.indices.iter().map(|t| t.map(|i| mesh.uvs[i as usize])).collect()
                };
                let texture =
                    mask.texture.map(|t| textures.entry(t).or_insert_with(|| Arc::new(scene.textures[t as usize].clone())).clone());
                cut.meshes.push(CutoutMesh { uvs, mask, texture });
                cut.meshes.len() as u32 - 1
            });
            cut.instance_mesh.push(entry);
        }
        Some(cut)
    }

    /// Whether the point at barycentrics (`b1`, `b2`) of `triangle` of `instance` is a hole.
    #[inline]
    pub fn hole(&self, instance: u32, triangle: u32, b1: f32, b2: f32) -> bool {
        let Some(m) = self.instance_mesh.get(instance as usize).and_then(|&e| self.meshes.get(e as usize)) else {
            return false;
        };
        let [u0, u1, u2] = m.uvs[triangle as usize];
        let uv = u0 * (1.0 - b1 - b2) + u1 * b1 + u2 * b2;
        m.mask.cuts(m.texture.as_deref(), uv)
    }
}

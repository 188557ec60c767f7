//! Intel Embree (3.13, through the `embree3` crate) on the same scene as the exact tracer: the
//! reference the cross-check test and the backend comparison measure [`crate::ExactTracer`]
//! against. Behind the `embree` feature, which needs the system library (`libembree-dev`).
//!
//! Every instance is flattened into world-space triangles of one Embree triangle geometry;
//! Embree's `primID` indexes [`EmbreeScene::ids`], which gives back our (instance, triangle).
//! Queries use the single-ray API (`rtcOccluded1` / `rtcIntersect1`) with `tnear = 0` and
//! `tfar = t_max`, so the timings compare single-ray traversal with single-ray traversal.

use crate::tracer::PrimId;
use crate::{ClosestHit, Hit, SceneFrame, Visibility};
use embree3::{BufferUsage, Device, Format, GeometryKind, IntersectContext, RayHit};
use glimpse_core::Ray;

pub use embree3::Error as EmbreeError;

/// A committed Embree scene of one frame's world-space triangles.
pub struct EmbreeScene {
    /// `'static`: the geometry's buffers are Embree-allocated, so the scene borrows no host memory.
    scene: embree3::Scene<'static>,
    /// Per Embree `primID`: the instance and the triangle (index into the mesh's `indices`).
    pub ids: Vec<PrimId>,
    // Dropped after the scene: the device outlives everything created from it.
    _device: Device,
}

impl EmbreeScene {
    /// Builds with Embree's defaults (medium-quality BVH, default scene flags).
    pub fn build(frame: &SceneFrame) -> Result<EmbreeScene, EmbreeError> {
        let scene_data = frame.scene;
        let mut vertices: Vec<[f32; 3]> = Vec::new();
        let mut ids = Vec::new();
        for (ii, inst) in scene_data.instances.iter().enumerate() {
            let m = frame.transforms[ii];
            let pos = &frame.positions[inst.mesh as usize];
            for (ti, t) in scene_data.meshes[inst.mesh as usize].indices.iter().enumerate() {
                vertices.extend(t.map(|i| m.transform_point3(pos[i as usize]).to_array()));
                ids.push(PrimId { instance: ii as u32, triangle: ti as u32 });
            }
        }
        let device = Device::new()?;
        let mut scene: embree3::Scene<'static> = device.create_scene()?;
        if !ids.is_empty() {
            let mut geometry = device.create_geometry(GeometryKind::TRIANGLE)?;
            geometry.set_new_buffer::<[f32; 3]>(BufferUsage::VERTEX, 0, Format::FLOAT3, 12, vertices.len())?.copy_from_slice(&vertices);
            let indices: Vec<[u32; 3]> = (0..ids.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
            geometry.set_new_buffer::<[u32; 3]>(BufferUsage::INDEX, 0, Format::UINT3, 12, indices.len())?.copy_from_slice(&indices);
            let geometry = geometry.commit();
            scene.attach_geometry(&geometry);
        }
        scene.commit();
        Ok(EmbreeScene { scene, ids, _device: device })
    }

    pub fn triangle_count(&self) -> usize {
        self.ids.len()
    }

    fn embree_ray(ray: &Ray, t_max: f32) -> embree3::Ray {
        embree3::Ray::segment(ray.origin.to_array(), ray.dir.to_array(), 0.0, t_max)
    }
}

impl Visibility for EmbreeScene {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let mut ctx = IntersectContext::incoherent();
        let mut r = Self::embree_ray(ray, t_max);
        self.scene.occluded(&mut ctx, &mut r)
    }
}

impl ClosestHit for EmbreeScene {
    fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let mut ctx = IntersectContext::incoherent();
        let mut rh = RayHit::from_ray(Self::embree_ray(ray, t_max));
        self.scene.intersect(&mut ctx, &mut rh);
        if !rh.hit.is_valid() {
            return None;
        }
        let id = self.ids[rh.hit.primID as usize];
        Some(Hit { t: rh.ray.tfar, b1: rh.hit.u, b2: rh.hit.v, instance: id.instance, triangle: id.triangle })
    }
}

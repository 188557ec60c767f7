//! Every ray against every triangle: slow, obviously right, the oracle the BVH is tested against.

use crate::triangle::PreparedRay;
use crate::{ClosestHit, Hit, SceneFrame, Visibility};
use glimpse_core::{Ray, Vec3A};

pub struct BruteForce {
    triangles: Vec<([Vec3A; 3], u32, u32)>,
}

impl BruteForce {
    pub fn new(frame: &SceneFrame) -> Self {
        let scene = frame.scene;
        let mut triangles = Vec::new();
        for (ii, inst) in scene.instances.iter().enumerate() {
            let m = frame.transforms[ii];
            let pos = &frame.positions[inst.mesh as usize];
            for (ti, t) in scene.meshes[inst.mesh as usize].indices.iter().enumerate() {
                triangles.push((t.map(|i| Vec3A::from(m.transform_point3(pos[i as usize]))), ii as u32, ti as u32));
            }
        }
        Self { triangles }
    }
}

impl Visibility for BruteForce {
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let r = PreparedRay::new(ray);
        self.triangles.iter().any(|(v, _, _)| r.intersect_triangle(v, t_max).is_some())
    }
}

impl ClosestHit for BruteForce {
    fn closest_hit(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let r = PreparedRay::new(ray);
        let mut best: Option<Hit> = None;
        for (v, instance, triangle) in &self.triangles {
            if let Some((t, b1, b2)) = r.intersect_triangle(v, best.map_or(t_max, |h| h.t)) {
                best = Some(Hit { t, b1, b2, instance: *instance, triangle: *triangle });
            }
        }
        best
    }
}

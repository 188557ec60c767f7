//! Mirrored instances keep their faces' orientation.
//!
//! A placement with a negative determinant (a negative scale: a mirrored copy) reverses the
//! winding of its triangles in world space, so the winding normal (the side an emitter lights,
//! the front a one-sided surface shows) would point into the object while its shading normals,
//! transformed by the inverse transpose, still point out. glTF defines it the other way round
//! (a negative determinant makes the winding clockwise, §3.7.4), as pbrt-v4 does
//! (`transformSwapsHandedness`): the author's orientation is kept. So [`orient_mirrored_instances`]
//! stores a mirrored instance's triangles with two corners swapped: in place when every
//! instance of the mesh is mirrored, else in a copy for the mirrored ones. The sign is read at
//! time 0 (an animation whose scale changes sign keeps that frame's winding).

use crate::Scene;

/// Swaps two corners of every triangle of each mirrored instance's mesh (copying a mesh that
/// unmirrored instances share); returns how many instances were mirrored.
pub fn orient_mirrored_instances(scene: &mut Scene) -> usize {
    let mirrored: Vec<bool> = scene.instances.iter().map(|i| i.motion.at(0.0).determinant() < 0.0).collect();
    // Per mesh: (instances mirrored, instances not).
    let mut uses = vec![(0u32, 0u32); scene.meshes.len()];
    for (instance, &m) in scene.instances.iter().zip(&mirrored) {
        if let Some(u) = uses.get_mut(instance.mesh as usize) {
            if m { u.0 += 1 } else { u.1 += 1 }
        }
    }
    let mut flipped_copy: Vec<Option<u32>> = vec![None; scene.meshes.len()];
    for (mesh, (copy, &(mirrored_uses, plain_uses))) in flipped_copy.iter_mut().zip(&uses).enumerate() {
        if mirrored_uses == 0 {
            continue;
        }
        if plain_uses == 0 {
            flip_winding(&mut scene.meshes[mesh]);
        } else {
            let mut flipped = scene.meshes[mesh].clone();
            flip_winding(&mut flipped);
            *copy = Some(scene.meshes.len() as u32);
            scene.meshes.push(flipped);
        }
    }
    for (instance, &m) in scene.instances.iter_mut().zip(&mirrored) {
        if let (true, Some(copy)) = (m, flipped_copy.get(instance.mesh as usize).copied().flatten()) {
            instance.mesh = copy;
        }
    }
    mirrored.iter().filter(|&&m| m).count()
}

fn flip_winding(mesh: &mut crate::Mesh) {
    mesh.indices.iter_mut().for_each(|t| t.swap(1, 2));
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Instance, Mesh};
    use glimpse_core::{Mat4, Vec3};

    /// The world winding normal of an instance's first triangle.
    fn winding_normal(scene: &Scene, instance: usize) -> Vec3 {
        let inst = &scene.instances[instance];
        let mesh = &scene.meshes[inst.mesh as usize];
        let m = inst.motion.at(0.0);
        let [a, b, c] = mesh.indices[0].map(|i| m.transform_point3(mesh.positions[i as usize]));
        (b - a).cross(c - a).normalize()
    }

    #[test]
    fn a_mirrored_copy_faces_as_its_normals_do() {
        // A quad facing +y, placed as is and mirrored upside down (scale y = −1): the mirrored
        // copy's shading normal points down, and so must its winding.
        let quad = Mesh {
            normals: vec![Vec3::Y; 4],
            ..Mesh::quad("q", 0, [Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 0.0)])
        };
        let up = (quad.positions[1] - quad.positions[0]).cross(quad.positions[2] - quad.positions[0]);
        assert!(up.y > 0.0, "the test quad's winding faces +y");
        let mut scene = Scene { meshes: vec![quad], ..Default::default() };
        let mirror = Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)) * Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
        scene.instances = vec![Instance::fixed(0, Mat4::IDENTITY), Instance::fixed(0, mirror)];
        assert!(winding_normal(&scene, 1).y > 0.9, "before: the mirrored copy's winding faces up, against its normals");
        assert_eq!(orient_mirrored_instances(&mut scene), 1);
        assert_eq!(scene.meshes.len(), 2, "the shared mesh is copied for the mirrored instance");
        assert!(winding_normal(&scene, 0).y > 0.9, "the unmirrored instance is unchanged");
        assert!(winding_normal(&scene, 1).y < -0.9, "the mirrored copy faces down, as its normal");
        // Every instance mirrored: flipped in place, no copy.
        scene.instances.remove(0);
        scene.meshes.truncate(1);
        scene.instances[0].mesh = 0;
        assert_eq!(orient_mirrored_instances(&mut scene), 1);
        assert_eq!(scene.meshes.len(), 1);
        assert!(winding_normal(&scene, 0).y < -0.9);
    }
}

//! The whole precomputation (paper Sec. 4 and 6; Table 3's quantities): BRDF tables for the glossy
//! materials, the lighting cache of every mesh, their octrees — as flat arrays of plain `Copy`
//! types (GPU-uploadable), and its disk cache: `cache_dir()/wavecache/<hash>.bin`, keyed by a
//! hash of the scene's geometry, materials, lights and environment, every parameter, the seed
//! and the crate version. A read failure just recomputes.

use crate::bake::{self, CachePoint, Integrator, MeshCache};
use crate::brdf::{self, BrdfTable, MaterialBrdf};
use crate::haar::{HaarNode, TreeRef};
use crate::half::f32_to_f16_finite;
use crate::points::{self, OctNode};
use crate::{Class, WavecacheParams};
use bytemuck::Pod;
use glimpse_core::Vec3;
use glimpse_render::Stopwatch;
use glimpse_scene::SceneFrame;
use glimpse_trace::ExactTracer;
use std::path::{Path, PathBuf};

/// Bins of cos θ_o in the diffuse albedo tables.
pub const ALBEDO_BINS: u32 = 32;

#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    #[error("wavecache file {path}: {source}")]
    Io { path: String, source: std::io::Error },
    #[error("wavecache file {path}: {message}")]
    Format { path: String, message: String },
}

/// Everything the runtime reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WaveCache {
    pub key: u64,
    /// Per material (res = 0: not tabulated).
    pub brdf_tables: Vec<BrdfTable>,
    pub brdf_trees: Vec<TreeRef>,
    pub brdf_nodes: Vec<HaarNode>,
    /// Per material, [`ALBEDO_BINS`] × (A_d, A_s).
    pub albedo: Vec<[f32; 2]>,
    /// Per instance.
    pub meshes: Vec<MeshCache>,
    pub octree: Vec<OctNode>,
    /// In each mesh's octree leaf order.
    pub points: Vec<CachePoint>,
    /// fp16 RGB irradiance of diffuse points.
    pub irradiance: Vec<[u16; 3]>,
    pub radiance_trees: Vec<TreeRef>,
    pub radiance_nodes: Vec<HaarNode>,
    /// [brdf ms, lighting ms, rays traced] of the run that computed it.
    pub build_info: Vec<f64>,
}

fn bytes<T: Pod>(v: &[T]) -> usize {
    std::mem::size_of_val(v)
}

impl WaveCache {
    /// Bytes of the BRDF part (tables and trees) — Table 3's "pre-storage BRDFs".
    pub fn brdf_bytes(&self) -> usize {
        bytes(&self.brdf_tables) + bytes(&self.brdf_trees) + bytes(&self.brdf_nodes) + bytes(&self.albedo)
    }

    /// Bytes of the lighting part — Table 3's "pre-storage lighting".
    pub fn lighting_bytes(&self) -> usize {
        bytes(&self.meshes)
            + bytes(&self.octree)
            + bytes(&self.points)
            + bytes(&self.irradiance)
            + bytes(&self.radiance_trees)
            + bytes(&self.radiance_nodes)
    }

    pub fn memory_bytes(&self) -> usize {
        self.brdf_bytes() + self.lighting_bytes()
    }

    pub fn point_count(&self) -> usize {
        self.points.len()
    }

    /// Runs the precomputation. `tick` advances the progress bar by units of work (one ω_o map or
    /// one cache point).
    pub fn build(
        frame: &SceneFrame,
        tracer: &ExactTracer,
        p: &WavecacheParams,
        seed: u64,
        key: u64,
        tick: &(dyn Fn(u64) + Sync),
    ) -> WaveCache {
        let scene = frame.scene;
        let mut c = WaveCache { key, ..Default::default() };
        let classes: Vec<Class> = scene.materials.iter().map(|m| p.classify(m)).collect();
        let inst_class: Vec<Class> = scene.instances.iter().map(|i| classes[scene.meshes[i.mesh as usize].material as usize]).collect();

        // BRDFs (only materials used by a glossy instance).
        let sw = Stopwatch::start();
        for (mi, m) in scene.materials.iter().enumerate() {
            let used = scene
                .instances
                .iter()
                .enumerate()
                .any(|(ii, i)| scene.meshes[i.mesh as usize].material as usize == mi && inst_class[ii] == Class::Glossy);
            let mb = MaterialBrdf { model: p.brdf, base: m.base_color, metallic: m.metallic, roughness: m.roughness };
            if used {
                let beta = bake::brdf_beta(m.roughness, p.brdf_beta_scale);
                let t = brdf::tabulate(
                    &mb,
                    p.brdf_grid_u1,
                    p.brdf_grid_u2,
                    p.brdf_res,
                    p.brdf_strata,
                    beta,
                    &mut c.brdf_nodes,
                    &mut c.brdf_trees,
                    tick,
                );
                c.brdf_tables.push(t);
            } else {
                c.brdf_tables.push(BrdfTable::default());
            }
            let (model, r) = if classes[mi] == Class::Diffuse { (p.brdf, m.roughness) } else { (BrdfModel::Lambert, 1.0) };
            c.albedo.extend(brdf::albedo_table(model, r, ALBEDO_BINS, 64));
        }
        let brdf_ms = sw.ms();

        // Lighting.
        let sw = Stopwatch::start();
        let integ = Integrator::new(frame, tracer, p.max_depth, p.brdf);
        let meshes: Vec<_> = (0..scene.instances.len()).map(|i| bake::world_mesh(frame, i)).collect();
        let areas: Vec<f32> = meshes.iter().map(|m| m.area()).collect();
        let total = |class: Class| -> f32 { (0..areas.len()).filter(|&i| inst_class[i] == class).map(|i| areas[i]).sum() };
        let (area_d, area_g) = (total(Class::Diffuse), total(Class::Glossy));
        let mut rays = 0u64;
        for (i, wm) in meshes.iter().enumerate() {
            let class = inst_class[i];
            let material = scene.meshes[scene.instances[i].mesh as usize].material;
            let mut mc = MeshCache {
                class: class as u32,
                material,
                first_node: c.octree.len() as u32,
                first_point: c.points.len() as u32,
                ..Default::default()
            };
            if class == Class::Mirror || areas[i] <= 0.0 {
                c.meshes.push(mc);
                continue;
            }
            let (budget, area_all) = if class == Class::Glossy { (p.glossy_points, area_g) } else { (p.diffuse_points, area_d) };
            let m = ((budget as f64 * areas[i] as f64 / area_all.max(1e-30) as f64).round() as usize).max(p.min_points as usize);
            let samples = points::poisson_points(wm, m, seed ^ (i as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
            let r_max = points::r_max(areas[i], samples.len());
            let map_res =
                if class == Class::Glossy { p.map_resolution(scene.materials[material as usize].roughness).unwrap_or(4) } else { 0 };
            let baked = bake::bake_points(&integ, samples, class, map_res, p, seed.wrapping_add(i as u64 * 7919), tick);
            rays += baked.rays;
            let positions: Vec<Vec3> = baked.samples.iter().map(|s| s.position).collect();
            // Sec. 6 sparsifies "objects with low-frequency reflections": the irradiance points only (a
            // glossy point's map differs from its neighbours' even where their energies agree).
            let strength = if class == Class::Diffuse { p.sparsify } else { 0.0 };
            let mut keep = bake::sparsify(&positions, &baked.energy, r_max, strength, seed ^ i as u64);
            for (k, e) in keep.iter_mut().zip(&baked.energy) {
                *k &= *e >= p.min_energy;
            }
            if !keep.iter().any(|k| *k) {
                keep.iter_mut().for_each(|k| *k = true);
            }
            let mut pts = Vec::new();
            let mut payload_trees = Vec::new();
            for (k, s) in baked.samples.iter().enumerate() {
                if !keep[k] {
                    continue;
                }
                let payload = if class == Class::Glossy {
                    let (nodes, mut t) = baked.maps[k].clone();
                    t.first = c.radiance_nodes.len() as u32;
                    c.radiance_nodes.extend_from_slice(&nodes);
                    payload_trees.push(t);
                    (c.radiance_trees.len() + payload_trees.len() - 1) as u32
                } else {
                    let e = baked.irradiance[k];
                    c.irradiance.push([e.x, e.y, e.z].map(f32_to_f16_finite));
                    (c.irradiance.len() - 1) as u32
                };
                pts.push(CachePoint {
                    position: s.position.to_array(),
                    normal: s.normal.to_array(),
                    shading_normal: s.shading_normal.to_array(),
                    energy: baked.energy[k],
                    payload,
                });
            }
            c.radiance_trees.extend(payload_trees);
            let (nodes, order) = bake::octree(&pts);
            c.points.extend(order.iter().map(|&o| pts[o as usize]));
            c.octree.extend(nodes.iter().copied());
            mc.node_count = nodes.len() as u32;
            mc.point_count = pts.len() as u32;
            mc.points_before = keep.len() as u32;
            mc.r_max = points::r_max(areas[i], pts.len());
            mc.map_res = map_res;
            c.meshes.push(mc);
        }
        c.build_info = vec![brdf_ms, sw.ms(), rays as f64];
        c
    }

    /// Units of work [`WaveCache::build`] ticks (for the progress bar's length).
    pub fn work_units(frame: &SceneFrame, p: &WavecacheParams) -> u64 {
        let scene = frame.scene;
        let glossy_materials = scene
            .materials
            .iter()
            .enumerate()
            .filter(|(mi, m)| {
                p.classify(m) == Class::Glossy && scene.instances.iter().any(|i| scene.meshes[i.mesh as usize].material as usize == *mi)
            })
            .count() as u64;
        let instances = scene.instances.len() as u64;
        glossy_materials * (p.brdf_grid_u1 * p.brdf_grid_u2) as u64
            + (p.diffuse_points + p.glossy_points) as u64
            + instances * p.min_points as u64
    }

    // ----------------------------------------------------------------------------------------
    // Disk cache

    const MAGIC: &'static [u8; 8] = b"WAVECAC1";

    /// Writes the cache to `path` (creating its folder).
    pub fn save(&self, path: &Path) -> Result<(), CacheError> {
        let io = |source| CacheError::Io { path: path.display().to_string(), source };
        if let Some(d) = path.parent() {
            std::fs::create_dir_all(d).map_err(io)?;
        }
        let mut out = Vec::with_capacity(self.memory_bytes() + 256);
        out.extend_from_slice(Self::MAGIC);
        out.extend_from_slice(&self.key.to_le_bytes());
        fn put<T: Pod>(out: &mut Vec<u8>, v: &[T]) {
            out.extend_from_slice(&(std::mem::size_of_val(v) as u64).to_le_bytes());
            out.extend_from_slice(bytemuck::cast_slice(v));
        }
        put(&mut out, &self.brdf_tables);
        put(&mut out, &self.brdf_trees);
        put(&mut out, &self.brdf_nodes);
        put(&mut out, &self.albedo);
        put(&mut out, &self.meshes);
        put(&mut out, &self.octree);
        put(&mut out, &self.points);
        put(&mut out, &self.irradiance);
        put(&mut out, &self.radiance_trees);
        put(&mut out, &self.radiance_nodes);
        put(&mut out, &self.build_info);
        // Write then rename, so a reader never sees half a file.
        let tmp = path.with_extension(format!("tmp{}", std::process::id()));
        std::fs::write(&tmp, &out).map_err(io)?;
        std::fs::rename(&tmp, path).map_err(io)
    }

    /// Reads a cache written by [`WaveCache::save`]; the key must match.
    pub fn load(path: &Path, key: u64) -> Result<WaveCache, CacheError> {
        let data = std::fs::read(path).map_err(|source| CacheError::Io { path: path.display().to_string(), source })?;
        let bad = |message: &str| CacheError::Format { path: path.display().to_string(), message: message.into() };
        if data.len() < 16 || &data[..8] != Self::MAGIC {
            return Err(bad("not a wavecache file"));
        }
        if u64::from_le_bytes(data[8..16].try_into().map_err(|_| bad("short header"))?) != key {
            return Err(bad("key mismatch"));
        }
        let mut at = 16usize;
        fn get<T: Pod>(data: &[u8], at: &mut usize) -> Option<Vec<T>> {
            let len = u64::from_le_bytes(data.get(*at..*at + 8)?.try_into().ok()?) as usize;
            *at += 8;
            let body = data.get(*at..at.checked_add(len)?)?;
            *at += len;
            if !len.is_multiple_of(std::mem::size_of::<T>()) {
                return None;
            }
            Some(bytemuck::pod_collect_to_vec(body))
        }
        let short = || bad("truncated");
        let c = WaveCache {
            key,
            brdf_tables: get(&data, &mut at).ok_or_else(short)?,
            brdf_trees: get(&data, &mut at).ok_or_else(short)?,
            brdf_nodes: get(&data, &mut at).ok_or_else(short)?,
            albedo: get(&data, &mut at).ok_or_else(short)?,
            meshes: get(&data, &mut at).ok_or_else(short)?,
            octree: get(&data, &mut at).ok_or_else(short)?,
            points: get(&data, &mut at).ok_or_else(short)?,
            irradiance: get(&data, &mut at).ok_or_else(short)?,
            radiance_trees: get(&data, &mut at).ok_or_else(short)?,
            radiance_nodes: get(&data, &mut at).ok_or_else(short)?,
            build_info: get(&data, &mut at).ok_or_else(short)?,
        };
        c.validate().map_err(|m| bad(&m))?;
        Ok(c)
    }

    /// Index checks, so a corrupt file is an error rather than a panic at runtime.
    pub fn validate(&self) -> Result<(), String> {
        for m in &self.meshes {
            if (m.first_node + m.node_count) as usize > self.octree.len() || (m.first_point + m.point_count) as usize > self.points.len() {
                return Err("mesh range out of bounds".into());
            }
        }
        for t in self.brdf_trees.iter() {
            if t.count == 0 || (t.first as u64 + t.count as u64) as usize > self.brdf_nodes.len() {
                return Err("BRDF tree out of bounds".into());
            }
        }
        for t in self.radiance_trees.iter() {
            if t.count == 0 || (t.first as u64 + t.count as u64) as usize > self.radiance_nodes.len() {
                return Err("radiance tree out of bounds".into());
            }
        }
        for (mi, t) in self.brdf_tables.iter().enumerate() {
            if t.res > 0 && (t.first_tree as u64 + (t.n_u1 * t.n_u2) as u64) as usize > self.brdf_trees.len() {
                return Err(format!("BRDF table {mi} out of bounds"));
            }
        }
        Ok(())
    }

    /// Where the cache of `key` lives.
    pub fn path_for(key: u64) -> Option<PathBuf> {
        glimpse_render::cache_dir().map(|d| d.join("wavecache").join(format!("{key:016x}.bin")))
    }
}

use glimpse_render::bsdf::BrdfModel;

/// FNV-1a, 64 bit.
pub struct Fnv(pub u64);

impl Default for Fnv {
    fn default() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv {
    pub fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x100_0000_01b3);
        }
    }
    pub fn f32s(&mut self, v: impl IntoIterator<Item = f32>) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
}

/// The disk-cache key: the scene's geometry (world transforms, positions, normals, indices),
/// materials, textures, lights and environment, every parameter that changes the result, the seed
/// and the crate version.
pub fn cache_key(frame: &SceneFrame, p: &WavecacheParams, seed: u64) -> u64 {
    let scene = frame.scene;
    let mut h = Fnv::default();
    h.bytes(env!("CARGO_PKG_VERSION").as_bytes());
    // Every parameter that changes the result (not the progress bar or the disk-cache switch).
    let p = WavecacheParams { disk_cache: true, progress: true, ..p.clone() };
    h.bytes(format!("{p:?} seed={seed}").as_bytes());
    for (i, inst) in scene.instances.iter().enumerate() {
        h.f32s(frame.transforms[i].to_cols_array());
        h.bytes(&inst.mesh.to_le_bytes());
    }
    for (k, m) in scene.meshes.iter().enumerate() {
        h.f32s(frame.positions[k].iter().flat_map(|v| v.to_array()));
        h.f32s(frame.normals[k].iter().flat_map(|v| v.to_array()));
        h.f32s(m.uvs.iter().flat_map(|v| v.to_array()));
        for t in &m.indices {
            h.bytes(bytemuck::cast_slice(t));
        }
        h.bytes(&m.material.to_le_bytes());
    }
    h.bytes(format!("{:?}", scene.materials).as_bytes());
    for t in &scene.textures {
        h.f32s(t.pixels.iter().flat_map(|v| v.to_array()));
    }
    h.bytes(format!("{:?}", frame.lights).as_bytes());
    if let Some(env) = &scene.environment {
        h.f32s([env.scale]);
        h.f32s(env.image.pixels.iter().flat_map(|v| v.to_array()));
    }
    h.0
}

//! The whole precomputation (paper Sec. 4 and 6; Table 3's quantities): BRDF tables for the glossy
//! materials, the lighting cache of every mesh, their octrees — as flat arrays of plain `Copy`
//! types (GPU-uploadable), and its disk cache: `cache_dir()/wavecache/<hash>.bin`, keyed by a
//! hash of the scene's geometry, materials, lights and environment, every parameter, the seed
//! and the crate version. The file is a `glimpse_core::cache_file` (version, XXH3 checksum) and
//! is fully validated before use ([`WaveCache::validate`]); a bad file is reported in one warning
//! line, deleted and recomputed.

use crate::bake::{self, CachePoint, Integrator, MeshCache};
use crate::brdf::{self, BrdfTable, MaterialBrdf};
use crate::haar::{self, HaarNode, TreeRef};
use crate::half::f32_to_f16_finite;
use crate::points::{self, MAX_DEPTH, OctNode};
use crate::{Class, WavecacheParams};
use bytemuck::Pod;
use glimpse_core::Vec3;
use glimpse_core::bounded_read::{ReadError, limit};
use glimpse_core::cache_file::{self, CacheFileError, CacheFormat, PayloadReader};
use glimpse_core::memory_budget::BudgetError;
use glimpse_render::Stopwatch;
use glimpse_render::bsdf::BrdfModel;
use glimpse_scene::{MaterialModel, SceneFrame};
use glimpse_trace::ExactTracer;
use std::path::{Path, PathBuf};

/// [`WaveCache::env_visibility_first`] of a map without a visibility map.
pub const NO_VISIBILITY: u32 = u32::MAX;

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
    /// Per material: its BRDF with a black base colour (res = 0: none), for glossy materials
    /// whose table is not of their own colour ([`WaveCache::brdf_base`]). The BRDF is affine in
    /// the base colour per channel (the diffuse lobe is linear in it, Schlick's F0 and a
    /// conductor's F are), so the BRDF of base c is black + c / b × (b's − black's) exactly, b
    /// the table's base, and the product with the radiance is blended the same way
    /// ([`crate::technique::Runtime::glossy`]).
    pub brdf_black: Vec<BrdfTable>,
    /// Per material: the base colour its `brdf_tables` entry was tabulated with: its own factor
    /// (one table, one product per point), or white where textured or where it shares white
    /// and black tables with materials of other colours ([`BrdfPlan`]).
    pub brdf_base: Vec<[f32; 3]>,
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
    /// Per radiance tree: where its environment visibility map starts in `env_visibility`
    /// (N² bytes, N = 2^levels), or [`NO_VISIBILITY`] where its map holds the environment's
    /// direct light as the paper's do (`env_direct`, [`crate::WavecacheParams::env_direct`]).
    pub env_visibility_first: Vec<u32>,
    /// The visibility maps: per texel, the share of the environment's light arriving, 0–255.
    pub env_visibility: Vec<u8>,
    /// [brdf ms, lighting ms, rays traced] of the run that computed it.
    pub build_info: Vec<f64>,
}

fn bytes<T: Pod>(v: &[T]) -> usize {
    std::mem::size_of_val(v)
}

impl WaveCache {
    /// The irradiance a diffuse cache point stores (its `payload`), decoded from fp16; `None`
    /// for a payload outside the table.
    pub fn irradiance_at(&self, payload: u32) -> Option<Vec3> {
        let f = crate::half::f16_to_f32_finite;
        self.irradiance.get(payload as usize).map(|v| Vec3::new(f(v[0]), f(v[1]), f(v[2])))
    }

    /// Bytes of the BRDF part (tables and trees) — Table 3's "pre-storage BRDFs".
    pub fn brdf_bytes(&self) -> usize {
        bytes(&self.brdf_tables)
            + bytes(&self.brdf_black)
            + bytes(&self.brdf_base)
            + bytes(&self.brdf_trees)
            + bytes(&self.brdf_nodes)
            + bytes(&self.albedo)
    }

    /// Bytes of the lighting part — Table 3's "pre-storage lighting".
    pub fn lighting_bytes(&self) -> usize {
        bytes(&self.meshes)
            + bytes(&self.octree)
            + bytes(&self.points)
            + bytes(&self.irradiance)
            + bytes(&self.radiance_trees)
            + bytes(&self.radiance_nodes)
            + bytes(&self.env_visibility_first)
            + bytes(&self.env_visibility)
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
    ) -> Result<WaveCache, BudgetError> {
        let scene = frame.scene;
        let mut c = WaveCache { key, ..Default::default() };
        let classes: Vec<Class> = scene.materials.iter().map(|m| p.classify(m)).collect();
        let inst_class: Vec<Class> = scene.instances.iter().map(|i| classes[scene.meshes[i.mesh as usize].material as usize]).collect();

        // BRDFs (only materials used by a glossy instance).
        let sw = Stopwatch::start();
        let mut tabulated: std::collections::HashMap<String, BrdfTable> = std::collections::HashMap::new();
        let plan = BrdfPlan::new(frame, p);
        for (mi, m) in scene.materials.iter().enumerate() {
            let (mb, beta) = material_brdf(p, m, plan.roughness[mi]);
            // Equal BRDFs share one table (the headers point at the same trees).
            let mut tabulate = |base: Vec3| {
                let mb = MaterialBrdf { base, ..mb };
                *tabulated.entry(brdf_key(&mb, beta)).or_insert_with(|| {
                    brdf::tabulate(
                        &mb,
                        p.brdf_grid_u1,
                        p.brdf_grid_u2,
                        p.brdf_res,
                        p.brdf_strata,
                        beta,
                        &mut c.brdf_nodes,
                        &mut c.brdf_trees,
                        tick,
                    )
                })
            };
            let (table, black, base) = match plan.tables[mi] {
                None => (BrdfTable::default(), BrdfTable::default(), m.base_color),
                Some(TablePlan::Own) => (tabulate(m.base_color), BrdfTable::default(), m.base_color),
                Some(TablePlan::WhiteAndBlack) => (tabulate(Vec3::ONE), tabulate(Vec3::ZERO), Vec3::ONE),
            };
            c.brdf_tables.push(table);
            c.brdf_black.push(black);
            c.brdf_base.push(base.to_array());
            c.check_budget()?;
            // Eq. 19's albedos: the glTF material's lobes, Lambert's (A_d = 1, A_s = 0) for a
            // `diffuse` one, as `pt` shades it.
            let lambertian = m.model == MaterialModel::Diffuse || classes[mi] != Class::Diffuse;
            let (model, r) = if lambertian { (BrdfModel::Lambert, 1.0) } else { (p.brdf, m.roughness) };
            c.albedo.extend(brdf::albedo_table(model, r, ALBEDO_BINS, 64));
        }
        let brdf_ms = sw.ms();

        // Lighting.
        let sw = Stopwatch::start();
        let mut integ = Integrator::new(frame, tracer, p.max_depth, p.brdf);
        integ.punctual_irradiance = p.caches_punctual(frame.lights.len());
        let meshes: Vec<_> = (0..scene.instances.len()).map(|i| bake::world_mesh(frame, i)).collect();
        let areas: Vec<f32> = meshes.iter().map(|m| m.area()).collect();
        let total = |class: Class| -> f32 { (0..areas.len()).filter(|&i| inst_class[i] == class).map(|i| areas[i]).sum() };
        let (area_d, area_g) = (total(Class::Diffuse), total(Class::Glossy));
        let plan = plan_points(frame, p, &inst_class, &areas);
        let (mut rays, mut enclosed) = (0u64, 0usize);
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
            let two_sided = p.two_sided(i);
            let m = if two_sided { plan.points[i] / 2 } else { plan.points[i] };
            let mut samples = points::poisson_points(wm, m, seed ^ (i as u64).wrapping_mul(0x2545_f491_4f6c_dd1d));
            let r_max = points::r_max(areas[i], samples.len());
            if two_sided {
                // The back side's points: the same positions, both normals turned over, so they
                // cache the back hemisphere's light (and the query's normal term picks the side).
                let backs: Vec<_> =
                    samples.iter().map(|s| points::SurfaceSample { normal: -s.normal, shading_normal: -s.shading_normal, ..*s }).collect();
                samples.extend(backs);
            }
            let map_res = plan.map_res[i];
            let roughness = scene.materials.get(material as usize).map_or(1.0, |m| m.roughness);
            let split_env = class == Class::Glossy && p.split_env(scene.environment.as_ref(), map_res, roughness);
            let map = bake::MapSettings { res: map_res, samples: p.texel_samples, light_samples: p.texel_light_samples, split_env };
            let baked = bake::bake_points(&integ, samples, class, map, p, seed.wrapping_add(i as u64 * 7919), tick);
            rays += baked.rays;
            let positions: Vec<Vec3> = baked.samples.iter().map(|s| s.position).collect();
            // Sec. 6 sparsifies "objects with low-frequency reflections": the irradiance points only (a
            // glossy point's map differs from its neighbours' even where their energies agree).
            let strength = if class == Class::Diffuse { p.sparsify } else { 0.0 };
            let mut keep = bake::sparsify(&positions, &baked.energy, r_max, strength, seed ^ i as u64);
            for ((k, e), buried) in keep.iter_mut().zip(&baked.energy).zip(&baked.enclosed) {
                *k &= *e >= p.min_energy && !buried;
            }
            enclosed += baked.enclosed.iter().filter(|b| **b).count();
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
                    match baked.visibility.get(k) {
                        Some(v) => {
                            c.env_visibility_first.push(c.env_visibility.len() as u32);
                            c.env_visibility.extend_from_slice(v);
                        }
                        None => c.env_visibility_first.push(NO_VISIBILITY),
                    }
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
                    reach: baked.reach[k],
                    payload,
                });
            }
            c.radiance_trees.extend(payload_trees);
            let (nodes, order) = bake::octree(&pts);
            c.points.extend(order.iter().map(|&o| pts[o as usize]));
            c.octree.extend(nodes.iter().copied());
            c.check_budget()?;
            mc.node_count = nodes.len() as u32;
            mc.point_count = pts.len() as u32;
            mc.points_before = keep.len() as u32;
            mc.r_max = points::r_max(areas[i], pts.len());
            mc.map_res = map_res;
            c.meshes.push(mc);
        }
        let _ = (area_d, area_g);
        c.build_info = vec![brdf_ms, sw.ms(), rays as f64, plan.paths as f64, plan.scale, enclosed as f64];
        Ok(c)
    }

    /// Bytes of the cache known before its build, for the memory budget: the planned points with
    /// their octree nodes and payload slots (an fp16 irradiance or a tree header each) and the
    /// BRDF tables' tree headers (one per ω_o of every glossy material). The Haar coefficients
    /// kept (β) depend on the lighting: [`WaveCache::build`] checks them as they grow.
    pub fn estimated_bytes(frame: &SceneFrame, p: &WavecacheParams) -> u64 {
        let (inst_class, areas) = classes_and_areas(frame, p);
        let plan = plan_points(frame, p, &inst_class, &areas);
        let point = (std::mem::size_of::<CachePoint>() + std::mem::size_of::<OctNode>()) as u64;
        let payload = |c: Class| if c == Class::Glossy { std::mem::size_of::<TreeRef>() as u64 } else { 6 };
        let points: u64 = plan.points.iter().zip(&inst_class).map(|(&m, &c)| m as u64 * (point + payload(c))).sum();
        let brdf = Self::brdf_table_count(frame, p) * (p.brdf_grid_u1 * p.brdf_grid_u2) as u64 * std::mem::size_of::<TreeRef>() as u64;
        points + brdf
    }

    /// Refuses a cache in the making that has outgrown the memory budget.
    fn check_budget(&self) -> Result<(), BudgetError> {
        glimpse_core::memory_budget::check(
            "wavecache: the radiance cache (points and Haar coefficients) so far",
            self.memory_bytes() as u64,
        )
    }

    /// BRDF tables the build tabulates ([`BrdfPlan::table_count`]).
    pub fn brdf_table_count(frame: &SceneFrame, p: &WavecacheParams) -> u64 {
        BrdfPlan::new(frame, p).table_count(frame, p)
    }

    /// Units of work [`WaveCache::build`] ticks (for the progress bar's length).
    pub fn work_units(frame: &SceneFrame, p: &WavecacheParams) -> u64 {
        let tables = Self::brdf_table_count(frame, p);
        let (inst_class, areas) = classes_and_areas(frame, p);
        let points: usize = plan_points(frame, p, &inst_class, &areas).points.iter().sum();
        tables * (p.brdf_grid_u1 * p.brdf_grid_u2) as u64 + points as u64
    }

    // ----------------------------------------------------------------------------------------
    // Disk cache: a `glimpse_core::cache_file` (magic, version, length, XXH3 checksum) whose
    // payload is the key and the arrays, each as a u64 byte length and its plain bytes.

    /// Bump when the payload's layout or any array element's layout changes.
    pub const FORMAT: CacheFormat = CacheFormat { magic: *b"WAVECACH", version: 6 };

    /// The payload of [`WaveCache::FORMAT`] as one buffer (tests; [`WaveCache::save`] writes
    /// the parts where they lie).
    pub fn to_payload(&self) -> Vec<u8> {
        self.with_payload_parts(|parts| parts.concat())
    }

    /// Calls `f` with the payload as consecutive parts: the key, then each array's u64 byte
    /// length and its bytes. Never one buffer: a copy of a 2.3 GB cache doubled the process's
    /// peak memory while it was saved.
    fn with_payload_parts<R>(&self, f: impl FnOnce(&[&[u8]]) -> R) -> R {
        use bytemuck::cast_slice;
        let arrays: [&[u8]; 15] = [
            cast_slice(&self.brdf_tables),
            cast_slice(&self.brdf_black),
            cast_slice(&self.brdf_base),
            cast_slice(&self.brdf_trees),
            cast_slice(&self.brdf_nodes),
            cast_slice(&self.albedo),
            cast_slice(&self.meshes),
            cast_slice(&self.octree),
            cast_slice(&self.points),
            cast_slice(&self.irradiance),
            cast_slice(&self.radiance_trees),
            cast_slice(&self.radiance_nodes),
            cast_slice(&self.env_visibility_first),
            &self.env_visibility,
            cast_slice(&self.build_info),
        ];
        let key = self.key.to_le_bytes();
        let lengths = arrays.map(|a| (a.len() as u64).to_le_bytes());
        let mut parts: Vec<&[u8]> = vec![&key];
        for (length, array) in lengths.iter().zip(arrays) {
            parts.push(length);
            parts.push(array);
        }
        f(&parts)
    }

    /// Parses and fully validates ([`WaveCache::validate`]) a payload; the key must match.
    pub fn from_payload(data: &[u8], key: u64) -> Result<WaveCache, String> {
        let mut bytes = data;
        let mut r = PayloadReader::new(&mut bytes, data.len() as u64);
        let c = Self::read_arrays(&mut r, key)?;
        if r.remaining() != 0 {
            return Err(format!("{} bytes after the last array", r.remaining()));
        }
        c.validate()?;
        Ok(c)
    }

    /// The key and the arrays in [`WaveCache::with_payload_parts`]' order, each straight into
    /// its own storage (a length is checked against the bytes left before anything is
    /// allocated). Not validated.
    fn read_arrays(r: &mut PayloadReader, key: u64) -> Result<WaveCache, String> {
        let mut found = [0u8; 8];
        r.read_exact(&mut found).map_err(|e| format!("key: {e}"))?;
        if u64::from_le_bytes(found) != key {
            return Err("key mismatch".into());
        }
        Ok(WaveCache {
            key,
            brdf_tables: r.array("BRDF tables")?,
            brdf_black: r.array("black-base BRDF tables")?,
            brdf_base: r.array("BRDF table base colours")?,
            brdf_trees: r.array("BRDF trees")?,
            brdf_nodes: r.array("BRDF nodes")?,
            albedo: r.array("albedo")?,
            meshes: r.array("meshes")?,
            octree: r.array("octree")?,
            points: r.array("points")?,
            irradiance: r.array("irradiance")?,
            radiance_trees: r.array("radiance trees")?,
            radiance_nodes: r.array("radiance nodes")?,
            env_visibility_first: r.array("environment visibility offsets")?,
            env_visibility: r.array("environment visibility")?,
            build_info: r.array("build info")?,
        })
    }

    /// Writes the cache to `path` (creating its folder) atomically.
    pub fn save(&self, path: &Path) -> Result<(), CacheError> {
        self.with_payload_parts(|parts| cache_file::write_parts(path, Self::FORMAT, parts))
            .map_err(|e| CacheError::Io { path: path.display().to_string(), source: e.into() })
    }

    /// Reads a cache written by [`WaveCache::save`]: header, checksum, key and structure validated.
    pub fn load(path: &Path, key: u64) -> Result<WaveCache, CacheError> {
        let format = |message: String| CacheError::Format { path: path.display().to_string(), message };
        let c = cache_file::read_streamed(path, Self::FORMAT, limit::CACHE, |r| Self::read_arrays(r, key)).map_err(|e| match e {
            CacheFileError::Read(ReadError::Io { source, .. }) => CacheError::Io { path: path.display().to_string(), source },
            other => format(other.to_string()),
        })?;
        c.validate().map_err(format)?;
        Ok(c)
    }

    /// The disk cache's policy ([`cache_file::load_streamed_or_discard`]): the cache at `path` if it is
    /// valid; a missing file is `None`, a bad one is reported in one warning line, deleted, and
    /// `None` (the caller rebuilds).
    pub fn load_or_discard(path: &Path, key: u64) -> Option<WaveCache> {
        cache_file::load_streamed_or_discard(path, Self::FORMAT, limit::CACHE, |r| Self::read_arrays(r, key), WaveCache::validate)
    }

    /// Full structural validation, so that no file — corrupt, or crafted with a valid checksum —
    /// can make the runtime panic, loop or read out of range: every range inside its array, every
    /// octree and Haar tree a proper tree (children after their parent, each node reached exactly
    /// once: no cycles, no sharing), depths within the traversal stacks, and every float finite.
    pub fn validate(&self) -> Result<(), String> {
        let materials = self.brdf_tables.len();
        if self.albedo.len() != materials * ALBEDO_BINS as usize {
            return Err(format!("{} albedo entries for {materials} materials", self.albedo.len()));
        }
        if self.albedo.iter().flatten().any(|v| !v.is_finite()) {
            return Err("non-finite albedo".into());
        }
        if self.build_info.iter().any(|v| !v.is_finite()) {
            return Err("non-finite build info".into());
        }
        for (i, t) in self.brdf_trees.iter().enumerate() {
            validate_haar_tree(&self.brdf_nodes, t).map_err(|m| format!("BRDF tree {i}: {m}"))?;
        }
        for (i, t) in self.radiance_trees.iter().enumerate() {
            validate_haar_tree(&self.radiance_nodes, t).map_err(|m| format!("radiance tree {i}: {m}"))?;
        }
        if self.env_visibility_first.len() != self.radiance_trees.len() {
            return Err(format!("{} visibility offsets for {} radiance trees", self.env_visibility_first.len(), self.radiance_trees.len()));
        }
        for (i, (&first, t)) in self.env_visibility_first.iter().zip(&self.radiance_trees).enumerate() {
            let texels = 1u64 << (2 * t.levels);
            if first != NO_VISIBILITY && (t.levels < 2 || first as u64 + texels > self.env_visibility.len() as u64) {
                return Err(format!("radiance tree {i}: visibility map of {texels} texels at {first} out of range"));
            }
        }
        if self.brdf_black.len() != materials || self.brdf_base.len() != materials {
            return Err(format!(
                "{} black-base BRDF tables and {} base colours for {materials} materials",
                self.brdf_black.len(),
                self.brdf_base.len()
            ));
        }
        if self.brdf_base.iter().flatten().any(|v| !v.is_finite()) {
            return Err("non-finite BRDF table base colour".into());
        }
        for (mi, t) in self.brdf_tables.iter().chain(&self.brdf_black).enumerate() {
            if t.res == 0 {
                continue;
            }
            let trees = t.n_u1 as u64 * t.n_u2 as u64;
            if t.n_u1 == 0 || t.n_u2 == 0 || t.first_tree as u64 + trees > self.brdf_trees.len() as u64 {
                return Err(format!("BRDF table {mi}: grid {}×{} from tree {} out of range", t.n_u1, t.n_u2, t.first_tree));
            }
        }
        if self.irradiance.iter().flatten().any(|&h| !f16_is_finite(h)) {
            return Err("non-finite irradiance".into());
        }
        for (mi, m) in self.meshes.iter().enumerate() {
            let bad = |what: String| Err(format!("mesh {mi}: {what}"));
            if m.class > Class::Mirror as u32 || m.material as usize >= materials {
                return bad(format!("class {} or material {} out of range", m.class, m.material));
            }
            if !m.r_max.is_finite() || m.r_max < 0.0 {
                return bad(format!("r_max {}", m.r_max));
            }
            let nodes_end = m.first_node as u64 + m.node_count as u64;
            let points_end = m.first_point as u64 + m.point_count as u64;
            if nodes_end > self.octree.len() as u64 || points_end > self.points.len() as u64 {
                return bad("node or point range out of bounds".into());
            }
            if m.point_count > 0 && m.node_count == 0 {
                return bad("points without an octree".into());
            }
            let nodes = &self.octree[m.first_node as usize..nodes_end as usize];
            validate_octree(nodes, m.point_count).map_err(|e| format!("mesh {mi}: {e}"))?;
            let payloads = if m.class == Class::Glossy as u32 { self.radiance_trees.len() } else { self.irradiance.len() };
            for p in &self.points[m.first_point as usize..points_end as usize] {
                let floats = p.position.iter().chain(&p.normal).chain(&p.shading_normal).chain([&p.energy, &p.reach]);
                if floats.into_iter().any(|v| !v.is_finite()) {
                    return bad("non-finite cache point".into());
                }
                if p.reach <= 0.0 {
                    return bad(format!("cache point reach {} not positive", p.reach));
                }
                if m.class != Class::Mirror as u32 && p.payload as usize >= payloads {
                    return bad(format!("point payload {} out of range ({payloads})", p.payload));
                }
            }
        }
        Ok(())
    }

    /// Where the cache of `key` lives.
    pub fn path_for(key: u64) -> Option<PathBuf> {
        glimpse_render::structure_cache_dir().map(|d| d.join("wavecache").join(format!("{key:016x}.bin")))
    }
}

/// Levels of the largest half-cube a tree may come from (N = 2^16 ≫ any map resolution); it
/// bounds [`haar::product`]'s fixed stack (3 entries per level + 1 ≤ 64).
pub const MAX_HAAR_LEVELS: u32 = 16;

fn f16_is_finite(h: u16) -> bool {
    h & 0x7c00 != 0x7c00
}

/// A packed Haar tree ([`haar::pack`]) inside `nodes`: in range, each node's 4 children after it
/// and inside the tree, every node reached exactly once from the root, no deeper than `levels`.
fn validate_haar_tree(nodes: &[HaarNode], t: &TreeRef) -> Result<(), String> {
    let end = t.first as u64 + t.count as u64;
    if t.count == 0 || end > nodes.len() as u64 {
        return Err(format!("nodes {}..{end} out of bounds ({})", t.first, nodes.len()));
    }
    if t.levels > MAX_HAAR_LEVELS || t.depth > t.levels {
        return Err(format!("levels {} / depth {} out of range", t.levels, t.depth));
    }
    let tree = &nodes[t.first as usize..end as usize];
    // level[i] + 1 of every node reached so far (0: not reached).
    let mut level = vec![0u32; tree.len()];
    level[0] = 1;
    for (i, n) in tree.iter().enumerate() {
        if level[i] == 0 {
            return Err(format!("node {i} is not reached from the root"));
        }
        if n.c.iter().chain(n.d.iter().flatten()).any(|&h| !f16_is_finite(h)) {
            return Err(format!("node {i}: non-finite coefficient"));
        }
        if n.first_child == haar::NONE {
            continue;
        }
        let (first, l) = (n.first_child as u64, level[i]);
        if first <= i as u64 || first + 4 > tree.len() as u64 || l >= t.levels {
            return Err(format!("node {i}: children at {first} out of order, out of range or too deep"));
        }
        for (c, child) in level.iter_mut().enumerate().skip(first as usize).take(4) {
            if *child != 0 {
                return Err(format!("node {c} has two parents"));
            }
            *child = l + 1;
        }
    }
    Ok(())
}

/// One mesh's octree (indices relative to its first node): children contiguous, after their
/// parent and inside the mesh's nodes, every node reached exactly once, depth ≤ [`MAX_DEPTH`],
/// leaves' points inside the mesh's `point_count`, bounds and normals finite.
fn validate_octree(nodes: &[OctNode], point_count: u32) -> Result<(), String> {
    let mut depth = vec![0u32; nodes.len()];
    if let Some(d) = depth.first_mut() {
        *d = 1;
    }
    for (i, n) in nodes.iter().enumerate() {
        if depth[i] == 0 {
            return Err(format!("octree node {i} is not reached from the root"));
        }
        let floats = n.min.iter().chain(&n.max).chain(&n.normal);
        // An empty node keeps the empty box (±∞): only nodes with points need finite bounds.
        if n.point_count > 0 && floats.into_iter().any(|v| !v.is_finite()) {
            return Err(format!("octree node {i}: non-finite bounds or normal"));
        }
        if n.child_count == 0 {
            if n.first_point as u64 + n.point_count as u64 > point_count as u64 {
                return Err(format!("octree leaf {i}: points out of range"));
            }
            continue;
        }
        let (first, count) = (n.first_child as u64, n.child_count as u64);
        if count > 8 || first <= i as u64 || first + count > nodes.len() as u64 || depth[i] > MAX_DEPTH {
            return Err(format!("octree node {i}: children {first}+{count} out of order, out of range or too deep"));
        }
        let d = depth[i] + 1;
        for (c, child) in depth.iter_mut().enumerate().skip(first as usize).take(count as usize) {
            if *child != 0 {
                return Err(format!("octree node {c} has two parents"));
            }
            *child = d;
        }
    }
    Ok(())
}

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

/// A material's BRDF as the tables tabulate it, at `roughness` ([`BrdfPlan::roughness`]), and
/// its Haar threshold β.
fn material_brdf(p: &WavecacheParams, m: &glimpse_scene::Material, roughness: f32) -> (MaterialBrdf, f64) {
    let mb = MaterialBrdf { model: p.brdf, material: m.model, base: m.base_color, metallic: m.metallic, roughness };
    (mb, bake::brdf_beta(roughness, p.brdf_beta_scale))
}

/// How a glossy material's BRDF is tabulated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TablePlan {
    /// One table with the material's own base colour: one product per cache point.
    Own,
    /// A white-base and a black-base table, which any base colour blends exactly (the BRDF is
    /// affine in it): for a textured material, and, where the tables would pass
    /// `brdf_max_tables`, for every material whose BRDF others share in another colour. Two
    /// products per point instead of one (`million-triangles`' shading at 96 × 64 took 13 →
    /// 20 ms when its three colours of one roughness shared them), and two tables for all the
    /// colours instead of one each (`scenes/extra/forest`'s 400 heads in 6 colours: 180 tables,
    /// 5 GiB, one per colour and roughness; 100 shared, 2.4 GiB).
    WhiteAndBlack,
}

/// Which BRDF tables the build tabulates, per material.
#[derive(Clone, Debug, PartialEq)]
pub struct BrdfPlan {
    /// `None`: no glossy instance uses the material.
    pub tables: Vec<Option<TablePlan>>,
    /// The roughness its tables are tabulated at: its own, or snapped (`brdf_max_tables`).
    pub roughness: Vec<f32>,
}

impl BrdfPlan {
    /// The fastest plan within `p.brdf_max_tables` tables (each about 24 MiB at the defaults;
    /// a scene of many materials would pass the 4 GiB target), in three steps, each taken only
    /// where the one before needs more tables: (1) every glossy material its own table, one
    /// per distinct BRDF, a textured one white and black; (2) materials whose BRDF differs only
    /// in colour share white and black tables; (3) their roughnesses snap to
    /// `brdf_max_tables / (2 × the distinct models and metallics)` levels spread evenly over
    /// their range (ours; the paper tabulates
    /// each material, `profile=paper`: no limit), and the summary line says by how much
    /// ([`BrdfPlan::max_snap`]).
    pub fn new(frame: &SceneFrame, p: &WavecacheParams) -> BrdfPlan {
        let own: Vec<f32> = frame.scene.materials.iter().map(|m| m.roughness).collect();
        let max = Self::max_tables(p);
        let fits = |plan: &BrdfPlan| max == 0 || plan.table_count(frame, p) <= max;
        let plan = Self::with_roughness(frame, p, own.clone(), false);
        if fits(&plan) {
            return plan;
        }
        let plan = Self::with_roughness(frame, p, own, true);
        if fits(&plan) {
            return plan;
        }
        let glossy = || plan.roughness.iter().zip(&plan.tables).filter(|(_, t)| t.is_some()).map(|(&r, _)| r);
        let (lo, hi) = glossy().fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), r| (lo.min(r), hi.max(r)));
        // Each roughness level is tabulated once per model and metallic among the materials
        // (white and black each): `gallery`'s metals and dielectrics are two.
        let variants: std::collections::HashSet<String> = (frame.scene.materials.iter().zip(&plan.tables))
            .filter(|(_, t)| t.is_some())
            .map(|(m, _)| format!("{:?} {:?}", m.model, m.metallic))
            .collect();
        let levels = (max / (2 * variants.len() as u64).max(1)).max(1);
        let snap = |r: f32| {
            if levels == 1 {
                0.5 * (lo + hi)
            } else {
                lo + ((r - lo) * (levels - 1) as f32 / (hi - lo)).round() * (hi - lo) / (levels - 1) as f32
            }
        };
        let snapped = plan.roughness.iter().zip(&plan.tables).map(|(&r, t)| if t.is_some() && hi > lo { snap(r) } else { r }).collect();
        Self::with_roughness(frame, p, snapped, true)
    }

    /// The table limit (0: none): `brdf_max_tables`, and no more than fit
    /// [`crate::BRDF_TABLES_MAX_BYTES`] if every table were as large as it can be
    /// ([`BrdfPlan::max_table_bytes`]), so the tables stay under it at any resolution and grid.
    pub fn max_tables(p: &WavecacheParams) -> u64 {
        match p.brdf_max_tables {
            0 => 0,
            n => (n as u64).min((crate::BRDF_TABLES_MAX_BYTES / Self::max_table_bytes(p)).max(1)),
        }
    }

    /// The most bytes one table can take: a tree per ω_o, each with every node of its N² map's
    /// quadtree ((N² − 1)/3 nodes; 39 MB at the defaults; a table measured 5.8–30 MB).
    pub fn max_table_bytes(p: &WavecacheParams) -> u64 {
        let n2 = (p.brdf_res as u64).pow(2);
        let per_tree = (n2 - 1) / 3 * std::mem::size_of::<HaarNode>() as u64 + std::mem::size_of::<TreeRef>() as u64;
        (p.brdf_grid_u1 * p.brdf_grid_u2) as u64 * per_tree
    }

    /// The plan at these roughnesses; `share_colours`: materials whose BRDF differs only in
    /// colour share white and black tables.
    fn with_roughness(frame: &SceneFrame, p: &WavecacheParams, roughness: Vec<f32>, share_colours: bool) -> BrdfPlan {
        let scene = frame.scene;
        let glossy_used: Vec<bool> = (0..scene.materials.len())
            .map(|mi| {
                scene.instances.iter().any(|i| scene.meshes[i.mesh as usize].material as usize == mi)
                    && p.classify(&scene.materials[mi]) == Class::Glossy
            })
            .collect();
        let colourless = |mi: usize| {
            let (mb, beta) = material_brdf(p, &scene.materials[mi], roughness[mi]);
            brdf_key(&MaterialBrdf { base: Vec3::ZERO, ..mb }, beta)
        };
        // Per colourless BRDF: its colours.
        let mut colours: std::collections::HashMap<String, std::collections::HashSet<String>> = Default::default();
        for (mi, m) in scene.materials.iter().enumerate().filter(|&(mi, _)| glossy_used[mi]) {
            colours.entry(colourless(mi)).or_default().insert(format!("{:?}", m.base_color));
        }
        let plan = |mi: usize| {
            let textured = scene.base_color_varies(mi as u32);
            if textured || (share_colours && colours[&colourless(mi)].len() > 1) { TablePlan::WhiteAndBlack } else { TablePlan::Own }
        };
        let tables = (0..scene.materials.len()).map(|mi| glossy_used[mi].then(|| plan(mi))).collect();
        BrdfPlan { tables, roughness }
    }

    /// The distinct tables: one per distinct BRDF among the planned (base, roughness) pairs.
    pub fn table_count(&self, frame: &SceneFrame, p: &WavecacheParams) -> u64 {
        let mut keys = std::collections::HashSet::new();
        for ((m, plan), &r) in frame.scene.materials.iter().zip(&self.tables).zip(&self.roughness) {
            let (mb, beta) = material_brdf(p, m, r);
            let bases = match plan {
                None => vec![],
                Some(TablePlan::Own) => vec![m.base_color],
                Some(TablePlan::WhiteAndBlack) => vec![Vec3::ONE, Vec3::ZERO],
            };
            keys.extend(bases.into_iter().map(|base| brdf_key(&MaterialBrdf { base, ..mb }, beta)));
        }
        keys.len() as u64
    }

    /// The largest change of a glossy material's roughness by the snapping (0: none).
    pub fn max_snap(&self, frame: &SceneFrame) -> f32 {
        frame.scene.materials.iter().zip(&self.roughness).map(|(m, &r)| (m.roughness - r).abs()).fold(0.0, f32::max)
    }
}

/// What makes two BRDF tables equal: every parameter [`brdf::tabulate`] reads of the material
/// (`Debug` prints each float exactly), and β. Real scenes repeat one material under many
/// names (an OBJ's objects, a glTF's duplicated materials, a scene file's placements): 400 such
/// placements of one head tabulated 400 tables, 9 GiB.
fn brdf_key(mb: &MaterialBrdf, beta: f64) -> String {
    format!("{mb:?} {beta:?}")
}

/// Each instance's class and world-space area.
pub fn classes_and_areas(frame: &SceneFrame, p: &WavecacheParams) -> (Vec<Class>, Vec<f32>) {
    let scene = frame.scene;
    let classes: Vec<Class> = scene.materials.iter().map(|m| p.classify(m)).collect();
    let inst_class = scene.instances.iter().map(|i| classes[scene.meshes[i.mesh as usize].material as usize]).collect();
    let areas = (0..scene.instances.len()).map(|i| bake::world_mesh(frame, i).area()).collect();
    (inst_class, areas)
}

/// How many cache points each instance gets, and the paths the lighting precomputation traces
/// for them.
#[derive(Clone, Debug, PartialEq)]
pub struct PointPlan {
    /// Per instance (0 for mirrors and zero-area meshes).
    pub points: Vec<usize>,
    /// Per instance: the glossy radiance-map resolution (0 for diffuse).
    pub map_res: Vec<u32>,
    /// Σ points × paths per point (irradiance samples, or texels × samples per texel).
    pub paths: u64,
    /// Per instance: its points × paths per point.
    pub instance_paths: Vec<u64>,
    /// The factor the point budgets were multiplied by to fit `path_budget` (1: they fit).
    pub scale: f64,
}

/// Points per instance: the class's budget shared by area (at least `min_points` per mesh), all
/// scaled down together when the paths they need exceed `p.path_budget` (0: no limit). Why a
/// budget: the point counts are per scene, so a scene with much glossy area (each glossy point
/// traces texels × `texel_samples` paths, 49K at roughness 0.12) cost minutes (`glints` 206M
/// paths, 92 s; `textured-glossy` 463 s); the budget keeps any scene near the tuned scenes' cost
/// (`glossy`: 20.9 s) and leaves those unchanged.
///
/// No mesh's points are closer than `p.min_spacing` × the scene's diagonal (r_max): a class's
/// budget is shared by its area alone, so a class of tiny total area took its whole budget there
/// (`sponza-interior`'s 0.2 m² emitter, the one diffuse mesh: 20,000 points, 10.2M of 78.8M
/// paths, while 7,541 m² of glossy Sponza shared 4,184 points). The paths saved go to the other
/// meshes when the budget binds.
pub fn plan_points(frame: &SceneFrame, p: &WavecacheParams, inst_class: &[Class], areas: &[f32]) -> PointPlan {
    let scene = frame.scene;
    // r_max = √(A / (2√3 M)) ≥ r_min  ⇔  M ≤ A / (2√3 r_min²).
    let r_min = p.min_spacing as f64 * frame.bounds.extent().length() as f64;
    let most_points = |area: f64| if r_min > 0.0 { (area / (2.0 * 3f64.sqrt() * r_min * r_min)).floor() } else { f64::INFINITY };
    let total = |class: Class| -> f64 { (0..areas.len()).filter(|&i| inst_class[i] == class).map(|i| areas[i] as f64).sum() };
    let (area_d, area_g) = (total(Class::Diffuse), total(Class::Glossy));
    let map_res: Vec<u32> = (0..areas.len())
        .map(|i| {
            let material = scene.meshes[scene.instances[i].mesh as usize].material as usize;
            if inst_class[i] == Class::Glossy { p.map_resolution(scene.materials[material].roughness).unwrap_or(4) } else { 0 }
        })
        .collect();
    // A glossy mesh's fewest points by its curvature (`curvature_deg`).
    let theta = p.curvature_deg.to_radians() as f64;
    let curved: Vec<usize> = (0..areas.len())
        .map(|i| {
            if inst_class[i] != Class::Glossy || theta <= 0.0 || areas[i] <= 0.0 {
                return 0;
            }
            (bake::world_mesh(frame, i).normal_coverage() as f64 / (std::f64::consts::PI * theta * theta)).ceil() as usize
        })
        .collect();
    let per_point = |i: usize| -> u64 {
        match inst_class[i] {
            Class::Glossy => crate::halfcube::HalfCube::new(map_res[i]).texels() as u64 * p.texel_samples as u64,
            _ => p.irradiance_samples as u64,
        }
    };
    let plan = |scale: f64, curved: &[usize]| -> PointPlan {
        let points: Vec<usize> = (0..areas.len())
            .map(|i| {
                let (budget, area_all) = match inst_class[i] {
                    Class::Mirror => return 0,
                    Class::Glossy => (p.glossy_points, area_g),
                    Class::Diffuse => (p.diffuse_points, area_d),
                };
                if areas[i] <= 0.0 {
                    return 0;
                }
                let share = (budget as f64 * scale * areas[i] as f64 / area_all.max(1e-30)).round();
                let fewest = (p.min_points as usize).max(curved[i]);
                let one_side = (share.min(most_points(areas[i] as f64)) as usize).max(fewest);
                // Both sides of an instance whose back is seen: the same density on each.
                if p.two_sided(i) { 2 * one_side } else { one_side }
            })
            .collect();
        let instance_paths: Vec<u64> = points.iter().enumerate().map(|(i, &m)| m as u64 * per_point(i)).collect();
        PointPlan { points, map_res: map_res.clone(), paths: instance_paths.iter().sum(), instance_paths, scale }
    };
    let full = plan(1.0, &curved);
    if p.path_budget > 0 && full.paths > p.path_budget {
        // Scale both budgets by the ratio (the per-mesh minimum makes the result a little over it).
        return plan(p.path_budget as f64 / full.paths as f64, &curved);
    }
    // Too few paths: both budgets scale up to the floor (each mesh still capped by `min_spacing`),
    // by the ratio of the plan by area alone: the curvature minimum, which the scaled shares
    // mostly pass, must not shrink the others' scale (`scenes/extra/sponza-studio`: 7.3 → 6.1×,
    // RMSE against 1,024-spp `pt` 0.214 → 0.225).
    let floor = if p.path_budget > 0 { p.path_floor.min(p.path_budget) } else { p.path_floor };
    let by_area = plan(1.0, &vec![0; curved.len()]).paths;
    if full.paths > 0 && full.paths < floor && by_area > 0 {
        return plan(floor as f64 / by_area as f64, &curved);
    }
    full
}

/// Paths in the pilot of [`mean_rays_per_path`].
pub const PILOT_PATHS: usize = 2048;

/// Mean rays one precompute path traces on this scene (at least 1): a pilot of [`PILOT_PATHS`]
/// irradiance paths from points spread over the meshes as the plan's paths are. Why: the path
/// budget counts paths, but a closed interior's paths bounce to `max_depth` with a shadow ray at
/// every vertex while an open scene's escape after a bounce or two, so equal path counts cost
/// minutes on one and seconds on the other (`sponza-interior`: 220 s under the 80M-path budget).
pub fn mean_rays_per_path(frame: &SceneFrame, tracer: &ExactTracer, p: &WavecacheParams, seed: u64) -> f64 {
    use rayon::prelude::*;
    let (inst_class, areas) = classes_and_areas(frame, p);
    let plan = plan_points(frame, p, &inst_class, &areas);
    let total: u64 = plan.instance_paths.iter().sum();
    if total == 0 {
        return 1.0;
    }
    let mut rng = glimpse_core::Rng::new(seed, 0x9170);
    let mut starts = Vec::new();
    for (i, &paths) in plan.instance_paths.iter().enumerate() {
        let n = (PILOT_PATHS as f64 * paths as f64 / total as f64).round() as usize;
        if n > 0 {
            starts.extend(bake::world_mesh(frame, i).sample(n, &mut rng));
        }
    }
    if starts.is_empty() {
        return 1.0;
    }
    let integ = Integrator::new(frame, tracer, p.max_depth, p.brdf);
    let rays: u64 =
        starts.par_iter().enumerate().map(|(k, s)| integ.irradiance(s, &mut glimpse_core::Rng::new(seed ^ 0x9170, k as u64)).1).sum();
    (rays as f64 / starts.len() as f64).max(1.0)
}

/// Bumped when the precomputation's result changes for the same scene and parameters, so a
/// cache written by older code is not read: 2 = the materials' own models (a conductor's
/// Fresnel, a Lambertian `diffuse`) in the BRDF and albedo tables (session 23); 3 = the BRDF
/// tables' plan ([`BrdfPlan`], session 27).
const CACHE_REVISION: u32 = 3;

/// The disk-cache key: the scene's geometry (world transforms, positions, normals, indices),
/// materials, textures, lights and environment, every parameter that changes the result, the seed
/// and the crate version, results revision ([`glimpse_render::RESULTS_REVISION`]) and
/// [`CACHE_REVISION`].
pub fn cache_key(frame: &SceneFrame, p: &WavecacheParams, seed: u64) -> u64 {
    let scene = frame.scene;
    let mut h = Fnv::default();
    h.bytes(env!("CARGO_PKG_VERSION").as_bytes());
    h.bytes(&glimpse_render::RESULTS_REVISION.to_le_bytes());
    h.bytes(&CACHE_REVISION.to_le_bytes());
    // Every parameter that changes the cache, and none that only the runtime reads.
    let p = p.precompute_part();
    h.bytes(format!("{p:?} seed={seed}").as_bytes());
    for (i, inst) in scene.instances.iter().enumerate() {
        h.f32s(frame.transforms[i].to_cols_array());
        h.bytes(&inst.mesh.to_le_bytes());
    }
    for (k, m) in scene.meshes.iter().enumerate() {
        h.f32s(frame.positions[k].iter().flat_map(|v| v.to_array()));
        h.f32s(frame.normals[k].iter().flat_map(|v| v.to_array()));
        h.f32s(m.uvs.iter().flat_map(|v| v.to_array()));
        h.f32s(m.colors.iter().flat_map(|v| v.to_array()));
        h.f32s(m.tangents.iter().flat_map(|v| v.to_array()));
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

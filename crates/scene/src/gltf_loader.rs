//! glTF 2.0 loader (`.gltf` with external or `data:` buffers, and `.glb`), on top of the `gltf`
//! crate. It renders the default scene (else the first; else every root node).
//!
//! What becomes what:
//! * Meshes: each triangles-mode primitive becomes one [`Mesh`] with one material (POSITION,
//!   NORMAL, TEXCOORD_0, COLOR_0 as a linear factor of the base colour, indices). Other modes (points, lines, strips, fans) are skipped with a
//!   warning. Primitives are converted once per glTF mesh and shared by every node using it.
//! * Nodes: the hierarchy is flattened; every node with a mesh adds one [`Instance`] per
//!   primitive with the node's world transform (`parent · T · R · S`).
//! * Materials (metallic-roughness): base colour factor (alpha ignored) × base colour texture
//!   (8/16-bit images are sRGB-decoded to linear RGB with `srgb_decode`, float images taken as
//!   linear; its `KHR_texture_transform` is applied to the primitive's uvs), roughness and metallic factors, emission = `emissiveFactor` ×
//!   `KHR_materials_emissive_strength` (read from the raw JSON, since the workspace does not
//!   enable that `gltf` feature). Emission is radiance in W/(m²·sr). An emissive texture is
//!   read per texel by the references ([`EmissionMap`]); its mean × the factor is the
//!   material's one emission (the light selection's weight, the RSM's lights). `KHR_materials_transmission` (factor ≥ 0.5) makes
//!   the material smooth glass (the dielectric, `KHR_materials_ior`'s index or 1.5, tinted by
//!   the base colour; a rough one with a warning). A metallic-roughness texture (raw G
//!   roughness, B metallic) is read per texel by the references ([`MetallicRoughnessMap`]) and
//!   its mean × the factors is the material's one BRDF for the techniques; where its uvs differ
//!   from the base colour texture's (another set or transform) the mean alone is used (warning).
//!   A normal texture (raw, tangent space) bends the shading normal per texel for every
//!   technique ([`NormalMap`]; the tangent frame from the `TANGENT` attribute where the
//!   primitive has one, else from the triangle's uvs, as pbrt-v4 builds it),
//!   on the base colour texture's uvs only (else ignored, warning). Occlusion textures, alpha
//!   mode BLEND and texture sets other than 0 are ignored with one warning each, and every other
//!   extension the file uses is named in one warning.
//! * Camera: the first perspective camera node in depth-first order, at time 0: position, target
//!   = position + forward (the node's −Z), up (the node's +Y), `yfov`.
//! * Lights (`KHR_lights_punctual`): point, spot (inner/outer cone half-angles) and directional,
//!   at the node's origin, light travelling along the node's −Z, moving with the node.
//!   **Units**: glTF gives point and spot intensity in candela (lm/sr) and directional in lux
//!   (lm/m²); we use `intensity × color` unchanged as W/sr and W/m², i.e. one renderer unit per
//!   photometric unit with no 683 lm/W factor. Emission factors are taken as radiance the same
//!   way, so lights and emitters keep the balance that real-time glTF viewers show. `range` is
//!   ignored (falloff is inverse-square).
//! * Animation: translation, rotation and scale channels of every animation clip (played
//!   together; if two channels drive the same node property the first wins). LINEAR and STEP are
//!   exact at keys; CUBICSPLINE uses the spline's value keys, linearly (warning). An instance or
//!   light whose node or any ancestor is animated gets [`Motion::Keyframes`] of its world
//!   transform, sampled at the union of its chain's key times (a STEP jump gets two keys at the
//!   same time, the value before and after). World matrices are decomposed into
//!   translation/rotation/scale, so shear from a non-uniformly scaled rotating parent is lost.
//! * Skins and morph targets: ignored with a warning (meshes are drawn in their rest pose).
//! * Errors name the file: unreadable → [`SceneError::Io`]; malformed JSON/GLB or invalid
//!   references → [`SceneError::Parse`] with the parser's message (serde's line and column).
//!   Meshes that no node of the scene places are not loaded. Accessors are checked (type, count,
//!   stride) before reading, because the `gltf` readers
//!   assume valid data; a panic inside the `gltf` crate is turned into an error. Out-of-range
//!   vertex indices and NaN are left to [`crate::validate`].

use crate::obj_loader::guard;
use crate::{
    AlphaMask, Bitangent, Camera, EmissionMap, Instance, Light, Material, MaterialModel, Mesh, MetallicRoughnessMap, Motion, NormalMap,
    NormalMapShadowing, Scene, SceneError, Transform, TransformKey,
};
use glimpse_core::bounded_read::{check_file, limit, read_bounded};
use glimpse_core::image::srgb_decode;
use glimpse_core::{Image, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

/// The extensions this loader reads (any other the file uses is named in a warning).
const READ_EXTENSIONS: [&str; 5] =
    ["KHR_lights_punctual", "KHR_materials_emissive_strength", "KHR_texture_transform", "KHR_materials_transmission", "KHR_materials_ior"];

pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let bytes = read_bounded(path, "glTF file", limit::MESH).map_err(|e| SceneError::io(path, e.reason()))?;
    guard(path, "glTF", || {
        let (doc, loader) = Loader::new(path, &bytes)?;
        loader.run(&doc)
    })?
}

/// One translation, rotation or scale track of one node.
struct Channel {
    property: Property,
    times: Vec<f32>,
    /// xyz (translation, scale) or xyzw (rotation).
    values: Vec<Vec4>,
    step: bool,
}

impl Channel {
    /// The value at `t`; with `left`, the limit from before `t` (differs from the value at `t`
    /// only at a STEP key).
    fn sample(&self, t: f32, left: bool) -> Vec4 {
        let n = self.times.len();
        if t <= self.times[0] {
            return self.values[0];
        }
        if t > self.times[n - 1] || (!left && t == self.times[n - 1]) {
            return self.values[n - 1];
        }
        // The segment [i, i + 1] containing t (for `left`, the one ending at t).
        let i = if left { self.times.partition_point(|&k| k < t) } else { self.times.partition_point(|&k| k <= t) } - 1;
        let (a, b) = (self.values[i], self.values[i + 1]);
        if self.step {
            return a;
        }
        let s = ((t - self.times[i]) / (self.times[i + 1] - self.times[i]).max(f32::MIN_POSITIVE)).clamp(0.0, 1.0);
        match self.property {
            Property::Rotation => Vec4::from(Quat::from_vec4(a).normalize().slerp(Quat::from_vec4(b).normalize(), s)),
            _ => a.lerp(b, s),
        }
    }
}

/// Conversion state; the glTF document itself is passed alongside, so that its node, mesh and
/// material views can be held while the loader changes.
struct Loader<'a> {
    path: &'a Path,
    buffers: Vec<gltf::buffer::Data>,
    /// The raw JSON, for extensions the `gltf` crate is not built to read.
    json: gltf::json::Value,
    scene: Scene,
    /// Per node: its parent, rest transform and animation tracks.
    parent: Vec<Option<usize>>,
    rest: Vec<Transform>,
    rest_matrix: Vec<Mat4>,
    channels: Vec<Vec<Channel>>,
    /// glTF mesh index → our mesh ids (one per kept primitive).
    meshes: HashMap<usize, Vec<u32>>,
    /// glTF material index (`None`: the default material) → our material id.
    materials: HashMap<Option<usize>, u32>,
    /// (glTF image index, sRGB-decoded) → our texture id (`None`: could not be decoded).
    textures: HashMap<(usize, bool), Option<u32>>,
    /// Per glTF image: its alpha channel as a coverage texture (`None`: it has none).
    coverages: HashMap<usize, Option<u32>>,
    /// Ignored features → how often, reported as one warning each.
    ignored: BTreeMap<&'static str, usize>,
}

impl<'a> Loader<'a> {
    fn new(path: &'a Path, bytes: &[u8]) -> Result<(gltf::Document, Self), SceneError> {
        let parse = |e: &dyn std::fmt::Display| SceneError::parse(path, e);
        let json_bytes = if bytes.starts_with(b"glTF") {
            gltf::Glb::from_slice(bytes).map_err(|e| parse(&e))?.json.into_owned()
        } else {
            bytes.to_vec()
        };
        let json: gltf::json::Value = gltf::json::deserialize::from_slice(&json_bytes).map_err(|e| parse(&e))?;
        check_positions(&json).map_err(|m| parse(&m))?;
        let gltf::Gltf { document: doc, mut blob } = gltf::Gltf::from_slice(bytes).map_err(|e| parse(&e))?;

        let base = path.parent().unwrap_or(Path::new(""));
        let mut buffers = Vec::new();
        for b in doc.buffers() {
            let what = match b.source() {
                gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => format!("buffer {} ('{uri}')", b.index()),
                _ => format!("buffer {}", b.index()),
            };
            // External files are read here, bounded (regular files under the mesh limit); the
            // `gltf` importer would read a `/dev/zero` uri until memory runs out.
            let external = match b.source() {
                gltf::buffer::Source::Uri(uri) => uri_path(base, uri),
                gltf::buffer::Source::Bin => None,
            };
            let data = match external {
                Some(file) => {
                    let mut bytes =
                        read_bounded(&file, "glTF buffer", limit::MESH).map_err(|e| SceneError::io(path, format!("{what}: {e}")))?;
                    bytes.resize(bytes.len().next_multiple_of(4), 0);
                    gltf::buffer::Data(bytes)
                }
                None => gltf::buffer::Data::from_source_and_blob(b.source(), Some(base), &mut blob).map_err(|e| match e {
                    gltf::Error::Io(e) => SceneError::io(path, format!("{what}: {e}")),
                    e => parse(&format!("{what}: {e}")),
                })?,
            };
            if data.len() < b.length() {
                return Err(parse(&format!("{what}: declares {} bytes but holds {}", b.length(), data.len())));
            }
            buffers.push(data);
        }

        let n = doc.nodes().len();
        let mut parent = vec![None; n];
        for node in doc.nodes() {
            for child in node.children() {
                if parent[child.index()].replace(node.index()).is_some() {
                    return Err(parse(&format!("node {} has more than one parent", child.index())));
                }
            }
        }
        for start in 0..n {
            let (mut p, mut steps) = (parent[start], 0);
            while let Some(q) = p {
                steps += 1;
                if steps > n {
                    return Err(parse(&format!("the node hierarchy has a cycle through node {start}")));
                }
                p = parent[q];
            }
        }
        let rest = doc
            .nodes()
            .map(|node| {
                let (t, r, s) = node.transform().decomposed();
                Transform { translation: Vec3::from_array(t), rotation: Quat::from_array(r), scale: Vec3::from_array(s) }
            })
            .collect();
        let rest_matrix = doc.nodes().map(|node| Mat4::from_cols_array_2d(&node.transform().matrix())).collect();
        let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
        let loader = Self {
            path,
            buffers,
            json,
            scene: Scene { name, ..Default::default() },
            parent,
            rest,
            rest_matrix,
            channels: (0..n).map(|_| Vec::new()).collect(),
            meshes: HashMap::new(),
            materials: HashMap::new(),
            textures: HashMap::new(),
            coverages: HashMap::new(),
            ignored: BTreeMap::new(),
        };
        Ok((doc, loader))
    }

    fn parse_err(&self, message: String) -> SceneError {
        SceneError::parse(self.path, message)
    }

    fn warn(&mut self, message: String) {
        self.scene.warnings.push(format!("{}: {message}", self.path.display()));
    }

    fn ignore(&mut self, what: &'static str) {
        *self.ignored.entry(what).or_default() += 1;
    }

    fn run(mut self, doc: &gltf::Document) -> Result<Scene, SceneError> {
        // An extension the file uses and nothing here reads changes what the author sees, so
        // it is named (a required one the `gltf` crate does not know is already an error).
        let unread: Vec<&str> = doc.extensions_used().filter(|e| !READ_EXTENSIONS.contains(e)).collect();
        if !unread.is_empty() {
            self.warn(format!("ignored glTF extensions {} (their effect is not rendered)", unread.join(", ")));
        }
        self.read_animations(doc)?;
        let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => {
                if doc.scenes().len() > 1 {
                    self.warn(format!("the file has {} scenes; loading scene {} only", doc.scenes().len(), s.index()));
                }
                s.nodes().map(|n| n.index()).collect()
            }
            None => (0..self.parent.len()).filter(|&i| self.parent[i].is_none()).collect(),
        };

        // Depth-first, parents before children, so world matrices compose in one pass.
        let nodes: Vec<gltf::Node> = doc.nodes().collect();
        let mut world = vec![Mat4::IDENTITY; nodes.len()];
        let mut animated = vec![false; nodes.len()];
        let mut visited = vec![false; nodes.len()];
        let mut stack: Vec<usize> = roots.into_iter().rev().collect();
        while let Some(i) = stack.pop() {
            // A root listed twice (invalid, but seen) would otherwise draw its subtree twice.
            if std::mem::replace(&mut visited[i], true) {
                continue;
            }
            let node = &nodes[i];
            let (parent_world, parent_animated) = self.parent[i].map_or((Mat4::IDENTITY, false), |p| (world[p], animated[p]));
            world[i] = parent_world * self.rest_matrix[i];
            animated[i] = parent_animated || !self.channels[i].is_empty();
            let motion = if animated[i] { Motion::Keyframes(self.world_keys(i)) } else { Motion::Fixed(world[i]) };

            if let Some(mesh) = node.mesh() {
                if node.skin().is_some() {
                    self.ignore("skins (meshes drawn in their rest pose)");
                }
                for id in self.mesh(&mesh)? {
                    self.scene.instances.push(Instance { mesh: id, motion: motion.clone() });
                }
            }
            if let Some(light) = node.light() {
                let light = self.light(&light)?;
                self.scene.lights.push(light.with_motion(motion.clone()));
            }
            if let Some(camera) = node.camera() {
                self.camera(&camera, &motion, animated[i]);
            }
            stack.extend(node.children().map(|c| c.index()).collect::<Vec<_>>().into_iter().rev());
        }

        let ignored = std::mem::take(&mut self.ignored);
        for (what, count) in ignored {
            self.warn(format!("ignored {what} ({count}×)"));
        }
        Ok(self.scene)
    }

    /// Reads every translation/rotation/scale channel into `self.channels`.
    fn read_animations(&mut self, doc: &gltf::Document) -> Result<(), SceneError> {
        let root = doc.as_json();
        for anim in doc.animations() {
            for (ci, ch) in anim.channels().enumerate() {
                let what = format!("animation {} channel {ci}", anim.index());
                // gltf-json does not validate channel targets, and the typed view unwraps them.
                let target = &root.animations[anim.index()].channels[ci].target;
                if target.node.value() >= root.nodes.len() {
                    return Err(self.parse_err(format!("{what}: target node {} does not exist", target.node.value())));
                }
                if !matches!(target.path, gltf::json::validation::Checked::Valid(_)) {
                    return Err(self.parse_err(format!("{what}: unknown target path")));
                }
                let node = ch.target().node().index();
                let property = ch.target().property();
                if property == Property::MorphTargetWeights {
                    self.ignore("morph-target weight animations");
                    continue;
                }
                if self.channels[node].iter().any(|c| c.property == property) {
                    self.warn(format!("{what}: node {node} already has a {property:?} track; this one is ignored"));
                    continue;
                }
                let sampler = ch.sampler();
                let input = sampler.input();
                let output = sampler.output();
                self.check_accessor(&input, &[DataType::F32], Dimensions::Scalar)
                    .map_err(|m| self.parse_err(format!("{what} input: {m}")))?;
                let (types, dims): (&[DataType], _) = match property {
                    Property::Rotation => (&[DataType::F32, DataType::I8, DataType::U8, DataType::I16, DataType::U16], Dimensions::Vec4),
                    _ => (&[DataType::F32], Dimensions::Vec3),
                };
                self.check_accessor(&output, types, dims).map_err(|m| self.parse_err(format!("{what} output: {m}")))?;

                let buffers = &self.buffers;
                let reader = ch.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
                let missing = || self.parse_err(format!("{what}: its data lies outside its buffer"));
                let times: Vec<f32> = reader.read_inputs().ok_or_else(missing)?.collect();
                let values: Vec<Vec4> = match reader.read_outputs().ok_or_else(missing)? {
                    gltf::animation::util::ReadOutputs::Translations(it) => it.map(|v| Vec3::from_array(v).extend(0.0)).collect(),
                    gltf::animation::util::ReadOutputs::Scales(it) => it.map(|v| Vec3::from_array(v).extend(0.0)).collect(),
                    gltf::animation::util::ReadOutputs::Rotations(r) => r.into_f32().map(Vec4::from_array).collect(),
                    gltf::animation::util::ReadOutputs::MorphTargetWeights(_) => continue,
                };
                let cubic = sampler.interpolation() == Interpolation::CubicSpline;
                let values: Vec<Vec4> = if cubic {
                    self.ignore("CUBICSPLINE tangents (value keys interpolated linearly)");
                    values.chunks_exact(3).map(|c| c[1]).collect()
                } else {
                    values
                };
                if times.len() != values.len() {
                    return Err(self.parse_err(format!("{what}: {} key times but {} values", times.len(), values.len())));
                }
                if times.iter().any(|t| !t.is_finite()) || times.windows(2).any(|w| w[1] < w[0]) {
                    return Err(self.parse_err(format!("{what}: key times must be finite and increasing")));
                }
                let step = sampler.interpolation() == Interpolation::Step;
                self.channels[node].push(Channel { property, times, values, step });
            }
        }
        Ok(())
    }

    /// Checks what the `gltf` readers assume (they index and assert rather than fail).
    fn check_accessor(&self, a: &gltf::Accessor, types: &[DataType], dims: Dimensions) -> Result<(), String> {
        if !types.contains(&a.data_type()) || a.dimensions() != dims {
            return Err(format!("accessor {} is {:?} {:?}, expected {dims:?} of {types:?}", a.index(), a.dimensions(), a.data_type()));
        }
        if a.count() == 0 {
            return Err(format!("accessor {} is empty", a.index()));
        }
        if let Some(view) = a.view()
            && view.stride().is_some_and(|s| s < a.size())
        {
            return Err(format!("accessor {}: byteStride is smaller than one element", a.index()));
        }
        // Every count against the bytes that back it, before the readers allocate.
        let (index, count, elem) = (a.index(), a.count() as u64, a.size() as u64);
        match a.view() {
            Some(view) => {
                let stride = view.stride().unwrap_or(a.size()) as u64;
                let need = a.offset() as u64 + stride * (count - 1) + elem;
                self.check_view(&view, need).map_err(|m| format!("accessor {index}: {count} elements {m}"))?;
            }
            None => {
                // Zeros plus sparse values: at most as many bytes as the file's buffers hold (a
                // 719-byte file must not ask for 2^31 elements).
                let total: u64 = self.buffers.iter().map(|b| b.len() as u64).sum();
                if count.saturating_mul(elem) > total {
                    return Err(format!(
                        "accessor {index} has no bufferView: {count} elements of {elem} bytes is more than the {total} bytes of the file's buffers"
                    ));
                }
            }
        }
        if let Some(sparse) = a.sparse() {
            let n = sparse.count() as u64;
            if n == 0 || n > count {
                return Err(format!("accessor {index}: sparse count {n} is 0 or more than the accessor's {count}"));
            }
            let (indices, values) = (sparse.indices(), sparse.values());
            let index_bytes = match self.json["accessors"][index]["sparse"]["indices"]["componentType"].as_u64() {
                Some(5121) => 1,
                Some(5123) => 2,
                Some(5125) => 4,
                other => return Err(format!("accessor {index}: sparse index type {other:?} is not 5121, 5123 or 5125")),
            };
            self.check_view(&indices.view(), indices.offset() as u64 + n * index_bytes)
                .map_err(|m| format!("accessor {index}: {n} sparse indices {m}"))?;
            self.check_view(&values.view(), values.offset() as u64 + n * elem)
                .map_err(|m| format!("accessor {index}: {n} sparse values {m}"))?;
        }
        Ok(())
    }

    /// A buffer view inside its buffer and at least `need` bytes long.
    fn check_view(&self, view: &gltf::buffer::View, need: u64) -> Result<(), String> {
        let buffer = self.buffers.get(view.buffer().index()).map_or(0, |b| b.len() as u64);
        let (offset, length) = (view.offset() as u64, view.length() as u64);
        if offset + length > buffer {
            return Err(format!("lie in buffer view {} outside its buffer ({buffer} bytes)", view.index()));
        }
        if need > length {
            return Err(format!("need {need} bytes, buffer view {} holds {length}", view.index()));
        }
        Ok(())
    }

    /// The node's local transform at time `t` (`left`: the limit from before `t`).
    fn local(&self, node: usize, t: f32, left: bool) -> Mat4 {
        let mut tr = self.rest[node];
        if self.channels[node].is_empty() {
            return self.rest_matrix[node];
        }
        for c in &self.channels[node] {
            let v = c.sample(t, left);
            match c.property {
                Property::Translation => tr.translation = v.truncate(),
                Property::Rotation => tr.rotation = Quat::from_vec4(v).normalize(),
                Property::Scale => tr.scale = v.truncate(),
                Property::MorphTargetWeights => {}
            }
        }
        tr.matrix()
    }

    /// World-transform keys of an animated node: at every key time of its chain, plus the value
    /// just before every STEP jump.
    fn world_keys(&self, node: usize) -> Vec<TransformKey> {
        let mut chain = vec![node];
        let mut n = node;
        while let Some(p) = self.parent[n] {
            chain.push(p);
            n = p;
        }
        // (time, left) samples, sorted with the left limit first.
        let mut samples: Vec<(f32, bool)> = Vec::new();
        for &n in &chain {
            for c in &self.channels[n] {
                samples.extend(c.times.iter().map(|&t| (t, false)));
                if c.step {
                    samples.extend(c.times.iter().skip(1).map(|&t| (t, true)));
                }
            }
        }
        samples.sort_by(|a, b| a.0.total_cmp(&b.0).then(b.1.cmp(&a.1)));
        samples.dedup();
        samples
            .into_iter()
            .map(|(t, left)| {
                let m = chain.iter().rev().fold(Mat4::IDENTITY, |acc, &n| acc * self.local(n, t, left));
                let (scale, rotation, translation) = m.to_scale_rotation_translation();
                TransformKey { time: t, transform: Transform { translation, rotation, scale } }
            })
            .collect()
    }

    /// Our meshes for a glTF mesh (converted on first use).
    fn mesh(&mut self, mesh: &gltf::Mesh) -> Result<Vec<u32>, SceneError> {
        if let Some(ids) = self.meshes.get(&mesh.index()) {
            return Ok(ids.clone());
        }
        let mut ids = Vec::new();
        for prim in mesh.primitives() {
            let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
            if prim.mode() != gltf::mesh::Mode::Triangles {
                self.warn(format!("{what}: mode {:?} is not triangles; skipped", prim.mode()));
                continue;
            }
            if prim.morph_targets().len() > 0 {
                self.ignore("morph targets");
            }
            let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
                self.warn(format!("{what}: no POSITION attribute; skipped"));
                continue;
            };
            let err = |m: String| SceneError::parse(self.path, format!("{what}: {m}"));
            self.check_accessor(&pos_acc, &[DataType::F32], Dimensions::Vec3).map_err(|m| err(format!("POSITION: {m}")))?;
            let normals_ok =
                prim.get(&gltf::Semantic::Normals).map(|a| self.check_accessor(&a, &[DataType::F32], Dimensions::Vec3).is_ok());
            let uv_types = [DataType::F32, DataType::U8, DataType::U16];
            let uvs_ok = prim.get(&gltf::Semantic::TexCoords(0)).map(|a| self.check_accessor(&a, &uv_types, Dimensions::Vec2).is_ok());
            let tangents_ok =
                prim.get(&gltf::Semantic::Tangents).map(|a| self.check_accessor(&a, &[DataType::F32], Dimensions::Vec4).is_ok());
            let colors_ok = prim
                .get(&gltf::Semantic::Colors(0))
                .map(|a| [Dimensions::Vec3, Dimensions::Vec4].into_iter().any(|d| self.check_accessor(&a, &uv_types, d).is_ok()));
            if let Some(idx) = prim.indices() {
                self.check_accessor(&idx, &[DataType::U8, DataType::U16, DataType::U32], Dimensions::Scalar)
                    .map_err(|m| err(format!("indices: {m}")))?;
            }

            let buffers = &self.buffers;
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let outside = |what: &str| err(format!("{what} data lies outside its buffer"));
            let positions: Vec<Vec3> = reader.read_positions().ok_or_else(|| outside("POSITION"))?.map(Vec3::from_array).collect();
            // Read only checked accessors: the readers assert on the element type.
            let mut normals: Vec<Vec3> = match normals_ok.and_then(|ok| ok.then(|| reader.read_normals()).flatten()) {
                Some(it) => it.map(Vec3::from_array).collect(),
                None => Vec::new(),
            };
            let mut uvs: Vec<Vec2> = match uvs_ok.and_then(|ok| ok.then(|| reader.read_tex_coords(0)).flatten()) {
                Some(it) => it.into_f32().map(Vec2::from_array).collect(),
                None => Vec::new(),
            };
            // COLOR_0 is linear RGB(A), a factor of the base colour (alpha ignored).
            let mut colors: Vec<Vec3> = match colors_ok.and_then(|ok| ok.then(|| reader.read_colors(0)).flatten()) {
                Some(it) => it.into_rgb_f32().map(Vec3::from_array).collect(),
                None => Vec::new(),
            };
            let mut tangents: Vec<Vec4> = match tangents_ok.and_then(|ok| ok.then(|| reader.read_tangents()).flatten()) {
                Some(it) => it.map(Vec4::from_array).collect(),
                None => Vec::new(),
            };
            let indices: Vec<u32> = match reader.read_indices() {
                Some(it) => it.into_u32().collect(),
                None if prim.indices().is_some() => return Err(outside("index")),
                None => (0..positions.len() as u32).collect(),
            };
            let mut dropped = Vec::new();
            if !normals.is_empty() && normals.len() != positions.len() {
                normals.clear();
                dropped.push("normals");
            }
            if !uvs.is_empty() && uvs.len() != positions.len() {
                uvs.clear();
                dropped.push("texture coordinates");
            }
            if !colors.is_empty() && colors.len() != positions.len() {
                colors.clear();
                dropped.push("colours");
            }
            if !tangents.is_empty() && tangents.len() != positions.len() {
                tangents.clear();
                dropped.push("tangents");
            }
            if !dropped.is_empty() {
                self.warn(format!("{what}: {} do not match the vertex count; dropped", dropped.join(" and ")));
            }
            if [normals_ok, uvs_ok, colors_ok, tangents_ok].contains(&Some(false)) {
                self.ignore("NORMAL, TEXCOORD_0, COLOR_0 or TANGENT accessors of an unexpected type or size");
            }
            let material = self.material(prim.material())?;
            if let Some(transform) = self.base_color_uv_transform(&prim.material()) {
                uvs.iter_mut().for_each(|uv| *uv = transform(*uv));
            }
            let name = match mesh.name() {
                Some(n) => format!("{n}.{}", prim.index()),
                None => what.clone(),
            };
            let indices = indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
            self.scene.meshes.push(Mesh { name, positions, normals, uvs, colors, tangents, indices, material, deformation: None });
            ids.push(self.scene.meshes.len() as u32 - 1);
        }
        self.meshes.insert(mesh.index(), ids.clone());
        Ok(ids)
    }

    fn material(&mut self, m: gltf::Material) -> Result<u32, SceneError> {
        if let Some(&id) = self.materials.get(&m.index()) {
            return Ok(id);
        }
        let mut mat = Material { name: m.name().unwrap_or("default").to_owned(), ..Default::default() };
        if let Some(index) = m.index() {
            let pbr = m.pbr_metallic_roughness();
            mat.base_color = Vec4::from_array(pbr.base_color_factor()).truncate();
            mat.roughness = pbr.roughness_factor();
            mat.metallic = pbr.metallic_factor();
            if let Some(info) = pbr.base_color_texture() {
                if info.tex_coord() != 0 {
                    self.ignore("texture coordinate sets other than TEXCOORD_0 (set 0 used)");
                }
                mat.base_color_texture = self.texture(info.texture().source())?;
            }
            // Extensions the `gltf` crate's features do not read, from the raw JSON.
            let extensions = &self.json["materials"][index]["extensions"];
            let transmission = extensions["KHR_materials_transmission"]["transmissionFactor"].as_f64().unwrap_or(0.0);
            let ior = extensions["KHR_materials_ior"]["ior"].as_f64().unwrap_or(1.5) as f32;
            let strength = extensions["KHR_materials_emissive_strength"]["emissiveStrength"].as_f64().unwrap_or(1.0) as f32;
            // Glass (most of the light transmitted): the smooth dielectric with `KHR_materials_ior`'s
            // index (glTF's default 1.5), tinted by the base colour as glTF's transmission is;
            // rough transmission is not modelled.
            if transmission >= 0.5 {
                mat.model = MaterialModel::Dielectric { ior };
                if mat.roughness > 0.0 {
                    self.ignore("the roughness of transmitting materials (drawn as smooth glass)");
                }
            }
            mat.emission = Vec3::from_array(m.emissive_factor()) * strength;
            // An emissive texture: the references read it per texel ([`EmissionMap`]); the
            // material's own emission is its mean × the factor (the light selection's weight,
            // and the one radiance of the techniques that build lights per emitter).
            if let Some(info) = m.emissive_texture()
                && mat.is_emissive()
                && let Some(texture) = self.texture(info.texture().source())?
            {
                let factor = mat.emission;
                mat.emission *= self.scene.textures[texture as usize].mean();
                if info.tex_coord() == 0 && self.same_transform(index, &["emissiveTexture"]) {
                    mat.emission_map = Some(EmissionMap { texture, factor });
                } else {
                    self.ignore("emissive textures whose uvs differ from the base colour texture's (their mean used)");
                }
            }
            // A metallic-roughness texture (G roughness, B metallic, glTF's channels): the
            // references read it per texel; the material's own values are its mean × the
            // factors, the one BRDF per material that per-material precomputation uses (the
            // BRDF is affine in metallic, so the mean keeps the average reflectance; roughness
            // is averaged as a parameter). The factors alone (1 and 1 unless given) would make
            // such a material an entirely rough metal.
            if let Some(info) = pbr.metallic_roughness_texture()
                && let Some(texture) = self.data_texture(info.texture().source())?
            {
                let (metallic, roughness) = (mat.metallic, mat.roughness);
                let mean = self.scene.textures[texture as usize].mean();
                mat.roughness *= mean.y;
                mat.metallic *= mean.z;
                if info.tex_coord() == 0 && self.same_transform(index, &["pbrMetallicRoughness", "metallicRoughnessTexture"]) {
                    mat.metallic_roughness_map = Some(MetallicRoughnessMap { texture, metallic, roughness });
                } else {
                    self.ignore("metallic-roughness textures whose uvs differ from the base colour texture's (their mean used)");
                }
            }
            // A normal texture on the base colour texture's uvs (the primitive's uvs carry
            // that texture's transform): the shading normal per texel ([`NormalMap`]).
            if let Some(normal) = m.normal_texture() {
                let same_uvs = normal.tex_coord() == 0 && self.same_transform(index, &["normalTexture"]);
                match self.data_texture(normal.texture().source())? {
                    Some(texture) if same_uvs => {
                        mat.normal_map = Some(NormalMap {
                            texture,
                            scale: normal.scale(),
                            bitangent: Bitangent::ImageUp,
                            shadowing: NormalMapShadowing::None,
                        })
                    }
                    Some(_) => self.ignore("normal textures whose uvs differ from the base colour texture's"),
                    None => {}
                }
            }
            if m.occlusion_texture().is_some() {
                self.ignore("occlusion textures (ambient occlusion is what the techniques compute)");
            }
            match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => {}
                gltf::material::AlphaMode::Mask => {
                    let texture = match pbr.base_color_texture() {
                        Some(info) => self.coverage(info.texture().source())?,
                        None => None,
                    };
                    let (factor, cutoff) = (pbr.base_color_factor()[3], m.alpha_cutoff().unwrap_or(0.5));
                    mat.alpha_mask = Some(AlphaMask { texture, factor, cutoff });
                    self.ignore("alpha mode MASK in the voxel array's own grid and on the GPU (the references, shadow maps, ROMA and the distance field cut it out)");
                }
                gltf::material::AlphaMode::Blend => self.ignore("alpha mode BLEND (drawn opaque)"),
            }
        }
        let id = self.scene.add_material(mat);
        self.materials.insert(m.index(), id);
        Ok(id)
    }

    /// Whether the texture at `path` in material `index`'s JSON has the base colour texture's
    /// `KHR_texture_transform` (both none, or the same values as written): the primitive's uvs
    /// carry that transform, so only such a texture can be read per point on them.
    fn same_transform(&self, index: usize, path: &[&str]) -> bool {
        let material = &self.json["materials"][index];
        let texture = path.iter().fold(material, |v, key| &v[*key]);
        let transform = |t: &gltf::json::Value| t["extensions"]["KHR_texture_transform"].clone();
        transform(texture) == transform(&material["pbrMetallicRoughness"]["baseColorTexture"])
    }

    /// `KHR_texture_transform` on a material's base colour texture, as a map of the primitive's
    /// uvs (the texture is the only one read, so its transform is the uvs'): offset · rotation ·
    /// scale, as the extension defines them. `None` without one.
    fn base_color_uv_transform(&mut self, m: &gltf::Material) -> Option<impl Fn(Vec2) -> Vec2 + use<>> {
        let info = m.pbr_metallic_roughness().base_color_texture()?;
        let t = info.texture_transform()?;
        if t.tex_coord().is_some_and(|set| set != 0) {
            self.ignore("texture coordinate sets other than TEXCOORD_0 (set 0 used)");
        }
        let ([ox, oy], [sx, sy], (sin, cos)) = (t.offset(), t.scale(), t.rotation().sin_cos());
        Some(move |uv: Vec2| Vec2::new(cos * sx * uv.x + sin * sy * uv.y + ox, -sin * sx * uv.x + cos * sy * uv.y + oy))
    }

    /// Decodes a colour image into a linear texture (once); an image that cannot be read is a
    /// warning.
    fn texture(&mut self, image: gltf::Image) -> Result<Option<u32>, SceneError> {
        self.decoded_texture(image, true)
    }

    /// An image of data, not colour (metallic-roughness, normals): its raw channels in [0, 1],
    /// not sRGB-decoded (once); `None` (with a warning) where it cannot be read.
    fn data_texture(&mut self, image: gltf::Image) -> Result<Option<u32>, SceneError> {
        self.decoded_texture(image, false)
    }

    fn decoded_texture(&mut self, image: gltf::Image, srgb: bool) -> Result<Option<u32>, SceneError> {
        let index = image.index();
        if let Some(&id) = self.textures.get(&(index, srgb)) {
            return Ok(id);
        }
        let id = match self.image_data(image)? {
            Some(data) => match decoded_image(&data, srgb) {
                Some(img) => {
                    self.scene.textures.push(img);
                    Some(self.scene.textures.len() as u32 - 1)
                }
                None => {
                    self.warn(format!("image {index}: pixel data does not match its size; texture ignored"));
                    None
                }
            },
            None => None,
        };
        self.textures.insert((index, srgb), id);
        Ok(id)
    }

    /// An image's alpha channel as a coverage texture (once; linear, in every channel); `None`
    /// where it has no alpha channel (coverage 1) or cannot be read (a warning).
    fn coverage(&mut self, image: gltf::Image) -> Result<Option<u32>, SceneError> {
        let index = image.index();
        if let Some(&id) = self.coverages.get(&index) {
            return Ok(id);
        }
        let id = match self.image_data(image)? {
            Some(data) => alpha_image(&data).map(|img| {
                self.scene.textures.push(img);
                self.scene.textures.len() as u32 - 1
            }),
            None => None,
        };
        self.coverages.insert(index, id);
        Ok(id)
    }

    /// An image's decoded pixels; one that cannot be found or decoded is a warning and `None`,
    /// a buffer view outside its buffer an error.
    fn image_data(&mut self, image: gltf::Image) -> Result<Option<gltf::image::Data>, SceneError> {
        let what = format!("image {}", image.index());
        // The typed `source()` unwraps these; gltf-json does not check them.
        let raw = &self.json["images"][image.index()];
        let usable = if raw["bufferView"].is_null() { raw["uri"].is_string() } else { raw["mimeType"].is_string() };
        if !usable {
            self.warn(format!("{what} has neither a uri nor a bufferView with a mimeType; texture ignored"));
            return Ok(None);
        }
        if let gltf::image::Source::View { view, .. } = image.source() {
            let len = self.buffers.get(view.buffer().index()).map_or(0, |b| b.len());
            if view.offset().checked_add(view.length()).is_none_or(|end| end > len) {
                return Err(self.parse_err(format!("{what}: its buffer view lies outside its buffer")));
            }
        }
        let base = self.path.parent().unwrap_or(Path::new(""));
        if let gltf::image::Source::Uri { uri, .. } = image.source()
            && let Some(file) = uri_path(base, uri)
            && let Err(e) = check_file(&file, "texture", limit::IMAGE)
        {
            self.warn(format!("{what} ('{uri}') not loaded ({e}); using the factor alone"));
            return Ok(None);
        }
        match gltf::image::Data::from_source(image.source(), Some(base), &self.buffers) {
            Ok(data) => Ok(Some(data)),
            Err(e) => {
                let uri = match image.source() {
                    gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => format!(" ('{uri}')"),
                    _ => String::new(),
                };
                self.warn(format!("{what}{uri} not loaded ({e}); using the factor alone"));
                Ok(None)
            }
        }
    }

    fn light(&mut self, light: &gltf::khr_lights_punctual::Light) -> Result<Light, SceneError> {
        use gltf::khr_lights_punctual::Kind;
        let intensity = Vec3::from_array(light.color()) * light.intensity();
        let (position, forward) = (Vec3::ZERO, Vec3::NEG_Z);
        if light.range().is_some() {
            self.ignore("light ranges (inverse-square falloff used)");
        }
        // The typed `kind()` unwraps a spot light's cone object, which gltf-json does not require.
        let raw = &self.json["extensions"]["KHR_lights_punctual"]["lights"][light.index()];
        if raw["type"] == "spot" && raw["spot"].is_null() {
            return Err(self.parse_err(format!("light {}: a spot light without its 'spot' object", light.index())));
        }
        Ok(match light.kind() {
            Kind::Point => Light { direction: forward, ..Light::point(position, intensity) },
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                Light::spot(position, forward, intensity, inner_cone_angle, outer_cone_angle)
            }
            Kind::Directional => Light::directional(forward, intensity),
        })
    }

    fn camera(&mut self, camera: &gltf::Camera, motion: &Motion, animated: bool) {
        if self.scene.camera.is_some() {
            return;
        }
        let gltf::camera::Projection::Perspective(p) = camera.projection() else {
            self.ignore("orthographic cameras");
            return;
        };
        if animated {
            self.ignore("camera animation (the camera at time 0 used)");
        }
        let m = motion.at(0.0);
        let position = m.transform_point3(Vec3::ZERO);
        let forward = m.transform_vector3(Vec3::NEG_Z).normalize_or(Vec3::NEG_Z);
        let up = m.transform_vector3(Vec3::Y).normalize_or(Vec3::Y);
        self.scene.camera = Some(Camera::vertical(position, position + forward, up, p.yfov()));
    }
}

/// gltf-json's validator indexes the accessors with each POSITION attribute unchecked, so an
/// out-of-range one is caught here first.
/// The file a buffer or image `uri` names, as the `gltf` importer resolves it (relative to the
/// glTF's folder, percent-decoded; or `file:`), or `None` for `data:` and other schemes.
fn uri_path(base: &Path, uri: &str) -> Option<PathBuf> {
    if let Some(rest) = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")) {
        return Some(PathBuf::from(rest));
    }
    if uri.contains(':') {
        return None;
    }
    let bytes = uri.as_bytes();
    let mut decoded = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        match (bytes[i], bytes.get(i + 1).copied().and_then(hex), bytes.get(i + 2).copied().and_then(hex)) {
            (b'%', Some(h), Some(l)) => {
                decoded.push((h * 16 + l) as u8);
                i += 3;
            }
            (b, _, _) => {
                decoded.push(b);
                i += 1;
            }
        }
    }
    Some(base.join(String::from_utf8(decoded).ok()?))
}

fn check_positions(json: &gltf::json::Value) -> Result<(), String> {
    let accessors = json["accessors"].as_array().map_or(0, Vec::len);
    for (mi, mesh) in json["meshes"].as_array().into_iter().flatten().enumerate() {
        for (pi, prim) in mesh["primitives"].as_array().into_iter().flatten().enumerate() {
            if let Some(i) = prim["attributes"]["POSITION"].as_u64()
                && i >= accessors as u64
            {
                return Err(format!("meshes[{mi}].primitives[{pi}].attributes.POSITION: accessor {i} does not exist"));
            }
        }
    }
    Ok(())
}

/// (channels, bytes per channel) of a decoded glTF image, `None` where it has no pixels or its
/// data is shorter than its size says.
fn checked_layout(data: &gltf::image::Data) -> Option<(usize, usize)> {
    use gltf::image::Format as F;
    let (channels, bytes) = match data.format {
        F::R8 => (1, 1),
        F::R8G8 => (2, 1),
        F::R8G8B8 => (3, 1),
        F::R8G8B8A8 => (4, 1),
        F::R16 => (1, 2),
        F::R16G16 => (2, 2),
        F::R16G16B16 => (3, 2),
        F::R16G16B16A16 => (4, 2),
        F::R32G32B32FLOAT => (3, 4),
        F::R32G32B32A32FLOAT => (4, 4),
    };
    let (w, h) = (data.width as usize, data.height as usize);
    let ok = w > 0 && h > 0 && data.pixels.len() >= w.checked_mul(h)?.checked_mul(channels * bytes)?;
    ok.then_some((channels, bytes))
}

/// Channel value `i` of a decoded image as stored: 8- and 16-bit ones scaled to [0, 1], floats
/// as they are.
fn raw_channel(data: &gltf::image::Data, bytes: usize, i: usize) -> f32 {
    let b = &data.pixels[i * bytes..(i + 1) * bytes];
    match bytes {
        1 => b[0] as f32 / 255.0,
        2 => u16::from_ne_bytes([b[0], b[1]]) as f32 / 65535.0,
        _ => f32::from_ne_bytes([b[0], b[1], b[2], b[3]]),
    }
}

/// A decoded image's colour channels; with `srgb`, 8- and 16-bit values are sRGB-decoded (colour
/// is sRGB-encoded, floats are linear), without it taken raw (data).
fn decoded_image(data: &gltf::image::Data, srgb: bool) -> Option<Image> {
    let (channels, bytes) = checked_layout(data)?;
    let channel = |i: usize| {
        let v = raw_channel(data, bytes, i);
        if srgb && bytes < 4 { srgb_decode(v) } else { v }
    };
    let w = data.width as usize;
    Some(Image::from_fn(data.width, data.height, |x, y| {
        let p = (y as usize * w + x as usize) * channels;
        // One or two channels are grey (+ alpha).
        if channels < 3 { Vec3::splat(channel(p)) } else { Vec3::new(channel(p), channel(p + 1), channel(p + 2)) }
    }))
}

/// The alpha channel (the last of two or four; linear in glTF) as a grey image; `None` without one.
fn alpha_image(data: &gltf::image::Data) -> Option<Image> {
    let (channels, bytes) = checked_layout(data)?;
    if channels % 2 == 1 {
        return None;
    }
    let w = data.width as usize;
    Some(Image::from_fn(data.width, data.height, |x, y| {
        Vec3::splat(raw_channel(data, bytes, (y as usize * w + x as usize) * channels + channels - 1))
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channels_interpolate_step_and_hold() {
        let values = vec![Vec4::ZERO, Vec4::X, Vec4::new(3.0, 0.0, 0.0, 0.0)];
        let linear = Channel { property: Property::Translation, times: vec![0.0, 1.0, 2.0], values: values.clone(), step: false };
        let step = Channel { step: true, ..linear_clone(&linear) };
        let x = |c: &Channel, t: f32, left: bool| c.sample(t, left).x;
        println!(
            "linear at 0.5, 1.5: {} {}; step at 0.5, 1 (left), 1, 2 (left), 2: {} {} {} {} {}",
            x(&linear, 0.5, false),
            x(&linear, 1.5, false),
            x(&step, 0.5, false),
            x(&step, 1.0, true),
            x(&step, 1.0, false),
            x(&step, 2.0, true),
            x(&step, 2.0, false)
        );
        assert_eq!((x(&linear, -1.0, false), x(&linear, 0.5, false), x(&linear, 1.5, false), x(&linear, 9.0, false)), (0.0, 0.5, 2.0, 3.0));
        assert_eq!((x(&linear, 1.0, true), x(&linear, 1.0, false)), (1.0, 1.0), "linear is continuous");
        assert_eq!((x(&step, 0.5, false), x(&step, 1.0, true), x(&step, 1.0, false)), (0.0, 0.0, 1.0));
        assert_eq!((x(&step, 2.0, true), x(&step, 2.0, false), x(&step, 0.0, true)), (1.0, 3.0, 0.0));
        let rot = Channel {
            property: Property::Rotation,
            times: vec![0.0, 1.0],
            values: vec![Vec4::from(Quat::IDENTITY), Vec4::from(Quat::from_rotation_y(1.0))],
            step: false,
        };
        let q = Quat::from_vec4(rot.sample(0.25, false));
        assert!((q.angle_between(Quat::IDENTITY) - 0.25).abs() < 1e-5, "slerp");
    }

    fn linear_clone(c: &Channel) -> Channel {
        Channel { property: c.property, times: c.times.clone(), values: c.values.clone(), step: c.step }
    }
}

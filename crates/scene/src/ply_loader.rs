//! PLY meshes (ASCII, binary little- and big-endian) through `ply-rs-bw`: positions (`x y z`),
//! optional normals (`nx ny nz`), texture coordinates (`u v`, `s t` or `texture_u texture_v`)
//! and vertex colours (`red green blue`: 8- or 16-bit integers scaled to [0, 1], floats as they
//! are; sRGB-decoded, since scanners and MeshLab write display colours; Mitsuba's scenes read
//! them as Mitsuba does, [`PlyColors`]), and faces
//! (`vertex_indices` or `vertex_index`) of three or more vertices, fanned into triangles. Other
//! elements and properties (alpha, edges) are read past and ignored.
//!
//! Before anything is allocated, the element counts of the header are checked against the bytes
//! that follow it (a binary element has a known minimum size; an ASCII one takes at least two
//! bytes), so a header that promises more than the file holds is an error naming the element,
//! not an allocation of whatever the header says.

use crate::{Material, Mesh, Scene, SceneError};
use glimpse_core::image::srgb_decode;
use glimpse_core::{Mat4, Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{ElementDef, Encoding, Header, Property, PropertyAccess, PropertyAccessResult, PropertyType, ScalarType};
use std::io::Cursor;
use std::path::Path;

/// A scene of the one mesh in `path`, with the default material (a PLY file has none).
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let mut scene = Scene { name: path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(), ..Default::default() };
    let material = scene.add_material(Material::default());
    scene.add_mesh(load_mesh(path, material)?, Mat4::IDENTITY);
    Ok(scene)
}

/// How a PLY file's vertex colours are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlyColors {
    /// Display colours (scanners, MeshLab): integers scaled to [0, 1], then sRGB-decoded.
    Display,
    /// Mitsuba 3's reading (measured in 3.9.1 through its `mesh_attribute`): every value as it is
    /// stored, linear, integers not scaled (its loader warns that they should be in [0, 1]).
    Mitsuba,
}

/// Reads `path` into one mesh with material `material`. Vertex uvs keep the file's values: PLY
/// has no orientation convention, and Mitsuba 3 (whose scenes carry PLY files) reads them as is.
pub fn load_mesh(path: &Path, material: u32) -> Result<Mesh, SceneError> {
    load_mesh_with(path, material, PlyColors::Display)
}

/// [`load_mesh`] with the vertex colours read as `colors` says.
pub fn load_mesh_with(path: &Path, material: u32, colors: PlyColors) -> Result<Mesh, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, format!("cannot read the PLY file: {e}")))?;
    parse(&bytes, path, material, colors)
}

/// Parses PLY bytes; `path` names them in errors.
pub fn parse(bytes: &[u8], path: &Path, material: u32, colors: PlyColors) -> Result<Mesh, SceneError> {
    let err = |m: String| SceneError::parse(path, m);
    if !bytes.starts_with(b"ply") {
        return Err(err("line 1: not a PLY file (it must start with 'ply')".into()));
    }
    let parser = Parser::<Element>::new();
    let mut reader = Reader::new(Cursor::new(bytes));
    let header = parser.read_header(&mut reader).map_err(|e| err(format!("header: {}", one_line(&e.to_string()))))?;
    let header_len = reader.get_ref().position() as usize;
    check_counts(&header, &bytes[..header_len], bytes.len().saturating_sub(header_len)).map_err(err)?;
    let vertex_def = header.elements.get("vertex").ok_or_else(|| err("the header declares no 'vertex' element".into()))?;
    let has = |k: &str| vertex_def.properties.contains_key(k);
    for axis in ["x", "y", "z"] {
        if !has(axis) {
            return Err(err(format!("element 'vertex' has no '{axis}' property")));
        }
    }
    let payload = parser.read_payload(&mut reader, &header).map_err(|e| err(one_line(&e.to_string())))?;

    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let mut mesh = Mesh { name, material, ..Default::default() };
    let vertices = payload.get("vertex").map(Vec::as_slice).unwrap_or_default();
    let has_uvs = [("u", "v"), ("s", "t"), ("texture_u", "texture_v")].into_iter().any(|(u, v)| has(u) && has(v));
    let has_normals = has("nx") && has("ny") && has("nz");
    let has_colors = has("red") && has("green") && has("blue");
    for v in vertices {
        let [x, y, z, nx, ny, nz, u, w, r, g, b] = v.values;
        if has_colors {
            let stored = Vec3::new(r, g, b);
            mesh.colors.push(match colors {
                PlyColors::Display => (stored * v.color_scale).map(srgb_decode),
                PlyColors::Mitsuba => stored,
            });
        }
        mesh.positions.push(Vec3::new(x, y, z));
        if has_normals {
            mesh.normals.push(Vec3::new(nx, ny, nz));
        }
        if has_uvs {
            mesh.uvs.push(Vec2::new(u, w));
        }
    }
    let n = mesh.positions.len() as u32;
    for (f, face) in payload.get("face").map(Vec::as_slice).unwrap_or_default().iter().enumerate() {
        let idx = match &face.indices {
            Ok(idx) => idx,
            Err(problem) => return Err(err(format!("face {f}: {problem}"))),
        };
        if idx.len() < 3 {
            return Err(err(format!("face {f} has {} vertices (at least 3 are needed)", idx.len())));
        }
        if let Some(bad) = idx.iter().find(|&&k| k >= n) {
            return Err(err(format!("face {f} refers to vertex {bad}, but there are only {n} vertices")));
        }
        // A fan: exact for the convex quads and polygons that PLY exporters write.
        for k in 1..idx.len() - 1 {
            mesh.indices.push([idx[0], idx[k], idx[k + 1]]);
        }
    }
    if mesh.indices.is_empty() {
        return Err(err("the file has no faces".into()));
    }
    Ok(mesh)
}

/// One element of any kind, kept compact (a map per vertex would cost ~10× the memory): the
/// vertex slots glimpse reads and a face's index list; other properties are dropped as read.
struct Element {
    /// x, y, z, nx, ny, nz, u, v, red, green, blue (the colours as stored).
    values: [f32; 11],
    /// What the stored colours are multiplied by to span [0, 1]: 1/255 for 8-bit integers,
    /// 1/65535 for 16-bit ones, 1 for floats.
    color_scale: f32,
    /// The face's vertex indices, or why they cannot be used.
    indices: Result<Vec<u32>, &'static str>,
}

impl PropertyAccess for Element {
    fn new() -> Self {
        Self { values: [0.0; 11], color_scale: 1.0, indices: Err("no 'vertex_indices' list") }
    }

    fn set_property(&mut self, name: &str, property: Property) -> PropertyAccessResult {
        let slot = match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            "nx" => 3,
            "ny" => 4,
            "nz" => 5,
            "u" | "s" | "texture_u" => 6,
            "v" | "t" | "texture_v" => 7,
            "red" | "green" | "blue" => {
                let slot = match name {
                    "red" => 8,
                    "green" => 9,
                    _ => 10,
                };
                // Integer colours span their type's range; float ones are in [0, 1].
                self.color_scale = match property {
                    Property::UChar(_) => 1.0 / 255.0,
                    Property::UShort(_) => 1.0 / 65535.0,
                    _ => 1.0,
                };
                self.values[slot] = match property.to_f32_lossy() {
                    Some(c) => c,
                    None => return PropertyAccessResult::UnsupportedType,
                };
                return PropertyAccessResult::Set;
            }
            "vertex_indices" | "vertex_index" => {
                self.indices = property.to_u32_list().ok_or("vertex indices must be a list of non-negative integers");
                return PropertyAccessResult::Set;
            }
            _ => return PropertyAccessResult::Ignored,
        };
        match property.to_f32_lossy() {
            Some(v) => {
                self.values[slot] = v;
                PropertyAccessResult::Set
            }
            None => PropertyAccessResult::UnsupportedType,
        }
    }
}

/// Errors when an element's count cannot fit in `payload_bytes`, naming the header line that
/// declares it.
fn check_counts(header: &Header, header_text: &[u8], payload_bytes: usize) -> Result<(), String> {
    let mut need: u128 = 0;
    for (name, def) in &header.elements {
        let per_element = match header.encoding {
            Encoding::Ascii => 2, // at least one digit and a line break
            Encoding::BinaryBigEndian | Encoding::BinaryLittleEndian => min_binary_size(def),
        };
        need += def.count as u128 * per_element as u128;
        if need > payload_bytes as u128 {
            let text = String::from_utf8_lossy(header_text);
            let line = text.lines().position(|l| l.split_whitespace().take(2).eq(["element", name.as_str()])).map_or(0, |i| i + 1);
            return Err(format!(
                "line {line}: element '{name}': the header declares {} '{name}' elements, but only {payload_bytes} bytes follow it (truncated file or wrong count)",
                def.count
            ));
        }
    }
    Ok(())
}

/// The fewest bytes one binary element can take: every scalar, and every list's length field.
fn min_binary_size(def: &ElementDef) -> usize {
    def.properties
        .values()
        .map(|p| match &p.data_type {
            PropertyType::Scalar(t) | PropertyType::List(t, _) => scalar_size(t),
        })
        .sum()
}

fn scalar_size(t: &ScalarType) -> usize {
    match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    }
}

/// The parser's messages quote the offending line over several lines; the command line prints one.
fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    const QUAD_ASCII: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property float u\nproperty float v\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n4 0 1 2 3\n";

    #[test]
    fn an_ascii_quad_becomes_two_triangles_with_uvs() {
        let m = parse(QUAD_ASCII.as_bytes(), Path::new("quad.ply"), 7, PlyColors::Display).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.uvs[2], Vec2::new(1.0, 1.0));
        assert!(m.normals.is_empty());
        assert_eq!(m.material, 7);
    }

    #[test]
    fn a_count_larger_than_the_file_is_refused_before_reading() {
        let text = QUAD_ASCII.replace("element vertex 4", "element vertex 4000000000");
        let e = parse(text.as_bytes(), Path::new("big.ply"), 0, PlyColors::Display).unwrap_err().to_string();
        assert!(e.contains("big.ply") && e.contains("4000000000 'vertex'"), "{e}");
    }
}

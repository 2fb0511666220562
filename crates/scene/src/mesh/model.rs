//! glTF 2.0 models (`.gltf` with external or embedded buffers, `.glb`) read as world-space
//! triangles through the `gltf` crate.
//!
//! Every primitive of every mesh reachable from the default scene (or, without one, every
//! scene) is read: triangle lists, strips and fans, indexed or not. A node's points go to
//! the world by the scene file's transform times the node's transforms from the root down,
//! `x ↦ T·N₁·…·Nₖ·x`; normals by the inverse transpose of that matrix's 3 × 3 part.

use super::Triangle;
use crate::vec3::{Vec3, normalize};
use haze_core::Rgb;
use std::path::Path;

/// A 4 × 4 affine transform, row-major: `y_i = Σ_j m[i][j]·x_j + m[i][3]`.
pub type Affine = [[f64; 4]; 4];

pub const IDENTITY: Affine = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// `a·b`.
pub fn compose(a: &Affine, b: &Affine) -> Affine {
    let mut m = [[0.0; 4]; 4];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = (0..4).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// `translate · rotate(axis, degrees) · scale` (Rodrigues' rotation).
pub fn trs(translate: Vec3, axis: Vec3, degrees: f64, scale: Vec3) -> Option<Affine> {
    let (s, c) = degrees.to_radians().sin_cos();
    let k = if degrees == 0.0 {
        [0.0, 0.0, 1.0]
    } else {
        normalize(axis)?
    };
    let mut m = IDENTITY;
    for i in 0..3 {
        for j in 0..3 {
            let eps = |a: usize, b: usize| -> f64 {
                // The cross-product matrix [k]×.
                match (a, b) {
                    (0, 1) => -k[2],
                    (0, 2) => k[1],
                    (1, 0) => k[2],
                    (1, 2) => -k[0],
                    (2, 0) => -k[1],
                    (2, 1) => k[0],
                    _ => 0.0,
                }
            };
            let r = if i == j { c } else { 0.0 } + s * eps(i, j) + (1.0 - c) * k[i] * k[j];
            m[i][j] = r * scale[j];
        }
        m[i][3] = translate[i];
    }
    Some(m)
}

fn apply_point(m: &Affine, p: Vec3) -> Vec3 {
    [0, 1, 2].map(|i| m[i][0] * p[0] + m[i][1] * p[1] + m[i][2] * p[2] + m[i][3])
}

/// The cofactor matrix of `m`'s 3 × 3 part: the inverse transpose up to the determinant's
/// positive factor or sign (the sign is applied by the caller).
fn cofactor(m: &Affine) -> [[f64; 3]; 3] {
    let a = |i: usize, j: usize| m[i % 3][j % 3];
    let mut c = [[0.0; 3]; 3];
    for (i, row) in c.iter_mut().enumerate() {
        for (j, x) in row.iter_mut().enumerate() {
            *x = a(i + 1, j + 1) * a(i + 2, j + 2) - a(i + 1, j + 2) * a(i + 2, j + 1);
        }
    }
    c
}

/// A material of the model: its base colour (linear RGB) as the Lambert albedo.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    /// The glTF material's `baseColorFactor` (white when the primitive has none).
    pub base_color: Rgb,
    pub triangles: Vec<Triangle>,
}

/// Reads the model at `path`, placed by `transform`; one [`Part`] per glTF material used.
/// The error is one line naming the file.
pub fn load(path: &Path, transform: &Affine) -> Result<Vec<Part>, String> {
    let name = path.display();
    let fail = |p: String| format!("{name}: {p}");
    let bytes = std::fs::read(path).map_err(|e| {
        fail(match e.kind() {
            std::io::ErrorKind::NotFound => "no such model file".to_string(),
            _ => format!("cannot read ({e})"),
        })
    })?;
    let gltf = gltf::Gltf::from_slice(&bytes).map_err(|e| {
        fail(format!(
            "not a glTF 2.0 model ({})",
            one_line(&e.to_string())
        ))
    })?;
    let buffers =
        gltf::import_buffers(&gltf.document, path.parent(), gltf.blob.clone()).map_err(|e| {
            fail(format!(
                "cannot read its buffers ({})",
                one_line(&e.to_string())
            ))
        })?;
    let roots: Vec<gltf::Node<'_>> = match gltf.document.default_scene() {
        Some(s) => s.nodes().collect(),
        None => gltf.document.scenes().flat_map(|s| s.nodes()).collect(),
    };
    let mut parts: Vec<(Option<usize>, Part)> = Vec::new();
    let mut stack: Vec<(gltf::Node<'_>, Affine)> =
        roots.into_iter().map(|n| (n, *transform)).collect();
    while let Some((node, parent)) = stack.pop() {
        let local = node.transform().matrix();
        // glTF matrices are column-major: local[column][row].
        let mut l = IDENTITY;
        for (i, row) in l.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = local[j][i] as f64;
            }
        }
        let world = compose(&parent, &l);
        if let Some(mesh) = node.mesh() {
            for prim in mesh.primitives() {
                let tris = primitive(&prim, &buffers, &world).map_err(|p| {
                    fail(format!(
                        "mesh {} primitive {}: {p}",
                        mesh.index(),
                        prim.index()
                    ))
                })?;
                let key = prim.material().index();
                let part = match parts.iter_mut().find(|(k, _)| *k == key) {
                    Some((_, p)) => p,
                    None => {
                        let c = prim.material().pbr_metallic_roughness().base_color_factor();
                        parts.push((
                            key,
                            Part {
                                base_color: [c[0] as f64, c[1] as f64, c[2] as f64],
                                triangles: Vec::new(),
                            },
                        ));
                        &mut parts.last_mut().expect("just pushed").1
                    }
                };
                part.triangles.extend(tris);
            }
        }
        stack.extend(node.children().map(|c| (c, world)));
    }
    parts.retain(|(_, p)| !p.triangles.is_empty());
    if parts.is_empty() {
        return Err(fail("no triangles in its scene".to_string()));
    }
    Ok(parts.into_iter().map(|(_, p)| p).collect())
}

fn one_line(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// The world-space triangles of one primitive (none for points and lines; degenerate
/// triangles dropped).
fn primitive(
    prim: &gltf::Primitive<'_>,
    buffers: &[gltf::buffer::Data],
    world: &Affine,
) -> Result<Vec<Triangle>, String> {
    use gltf::accessor::{DataType, Dimensions};
    use gltf::mesh::{Mode, Semantic};
    // The reader assumes what glTF requires of these accessors; check it first.
    for (semantic, acc) in prim.attributes() {
        if matches!(semantic, Semantic::Positions | Semantic::Normals)
            && (acc.dimensions() != Dimensions::Vec3 || acc.data_type() != DataType::F32)
        {
            return Err(format!("{semantic:?} must be float VEC3"));
        }
        if acc.count() == 0 {
            return Err(format!("accessor {} is empty", acc.index()));
        }
    }
    if let Some(acc) = prim.indices() {
        if acc.dimensions() != Dimensions::Scalar || acc.data_type() == DataType::F32 {
            return Err("indices must be unsigned integer SCALAR".to_string());
        }
        if acc.count() == 0 {
            return Err(format!("accessor {} is empty", acc.index()));
        }
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let Some(positions) = reader.read_positions() else {
        return Err("no POSITION attribute".to_string());
    };
    let positions: Vec<Vec3> = positions
        .map(|p| apply_point(world, p.map(|x| x as f64)))
        .collect();
    if positions.iter().flatten().any(|x| !x.is_finite()) {
        return Err("positions must be finite".to_string());
    }
    let normals: Option<Vec<Vec3>> = reader.read_normals().map(|ns| {
        let c = cofactor(world);
        let det: f64 = (0..3).map(|j| world[0][j] * c[0][j]).sum();
        let sign = if det < 0.0 { -1.0 } else { 1.0 };
        ns.map(|n| {
            let n = n.map(|x| x as f64);
            let m = [0, 1, 2].map(|i| sign * (c[i][0] * n[0] + c[i][1] * n[1] + c[i][2] * n[2]));
            normalize(m).unwrap_or([0.0; 3])
        })
        .collect()
    });
    if let Some(ns) = &normals
        && ns.len() != positions.len()
    {
        return Err("NORMAL and POSITION counts differ".to_string());
    }
    let indices: Vec<usize> = match reader.read_indices() {
        Some(ix) => ix.into_u32().map(|i| i as usize).collect(),
        None => (0..positions.len()).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i >= positions.len()) {
        return Err(format!(
            "index {bad} beyond its {} vertices",
            positions.len()
        ));
    }
    let corners: Vec<[usize; 3]> = match prim.mode() {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
        Mode::TriangleStrip => (2..indices.len())
            .map(|k| {
                // Every other triangle of a strip is reversed to keep the winding.
                if k % 2 == 0 {
                    [indices[k - 2], indices[k - 1], indices[k]]
                } else {
                    [indices[k - 1], indices[k - 2], indices[k]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..indices.len())
            .map(|k| [indices[0], indices[k - 1], indices[k]])
            .collect(),
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => Vec::new(),
    };
    Ok(corners
        .into_iter()
        .map(|c| Triangle {
            p: c.map(|i| positions[i]),
            n: normals.as_ref().and_then(|ns| {
                let n = c.map(|i| ns[i]);
                n.iter().all(|v| v != &[0.0; 3]).then_some(n)
            }),
        })
        .filter(|t| t.face_normal().is_some())
        .collect())
}

/// One indexed triangle list to write as glTF: `f32` positions, optional unit normals
/// (one per position), indices in threes, the material's base colour.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleList {
    pub positions: Vec<[f32; 3]>,
    pub normals: Option<Vec<[f32; 3]>>,
    pub indices: Vec<u32>,
    pub base_color: [f32; 3],
}

/// `list` as glTF: the JSON document (one scene, one node, one mesh, one primitive, one
/// material) and its binary buffer (positions, normals, `u32` indices). The buffer is
/// at `uri`, or with `None` the GLB's own binary chunk.
pub fn encode(list: &TriangleList, uri: Option<&str>) -> (String, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut push = |bytes: &[u8], target: u32| {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{},"target":{target}}}"#,
            bytes.len()
        ));
    };
    let n = list.positions.len();
    push(bytemuck::cast_slice(&list.positions), 34962);
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in &list.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let mut accessors = vec![format!(
        r#"{{"bufferView":0,"componentType":5126,"count":{n},"type":"VEC3","min":{lo:?},"max":{hi:?}}}"#
    )];
    let mut attributes = r#""POSITION":0"#.to_string();
    if let Some(ns) = &list.normals {
        push(bytemuck::cast_slice(ns), 34962);
        accessors.push(format!(
            r#"{{"bufferView":1,"componentType":5126,"count":{n},"type":"VEC3"}}"#
        ));
        attributes.push_str(r#","NORMAL":1"#);
    }
    push(bytemuck::cast_slice(&list.indices), 34963);
    accessors.push(format!(
        r#"{{"bufferView":{},"componentType":5125,"count":{},"type":"SCALAR"}}"#,
        views.len() - 1,
        list.indices.len()
    ));
    let uri = uri.map_or(String::new(), |u| format!(r#","uri":"{u}""#));
    let [r, g, b] = list.base_color;
    let json = format!(
        r#"{{"asset":{{"version":"2.0","generator":"haze"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],"meshes":[{{"primitives":[{{"attributes":{{{attributes}}},"indices":{},"material":0}}]}}],"materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[{r},{g},{b},1]}}}}],"accessors":[{}],"bufferViews":[{}],"buffers":[{{"byteLength":{}{uri}}}]}}"#,
        accessors.len() - 1,
        accessors.join(","),
        views.join(","),
        bin.len()
    );
    (json, bin)
}

/// `list` as a GLB (glTF binary): the 12-byte header, the JSON chunk padded with spaces
/// and the binary chunk padded with zeros to 4 bytes.
pub fn glb(list: &TriangleList) -> Vec<u8> {
    let (json, mut bin) = encode(list, None);
    let mut json = json.into_bytes();
    while json.len() % 4 != 0 {
        json.push(b' ');
    }
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// A UV sphere of `rings × 2·rings` quads (two triangles each, one at the poles), unit
/// normals at the vertices: the tessellated twin of an analytic sphere. Its triangles are
/// inscribed: they lie inside the sphere, at most `r·(1 − cos ρ)` below it, `ρ` the
/// angular circumradius of the largest triangle (at the equator, legs of `π/rings`:
/// `ρ ≈ π/(√2·rings)`), i.e. `≈ r·π²/(4·rings²)`.
pub fn uv_sphere(center: [f32; 3], radius: f32, rings: u32, base_color: [f32; 3]) -> TriangleList {
    let segs = 2 * rings;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..=rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segs {
            let ph = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
            let n = [th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()];
            normals.push(n);
            positions.push([0, 1, 2].map(|k| center[k] + radius * n[k]));
        }
    }
    let at = |i: u32, j: u32| i * (segs + 1) + j;
    let mut indices = Vec::new();
    for i in 0..rings {
        for j in 0..segs {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            if i + 1 < rings {
                indices.extend([a, b, c]);
            }
            if i > 0 {
                indices.extend([a, c, d]);
            }
        }
    }
    TriangleList {
        positions,
        normals: Some(normals),
        indices,
        base_color,
    }
}

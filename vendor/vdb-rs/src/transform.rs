#[derive(Debug)]
pub enum Map {
    UniformScaleMap {
        scale_values: glam::DVec3,
        voxel_size: glam::DVec3,
        scale_values_inverse: glam::DVec3,
        inv_scale_sqr: glam::DVec3,
        inv_twice_scale: glam::DVec3,
    },
    /// haze: unequal voxel sides, no translation.
    ScaleMap {
        scale_values: glam::DVec3,
        voxel_size: glam::DVec3,
        scale_values_inverse: glam::DVec3,
        inv_scale_sqr: glam::DVec3,
        inv_twice_scale: glam::DVec3,
    },
    /// haze: unit voxels moved by `translation`.
    TranslationMap { translation: glam::DVec3 },
    /// haze: a general linear map, OpenVDB's `Mat4d` as stored (row-major; a point is a
    /// row vector, `world = [i, j, k, 1] · M`, the translation in elements 12..15).
    AffineMap { matrix: [f64; 16] },
    ScaleTranslateMap {
        translation: glam::DVec3,
        scale_values: glam::DVec3,
        voxel_size: glam::DVec3,
        scale_values_inverse: glam::DVec3,
        inv_scale_sqr: glam::DVec3,
        inv_twice_scale: glam::DVec3,
    },
}

// The lights' records as words (a module, `#import light_records`; the importer binds the
// records as `lights: array<u32>`, f32 values stored bit for bit).

// The f32 at word i.
fn word(i: u32) -> f32 {
    return bitcast<f32>(lights[i]);
}

// The vector in words i, i + 1, i + 2.
fn light_vec(i: u32) -> vec3<f32> {
    return vec3<f32>(word(i), word(i + 1u), word(i + 2u));
}

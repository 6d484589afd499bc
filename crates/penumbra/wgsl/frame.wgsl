// The orthonormal basis about a unit normal of Duff et al. 2017, the twin
// of `Frame::from_normal` (src/geom/sampling/): every tangent frame of the
// kernels (AO rays, field maps, SSAO samples). Self-contained: kernels
// prepend it.

// Frame::from_normal(n) as the columns (t, b, n). copysign(1, n.z) reads the
// sign bit so that n.z = -0.0 gives the same frame as on the CPU.
fn frame_basis(n: vec3<f32>) -> mat3x3<f32> {
    let sign = select(1.0, -1.0, (bitcast<u32>(n.z) & 0x80000000u) != 0u);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

// Frame::to_world(local) of a frame_basis made once for many directions.
fn basis_to_world(f: mat3x3<f32>, local: vec3<f32>) -> vec3<f32> {
    return f[0] * local.x + f[1] * local.y + f[2] * local.z;
}

// Frame::from_normal(n).to_world(local).
fn frame_to_world(n: vec3<f32>, local: vec3<f32>) -> vec3<f32> {
    return basis_to_world(frame_basis(n), local);
}

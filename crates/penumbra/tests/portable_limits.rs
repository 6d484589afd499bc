//! Every kernel against its CPU twin on a device created with WebGPU's
//! portable limits (`wgpu::Limits::default()`: 8 storage buffers per stage,
//! 16 KiB of workgroup memory, 256 invocations per workgroup, 2048-texel 3D
//! textures, 256 MiB buffers), the limits a host engine that asks for no
//! more gives penumbra. The comparisons and their tolerances are the twin
//! tests' (`twins/mod.rs`), on small inputs; each prints its worst
//! deviation. Without an adapter the tests say so and pass.
//!
//! wgpu does not check workgroup memory against the device's limit, so
//! these runs alone would not catch a kernel over it on lavapipe (which has
//! 32 KiB): `sh_transfer` is asserted to be compiled in its portable form,
//! and `wgsl_validate.rs` checks every module against the portable limits.

mod common;
mod twins;

use common::{asset, portable_gpu};
use penumbra::gpu::GpuContext;
use penumbra::gpu::device::{Device, Needs};
use penumbra::gpu::kernels::Kernels;
use penumbra::prt::gpu::{ShTransferForm, ShTransferKernels};
use penumbra::prt::transfer::{Brdf, Integration};
use penumbra::scene::procedural::all_scenes;
use penumbra::scene::{Camera, load_obj};
use penumbra::ssao::gbuffer::ScreenView;

/// The portable device, checked to have the portable limits where they
/// are below lavapipe's own.
fn portable() -> Option<GpuContext> {
    let ctx = portable_gpu()?;
    let (limits, portable) = (ctx.limits(), wgpu::Limits::default());
    assert_eq!(
        limits.max_storage_buffers_per_shader_stage,
        portable.max_storage_buffers_per_shader_stage
    );
    assert_eq!(
        limits.max_compute_workgroup_storage_size,
        portable.max_compute_workgroup_storage_size
    );
    assert_eq!(
        limits.max_compute_invocations_per_workgroup,
        portable.max_compute_invocations_per_workgroup
    );
    assert_eq!(limits.max_texture_dimension_3d, portable.max_texture_dimension_3d);
    assert_eq!(limits.max_buffer_size, portable.max_buffer_size);
    Some(ctx)
}

/// The checks `Device::require` makes pass: what every command's GPU path
/// uses fits the portable limits.
#[test]
fn every_method_is_allowed_on_a_portable_device() {
    let Some(ctx) = portable() else { return };
    for needs in [&Needs::COMPUTE, &Needs::SSAO] {
        let device = Device::gpu(ctx.clone()).require(needs).unwrap();
        assert!(device.is_gpu(), "{}", needs.what);
        assert!(needs.exceeded(&ctx.limits()).is_empty());
    }
}

#[test]
fn ray_casting_kernels_on_a_portable_device() {
    let Some(ctx) = portable() else { return };
    for (name, mesh) in all_scenes() {
        let mut rays = twins::random_rays(&mesh, 2000, 42);
        rays.extend(Camera::default_for(&mesh.bounds()).primary_rays(32, 32));
        twins::compare_traces(&ctx, name, &mesh, &rays);
    }
    twins::compare_ao_samples(&ctx, 50);
    for (name, mesh) in all_scenes().into_iter().filter(|(n, _)| *n != "wall-on-floor") {
        twins::compare_ao(&ctx, name, &mesh, 64);
    }
    for name in ["cube-with-hole.obj", "sphere-on-plane.obj"] {
        let mesh = load_obj(&asset(name)).unwrap();
        twins::compare_packets(&ctx, name, &mesh, &Camera::default_for(&mesh.bounds()), 48);
    }
}

/// 46x46 = 2116 maps are more layers than a portable 3D texture has
/// (2048): the texture maps tile 2x2 to a layer, the lookups stay the
/// CPU's.
#[test]
fn field_kernels_on_a_portable_device() {
    let Some(ctx) = portable() else { return };
    twins::compare_field_lookup(&ctx, 46, 8, 4000);
    twins::compare_field_ao(&ctx, 9, 8);
}

#[test]
fn ssao_kernels_on_a_portable_device() {
    let Some(ctx) = portable() else { return };
    let mesh = load_obj(&asset("sphere-on-plane.obj")).unwrap();
    let camera = Camera::default_for(&mesh.bounds());
    twins::compare_gbuffers(&ctx, "sphere-on-plane", &mesh, &camera, (64, 48));
    // Odd sizes: the half-resolution grid's last column and row.
    let (w, h) = (41, 31);
    let view = ScreenView::new(&camera, w, h);
    let gb = twins::cpu_gbuffer(&mesh, &camera, w, h);
    twins::compare_ssao_kernels(&ctx, "sphere-on-plane", &gb, &view, 0.5);
}

/// The SH transfer kernel in its portable form (8 vertices a workgroup,
/// within 16 KiB of workgroup memory), with masks of every side; where the
/// adapter's own limits give the wide form (16 vertices), both forms'
/// results bit for bit the same.
#[test]
fn sh_transfer_kernel_on_a_portable_device() {
    let Some(ctx) = portable() else { return };
    let form = ShTransferKernels::cached(&ctx).form;
    assert_eq!(form.module.name, ShTransferForm::PORTABLE.module.name);
    let adapter = common::gpu().filter(|a| ShTransferKernels::cached(a).form.max_vertices > form.max_vertices);
    let phong = Brdf::Phong {
        shininess: 16.0,
        specular: 0.4,
    };
    let cases: [twins::TransferCase; 3] = [
        ("cloth", 0.7, Brdf::Diffuse, Integration::Cells, 5, 32, 256),
        ("character", 0.5, Brdf::Diffuse, Integration::Pixels, 4, 16, u64::MAX),
        ("cloth", 0.2, phong, Integration::CellsLinear, 8, 64, u64::MAX),
    ];
    for case in cases {
        let portable = twins::compare_transfer(&ctx, case);
        if let Some(adapter) = &adapter {
            let wide = twins::compare_transfer(adapter, case);
            let bits = |f: &penumbra::prt::gpu::GpuFrame| {
                let radiance = f.radiance.iter().flatten();
                f.transfer
                    .iter()
                    .chain(radiance)
                    .map(|v| v.to_bits())
                    .collect::<Vec<u32>>()
            };
            assert!(bits(&portable) == bits(&wide), "{}: the forms differ", case.0);
            println!("{} t={}: the portable and wide forms agree bit for bit", case.0, case.1);
        }
    }
}

#[test]
fn ray_tracing_kernels_on_a_portable_device() {
    let Some(ctx) = portable() else { return };
    for name in ["checker-spheres", "cornell-mirror-glass"] {
        let scene = penumbra::scene::load_scene_shaded(&asset("raytrace").join(format!("{name}.json"))).unwrap();
        twins::compare_whitted(&ctx, name, &scene, &scene.camera.unwrap(), (48, 36));
    }
    twins::compare_whitted_listed(&Device::gpu(ctx.clone()), (48, 36));
    twins::compare_whitted_image(&ctx, (48, 36));
    twins::compare_whitted_trees(&ctx, &["checker-spheres", "cornell-mirror-glass"], 400);
    twins::compare_interpolate(&ctx, 5000);
    twins::compare_bounded(&ctx, (320, 240));
}

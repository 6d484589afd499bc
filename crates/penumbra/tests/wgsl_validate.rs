//! Every WGSL file parses and validates with naga, alone and as composed into
//! kernels; every file in `wgsl/` is compiled into the library. Errors name
//! the file and line.

use penumbra::gpu::wgsl::{FILES, MODULES, VARIANTS};

#[test]
fn every_wgsl_file_is_compiled_in() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/wgsl");
    let mut on_disk: Vec<String> = std::fs::read_dir(dir)
        .expect("wgsl/ exists")
        .map(|e| e.expect("readable entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".wgsl"))
        .map(|n| format!("wgsl/{n}"))
        .collect();
    on_disk.sort();
    let mut compiled: Vec<String> = FILES.iter().map(|f| f.path.to_string()).collect();
    compiled.sort();
    assert_eq!(on_disk, compiled, "wgsl/ and penumbra::gpu::wgsl::FILES differ");
}

/// Library files validate alone, or after the library files that precede
/// them in a kernel module (the displacement-field map-access files need the
/// field's parameters), or in every module they are part of (the texture
/// maps read their words through `map_word`, which each composing kernel
/// defines over its own buffer); kernel files (the last part of a module)
/// only make sense after their libraries and are validated as composed.
#[test]
fn every_library_file_validates_alone() {
    let mut failures = Vec::new();
    let kernels: Vec<&str> = MODULES.iter().filter_map(|m| m.parts.last()).map(|f| f.path).collect();
    for file in FILES.iter().filter(|f| !kernels.contains(&f.path)) {
        let prefix = MODULES.iter().find_map(|m| {
            let at = m.parts.iter().position(|p| p == file)?;
            Some(penumbra::gpu::wgsl::Composition {
                parts: &m.parts[..=at],
                ..*m
            })
        });
        let composed = || {
            let mut within = MODULES.iter().filter(|m| m.parts.contains(file)).peekable();
            within.peek().ok_or_else(|| format!("{}: in no module", file.path))?;
            within
                .map(|m| m.validate())
                .collect::<Result<Vec<_>, _>>()
                .map(|mut v| v.remove(0))
        };
        let result = file.validate().or_else(|alone| match prefix {
            Some(p) if p.parts.len() > 1 => p.validate().or_else(|_| composed()),
            _ => Err(alone),
        });
        match result {
            Ok(module) => println!(
                "{}: ok ({} functions, {} entry points)",
                file.path,
                module.functions.len(),
                module.entry_points.len()
            ),
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_file_is_validated_somewhere() {
    for file in FILES {
        let in_module = MODULES.iter().any(|m| m.parts.contains(file));
        assert!(
            in_module || file.validate().is_ok(),
            "{} is in no kernel module",
            file.path
        );
    }
}

#[test]
fn every_kernel_module_validates() {
    let mut failures = Vec::new();
    for module in MODULES.iter().chain(VARIANTS) {
        match module.validate() {
            Ok(m) => {
                let entries: Vec<&str> = m.entry_points.iter().map(|e| e.name.as_str()).collect();
                println!("{}: ok, entry points {entries:?}", module.name);
                assert!(!entries.is_empty(), "{} has no entry point", module.name);
            }
            Err(e) => failures.push(e),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// What each entry point asks of a device (read with naga), the demands
/// each module writes out equal to it, and every module of `MODULES` within
/// WebGPU's portable limits (`wgpu::Limits::default()`; wgpu itself does not
/// check workgroup memory), a variant only within the adapter's own.
/// Prints the table.
#[test]
fn every_kernel_module_fits_the_portable_limits() {
    let portable = wgpu::Limits::default();
    println!(
        "{:<40} {:>7} {:>7} {:>7} {:>9} {:>11}",
        "entry point", "storage", "layout", "sampled", "wg bytes", "size"
    );
    let mut over = Vec::new();
    for module in MODULES.iter().chain(VARIANTS) {
        let r = module.resources().unwrap();
        for e in &r.entries {
            println!(
                "{:<40} {:>7} {:>7} {:>7} {:>9} {:>11}",
                e.name,
                e.storage_buffers,
                r.storage_buffers,
                e.sampled_textures,
                e.workgroup_bytes,
                format!("{:?}", e.workgroup_size)
            );
            // Only the host's image is a storage texture.
            let textures = u32::from(e.name == "whitted_image.whitted_image");
            assert_eq!(e.storage_textures, textures, "{}", e.name);
        }
        assert_eq!(module.demands, r.demands(), "{}: the written-out demands", module.name);
        let exceeded = module.exceeded(&portable);
        if VARIANTS.iter().any(|v| v.name == module.name) {
            println!("  {} (a variant) exceeds: {exceeded:?}", module.name);
        } else {
            over.extend(exceeded.iter().map(ToString::to_string));
        }
    }
    assert!(over.is_empty(), "over WebGPU's portable limits: {over:?}");
}

#[test]
fn errors_point_at_the_original_file_and_line() {
    // A broken copy of a kernel: the error must name the kernel file, not the
    // line in the concatenated module.
    let broken = penumbra::gpu::wgsl::WgslFile {
        path: "wgsl/broken.wgsl",
        text: "fn ok() {}\nfn bad() -> u32 { return 1.5; }\n",
    };
    let parts: &'static [penumbra::gpu::wgsl::WgslFile] = Box::leak(Box::new([penumbra::gpu::wgsl::SAMPLING, broken]));
    let composed = penumbra::gpu::wgsl::Composition {
        name: "broken",
        parts,
        ..penumbra::gpu::wgsl::TRACE_RAYS_MODULE
    };
    let err = composed.validate().unwrap_err();
    assert!(err.starts_with("wgsl/broken.wgsl:2:"), "{err}");
}

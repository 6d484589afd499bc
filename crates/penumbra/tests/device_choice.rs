//! What each `DeviceChoice` opens on this machine: `GpuIfAny` takes the
//! adapter `Gpu` would (lavapipe included) and falls back to the CPU where
//! `Gpu` fails; `Auto` passes over a software adapter.

use penumbra::{Device, DeviceChoice};

#[test]
fn gpu_if_any_takes_whatever_adapter_gpu_would() {
    let gpu = Device::open(DeviceChoice::Gpu);
    let any = Device::open(DeviceChoice::GpuIfAny).expect("an automatic choice never fails");
    assert!(any.is_automatic());
    assert_eq!(any.adapter(), gpu.as_ref().ok().and_then(Device::adapter));
    assert_eq!(any.fallback_reason().is_some(), gpu.is_err());
    let software = gpu
        .as_ref()
        .ok()
        .and_then(Device::adapter)
        .is_some_and(|a| a.to_lowercase().contains("llvmpipe"));
    let auto = Device::open(DeviceChoice::Auto).unwrap();
    if software {
        assert!(any.is_gpu(), "lavapipe: GpuIfAny runs on it");
        assert!(!auto.is_gpu(), "lavapipe: Auto runs on the CPU");
    } else {
        println!(
            "no software adapter here ({:?}): only the agreement with Gpu is checked",
            any.adapter()
        );
    }
}

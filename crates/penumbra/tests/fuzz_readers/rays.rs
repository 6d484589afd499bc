//! Ray files: `read_rays`.

use std::path::Path;

use glam::Vec3;
use penumbra::io::rays::read_rays;
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::select;

use crate::harness::{Budget, KIB, Reader, call, fail, names, write_case};
use crate::inputs::{SPECIAL_F32, either, wildness};

const BUDGET: Budget = Budget::new(3, 64 * KIB);

pub static RAYS: Reader = Reader::new("rays", &["read_rays"], check);

fn check(dir: &Path, input: &[u8]) -> Result<(), String> {
    let path = write_case(dir.join("case.f32"), input)?;
    match call("read_rays", BUDGET, input.len(), || read_rays(&path))? {
        Ok(rays) => {
            if rays.len() * 24 != input.len() {
                return fail(format!("{} rays from {} bytes", rays.len(), input.len()));
            }
            match rays.iter().find(|r| {
                !Vec3::from(r.origin).is_finite() || !Vec3::from(r.dir).is_finite() || Vec3::from(r.dir) == Vec3::ZERO
            }) {
                Some(r) => fail(format!("ray {r:?} is not finite with a non-zero direction")),
                None => Ok(()),
            }
        }
        Err(e) => names(&e, &path),
    }
}

fn ray_records(rays: &[[f32; 6]]) -> Vec<u8> {
    rays.iter().flatten().flat_map(|c| c.to_le_bytes()).collect()
}

pub fn seeds() -> Vec<Vec<u8>> {
    let fan: Vec<[f32; 6]> = (0..64)
        .map(|i| {
            let a = i as f32 * 0.1;
            [0.0, 1.0, 5.0, a.cos(), -0.2, -a.sin()]
        })
        .collect();
    let many: Vec<[f32; 6]> = (0..2_000).map(|i| [i as f32, 0.0, 0.0, 0.0, 1.0, 0.0]).collect();
    vec![
        Vec::new(),
        ray_records(&[[0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]),
        ray_records(&fan),
        ray_records(&many),
        ray_records(&[
            [1e30, -1e30, 0.0, 1e-45, 0.0, -0.0],
            [-0.0, 0.0, 3.0, f32::MAX, f32::MIN, 1.0],
        ]),
    ]
}

pub fn structured() -> impl Strategy<Value = Vec<u8>> {
    wildness().prop_flat_map(|wild| {
        let component = either(
            wild,
            -1e3f32..1e3,
            prop_oneof![2 => select(SPECIAL_F32), 1 => any::<f32>()],
        );
        let tail = either(wild, Just(Vec::new()), vec(any::<u8>(), 1..24));
        (vec(vec(component, 6), 0..48), tail).prop_map(|(rays, tail)| {
            let mut b: Vec<u8> = rays.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
            b.extend(tail);
            b
        })
    })
}

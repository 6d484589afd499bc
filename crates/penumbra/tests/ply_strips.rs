//! A PLY of triangle strips (a `tristrips` element, as scanned models have
//! it) reads as the same mesh written as OBJ: the procedural scenes and,
//! with the shared data set, the cow, stripified here by a greedy
//! stripifier (`mesh_formats/write.rs`) that keeps the triangles' order and
//! winding, joining strips by restarts and by repeated vertices.

mod common;
#[path = "mesh_formats/write.rs"]
mod write;

use std::path::Path;

use common::{TempDir, data_model};
use penumbra::scene::{Mesh, ObjFile, load_mesh, load_mesh_file, procedural, write_obj};
use write::{Ply, ply_strips, stripify};

/// Whether `a` is `b` turned (the same corners in the same cyclic order).
fn same_turn(a: [u32; 3], b: [u32; 3]) -> bool {
    let [x, y, z] = b;
    a == b || a == [y, z, x] || a == [z, x, y]
}

/// `mesh` as OBJ (its triangles as the strips give them) and as strips in
/// `forms`: both read through `load_mesh_file` to the same positions and
/// triangles, in the same order; `load_mesh` agrees. With `faces`, the
/// first half of the triangles go in a `face` element (declared after the
/// strips: still read first).
fn strips_read_as_obj(dir: &TempDir, name: &str, mesh: &Mesh, forms: &[Ply], faces: bool) {
    let split = if faces { mesh.triangles.len() / 2 } else { 0 };
    let (face_part, strip_part) = mesh.triangles.split_at(split);
    let stripped = stripify(strip_part);
    let (list, decoded) = (&stripped.list, &stripped.triangles);
    // The stripifier's own check: the same triangles, winding and order.
    assert_eq!(decoded.len(), strip_part.len());
    for (t, (&d, &s)) in decoded.iter().zip(strip_part).enumerate() {
        assert!(same_turn(d, s), "{name}: triangle {t} is {d:?}, stripified from {s:?}");
    }
    if strip_part.len() > 2 {
        assert!(
            stripped.strips < strip_part.len(),
            "{name}: no strip of more than one triangle"
        );
    }
    let triangles: Vec<[u32; 3]> = face_part.iter().chain(decoded).copied().collect();
    let as_stripped = Mesh::new(mesh.positions.clone(), triangles).unwrap();
    let obj_path = dir.write(&format!("{name}.obj"), write_obj(&as_stripped, name));
    let obj = load_mesh_file(Path::new(&obj_path)).unwrap();
    println!(
        "{name}: {} triangles ({split} as faces), {} strips of {} entries",
        mesh.triangles.len(),
        stripped.strips,
        list.len()
    );
    for &form in forms {
        let bytes = ply_strips(&mesh.positions, face_part, list, form);
        let path = dir.write(&format!("{name}-{form:?}.ply"), bytes);
        let ply: ObjFile = load_mesh_file(Path::new(&path)).unwrap_or_else(|e| panic!("{name} {form:?}: {e}"));
        assert!(
            ply.mesh.positions == obj.mesh.positions,
            "{name} {form:?}: positions differ"
        );
        assert!(
            ply.mesh.triangles == obj.mesh.triangles,
            "{name} {form:?}: triangles differ"
        );
        assert_eq!(load_mesh(Path::new(&path)).unwrap(), ply.mesh, "{name} {form:?}");
        // A polygon's triangles share a face number; each strip triangle
        // is a face of its own.
        let faces: Vec<u32> = (0..ply.mesh.triangles.len() as u32).collect();
        assert_eq!(ply.triangle_faces, faces, "{name} {form:?}");
    }
}

#[test]
fn procedural_meshes_as_strips_read_as_their_obj() {
    let dir = TempDir::new("ply_strips_procedural");
    let forms = [Ply::Ascii, Ply::LittleEndian, Ply::BigEndian];
    for (name, mesh) in procedural::all_scenes() {
        strips_read_as_obj(&dir, name, &mesh, &forms, false);
        strips_read_as_obj(&dir, &format!("{name}-mixed"), &mesh, &forms, true);
    }
}

#[test]
fn shared_cow_as_strips_reads_as_its_obj() {
    let Some(path) = data_model("cow.obj") else {
        println!("PENUMBRA_DATA is not set: skipped");
        return;
    };
    let dir = TempDir::new("ply_strips_cow");
    let mesh = load_mesh(&path).unwrap();
    strips_read_as_obj(&dir, "cow", &mesh, &[Ply::LittleEndian], false);
}

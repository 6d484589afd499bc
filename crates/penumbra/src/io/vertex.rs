//! Per-vertex results out, through `crate::io::output`'s atomic writer:
//!
//! * AO as CSV (`index,ao` lines, no header: the command-line contract) or,
//!   for a `.ply` name, as the mesh with vertex colours, as bakers expect:
//!   binary little-endian PLY, `float x y z`, `uchar red green blue` = AO x
//!   255 rounded (linear, like the grey PNG: grey / 255 is the AO), `float
//!   quality` = AO exactly (MeshLab's per-vertex scalar), and the triangles
//!   (`list uchar uint vertex_indices`) in the mesh's order, so penumbra's
//!   own reader (and any other) gives back the same mesh.
//! * PRT radiance (and optionally the transfer vectors) per frame and
//!   vertex as CSV with a header row, written a frame at a time.

use std::io::Write;
use std::path::Path;

use crate::error::{Error, Result};
use crate::io::output::Pending;
use crate::scene::Mesh;

/// How per-vertex AO is written, by the file's extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VertexFormat {
    /// `index,ao` lines (any extension but `.ply`).
    Csv,
    /// The mesh with AO as vertex colours.
    Ply,
}

impl VertexFormat {
    /// [`VertexFormat::Ply`] for a `.ply` extension (case-insensitive),
    /// else [`VertexFormat::Csv`].
    pub fn of(path: &Path) -> VertexFormat {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        if ext.as_deref() == Some("ply") {
            VertexFormat::Ply
        } else {
            VertexFormat::Csv
        }
    }
}

/// `index,ao` lines, no header.
pub fn write_ao_csv(path: &Path, ao: &[f32]) -> Result<()> {
    crate::io::output::write_with(path, |out| {
        for (i, a) in ao.iter().enumerate() {
            writeln!(out, "{i},{a}").map_err(|e| e.to_string())?;
        }
        Ok(())
    })
}

/// The mesh with `ao` as vertex colours (binary little-endian PLY).
pub fn write_ao_ply(path: &Path, mesh: &Mesh, ao: &[f32]) -> Result<()> {
    if ao.len() != mesh.positions.len() {
        return Err(Error::internal(format!(
            "{} AO values for {} vertices",
            ao.len(),
            mesh.positions.len()
        )));
    }
    // A far-off model (`scene::frame`) is written back where it was, in
    // doubles: in floats it would lose the detail its reader kept.
    let far = mesh.origin != glam::DVec3::ZERO;
    let ty = if far { "double" } else { "float" };
    let header = format!(
        "ply\nformat binary_little_endian 1.0\n\
         comment penumbra ambient accessibility: red = green = blue = ao x 255 (linear), quality = ao\n\
         element vertex {}\nproperty {ty} x\nproperty {ty} y\nproperty {ty} z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\nproperty float quality\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    crate::io::output::write_with(path, |out| {
        let mut body = Vec::with_capacity(header.len() + 19 * ao.len() + 13 * mesh.triangles.len());
        body.extend_from_slice(header.as_bytes());
        for (p, &a) in mesh.positions.iter().zip(ao) {
            match far {
                true => mesh
                    .to_world(*p)
                    .to_array()
                    .iter()
                    .for_each(|c| body.extend(c.to_le_bytes())),
                false => p.to_array().iter().for_each(|c| body.extend(c.to_le_bytes())),
            }
            let grey = (a.clamp(0.0, 1.0) * 255.0).round() as u8;
            body.extend_from_slice(&[grey; 3]);
            body.extend_from_slice(&a.to_le_bytes());
        }
        for t in &mesh.triangles {
            body.push(3);
            for v in t {
                body.extend_from_slice(&v.to_le_bytes());
            }
        }
        out.write_all(&body).map_err(|e| e.to_string())
    })
}

/// PRT's per-vertex CSV: a header row `frame,vertex,r,g,b` (with the
/// transfer: `,t0,...,t{n-1}`), then one row per frame and vertex, frames
/// in order, vertices in file order. r, g, b: the vertex's exitant
/// radiance, albedo included (what the images interpolate), linear; t_i:
/// its world-space transfer vector, so that r = albedo_r x sum_i t_i L_i,r
/// with L the lighting of the frame (`prt::sh_out`'s `lighting`, turned by
/// `--env-spin`).
pub struct PrtVertexCsv {
    file: Pending,
    /// Transfer coefficients per row.
    transfer: usize,
}

impl PrtVertexCsv {
    /// Starts `path`; `transfer`: the coefficients per vertex to add to
    /// each row (0: none).
    pub fn create(path: &Path, transfer: usize) -> Result<PrtVertexCsv> {
        let mut file = Pending::create(path)?;
        let mut head = String::from("frame,vertex,r,g,b");
        for i in 0..transfer {
            head += &format!(",t{i}");
        }
        if let Err(e) = writeln!(file.writer(), "{head}") {
            return Err(file.fail(e));
        }
        Ok(PrtVertexCsv { file, transfer })
    }

    /// Appends frame `f`: radiance per vertex times `albedo`, and the
    /// transfer vectors (as many per vertex as `create` was told) where
    /// asked.
    pub fn frame(&mut self, f: usize, radiance: &[[f32; 3]], albedo: [f32; 3], transfer: &[f32]) -> Result<()> {
        let n = self.transfer;
        if n > 0 && transfer.len() != n * radiance.len() {
            let problem = format!("{} transfer values for {} vertices", transfer.len(), radiance.len());
            return Err(Error::internal(problem));
        }
        let out = self.file.writer();
        let mut line = String::new();
        for (v, rgb) in radiance.iter().enumerate() {
            line.clear();
            let [r, g, b] = [0, 1, 2].map(|c| rgb[c] * albedo[c]);
            line += &format!("{f},{v},{r},{g},{b}");
            for t in &transfer[v * n..(v + 1) * n] {
                line += &format!(",{t}");
            }
            line.push('\n');
            out.write_all(line.as_bytes())
                .map_err(|e| Error::internal(format!("cannot write the per-vertex CSV: {e}")))?;
        }
        Ok(())
    }

    /// Renames the finished file into place.
    pub fn finish(self) -> Result<()> {
        self.file.finish()
    }
}

/// Rows `frame,vertex,r,g,b[,t...]` read back (tests and tools): the
/// header's names and the rows' numbers.
pub fn read_prt_csv(path: &Path) -> Result<(Vec<String>, Vec<Vec<f64>>)> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::read(path, e))?;
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().unwrap_or_default().split(',').map(String::from).collect();
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        let row: std::result::Result<Vec<f64>, _> = line.split(',').map(str::parse).collect();
        let row = row.map_err(|e| Error::file(path, format!("line {}", i + 2), format!("{e}")))?;
        if row.len() != header.len() {
            let problem = format!("{} fields, the header has {}", row.len(), header.len());
            return Err(Error::file(path, format!("line {}", i + 2), problem));
        }
        rows.push(row);
    }
    Ok((header, rows))
}

#[cfg(all(test, feature = "ply"))]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::scene::parse_ply;

    #[test]
    fn ao_ply_reads_back_as_the_same_mesh_with_ao_colours() {
        let dir = std::env::temp_dir().join(format!("penumbra-vertex-out-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mesh = Mesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::new(0.0, 1.5, -2.0),
                Vec3::new(1e-7, 3.0, 1e6),
            ],
            triangles: vec![[0, 1, 2], [2, 1, 3]],
            objects: Vec::new(),
            origin: glam::DVec3::ZERO,
        };
        let ao = [0.0, 0.5, 1.0, 0.123];
        let path = dir.join("ao.ply");
        write_ao_ply(&path, &mesh, &ao).unwrap();
        let back = parse_ply(&std::fs::read(&path).unwrap()).unwrap();
        assert_eq!(back.mesh.positions, mesh.positions);
        assert_eq!(back.mesh.triangles, mesh.triangles);
        let colours = back.vertex_colors.unwrap();
        for (c, a) in colours.iter().zip(ao) {
            assert_eq!(*c, Vec3::splat((a * 255.0f32).round() / 255.0));
        }
        assert!(write_ao_ply(&path, &mesh, &ao[..3]).is_err());
        let csv = dir.join("ao.csv");
        write_ao_csv(&csv, &ao).unwrap();
        assert_eq!(std::fs::read_to_string(&csv).unwrap(), "0,0\n1,0.5\n2,1\n3,0.123\n");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn prt_csv_holds_a_row_per_frame_and_vertex() {
        let dir = std::env::temp_dir().join(format!("penumbra-prt-csv-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("v.csv");
        let mut csv = PrtVertexCsv::create(&path, 4).unwrap();
        assert!(!path.exists(), "nothing is in place before finish");
        let radiance = [[0.25, 0.5, 1.0], [2.0, 0.0, 1e-6]];
        let transfer: Vec<f32> = (0..8).map(|i| i as f32 * 0.5).collect();
        for f in 0..3 {
            csv.frame(f, &radiance, [1.0, 1.0, 0.5], &transfer).unwrap();
        }
        csv.finish().unwrap();
        let (header, rows) = read_prt_csv(&path).unwrap();
        assert_eq!(header.join(","), "frame,vertex,r,g,b,t0,t1,t2,t3");
        assert_eq!(rows.len(), 6);
        let row: Vec<f32> = rows[3].iter().map(|&x| x as f32).collect();
        assert_eq!(
            row,
            vec![1.0, 1.0, 2.0, 0.0, 0.5e-6, 2.0, 2.5, 3.0, 3.5],
            "values round-trip as f32"
        );
        let dropped = PrtVertexCsv::create(&dir.join("w.csv"), 0).unwrap();
        drop(dropped);
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "an unfinished file leaves nothing"
        );
        let _ = std::fs::remove_dir_all(dir);
    }
}

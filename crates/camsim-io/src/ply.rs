//! Triangle meshes as PLY files (binary little-endian, the format of BOP's object models):
//! `element vertex` with float `x y z`, `element face` with a uchar-counted int `vertex_indices`
//! list (Turk's PLY format as the BOP toolkit and MeshLab read it).

use crate::error::{IoError, Result};
use std::path::Path;

/// Write `positions` (any unit; BOP's are mm) and `faces` (counter-clockwise seen from outside)
/// atomically; `comment` goes into the header.
pub fn write_ply_mesh(
    path: &Path,
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    comment: &str,
) -> Result<()> {
    if let Some(f) = faces
        .iter()
        .find(|f| f.iter().any(|&i| i as usize >= positions.len()))
    {
        return Err(IoError::invalid(
            path,
            format!(
                "face {f:?} names a vertex beyond the {} vertices",
                positions.len()
            ),
        ));
    }
    crate::atomic::write_atomic(path, |w| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment {}\nelement vertex {}\n\
             property float x\nproperty float y\nproperty float z\nelement face {}\n\
             property list uchar int vertex_indices\nend_header\n",
            comment.replace('\n', " "),
            positions.len(),
            faces.len()
        )?;
        let mut buf = Vec::with_capacity(12 * positions.len() + 13 * faces.len());
        for p in positions {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
        }
        for f in faces {
            buf.push(3);
            for &i in f {
                buf.extend_from_slice(&(i as i32).to_le_bytes());
            }
        }
        Ok(w.write_all(&buf)?)
    })
}

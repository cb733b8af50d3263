//! The affine transform of scene data ([`Transform`], a 4x4 matrix acting on column vectors) and
//! its determinant and inverse: the one type every scene module (scene, media, motion, xform)
//! shares, in a module that uses none of them.

// `!(x > 0.0)` comparisons are deliberate: they also reject NaN.

/// Affine transform as a 4x4 matrix, row-major, acting on column vectors (`p' = m * p`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    pub m: [[f64; 4]; 4],
}

impl Default for Transform {
    fn default() -> Self {
        Transform::identity()
    }
}

impl Transform {
    pub fn identity() -> Self {
        let mut m = [[0.0; 4]; 4];
        for (i, row) in m.iter_mut().enumerate() {
            row[i] = 1.0;
        }
        Transform { m }
    }
    pub fn translate(d: [f64; 3]) -> Self {
        let mut t = Transform::identity();
        t.m[0][3] = d[0];
        t.m[1][3] = d[1];
        t.m[2][3] = d[2];
        t
    }
    pub fn scale(s: [f64; 3]) -> Self {
        let mut t = Transform::identity();
        t.m[0][0] = s[0];
        t.m[1][1] = s[1];
        t.m[2][2] = s[2];
        t
    }
    /// Rotation by `angle_deg` about `axis` (Rodrigues' formula, pbrt-v4 `Rotate`).
    pub fn rotate(angle_deg: f64, axis: [f64; 3]) -> Self {
        let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        let (x, y, z) = (axis[0] / len, axis[1] / len, axis[2] / len);
        let (s, c) = angle_deg.to_radians().sin_cos();
        let mut t = Transform::identity();
        t.m[0] = [
            x * x + (1.0 - x * x) * c,
            x * y * (1.0 - c) - z * s,
            x * z * (1.0 - c) + y * s,
            0.0,
        ];
        t.m[1] = [
            x * y * (1.0 - c) + z * s,
            y * y + (1.0 - y * y) * c,
            y * z * (1.0 - c) - x * s,
            0.0,
        ];
        t.m[2] = [
            x * z * (1.0 - c) - y * s,
            y * z * (1.0 - c) + x * s,
            z * z + (1.0 - z * z) * c,
            0.0,
        ];
        t
    }
    /// `self * other` (apply `other` first).
    pub fn then_apply_to(&self, other: &Transform) -> Transform {
        let mut m = [[0.0; 4]; 4];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..4).map(|k| self.m[i][k] * other.m[k][j]).sum();
            }
        }
        Transform { m }
    }
    pub fn apply_point(&self, p: [f64; 3]) -> [f64; 3] {
        let m = &self.m;
        let x = m[0][0] * p[0] + m[0][1] * p[1] + m[0][2] * p[2] + m[0][3];
        let y = m[1][0] * p[0] + m[1][1] * p[1] + m[1][2] * p[2] + m[1][3];
        let z = m[2][0] * p[0] + m[2][1] * p[1] + m[2][2] * p[2] + m[2][3];
        let w = m[3][0] * p[0] + m[3][1] * p[1] + m[3][2] * p[2] + m[3][3];
        if w == 1.0 {
            [x, y, z]
        } else {
            [x / w, y / w, z / w]
        }
    }
    pub fn apply_vector(&self, v: [f64; 3]) -> [f64; 3] {
        let m = &self.m;
        [
            m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
            m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
            m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
        ]
    }
}

/// Determinant of the upper-left 3x3 (negative when the transform swaps handedness).
pub fn det3(t: &Transform) -> f64 {
    let m = &t.m;
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Inverse of a 4x4 matrix (Gauss-Jordan with partial pivoting); None if singular.
pub fn inverse(t: &Transform) -> Option<Transform> {
    let mut a = t.m;
    let mut inv = Transform::identity().m;
    for col in 0..4 {
        let piv = (col..4).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if !(a[piv][col].abs() > 1e-300) {
            return None;
        }
        a.swap(col, piv);
        inv.swap(col, piv);
        let d = a[col][col];
        for k in 0..4 {
            a[col][k] /= d;
            inv[col][k] /= d;
        }
        for row in 0..4 {
            if row != col {
                let f = a[row][col];
                if f != 0.0 {
                    for k in 0..4 {
                        a[row][k] -= f * a[col][k];
                        inv[row][k] -= f * inv[col][k];
                    }
                }
            }
        }
    }
    inv.iter()
        .flatten()
        .all(|v| v.is_finite())
        .then_some(Transform { m: inv })
}

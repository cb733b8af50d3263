//! Small f32 vector algebra for the tracer's hot loops (world space, metres).

use std::ops::{Add, AddAssign, Div, Index, Mul, Neg, Sub};

/// Minimum by one comparison (a single `minss`; with a NaN operand it returns `b`).
#[inline(always)]
pub fn fmin(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// Maximum by one comparison (a single `maxss`; with a NaN operand it returns `b`).
#[inline(always)]
pub fn fmax(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// A 3-vector of f32 (points, directions, normals).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct V3 {
    pub x: f32,
    pub y: f32,
    pub z: f32,
}

impl V3 {
    /// Build from components.
    #[inline(always)]
    pub const fn new(x: f32, y: f32, z: f32) -> V3 {
        V3 { x, y, z }
    }
    /// Convert an f64 triple (scene description) to f32.
    #[inline]
    pub fn from_f64(p: [f64; 3]) -> V3 {
        V3::new(p[0] as f32, p[1] as f32, p[2] as f32)
    }
    /// Same value in every component.
    #[inline(always)]
    pub const fn splat(v: f32) -> V3 {
        V3 { x: v, y: v, z: v }
    }
    /// Dot product.
    #[inline(always)]
    pub fn dot(self, o: V3) -> f32 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// Cross product (right-handed formula).
    #[inline(always)]
    pub fn cross(self, o: V3) -> V3 {
        V3::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    /// Squared length.
    #[inline(always)]
    pub fn length_squared(self) -> f32 {
        self.dot(self)
    }
    /// Length.
    #[inline(always)]
    pub fn length(self) -> f32 {
        self.length_squared().sqrt()
    }
    /// Unit vector in the same direction (NaN for the zero vector).
    #[inline(always)]
    pub fn normalize(self) -> V3 {
        self * (1.0 / self.length())
    }
    /// Component-wise minimum.
    #[inline(always)]
    pub fn min(self, o: V3) -> V3 {
        V3::new(fmin(self.x, o.x), fmin(self.y, o.y), fmin(self.z, o.z))
    }
    /// Component-wise maximum.
    #[inline(always)]
    pub fn max(self, o: V3) -> V3 {
        V3::new(fmax(self.x, o.x), fmax(self.y, o.y), fmax(self.z, o.z))
    }
    /// Component-wise product.
    #[inline(always)]
    pub fn mul_elem(self, o: V3) -> V3 {
        V3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
    /// Component-wise absolute value.
    #[inline(always)]
    pub fn abs(self) -> V3 {
        V3::new(self.x.abs(), self.y.abs(), self.z.abs())
    }
    /// True when every component is finite.
    #[inline]
    pub fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite() && self.z.is_finite()
    }
    /// `self` flipped to lie in the hemisphere of `v`.
    #[inline(always)]
    pub fn face_forward(self, v: V3) -> V3 {
        if self.dot(v) < 0.0 {
            -self
        } else {
            self
        }
    }
}

impl Add for V3 {
    type Output = V3;
    #[inline(always)]
    fn add(self, o: V3) -> V3 {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl AddAssign for V3 {
    #[inline(always)]
    fn add_assign(&mut self, o: V3) {
        *self = *self + o;
    }
}
impl Sub for V3 {
    type Output = V3;
    #[inline(always)]
    fn sub(self, o: V3) -> V3 {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
impl Mul<f32> for V3 {
    type Output = V3;
    #[inline(always)]
    fn mul(self, s: f32) -> V3 {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
}
impl Div<f32> for V3 {
    type Output = V3;
    #[inline(always)]
    fn div(self, s: f32) -> V3 {
        self * (1.0 / s)
    }
}
impl Neg for V3 {
    type Output = V3;
    #[inline(always)]
    fn neg(self) -> V3 {
        V3::new(-self.x, -self.y, -self.z)
    }
}
impl Index<usize> for V3 {
    type Output = f32;
    #[inline(always)]
    fn index(&self, i: usize) -> &f32 {
        match i {
            0 => &self.x,
            1 => &self.y,
            _ => &self.z,
        }
    }
}

/// An orthonormal frame around a unit normal `n` (branchless construction, Duff et al. 2017,
/// "Building an Orthonormal Basis, Revisited", JCGT 6(1)).
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub s: V3,
    pub t: V3,
    pub n: V3,
}

impl Frame {
    /// Frame whose z axis is the unit vector `n`.
    #[inline(always)]
    pub fn from_normal(n: V3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = V3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = V3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }
    /// Local (frame) coordinates to world.
    #[inline(always)]
    pub fn to_world(&self, v: V3) -> V3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
    /// World to local (frame) coordinates.
    #[inline(always)]
    pub fn to_local(&self, v: V3) -> V3 {
        V3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_for_many_normals() {
        for i in 0..1000 {
            let a = i as f32 * 0.37;
            let b = (i as f32 * 0.11).sin() * 1.5;
            let n = V3::new(a.cos() * b.cos(), a.sin() * b.cos(), b.sin()).normalize();
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            assert!(
                f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5 && f.t.dot(n).abs() < 1e-5
            );
            let v = V3::new(0.3, -0.5, 0.8);
            let back = f.to_local(f.to_world(v));
            assert!((back - v).length() < 1e-5);
        }
    }
}

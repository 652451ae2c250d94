//! Pinhole camera as docs/conventions.md defines it (fov on the smaller side). A static
//! scene's camera sits at the render-space origin; a later frame of an animation sits at `eye`
//! (its offset from frame 0's camera, computed in f64 and rounded once).

use crate::core::geometry::Ray;
use glam::{DVec3, Vec3};

/// A pinhole camera: film size in pixels, an orthonormal frame, the field of view and a
/// position in render space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Film width in pixels.
    pub width: u32,
    /// Film height in pixels.
    pub height: u32,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    /// tan(fov/2)·(ax, ay): the film half-extent at distance 1.
    half: (f32, f32),
    /// Position in render space: zero for frame 0 (and every static scene).
    eye: Vec3,
}

impl Camera {
    /// `forward`, `up` in world space (f64); the caller has validated them (non-parallel, finite).
    pub fn new(forward: DVec3, up: DVec3, fov_deg: f64, width: u32, height: u32) -> Self {
        let forward = forward.normalize();
        let right = forward.cross(up).normalize();
        let true_up = right.cross(forward);
        let tan = (fov_deg.to_radians() * 0.5).tan();
        let aspect = width as f64 / height as f64;
        let (ax, ay) = if width >= height {
            (aspect, 1.0)
        } else {
            (1.0, 1.0 / aspect)
        };
        Self {
            width,
            height,
            right: right.as_vec3(),
            up: true_up.as_vec3(),
            forward: forward.as_vec3(),
            half: ((tan * ax) as f32, (tan * ay) as f32),
            eye: Vec3::ZERO,
        }
    }

    /// The same camera placed at `eye` in render space.
    pub fn with_eye(self, eye: Vec3) -> Self {
        Self { eye, ..self }
    }

    /// Position in render space (zero for frame 0 and for every static scene).
    pub fn eye(&self) -> Vec3 {
        self.eye
    }

    /// The film frame as [`Camera::ray`] uses it: (right, up, forward, film half-extents at
    /// distance 1), for renderers that build primary rays themselves (the GPU kernel).
    pub fn film_frame(&self) -> (Vec3, Vec3, Vec3, (f32, f32)) {
        (self.right, self.up, self.forward, self.half)
    }

    /// Primary ray through film position (u, v) ∈ [0,1]², u to the right, v downward.
    #[inline]
    pub fn ray(&self, u: f32, v: f32) -> Ray {
        let x = (2.0 * u - 1.0) * self.half.0;
        let y = (1.0 - 2.0 * v) * self.half.1;
        let d = (self.right * x + self.up * y + self.forward).normalize();
        Ray::new(self.eye, d)
    }

    /// Primary ray for pixel (px, py) with a jitter (jx, jy) ∈ [0,1)² inside it (box filter).
    #[inline]
    pub fn pixel_ray(&self, px: u32, py: u32, jx: f32, jy: f32) -> Ray {
        self.ray(
            (px as f32 + jx) / self.width as f32,
            (py as f32 + jy) / self.height as f32,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_looks_forward_and_corners_follow_fov() {
        let cam = Camera::new(DVec3::new(0.0, 0.0, -1.0), DVec3::Y, 90.0, 64, 32);
        let c = cam.ray(0.5, 0.5);
        assert!((c.d - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // fov applies to the smaller side (height): top edge at 45°.
        let top = cam.ray(0.5, 0.0).d;
        assert!((top.y / -top.z - 1.0).abs() < 1e-5);
        // width = 2·height: right edge at atan(2).
        let right = cam.ray(1.0, 0.5).d;
        assert!((right.x / -right.z - 2.0).abs() < 1e-5);
        // Row 0 is the top: v = 0 looks up; column 0 is the left: u = 0 looks to −x.
        assert!(cam.ray(0.0, 0.5).d.x < 0.0);
    }
}

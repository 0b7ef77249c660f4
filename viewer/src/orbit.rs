//! The orbit camera: a point of interest, a distance from it and two angles.

use kdbeam::{Aabb, Camera, Result, Vec3};

/// A camera circling `target` at `distance`, turned `yaw` radians about +y and raised `pitch`
/// radians above the horizontal plane.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    /// The point looked at.
    pub target: Vec3,
    /// Distance from the target to the eye.
    pub distance: f32,
    /// Angle about +y; 0 puts the eye on −z of the target (the standard camera's side).
    pub yaw: f32,
    /// Angle above the horizontal, kept inside ±85°.
    pub pitch: f32,
}

/// The steepest pitch: the view must not turn vertical (the camera has no up vector then).
const MAX_PITCH: f32 = 85.0 * std::f32::consts::PI / 180.0;

/// Field of view in degrees, the standard camera's (2·atan(½)).
const FOV: f32 = 53.130_1;

impl Orbit {
    /// The view of the standard camera of `bounds`: from −z, at the distance that frames the box.
    #[must_use]
    pub fn framing(bounds: &Aabb) -> Orbit {
        let (target, radius) = if bounds.is_empty() {
            (Vec3::ZERO, 1.0)
        } else {
            (bounds.center(), 0.5 * bounds.extent().length().max(1e-6))
        };
        Orbit {
            target,
            distance: 2.2 * radius,
            yaw: 0.0,
            pitch: 0.25,
        }
    }

    /// Turns by `yaw` and `pitch` radians (the pitch clamped to ±85°).
    pub fn turn(&mut self, yaw: f32, pitch: f32) {
        self.yaw = (self.yaw + yaw).rem_euclid(std::f32::consts::TAU);
        self.pitch = (self.pitch + pitch).clamp(-MAX_PITCH, MAX_PITCH);
    }

    /// Moves in by the factor `factor` (< 1) or out (> 1); non-positive or non-finite factors
    /// are ignored.
    pub fn zoom(&mut self, factor: f32) {
        if factor > 0.0 && factor.is_finite() {
            self.distance = (self.distance * factor).clamp(1e-4, 1e6);
        }
    }

    /// The eye's position.
    #[must_use]
    pub fn eye(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        self.target + self.distance * Vec3::new(-sy * cp, sp, -cy * cp)
    }

    /// The camera for a `width × height` picture.
    ///
    /// # Errors
    /// As [`Camera::look_at`] (a non-finite target or distance).
    pub fn camera(&self, width: u32, height: u32) -> Result<Camera> {
        Camera::look_at(self.eye(), self.target, FOV, width, height)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_eye_keeps_its_distance_and_the_pitch_its_bounds() {
        let mut o = Orbit::framing(&Aabb::from_points([Vec3::ZERO, Vec3::ONE]));
        let d = o.distance;
        for _ in 0..50 {
            o.turn(0.3, 0.2);
            assert!(((o.eye() - o.target).length() - d).abs() < 1e-4 * d);
            assert!(o.pitch.abs() <= MAX_PITCH);
            assert!(o.camera(16, 16).is_ok());
        }
        o.zoom(0.5);
        assert!((o.distance - 0.5 * d).abs() < 1e-6);
        o.zoom(f32::NAN);
        o.zoom(-1.0);
        assert!((o.distance - 0.5 * d).abs() < 1e-6);
    }
}

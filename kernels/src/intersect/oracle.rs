//! The watertight test in `f64`: the ground truth of the tests and of the error benchmark.
//!
//! The same algorithm as [`super::watertight`] (axis permutation, shear, edge functions `U, V, W`,
//! same-sign test, `t = T / det`), with every step in `f64` on the `f32` inputs. `f32` products
//! are exact in `f64`, so only the sums and divisions round, each at `2^-53`: its `t` and
//! barycentrics are correct to about `1e-15` relative for any triangle that is not nearly
//! edge-on to the ray, which is what the `f32` tests are measured against. Written on its own
//! (not sharing code with the `f32` test) so that a mistake in one does not hide in the other.

use glam::DVec3;

use crate::ray::Ray;
use crate::triangle::Triangle;

/// Where a ray meets a triangle, in `f64`: `t`, `u` (weight of `v1`), `v` (weight of `v2`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleHit {
    /// Ray parameter of the hit.
    pub t: f64,
    /// Barycentric weight of `v1`.
    pub u: f64,
    /// Barycentric weight of `v2`.
    pub v: f64,
}

/// A ray prepared for the `f64` watertight test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OracleRay {
    /// The origin.
    origin: DVec3,
    /// `(kx, ky, kz)`: `kz` the axis of the largest `|d|`, `kx, ky` the next two (swapped when
    /// `d[kz] < 0`).
    axes: [usize; 3],
    /// `(d[kx]/d[kz], d[ky]/d[kz], 1/d[kz])`.
    shear: [f64; 3],
}

impl OracleRay {
    /// Prepares `ray` (converted exactly to `f64`; its `tmin`/`tmax` are not used). A ray whose
    /// direction has a NaN or infinite component never hits.
    #[must_use]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.direction.as_dvec3();
        let a = d.abs();
        let kz = if a.x > a.y && a.x > a.z {
            0
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut axes = [(kz + 1) % 3, (kz + 2) % 3, kz];
        if d[kz] < 0.0 {
            axes.swap(0, 1);
        }
        let [kx, ky, _] = axes;
        // An infinite direction names no point at a finite `t > 0`: poison the ray.
        let origin = if d[kz].is_finite() {
            ray.origin.as_dvec3()
        } else {
            DVec3::NAN
        };
        OracleRay {
            origin,
            axes,
            shear: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
        }
    }

    /// The hit with `tmin <= t <= tmax`, if any (edges and vertices included, both windings).
    /// Degenerate triangles (`det = 0`) and rays with NaN never hit.
    #[must_use]
    pub fn intersect(&self, tri: &Triangle, tmin: f64, tmax: f64) -> Option<OracleHit> {
        let [kx, ky, kz] = self.axes;
        let [sx, sy, sz] = self.shear;
        let project = |p: DVec3| {
            let a = p - self.origin;
            (a[kx] - sx * a[kz], a[ky] - sy * a[kz], sz * a[kz])
        };
        let (ax, ay, az) = project(tri.v0.as_dvec3());
        let (bx, by, bz) = project(tri.v1.as_dvec3());
        let (cx, cy, cz) = project(tri.v2.as_dvec3());
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
        let same_sign = (u >= 0.0 && v >= 0.0 && w >= 0.0) || (u <= 0.0 && v <= 0.0 && w <= 0.0);
        let det = u + v + w;
        if !same_sign || det == 0.0 {
            return None;
        }
        let t = (u * az + v * bz + w * cz) / det;
        (t >= tmin && t <= tmax).then(|| OracleHit {
            t,
            u: v / det,
            v: w / det,
        })
    }
}

//! Cosine-weighted directions about a normal, from only `+`, `×`, `÷` and `√`, so that a seed
//! gives the same rays on every platform.

use glam::Vec3;

use crate::scene::rng::Rng;

/// A unit direction drawn with density `cos θ / π` about the unit vector `n`.
///
/// Malley's method (the projection of a uniform disk onto the hemisphere, as in Pharr, Jakob &
/// Humphreys, *Physically Based Rendering*, 13.6.3): draw `(x, y)` uniform in the unit disk by
/// rejection from the square `[−1, 1)²` (accepted with probability π/4), and lift it to
/// `(x, y, √(1 − x² − y²))`; the lifted point is cosine-distributed. It is then expressed in the
/// orthonormal basis of Duff et al., *Building an Orthonormal Basis, Revisited* (JCGT 2017),
/// whose third vector is `n`. The result is strictly above the tangent plane before rounding
/// (`x² + y² < 1`), and within a few ulps of unit length.
pub(super) fn cosine_direction(rng: &mut Rng, n: Vec3) -> Vec3 {
    let (x, y, s) = loop {
        let x = rng.range(-1.0, 1.0);
        let y = rng.range(-1.0, 1.0);
        let s = x * x + y * y;
        if s < 1.0 {
            break (x, y, s);
        }
    };
    let z = (1.0 - s).sqrt();
    let (t, b) = basis(n);
    t * x + b * y + n * z
}

/// Two unit vectors that make `(t, b, n)` an orthonormal basis (Duff et al., listing 3).
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_basis_is_orthonormal_for_every_octant() {
        let mut rng = Rng::new(3);
        for _ in 0..1000 {
            let n = rng.unit_vector();
            let (t, b) = basis(n);
            for (what, v) in [("t·n", t.dot(n)), ("b·n", b.dot(n)), ("t·b", t.dot(b))] {
                // A few ulps of rounding in each of the three products summed.
                assert!(v.abs() < 1e-5, "{what} = {v} for {n}");
            }
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn directions_are_cosine_weighted_about_the_normal() {
        // E[cos θ] = 2/3 under the density cos θ / π; the mean of 100 000 draws has a standard
        // deviation of √(1/2 − 4/9)/√100 000 ≈ 7.5e-4, so 5e-3 is over 6 of them.
        let mut rng = Rng::new(11);
        for n in [Vec3::Z, Vec3::NEG_Z, Vec3::new(0.6, -0.8, 0.0), Vec3::X] {
            let draws = 100_000;
            let mut sum = 0.0f64;
            for _ in 0..draws {
                let d = cosine_direction(&mut rng, n);
                let c = d.dot(n);
                assert!(c > -1e-6, "below the tangent plane: {d} about {n}");
                assert!((d.length() - 1.0).abs() < 1e-5);
                sum += f64::from(c);
            }
            let mean = sum / f64::from(draws);
            assert!((mean - 2.0 / 3.0).abs() < 5e-3, "mean cos {mean} about {n}");
        }
    }
}

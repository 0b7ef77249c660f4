//! Build statistics.

use std::fmt;
use std::time::Duration;

/// What a build produced and how long it took.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct BuildStats {
    /// Triangles in the mesh.
    pub triangles: usize,
    /// All nodes, inner and leaf.
    pub nodes: usize,
    /// Leaf nodes, empty ones included.
    pub leaves: usize,
    /// Leaves holding at least one triangle.
    pub nonempty_leaves: usize,
    /// Triangle references summed over leaves (a triangle straddling splits counts once per leaf).
    pub triangle_refs: usize,
    /// Deepest leaf (the root has depth 0).
    pub max_depth: u32,
    /// Bytes of nodes, leaf records and leaf-ordered triangle arrays.
    pub bytes: usize,
    /// Wall-clock time of the build.
    #[serde(serialize_with = "seconds")]
    pub build_time: Duration,
}

fn seconds<S: serde::Serializer>(d: &Duration, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f64(d.as_secs_f64())
}

impl BuildStats {
    /// Mean triangles per non-empty leaf (0 when there are none).
    pub fn mean_leaf_size(&self) -> f64 {
        ratio(self.triangle_refs, self.nonempty_leaves)
    }

    /// Nodes per triangle: the tree-size axis of Reshetov's Figs. 7–9.
    pub fn nodes_per_triangle(&self) -> f64 {
        ratio(self.nodes, self.triangles)
    }

    /// Bytes per mesh triangle.
    pub fn bytes_per_triangle(&self) -> f64 {
        ratio(self.bytes, self.triangles)
    }

    /// Mesh triangles built per second.
    pub fn triangles_per_second(&self) -> f64 {
        self.triangles as f64 / self.build_time.as_secs_f64().max(1e-9)
    }
}

fn ratio(a: usize, b: usize) -> f64 {
    if b == 0 {
        0.0
    } else {
        a as f64 / b as f64
    }
}

impl fmt::Display for BuildStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} triangles, {} nodes ({:.2}/triangle), {} leaves ({} non-empty, {:.2} triangles each), \
             depth {}, {:.1} MiB ({:.0} B/triangle), built in {:.3} s ({:.2} M triangles/s)",
            self.triangles,
            self.nodes,
            self.nodes_per_triangle(),
            self.leaves,
            self.nonempty_leaves,
            self.mean_leaf_size(),
            self.max_depth,
            self.bytes as f64 / (1 << 20) as f64,
            self.bytes_per_triangle(),
            self.build_time.as_secs_f64(),
            self.triangles_per_second() / 1e6,
        )
    }
}

//! Counters that make the pruning and the Newton solves measurable.

use std::ops::AddAssign;

use super::newton::NewtonCounters;

/// What one (or several, after `+=`) single-scattering evaluations did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ScatterStats {
    /// Eye segments evaluated.
    pub segments: u64,
    /// Hierarchy nodes examined.
    pub nodes_visited: u64,
    /// Nodes discarded (with their subtrees) by the spindle test.
    pub nodes_pruned_spindle: u64,
    /// Triangles reached in the leaves (or all triangles for the brute force).
    pub triangles_visited: u64,
    /// Triangles discarded by the sidedness test (light not outside, or V never inside).
    pub triangles_pruned_sidedness: u64,
    /// Triangles discarded by the spindle test on their bounding sphere.
    pub triangles_pruned_spindle: u64,
    /// Triangles discarded by the shading-normal cone test.
    pub triangles_pruned_normal_cone: u64,
    /// Triangles whose interval analysis found no support on the eye segment.
    pub triangles_without_support: u64,
    /// Triangles that contributed at least one path.
    pub triangles_contributing: u64,
    /// Triangles whose edge events were inconsistent (a fold of the solution curve inside the
    /// triangle, i.e. a caustic crossing the eye segment there): sampled over the hull of their
    /// events with several seeds.
    pub triangles_fallback: u64,
    /// Sample points along the eye segment at which a triangle was solved.
    pub samples: u64,
    /// Sub-intervals of the adaptive quadrature over all support pieces (15 samples each).
    pub subintervals: u64,
    /// Refracted paths found (contributions added).
    pub paths: u64,
    /// Interior (α, β) solves.
    pub interior: NewtonCounters,
    /// Edge (x, t) solves.
    pub edge: NewtonCounters,
}

impl ScatterStats {
    /// All Newton solves (interior and edge).
    pub fn newton_solves(&self) -> u64 {
        self.interior.solves + self.edge.solves
    }

    /// All Newton iterations.
    pub fn newton_iterations(&self) -> u64 {
        self.interior.iterations + self.edge.iterations
    }
}

impl AddAssign for NewtonCounters {
    fn add_assign(&mut self, o: Self) {
        self.solves += o.solves;
        self.iterations += o.iterations;
        self.failures += o.failures;
    }
}

impl AddAssign for ScatterStats {
    fn add_assign(&mut self, o: Self) {
        self.segments += o.segments;
        self.nodes_visited += o.nodes_visited;
        self.nodes_pruned_spindle += o.nodes_pruned_spindle;
        self.triangles_visited += o.triangles_visited;
        self.triangles_pruned_sidedness += o.triangles_pruned_sidedness;
        self.triangles_pruned_spindle += o.triangles_pruned_spindle;
        self.triangles_pruned_normal_cone += o.triangles_pruned_normal_cone;
        self.triangles_without_support += o.triangles_without_support;
        self.triangles_contributing += o.triangles_contributing;
        self.triangles_fallback += o.triangles_fallback;
        self.samples += o.samples;
        self.subintervals += o.subintervals;
        self.paths += o.paths;
        self.interior += o.interior;
        self.edge += o.edge;
    }
}

//! The error metrics an irradiance record's radius can come from.

use crate::cache::Interpolation;
use crate::error::{Error, Result};

/// How a record's radii follow from its gather (the parameter is
/// [`IrradianceSettings::accuracy`](super::IrradianceSettings::accuracy)). E, ∇E are the
/// irradiance and Ward-Heckbert gradient of the settings' scalar (e.g. luminance), D the
/// harmonic-mean hit distance. C: `RADDIFF_METRIC_*` (the discriminants).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Metric {
    /// Ward's split sphere (1988): radius a·D. `a` dimensionless, typically 0.1-0.3.
    SplitSphere = 0,
    /// The split sphere bounded by the measured gradient (Ward-Heckbert, Křivánek):
    /// a·min(D, E/|∇E|). `a` dimensionless.
    BoundedSplitSphere = 1,
    /// Jarosz et al. 2008: radius ε·E/|∇E| from the gradient alone; unbounded where ∇E = 0.
    /// `ε` dimensionless.
    Gradient = 2,
    /// The occlusion-unaware (radiometric) Hessian (thesis ch. 4), anisotropic records: the
    /// relative-error bound of [`gather::radii`](crate::gather::radii). Needs the hits' normals
    /// and no medium.
    HessianUnaware = 3,
    /// The geometric Hessian (thesis eq. 4.23: the radiometric Hessian with every hit's radiance
    /// replaced by the gather's largest), anisotropic records. Needs the hits' normals and no
    /// medium.
    HessianGeometric = 4,
    /// The occlusion-aware Hessian (Schwarzhaupt et al., thesis ch. 6), isotropic (disc)
    /// records.
    HessianIsotropic = 5,
    /// The occlusion-aware Hessian, anisotropic (ellipse) records: the default.
    HessianAnisotropic = 6,
}

/// The Hessians a gather evaluation can hold (see
/// [`GatherEvaluation`](super::GatherEvaluation)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum HessianKind {
    /// The occlusion-aware Hessian of the triangulated gather
    /// ([`gather::hessian`](crate::gather::hessian)), with the thesis' robustness term.
    OcclusionAware,
    /// The occlusion-unaware (radiometric) Hessian
    /// ([`gather::hessian::unaware`](crate::gather::hessian::unaware)); needs hit normals.
    Unaware,
    /// The geometric Hessian (thesis eq. 4.23) with the gather's largest scalar radiance as the
    /// scene's; needs hit normals.
    Geometric,
}

impl Metric {
    /// Every metric, in discriminant order.
    pub const ALL: [Metric; 7] = [
        Metric::SplitSphere,
        Metric::BoundedSplitSphere,
        Metric::Gradient,
        Metric::HessianUnaware,
        Metric::HessianGeometric,
        Metric::HessianIsotropic,
        Metric::HessianAnisotropic,
    ];

    /// The metric's name, as the demo's command line spells it (`split-sphere`,
    /// `bounded-split-sphere`, `gradient`, `hessian-unaware`, `hessian-geometric`,
    /// `hessian-isotropic`, `hessian-anisotropic`).
    pub fn name(self) -> &'static str {
        match self {
            Metric::SplitSphere => "split-sphere",
            Metric::BoundedSplitSphere => "bounded-split-sphere",
            Metric::Gradient => "gradient",
            Metric::HessianUnaware => "hessian-unaware",
            Metric::HessianGeometric => "hessian-geometric",
            Metric::HessianIsotropic => "hessian-isotropic",
            Metric::HessianAnisotropic => "hessian-anisotropic",
        }
    }

    /// The metric whose [`Metric::name`] is `name`.
    pub fn parse(name: &str) -> Option<Metric> {
        Metric::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The Hessian the metric's radii come from (`None` for the split-sphere family and the
    /// gradient metric).
    pub fn hessian(self) -> Option<HessianKind> {
        match self {
            Metric::SplitSphere | Metric::BoundedSplitSphere | Metric::Gradient => None,
            Metric::HessianUnaware => Some(HessianKind::Unaware),
            Metric::HessianGeometric => Some(HessianKind::Geometric),
            Metric::HessianIsotropic | Metric::HessianAnisotropic => {
                Some(HessianKind::OcclusionAware)
            }
        }
    }

    /// Whether the metric needs the surface normal at every hit (the occlusion-unaware
    /// Hessians), which a tracing callback does not report.
    pub fn needs_hit_normals(self) -> bool {
        matches!(self, Metric::HessianUnaware | Metric::HessianGeometric)
    }

    /// The interpolation the metric's records are made for: Ward-Heckbert weights for the
    /// split-sphere family and the gradient metric (their radius is Ward's validity radius),
    /// tent weights for the Hessian metrics (their radius bounds the extrapolation error over the
    /// whole record, to which the tent's fall-off to zero at the boundary belongs; thesis ch. 6).
    pub fn interpolation(self) -> Interpolation {
        if self.hessian().is_some() {
            Interpolation::Tent
        } else {
            Interpolation::Ward
        }
    }
}

impl TryFrom<u32> for Metric {
    type Error = Error;
    fn try_from(v: u32) -> Result<Self> {
        Metric::ALL.get(v as usize).copied().ok_or_else(|| {
            Error::InvalidArgument(format!(
                "metric {v} is not one of RADDIFF_METRIC_SPLIT_SPHERE (0) to \
                 RADDIFF_METRIC_HESSIAN_ANISOTROPIC (6)"
            ))
        })
    }
}

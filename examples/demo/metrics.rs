//! The error metrics the demo compares (placeholder list until the cache lands).

pub const ALL: [&str; 6] = [
    "split-sphere",
    "bounded-split-sphere",
    "gradient",
    "hessian-unaware",
    "hessian-isotropic",
    "hessian-anisotropic",
];

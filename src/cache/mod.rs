//! The generic radiance cache: records, error metrics, spatial index, interpolation, persistence.

//! TEMPORARY: stand-ins until the cache safeguards land.
use raddiff::cache::{Cache, CacheConfig};
pub trait ConfigShim {
    fn with_gradient_limit(self, c: f64) -> Self;
}
impl ConfigShim for CacheConfig {
    fn with_gradient_limit(self, _c: f64) -> Self {
        self
    }
}
pub trait CacheShim {
    fn clamp_neighbours(&mut self) -> usize;
}
impl CacheShim for Cache<[f32; 3]> {
    fn clamp_neighbours(&mut self) -> usize {
        0
    }
}

//! AFL++ target `cache_irradiance`: see `raddiff_fuzz::targets::cache_irradiance` for the inputs and the properties checked.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        raddiff_fuzz::targets::cache_irradiance::run(data);
    });
}

//! AFL++ target `cache_ops`: see `raddiff_fuzz::targets::cache_ops` for the inputs and the properties checked.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        raddiff_fuzz::targets::cache_ops::run(data);
    });
}

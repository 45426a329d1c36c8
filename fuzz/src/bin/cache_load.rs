//! AFL++ target `cache_load`: see `raddiff_fuzz::targets::cache_load` for the inputs and the properties checked.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        raddiff_fuzz::targets::cache_load::run(data);
    });
}

//! AFL++ target `kernels`: see `raddiff_fuzz::targets::kernels` for the inputs and the properties checked.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        raddiff_fuzz::targets::kernels::run(data);
    });
}

//! AFL++ target `gather_evaluate`: see `raddiff_fuzz::targets::gather_evaluate` for the inputs and the properties checked.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        raddiff_fuzz::targets::gather_evaluate::run(data);
    });
}

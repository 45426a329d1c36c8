//! AFL++ target `radii`: see `raddiff_fuzz::targets::radii` for the inputs and the properties checked.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        raddiff_fuzz::targets::radii::run(data);
    });
}

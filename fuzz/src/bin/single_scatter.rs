//! AFL++ target `single_scatter`: see `raddiff_fuzz::targets::single_scatter` for the inputs and the properties checked.
fn main() {
    afl::fuzz!(|data: &[u8]| {
        raddiff_fuzz::targets::single_scatter::run(data);
    });
}

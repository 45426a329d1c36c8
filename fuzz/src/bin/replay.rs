//! Replays files through a fuzz target without AFL++, printing each outcome (debugging a finding):
//! `cargo run --release --bin replay -- TARGET FILE...`.
use raddiff_fuzz::targets;

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(name) = args.next() else {
        eprintln!(
            "usage: replay TARGET FILE...  (targets: {})",
            targets::NAMES.join(", ")
        );
        std::process::exit(2);
    };
    let Some(run) = targets::by_name(&name) else {
        eprintln!(
            "unknown target {name} (targets: {})",
            targets::NAMES.join(", ")
        );
        std::process::exit(2);
    };
    for file in args {
        let data = std::fs::read(&file).unwrap_or_else(|e| panic!("reading {file}: {e}"));
        println!("{file}: {:?}", run(&data));
    }
}

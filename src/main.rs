//! The `penumbra` binary: see `penumbra --help` and CONTRACT.md.

fn main() {
    std::process::exit(penumbra::cli::run(std::env::args_os()));
}

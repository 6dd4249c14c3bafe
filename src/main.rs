//! The `drive-sim` binary: see `drive_sim::cli`.

fn main() {
    std::process::exit(drive_sim::cli::main());
}

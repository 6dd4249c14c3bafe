//! The `drive-sim` binary: parses the command line ([`cli`]), calls the library and prints.

mod cli;

fn main() {
    std::process::exit(cli::main());
}
